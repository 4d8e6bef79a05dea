"""Truncation and noise parts of the disturbed local errors against the sampling period.

One reference run at a fine base period h0 gives exact samples at every multiple
``k h0`` by subsampling, so the truncation term (exact local error on those samples),
the first-order path prediction and the domain bound can be drawn against h, and the
h where truncation and noise cross can be read off, per rule.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import _checks as checks
from .._noise import noise_amplitudes
from .._trajectory import Trajectory
from ..exceptions import NumericalError, SingularPitchError
from ..models import Model
from ._bound import assemble_bound, jacobian_pair, subsample
from ._domain import Domain
from ._gains import supported_method
from ._path import path_prediction

__all__ = ["RANK_BY", "ErrorCurves", "error_curves", "h_grid", "largest_h", "rank_key"]

RANK_BY = ("max", "eta", "v")


@dataclass(frozen=True)
class ErrorCurves:
    """Parts of the disturbed local errors of several rules against h.

    Every array has shape (K, 2): column 0 the position block eta (m, rad), column 1
    the velocity block v (m/s, rad/s); rows follow ``h``.

    Attributes
    ----------
    h : ndarray, shape (K,)
        Sampling periods (s), increasing.
    eta_pct, v_pct : float
        Noise levels (%).
    methods : tuple of str
    truncation : mapping method -> ndarray (K, 2)
        Largest undisturbed local error on exact samples.
    predicted_noise, predicted : mapping method -> ndarray (K, 2)
        Noise part and total of the first-order path prediction (max over samples).
    bound_noise, bound : mapping method -> ndarray (K, 2)
        Noise part and total of the domain bound (24)-(25); NaN where no bound was
        computed (no domain: the Jacobian maxima (19)-(23) exist for the 6-DoF
        vehicle only).
    failed : mapping method -> (h, reason)
        The rules whose prediction failed at some period of the grid (Newton not
        converging, a state at the singular pitch, a non-finite prediction), with the
        first such h (s) and why: their curves are NaN from there on, so ``largest_h``
        ends before it.
    """

    h: np.ndarray
    eta_pct: float
    v_pct: float
    methods: tuple[str, ...]
    truncation: Mapping[str, np.ndarray]
    predicted_noise: Mapping[str, np.ndarray]
    predicted: Mapping[str, np.ndarray]
    bound_noise: Mapping[str, np.ndarray]
    bound: Mapping[str, np.ndarray]
    failed: Mapping[str, tuple[float, str]] = field(default_factory=dict)

    def crossing(self, method: str) -> tuple[float | None, float | None]:
        """The h (s) where the truncation curve meets the predicted noise curve, per
        block (eta, v), by log-log interpolation; None when they do not cross."""
        out: list[float | None] = []
        for b in (0, 1):
            tr = self.truncation[method][:, b]
            nz = self.predicted_noise[method][:, b]
            diff = np.log(np.maximum(tr, 1e-300)) - np.log(np.maximum(nz, 1e-300))
            hit = np.flatnonzero((diff[:-1] < 0) & (diff[1:] >= 0))
            if hit.size == 0 or not (nz > 0).any():
                out.append(None)
                continue
            i = int(hit[0])
            w = -diff[i] / (diff[i + 1] - diff[i])
            lh = np.log(self.h[i]) + w * (np.log(self.h[i + 1]) - np.log(self.h[i]))
            out.append(float(np.exp(lh)))
        return out[0], out[1]


def h_grid(h: float, h_min: float = 0.02, h_max: float | None = None) -> tuple[float, list[int]]:
    """Base period h0 = h / m (m = ceil(h / h_min)) and the multiples k of it to visit:
    about 6 per decade from h0 to ``h_max`` (default max(2 s, 4 h)), always with k = m."""
    h = checks.period(h)
    m = max(1, checks.ceil_ratio(h, h_min))
    h0 = h / m
    top = max(2.0, 4.0 * h) if h_max is None else h_max
    kmax = max(m, checks.floor_ratio(top, h0))
    ks = {int(round(k)) for k in np.geomspace(1, kmax, int(6 * math.log10(kmax) + 2))}
    ks.add(m)
    return h0, sorted(k for k in ks if k >= 1)


def samples_needed(methods: Sequence[Any]) -> int:
    """Samples a run must hold for the error curves of ``methods``: the longest history
    and 3 predictions."""
    return max(supported_method(m, "methods").history for m in methods) + 3


def usable_periods(methods: Sequence[Any], base: Trajectory, ks: Sequence[int]) -> list[int]:
    """The multiples k of ``base.h`` that leave at least 3 predictions for every rule
    (:func:`samples_needed`)."""
    need = samples_needed(methods)
    return [k for k in ks if (base.n_samples - 1) // k + 1 >= need]


# What ends a rule's curve (the other rules' curves go on): its prediction failing
# at a period of the grid.
_CURVE_FAILURES = (NumericalError, SingularPitchError, FloatingPointError)


def error_curves(
    model: Model,
    methods: Sequence[Any],
    base: Trajectory,
    ks: Sequence[int],
    eta_pct: float,
    v_pct: float,
    domain: Domain | None,
    signal: Any = None,
    *,
    samples: int = 5000,
    amplitudes: Any = None,
) -> ErrorCurves:
    """Curves of :class:`ErrorCurves` at the periods ``k base.h`` for k in ``ks``.

    ``model`` is a vehicle, or any model whose states are positions/angles and rates
    (:func:`state_blocks`); ``domain`` None computes no bound (its curves NaN).
    Periods that leave fewer than 3 predictions for some rule are dropped.
    ``amplitudes`` (shape (nx,), state units) replaces the noise amplitudes of
    ``eta_pct``, ``v_pct`` (per-state levels, e.g. estimated from a log).

    A rule whose prediction fails at some period (:attr:`ErrorCurves.failed`) has NaN
    there and at every longer period; the other rules' curves are complete.
    """
    amp = (
        noise_amplitudes(model.state_units, eta_pct, v_pct)
        if amplitudes is None
        else np.asarray(amplitudes, dtype=float)
    )
    reports = None if domain is None else jacobian_pair(model, domain, amp, samples)
    ms = [supported_method(m, "methods") for m in methods]
    ks = usable_periods(ms, base, ks)
    if not ks:
        raise ValueError("the reference run is too short for the requested periods.")
    keys = ("truncation", "predicted_noise", "predicted", "bound_noise", "bound")
    store: dict[str, dict[str, np.ndarray]] = {
        key: {m.name: np.full((len(ks), 2), np.nan) for m in ms} for key in keys
    }
    failed: dict[str, tuple[float, str]] = {}
    for row, k in enumerate(ks):
        clean = subsample(base, k)
        cache: dict[Any, Any] = {}  # f and df/dx at these samples, shared by the rules
        for m in ms:
            if m.name in failed:
                continue
            try:
                _curve_point(store, row, m, model, clean, amp, signal, cache, reports, samples,
                             eta_pct, v_pct)  # fmt: skip
            except _CURVE_FAILURES as exc:
                failed[m.name] = (
                    float(clean.h),
                    f"{type(exc).__name__}: {' '.join(str(exc).split())}",
                )
                for key in keys:
                    store[key][m.name][row:] = np.nan
    return ErrorCurves(
        h=base.h * np.asarray(ks, dtype=float),
        eta_pct=float(eta_pct),
        v_pct=float(v_pct),
        methods=tuple(m.name for m in ms),
        failed=failed,
        **store,
    )


def _curve_point(
    store: dict[str, dict[str, np.ndarray]],
    row: int,
    m: Any,
    model: Any,
    clean: Trajectory,
    amp: np.ndarray,
    signal: Any,
    cache: dict[Any, Any],
    reports: Any,
    samples: int,
    eta_pct: float,
    v_pct: float,
) -> None:
    """Row ``row`` of every curve of rule ``m`` at the samples ``clean``."""
    p = path_prediction(model, m, clean, amp, signal, eta_pct, v_pct, cache=cache)
    if not (np.isfinite(p.eta) and np.isfinite(p.v)):
        raise FloatingPointError(f"the prediction is not finite at h = {clean.h:g} s")
    store["truncation"][m.name][row] = p.truncation
    store["predicted_noise"][m.name][row] = p.noise
    store["predicted"][m.name][row] = (p.eta, p.v)
    if reports is None:
        return
    jac, widened = reports
    b = assemble_bound(m, clean.h, eta_pct, v_pct, amp, jac, widened, p.truncation, samples=clean)
    store["bound_noise"][m.name][row] = (b.eta.noise, b.v.noise)
    store["bound"][m.name][row] = b.total


def rank_key(eta: float, v: float, rank_by: str) -> float:
    """The number a rule is ranked by: the larger block error ("max") or one block."""
    if rank_by == "eta":
        return eta
    if rank_by == "v":
        return v
    return max(eta, v)


def _meets(values: np.ndarray, tol: tuple[float, float], rank_by: str) -> np.ndarray:
    ok_eta = values[:, 0] <= tol[0]
    ok_v = values[:, 1] <= tol[1]
    if rank_by == "eta":
        return ok_eta
    if rank_by == "v":
        return ok_v
    return ok_eta & ok_v


def check_tolerance(tolerance: Any) -> tuple[float, float]:
    """``tolerance`` as (eta, v); one number is both.

    Raises
    ------
    ValueError
        for anything but one or two positive finite numbers.
    """
    t = np.atleast_1d(np.asarray(tolerance, dtype=float))
    if t.size == 1:
        t = np.repeat(t, 2)
    if t.shape != (2,) or not np.isfinite(t).all() or (t <= 0).any():
        raise ValueError(
            f"`tolerance` must be a positive number or a pair (eta, v), got {tolerance!r}."
        )
    return float(t[0]), float(t[1])


def largest_h(
    curves: ErrorCurves,
    method: str,
    tolerance: float | tuple[float, float],
    *,
    rank_by: str = "max",
    which: str = "predicted",
) -> float | None:
    """Largest h of the curves' grid such that the error at every grid h' <= h meets
    the tolerance (so the answer never grows when the tolerance shrinks).

    Parameters
    ----------
    curves : ErrorCurves
    method : str
    tolerance : float or (float, float)
        On the eta and v errors (one number: both).
    rank_by : {"max", "eta", "v"}
        Which blocks must meet it: both, or one.
    which : {"predicted", "bound"}

    Returns
    -------
    float (s), or None when even the smallest h fails (or no bound was computed).
    """
    tol = check_tolerance(tolerance)
    if which not in ("predicted", "bound"):
        raise ValueError(f"`which` must be 'predicted' or 'bound', got {which!r}.")
    values = (curves.predicted if which == "predicted" else curves.bound)[method]
    ok = _meets(values, tol, rank_by)
    if not ok[0]:
        return None
    first_bad = np.flatnonzero(~ok)
    last = int(first_bad[0]) - 1 if first_bad.size else ok.size - 1
    return float(curves.h[last])
