"""Local errors of sampled-data models on a real (validated) log."""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, cast

import numpy as np

from .._baselines import BASELINES
from .._estimate import EstimationResult
from .._local_errors import error_norm, error_window, local_errors
from .._noise import NOISE_ORDER, NOISE_REFERENCE, NoiseEstimate, estimate_noise
from .._predict import HELD_INPUT_TEXT, predict
from ..exceptions import (
    JacobianUnavailableError,
    LogFormatError,
    NumericalError,
    SingularPitchError,
)
from ..methods import Estimator, NoiseAnalysis, get_method, get_predictor, stencil_steps
from ..methods._base import fixed_step
from ..models import Model
from ..sensitivity import fastest_time_constant, noise_floor_squares, stability_limits
from ..sensitivity._floor import FLOOR_FACTOR
from ..sensitivity._stability import StabilityLimit, jacobian_eigenvalues
from ._read import LogData
from ._time import TIME_UNITS
from ._units import split_header

__all__ = [
    "MAX_H_RATE",
    "MIN_H_RATE",
    "MIN_H_S",
    "ROW_KEYS",
    "LogEvaluation",
    "estimate_log_noise",
    "evaluate_log",
]

#: Largest h / tau (tau: the model's fastest time constant on the logged states) that
#: :func:`evaluate_log` accepts. Beyond it the fastest mode decays by more than
#: e^-10 = 4.5e-5 within one sample, so the data hold nothing of it, and an explicit
#: rule's one-step map amplifies it by |1 + h lambda| >= 9 (Euler; the stability
#: intervals of the explicit rules end at h |lambda| <= 2.8). A log sampled that
#: coarsely is most likely a log whose time unit is wrong: ms read as s multiplies
#: h / tau by 1000, s read as min by 60 (the example log: h / tau = 0.43).
MAX_H_RATE = 10.0

#: Smallest h / tau at which :func:`evaluate_log` does not warn. A consistent rule's
#: prediction differs from the hold (x_n+1 = x_n) by h f = about h / tau of the motion
#: within one time constant, and two rules of order >= 1 differ from each other by
#: about (h / tau)^2 / 2 of it: below h / tau = 1e-3 that is under 5e-7, beneath any
#: sensor's resolution, so the table cannot tell the rules apart. Real vehicle logs
#: (10..1000 Hz, tau >= 0.1 s) lie above it; a log in s labelled ms lies 1000 times
#: below its true h / tau (the example log: 0.43 -> 4.3e-4).
MIN_H_RATE = 1e-3

#: Smallest sampling period (s) :func:`evaluate_log` accepts: no vehicle log records
#: its states at more than 1 MHz, so a shorter step is a time unit read wrong (seconds
#: labelled ns give h = 1e-10 s).
MIN_H_S = 1e-6


#: The columns of every row of :attr:`LogEvaluation.rows` (and of ``--out``).
ROW_KEYS = (
    "method", "kind", "order", "err_eta", "err_v", "err_all", "samples",
    "floor_eta", "floor_v", "floor_all", "at_floor_eta", "at_floor_v", "at_floor_all",
    "h_stable", "stable", "failed",
)  # fmt: skip


