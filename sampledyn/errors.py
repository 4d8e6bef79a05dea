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
(:func:`sampledyn.methods.uniform_grid`) w = 1 exactly and the numbers are the
unweighted ones, bit for bit. The errors themselves are not rescaled by the step
(``e_n / h_n^{s+1}`` would depend on the rule's order and mix truncation with noise).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ._trajectory import Trajectory, uniform_grid

__all__ = ["ERROR_NORMS", "error_norm", "error_norms", "local_errors"]

ERROR_NORMS = ("rms", "max", "l2_over_n", "l2", "mean")


def local_errors(x_hat: np.ndarray, reference: Trajectory | np.ndarray) -> np.ndarray:
    """Disturbed local errors ``x_ref[n] - x_hat[n]`` (section 5.1).

    With measured data as the reference these are the paper's disturbed local errors
    (measurement minus prediction); with ``measured.clean`` they are the errors
    against the exact samples.

    Returns
    -------
    ndarray, shape (N, nx); NaN where the prediction is NaN.
    """
    ref = reference.x if isinstance(reference, Trajectory) else np.asarray(reference, dtype=float)
    x_hat = np.asarray(x_hat, dtype=float)
    if x_hat.shape != ref.shape:
        raise ValueError(f"`x_hat` has shape {x_hat.shape}, the reference {ref.shape}.")
    return ref - x_hat


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
        raise ValueError(
            f"`errors` must have shape (len(t), nx), got {e.shape} with len(t)={t.shape[0]}."
        )
    if components is not None:
        e = e[:, components]
    for kind in kinds:
        if kind not in ERROR_NORMS:
            raise ValueError(f"unknown norm kind {kind!r}; valid: {', '.join(ERROR_NORMS)}.")
    sq = np.einsum("ij,ij->i", e, e)  # NaN where any component is NaN
    keep = ~np.isnan(sq)
    if where is not None:
        where = np.asarray(where, dtype=bool)
        if where.shape != keep.shape:
            raise ValueError(f"`where` must have shape {keep.shape}, got {where.shape}.")
        keep &= where
    if after is not None:
        keep &= t >= after - 1e-9 * max(1.0, abs(after))
    sq = sq[keep]
    if sq.size == 0:
        raise ValueError(
            f"no samples with a prediction at t >= after={after}; "
            "shorten `after` or lengthen the run."
        )
    w = _step_weights(t, keep)
    total = float(sq.sum()) if w is None else float((w * sq).sum())
    out: dict[str, float] = {}
    for kind in kinds:
        if kind == "rms":
            out[kind] = float(np.sqrt(total / sq.size))
        elif kind == "max":
            out[kind] = float(np.sqrt(sq.max()))
        elif kind == "l2_over_n":
            out[kind] = float(np.sqrt(total) / sq.size)
        elif kind == "l2":
            out[kind] = float(np.sqrt(total))
        elif w is None:
            out[kind] = float(np.sqrt(sq).mean())
        else:
            out[kind] = float((w * np.sqrt(sq)).sum() / sq.size)
    return out


def _step_weights(t: np.ndarray, keep: np.ndarray) -> np.ndarray | None:
    """Weights of the kept samples on a non-uniform grid (module docstring), None on a
    uniform one."""
    if t.size < 2 or uniform_grid(t, (t[-1] - t[0]) / (t.size - 1)):
        return None
    steps = np.diff(t)
    span = np.concatenate([steps[:1], steps])[keep]  # sample n: t_n - t_{n-1}
    return span / span.mean()
