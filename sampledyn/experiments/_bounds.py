"""Monte Carlo checks of the bound (24)-(25), on the engine.

The bound itself is analysis (:mod:`sampledyn.sensitivity`); here noisy copies of
exact samples are fed through the rules by the engine's cell function, and their
disturbed local errors measured: per rule and noise level, the largest error and the
rms over all samples of all seeds, and the largest noise contribution (disturbed
minus undisturbed local error at the same sample). The exact samples are simulated
once and handed to the engine (``reference``), which takes every k-th sample of
them for a multiple k of their period.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._noise import noise_amplitudes
from .._trajectory import Trajectory
from ..models import Model, Vehicle
from ..sensitivity import Domain, gentle_input, path_prediction, scaled_inertia
from ..sensitivity._bound import (
    ErrorBound,
    assemble_bound,
    domain_maxima,
    jacobian_pair,
    reference_at,
    truncation_errors,
    truncation_estimate,
)
from ..sensitivity._domain import check_vehicle, pitch_guard
from ..sensitivity._gains import supported_method
from .sweep import SweepConfig, exact_samples
from .sweep._run import run_study

__all__ = [
    "InertiaSensitivity",
    "MonteCarloRow",
    "inertia_sensitivity",
    "measure_noisy",
    "monte_carlo_check",
    "reference_samples",
]


def reference_samples(
    model: Model,
    h: float,
    signal: Any = None,
    reference: Trajectory | None = None,
    T: float = 60.0,
    x0: Any = None,
) -> tuple[Trajectory, Any]:
    """Exact samples at sampling period ``h`` and the signal that made them.

    The reference given (clean samples, or measured ones whose ``clean`` is used) is
    subsampled to h; otherwise the model is simulated for T seconds under ``signal``
    (default :func:`sampledyn.sensitivity.gentle_input`) by the engine's simulation.
    """
    if reference is None:
        signal = gentle_input(model) if signal is None else signal
        return exact_samples(model, signal, T, h, x0), signal
    return reference_at(reference, h), signal


def measure_noisy(
    model: Model,
    methods: Sequence[str],
    clean: Trajectory,
    signal: Any,
    h: float,
    noise_levels: Sequence[tuple[float, float]],
    seeds: int,
    base_seed: int,
    norms: Sequence[str],
    *,
    workers: int | None = None,
) -> dict[tuple[float, float, str, str], np.ndarray]:
    """Norms of the disturbed local errors on ``seeds`` noisy copies of ``clean`` (exact
    samples at a period dividing ``h``), computed by the engine.

    Returns
    -------
    dict (eta %, v %, method, norm) -> ndarray, shape (seeds, 3): the norm over the
    eta, the v and all components, one row per seed (NaN where a cell failed; the
    noise-free pair, which runs once, repeated).
    """
    if signal is None:
        from ..signals import ZeroOrderHold

        signal = ZeroOrderHold(clean.t, clean.u)  # the sampled input, held
    config = SweepConfig(
        vehicle=str(getattr(model, "name", type(model).__name__)),
        inputs=({"name": "signal", "type": type(signal).__name__},),
        T=float(clean.t[-1] - clean.t[0]),
        after=0.0,
        h=(float(h),),
        methods=tuple(methods),
        noise=tuple((float(e), float(v)) for e, v in noise_levels),
        seeds=range(seeds),
        norms=tuple(norms),
        base_seed=base_seed,
        model=model,
        signals=(signal,),
        reference=clean,
    )
    options = {"workers": workers} if workers is not None and workers > 1 else {}
    result = run_study(config, None, **options)
    out: dict[tuple[float, float, str, str], list[tuple[float, ...]]] = {}
    for c in result.cells:
        ok = c["status"] == "ok"
        value = (
            (float(c["err_eta"]), float(c["err_v"]), float(c["err_all"])) if ok else (math.nan,) * 3
        )
        out.setdefault((c["eta_pct"], c["v_pct"], c["method"], c["norm"]), []).append(value)
    full = {}
    for (e, v, m, n), values in out.items():
        rows = np.array(values)
        if (e, v) == (0.0, 0.0) and rows.shape[0] < seeds:  # the noise-free pair runs once
            rows = np.repeat(rows[:1], seeds, axis=0)
        full[(e, v, m, n)] = rows
    return full


def pooled(per_seed: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Largest errors and rms over all samples of all seeds from per-seed "max" and
    "rms" (every seed has the same samples): shapes (2,) each, (eta, v)."""
    worst = per_seed["max"][:, :2].max(axis=0)
    return worst, np.sqrt(np.mean(per_seed["rms"][:, :2] ** 2, axis=0))


