"""Multi-step error: k-step-ahead predictions and free runs of each rule on sampled,
noisy data (what an MPC horizon sees, not only one step).

Data: the RexROV, open loop, under the paper's Fig. 6 thruster rpm (+1 % buoyancy),
exact samples (:func:`sampledyn.simulate`) with the paper's uniform measurement noise.
For each rule, h and noise level: the k-step-ahead predictions of
:meth:`~sampledyn.DiscreteModel.rollout` (z from the noisy data at n - k,
stepped k times with the applied inputs) against the exact samples, k = 1..K; and a
free run of the discrete model from the noisy data at the start of the window over the
whole window. Errors: rms over the window of the Euclidean norm of the position/angle
(eta) and velocity (v) parts of the error.

The BlueROV2 Heavy is left out: it pitches over open loop under the Fig. 6 input, and
with its roll-pitch hold (a ClosedLoop) the implicit Tustin step has no compiled
Jacobian kernel.

The study runs on the experiment engine with cells of kind ``multistep``
(:class:`MultistepCells`): the exact samples are simulated once per h and shared by
every rule, noise pair and seed; the k = 1..K predictions and the free run of a rule
on one noisy trajectory are its K + 1 cells, computed together.
"""

from __future__ import annotations

import math
import os
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._discretize import discretize
from .._discretize._model import check_rule
from .._noise import add_noise
from ..exceptions import SweepConfigError
from ..methods import DiscreteTimeSystem, get_method
from ._closed_loop import study_order
from ._studies import StudyDefinition
from .sweep import SweepConfig
from .sweep._cells import warning_text, worker_name
from .sweep._compute import CELL_ERRORS, ChunkResult, SimResult
from .sweep._prediction import PredictionCells

__all__ = [
    "MULTISTEP",
    "MULTISTEP_STUDY",
    "MultistepCells",
    "MultistepStudy",
    "run_multistep_study",
    "summarize_multistep",
]


@dataclass(frozen=True)
class MultistepStudy:
    """Settings (defaults: RexROV, T = 300 s, window from 50 s, K = 20 steps); the
    grid values are checked by the engine's
    :class:`~sampledyn.experiments.sweep.SweepConfig`, once.

    ``seed`` is the root of the noise seeds (seed k draws from
    SeedSequence([seed, k])); ``K`` the horizon (the measures are k = 1..K and the
    free run)."""

    vehicle: str = "rexrov"
    methods: tuple[str, ...] = ("E", "AB2", "AB4", "ABu4", "RK4", "T")
    h: tuple[float, ...] = (0.1, 0.5)
    noise_pairs: tuple[tuple[float, float], ...] = ((0, 0), (2, 2), (10, 10), (20, 20))
    seeds: int = 3
    T: float = 300.0
    after: float = 50.0
    K: int = 20
    buoyancy_pct: float = 1.0
    seed: int = 0


def _rms_norm(err: np.ndarray) -> float:
    if not np.isfinite(err).all() or np.abs(err).max(initial=0.0) > 1e100:
        return float("inf")
    return float(np.sqrt(np.mean(np.sum(err * err, axis=1))))


_FREE_RUN = "free run"
#: Largest horizon K of the multi-step study (see MultistepCells.check_options).
MAX_HORIZON = 1000


def _horizon(measure: str) -> int:
    """k of a measure "k=<k>" (0 for the free run)."""
    return 0 if measure == _FREE_RUN else int(measure.partition("=")[2])


