"""Compiled passes over the rows of an array: sums in a fixed order, noisy samples
(imported on first use: the modules that offer them stay free of numba at import
time)."""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["add_scaled_draws", "squares_in_order", "squares_of_sets"]


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


@njit(cache=True)
def squares_of_sets(e, cols, starts, dest, parent, skip, out):  # pragma: no cover - compiled
    """``out[dest[k], n]`` = :func:`squares_in_order` of row n over the columns
    ``cols[starts[k]:starts[k + 1]]``, every set in one pass over the rows.

    A set whose first ``skip[k]`` columns are the set written to ``out[parent[k]]``
    (an earlier one; -1: none) goes on from that set's sums: the same additions in
    the same order, not repeated. Rows go in blocks of 256, the squares of a block once, so
    each sum runs over independent rows instead of one chain of additions per row."""
    n_rows, nx = e.shape
    block = 256
    sq = np.empty((nx, block))
    acc = np.empty(block)
    for lo in range(0, n_rows, block):
        m = min(block, n_rows - lo)
        for r in range(m):
            for j in range(nx):
                x = e[lo + r, j]
                sq[j, r] = x * x
        for k in range(starts.shape[0] - 1):
            first = starts[k] + skip[k]
            if parent[k] >= 0:
                for r in range(m):
                    acc[r] = out[parent[k], lo + r]
            else:
                c = cols[first]
                for r in range(m):
                    acc[r] = sq[c, r]
                first += 1
            for i in range(first, starts[k + 1]):
                c = cols[i]
                for r in range(m):
                    acc[r] += sq[c, r]
            for r in range(m):
                out[dest[k], lo + r] = acc[r]


@njit(cache=True)
def add_scaled_draws(x, draws, cols, amp, low, span, out):  # pragma: no cover - compiled
    """``out[n, cols[k]] = x[n, cols[k]] + (low + span draws[n, k]) amp[cols[k]]``, each
    operation rounded in that order (numpy's ``uniform(low, low + span)`` of the draws,
    times the amplitude, added to the sample); the other columns of ``out`` untouched."""
    for n in range(x.shape[0]):
        for k in range(cols.shape[0]):
            c = cols[k]
            out[n, c] = x[n, c] + (low + span * draws[n, k]) * amp[c]
