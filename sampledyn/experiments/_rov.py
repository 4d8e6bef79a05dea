"""The ROV case study of section 6 (Figs. 6-7), a built-in study of the engine.

The study is the sweep file ``studies/fig7.toml`` (the same grid as
``examples/sweep_fig7.toml``): exact samples of a vehicle under the Fig. 6 thruster
input, simulated once at h = 0.1 s (h = 0.5 s takes every fifth sample); for every
noise pair (eta %, v %) and seed, uniform white noise is added, the one-step
predictors are fed with the noisy samples, and the disturbed local errors (section
5.1: measurement minus prediction) are measured on t >= after, separately for
positions/angles (eta) and rates (v). Which model and input each rule predicts with,
open or closed loop, is the engine's rule (:func:`sampledyn.experiments.sweep.
prediction_inputs`).

By default the RexROV runs open loop, as the paper ran its vehicle; the study file's
``per_vehicle`` table says what each vehicle uses (the BlueROV2 Heavy, which tumbles
under the Fig. 6 input, gets a roll-pitch hold).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from ..exceptions import ArgumentError
from ._studies import StudyDefinition

__all__ = [
    "FIG7",
    "FIG7_NORMS",
    "FIG7_STUDY_FILE",
    "ROVStudy",
    "fig7_rows",
    "fig7_vehicle",
    "run_rov_study",
    "summarize_rov",
]

#: The built-in Fig. 7 study (a sweep file).
FIG7_STUDY_FILE = Path(__file__).parent / "studies" / "fig7.toml"
#: The norms the Fig. 7 study reports (the paper's: Euclidean over the six eta (m and
#: rad mixed) and over the six v components (m/s and rad/s mixed)).
FIG7_NORMS = ("l2_over_n", "rms")
#: The same norms split by unit, for the figure: column prefix -> (units, block).
SPLIT = {
    "lin_pos": (("m", "m/s"), "eta"),  # positions (m)
    "ang_pos": (("rad", "rad/s"), "eta"),  # Euler angles (rad)
    "lin_vel": (("m", "m/s"), "v"),  # linear velocities (m/s)
    "ang_vel": (("rad", "rad/s"), "v"),  # angular rates (rad/s)
}
_HOLD = "roll_pitch_hold"


def fig7_vehicle(vehicle: Any, buoyancy_pct: float = 1.0) -> Any:
    """The vehicle with its displaced volume set so that B = (1 + pct/100) W."""
    return vehicle.with_buoyancy(buoyancy_pct)


@dataclass(frozen=True)
class ROVStudy:
    """Settings of the Fig. 7 study; None keeps the built-in study's value
    (:data:`FIG7_STUDY_FILE`: the paper's settings on the RexROV, and what its
    ``per_vehicle`` table says for the vehicle).

    Attributes
    ----------
    vehicle : str
        Built-in vehicle name or path of a vehicle file (default "rexrov").
    T, after : float
        Duration and start of the error window (s). Paper: 5000 and 1000.
    h : tuple of float
        Sampling periods (s). Paper: 0.1 and 0.5.
    noise_pairs : tuple of (eta %, v %)
        Paper: the 12 pairs of Fig. 7.
    methods : tuple of str
        Paper: AB1 and AB4; AB2, AB3 and RK4 are extra columns.
    seeds : int
        Monte Carlo repetitions per noisy cell (the noise-free cell runs once).
    seed : int
        Root of the noise seeds: seed k of a cell draws from SeedSequence([seed, k]).
    buoyancy_pct : float
        Positive buoyancy of the experiment in percent of the weight (paper: 1 %); the
        vehicle file keeps its published volume, the experiment scales it.
    distribution : str
        "uniform" (the paper's) or "gaussian".
    attitude_hold : bool or None
        Close a roll-pitch PD loop on the vertical thrusters
        (:class:`sampledyn.models.AttitudeHold`) or not; None: what the study's
        ``per_vehicle`` table says for the vehicle (the BlueROV2 Heavy: yes; every
        other vehicle: no, as in the paper). With the hold the thrusters turn at the
        Fig. 6 rpm plus the loop's correction, and the measured input is that applied
        rpm.
    hold_gains : (kp, kd) or None
        Gains of the hold (N m/rad, N m s/rad, > 0); None: the study table's for the
        vehicle (``feedback_tuning``: RexROV 16000 and 7200, BlueROV2 Heavy 40 and 6),
        else the law's defaults (40 and 6).
    rtol : float
        Tolerance of the exact samples (atol the same).
    norm : str
        The norm of the table and figure (:data:`FIG7_NORMS`).

    Raises
    ------
    ValueError
        for gains that are not two numbers > 0, or gains with the hold switched off.
    """

    vehicle: str | None = None
    T: float | None = None
    after: float | None = None
    h: tuple[float, ...] | None = None
    noise_pairs: tuple[tuple[float, float], ...] | None = None
    methods: tuple[str, ...] | None = None
    seeds: int | None = None
    seed: int | None = None
    buoyancy_pct: float | None = None
    distribution: str | None = None
    attitude_hold: bool | None = None
    hold_gains: tuple[float, float] | None = None
    rtol: float | None = None
    norm: str = FIG7_NORMS[0]

    def __post_init__(self) -> None:
        gains = self.hold_gains
        if gains is not None and (
            len(gains) != 2 or not all(isinstance(g, int | float) and math.isfinite(g) and g > 0
                                       for g in gains)
        ):  # fmt: skip
            raise ArgumentError(
                "hold_gains",
                "`hold_gains` must be two numbers > 0, KP (N m/rad) and KD (N m s/rad), e.g. "
                f"16000,7200; got {','.join(f'{g:g}' for g in gains)}.",
            )
        if gains is not None and self.attitude_hold is False:
            raise ArgumentError(
                "hold_gains",
                "`hold_gains` are gains of the attitude hold, and `attitude_hold` switches it "
                "off; give one or the other.",
            )
        if self.norm not in FIG7_NORMS:
            raise ValueError(
                f"the Fig. 7 study reports the norms {', '.join(FIG7_NORMS)}, not {self.norm!r}."
            )

    def config(self, base_dir: str | os.PathLike[str] | None = None) -> Any:
        """The sweep grid of this study: the study file read for the vehicle, with the
        values given here (relative vehicle paths resolve against ``base_dir``,
        default the working directory).

        Raises
        ------
        SweepConfigError
            naming a bad setting (a ``ValueError``).
        """
        from ..models._names import is_model_file
        from .sweep import load_config

        vehicle = self.vehicle
        if vehicle is not None and base_dir is not None and not Path(vehicle).is_absolute():
            vehicle = str(Path(base_dir) / vehicle) if is_model_file(vehicle) else vehicle
        base = load_config(FIG7_STUDY_FILE, vehicle=vehicle)
        given: dict[str, Any] = {
            "T": self.T, "after": self.after, "h": self.h, "noise": self.noise_pairs,
            "methods": self.methods, "seeds": None if self.seeds is None else range(self.seeds),
            "base_seed": self.seed, "buoyancy_pct": self.buoyancy_pct,
            "distribution": self.distribution, "rtol": self.rtol,
        }  # fmt: skip
        config = replace(base, **{k: v for k, v in given.items() if v is not None})
        return self._feedback(config)

    def _feedback(self, config: Any) -> Any:
        """``config`` with the hold the switches ask for (the table's otherwise)."""
        gains = {}
        if self.hold_gains is not None:
            gains = dict(zip(("kp", "kd"), self.hold_gains, strict=True))
        held = config.feedback is not None and config.feedback["law"] == _HOLD
        if self.attitude_hold is False:
            return config.with_feedback(None)
        if self.attitude_hold is None and not gains:
            return config
        if self.attitude_hold is None and not held:
            raise ArgumentError(
                "hold_gains",
                f"`hold_gains` are gains of the attitude hold, which {config.vehicle!r} does "
                "not use by default; switch `attitude_hold` on.",
            )
        if held:
            return replace(config, feedback={**config.feedback, **gains})
        return config.with_feedback(_HOLD, **gains)


def _columns(norm: str, norms: tuple[str, ...]) -> list[tuple[str, str]]:
    """(column, block) pairs a cell of ``norm`` fills (the norm read by the engine's
    one parser, :func:`~sampledyn.experiments.sweep._norms.parse_norm`)."""
    from .sweep._norms import parse_norm

    spec = parse_norm(norm)
    if spec.kind not in norms or spec.part != "disturbed" or spec.mask is not None:
        return []
    if spec.units is None:
        return [(f"pos_{spec.kind}", "eta"), (f"vel_{spec.kind}", "v")]
    return [(f"{p}_{spec.kind}", b) for p, (u, b) in SPLIT.items() if u == spec.units]


def fig7_rows(
    cells: list[dict[str, Any]], norms: tuple[str, ...] = FIG7_NORMS
) -> list[dict[str, Any]]:
    """One row per (h, noise pair, seed, method) from the engine's cells, with the
    position and velocity norms ``pos_<norm>``, ``vel_<norm>`` (the paper's: m and rad
    mixed, m/s and rad/s mixed) and, where the study computed them, the same split by
    unit (``lin_pos_``, ``ang_pos_``, ``lin_vel_``, ``ang_vel_<norm>``: m, rad, m/s,
    rad/s); NaN where the cell failed (its message in ``error``)."""
    rows: dict[tuple[Any, ...], dict[str, Any]] = {}
    columns_of: dict[str, list[tuple[str, str]]] = {}
    for c in cells:
        if c["norm"] not in columns_of:
            columns_of[c["norm"]] = _columns(c["norm"], norms)
        columns = columns_of[c["norm"]]
        if not columns:
            continue
        key = (c["h"], c["eta_pct"], c["v_pct"], c["seed"], c["method"])
        row = rows.setdefault(key, {k: c[k] for k in _INDEX})
        ok = c["status"] == "ok"
        for column, block in columns:
            row[column] = float(c[f"err_{block}"]) if ok else math.nan
        if not ok:
            row["error"] = c.get("error") or "failed"
    split = [f"{p}_{n}" for p in SPLIT for n in norms]
    have = {k for r in rows.values() for k in r}
    order = [f"{q}_{n}" for q in ("pos", "vel") for n in norms] + [k for k in split if k in have]
    return [
        {**{k: r[k] for k in _INDEX},
         **{k: r.get(k, math.nan) for k in order},
         **({"error": r["error"]} if "error" in r else {})}
        for r in rows.values()
    ]  # fmt: skip


_INDEX = ("h", "eta_pct", "v_pct", "seed", "method")


def summarize_rov(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Mean and standard deviation over seeds, one row per (h, noise pair, method)."""
    import numpy as np

    groups: dict[tuple[Any, ...], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["h"], r["eta_pct"], r["v_pct"], r["method"]), []).append(r)
    out = []
    keys = [k for k in rows[0] if k.startswith(("pos_", "vel_", *(f"{p}_" for p in SPLIT)))]
    for (h, e, v, m), grp in groups.items():
        row: dict[str, Any] = {"h": h, "eta_pct": e, "v_pct": v, "method": m, "seeds": len(grp)}
        for k in keys:
            vals = np.array([g[k] for g in grp])
            row[k] = float(vals.mean())
            row[f"{k}_std"] = float(vals.std(ddof=1)) if vals.size > 1 else 0.0
        out.append(row)
    return out


class Fig7Study(StudyDefinition):
    """The Fig. 7 study (one engine run: the study file read for the vehicle)."""

    name = "fig7"
    settings_type = ROVStudy

    def configs(self, settings: ROVStudy) -> tuple[Any, ...]:
        return (settings.config(),)

    def rows(self, settings: ROVStudy, results: Sequence[Any]) -> list[dict[str, Any]]:
        (result,) = results
        norms = tuple(n for n in result.study.config.norms if n in FIG7_NORMS) or FIG7_NORMS
        return fig7_rows(result.cells, norms)

    def summary(self, settings: ROVStudy, rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
        return summarize_rov(rows)

    def defaults(self) -> dict[str, Any]:
        """The study file's values (on its vehicle)."""
        c = ROVStudy().config()
        return {"h": c.h, "T": c.T, "after": c.after, "seeds": len(c.seeds),
                "seed": c.base_seed, "vehicle": c.vehicle, "methods": c.methods,
                "norm": ROVStudy.norm}  # fmt: skip

    def default_out(self, settings: ROVStudy, configs: Sequence[Any]) -> str:
        """``out/fig7`` for the study file's vehicle (the RexROV), ``out/fig7_<name>``
        for another, so one run does not overwrite the other."""
        (config,) = configs
        return fig7_out(config.vehicle)


def fig7_out(vehicle: str) -> str:
    """Default output folder of fig7 for ``vehicle`` (see :meth:`Fig7Study.default_out`)."""
    from .sweep import load_config

    default = load_config(FIG7_STUDY_FILE).vehicle
    return "out/fig7" if vehicle == default else f"out/fig7_{Path(vehicle).stem}"


#: The registered study ``reproduce fig7``.
FIG7 = Fig7Study()


def run_rov_study(
    study: ROVStudy | Any = None,
    *,
    store: str | os.PathLike[str] | None = None,
    workers: int | None = 2,
    scheduler: str | None = None,
    progress: bool = False,
) -> dict[str, Any]:
    """Run the Fig. 7 study on the engine.

    Parameters
    ----------
    study : ROVStudy or SweepConfig
        Default ``ROVStudy()``; a SweepConfig runs as it is.
    store : path, optional
        Results store: the cells are kept there, and a rerun (after a kill, say)
        computes only the missing ones.
    workers : int or None
        Local worker processes (None or 1: in this process).
    scheduler : str, optional
        Address of a Dask scheduler instead of local workers.
    progress : bool
        Show a progress bar.

    Returns
    -------
    dict with ``rows`` (one dict per h, noise pair, seed and method, with the position
    and velocity norms ``pos_l2_over_n``, ``pos_rms``, ``vel_l2_over_n``,
    ``vel_rms``), ``certificates`` (h -> max scaled per-interval flow error of the
    exact samples), ``motion`` (h -> statistics of the forced motion), ``model`` (its
    label), ``config`` (the SweepConfig) and ``summary`` (what the run computed).
    """
    settings = ROVStudy() if study is None else study
    configs = None if isinstance(settings, ROVStudy) else (settings,)
    run = FIG7.run(
        settings if isinstance(settings, ROVStudy) else ROVStudy(),
        configs=configs, store=store, workers=workers, scheduler=scheduler, progress=progress,
    )  # fmt: skip
    (result,) = run.results
    return {
        "rows": run.rows,
        "certificates": result.certificates(),
        "motion": result.summaries(),
        "model": next(iter(result.study.trajectories.values()))["vehicle"],
        "config": result.study.config,
        "summary": result.summary,
    }