class MultistepCells(PredictionCells):
    """The cells of the multi-step study: k-step-ahead predictions and a free run.

    Shared per h: the exact samples of the model under the input (as a prediction
    study, but every h simulated on its own). A cell: one rule's k-step-ahead
    predictions (:meth:`~sampledyn.DiscreteModel.rollout`, z from the noisy
    data at n - k, k steps with the applied inputs) against the exact samples on
    t >= after, for one noise pair and seed, or its free run over that window from
    the noisy state at its start (measure "free run"). ``err_eta`` and ``err_v`` are
    the rms over the window of the Euclidean norm of the eta and v parts of the error
    (inf where not finite or beyond 1e100); ``result``: ``k`` (0 for the free run)
    and ``diverged`` (an rms of 1e3 or more).

    Sweep-file key of its own: ``horizon = 20`` (K: the measures are k = 1..K and the
    free run).
    """

    name = "multistep"
    description = "k-step-ahead predictions and free runs of each rule's discrete model"
    uses = frozenset(
        ("buoyancy_pct", "input", "methods", "orders", "eta_pct", "v_pct", "noise", "seeds",
         "base_seed", "distribution", "rtol", "x0")
    )  # fmt: skip
    option_keys = ("horizon",)
    subsample = False
    measure_label = "horizons"
    measure_name = "horizon"
    columns = (("err_eta", float), ("err_v", float), ("k", int), ("diverged", bool))

    def check_method(self, name: str) -> None:
        check_rule(name, None)  # the grid's check names `methods`

    def check_options(self, options: Mapping[str, Any]) -> dict[str, Any]:
        K = options.get("horizon", 20)
        if isinstance(K, bool) or not isinstance(K, int) or K < 1:
            raise SweepConfigError("horizon", f"`horizon` must be an int >= 1, got {K!r}.")
        if K > MAX_HORIZON:
            raise SweepConfigError(
                "horizon",
                f"`horizon` = {K:.4g} is above {MAX_HORIZON}: every k = 1..K is a cell per "
                "rule, noise pair and seed, and its k-step rollout costs k steps per sample; "
                "an MPC horizon is tens of steps.",
            )
        return {"horizon": K}

    def measures(self, config: Any) -> tuple[str, ...]:
        """k = 1..K and the free run; refused (SweepConfigError naming `after`) when
        the window starts before every prediction exists (:func:`check_window`)."""
        K = config.options["horizon"]
        check_window(config.after, config.h, config.methods, K)
        return (*(f"k={k}" for k in range(1, K + 1)), _FREE_RUN)

    def compute(self, setup: Any, shared: SimResult, chunk: Any) -> ChunkResult:
        worker = worker_name()
        rows: list[dict[str, Any]] = []
        exact = shared.traj
        start = int(round(setup.after / chunk.h))
        for group in chunk.groups:
            meas = None
            if exact is not None:
                seq = np.random.SeedSequence([setup.base_seed, group.seed])
                meas = add_noise(
                    exact, group.eta_pct, group.v_pct, seq, distribution=setup.distribution
                )
            by_method: dict[str, list[tuple[str, str]]] = {}
            for key, method, measure in group.cells:
                by_method.setdefault(method, []).append((key, measure))
            for method, cells in by_method.items():
                t0 = time.perf_counter()
                found: dict[str, tuple[float, float]] = {}
                error = "" if exact is not None else str(shared.meta.get("error", "failed"))
                with warnings.catch_warnings(record=True) as caught:
                    warnings.simplefilter("always")
                    try:
                        if meas is not None:
                            dm = discretize(setup.model, method, chunk.h)
                            for _key, measure in cells:
                                found[measure] = _errors(dm, meas, exact, start, measure)
                    except (*CELL_ERRORS, NotImplementedError) as exc:
                        error = f"{type(exc).__name__}: {exc}"[:400]
                msgs = warning_text(caught)
                seconds = (time.perf_counter() - t0) / len(cells)
                for key, measure in cells:
                    pos, vel = found.get(measure, (math.nan, math.nan))
                    values = {"err_eta": pos, "err_v": vel} if error else {
                        "err_eta": pos, "err_v": vel, "k": _horizon(measure),
                        "diverged": not max(pos, vel) < 1e3,
                    }  # fmt: skip
                    rows.append(
                        {
                            "key": key, "status": "error" if error else "ok",
                            "values": values, "seconds": seconds, "error": error,
                            "warnings": msgs, "worker": worker,
                        }
                    )  # fmt: skip
        return ChunkResult(chunk.traj_key, shared.meta, rows)


def check_window(after: float, hs: Sequence[float], methods: Sequence[str], K: int) -> None:
    """Raise a SweepConfigError naming `after` if the window t >= after starts before
    the K-step-ahead predictions of every rule exist: the prediction of sample n
    starts from the data at n - K and the rule's history before it, so it needs
    n >= K + history - 1 (history: the samples z keeps, 1 for a one-step rule, s for
    AB_s). Without the check the rows before it are NaN (no prediction), which the
    rms counted as a divergence of every rule at large k.
    """
    history, rule = max((_history(m), m) for m in methods)
    for h in hs:
        first = K + history - 1
        start = int(round(after / h))
        if start < first:
            raise SweepConfigError(
                "after",
                f"`after` = {after:g} s starts the window at sample {start} of h = "
                f"{h:g} s, before the {K}-step-ahead predictions exist (from sample "
                f"{first}: {K} steps and {rule}'s {history} sample(s) of history); give "
                f"`after` >= {first * h:g} s (or, in a sweep file, a smaller `horizon`).",
            )


