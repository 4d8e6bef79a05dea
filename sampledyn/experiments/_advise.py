"""Which sampled-data model to use: rank the rules for a model, h and noise level.

For each rule the advice gives

* the **predicted** largest disturbed local errors (first order in the noise, along a
  reference run: :func:`sampledyn.sensitivity.path_prediction`), by which the rules
  are ranked;
* the **guaranteed** bound (24)-(25) over the domain of that run
  (:func:`sampledyn.sensitivity.disturbed_error_bound`), never below the measured
  errors but loose for Runge-Kutta and Tustin once h L >~ 1 (6-DoF vehicles only:
  the Jacobian maxima (19)-(23) are derived for eqs. (5)-(7));
* the **measured** largest (and rms) errors on noisy copies of the run, when
  ``validate``: a Monte Carlo study on the engine;
* the largest h whose prediction (and whose bound) stays under a tolerance.

Any model whose states split into positions/angles (units m, rad) and rates (m/s,
rad/s) can be advised (:func:`sampledyn.sensitivity.state_blocks`); a closed loop is
predicted as the engine predicts it (:func:`sampledyn.experiments.sweep.
prediction_inputs`).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

from .. import _checks as checks
from .._noise import noise_amplitudes
from .._trajectory import Trajectory
from ..models import ClosedLoop, Model, Vehicle
from ..sensitivity import (
    Domain,
    error_curves,
    first_order_gain,
    gentle_input,
    largest_h,
    state_blocks,
)
from ..sensitivity._bound import domain_maxima, exact_reference, period_ratio
from ..sensitivity._curves import (
    RANK_BY,
    ErrorCurves,
    check_tolerance,
    h_grid,
    rank_key,
    samples_needed,
    usable_periods,
)
from ..sensitivity._domain import check_vehicle
from ..sensitivity._gains import supported_method
from ..sensitivity._jacobians import JacobianReport
from ._bounds import measure_noisy, pooled
from .sweep import exact_samples

__all__ = ["DEFAULT_METHODS", "TIE", "Advice", "AdviceRow", "advise", "default_input"]

DEFAULT_METHODS = ("E", "AB2", "AB3", "AB4", "AB5", "AB6", "RK2", "RK3", "RK4", "T")
TIE = 0.10  # relative margin within which predicted errors count as equal
NO_BOUND = (
    "no guaranteed bound for this model: the Jacobian maxima (19)-(23) behind (24)-(25) "
    "are derived for the 6-DoF vehicle of eqs. (5)-(7) in open loop"
)


@dataclass(frozen=True)
class AdviceRow:
    """One rule in the advice. Errors are maxima over samples of per-sample Euclidean
    norms: eta in (m, rad) mixed, v in (m/s, rad/s) mixed.

    Attributes
    ----------
    method : str
    order : int
    first_order_gain : float
        a_s for AB_s, 1 for RK_s and T (noise gain ``~ c h L``).
    predicted_eta, predicted_v : float
        First-order path prediction.
    bound_eta, bound_v : float
        Guaranteed bound (24)-(25) over the domain.
    truncation_eta, truncation_v : float
        Undisturbed local error (noise-free part).
    measured_eta, measured_v, measured_rms_eta, measured_rms_v : float
        Monte Carlo maxima and rms (NaN without validation).
    h_max, h_max_guaranteed : float or None
        Largest h (s) of the search grid whose prediction / bound meets the tolerance
        (None: no tolerance given, or not even the smallest h meets it).
    rank : int
        1 = smallest predicted error.
    near_best : bool
        Predicted error within ``TIE`` (10 %) of the best: as good, for practical purposes
        (the prediction is a first-order worst case, not an exact value).
    measured_rank : int or None
        Rank by the measured maxima.
    """

    method: str
    order: int
    first_order_gain: float
    predicted_eta: float
    predicted_v: float
    bound_eta: float
    bound_v: float
    truncation_eta: float
    truncation_v: float
    measured_eta: float
    measured_v: float
    measured_rms_eta: float
    measured_rms_v: float
    h_max: float | None
    h_max_guaranteed: float | None
    rank: int
    measured_rank: int | None
    near_best: bool = False


@dataclass(frozen=True)
class Advice:
    """Ranked rules for one vehicle, sampling period and noise level.

    Attributes
    ----------
    vehicle : str
    h, eta_pct, v_pct : float
    tolerance : tuple of float or None
        (eta, v) tolerance used for ``h_max``.
    rank_by : {"max", "eta", "v"}
    rows : tuple of AdviceRow
        Sorted by predicted error (best first).
    domain : Domain or None
        Box of the reference run (the Jacobian maxima's domain); None without a bound.
    jacobians : JacobianReport or None
        None without a bound.
    curves : ErrorCurves
        Truncation / noise against h for every rule (for :func:`plot_crossing`).
    rank_agreement : float or None
        Kendall tau between the predicted and the measured orders (1 = same order).
    seeds : int
        Monte Carlo repetitions (0 without validation).
    notes : tuple of str
        What the table leaves out and why (e.g. no bound for a model that is not a
        6-DoF vehicle).
    """

    vehicle: str
    h: float
    eta_pct: float
    v_pct: float
    tolerance: tuple[float, float] | None
    rank_by: str
    rows: tuple[AdviceRow, ...]
    domain: Domain | None
    jacobians: JacobianReport | None
    curves: ErrorCurves
    rank_agreement: float | None
    seeds: int
    notes: tuple[str, ...] = field(default=())

    @property
    def best(self) -> str:
        """The rule with the smallest predicted error."""
        return self.rows[0].method

    @property
    def near_best(self) -> tuple[str, ...]:
        """The rules predicted within ``TIE`` (10 %) of the best, best first."""
        return tuple(r.method for r in self.rows if r.near_best)

    def row(self, method: str) -> AdviceRow:
        """The row of ``method`` (by name)."""
        for r in self.rows:
            if r.method == method:
                return r
        raise KeyError(
            f"no method {method!r} in this advice; have {[r.method for r in self.rows]}."
        )

    def table(self) -> str:
        """The ranked table as plain text."""

        def g(x: float) -> str:
            return (
                "      n/a"
                if x is None or (isinstance(x, float) and math.isnan(x))
                else f"{x:9.3g}"
            )

        head = (
            f"{'rank':>4s} {'method':6s} {'gain':>6s} | {'pred eta':>9s} {'meas eta':>9s} "
            f"{'bound eta':>9s} | {'pred v':>9s} {'meas v':>9s} {'bound v':>9s}"
        )
        if self.tolerance is not None:
            head += f" | {'h_max':>7s} {'h_max_g':>7s}"
        lines = [
            f"{self.vehicle}: h = {self.h:g} s, noise (eta, v) = ({self.eta_pct:g} %, "
            f"{self.v_pct:g} %); ranked by predicted {self.rank_by} error",
        ]
        if self.domain is not None:
            lines.append(f"domain: {self.domain.describe()}")
        lines.append(head)
        for r in self.rows:
            line = (
                f"{r.rank:3d}{'*' if r.near_best else ' '} {r.method:6s} "
                f"{r.first_order_gain:6.3g} | {g(r.predicted_eta)} "
                f"{g(r.measured_eta)} {g(r.bound_eta)} | {g(r.predicted_v)} "
                f"{g(r.measured_v)} {g(r.bound_v)}"
            )
            if self.tolerance is not None:
                hm = "-" if r.h_max is None else f"{r.h_max:.3g}"
                hg = "-" if r.h_max_guaranteed is None else f"{r.h_max_guaranteed:.3g}"
                line += f" | {hm:>7s} {hg:>7s}"
            lines.append(line)
        lines.append(f"* predicted within {TIE:.0%} of the best: as good in practice")
        if self.rank_agreement is not None:
            lines.append(
                f"measured over {self.seeds} noise seeds; Kendall tau (predicted vs measured "
                f"order) = {self.rank_agreement:.2f}"
            )
        if self.tolerance is not None:
            lines.append(
                f"h_max: largest h (s) whose predicted (h_max) / guaranteed (h_max_g) error "
                f"stays <= tolerance (eta, v) = {self.tolerance}"
            )
        lines.extend(f"n/a: {note}" for note in self.notes)
        return "\n".join(lines)


def default_input(model: Model) -> Any:
    """The default reference input of ``advise``: the Fig. 6 thruster pattern at 20 %
    (:func:`sampledyn.sensitivity.gentle_input`) of a vehicle (or of the vehicle in a
    closed loop).

    Raises
    ------
    ValueError
        if none can be built (not a vehicle, or not 4 vertical and 4 horizontal
        thrusters), saying to give the input.
    """
    plant = model.plant if isinstance(model, ClosedLoop) else model
    why = f"{getattr(model, 'name', type(model).__name__)!r} is not a thruster vehicle"
    if isinstance(plant, Vehicle):
        try:
            return gentle_input(plant)
        except ValueError as exc:
            why = str(exc)
    raise ValueError(
        "`signal`: advise has no default input for this model (the default is the Fig. 6 "
        f"thruster pattern at 20 %, which needs 4 vertical and 4 horizontal thrusters; "
        f"{why}); give the input: signal=... (sampledyn advise --input NAME or "
        "--input '{ name = \"sinusoidal\", ... }')."
    )


def _curves(
    model: Model,
    ms: list[Any],
    base: Trajectory,
    ks: list[int],
    eta_pct: float,
    v_pct: float,
    domain: Domain | None,
    signal: Any,
    samples: int,
) -> ErrorCurves:
    """Error curves of every rule, each predicting as the engine predicts it (a
    closed loop: rules that use samples only with the plant and the applied input)."""
    from .sweep import prediction_inputs

    groups: dict[int, tuple[Any, Trajectory, Any, list[Any]]] = {}
    applied = None
    if isinstance(model, ClosedLoop):
        u = model.applied_input(base.t, base.x, base.u)
        applied = base.replace(u=u, input_names=tuple(model.plant.input_names))
    for m in ms:
        use_model, data, sig = prediction_inputs(
            model, m, applied if applied is not None else base, base, signal
        )
        groups.setdefault(id(use_model), (use_model, data, sig, []))[3].append(m)
    # The curves run every rule at periods up to h_max_search (2 s and more), where an
    # RK stage or a prediction can leave the data's pitch range by far; a vehicle's
    # warning about such an f argument would read as if the data went there (the data's
    # own range is the domain, checked and printed). Those errors show in the curves.
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=r"pitch \|theta\| up to", category=UserWarning)
        parts = [
            error_curves(gm, gms, data, ks, eta_pct, v_pct, domain, sig, samples=samples)
            for gm, data, sig, gms in groups.values()
        ]
    if len(parts) == 1:
        return parts[0]
    merged: dict[str, dict[str, np.ndarray]] = {}
    for key in ("truncation", "predicted_noise", "predicted", "bound_noise", "bound"):
        merged[key] = {n: getattr(p, key)[n] for p in parts for n in p.methods}
    return ErrorCurves(
        h=parts[0].h,
        eta_pct=float(eta_pct),
        v_pct=float(v_pct),
        methods=tuple(m.name for m in ms),
        **merged,
    )


def _checked_arguments(
    model: Model, h: Any, methods: Any, rank_by: Any, seeds: Any, base_seed: Any, workers: Any
) -> list[Any]:
    """The methods of :func:`advise`, its other arguments checked (named)."""
    if isinstance(model, Vehicle):
        check_vehicle(model, "model")
    else:
        state_blocks(model.state_units, "model")
    if rank_by not in RANK_BY:
        raise ValueError(f"`rank_by` must be one of {RANK_BY}, got {rank_by!r}.")
    checks.period(h)
    checks.count(seeds, "seeds")
    checks.count(base_seed, "base_seed", least=0)
    ms = [supported_method(m, "methods") for m in methods]
    if not ms:
        raise ValueError("`methods` is empty; give at least one rule, e.g. ('E', 'AB4').")
    if workers is not None:
        checks.count(workers, "workers")
    return ms


def _check_run_length(ms: list[Any], h: float, T: Any) -> None:
    """The reference run of :func:`advise` is long enough for every rule's history."""
    checks.positive(T, "T", what="reference run length", unit="s")
    longest = max(ms, key=lambda m: m.history)
    t_min = (samples_needed(ms) - 1) * h
    if T < t_min:
        raise ValueError(
            f"reference run length `T` = {T:g} s is too short for h = {h:g} s: "
            f"{longest.name} needs {longest.history} samples of history and 3 "
            f"predictions; give T >= {t_min:g} s."
        )


def _reference_run(
    model: Model, signal: Any, reference: Any, h: float, T: float, x0: Any, h_max: Any
) -> tuple[Trajectory, Any]:
    """The exact samples the curves are computed on (simulated, or the reference
    given) and the multiples k of their period that the curves visit."""
    if reference is None:
        h0, ks = h_grid(h, h_max=h_max)
        n_int = max(1, round(T / h))
        return exact_samples(model, signal, n_int * h, h0, x0), ks
    base = exact_reference(reference)
    m_ratio = period_ratio(h, base.h)
    top = max(2.0, 4.0 * h) if h_max is None else h_max
    grid = np.geomspace(1, max(m_ratio, top / base.h), 25)
    return base, sorted({int(round(k)) for k in grid} | {m_ratio})


def advise(
    model: Model,
    h: float,
    eta_pct: float,
    v_pct: float,
    methods: Sequence[str] = DEFAULT_METHODS,
    domain: Domain | None = None,
    tolerance: float | tuple[float, float] | None = None,
    validate: bool = True,
    *,
    signal: Any = None,
    reference: Trajectory | None = None,
    T: float = 60.0,
    x0: Any = None,
    seeds: int = 3,
    base_seed: int = 0,
    rank_by: str = "max",
    h_max_search: float | None = None,
    samples: int = 5000,
    workers: int | None = None,
) -> Advice:
    """Rank sampled-data rules by their predicted one-step error on noisy data.

    Parameters
    ----------
    model : Model
        A 6-DoF vehicle (no thruster lag; the guaranteed bound is computed for it), or
        any model whose states are positions/angles (units m, rad) and rates (m/s,
        rad/s), e.g. a :class:`sampledyn.models.SymbolicModel` or a closed loop.
    h : float
        Sampling period (s).
    eta_pct, v_pct : float
        Uniform noise levels, % of 1 m / 30 deg and 1 m/s / 30 deg/s.
    methods : sequence of str
        Rules to compare ("E", "AB<s>", "RK<s>", "T").
    domain : Domain, optional
        Box for the guaranteed bound (vehicles); default: the box of the reference run.
    tolerance : float or (float, float), optional
        Error tolerance on eta (m, rad) and v (m/s, rad/s); gives ``h_max`` per rule.
    validate : bool
        Also measure the errors on ``seeds`` noisy copies of the reference run (a
        Monte Carlo study on the engine).
    signal : Signal, optional
        Input of the reference run (a closed loop: its reference). Default
        :func:`default_input` (the Fig. 6 pattern at 20 %, for a thruster vehicle).
    reference : Trajectory, optional
        Exact samples at a period dividing h (instead of simulating).
    T : float
        Duration of the simulated reference run (s).
    x0 : ndarray, shape (nx,), optional
        Its initial state.
    seeds, base_seed : int
        Monte Carlo repetitions, seeded ``SeedSequence([base_seed, k])``.
    rank_by : {"max", "eta", "v"}
        Rank by the larger of the two blocks' errors, or by one block.
    h_max_search : float, optional
        Largest h (s) tried for ``h_max`` (default max(2 s, 4 h)).
    samples : int
        Random samples of the Jacobian check.
    workers : int, optional
        Local worker processes of the Monte Carlo (default: in this process).

    Returns
    -------
    Advice

    Raises
    ------
    ValueError
        for a model whose states do not split into positions/angles and rates, a
        model without a default input and no ``signal``, and bad arguments (named).
    TypeError
        for a ``reference`` or ``domain`` of the wrong type.
    """
    vehicle = isinstance(model, Vehicle)
    ms = _checked_arguments(model, h, methods, rank_by, seeds, base_seed, workers)
    if reference is None:
        _check_run_length(ms, h, T)
    tol = None if tolerance is None else check_tolerance(tolerance)
    amp = noise_amplitudes(model.state_units, eta_pct, v_pct)
    if domain is not None and not vehicle:
        raise ValueError("`domain` bounds the Jacobians of a 6-DoF vehicle; this model is not.")
    if reference is None:
        signal = default_input(model) if signal is None else signal
    base, ks = _reference_run(model, signal, reference, h, T, x0, h_max_search)
    jac = None
    notes: list[str] = []
    if vehicle:
        domain, jac, _ = domain_maxima(cast(Vehicle, model), base, signal, domain, amp, samples)
    else:
        notes.append(f"bound, h_max_g: {NO_BOUND}.")
    curves = _curves(
        model, ms, base, usable_periods(ms, base, ks), eta_pct, v_pct, domain, signal, samples
    )
    at = int(np.argmin(np.abs(curves.h - h)))
    if not checks.same_period(h, float(curves.h[at])):
        raise ValueError(f"the reference run is too short for h = {h} s; raise `T`.")

    measured: dict[str, tuple[float, float, float, float]] = {}
    if validate:
        found = measure_noisy(
            model, [m.name for m in ms], base, signal, h, [(eta_pct, v_pct)], seeds,
            base_seed, ("max", "rms"), workers=workers,
        )  # fmt: skip
        for m in ms:
            per = {n: found[(float(eta_pct), float(v_pct), m.name, n)] for n in ("max", "rms")}
            worst, rms = pooled(per)
            measured[m.name] = (float(worst[0]), float(worst[1]), float(rms[0]), float(rms[1]))
    else:
        notes.append("meas: no Monte Carlo (validate=False).")

    pred_key = {
        m.name: rank_key(
            float(curves.predicted[m.name][at, 0]), float(curves.predicted[m.name][at, 1]), rank_by
        )
        for m in ms
    }
    order = sorted(pred_key, key=lambda n: pred_key[n])
    meas_order: list[str] = []
    tau = None
    if validate:
        meas_key = {n: rank_key(measured[n][0], measured[n][1], rank_by) for n in measured}
        meas_order = sorted(meas_key, key=lambda n: meas_key[n])
        if len(ms) > 1:
            from scipy.stats import kendalltau

            tau = float(kendalltau([pred_key[n] for n in order], [meas_key[n] for n in order])[0])
    nan4 = (math.nan,) * 4
    rows = []
    for rank, name in enumerate(order, start=1):
        m = next(mm for mm in ms if mm.name == name)
        pe, pv = curves.predicted[name][at]
        be, bv = curves.bound[name][at]
        te, tv = curves.truncation[name][at]
        me, mv, re, rv = measured.get(name, nan4)
        rows.append(
            AdviceRow(
                method=name,
                order=int(m.order),
                first_order_gain=float(first_order_gain(m)),
                predicted_eta=float(pe),
                predicted_v=float(pv),
                bound_eta=float(be),
                bound_v=float(bv),
                truncation_eta=float(te),
                truncation_v=float(tv),
                measured_eta=me,
                measured_v=mv,
                measured_rms_eta=re,
                measured_rms_v=rv,
                h_max=None if tol is None else largest_h(curves, name, tol, rank_by=rank_by),
                h_max_guaranteed=None
                if tol is None or not vehicle
                else largest_h(curves, name, tol, rank_by=rank_by, which="bound"),
                rank=rank,
                measured_rank=meas_order.index(name) + 1 if validate else None,
                near_best=pred_key[name] <= pred_key[order[0]] * (1.0 + TIE),
            )
        )
    return Advice(
        vehicle=getattr(model, "name", type(model).__name__),
        h=float(h),
        eta_pct=float(eta_pct),
        v_pct=float(v_pct),
        tolerance=tol,
        rank_by=rank_by,
        rows=tuple(rows),
        domain=domain,
        jacobians=jac,
        curves=curves,
        rank_agreement=tau,
        seeds=seeds if validate else 0,
        notes=tuple(notes),
    )
