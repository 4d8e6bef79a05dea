"""Compiled passes over the rows of an array: sums in a fixed order, noisy samples
(imported on first use: the modules that offer them stay free of numba at import
time)."""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["add_scaled_draws", "squares_in_order", "squares_of_sets", "window_sums"]

#: The longest run numpy's pairwise summation adds with 8 accumulators (PW_BLOCKSIZE).
PAIRWISE_BLOCK = 128


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
def _pairwise_leaf(v, m):  # pragma: no cover - compiled
    """numpy's pairwise sum of ``v[:m]``, m <= PAIRWISE_BLOCK (one leaf of its tree)."""
    if m < 8:
        res = 0.0
        for i in range(m):
            res += v[i]
        return res
    r0, r1, r2, r3 = v[0], v[1], v[2], v[3]
    r4, r5, r6, r7 = v[4], v[5], v[6], v[7]
    top = m - m % 8
    for i in range(8, top, 8):
        r0 += v[i]
        r1 += v[i + 1]
        r2 += v[i + 2]
        r3 += v[i + 3]
        r4 += v[i + 4]
        r5 += v[i + 5]
        r6 += v[i + 6]
        r7 += v[i + 7]
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    for i in range(top, m):
        res += v[i]
    return res


@njit(cache=True)
def window_sums(a, b, first, cols, starts, dest, parent, skip, leaves, joins, extra, out):  # pragma: no cover - compiled
    """Per component set k, over the rows ``first..N-1`` of ``e = a - b`` (shape (N,
    nx)), the sums a norm needs, in one pass and without the arrays: ``out[0, k]`` the
    sum of the per-row sums of squares (:func:`squares_of_sets`, the same bits), as
    ``np.sum`` of them adds (numpy's pairwise tree: ``leaves``, rows (offset, count)
    from ``first``; ``joins``, node pairs added in order, a node being a leaf k >= 0
    or the join -1 - j), ``out[1, k]`` their largest, ``out[2, k]`` the pairwise sum of
    their square roots (if ``roots``), ``out[3, k]`` the number of rows that are NaN
    (then the others mean nothing)."""
    nx = a.shape[1]
    n_sets = starts.shape[0] - 1
    block = PAIRWISE_BLOCK
    sq = np.empty((nx, block))
    vals = np.empty((n_sets, block))
    leaf = np.empty((2, n_sets, leaves.shape[0]))
    join = np.empty((2, n_sets, joins.shape[0]))
    for k in range(n_sets):
        out[1, k] = -np.inf
    for q in range(leaves.shape[0]):
        lo = first + leaves[q, 0]
        m = leaves[q, 1]
        # The squares of the leaf's rows once, by component, then each set's sums with
        # the rows innermost (independent, vectorised), as squares_of_sets forms them.
        for r in range(m):
            for j in range(nx):
                x = a[lo + r, j] - b[lo + r, j]
                sq[j, r] = x * x
        for k in range(n_sets):
            acc = vals[dest[k]]
            i0 = starts[k] + skip[k]
            if parent[k] >= 0:
                prev = vals[parent[k]]
                for r in range(m):
                    acc[r] = prev[r]
            else:
                sc = sq[cols[i0]]
                for r in range(m):
                    acc[r] = sc[r]
                i0 += 1
            for i in range(i0, starts[k + 1]):
                sc = sq[cols[i]]
                for r in range(m):
                    acc[r] += sc[r]
        for k in range(n_sets):
            v = vals[k]
            leaf[0, k, q] = _pairwise_leaf(v, m)
            if extra:
                mx = out[1, k]
                for r in range(m):
                    mx = max(mx, v[r])
                out[1, k] = mx
                for r in range(m):
                    v[r] = np.sqrt(v[r])
                leaf[1, k, q] = _pairwise_leaf(v, m)
    for s in range(1 + extra):
        for k in range(n_sets):
            for j in range(joins.shape[0]):
                total = 0.0
                for side in range(2):
                    node = joins[j, side]
                    part = leaf[s, k, node] if node >= 0 else join[s, k, -1 - node]
                    total = part if side == 0 else total + part
                join[s, k, j] = total
            if joins.shape[0]:
                out[2 * s, k] = join[s, k, joins.shape[0] - 1]
            else:
                out[2 * s, k] = leaf[s, k, 0]


@njit(cache=True)
def add_scaled_draws(x, draws, cols, amp, low, span, out):  # pragma: no cover - compiled
    """``out[n, cols[k]] = x[n, cols[k]] + (low + span draws[n, k]) amp[cols[k]]``, each
    operation rounded in that order (numpy's ``uniform(low, low + span)`` of the draws,
    times the amplitude, added to the sample); the other columns of ``out`` untouched."""
    for n in range(x.shape[0]):
        for k in range(cols.shape[0]):
            c = cols[k]
            out[n, c] = x[n, c] + (low + span * draws[n, k]) * amp[c]