@dataclass(frozen=True)
class MonteCarloRow:
    """Bound and measured disturbed local errors of one rule at one noise level.

    Errors are per-sample Euclidean norms over the 6 eta (m, rad) or 6 v (m/s, rad/s)
    components of ``measured - prediction``; ``measured_*`` is their maximum over all
    samples and seeds, ``rms_*`` the root mean square over them.

    Attributes
    ----------
    method : str
    h, eta_pct, v_pct : float
    seeds, samples : int
        Monte Carlo repetitions, and samples with a prediction per repetition.
    bound : ErrorBound
    measured_eta, measured_v, rms_eta, rms_v : float
    noise_eta, noise_v : float
        Largest noise contribution ``||eps~_n - eps_n||`` (disturbed minus undisturbed
        local error at the same sample), over samples and seeds.
    violations : int
        Samples (over all seeds) whose error exceeds the bound in either block.
    """

    method: str
    h: float
    eta_pct: float
    v_pct: float
    seeds: int
    samples: int
    bound: ErrorBound
    measured_eta: float
    measured_v: float
    rms_eta: float
    rms_v: float
    noise_eta: float
    noise_v: float
    violations: int

    @property
    def tightness_eta(self) -> float:
        """Bound / measured maximum for the positions (>= 1 when the bound holds)."""
        return self.bound.eta.total / self.measured_eta if self.measured_eta > 0 else np.inf

    @property
    def tightness_v(self) -> float:
        """Bound / measured maximum for the velocities (>= 1 when the bound holds)."""
        return self.bound.v.total / self.measured_v if self.measured_v > 0 else np.inf


def monte_carlo_check(
    model: Vehicle,
    methods: Sequence[Any],
    h: float,
    noise_levels: Sequence[tuple[float, float]],
    *,
    reference: Trajectory | None = None,
    signal: Any = None,
    domain: Domain | None = None,
    seeds: int = 5,
    base_seed: int = 0,
    T: float = 60.0,
    x0: Any = None,
    samples: int = 5000,
    workers: int | None = None,
) -> tuple[MonteCarloRow, ...]:
    """Measure the disturbed local errors on noisy copies of exact samples (on the
    engine) and compare them, sample by sample, with the bound (24)-(25).

    Parameters
    ----------
    model : Vehicle
    methods : sequence of str
        Rules ("E", "AB<s>", "RK<s>", "T").
    h : float
        Sampling period (s).
    noise_levels : sequence of (eta %, v %)
    reference, signal, T, x0
        The exact samples: ``reference`` (at h or a divisor of it), else ``T``
        seconds of the model under ``signal`` (default
        :func:`sampledyn.sensitivity.gentle_input`) from ``x0``.
    domain : Domain, optional
        Default: the box of the reference run.
    seeds : int
        Noise realisations per level; seed k draws from ``SeedSequence([base_seed, k])``.
    samples : int
        Random samples of the Jacobian check.
    workers : int, optional
        Local worker processes of the engine (default: in this process).

    Returns
    -------
    tuple of MonteCarloRow, one per (noise level, method).
    """
    check_vehicle(model, "model")
    if isinstance(seeds, bool) or not isinstance(seeds, int) or seeds < 1:
        raise ValueError(f"`seeds` must be an int >= 1, got {seeds!r}.")
    clean, signal = reference_samples(model, h, signal, reference, T, x0)
    domain, _, _ = domain_maxima(model, clean, signal, domain, np.zeros(model.nx), samples)
    ms = [supported_method(m, "methods") for m in methods]
    trunc = {m.name: truncation_errors(model, m, clean, signal) for m in ms}
    estimate = {m.name: truncation_estimate(model, m, clean) for m in ms}
    levels = [(float(e), float(v)) for e, v in noise_levels]
    names = tuple(m.name for m in ms)
    found = measure_noisy(
        model, names, clean, signal, h, levels, seeds, base_seed, ("max", "rms", "noise:max"),
        workers=workers,
    )  # fmt: skip
    rows = []
    for eta_pct, v_pct in levels:
        amp = noise_amplitudes(model.state_units, eta_pct, v_pct)
        jac, jac_plus = jacobian_pair(model, domain, amp, samples)
        for m in ms:
            b = assemble_bound(
                m, h, eta_pct, v_pct, amp, jac, jac_plus, trunc[m.name], estimate[m.name]
            )
            per = {n: found[(eta_pct, v_pct, m.name, n)] for n in ("max", "rms", "noise:max")}
            worst, rms = pooled(per)
            noise = per["noise:max"][:, :2].max(axis=0)
            violations = 0
            if worst[0] > b.eta.total or worst[1] > b.v.total:
                # Only then count the samples beyond the bound, sample by sample.
                count = f"exceeds({b.eta.total!r},{b.v.total!r})"
                extra = measure_noisy(
                    model, (m.name,), clean, signal, h, [(eta_pct, v_pct)], seeds, base_seed,
                    (count,), workers=workers,
                )  # fmt: skip
                violations = int(extra[(eta_pct, v_pct, m.name, count)][:, 2].sum())
            rows.append(
                MonteCarloRow(
                    method=m.name,
                    h=float(h),
                    eta_pct=eta_pct,
                    v_pct=v_pct,
                    seeds=seeds,
                    samples=clean.n_samples - int(m.history),
                    bound=b,
                    measured_eta=float(worst[0]),
                    measured_v=float(worst[1]),
                    rms_eta=float(rms[0]),
                    rms_v=float(rms[1]),
                    noise_eta=float(noise[0]),
                    noise_v=float(noise[1]),
                    violations=violations,
                )
            )
    return tuple(rows)


