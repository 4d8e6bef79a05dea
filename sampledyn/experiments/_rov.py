"""The ROV case study of section 6 (Figs. 6-7) on a published vehicle.

Exact samples of the vehicle under the Fig. 6 thruster input are simulated once per
sampling period h; for every noise pair (eta %, v %) and seed, uniform white noise is
added, AB_s (and RK4) one-step predictors are fed with the noisy samples, and the
disturbed local errors (section 5.1: measurement minus prediction) are measured on
t >= after, separately for positions (eta) and rates (v).
"""

from __future__ import annotations

import math
import multiprocessing
import os
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import error_norms, local_errors
from ..methods import get_method
from ..noise import add_noise
from ..signals import fig6_thrusters
from ..simulate import simulate
from ._paper_fig7 import FIG7_NOISE_PAIRS
from .sweep import worker_init

__all__ = ["ROVStudy", "fig7_vehicle", "run_rov_study", "summarize"]

NORMS = ("l2_over_n", "rms")


@dataclass(frozen=True)
class ROVStudy:
    """Settings of the Fig. 7 study (defaults: the paper's).

    Attributes
    ----------
    vehicle : str
        Built-in vehicle name or path of a vehicle file.
    T, after : float
        Duration and start of the error window (s). Paper: 5000 and 1000.
    h_values : tuple of float
        Sampling periods (s). Paper: 0.1 and 0.5.
    noise_pairs : tuple of (eta %, v %)
        Paper: the 12 pairs of Fig. 7.
    methods : tuple of str
        Paper: AB1 and AB4; AB2, AB3 and RK4 are extra columns.
    seeds : int
        Monte Carlo repetitions per noisy cell (the noise-free cell runs once).
    base_seed : int
        Root of the noise seeds: seed k of a cell draws from SeedSequence([base_seed, k]).
    buoyancy_pct : float
        Positive buoyancy of the experiment in percent of the weight (paper: 1 %); the
        vehicle file keeps its published volume, the experiment scales it.
    attitude_hold, kp, kd : bool, float, float
        Close a roll-pitch PD loop on the vertical thrusters
        (:class:`sampledyn.models.AttitudeHold`, gains in N m/rad and N m s/rad). Not in
        the paper, whose input is open loop; without it the BlueROV2 Heavy pitches over
        under the Fig. 6 input (see the README). The thrusters then turn at the Fig. 6
        rpm plus the loop's correction, and the measured input is that applied rpm.
    rtol : float
        Tolerance of the exact samples (atol the same): 1e-11 keeps the certified
        per-interval flow error near 5e-12, 20 times below the 1e-10 asked for.
    """

    vehicle: str = "bluerov2_heavy"
    T: float = 5000.0
    after: float = 1000.0
    h_values: tuple[float, ...] = (0.1, 0.5)
    noise_pairs: tuple[tuple[float, float], ...] = FIG7_NOISE_PAIRS
    methods: tuple[str, ...] = ("AB1", "AB2", "AB3", "AB4", "RK4")
    seeds: int = 10
    base_seed: int = 0
    buoyancy_pct: float = 1.0
    distribution: str = "uniform"
    attitude_hold: bool = True
    kp: float = 40.0
    kd: float = 6.0
    rtol: float = 1e-11

    def __post_init__(self) -> None:
        if not self.after < self.T:
            raise ValueError(f"`after` = {self.after} s must be below T = {self.T} s.")
        if self.seeds < 1:
            raise ValueError(f"`seeds` must be >= 1, got {self.seeds}.")
        for name in self.methods:
            get_method(name)


def fig7_vehicle(vehicle: Any, buoyancy_pct: float = 1.0) -> Any:
    """The vehicle with its displaced volume set so that B = (1 + pct/100) W."""
    return vehicle.with_buoyancy(buoyancy_pct)


