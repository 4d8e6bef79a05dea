"""Compiled passes over the rows of an array: sums in a fixed order, noisy samples
(imported on first use: the modules that offer them stay free of numba at import
time)."""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = [
    "add_scaled_draws",
    "fir_rows",
    "squares_in_order",
    "squares_of_sets",
    "window_sums",
]

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


@njit  # compiled into its callers (cached with them)
def fir_rows(x, f, hw, lo, hi, out, shift):  # pragma: no cover - compiled
    """``out[k - shift] = x[k-1] + sum_i hw[k-s, i] f[k-1-i]`` for k = lo..hi-1 (lo >= s;
    ``hw[0]`` on every row if hw has one row), each product and sum rounded in that
    order: the prediction of an Adams-type rule from f at the samples
    (:func:`sampledyn.methods._adams.ab_filter_steps`), row by row (the inner loops run
    over contiguous rows, which the compiler vectorises)."""
    nx = x.shape[1]
    s = hw.shape[1]
    per_row = hw.shape[0] > 1
    for k in range(lo, hi):
        w = hw[k - s] if per_row else hw[0]
        xr = x[k - 1]
        o = out[k - shift]
        for j in range(nx):
            o[j] = xr[j]
        for i in range(s):
            c = w[i]
            fr = f[k - 1 - i]
            for j in range(nx):
                o[j] += c * fr[j]


@njit(cache=True)
def window_sums(  # noqa: C901 - one function: each compiled one costs compile time
    a, b, fir, hw, first, cols, starts, dest, parent, skip, leaves, joins, out
):  # pragma: no cover - compiled
    """Per component set k, over the rows ``first..N-1`` of the errors ``e = a - b``
    (shape (N, nx)), ``out[k]`` = the sum of the per-row sums of squares
    (:func:`squares_of_sets`, the same bits) as ``np.sum`` adds them, in one pass and
    without the arrays: numpy's pairwise tree, ``leaves`` rows (offset, count <=
    PAIRWISE_BLOCK) from ``first``, each summed with 8 accumulators, and ``joins``
    node pairs added in order (a node: leaf k >= 0, or join -1 - j). A NaN row makes
    ``out[k]`` NaN (the squares are >= 0). One function, not several: each compiled
    function costs the first run its compile time.

    With ``fir`` the prediction ``b`` is not an array but formed here by
    :func:`fir_rows` from ``a`` (the samples), ``b`` (f at the samples) and ``hw``
    (first >= s)."""
    nx = a.shape[1]
    n_sets = starts.shape[0] - 1
    block = PAIRWISE_BLOCK
    sq = np.empty((nx, block))
    pred = np.empty((block, nx))
    vals = np.empty((n_sets, block))
    leaf = np.empty((n_sets, leaves.shape[0]))
    join = np.empty(joins.shape[0])
    for q in range(leaves.shape[0]):
        lo = first + leaves[q, 0]
        m = leaves[q, 1]
        # The squares of the leaf's rows once, by component; then each set's per-row
        # sums with the rows innermost (independent: vectorised), as squares_of_sets.
        if fir:
            fir_rows(a, b, hw, lo, lo + m, pred, lo)
            for r in range(m):
                for j in range(nx):
                    x = a[lo + r, j] - pred[r, j]
                    sq[j, r] = x * x
        else:
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
        for k in range(n_sets):  # numpy's sum of a leaf (pairwise_sum, n <= 128)
            v = vals[k]
            if m < 8:
                res = 0.0
                for r in range(m):
                    res += v[r]
            else:
                r0, r1, r2, r3 = v[0], v[1], v[2], v[3]
                r4, r5, r6, r7 = v[4], v[5], v[6], v[7]
                top = m - m % 8
                for r in range(8, top, 8):
                    r0 += v[r]
                    r1 += v[r + 1]
                    r2 += v[r + 2]
                    r3 += v[r + 3]
                    r4 += v[r + 4]
                    r5 += v[r + 5]
                    r6 += v[r + 6]
                    r7 += v[r + 7]
                res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
                for r in range(top, m):
                    res += v[r]
            leaf[k, q] = res
    for k in range(n_sets):  # up the tree
        for j in range(joins.shape[0]):
            left, right = joins[j, 0], joins[j, 1]
            x = leaf[k, left] if left >= 0 else join[-1 - left]
            y = leaf[k, right] if right >= 0 else join[-1 - right]
            join[j] = x + y
        out[k] = join[joins.shape[0] - 1] if joins.shape[0] else leaf[k, 0]


@njit(cache=True)
def add_scaled_draws(
    x, first, second, stream, pos, amp, low, span, out
):  # pragma: no cover - compiled
    """Every element of ``out``, shape (N, nx), in one pass: component c of row n is
    ``x[n, c] + (low + span d[n, pos[c]]) amp[c]``, each operation rounded in that order
    (numpy's ``uniform(low, low + span)`` of the draws d, times the amplitude, added to
    the sample), with d = ``first`` where ``stream[c]`` is 1 and ``second`` where it is
    2; ``x[n, c]`` where it is 0 (a component without noise)."""
    for n in range(x.shape[0]):
        for c in range(x.shape[1]):
            g = stream[c]
            if g == 0:
                out[n, c] = x[n, c]
            elif g == 1:
                out[n, c] = x[n, c] + (low + span * first[n, pos[c]]) * amp[c]
            else:
                out[n, c] = x[n, c] + (low + span * second[n, pos[c]]) * amp[c]