@dataclass(frozen=True)
class InertiaSensitivity:
    """The bound and the measured errors against an inertia scale factor.

    Arrays have shape (K,) or (K, 2) (columns: eta, v), one row per ``scales``.

    Attributes
    ----------
    scales : ndarray
        Factor on M (mass, inertia, added mass; volume alike).
    minv_norm : ndarray
        ``||M^-1||`` of each scaled vehicle (1/kg, mixed).
    lipschitz : ndarray, shape (K, 2, 2)
        Jacobian maxima over the common domain.
    noise_bound_fixed : ndarray, shape (K, 2)
        Noise part of the bound over the common domain (the base vehicle's run), so
        only M differs.
    bound, predicted, truncation : ndarray, shape (K, 2)
        Over each scaled vehicle's own run under the same input: the bound, the path
        prediction and the undisturbed local error.
    measured, measured_noise, measured_rms : ndarray, shape (K, 2)
        Monte Carlo over that run (NaN without ``validate``): largest disturbed local
        error, largest noise contribution ``||eps~_n - eps_n||`` and rms error.
    bounds : tuple of ErrorBound
        The full bounds of the own runs (empty without ``own_runs``).
    method : str
    h, eta_pct, v_pct : float
    domain : Domain
        The common domain.
    """

    scales: np.ndarray
    minv_norm: np.ndarray
    lipschitz: np.ndarray
    noise_bound_fixed: np.ndarray
    bound: np.ndarray
    predicted: np.ndarray
    measured: np.ndarray
    measured_noise: np.ndarray
    measured_rms: np.ndarray
    truncation: np.ndarray
    bounds: tuple[ErrorBound, ...]
    method: str
    h: float
    eta_pct: float
    v_pct: float
    domain: Domain


