"""Local prediction errors (section 5.1) and their norms.

Norms on non-uniform time. The local error ``e_n = x_n - x_hat_n`` belongs to the
interval ``[t_{n-1}, t_n]`` its prediction spans. On a non-uniform grid (jittered or
bridged logs) the norms that sum or average over samples weight each sample by the
length of that interval, normalised so the weights sum to the number of samples
counted: ``w_n = (t_n - t_{n-1}) / mean step`` (``w_0 = (t_1 - t_0) / mean step``).
They are then Riemann sums of the time average of the error, so a stretch of the log
counts for its duration, not for how many records it holds (an interval bridging 3
dropped records counts like the 4 intervals it replaces), and they stay in the
units and scale of the unweighted norms:

=============  =======================================  ==========================
kind           uniform grid (w = 1)                     non-uniform grid
=============  =======================================  ==========================
"rms"          sqrt(mean ||e_n||^2)                     sqrt(sum w_n ||e_n||^2 / N)
"mean"         mean ||e_n||                             sum w_n ||e_n|| / N
"l2"           sqrt(sum ||e_n||^2)                      sqrt(sum w_n ||e_n||^2)
"l2_over_n"    sqrt(sum ||e_n||^2) / N                  sqrt(sum w_n ||e_n||^2) / N
"max"          max ||e_n||                              the same (a largest error
                                                        is not a sum)
=============  =======================================  ==========================

(N = number of samples counted.) On a grid that is uniform to the rounding of t
(:func:`sampledyn._trajectory.uniform_grid`) w = 1 exactly and the numbers are the
unweighted ones, bit for bit. The errors themselves are not rescaled by the step
(``e_n / h_n^{s+1}`` would depend on the rule's order and mix truncation with noise).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

from . import _checks as checks
from ._trajectory import Trajectory, uniform_grid
from .exceptions import ArgumentError

__all__ = [
    "ERROR_NORMS",
    "ErrorWindow",
    "error_norm",
    "error_norms",
    "error_window",
    "local_errors",
    "sum_of_squares",
    "sums_of_squares",
]

ERROR_NORMS = ("rms", "max", "l2_over_n", "l2", "mean")
_NO_WEIGHTS = np.zeros((1, 0))  # hw of ErrorWindow.norms_of_sets for a plain pair


def local_errors(
    x_hat: np.ndarray, reference: Trajectory | np.ndarray, *, out: np.ndarray | None = None
) -> np.ndarray:
    """Disturbed local errors ``x_ref[n] - x_hat[n]`` (section 5.1).

    With measured data as the reference these are the paper's disturbed local errors
    (measurement minus prediction); with ``measured.clean`` they are the errors
    against the exact samples.

    ``out`` (float64, the shape of ``x_hat``; it may be ``x_hat`` itself, a prediction
    that is not needed afterwards) receives the errors instead of a new array.

    Returns
    -------
    ndarray, shape (N, nx); NaN where the prediction is NaN.

    Raises
    ------
    sampledyn.exceptions.ArgumentError
        (argument ``x_hat``) if the shapes differ.
    TypeError
        if ``x_hat`` is a Trajectory (the arguments swapped).
    """
    if isinstance(x_hat, Trajectory):
        raise TypeError(
            "`x_hat` is a Trajectory: the prediction comes first, an array (N, nx) (from "
            "predict()), then the reference: local_errors(x_hat, reference)."
        )
    ref = reference.x if isinstance(reference, Trajectory) else np.asarray(reference, dtype=float)
    x_hat = np.asarray(x_hat, dtype=float)
    if x_hat.shape != ref.shape:
        raise ArgumentError(
            "x_hat",
            f"`x_hat` has shape {x_hat.shape}, the reference {ref.shape}: predict on the "
            "reference's samples (the same N and nx).",
        )
    return np.subtract(ref, x_hat, out=out)


def sum_of_squares(errors: np.ndarray, components: Any = None) -> np.ndarray:
    """Per-sample sum of squares over the selected components, ``sum_i e[n, i]^2``,
    shape (N,); NaN where a selected component is NaN. The one place every norm of
    local errors (and the noise bounds compared with them) forms it, so all agree to
    the last bit.

    errors : ndarray, shape (N, nx)
    components : None (all), a slice, or a sequence of int (in that order)

    The order of the floating-point sum is fixed on every machine: from the first
    selected component to the last, each square rounded (no fused multiply-add).
    """
    return sums_of_squares(errors, (components,))[0]


def sums_of_squares(errors: np.ndarray, component_sets: Any) -> np.ndarray:
    """:func:`sum_of_squares` for several component sets in one pass over the rows,
    shape (len(component_sets), N); row k is bit for bit
    ``sum_of_squares(errors, component_sets[k])``.

    Raises
    ------
    ValueError
        if ``errors`` is not 2-D or a set selects no component or one out of range.
    """
    e = np.asarray(errors, dtype=float)
    if e.ndim != 2:
        raise ValueError(f"`errors` must have shape (N, nx), got {e.shape}.")
    from ._sums import squares_of_sets  # numba, loaded on first use

    sets = _component_tuples(e.shape[1], component_sets)
    cols_, starts, dest, parent, skip = _prefix_plan(sets)
    out = np.empty((len(sets), e.shape[0]))
    squares_of_sets(np.ascontiguousarray(e), cols_, starts, dest, parent, skip, out)
    return out


def _component_tuples(nx: int, component_sets: Any) -> tuple[tuple[int, ...], ...]:
    """The component sets of :func:`sums_of_squares` as tuples of indices in 0..nx-1
    (sets given as a tuple of tuples of int: checked once per nx and sets).

    Raises ValueError for a set that selects no component or one out of range."""
    if isinstance(component_sets, tuple) and all(type(c) is tuple for c in component_sets):
        return _checked_tuples(nx, component_sets)
    return _checked(nx, component_sets)


@lru_cache(maxsize=64)
def _checked_tuples(
    nx: int, component_sets: tuple[tuple[int, ...], ...]
) -> tuple[tuple[int, ...], ...]:
    return _checked(nx, component_sets)


def _checked(nx: int, component_sets: Any) -> tuple[tuple[int, ...], ...]:
    cols = []
    for comps in component_sets:
        if comps is None or isinstance(comps, slice):
            idx = np.arange(nx)[slice(None) if comps is None else comps]
        else:
            idx = np.asarray(comps, dtype=np.int64).reshape(-1)
            if idx.size and (idx.min() < -nx or idx.max() >= nx):
                raise ValueError(f"components {idx.tolist()} out of range for nx = {nx}.")
            idx = np.where(idx < 0, idx + nx, idx)
        if idx.size == 0:
            raise ValueError(f"component set {comps!r} selects no component of {nx}.")
        cols.append(tuple(int(i) for i in idx))
    return tuple(cols)


@lru_cache(maxsize=64)
def _prefix_plan(sets: tuple[tuple[int, ...], ...]) -> tuple[np.ndarray, ...]:
    """The order :func:`sums_of_squares` forms the sets in: shortest first, each going
    on from the longest earlier set it starts with. (cols, starts, dest, parent, skip)
    of :func:`sampledyn._sums.squares_of_sets`."""
    order = sorted(range(len(sets)), key=lambda k: len(sets[k]))
    parent = np.full(len(sets), -1, dtype=np.int64)
    skip = np.zeros(len(sets), dtype=np.int64)
    for pos, k in enumerate(order):
        for j in order[:pos]:
            size = len(sets[j])
            if skip[pos] < size <= len(sets[k]) and sets[k][:size] == sets[j]:
                parent[pos], skip[pos] = j, size
    starts = np.zeros(len(sets) + 1, dtype=np.int64)
    starts[1:] = np.cumsum([len(sets[k]) for k in order])
    cols = np.array([i for k in order for i in sets[k]], dtype=np.int64)
    return cols, starts, np.array(order, dtype=np.int64), parent, skip


def error_norm(
    errors: np.ndarray,
    t: np.ndarray,
    kind: str = "rms",
    after: float | None = None,
    components: Any = None,
    where: np.ndarray | None = None,
) -> float:
    """A norm of local errors over the samples with t >= ``after`` (s).

    The per-sample error is the Euclidean norm over the selected components;
    samples with NaN (no prediction) are left out.

    errors : ndarray, shape (N, nx) or (N,)
    t : ndarray, shape (N,)
        Sample times (s); on a non-uniform grid they weight the samples.
    kind
        "rms": sqrt(mean ||e_n||^2); "max": max ||e_n||; "l2_over_n": sqrt(sum
        ||e_n||^2) / N; "l2": sqrt(sum ||e_n||^2); "mean": mean ||e_n||. On a
        non-uniform grid every kind but "max" weights sample n by the length of the
        interval its prediction spans (see the module docstring for the table).
    components : slice, sequence of int, or None
        State components to include (e.g. ``slice(0, 6)`` for eta).
    where : ndarray of bool, shape (N,), optional
        Only samples where this is True count (e.g. away from input jumps).

    Raises
    ------
    ValueError
        for an unknown ``kind``, shapes that do not fit, or no sample left.
    """
    return error_norms(errors, t, (kind,), after, components, where)[kind]


def error_norms(
    errors: np.ndarray,
    t: np.ndarray,
    kinds: tuple[str, ...] = ERROR_NORMS,
    after: float | None = None,
    components: Any = None,
    where: np.ndarray | None = None,
) -> dict[str, float]:
    """Several norms of :func:`error_norm` at once (the per-sample norms are computed
    once); returns kind -> value."""
    e = np.asarray(errors, dtype=float)
    t = np.asarray(t, dtype=float)
    if e.ndim == 1:
        e = e[:, None]
    if e.ndim != 2 or e.shape[0] != t.shape[0]:
        raise ArgumentError(
            "errors",
            f"`errors` must have shape (len(t), nx), got {e.shape} with len(t)={t.shape[0]}.",
        )
    _check_kinds(kinds)
    return error_window(t, after, where).norms(e, kinds, components)


def _check_kinds(kinds: tuple[str, ...]) -> None:
    for kind in kinds:
        if kind not in ERROR_NORMS:
            raise ArgumentError(
                "kinds",
                f"unknown norm kind {kind!r}{checks.did_you_mean(str(kind), ERROR_NORMS)}; "
                f"valid: {', '.join(ERROR_NORMS)}.",
            )


@dataclass(frozen=True)
class ErrorWindow:
    """The samples a norm counts (t >= ``after`` and ``where``), found once for several
    norms of errors on the same sample times (:func:`error_window`).

    Attributes
    ----------
    n_samples : int
        N, the number of samples of the errors it applies to.
    after : float or None
        Start of the window (s).
    rows : slice or ndarray of int
        The samples inside the window, ascending (a slice when they are the samples
        from some n on, as for increasing t without ``where``).
    span : ndarray or None
        ``t_n - t_{n-1}`` of those samples on a non-uniform grid (the weights of the
        module docstring before normalisation); None on a uniform one.
    """

    n_samples: int
    after: float | None
    rows: Any
    span: np.ndarray | None

    def norms(
        self, errors: np.ndarray, kinds: tuple[str, ...] = ERROR_NORMS, components: Any = None
    ) -> dict[str, float]:
        """:func:`error_norms` of ``errors``, shape (N, nx), on this window's samples
        (samples whose selected components hold NaN are left out, as there)."""
        if errors.shape[0] != self.n_samples:
            raise ArgumentError(
                "errors", f"`errors` has {errors.shape[0]} samples, the window {self.n_samples}."
            )
        _check_kinds(kinds)
        return self._norms(sum_of_squares(errors[self.rows], components), kinds)

    def norms_of_squares(
        self, squares: np.ndarray, kinds: tuple[str, ...] = ERROR_NORMS
    ) -> dict[str, float]:
        """:meth:`norms` from the per-sample sums of squares of all N samples, shape
        (N,) (:func:`sums_of_squares`: several component sets in one pass), the same
        numbers bit for bit."""
        if squares.shape != (self.n_samples,):
            raise ValueError(
                f"`squares` has shape {squares.shape}, the window {self.n_samples} samples."
            )
        _check_kinds(kinds)
        return self._norms(squares[self.rows], kinds)

    def norms_of_sets(
        self,
        a: np.ndarray,
        b: np.ndarray,
        component_sets: Any,
        kinds: tuple[str, ...] = ERROR_NORMS,
        hw: np.ndarray | None = None,
    ) -> list[dict[str, float]] | None:
        """:meth:`norms` of the errors ``a - b`` (both shape (N, nx), float64; e.g. the
        samples and a prediction) over each of ``component_sets``, from one compiled
        pass over the window's samples that forms neither the errors nor their squares
        as arrays: the same numbers bit for bit (the sums in numpy's pairwise order).

        With ``hw`` (shape (1, s) or (N - s, s)), ``b`` is f at the samples ``a`` and the
        prediction of row k is not an array either: ``a[k-1] + sum_i hw[., i] b[k-1-i]``
        as :func:`sampledyn._sums.fir_rows` forms it (an Adams-type rule).

        Returns None where that pass does not apply (then :meth:`norms_of_squares`):
        the kinds "max" and "mean" (not sums of the squares), a non-uniform grid
        (weighted norms), a window that is not the samples from some n on (a mask), a
        row without a prediction in it (NaN, or k < s with ``hw``).
        Raises ValueError as :func:`sums_of_squares` for a set that selects nothing."""
        if self.span is not None or not isinstance(self.rows, slice):
            return None
        first, n = self.rows.indices(self.n_samples)[:2]
        if n <= first or a.shape != b.shape or a.shape[0] != self.n_samples:
            return None
        if hw is not None and (first < hw.shape[1] or hw.shape[0] not in (1, n - hw.shape[1])):
            return None
        _check_kinds(kinds)
        if "max" in kinds or "mean" in kinds:  # not sums of the squares
            return None
        from ._sums import window_sums  # numba, loaded on first use
        from .models._base import readonly as ro

        sets = _component_tuples(a.shape[1], component_sets)
        cols, starts, dest, parent, skip = _prefix_plan(sets)
        leaves, joins = _pairwise_plan(n - first)
        out = np.empty(dest.size)
        # Read-only views of every input (the samples are, a prediction may not be):
        # one compiled specialisation whatever the caller's flags.
        window_sums(ro(a), ro(b), hw is not None, ro(_NO_WEIGHTS if hw is None else hw),
                    first, cols, starts, dest, parent, skip, leaves, joins, out)  # fmt: skip
        if np.isnan(out).any():  # a NaN row (the squares are >= 0: no inf - inf)
            return None
        size = n - first
        return [_kinds_of(kinds, float(total), size, math.nan, None) for total in out]

    def _norms(self, sq: np.ndarray, kinds: tuple[str, ...]) -> dict[str, float]:
        """The kinds from the sums of squares of the window's samples (NaN: none)."""
        span = self.span
        missing = np.isnan(sq)
        if missing.any():
            sq = sq[~missing]
            span = None if span is None else span[~missing]
        if sq.size == 0:
            if self.after is None:
                raise ArgumentError(
                    "errors",
                    f"no sample of the {self.n_samples} has a prediction; lengthen the run.",
                )
            raise ArgumentError(
                "after",
                f"no samples with a prediction at t >= after={self.after}; "
                "shorten `after` or lengthen the run.",
            )
        w = None if span is None else span / span.mean()
        total = float(sq.sum()) if w is None else float((w * sq).sum())

        def roots() -> float:
            r = np.sqrt(sq)
            return float(r.sum()) if w is None else float((w * r).sum())

        return _kinds_of(kinds, total, sq.size, float(sq.max()), roots)


def _kinds_of(
    kinds: tuple[str, ...], total: float, size: int, max_sq: float, roots: Any
) -> dict[str, float]:
    """The norms of the module docstring from the (weighted) sum of the per-sample sums
    of squares ``total``, their number ``size``, the largest ``max_sq``, and ``roots()``
    the (weighted) sum of their square roots (called only for "mean")."""
    out: dict[str, float] = {}
    for kind in kinds:
        if kind == "rms":
            out[kind] = float(np.sqrt(total / size))
        elif kind == "max":
            out[kind] = float(np.sqrt(max_sq))
        elif kind == "l2_over_n":
            out[kind] = float(np.sqrt(total) / size)
        elif kind == "l2":
            out[kind] = float(np.sqrt(total))
        else:
            out[kind] = float(roots() / size)
    return out


@lru_cache(maxsize=1)
def _numpy_sum_run() -> int | None:
    """The longest run ``np.sum`` of a contiguous float64 array gives one pairwise tree:
    None for the whole array (numpy >= 2.3), or the ufunc buffer size (numpy < 2.3
    sums runs of ``np.getbufsize()`` values, 8192 by default, and adds their sums in
    order). Found by a sum whose two orders round differently, not from the version:
    B + 1 values, 1 first and 2**-53 at B/2 and at B; one tree adds the two small ones
    first (1 + 2**-52), runs of B add each to 1 alone (rounds to 1)."""
    run = int(np.getbufsize())
    x = np.zeros(run + 1)
    x[0], x[run // 2], x[run] = 1.0, 2.0**-53, 2.0**-53
    return run if float(np.sum(x)) == 1.0 else None


@lru_cache(maxsize=16)
def _pairwise_plan(n: int) -> tuple[np.ndarray, np.ndarray]:
    """numpy's pairwise summation tree of n > 0 contiguous float64 values (the order
    ``np.sum`` adds them in, :func:`_numpy_sum_run`): the leaves, rows (offset, count)
    of at most :data:`sampledyn._sums.PAIRWISE_BLOCK` values each, in order, and the
    joins, rows (left, right) added in this order, a node being leaf k >= 0 or join
    -1 - j (the last join is the sum; none for one leaf)."""
    leaves: list[tuple[int, int]] = []
    joins: list[tuple[int, int]] = []

    def node(lo: int, m: int) -> int:
        if m <= 128:  # PAIRWISE_BLOCK; numpy splits a longer run at a multiple of 8
            leaves.append((lo, m))
            return len(leaves) - 1
        half = m // 2
        half -= half % 8
        pair = (node(lo, half), node(lo + half, m - half))
        joins.append(pair)
        return -len(joins)

    run = _numpy_sum_run() or n
    total = node(0, min(run, n))
    for lo in range(run, n, run):  # the runs' sums added in order
        joins.append((total, node(lo, min(run, n - lo))))
        total = -len(joins)
    return (np.array(leaves, dtype=np.int64).reshape(-1, 2),
            np.array(joins, dtype=np.int64).reshape(-1, 2))  # fmt: skip


def error_window(
    t: np.ndarray, after: float | None = None, where: np.ndarray | None = None
) -> ErrorWindow:
    """The samples of the times ``t`` (s), shape (N,), that the norms count: t >= ``after``
    (to 1e-9 relative) and, if given, ``where`` (bool, shape (N,)); with their step
    weights on a non-uniform grid. Several norms on the same times share it
    (:meth:`ErrorWindow.norms`).

    Raises
    ------
    ValueError
        if ``where`` has the wrong shape, or ``after`` is not a finite number.
    """
    if after is not None and not math.isfinite(after):
        raise ArgumentError("after", f"`after` must be a finite time (s) or None, got {after}.")
    t = np.asarray(t, dtype=float)
    n = t.shape[0]
    keep = None
    if where is not None:
        where = np.asarray(where, dtype=bool)
        if where.shape != (n,):
            raise ArgumentError("where", f"`where` must have shape {(n,)}, got {where.shape}.")
        keep = where.copy()
    if after is not None:
        late = checks.at_or_after(t, after)
        keep = late if keep is None else keep & late
    rows: Any = slice(0, n)
    if keep is not None:
        first = int(np.argmax(keep)) if keep.any() else n
        rows = slice(first, n) if keep[first:].all() else np.flatnonzero(keep)
    span = None
    if not (n < 2 or uniform_grid(t, (t[-1] - t[0]) / (n - 1))):
        steps = np.diff(t)
        span = np.concatenate([steps[:1], steps])[rows]  # sample n: t_n - t_{n-1}
    return ErrorWindow(n, after, rows, span)