def _history(method: str) -> int:
    """The samples of history the rule's z keeps (1 for a one-step rule)."""
    rule = get_method(method)
    assert isinstance(rule, DiscreteTimeSystem)  # the others are refused by check_method
    return max(lag for _, lag in rule.discrete_step.layout) + 1


def _errors(dm: Any, meas: Any, exact: Any, start: int, measure: str) -> tuple[float, float]:
    """(eta, v) rms errors of the k-step-ahead predictions or the free run."""
    k = _horizon(measure)
    with np.errstate(all="ignore"):
        if k:
            err = dm.rollout(meas, k)[start:] - exact.x[start:]
        else:
            z0 = dm.state_from_data(meas, start)
            run = dm.simulate(z0, meas.u[start:-1], float(meas.t[start]))[:, : dm.nx]
            err = run - exact.x[start:]
    return _rms_norm(err[:, :6]), _rms_norm(err[:, 6:])


MULTISTEP = MultistepCells()


def _config(study: MultistepStudy) -> SweepConfig:
    """The engine's grid of ``study`` (checked when made)."""
    return SweepConfig(
        kind=MULTISTEP.name,
        vehicle=study.vehicle,
        buoyancy_pct=study.buoyancy_pct,
        inputs=({"name": "fig6"},),
        T=study.T,
        after=study.after,
        h=tuple(study.h),
        methods=tuple(study.methods),
        noise=tuple((float(e), float(v)) for e, v in study.noise_pairs),
        seeds=range(study.seeds) if isinstance(study.seeds, int) else study.seeds,
        base_seed=study.seed,
        options={"horizon": study.K},
    )


class MultistepDefinition(StudyDefinition):
    """The multi-step study: one engine run."""

    name = "multistep"
    settings_type = MultistepStudy

    def configs(self, settings: MultistepStudy) -> tuple[SweepConfig, ...]:
        return (_config(settings),)

    def rows(self, settings: MultistepStudy, results: Sequence[Any]) -> list[dict[str, Any]]:
        """Rows in the study's order: h, method, noise pair, seed, k (free run last)."""
        (result,) = results
        order = study_order(settings)
        rows = []
        for c in result.cells:
            k = _horizon(c["horizon"])
            rows.append(
                (
                    (*order(c), k or settings.K + 1),  # the free run (k = 0) last
                    {
                        "method": c["method"], "h": float(c["h"]), "eta_pct": float(c["eta_pct"]),
                        "v_pct": float(c["v_pct"]), "seed": int(c["seed"]), "k": k,
                        "pos_rms": c["err_eta"], "vel_rms": c["err_v"],
                        "diverged": c["diverged"] is not False,  # a failed cell: True
                    },
                )
            )  # fmt: skip
        return [row for _order, row in sorted(rows, key=lambda r: r[0])]

    def summary(self, settings: MultistepStudy, rows: list[dict[str, Any]]) -> list[dict]:
        return summarize_multistep(rows)


#: The registered study ``reproduce multistep``.
MULTISTEP_STUDY = MultistepDefinition()


def run_multistep_study(
    study: MultistepStudy,
    progress: Callable[[str], None] | None = None,
    *,
    store: str | os.PathLike[str] | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    progress_bar: bool = False,
) -> list[dict[str, Any]]:
    """Rows (method, h, eta_pct, v_pct, seed, k, pos_rms, vel_rms, diverged); k = 0 is the
    free run; ``diverged``: a non-finite or > 1e3 rms error. Computed on the
    experiment engine (cells of kind ``multistep``; ``store``, ``workers``,
    ``scheduler``, ``progress_bar`` as :func:`sampledyn.experiments.
    run_closed_loop_study`; ``progress`` gets one line: what the engine computed)."""
    return MULTISTEP_STUDY.run(
        study, store=store, workers=workers, scheduler=scheduler, progress=progress_bar,
        say=progress,
    ).rows  # fmt: skip


def summarize_multistep(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Mean over seeds per (method, h, eta_pct, v_pct, k)."""
    groups: dict[tuple[Any, ...], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["method"], r["h"], r["eta_pct"], r["v_pct"], r["k"]), []).append(r)
    out = []
    for key, rs in groups.items():
        cell = dict(zip(("method", "h", "eta_pct", "v_pct", "k"), key, strict=True))
        for m in ("pos_rms", "vel_rms"):
            cell[m] = float(np.mean([r[m] for r in rs]))
        cell["diverged"] = int(sum(bool(r["diverged"]) for r in rs))
        out.append(cell)
    return out