def _cell_rows(
    model: Any,
    measured: Any,
    methods: tuple[str, ...],
    after: float,
    *,
    rk_model: Any = None,
    rk_u: Any = None,
    signal: Any = None,
) -> list[dict[str, Any]]:
    """Error norms of every method on one measured trajectory.

    Rules that use f at the samples only (AB_s) predict with ``model`` and the
    measured (applied) input, f evaluated once and shared. Rules that evaluate f
    between samples (RK_s, T) predict with ``rk_model`` (default ``model``) fed with
    the input samples ``rk_u`` (default the measured ones) and ``signal`` between
    samples.
    """
    rows = []
    cache: dict[Any, Any] = {}
    n_eta = 6
    for name in methods:
        method = get_method(name)
        if not method.intersample:
            x_hat = method.predict(model, measured, cache=cache)
        else:
            data = measured if rk_u is None else measured.replace(u=rk_u)
            x_hat = method.predict(rk_model or model, data, signal)
        err = local_errors(x_hat, measured)
        row: dict[str, Any] = {"method": method.name}
        for q, comp in (("pos", slice(0, n_eta)), ("vel", slice(n_eta, 2 * n_eta))):
            for kind, value in error_norms(err, measured.t, NORMS, after, comp).items():
                row[f"{q}_{kind}"] = value
        rows.append(row)
    return rows


# Data shared with forked worker processes (set before the pool starts).
_SHARED: dict[str, Any] = {}


def _run_cells(task: tuple[int, tuple[float, float], tuple[int, ...]]) -> list[dict[str, Any]]:
    """Rows of the cells (h index, noise pair, seeds); runs in a worker or in-process."""
    hi, (eta_pct, v_pct), seeds = task
    d = _SHARED
    study: ROVStudy = d["study"]
    traj = d["trajs"][hi]
    rows = []
    for k in seeds:
        seq = np.random.SeedSequence([study.base_seed, k])
        measured = add_noise(traj, eta_pct, v_pct, seq, distribution=study.distribution)
        cell = _cell_rows(
            d["model"],
            measured,
            study.methods,
            study.after,
            rk_model=d["sim_model"],
            rk_u=d["u_ref"][hi],
            signal=d["stage_signal"],
        )
        h = study.h_values[hi]
        rows += [{"h": h, "eta_pct": eta_pct, "v_pct": v_pct, "seed": k, **r} for r in cell]
    return rows


def _certify_task(_: Any = None) -> Any:
    """The certified run (same samples, bit for bit, plus the certificate)."""
    d = _SHARED
    study = d["study"]
    traj = simulate(
        d["sim_model"], d["signal"], T=study.T, h=d["h_min"], rtol=study.rtol, atol=study.rtol
    )
    return traj.certificate