@dataclass(frozen=True)
class LogEvaluation:
    """Result of :func:`evaluate_log`.

    Attributes
    ----------
    rows : list of dict
        One per baseline (``hold``, ``kinematics``, first) and per method, keys
        :data:`ROW_KEYS`: ``method``, ``kind`` ("baseline", "rule" or "estimated"),
        ``order`` (0 for a baseline), ``err_eta``, ``err_v``, ``err_all`` (the norm
        over position/angle, rate and all components), ``samples``; ``floor_eta``,
        ``floor_v``, ``floor_all``: the rms that the estimated noise alone gives
        through the rule (:func:`sampledyn.sensitivity.noise_floor_squares`), and
        ``at_floor_*``: the error is within :data:`FLOOR_FACTOR` of it (None unless
        ``norm="rms"``); ``h_stable``: the rule's largest stable step along the log
        (s; None for a baseline or without a Jacobian), ``stable``: the log's largest
        step is within it; ``failed``: None, or why the rule predicted nothing (its
        numbers are then NaN).
    estimations : tuple of EstimationResult
        The parameters estimated by each ABe_s / Ee row that succeeded, in row order.
    warnings : tuple of str
    notes : tuple of str
        The time base the rules predicted on (a uniform grid, or the logged stamps)
        and, on logged stamps, how each rule used the actual steps and its noise gain;
        the input between samples.
    left_out : tuple of str
        States predicted but not counted in the norms (``LogData.unmeasured``).
    noise : NoiseEstimate or None
        The measurement-noise levels estimated from the log
        (:func:`sampledyn.estimate_noise`).
    stability : tuple of StabilityLimit
        Each rule's largest stable step along the log (empty without a Jacobian).
    norm : str
        The norm of the errors.
    """

    rows: list[dict[str, Any]]
    estimations: tuple[EstimationResult, ...] = ()
    warnings: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    left_out: tuple[str, ...] = ()
    noise: NoiseEstimate | None = None
    stability: tuple[StabilityLimit, ...] = ()
    norm: str = "rms"

    @property
    def estimation(self) -> EstimationResult | None:
        """The first estimate (None without an estimated rule)."""
        return self.estimations[0] if self.estimations else None

    @property
    def failed(self) -> tuple[str, ...]:
        """The rows that failed, by method name."""
        return tuple(r["method"] for r in self.rows if r["failed"])

    def row(self, method: str) -> dict[str, Any]:
        """The row of ``method`` (a rule or a baseline).

        Raises
        ------
        KeyError
            naming the rows there are.
        """
        for r in self.rows:
            if r["method"] == method:
                return r
        raise KeyError(f"no row {method!r}; the rows are {[r['method'] for r in self.rows]}.")

    def table(self) -> str:
        """The error table as plain text (docs/logs.md explains how to read it)."""
        return _table(self)


def _cell(value: float, mark: bool | None) -> str:
    return f"{value:12.4e}{'*' if mark else ' '}"


def _table_row(r: dict[str, Any]) -> str:
    head = f"{r['method']:10s} {r['order']:5d}"
    if r["failed"]:
        return f"{head}  failed: {r['failed']}"
    nums = "".join(_cell(r[f"err_{b}"], r[f"at_floor_{b}"]) for b in ("eta", "v", "all"))
    floor = "".join(f"{r[f'floor_{b}']:11.3e}" for b in ("eta", "v"))
    stable = "-" if r["h_stable"] is None else f"{r['h_stable']:.3g}"
    flag = " !" if r["stable"] is False else "  "
    return f"{head} {nums} {r['samples']:8d} |{floor} | {stable:>9s}{flag}"


def _unresolved(noise: NoiseEstimate) -> list[str]:
    return [
        n
        for n, s, ok in zip(noise.state_names, noise.sigma, noise.resolved, strict=True)
        if np.isfinite(s) and not ok
    ]


def _table(ev: LogEvaluation) -> str:
    head = (
        f"{'method':10s} {'order':>5s} {'position/angle':>13s} {'velocity':>12s} "
        f"{'all':>12s}  {'samples':>8s} | {'floor eta':>9s} {'floor v':>10s} | "
        f"{'stable h':>9s}"
    )
    lines = [head, "-" * len(head)]
    kind = None
    for r in ev.rows:
        if kind == "baseline" and r["kind"] != "baseline":
            lines.append("")
        kind = r["kind"]
        lines.append(_table_row(r))
    lines += _legend(ev)
    return "\n".join(lines)