def inertia_sensitivity(
    vehicle: Any,
    scales: Sequence[float] = (0.25, 0.5, 1.0, 2.0, 4.0),
    *,
    method: str = "AB4",
    h: float = 0.1,
    eta_pct: float = 2.0,
    v_pct: float = 2.0,
    domain: Domain | None = None,
    signal: Any = None,
    T: float = 60.0,
    validate: bool = True,
    own_runs: bool = True,
    seeds: int = 3,
    samples: int = 2000,
    workers: int | None = None,
) -> InertiaSensitivity:
    """The bound (24)-(25) for the same vehicle made lighter or heavier, and the errors
    measured on each scaled vehicle's own run (on the engine).

    Parameters
    ----------
    vehicle : Vehicle
    scales : sequence of float
        Factors on M (see :func:`scaled_inertia`).
    method : str
        Rule.
    h : float
        Sampling period (s).
    eta_pct, v_pct : float
        Noise levels (%).
    domain : Domain, optional
        Common domain for ``noise_bound_fixed``; default: the box of the base
        vehicle's run.
    signal : Signal, optional
        Thruster input of the runs (default :func:`gentle_input` of the base vehicle).
    T : float
        Run duration (s).
    validate : bool
        Measure the errors on ``seeds`` noisy copies of each run.
    own_runs : bool
        Simulate every scaled vehicle for ``bound``, ``predicted``, ``truncation``
        (and ``measured``); without, those stay NaN and only the common-domain noise
        bound is computed.
    samples : int
        Random samples of each Jacobian check.
    workers : int, optional
        Local worker processes of the engine (default: in this process).

    Returns
    -------
    InertiaSensitivity
    """
    check_vehicle(vehicle)
    m = supported_method(method)
    sc = np.asarray(scales, dtype=float)
    if sc.ndim != 1 or sc.size == 0 or not np.isfinite(sc).all() or (sc <= 0).any():
        raise ValueError(f"`scales` must be positive numbers, got {scales!r}.")
    signal = gentle_input(vehicle) if signal is None else signal
    amp = noise_amplitudes(vehicle.state_units, eta_pct, v_pct)
    if domain is None:
        base, _ = reference_samples(vehicle, h, signal, None, T)
        domain = Domain.from_trajectory(base, vehicle.n_max, signal)
    dom = domain
    pitch_guard(vehicle, dom.theta_max_deg, "domain.theta_max_deg", stacklevel=3)
    minv, lips, fixed = [], [], []
    bound, pred, meas, meas_noise, meas_rms, trunc = (
        np.full((sc.size, 2), np.nan) for _ in range(6)
    )
    bounds = []
    for i, k in enumerate(sc):
        veh = scaled_inertia(vehicle, float(k))
        minv.append(float(np.linalg.norm(veh.minv, 2)))
        rep, rep_p = jacobian_pair(veh, dom, amp, samples)
        lips.append(rep.lipschitz)
        b_fixed = assemble_bound(m, h, eta_pct, v_pct, amp, rep, rep_p, (0.0, 0.0))
        fixed.append((b_fixed.eta.noise, b_fixed.v.noise))
        if not own_runs:
            continue
        clean: Trajectory
        clean, _ = reference_samples(veh, h, signal, None, T)
        own = Domain.from_trajectory(clean, veh.n_max, signal)
        pitch_guard(veh, own.theta_max_deg, "scales", stacklevel=3)
        r_own, r_own_p = jacobian_pair(veh, own, amp, samples)
        tr = truncation_errors(veh, m, clean, signal)
        b = assemble_bound(m, h, eta_pct, v_pct, amp, r_own, r_own_p, tr)
        bounds.append(b)
        bound[i] = b.total
        trunc[i] = tr
        p = path_prediction(veh, m, clean, amp, signal, eta_pct, v_pct)
        pred[i] = (p.eta, p.v)
        if validate:
            (row,) = monte_carlo_check(
                veh,
                [m],
                h,
                [(eta_pct, v_pct)],
                reference=clean,
                signal=signal,
                domain=own,
                seeds=seeds,
                samples=samples,
                workers=workers,
            )
            meas[i] = (row.measured_eta, row.measured_v)
            meas_noise[i] = (row.noise_eta, row.noise_v)
            meas_rms[i] = (row.rms_eta, row.rms_v)
    return InertiaSensitivity(
        scales=sc,
        minv_norm=np.array(minv),
        lipschitz=np.array(lips),
        noise_bound_fixed=np.array(fixed),
        bound=bound,
        predicted=pred,
        measured=meas,
        measured_noise=meas_noise,
        measured_rms=meas_rms,
        truncation=trunc,
        bounds=tuple(bounds),
        method=m.name,
        h=float(h),
        eta_pct=float(eta_pct),
        v_pct=float(v_pct),
        domain=dom,
    )
