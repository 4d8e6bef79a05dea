"""Local errors of sampled-data models on a real (validated) log."""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._estimate import EstimationResult
from .._local_errors import error_norm, error_window, local_errors
from .._noise import NOISE_REFERENCE
from .._predict import predict
from ..exceptions import JacobianUnavailableError, LogFormatError
from ..methods import Estimator, get_method, get_predictor, stencil_steps
from ..methods._base import fixed_step
from ..models import Model
from ..sensitivity import fastest_time_constant
from ._read import LogData
from ._time import TIME_UNITS
from ._units import split_header

__all__ = ["MAX_H_RATE", "MIN_H_S", "LogEvaluation", "evaluate_log"]

#: Largest h / tau (tau: the model's fastest time constant on the logged states) that
#: :func:`evaluate_log` accepts. Beyond it the fastest mode decays by more than
#: e^-10 = 4.5e-5 within one sample, so the data hold nothing of it, and an explicit
#: rule's one-step map amplifies it by |1 + h lambda| >= 9 (Euler; the stability
#: intervals of the explicit rules end at h |lambda| <= 2.8). A log sampled that
#: coarsely is most likely a log whose time unit is wrong: ms read as s multiplies
#: h / tau by 1000, s read as min by 60 (the example log: h / tau = 0.43).
MAX_H_RATE = 10.0

#: Smallest sampling period (s) :func:`evaluate_log` accepts: no vehicle log records
#: its states at more than 1 MHz, so a shorter step is a time unit read wrong (seconds
#: labelled ns give h = 1e-10 s).
MIN_H_S = 1e-6


@dataclass(frozen=True)
class LogEvaluation:
    """Result of :func:`evaluate_log`.

    Attributes
    ----------
    rows : list of dict
        One per method: ``method``, ``order``, ``err_eta``, ``err_v``, ``err_all``
        (the norm over position/angle, rate and all components) and ``samples``.
    estimation : EstimationResult or None
        The parameters estimated for an ABe_s / Ee row.
    warnings : tuple of str
    notes : tuple of str
        The time base the rules predicted on (a uniform grid, or the logged stamps)
        and, on logged stamps, how each rule used the actual steps and its noise gain.
    left_out : tuple of str
        States predicted but not counted in the norms (``LogData.unmeasured``).
    """

    rows: list[dict[str, Any]]
    estimation: EstimationResult | None
    warnings: tuple[str, ...]
    notes: tuple[str, ...] = ()
    left_out: tuple[str, ...] = ()


def _mask(valid: np.ndarray, history: int) -> np.ndarray:
    """True at k if rows k - history .. k are all valid."""
    ok = valid.copy()
    for lag in range(1, history + 1):
        ok[lag:] &= valid[:-lag]
        ok[:lag] = False
    return ok


def _norms(
    err: np.ndarray, data: LogData, where: np.ndarray, norm: str, after: float | None
) -> dict[str, Any]:
    kind = np.array([NOISE_REFERENCE.get(u, ("", 0.0))[0] for u in data.traj.state_units])
    counted = np.array([n not in data.unmeasured for n in data.traj.state_names])
    t = data.traj.t
    out: dict[str, Any] = {}
    for name, idx in (
        ("err_eta", np.flatnonzero((kind == "eta") & counted)),
        ("err_v", np.flatnonzero((kind == "v") & counted)),
    ):
        out[name] = error_norm(err, t, norm, after, idx, where=where) if idx.size else float("nan")
    out["err_all"] = error_norm(err, t, norm, after, np.flatnonzero(counted), where=where)
    keep = where & ~np.isnan(err).any(axis=1)
    if after is not None:
        keep &= t >= after
    out["samples"] = int(keep.sum())
    return out


def _segment(data: LogData, a: int, b: int) -> Any:
    """Rows [a, b) of the log as a Trajectory of their own (times as logged)."""
    tr = data.traj
    return tr.replace(t=tr.t[a:b], x=tr.x[a:b], u=tr.u[a:b])


