"""Adams-Bashforth rules of any order s, coefficients from Lagrange interpolation.

    x_{n+1} = x_n + h * sum_{i=0}^{s-1} a_i f(t_{n-i}, x_{n-i}, u_{n-i})

a_i = integral over tau in [0, 1] of the Lagrange basis polynomial of node -i on the
nodes 0, -1, ..., -(s-1) (time in units of h). Coefficients are exact ``Fraction``s,
newest first.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from functools import lru_cache
from typing import Any

import numpy as np
from numba import njit

from .._trajectory import Trajectory

__all__ = ["AdamsBashforth", "Euler", "ab_coefficients", "ab_filter"]


def _poly_mul_linear(poly: list[Fraction], root_shift: int, denom: int) -> list[Fraction]:
    """poly(tau) * (tau + root_shift) / denom, coefficients lowest degree first."""
    out = [Fraction(0)] * (len(poly) + 1)
    for k, c in enumerate(poly):
        out[k] += c * root_shift / denom
        out[k + 1] += c / denom
    return out


@lru_cache(maxsize=64)
def ab_coefficients(s: int) -> tuple[Fraction, ...]:
    """Adams-Bashforth coefficients (a_0, ..., a_{s-1}), newest first, exact.

    >>> ab_coefficients(2)
    (Fraction(3, 2), Fraction(-1, 2))
    """
    if isinstance(s, bool) or not isinstance(s, int | np.integer):
        raise TypeError(f"order `s` must be an int, got {type(s).__name__}.")
    if s < 1:
        raise ValueError(f"order `s` must be >= 1, got {s}.")
    coeffs = []
    for i in range(s):
        poly = [Fraction(1)]
        for j in range(s):
            if j != i:
                poly = _poly_mul_linear(poly, j, j - i)
        coeffs.append(sum((c / (k + 1) for k, c in enumerate(poly)), Fraction(0)))
    return tuple(coeffs)


def ab_filter(x: np.ndarray, f: np.ndarray, h: float, weights: np.ndarray) -> np.ndarray:
    """One-step AB prediction as a short FIR filter over precomputed f values.

    Parameters
    ----------
    x : ndarray, shape (N, nx)
        Sampled states.
    f : ndarray, shape (N, nx)
        f(t_n, x_n, u_n) for every sample.
    h : float
        Sampling period (s).
    weights : ndarray, shape (s,)
        a_0..a_{s-1}, newest first.

    Returns
    -------
    ndarray, shape (N, nx): row k predicts x[k] from samples k-1, ..., k-s; the first
    s rows are NaN.
    """
    n, nx = x.shape
    s = len(weights)
    out = np.full((n, nx), np.nan)
    if n <= s:
        return out
    _ab_fir(
        np.ascontiguousarray(x, dtype=float),
        np.ascontiguousarray(f, dtype=float),
        float(h),
        np.ascontiguousarray(weights, dtype=float),
        out,
    )
    return out


@njit(cache=True)
def _ab_fir(x, f, h, w, out):  # pragma: no cover - compiled
    """out[k] = x[k-1] + sum_i (h w[i]) f[k-1-i] for k >= s, row by row (the inner
    loops run over contiguous rows, which the compiler vectorises)."""
    n, nx = x.shape
    s = w.shape[0]
    for k in range(s, n):
        xr = x[k - 1]
        o = out[k]
        for j in range(nx):
            o[j] = xr[j]
        for i in range(s):
            c = h * w[i]
            fr = f[k - 1 - i]
            for j in range(nx):
                o[j] += c * fr[j]


@dataclass(frozen=True)
class AdamsBashforth:
    """Adams-Bashforth rule of order s (explicit, s-step).

    Attributes
    ----------
    order : int
        s >= 1; AB1 is Euler.
    coefficients : tuple of Fraction
        a_0..a_{s-1}, newest first; they sum to 1.
    a_s : Fraction
        sum of |a_i|, the noise gain of eqs. (24)-(25).
    """

    order: int
    name: str = ""
    coefficients: tuple[Fraction, ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "coefficients", ab_coefficients(self.order))
        if not self.name:
            object.__setattr__(self, "name", f"AB{self.order}")

    @property
    def a_s(self) -> Fraction:
        return sum((abs(a) for a in self.coefficients), Fraction(0))

    @property
    def weights(self) -> np.ndarray:
        """Coefficients as floats, newest first, shape (s,)."""
        return np.array([float(a) for a in self.coefficients])

    @property
    def history(self) -> int:
        """Number of past samples the rule needs."""
        return self.order

    def predict(self, model: Any, data: Trajectory, signal: Any = None) -> np.ndarray:
        """One-step-ahead predictions; f is evaluated once per sample.

        ``signal`` is not used: AB needs no input between samples.
        """
        f = model.f(data.t, data.x, data.u)
        return ab_filter(data.x, f, data.h, self.weights)


def Euler() -> AdamsBashforth:  # noqa: N802 - reads as a class in user code
    """Forward Euler, ``x_{n+1} = x_n + h f(t_n, x_n, u_n)``: the rule AB1 (= RK1)."""
    return AdamsBashforth(1, name="E")