def _legend(ev: LogEvaluation) -> list[str]:
    out = [
        "hold: x_n+1 = x_n; kinematics: positions and angles advanced with the logged rates "
        "(eq. (6)), rates held: a rule that does not beat them predicts nothing",
    ]
    if ev.noise is not None:
        out.append(
            f"noise (std, from {ev.noise.order}th differences of the logged states): "
            + ev.noise.describe()
        )
    if ev.norm == "rms":
        out.append(
            f"floor: the rms the estimated noise alone gives through the rule; * within "
            f"{FLOOR_FACTOR:g}x of it: that block measures the sensor, not the model"
        )
        vague = [] if ev.noise is None else _unresolved(ev.noise)
        if vague and ev.noise is not None:
            out.append(
                f"noise not resolved for {', '.join(vague)} (the motion is not smooth over "
                f"{ev.noise.order + 1} samples, so the differences hold it too): their floor "
                "is an upper bound, and their blocks get no * mark"
            )
    else:
        out.append(f"floor: rms of the noise alone (no * mark: the table's norm is {ev.norm})")
    if ev.stability and any(r["stable"] is False and not r["failed"] for r in ev.rows):
        h = ev.stability[0].h  # the legend of the "!" marks, printed where a row has one
        out.append(
            f"stable h: the rule's largest stable step (s) along the log (|R(h lambda)| <= 1 "
            f"for the eigenvalues of df/dx at every sample); ! the log's step {h:.4g} s "
            "is beyond it (see the warning)"
        )
    return out


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
        if not isinstance(m, NoiseAnalysis):  # an estimated rule: no fixed noise gain
            continue
        m = cast(Any, m)
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


def _check_period(
    model: Model, data: LogData, limit: float, eig: np.ndarray | None
) -> tuple[str, ...]:
    """Refuse a sampling period far beyond the model's fastest rate on the logged
    states (:data:`MAX_H_RATE`) or below :data:`MIN_H_S`; else a note with h / tau.
    ``eig``: the Jacobian's eigenvalues at the samples (None: no Jacobian)."""
    h = data.traj.h
    if h < MIN_H_S:
        hint = _unit_hint(data, 1e-3, 10.0, "check the time column and its unit.")
        raise LogFormatError(
            data.time_column,
            f"{data.source}: sampling period h = {h:.3g} s (time column "
            f"{data.time_column!r} read in {data.time_unit}) is below {MIN_H_S:g} s, faster "
            f"than any vehicle log is recorded; {hint}",
        )
    if eig is None:
        return ("h not checked against the model's rates: the model has no Jacobian",)
    tau = fastest_time_constant(model, data.traj, eig)
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
    if h < MIN_H_RATE * tau:
        warnings.warn(
            f"{data.source}: sampling period h = {h:.6g} s (time column "
            f"{data.time_column!r} read in {data.time_unit}) is only {h / tau:.3g} times the "
            f"model's fastest time constant tau = {tau:.3g} s, below h/tau = {MIN_H_RATE:g}: "
            "the rules differ from each other by about (h/tau)^2/2 of the motion within "
            "tau, beneath any sensor's resolution, so the table cannot tell them from one "
            "another or from the hold; "
            + _unit_hint(
                data,
                MIN_H_RATE * tau,
                limit * tau,
                "check the time column's unit.",
                "check the time stamps.",
            ),
            UserWarning,
            stacklevel=2,
        )
    return (
        f"h / tau = {h / tau:.3g}, tau = {tau:.3g} s the model's fastest time constant on "
        "the logged states",
    )


# A position or angle whose increments are this far from what the rates give
# (eta' = the model's f on the logged states; J(eta) nu for a vehicle) is reported.
# A unit mix-up shows as a factor of 57.3 (deg vs rad) or 3.28 (ft vs m); noise and
# the rates' lag on a real log keep the fit within a few tens of percent.
KINEMATIC_FACTOR = 2.0
_DEG = 180.0 / math.pi


def _kinematic_hint(ratio: float, unit: str) -> str:
    near = abs(math.log(ratio))
    if unit == "rad" and abs(near - math.log(_DEG)) < math.log(1.5):
        return (
            "is the angle column in rad under a [deg] header, or the rate columns in deg/s "
            "under [rad/s]?" if ratio < 1 else
            "is the angle column in deg under a [rad] header, or the rate columns in rad/s "
            "under [deg/s]?"
        )  # fmt: skip
    return "check the units of this column and of the rate columns."