def _time_base(data: LogData, methods: Sequence[Any]) -> tuple[str, ...]:
    """Say which time base the rules predict on, and how each uses the actual steps;
    refuse a rule that cannot predict on the log's (non-uniform) stamps."""
    uniform = [fixed_step(_segment(data, a, b)) is not None for a, b in data.segments]
    h = data.traj.h
    if all(uniform):
        where = "each segment" if len(uniform) > 1 else "the log"
        return (
            f"time base: a uniform grid t = n h, h = {h:.6g} s, on {where}; every rule "
            "with its fixed coefficients",
        )
    steps = np.diff(data.traj.t)
    within = np.concatenate([steps[a : b - 1] for a, b in data.segments])
    smp = data.sampling
    why = []
    if smp is not None and not smp.uniform:
        why.append(f"jittered by up to {data.jitter:.2%} of h")
    if smp is not None and smp.gaps and len(data.segments) == 1:  # bridged, not split
        why.append(f"{len(smp.gaps)} bridged gap(s)")
    kind = f" ({', '.join(why)})" if why else ""
    notes = [
        f"time base: the logged time stamps{kind}, not snapped to a grid: steps "
        f"{within.min():.6g}..{within.max():.6g} s, nominal h = {h:.6g} s"
    ]
    by_rule: dict[str, list[str]] = {}
    for m in methods:
        if not m.variable_step:
            raise LogFormatError(
                "t",
                f"{data.source}: {m.name} predicts on a uniform grid only ({m.step_rule}), "
                f"and this log's time stamps are not uniform{kind}. Use the fixed rules on "
                "the logged stamps (E, AB<s>, RK<s>, T, ...), or split the log at its gaps "
                "(gaps='split', --gaps split) if its segments are uniform.",
            )
        by_rule.setdefault(m.step_rule, []).append(m.name)
    notes += [f"  {', '.join(names)}: {rule}" for rule, names in by_rule.items()]
    notes.append(_noise_gains(data, methods))
    return tuple(notes)


def _noise_gains(data: LogData, methods: Sequence[Any]) -> str:
    """Each rule's noise gain per unit Lipschitz constant and step on the log's
    stencils (the worst step pattern within the largest step ratio one prediction
    spans, :func:`sampledyn.methods.stencil_steps`), against its uniform-grid value:
    the factor the noise bounds (24)-(25) take on these stamps."""
    parts = []
    for m in methods:
        h_max, ratio = stencil_steps(data.traj, int(m.history))
        on_log = float(np.max(m.noise_gain(h_max, np.eye(2), ratio))) / h_max
        uniform = float(np.max(m.noise_gain(h_max, np.eye(2), 1.0))) / h_max
        parts.append(f"{m.name} {on_log:.3g} (uniform {uniform:.3g}, step ratio {ratio:.3g})")
    return "  noise gain / (h L) on the logged steps, as the noise bounds take it: " + ", ".join(
        parts
    )


def _check_length(data: LogData, methods: Sequence[Any]) -> None:
    """Refuse a rule that cannot predict a single sample of the log: one prediction
    needs ``history`` samples before the one it predicts, in one segment."""
    longest = max(b - a for a, b in data.segments)
    for m in methods:
        need = int(m.history) + 1
        if longest < need:
            split = f" (its longest segment {longest})" if len(data.segments) > 1 else ""
            raise LogFormatError(
                "data",
                f"{data.source}: the log has {data.traj.n_samples} samples{split}; {m.name} "
                f"needs at least {need} for one prediction ({need - 1} before the sample it "
                f"predicts). Give a longer log, or leave {m.name} out of the methods.",
            )


def _unit_hint(
    data: LogData, low: float, high: float, otherwise: str, no_unit: str | None = None
) -> str:
    """'is the column in ms? label it t[ms]': the time unit, other than the column's,
    that puts h in [low, high] s with the least change; ``otherwise`` where none does,
    ``no_unit`` (default ``otherwise``) where the column's unit is no time unit."""
    unit = data.time_unit
    if unit not in TIME_UNITS:
        return otherwise if no_unit is None else no_unit
    mult, div = TIME_UNITS[unit]
    raw = data.traj.h * div / mult  # the step in the column's own numbers
    fits = [
        (abs(math.log(m / d * div / mult)), name)
        for name, (m, d) in TIME_UNITS.items()
        if name not in (unit, "µs") and low <= raw * m / d <= high
    ]
    if not fits:
        return otherwise
    alt = min(fits)[1]
    name = split_header(data.time_column)[0]
    return (
        f"is the column in {alt}? label it {name}[{alt}] (or give unit = {alt!r} in the "
        "mapping file)."
    )


