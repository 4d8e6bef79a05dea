"""How each sampled-data rule passes measurement noise into its one-step prediction.

With noisy samples ``x~_k = x(t_k) + delta_k`` the disturbed local error of section 5.1
splits as

    eps~_{n+1} = eps_{n+1} + (delta_{n+1} - delta_n) - [P(x~) - P(x)],

where ``eps`` is the undisturbed local error and ``P(x~) - P(x)`` is what the rule's
increment makes of the noise. Bounding ``||f_b(y + d) - f_b(y)|| <= L_b,eta ||d_eta|| +
L_b,v ||d_v||`` blockwise (b = eta, v; L the 2 x 2 matrix of Jacobian maxima, eqs.
(19)-(23)), every rule gives ``||P(x~) - P(x)||_b <= (G (||delta_eta||, ||delta_v||))_b``
with a non-negative 2 x 2 *noise gain* G:

* AB_s:  ``G = h a_s L`` with ``a_s = sum_i |a_i|``, eqs. (11)-(12), (24)-(25). The
  printed (11) lacks the factor h; dimensions require it (L is in 1/s), and the
  conclusions' "increases ... with the sampling time period h" agrees.
* RK_s (explicit, tableau a, b): stage i moves by ``Delta k_i <= K_i delta`` with
  ``K_i = L (I + h sum_j |a_ij| K_j)``, and ``G = h sum_i |b_i| K_i``. For a scalar
  L this is ``z + z^2/2 + ... + z^s/s!`` (z = h L) for the classical RK4, i.e. a gain
  of about ``h L`` whatever the order, where AB_s has ``a_s h L``.
* Tustin: the implicit solution moves by ``d = delta + (h/2) L (delta + d)``, so
  ``G = h L (I - h L / 2)^-1`` (scalar: ``z / (1 - z/2)``), finite while the spectral
  radius of ``h L / 2`` is below 1.

Euler is AB1 = RK1: all three give ``G = h L``.
"""

from __future__ import annotations

from fractions import Fraction
from functools import lru_cache
from typing import Any

import numpy as np

from ..methods import AdamsBashforth, RungeKutta, Tustin, get_method

__all__ = ["error_constant", "first_order_gain", "noise_gain", "supported_method"]


def supported_method(method: Any, argument: str = "method") -> Any:
    """The method object for ``method``; only fixed rules (AB_s, RK_s, T) have a bound."""
    m = get_method(method)
    if not isinstance(m, AdamsBashforth | RungeKutta | Tustin):
        raise ValueError(
            f"`{argument}` = {getattr(m, 'name', method)!r} has no noise bound: only the fixed "
            "rules E, AB<s>, RK<s> and T do (estimated rules change their parameters with "
            "the data)."
        )
    return m


@lru_cache(maxsize=32)
def _gamma(s: int) -> Fraction:
    # gamma_s = int_0^1 binom(tau + s - 1, s) dtau = int_0^1 prod_{j<s}(tau + j)/s! dtau
    poly = [Fraction(1)]
    for j in range(s):
        nxt = [Fraction(0)] * (len(poly) + 1)
        for k, c in enumerate(poly):
            nxt[k] += c * j
            nxt[k + 1] += c
        poly = nxt
    fact = 1
    for j in range(2, s + 1):
        fact *= j
    return sum((c / (k + 1) for k, c in enumerate(poly)), Fraction(0)) / fact


def error_constant(method: Any) -> Fraction | None:
    """Error constant gamma_s of AB_s: ``eps = gamma_s h^{s+1} x^{(s+1)} + ...``.

    (1/2, 5/12, 3/8, 251/720, 95/288, 19087/60480 for s = 1..6.) None for other rules.
    """
    m = supported_method(method)
    if isinstance(m, AdamsBashforth):
        return _gamma(m.order)
    return None


def first_order_gain(method: Any) -> Fraction:
    """The coefficient c of the noise gain ``G = c h L + O((h L)^2)``.

    ``a_s = sum |a_i|`` for AB_s; ``sum |b_i|`` (= 1 for the built-in tableaux) for
    RK_s; 1 for Tustin.
    """
    m = supported_method(method)
    if isinstance(m, AdamsBashforth):
        return m.a_s
    if isinstance(m, RungeKutta):
        return sum((abs(b) for b in m.tableau.b), Fraction(0))
    return Fraction(1)


def noise_gain(method: Any, h: float, lipschitz: Any) -> np.ndarray:
    """Noise gain G of ``method`` at sampling period ``h`` (see the module docstring).

    Parameters
    ----------
    method : str or method object
        "E", "AB<s>", "RK<s>" or "T".
    h : float
        Sampling period (s).
    lipschitz : array_like, shape (2, 2)
        ``[[L_eta_eta, L_eta_v], [L_v_eta, L_v_v]]``, non-negative (Jacobian maxima).

    Returns
    -------
    ndarray, shape (2, 2): ``||P(x~) - P(x)||_b <= (G @ (||delta_eta||, ||delta_v||))_b``.
    All entries inf for Tustin when the spectral radius of ``h L / 2`` is >= 1.
    """
    m = supported_method(method)
    L = np.asarray(lipschitz, dtype=float)
    if L.shape != (2, 2) or (L < 0).any() or not np.isfinite(L).all():
        raise ValueError(f"`lipschitz` must be a finite non-negative 2x2 array, got {L!r}.")
    if not (np.isfinite(h) and h > 0):
        raise ValueError(f"sampling period `h` must be > 0 s, got {h}.")
    if isinstance(m, AdamsBashforth):
        return h * float(m.a_s) * L
    eye = np.eye(2)
    if isinstance(m, Tustin):
        half = 0.5 * h * L
        if max(abs(np.linalg.eigvals(half))) >= 1.0:
            return np.full((2, 2), np.inf)
        return h * L @ np.linalg.inv(eye - half)
    tab = m.tableau
    ks: list[np.ndarray] = []
    for i in range(tab.stages):
        acc = eye.copy()
        for j in range(i):
            if tab.a[i][j] != 0:
                acc = acc + h * abs(float(tab.a[i][j])) * ks[j]
        ks.append(L @ acc)
    return h * sum((abs(float(b)) * k for b, k in zip(tab.b, ks, strict=True)), np.zeros((2, 2)))
