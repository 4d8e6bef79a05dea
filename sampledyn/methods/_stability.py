"""Linear stability of the rules: how a rule amplifies the mode y' = lambda y per step.

Applied to the test equation y' = lambda y with step h, every rule here is a linear
recursion in y whose growth per step depends on z = h lambda only (Hairer & Wanner,
*Solving Ordinary Differential Equations II*, Sec. IV.2 and V.1):

* a one-step rule multiplies y by its stability function R(z): ``R(z) = 1 + z b^T
  (I - z A)^-1 1`` for a Runge-Kutta tableau (a polynomial of degree s for an explicit
  one: ``sum_j (b^T A^(j-1) 1) z^j``; ``1 + z`` for Euler), ``(1 + z/2) / (1 - z/2)``
  for the trapezoid (Tustin), ``e^z`` for the exact flow (ZOH);
* a linear multistep rule is stable when every root zeta of its characteristic
  polynomial ``rho(zeta) - z sigma(zeta)`` lies in the closed unit disc; for AB_s
  ``zeta^s - zeta^(s-1) - z sum_i a_i zeta^(s-1-i)`` (a_0..a_{s-1} newest first).

A rule answers ``amplification(z)`` (:class:`~sampledyn.methods.Stability`): |R(z)|,
or the largest |zeta| of the multistep rule, at every z of an array; it is stable at
z where that is <= 1. :func:`largest_stable_steps` turns this into the largest step
at which a rule is stable for given eigenvalues lambda: along the ray z = r lambda /
|lambda| (r = h |lambda|), the first r where the amplification exceeds 1, divided by
|lambda|.
"""

from __future__ import annotations

from collections.abc import Sequence
from fractions import Fraction
from typing import Any

import numpy as np

__all__ = [
    "AMPLIFICATION_TOL",
    "largest_stable_steps",
    "multistep_amplification",
    "polynomial_amplification",
    "rational_amplification",
]

#: Amplification up to 1 + this counts as stable: the rounding of |R| where it is 1
#: (about 45 units of the last place; a growth of 1e-14 per step is 1e-8 after a
#: million steps).
AMPLIFICATION_TOL = 1e-14

# The scan of r = h |lambda| along each ray: geometric from R_MIN to R_MAX (every
# rule's region ends far inside |z| = 1e3, except the A-stable ones, which then count
# as stable at every step), then bisection between the last stable and the first
# unstable point to a relative width of 2^-BISECT (a region left and entered again between two
# points of the scan, 19 % apart, counts as left there).
_R_MIN, _R_MAX, _R_POINTS, _BISECT = 1e-6, 1e3, 121, 32


def polynomial_amplification(coeffs: Sequence[Fraction | float], z: Any) -> np.ndarray:
    """``|sum_j c_j z^j|`` (c_0 first), shape of z: an explicit Runge-Kutta rule's |R(z)|."""
    zz = np.asarray(z, dtype=complex)
    acc = np.zeros_like(zz)
    for c in reversed([float(c) for c in coeffs]):
        acc = acc * zz + c
    return np.abs(acc)


def rational_amplification(num: Sequence[float], den: Sequence[float], z: Any) -> np.ndarray:
    """``|N(z) / D(z)|`` (coefficients c_0 first); inf where D(z) = 0."""
    zz = np.asarray(z, dtype=complex)
    top = polynomial_amplification(num, zz)
    bottom = polynomial_amplification(den, zz)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(bottom > 0, top / np.where(bottom > 0, bottom, 1.0), np.inf)


def multistep_amplification(weights: Sequence[Fraction | float], z: Any) -> np.ndarray:
    """Largest |zeta| over the roots of ``zeta^s - (1 + z a_0) zeta^(s-1) - z a_1
    zeta^(s-2) - ... - z a_{s-1}`` (AB_s with weights a_0..a_{s-1}, newest first), at
    every z; shape of z. The roots are the eigenvalues of the companion matrix, all z
    at once."""
    a = np.array([float(w) for w in weights])
    zz = np.asarray(z, dtype=complex)
    flat = zz.reshape(-1)
    s = a.size
    if s == 1:
        return np.abs(1.0 + a[0] * zz)
    comp = np.zeros((flat.size, s, s), dtype=complex)
    # zeta^s = c_1 zeta^(s-1) + ... + c_s with c_1 = 1 + z a_0, c_i = z a_{i-1}
    comp[:, 0, 0] = 1.0 + flat * a[0]
    for i in range(1, s):
        comp[:, 0, i] = flat * a[i]
        comp[:, i, i - 1] = 1.0
    roots = np.linalg.eigvals(comp)
    return np.asarray(np.abs(roots).max(axis=1).reshape(zz.shape))


def largest_stable_steps(method: Any, eigenvalues: Any) -> np.ndarray:
    """Per eigenvalue lambda, the largest h such that ``method`` is stable at h' lambda
    for every 0 < h' <= h (s), shape of ``eigenvalues``.

    inf where the rule is stable along the whole ray (an A-stable rule and Re lambda
    <= 0, or r = h |lambda| up to 1e3), and for lambda = 0; 0 where it is unstable
    already at h |lambda| = 1e-6, the scan's first point (Euler on an undamped mode,
    Re lambda = 0, grows by sqrt(1 + (h |lambda|)^2) at every h > 0). ``method`` answers
    ``amplification(z)`` (:class:`~sampledyn.methods.Stability`). Accurate to a
    relative 2^-32 of the first exit from the region along the ray (scan on a
    geometric grid of r, then bisection); a region that the ray leaves and enters
    again counts up to its first exit.
    """
    lam = np.asarray(eigenvalues, dtype=complex)
    flat = lam.reshape(-1)
    out = np.full(flat.size, np.inf)
    mag = np.abs(flat)
    live = np.flatnonzero(mag > 0)
    if live.size == 0:
        return out.reshape(lam.shape)
    d = flat[live] / mag[live]  # unit directions
    r = np.geomspace(_R_MIN, _R_MAX, _R_POINTS)
    bad = method.amplification(d[:, None] * r[None, :]) > 1.0 + AMPLIFICATION_TOL
    hit = np.flatnonzero(bad.any(axis=1))
    first = np.argmax(bad[hit], axis=1)
    lo = np.where(first > 0, r[np.maximum(first - 1, 0)], 0.0)
    hi = r[first]
    dh = d[hit]
    for _ in range(_BISECT):
        mid = 0.5 * (lo + hi)
        worse = method.amplification(dh * mid) > 1.0 + AMPLIFICATION_TOL
        hi = np.where(worse, mid, hi)
        lo = np.where(worse, lo, mid)
    exit_r = np.full(live.size, np.inf)
    exit_r[hit] = np.where(first == 0, 0.0, lo)  # unstable at the scan's first r: 0
    out[live] = exit_r / mag[live]
    return out.reshape(lam.shape)