def _check_kinematics(model: Any, data: LogData) -> None:
    """Warn where a logged position or angle changes at a rate far from what the
    logged rates give (the model's f, the kinematics eta' = J(eta) nu of a vehicle),
    fitted over the log: radians under a [deg] header make every error about ten times
    larger without any other sign."""
    tr = data.traj
    eta = [k for k, u in enumerate(tr.state_units) if NOISE_REFERENCE.get(u, ("",))[0] == "eta"]
    if not eta or tr.n_samples < 5:
        return
    step = max(1, tr.n_samples // 20_000)  # enough samples for a fit, bounded work
    idx = np.arange(1, tr.n_samples - 1, step)
    idx = idx[data.valid[idx - 1] & data.valid[idx] & data.valid[idx + 1]]
    if idx.size < 3:
        return
    with np.errstate(all="ignore"):
        f = np.asarray(model.f(tr.t[idx], tr.x[idx], tr.u[idx]), dtype=float)
        dt = tr.t[idx + 1] - tr.t[idx - 1]
        rate = (tr.x[idx + 1] - tr.x[idx - 1]) / dt[:, None]
    for k in eta:
        a, b = rate[:, k], f[:, k]
        ok = np.isfinite(a) & np.isfinite(b)
        if ok.sum() < 3 or not np.any(b[ok]):
            continue
        a, b = a[ok], b[ok]
        ratio = float(a @ b / (b @ b))
        corr = float(np.corrcoef(a, b)[0, 1]) if a.std() > 0 and b.std() > 0 else 0.0
        if corr > 0.8 and not 1 / KINEMATIC_FACTOR <= ratio <= KINEMATIC_FACTOR:
            name, unit = tr.state_names[k], tr.state_units[k]
            warnings.warn(
                f"{data.source}: {name} changes {ratio:.3g} times as fast as the logged rates "
                f"say it should (least-squares fit of its increments against the model's "
                f"{name}' on the logged states, correlation {corr:.2f}); "
                + _kinematic_hint(ratio, unit)
                + " The errors are meaningless until the units agree.",
                UserWarning,
                stacklevel=3,
            )


def _eigenvalues(model: Any, data: LogData) -> np.ndarray | None:
    """The Jacobian's eigenvalues at the valid samples, or None without a Jacobian."""
    try:
        return jacobian_eigenvalues(model, _rows(data, np.flatnonzero(data.valid)))
    except JacobianUnavailableError:
        return None


def _rows(data: LogData, idx: np.ndarray) -> Any:
    tr = data.traj
    return tr.replace(t=tr.t[idx], x=tr.x[idx], u=tr.u[idx])


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


# The failures a rule's row reports (the other rows print): Newton not converging, a
# state at the singular pitch formed by the rule, non-finite arithmetic.
_FAILURES = (NumericalError, SingularPitchError, FloatingPointError)


def _with_newton(method: Any, newton: Mapping[str, Any] | None) -> Any:
    """``method`` with the Newton options of an implicit rule (those it takes)."""
    if not newton or not hasattr(method, "with_newton"):
        return method
    return method.with_newton(**newton)


def _predict_log(method: Any, model: Any, data: LogData) -> np.ndarray:
    """The rule's predictions segment by segment; NaN rows where it has none."""
    x_hat = np.full(data.traj.x.shape, np.nan)
    for a, b in data.segments:
        if b - a >= 2:
            x_hat[a:b] = predict(method, model, _segment(data, a, b))
    return x_hat


def _floor_errors(method: Any, model: Any, data: LogData, sigma: np.ndarray) -> np.ndarray:
    """Per sample and state, the rms one-step error of the noise alone (a pseudo error
    whose norms are the noise floor's, :func:`noise_floor_squares`); NaN rows where
    the rule predicts nothing."""
    out = np.full(data.traj.x.shape, np.nan)
    for a, b in data.segments:
        if b - a >= 2:
            out[a:b] = np.sqrt(noise_floor_squares(method, model, _segment(data, a, b), sigma))
    return out


@dataclass
class _Run:
    """What every row of :func:`evaluate_log` shares."""

    model: Any
    data: LogData
    norm: str
    after: float | None
    noise: NoiseEstimate | None
    limits: dict[str, StabilityLimit]
    estimations: list[EstimationResult]

    def norms(self, err: np.ndarray, history: int) -> dict[str, Any]:
        return _norms(err, self.data, _mask(self.data.valid, history), self.norm, self.after)

    def floors(self, method: Any, model: Any, history: int) -> dict[str, Any]:
        """floor_* and at_floor_* (NaN / None where no floor can be had)."""
        keys = ("eta", "v", "all")
        out: dict[str, Any] = {f"floor_{b}": math.nan for b in keys}
        out.update({f"at_floor_{b}": None for b in keys})
        if self.noise is None or not hasattr(method, "prediction_jacobians"):
            return out
        try:
            pseudo = _floor_errors(method, model, self.data, self.noise.sigma)
        except JacobianUnavailableError:
            return out
        mask = _mask(self.data.valid, history)
        got = _norms(pseudo, self.data, mask, "rms", self.after)
        for b in keys:
            out[f"floor_{b}"] = got[f"err_{b}"]
        return out

    def row(self, name: str, method: Any, kind: str) -> dict[str, Any]:
        row: dict[str, Any] = {"method": name, "kind": kind, "order": int(method.order)}
        limit = self.limits.get(name)
        row["h_stable"] = None if limit is None else limit.h_stable
        row["stable"] = None if limit is None else limit.stable
        try:
            row.update(self._numbers(method, kind))
            row["failed"] = None
        except _FAILURES as exc:
            row.update(_failed_numbers(type(exc).__name__, str(exc)))
        except ValueError as exc:
            if kind != "estimated":  # a fit that cannot be had; anything else is a mistake
                raise
            row.update(_failed_numbers(type(exc).__name__, str(exc)))
        return {k: row[k] for k in ROW_KEYS}

    def _numbers(self, method: Any, kind: str) -> dict[str, Any]:
        model, structure = self.model, method
        if kind == "estimated":
            x_hat, est = method.estimate_and_predict(self.model, self.data.traj, after=self.after)
            self.estimations.append(est)
            model, structure = est.model, get_method(est.structure)
        else:
            x_hat = _predict_log(method, self.model, self.data)
        err = local_errors(x_hat, self.data.traj)
        bad = np.isnan(err).any(axis=1) & _expected(self.data, method.history)
        if bad.any():
            n = int(np.flatnonzero(bad)[0])
            raise FloatingPointError(
                f"the prediction is not finite at {int(bad.sum())} samples (first: sample {n}, "
                f"t = {self.data.traj.t[n]:g} s)"
            )
        out = self.norms(err, method.history)
        out.update(self.floors(structure, model, method.history))
        if self.norm == "rms":
            for b in ("eta", "v", "all"):
                f = out[f"floor_{b}"]
                if math.isfinite(f) and self.resolved(b):
                    out[f"at_floor_{b}"] = bool(out[f"err_{b}"] <= FLOOR_FACTOR * f)
        return out

    def resolved(self, block: str) -> bool:
        """True if the noise of every counted state of ``block`` is resolved
        (:attr:`NoiseEstimate.resolved`): only then does a floor mark mean anything."""
        if self.noise is None:
            return False
        states = _block_states(self.data)[block]
        return bool(self.noise.resolved[states].all()) if states.size else False


def _expected(data: LogData, history: int) -> np.ndarray:
    """The rows a rule with ``history`` must predict: valid, with ``history`` valid rows
    before them in their segment."""
    inside = np.zeros(data.traj.n_samples, dtype=bool)
    for a, b in data.segments:
        inside[a + history : b] = True
    return inside & _mask(data.valid, history)


def _block_states(data: LogData) -> dict[str, np.ndarray]:
    """The counted states of each block ("eta", "v", "all"), as indices."""
    kind = np.array([NOISE_REFERENCE.get(u, ("", 0.0))[0] for u in data.traj.state_units])
    counted = np.array([n not in data.unmeasured for n in data.traj.state_names])
    return {
        "eta": np.flatnonzero((kind == "eta") & counted),
        "v": np.flatnonzero((kind == "v") & counted),
        "all": np.flatnonzero(counted),
    }


def _failed_numbers(kind: str, text: str) -> dict[str, Any]:
    nan = math.nan
    out: dict[str, Any] = {f"{k}_{b}": nan for k in ("err", "floor") for b in ("eta", "v", "all")}
    out.update({f"at_floor_{b}": None for b in ("eta", "v", "all")})
    out.update(samples=0, failed=f"{kind}: {' '.join(text.split())}")
    return out


def _stability(
    model: Any, data: LogData, rules: Sequence[Any], eig: np.ndarray | None
) -> tuple[StabilityLimit, ...]:
    """Each rule's largest stable step along the log; a warning for each rule the log's
    largest step is beyond."""
    if eig is None:
        return ()
    steps = np.concatenate([np.diff(data.traj.t[a:b]) for a, b in data.segments])
    h = float(steps.max()) if steps.size else float(data.traj.h)
    valid = _rows(data, np.flatnonzero(data.valid))
    limits = stability_limits(model, rules, valid, h=h, eigenvalues=eig)
    for lim in limits:
        if not lim.stable:
            warnings.warn(f"{data.source}: {lim.message(valid.t)}", UserWarning, stacklevel=3)
    return limits


def estimate_log_noise(data: LogData, order: int = NOISE_ORDER) -> NoiseEstimate:
    """The measurement-noise levels of a log's states (:func:`sampledyn.
    estimate_noise`), as :func:`evaluate_log` estimates them: on the valid rows, each
    segment on its own, the states the log does not measure left out (NaN)."""
    counted = [i for i, n in enumerate(data.traj.state_names) if n not in data.unmeasured]
    return estimate_noise(data.traj, order, rows=data.valid, states=counted, segments=data.segments)


def _input_note(rules: Sequence[Any]) -> tuple[str, ...]:
    between = [m.name for m in rules if m.intersample]
    if not between:
        return ()
    return (
        f"input between samples: {', '.join(between)} evaluate f inside each interval; a "
        "log does not say what the input did there, so they hold the logged sample "
        "(zero-order hold)",
    )


def evaluate_log(
    model: Model,
    data: LogData,
    methods: Sequence[str],
    *,
    norm: str = "rms",
    after: float | None = None,
    max_h_rate: float = MAX_H_RATE,
    baselines: bool = True,
    newton: Mapping[str, Any] | None = None,
    noise_order: int = NOISE_ORDER,
) -> LogEvaluation:
    """Disturbed local errors (section 5.1) of each method on the log, beside the
    baselines, the noise floor and each rule's stability limit.

    Parameters
    ----------
    model : Model
    data : LogData
        From :func:`read_log`. A log split at dropped records (``gaps="split"``) is
        predicted segment by segment; the norms run over all segments together.
    methods : sequence of str
        Registry names ("E", "AB2", "RK4", "T", ...). Runge-Kutta stages and Tustin's
        end point use the logged input held over each interval (zero-order hold; a
        note says so). An estimated rule ("Ee", "ABe<s>") first estimates the model's
        parameters on the log (l_2 norm of the AB_s one-step errors on t >= after, on
        the logged stamps), then predicts with them.
    norm : str
        See :func:`sampledyn.error_norm`. The floor marks need "rms".
    after : float, optional
        Count the errors on t >= after (s, log time) only; finite.
    max_h_rate : float
        Largest accepted h / tau, tau the model's fastest time constant
        (:func:`sampledyn.sensitivity.fastest_time_constant`) on the logged states
        (default :data:`MAX_H_RATE`; ``math.inf`` turns the check off).
    baselines : bool
        Add the rows ``hold`` and ``kinematics`` (:mod:`sampledyn._baselines`) first.
    newton : mapping, optional
        Options of the implicit rules' Newton iteration, ``{"tol": ..., "max_iter":
        ...}`` (Tustin's; see :class:`sampledyn.methods.Tustin`).
    noise_order : int
        Order of the differences the noise levels are estimated from
        (:func:`sampledyn.estimate_noise`).

    Returns
    -------
    LogEvaluation

    Raises
    ------
    LogFormatError
        for an estimated rule on a split log; for a log too short for a rule to
        predict one sample; for h > ``max_h_rate`` tau (most likely a wrong time unit:
        the message names the time column, its unit as read and the unit that would
        fit).
    ValueError
        for a non-finite ``after``.

    Notes
    -----
    **Failures are rows.** A rule whose prediction fails (Newton not converging, a
    state it forms at the singular pitch, a non-finite prediction) or an estimate
    that cannot be had gets a row with ``failed`` set to the reason; the other rows
    are computed.

    **Baselines, floor, stability** (docs/logs.md, "Reading the table"): the noise
    levels are estimated from the log's own high-order differences; each rule's noise
    floor is what that noise gives through the rule's prediction Jacobians; a rule
    whose largest stable step along the log is below the log's largest step is warned
    about (naming the rule, the step, the eigenvalue and the largest stable step).

    The rules predict on the time stamps as logged: on a jittered log or across a
    bridged gap each uses the actual steps (``variable_step`` rules: Adams weights of
    the actual nodes, a step h_n per interval for RK_s and T); on a uniform grid
    their fixed coefficients. Which one is in ``LogEvaluation.notes``. The norms
    weight the samples by their steps on non-uniform time (:mod:`sampledyn._local_errors`).
    """
    if not methods:
        raise ValueError("`methods` must name at least one method, e.g. ['E', 'AB2'].")
    error_window(data.traj.t, after)  # checks `after` before any work
    rules = [_with_newton(get_predictor(name, "methods"), newton) for name in methods]
    _check_length(data, rules)
    notes = _time_base(data, rules)
    if len(data.segments) > 1 and any(isinstance(m, Estimator) for m in rules):
        raise LogFormatError(
            "estimate",
            f"{data.source}: estimation on a log split into {len(data.segments)} segments "
            "is not supported; estimate on a log without gaps (or one segment of it).",
        )
    table: list[tuple[str, Any, str]] = [(n, b, "baseline") for n, b in BASELINES.items()]
    table = table if baselines else []
    table += [
        (name, m, "estimated" if isinstance(m, Estimator) else "rule")
        for name, m in zip(methods, rules, strict=True)
    ]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        # the held input is said once, as a note (below), not per rule and segment
        warnings.filterwarnings("ignore", message=".*" + re.escape(HELD_INPUT_TEXT[:40]))
        for message in data.warnings:
            warnings.warn(message, UserWarning, stacklevel=2)
        _warn_inputs_beyond_limits(model, data)
        eig = _eigenvalues(model, data)
        notes += _check_period(model, data, max_h_rate, eig)
        _check_kinematics(model, data)
        limits = _stability(model, data, rules, eig)
        run = _Run(model, data, norm, after, estimate_log_noise(data, noise_order), {}, [])
        run.limits = {lim.method: lim for lim in limits}
        rows = [run.row(name, m, kind) for name, m, kind in table]
    msgs = tuple(dict.fromkeys(str(w.message) for w in caught))
    notes += _input_note(rules)
    if data.unmeasured:
        notes += (f"left out of the norms (not measured by the log): {', '.join(data.unmeasured)}",)
    return LogEvaluation(
        rows, tuple(run.estimations), msgs, notes, tuple(data.unmeasured), run.noise, limits, norm
    )