def _check_period(model: Model, data: LogData, limit: float) -> tuple[str, ...]:
    """Refuse a sampling period far beyond the model's fastest rate on the logged
    states (:data:`MAX_H_RATE`) or below :data:`MIN_H_S`; else a note with h / tau."""
    h = data.traj.h
    if h < MIN_H_S:
        hint = _unit_hint(data, 1e-3, 10.0, "check the time column and its unit.")
        raise LogFormatError(
            data.time_column,
            f"{data.source}: sampling period h = {h:.3g} s (time column "
            f"{data.time_column!r} read in {data.time_unit}) is below {MIN_H_S:g} s, faster "
            f"than any vehicle log is recorded; {hint}",
        )
    try:
        tau = fastest_time_constant(model, data.traj)
    except JacobianUnavailableError:
        return ("h not checked against the model's rates: the model has no Jacobian",)
    if h > limit * tau:
        raise LogFormatError(
            data.time_column,
            f"{data.source}: sampling period h = {h:.6g} s (time column "
            f"{data.time_column!r} read in {data.time_unit}) is {h / tau:.3g} times the "
            f"model's fastest time constant tau = {tau:.3g} s (1/max|eig(df/dx)| on the "
            f"logged states), beyond h/tau = {limit:g}: the samples cannot resolve the "
            f"model's fastest motion; "
            + _unit_hint(
                data,
                0.0,
                limit * tau,
                "check the time column's unit and the vehicle.",
                "check the time stamps and the vehicle.",
            ),
        )
    return (
        f"h / tau = {h / tau:.3g}, tau = {tau:.3g} s the model's fastest time constant on "
        "the logged states",
    )


def _rows_text(rows: np.ndarray) -> str:
    """1-based data rows as ranges: 'data rows 4-7, 12'."""
    rows = np.asarray(rows) + 1
    runs: list[str] = []
    start = prev = int(rows[0])
    for r in [*map(int, rows[1:]), None]:
        if r is not None and r == prev + 1:
            prev = r
            continue
        runs.append(f"{start}-{prev}" if prev > start else f"{start}")
        if r is not None:
            start = prev = r
    shown = ", ".join(runs[:6]) + (f", ... ({len(runs) - 6} more ranges)" if len(runs) > 6 else "")
    return f"data row{'s' if rows.size > 1 else ''} {shown}"


def _limits(model: Model, data: LogData) -> tuple[np.ndarray, np.ndarray] | None:
    """The model's input limits: ``input_limits()`` where it has one, else +-n_max on
    its rpm inputs; None if it has neither."""
    if hasattr(model, "input_limits"):
        lo, hi = (np.asarray(a, dtype=float) for a in model.input_limits())
        return lo, hi
    n_max = getattr(model, "n_max", None)
    rpm = np.array([unit == "rpm" for unit in data.traj.input_units])
    if n_max is None or not rpm.any():
        return None
    hi = np.where(rpm, float(n_max), np.inf)
    return -hi, hi


def _warn_inputs_beyond_limits(model: Model, data: LogData) -> None:
    """Warn, naming the rows, where logged inputs leave the model's limits, e.g.
    thruster rpm beyond the vehicle's n_max (issue 13 item 6): the model saturates or
    extrapolates there, and a unit mistake shows up here first."""
    limits = _limits(model, data)
    if limits is None:
        return
    lo, hi = limits
    u = data.traj.u
    excess = np.maximum(u - hi, lo - u)  # > 0 beyond a limit
    bad = np.flatnonzero((excess > 0).any(axis=1))
    if bad.size == 0:
        return
    rows = data.rows[bad] if data.rows is not None else bad
    i, j = np.unravel_index(int(np.argmax(excess[bad])), (bad.size, u.shape[1]))
    n, unit = bad[i], data.traj.input_units[j]
    name = data.traj.input_names[j]
    is_n_max = getattr(model, "n_max", None) == hi[j] == -lo[j]
    warnings.warn(
        f"{data.source}: logged inputs beyond the model's limits in {bad.size} of "
        f"{data.traj.n_samples} samples ({_rows_text(rows)}); largest: {name} = "
        f"{u[n, j]:g} {unit}, limits [{lo[j]:g}, {hi[j]:g}] {unit}"
        + (" (the vehicle's n_max)" if is_n_max else "")
        + ". The model saturates or extrapolates there: check the log's units and the "
        "vehicle's thruster data.",
        stacklevel=3,
    )


