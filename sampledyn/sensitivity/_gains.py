"""How each sampled-data rule passes measurement noise into its one-step prediction.

With noisy samples ``x~_k = x(t_k) + delta_k`` the disturbed local error of section 5.1
splits as

    eps~_{n+1} = eps_{n+1} + (delta_{n+1} - delta_n) - [P(x~) - P(x)],

where ``eps`` is the undisturbed local error and ``P(x~) - P(x)`` is what the rule's
increment makes of the noise. Bounding ``||f_b(y + d) - f_b(y)|| <= L_b,eta ||d_eta|| +
L_b,v ||d_v||`` blockwise (b = eta, v; L the 2 x 2 matrix of Jacobian maxima, eqs.
(19)-(23)), every rule gives ``||P(x~) - P(x)||_b <= (G (||delta_eta||, ||delta_v||))_b``
with a non-negative 2 x 2 *noise gain* G, which the rule itself computes
(:meth:`sampledyn.methods.Method.noise_gain`): ``h a_s L`` for AB_s, the stage
recursion for RK_s, ``h L (I - h L/2)^-1`` for Tustin. The functions here name the
rule and ask it.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import numpy as np

from ..methods import Method, NoiseAnalysis, Predictor, get_method

__all__ = ["error_constant", "first_order_gain", "noise_gain", "supported_method"]


def supported_method(method: str | Method, argument: str = "method") -> Any:
    """The method object for ``method``: a predictor with a noise bound (a
    :class:`~sampledyn.methods.Predictor` and :class:`~sampledyn.methods.NoiseAnalysis`,
    the fixed rules; not the estimated ones, nor ZOH).

    Raises
    ------
    ValueError
        for a rule without a bound: one that estimates its parameters on the data
        (Ee, ABe_s), or one that predicts nothing on sampled data (ZOH).
    """
    m = get_method(method)
    if not (isinstance(m, NoiseAnalysis) and isinstance(m, Predictor)):
        raise ValueError(
            f"`{argument}` = {m.name!r} has no noise bound: only the fixed rules (E, "
            "AB<s>, RK<s>, T, ...) do (estimated rules change their parameters with "
            "the data)."
        )
    return m


def error_constant(method: str | Method) -> Fraction | None:
    """Error constant C of the rule's leading local error ``C h^{s+1} x^{(s+1)}``.

    gamma_s for AB_s (1/2, 5/12, 3/8, 251/720, 95/288, 19087/60480 for s = 1..6),
    -1/12 for Tustin, None for RK_s (no single constant).
    """
    return supported_method(method).error_constant


def first_order_gain(method: str | Method) -> Fraction:
    """The coefficient c of the noise gain ``G = c h L + O((h L)^2)``.

    ``a_s = sum |a_i|`` for AB_s; ``sum |b_i|`` (= 1 for the built-in tableaux) for
    RK_s; 1 for Tustin.
    """
    gain: Fraction = supported_method(method).first_order_gain
    return gain


def noise_gain(method: str | Method, h: float, lipschitz: Any, ratio: float = 1.0) -> np.ndarray:
    """Noise gain G of ``method`` at sampling period ``h`` (see the module docstring).

    Parameters
    ----------
    method : str or method object
        "E", "AB<s>", "RK<s>", "T", ... (any fixed rule).
    h : float
        Sampling period (s); on a non-uniform grid the largest step.
    lipschitz : array_like, shape (2, 2)
        ``[[L_eta_eta, L_eta_v], [L_v_eta, L_v_v]]``, non-negative (Jacobian maxima).
    ratio : float
        Largest ratio of the longest to the shortest step in one prediction's stencil
        (1 on a uniform grid; :func:`sampledyn.methods.stencil_steps`).

    Returns
    -------
    ndarray, shape (2, 2): ``||P(x~) - P(x)||_b <= (G @ (||delta_eta||, ||delta_v||))_b``.
    All entries inf for Tustin when the spectral radius of ``h L / 2`` is >= 1.

    Raises
    ------
    ValueError
        for an estimated rule (no bound), or a rule of order above
        :data:`sampledyn.methods._nodes.MAX_GAIN_ORDER` with ``ratio`` > 1.
    """
    return supported_method(method).noise_gain(h, lipschitz, ratio)
