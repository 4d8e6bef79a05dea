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
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

from .. import _checks as checks
from .._noise import noise_amplitudes
from .._trajectory import Trajectory
from ..exceptions import ArgumentError, NumericalError, SingularPitchError, WorkLimitError
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
    h_stable : float or None
        Largest h (s) at which the rule is stable along the reference run (the
        eigenvalues of df/dx at its samples, :func:`sampledyn.sensitivity.
        stability_limits`); None without a Jacobian.
    failed : str or None
        Why the rule's prediction failed at h itself (its numbers are then NaN and it
        ranks last); None if it did not.
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
    h_stable: float | None = None
    failed: str | None = None


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
        6-DoF vehicle), and where a rule's curve ended because it failed.
    noise_levels : ndarray, shape (nx,), or None
        The per-state noise standard deviations advised on (then ``eta_pct`` and
        ``v_pct`` are NaN); None for the levels of ``eta_pct``, ``v_pct``.
    baselines : tuple of AdviceRow
        ``hold`` and ``kinematics`` (:mod:`sampledyn._baselines`) at h, unranked:
        predicted, truncation and measured errors (the measured from noise draws of
        their own, in this process; no bound, no h_max).
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
    noise_levels: np.ndarray | None = None
    state_names: tuple[str, ...] = ()
    baselines: tuple[AdviceRow, ...] = ()

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
        head += f" | {'h_stab':>7s}"
        if self.noise_levels is None:
            noise = f"noise (eta, v) = ({self.eta_pct:g} %, {self.v_pct:g} %)"
        else:
            names = self.state_names or tuple(f"x{i}" for i in range(len(self.noise_levels)))
            noise = "noise per state (std, uniform): " + ", ".join(
                f"{n} {v:.2g}" for n, v in zip(names, self.noise_levels, strict=True) if v > 0
            )
        lines = [
            f"{self.vehicle}: h = {self.h:g} s, {noise}; ranked by predicted {self.rank_by} error"
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
            hs = "-" if r.h_stable is None else f"{r.h_stable:.3g}"
            unstable = r.h_stable is not None and self.h > r.h_stable
            line += f" | {hs:>7s}{' !' if unstable else ''}"
            if r.failed:
                line += f"  failed at h: {r.failed}"
            lines.append(line)
        for r in self.baselines:
            lines.append(
                f"   - {r.method:13s} | {g(r.predicted_eta)} {g(r.measured_eta)} "
                f"{g(r.bound_eta)} | {g(r.predicted_v)} {g(r.measured_v)} {g(r.bound_v)}"
            )
        lines.append(f"* predicted within {TIE:.0%} of the best: as good in practice")
        if self.baselines:
            lines.append(
                "-: baselines, no model of forces (hold: x_n+1 = x_n; kinematics: positions "
                "advanced with the rates, eq. (6), rates held): a rule that does not beat "
                "them predicts nothing"
            )
        lines.append(
            "h_stab: largest h (s) at which the rule is stable along the reference run "
            "(|R(h lambda)| <= 1 for the eigenvalues of df/dx at its samples); ! h is beyond it"
        )
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
        lines.extend((note if ": its curve" in note else f"n/a: {note}") for note in self.notes)
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
    amp: np.ndarray | None = None,
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
            error_curves(
                gm, gms, data, ks, eta_pct, v_pct, domain, sig, samples=samples, amplitudes=amp
            )
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
        failed={n: f for p in parts for n, f in p.failed.items()},
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
    checks.check_step(checks.period(h))
    if checks.count(seeds, "seeds") > checks.MAX_SEEDS:
        raise WorkLimitError(
            "seeds",
            f"`seeds` must be an int in 1..{checks.MAX_SEEDS} (10,000 seeds give the mean "
            f"error to 1 % of its spread), got {seeds!r}.",
        )
    if checks.count(base_seed, "base_seed", least=0) > checks.MAX_SEED:
        raise ArgumentError(
            "base_seed", f"`base_seed` must be an int <= 2^63 - 1, got {base_seed:.4g}."
        )
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


def _levels(model: Any, eta_pct: float, v_pct: float, noise_levels: Any) -> np.ndarray | None:
    """Uniform noise amplitudes per state from ``noise_levels`` (standard deviations,
    or a NoiseEstimate): a = sqrt(3) sigma, the uniform noise of that std; None when
    not given (the amplitudes of eta_pct, v_pct)."""
    if noise_levels is None:
        return None
    sigma = getattr(noise_levels, "sigma", noise_levels)
    sig = np.nan_to_num(np.asarray(sigma, dtype=float), nan=0.0)
    if sig.shape != (model.nx,) or not np.isfinite(sig).all() or (sig < 0).any():
        raise ValueError(
            f"`noise_levels` must be {model.nx} standard deviations >= 0 (state units, one "
            f"per state) or a NoiseEstimate, got shape {sig.shape}; e.g. the `noise` of "
            "sampledyn.logs.evaluate_log or sampledyn.estimate_noise(log)."
        )
    return np.sqrt(3.0) * sig


def _measure_levels(
    model: Any, ms: list[Any], base: Trajectory, signal: Any, h: float, amp: np.ndarray,
    seeds: int, base_seed: int,
) -> dict[str, tuple[float, float, float, float]]:  # fmt: skip
    """The Monte Carlo of per-state noise levels, in this process: uniform noise of
    amplitudes ``amp`` on the exact samples at h, ``seeds`` times; per rule the largest
    and the rms block errors over all seeds (NaN for a rule that fails)."""
    from .._local_errors import local_errors
    from .._predict import predict
    from ..sensitivity._bound import block_error_norms, reference_at

    clean = reference_at(base, h)
    out: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {m.name: [] for m in ms}
    for k in range(seeds):
        rng = np.random.default_rng(np.random.SeedSequence([base_seed, k]))
        noisy = clean.replace(x=clean.x + rng.uniform(-1.0, 1.0, clean.x.shape) * amp)
        for m in ms:
            try:
                err = local_errors(predict(m, model, noisy, signal), noisy)
            except (NumericalError, SingularPitchError, FloatingPointError):
                continue
            out[m.name].append(block_error_norms(err, noisy.state_units))
    found = {}
    for name, blocks in out.items():
        if len(blocks) < seeds:
            found[name] = (math.nan,) * 4
            continue
        eta = np.concatenate([b[0] for b in blocks])
        v = np.concatenate([b[1] for b in blocks])
        found[name] = (
            float(np.nanmax(eta)), float(np.nanmax(v)),
            float(np.sqrt(np.nanmean(eta**2))), float(np.sqrt(np.nanmean(v**2))),
        )  # fmt: skip
    return found


def _measured(
    model: Any, ms: list[Any], base: Trajectory, signal: Any, h: float, noise: Any,
    seeds: int, base_seed: int, workers: int | None,
) -> dict[str, tuple[float, float, float, float]]:  # fmt: skip
    """(max eta, max v, rms eta, rms v) per rule on noisy copies of the run."""
    eta_pct, v_pct, amp, own_rules = noise
    if amp is not None or own_rules:
        # per-state levels, or rules with options of their own (the engine builds its
        # rules from their names): the Monte Carlo in this process, with these rules
        amp = noise_amplitudes(model.state_units, eta_pct, v_pct) if amp is None else amp
        if isinstance(model, ClosedLoop):
            raise ValueError(
                "`noise_levels` or `newton` with `validate=True` are for open-loop models; "
                "for a closed loop give eta_pct, v_pct and the default Newton options (the "
                "engine's Monte Carlo), or validate=False."
            )
        return _measure_levels(model, ms, base, signal, h, amp, seeds, base_seed)
    found = measure_noisy(
        model, [m.name for m in ms], base, signal, h, [(eta_pct, v_pct)], seeds,
        base_seed, ("max", "rms"), workers=workers,
    )  # fmt: skip
    measured = {}
    for m in ms:
        per = {n: found[(float(eta_pct), float(v_pct), m.name, n)] for n in ("max", "rms")}
        worst, rms = pooled(per)
        measured[m.name] = (float(worst[0]), float(worst[1]), float(rms[0]), float(rms[1]))
    return measured


def _stable_steps(model: Any, ms: list[Any], base: Trajectory, h: float) -> dict[str, float]:
    """Each rule's largest stable step along the reference run (empty: no Jacobian)."""
    from ..exceptions import JacobianUnavailableError
    from ..sensitivity import stability_limits
    from ..sensitivity._bound import reference_at

    try:
        limits = stability_limits(model, ms, reference_at(base, h), h=h)
    except JacobianUnavailableError:
        return {}
    return {lim.method: lim.h_stable for lim in limits}


def _baseline_rows(
    model: Any, base: Trajectory, signal: Any, h: float, noise: tuple[Any, ...]
) -> tuple[AdviceRow, ...]:
    """The baselines at h: the path prediction and, with seeds, the errors measured on
    noisy copies (uniform noise of amplitudes ``amp``, seeded SeedSequence([base_seed,
    k, 1]): draws of their own)."""
    from .._baselines import BASELINES
    from ..sensitivity import path_prediction
    from ..sensitivity._bound import reference_at

    eta_pct, v_pct, amp, seeds, base_seed = noise
    clean = reference_at(base, h)
    plant = model.plant if isinstance(model, ClosedLoop) else model
    data = clean
    if isinstance(model, ClosedLoop):  # the plant and its applied input, as the rules
        u = model.applied_input(clean.t, clean.x, clean.u)
        data = clean.replace(u=u, input_names=tuple(model.plant.input_names))
    rows = []
    nan = math.nan
    for name, b in BASELINES.items():
        p = path_prediction(plant, b, data, amp, None, eta_pct, v_pct)
        measured = _measure_baseline(plant, b, data, amp, seeds, base_seed)
        rows.append(
            AdviceRow(
                method=name, order=0, first_order_gain=nan, predicted_eta=p.eta,
                predicted_v=p.v, bound_eta=nan, bound_v=nan, truncation_eta=p.truncation[0],
                truncation_v=p.truncation[1], measured_eta=measured[0],
                measured_v=measured[1], measured_rms_eta=measured[2],
                measured_rms_v=measured[3], h_max=None, h_max_guaranteed=None, rank=0,
                measured_rank=None,
            )
        )  # fmt: skip
    return tuple(rows)


def _measure_baseline(
    model: Any, baseline: Any, data: Trajectory, amp: np.ndarray, seeds: int, base_seed: int
) -> tuple[float, float, float, float]:
    """(max eta, max v, rms eta, rms v) of a baseline on ``seeds`` noisy copies."""
    from ..sensitivity._bound import block_error_norms

    if seeds == 0:
        return (math.nan,) * 4
    eta, v = [], []
    for k in range(seeds):
        rng = np.random.default_rng(np.random.SeedSequence([base_seed, k, 1]))
        noisy = data.replace(x=data.x + rng.uniform(-1.0, 1.0, data.x.shape) * amp)
        e, w = block_error_norms(noisy.x - baseline.predict(model, noisy), noisy.state_units)
        eta.append(e)
        v.append(w)
    ea, va = np.concatenate(eta), np.concatenate(v)
    return (
        float(np.nanmax(ea)), float(np.nanmax(va)),
        float(np.sqrt(np.nanmean(ea**2))), float(np.sqrt(np.nanmean(va**2))),
    )  # fmt: skip


def _sort_key(key: float) -> tuple[bool, float]:
    """Rank NaN (a rule that failed at h) last."""
    return (not math.isfinite(key), key if math.isfinite(key) else 0.0)


def _failure_notes(curves: ErrorCurves, h: float) -> list[str]:
    notes = []
    for name, (h_fail, why) in curves.failed.items():
        where = "at h itself" if abs(h_fail - h) <= 1e-9 * h else f"from h = {h_fail:.3g} s on"
        notes.append(f"{name}: its curve (and h_max) ends {where}: {why}")
    return notes


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
    noise_levels: Any = None,
    newton: Mapping[str, Any] | None = None,
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
        Uniform noise levels, % of 1 m / 30 deg and 1 m/s / 30 deg/s (not used with
        ``noise_levels``).
    methods : sequence of str
        Rules to compare ("E", "AB<s>", "RK<s>", "T").
    domain : Domain, optional
        Box for the guaranteed bound (vehicles); default: the box of the reference run.
    tolerance : float or (float, float), optional
        Error tolerance on eta (m, rad) and v (m/s, rad/s); gives ``h_max`` per rule.
    validate : bool
        Also measure the errors on ``seeds`` noisy copies of the reference run (a
        Monte Carlo study on the engine; in this process with ``noise_levels``).
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
    noise_levels : array_like, shape (nx,), or NoiseEstimate, optional
        Per-state noise standard deviations (state units), e.g. the levels estimated
        from a log (``evaluate_log(...).noise``, :func:`sampledyn.
        estimate_noise`): the noise is then uniform with these standard deviations
        (amplitude sqrt(3) sigma) instead of ``eta_pct``, ``v_pct``.
    newton : mapping, optional
        Newton options of the implicit rules, ``{"tol": ..., "max_iter": ...}``.

    Returns
    -------
    Advice
        A rule that fails at a trial period of the curves (Newton not converging, a
        singular pitch, a non-finite prediction) ends its curve and its h_max there,
        and the notes say so; one that fails at h itself ranks last, its row NaN with
        ``failed`` set. ``h_stable`` per row: the rule's largest stable step along the
        run.

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
    ms = [m.with_newton(**newton) if newton and hasattr(m, "with_newton") else m for m in ms]
    if reference is None:
        _check_run_length(ms, h, T)
    tol = None if tolerance is None else check_tolerance(tolerance)
    levels = _levels(model, eta_pct, v_pct, noise_levels)
    amp = noise_amplitudes(model.state_units, eta_pct, v_pct) if levels is None else levels
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
        model, ms, base, usable_periods(ms, base, ks), eta_pct, v_pct, domain, signal, samples,
        levels,
    )  # fmt: skip
    at = int(np.argmin(np.abs(curves.h - h)))
    if not checks.same_period(h, float(curves.h[at])):
        raise ValueError(f"the reference run is too short for h = {h} s; raise `T`.")
    notes += _failure_notes(curves, h)
    measured: dict[str, tuple[float, float, float, float]] = {}
    if validate:
        noise = (eta_pct, v_pct, levels, bool(newton))
        measured = _measured(model, ms, base, signal, h, noise, seeds, base_seed, workers)
    else:
        notes.append("meas: no Monte Carlo (validate=False).")
    stable = _stable_steps(model, ms, base, h)
    rows, tau = _advice_rows(ms, curves, at, measured, tol, rank_by, vehicle, stable, h)
    spec = (eta_pct, v_pct, amp, seeds if validate else 0, base_seed)
    baselines = _baseline_rows(model, base, signal, h, spec)
    return Advice(
        vehicle=getattr(model, "name", type(model).__name__),
        h=float(h),
        eta_pct=float(eta_pct) if levels is None else math.nan,
        v_pct=float(v_pct) if levels is None else math.nan,
        tolerance=tol,
        rank_by=rank_by,
        rows=tuple(rows),
        domain=domain,
        jacobians=jac,
        curves=curves,
        rank_agreement=tau,
        seeds=seeds if validate else 0,
        notes=tuple(notes),
        noise_levels=None if levels is None else levels / np.sqrt(3.0),
        state_names=tuple(model.state_names),
        baselines=baselines,
    )