def run_rov_study(
    study: ROVStudy = ROVStudy(), *, progress: bool = False, workers: int = 2
) -> dict[str, Any]:
    """Run the Fig. 7 study.

    The exact samples are simulated once at the smallest h (the Fig. 6 input is
    continuous in time, so the samples at a multiple of it are a subsample). With
    ``workers`` > 1 the cells run on forked worker processes, and the accuracy
    certificate (a second, certified run of the same samples) is computed by one of
    them meanwhile.

    Returns
    -------
    dict with ``rows`` (one dict per h, noise pair, seed and method, with the position
    and velocity norms ``pos_l2_over_n``, ``pos_rms``, ``vel_l2_over_n``, ``vel_rms``),
    ``certificates`` (h -> max scaled per-interval flow error of the exact samples),
    ``motion`` (h -> a few statistics of the forced motion) and ``model``.
    """
    from ..models import AttitudeHold, load_vehicle

    if not isinstance(workers, int) or workers < 1:
        raise ValueError(f"`workers` must be a positive int, got {workers!r}.")
    model = fig7_vehicle(load_vehicle(study.vehicle), study.buoyancy_pct)
    signal = fig6_thrusters(model)
    sim_model = AttitudeHold(model, study.kp, study.kd) if study.attitude_hold else model
    h_min = min(study.h_values)
    ratios = [h / h_min for h in study.h_values]
    if not all(abs(r - round(r)) < 1e-9 for r in ratios):
        raise ValueError(f"every h must be a multiple of the smallest, got {study.h_values}.")
    parallel = workers > 1 and "fork" in multiprocessing.get_all_start_methods()
    shared = simulate(
        sim_model,
        signal,
        T=study.T,
        h=h_min,
        certify=not parallel,
        rtol=study.rtol,
        atol=study.rtol,
    )
    trajs, u_ref, motion = [], [], {}
    for h, ratio in zip(study.h_values, ratios, strict=True):
        exact = shared.subsample(int(round(ratio)))
        motion[h] = motion_summary(exact)
        # What a log records: the rpm the thrusters actually turn at.
        applied = sim_model.applied_rpm(exact.x, exact.u) if study.attitude_hold else exact.u
        trajs.append(exact.replace(u=applied, input_names=model.input_names))
        u_ref.append(exact.u)
    _SHARED.update(
        study=study, model=model, sim_model=sim_model, signal=signal, h_min=h_min,
        trajs=trajs, u_ref=u_ref, stage_signal=_MemoSignal(signal),
    )  # fmt: skip
    # One task per (h, noise pair), split in two seed halves to balance the workers.
    tasks = []
    for hi in range(len(study.h_values)):
        for pair in study.noise_pairs:
            seeds = tuple(range(1 if pair == (0, 0) else study.seeds))
            for part in (seeds[::2], seeds[1::2]):
                if part:
                    tasks.append((hi, pair, part))
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(tasks), desc="Fig. 7 cells", unit="task")
    rows: list[dict[str, Any]] = []
    cert = shared.certificate
    try:
        if parallel:
            ctx = multiprocessing.get_context("fork")
            with ProcessPoolExecutor(
                max_workers=workers,
                mp_context=ctx,
                initializer=worker_init,  # the workers die with this process
                initargs=(os.getpid(),),
            ) as pool:
                cert_future = pool.submit(_certify_task)
                for result in pool.map(_run_cells, tasks):
                    rows += result
                    if bar is not None:
                        bar.update(1)
                cert = cert_future.result()
        else:
            for task in tasks:
                rows += _run_cells(task)
                if bar is not None:
                    bar.update(1)
    finally:
        if bar is not None:
            bar.close()
        _SHARED.clear()
    certificates = {}
    for h, ratio in zip(study.h_values, ratios, strict=True):
        sub = shared.replace(certificate=cert).subsample(int(round(ratio))).certificate
        certificates[h] = sub.max_error if sub is not None else math.nan
    return {"rows": rows, "certificates": certificates, "motion": motion, "model": sim_model}


class _MemoSignal:
    """A signal whose stage inputs are computed once per grid: every seed of a cell
    asks for the same ``intersample(t, tau)``."""

    def __init__(self, signal: Any) -> None:
        self._signal = signal
        self.nu = signal.nu
        self._cache: dict[tuple[int, float, float, float], np.ndarray] = {}

    def __call__(self, t: Any) -> np.ndarray:
        return self._signal(t)

    def intersample(self, t_start: np.ndarray, tau: float) -> np.ndarray:
        key = (t_start.shape[0], float(t_start[0]), float(t_start[-1]), float(tau))
        if key not in self._cache:
            self._cache[key] = self._signal.intersample(t_start, tau)
        return self._cache[key]


def motion_summary(traj: Any) -> dict[str, float]:
    """Statistics of the forced motion: mean surge speed (m/s), depth change (m, NED z;
    negative = ascent), largest |pitch| and |roll| (deg), distance travelled (m)."""
    x = traj.x
    return {
        "mean_surge_m_s": float(x[:, 6].mean()),
        "depth_change_m": float(x[-1, 2] - x[0, 2]),
        "max_abs_pitch_deg": float(np.degrees(np.abs(x[:, 4]).max())),
        "max_abs_roll_deg": float(np.degrees(np.abs(x[:, 3]).max())),
        "distance_m": float(np.linalg.norm(np.diff(x[:, :3], axis=0), axis=1).sum()),
    }


def summarize(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Mean and standard deviation over seeds, one row per (h, noise pair, method)."""
    groups: dict[tuple[Any, ...], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["h"], r["eta_pct"], r["v_pct"], r["method"]), []).append(r)
    out = []
    keys = [k for k in rows[0] if k.startswith(("pos_", "vel_"))]
    for (h, e, v, m), grp in groups.items():
        row: dict[str, Any] = {"h": h, "eta_pct": e, "v_pct": v, "method": m, "seeds": len(grp)}
        for k in keys:
            vals = np.array([g[k] for g in grp])
            row[k] = float(vals.mean())
            row[f"{k}_std"] = float(vals.std(ddof=1)) if vals.size > 1 else 0.0
        out.append(row)
    return out