def evaluate_log(
    model: Model,
    data: LogData,
    methods: Sequence[str],
    *,
    norm: str = "rms",
    after: float | None = None,
    max_h_rate: float = MAX_H_RATE,
) -> LogEvaluation:
    """Disturbed local errors (section 5.1) of each method on the log.

    Parameters
    ----------
    model : Model
    data : LogData
        From :func:`read_log`. A log split at dropped records (``gaps="split"``) is
        predicted segment by segment; the norms run over all segments together.
    methods : sequence of str
        Registry names ("E", "AB2", "RK4", "T", ...). Runge-Kutta stages use the
        logged input held over each interval (zero-order hold). An estimated rule
        ("Ee", "ABe<s>") first estimates the model's parameters on the log (l_2 norm
        of the AB_s one-step errors on t >= after), then predicts with them.
    norm : str
        See :func:`sampledyn.error_norm`.
    after : float, optional
        Count the errors on t >= after (s, log time) only; finite.
    max_h_rate : float
        Largest accepted h / tau, tau the model's fastest time constant
        (:func:`sampledyn.sensitivity.fastest_time_constant`) on the logged states
        (default :data:`MAX_H_RATE`; ``math.inf`` turns the check off).

    Returns
    -------
    LogEvaluation

    Raises
    ------
    LogFormatError
        for a rule that predicts on a uniform grid only (the estimated rules) on a log
        whose stamps are not uniform; for an estimated rule on a split log; for a log
        too short for a rule to predict one sample; for h > ``max_h_rate`` tau (most
        likely a wrong time unit: the message names the time column, its unit as read
        and the unit that would fit).
    ValueError
        for a non-finite ``after``.

    Notes
    -----
    The rules predict on the time stamps as logged: on a jittered log or across a
    bridged gap each uses the actual steps (``variable_step`` rules: Adams weights of
    the actual nodes, a step h_n per interval for RK_s and T); on a uniform grid
    their fixed coefficients. Which one is in ``LogEvaluation.notes``. The norms
    weight the samples by their steps on non-uniform time (:mod:`sampledyn._local_errors`).
    """
    if not methods:
        raise ValueError("`methods` must name at least one method, e.g. ['E', 'AB2'].")
    error_window(data.traj.t, after)  # checks `after` before any work
    rules = [get_predictor(name, "methods") for name in methods]
    _check_length(data, rules)
    notes = _time_base(data, rules)
    segments = data.segments
    if len(segments) > 1 and any(isinstance(get_method(name), Estimator) for name in methods):
        raise LogFormatError(
            "estimate",
            f"{data.source}: estimation on a log split into {len(segments)} segments is not "
            "supported; estimate on a log without gaps (or one segment of it).",
        )
    rows: list[dict[str, Any]] = []
    estimation = None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for message in data.warnings:
            warnings.warn(message, UserWarning, stacklevel=2)
        _warn_inputs_beyond_limits(model, data)
        notes += _check_period(model, data, max_h_rate)
        for name in methods:
            method: Any = get_method(name)
            if isinstance(method, Estimator):
                x_hat, estimation = method.estimate_and_predict(model, data.traj, after=after)
            else:
                x_hat = np.full(data.traj.x.shape, np.nan)
                for a, b in segments:
                    if b - a >= 2:
                        x_hat[a:b] = predict(method, model, _segment(data, a, b))
            err = local_errors(x_hat, data.traj)
            row = {"method": name, "order": int(method.order)}
            row.update(_norms(err, data, _mask(data.valid, method.history), norm, after))
            rows.append(row)
    msgs = tuple(dict.fromkeys(str(w.message) for w in caught))
    if data.unmeasured:
        notes += (f"left out of the norms (not measured by the log): {', '.join(data.unmeasured)}",)
    return LogEvaluation(rows, estimation, msgs, notes, tuple(data.unmeasured))
