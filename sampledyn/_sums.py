"""Compiled sums over the rows of an array, in a fixed order (imported on first use:
the modules that offer them stay free of numba at import time)."""

from __future__ import annotations

from numba import njit

__all__ = ["squares_in_order"]


@njit(cache=True)
def squares_in_order(e, cols, out):  # pragma: no cover - compiled
    """``out[n] = ((e[n, c0]^2 + e[n, c1]^2) + e[n, c2]^2) + ...`` over ``cols`` in
    their order, each square rounded (numba contracts no multiply-add into an FMA)."""
    for n in range(e.shape[0]):
        acc = 0.0
        for c in cols:
            x = e[n, c]
            acc += x * x
        out[n] = acc