def _advice_rows(
    ms: list[Any], curves: ErrorCurves, at: int, measured: dict[str, Any], tol: Any,
    rank_by: str, vehicle: bool, stable: dict[str, float], h: float,
) -> tuple[list[AdviceRow], float | None]:  # fmt: skip
    """The ranked rows and the Kendall tau of predicted vs measured order."""
    pred_key = {
        m.name: rank_key(
            float(curves.predicted[m.name][at, 0]), float(curves.predicted[m.name][at, 1]), rank_by
        )
        for m in ms
    }
    order = sorted(pred_key, key=lambda n: _sort_key(pred_key[n]))
    meas_order: list[str] = []
    tau = None
    if measured:
        meas_key = {n: rank_key(measured[n][0], measured[n][1], rank_by) for n in measured}
        meas_order = sorted(meas_key, key=lambda n: _sort_key(meas_key[n]))
        both = [n for n in order if math.isfinite(pred_key[n]) and math.isfinite(meas_key[n])]
        if len(both) > 1:
            from scipy.stats import kendalltau

            tau = float(kendalltau([pred_key[n] for n in both], [meas_key[n] for n in both])[0])
    nan4 = (math.nan,) * 4
    best = pred_key[order[0]]
    rows = []
    for rank, name in enumerate(order, start=1):
        m = next(mm for mm in ms if mm.name == name)
        pe, pv = curves.predicted[name][at]
        be, bv = curves.bound[name][at]
        te, tv = curves.truncation[name][at]
        me, mv, re, rv = measured.get(name, nan4)
        fail = curves.failed.get(name)
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
                measured_rank=meas_order.index(name) + 1 if measured else None,
                near_best=math.isfinite(pred_key[name]) and pred_key[name] <= best * (1.0 + TIE),
                h_stable=stable.get(name),
                failed=fail[1] if fail is not None and fail[0] <= h * (1 + 1e-9) else None,
            )
        )
    return rows, tau
