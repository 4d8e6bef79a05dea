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
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .sweep import SweepConfig, backend_options, run_study

__all__ = [
    "FIG7_STUDY_FILE",
    "NORMS",
    "ROVStudy",
    "fig7_rows",
    "fig7_vehicle",
    "run_rov_study",
    "summarize",
]

#: The built-in Fig. 7 study (a sweep file).
FIG7_STUDY_FILE = Path(__file__).parent / "studies" / "fig7.toml"
#: The norms the Fig. 7 study reports (the paper's: Euclidean over the six eta (m and
#: rad mixed) and over the six v components (m/s and rad/s mixed)).
NORMS = ("l2_over_n", "rms")
#: The same norms split by unit, for the figure: column prefix -> (units, block).
SPLIT = {
    "lin_pos": ("m,m/s", "eta"),  # positions (m)
    "ang_pos": ("rad,rad/s", "eta"),  # Euler angles (rad)
    "lin_vel": ("m,m/s", "v"),  # linear velocities (m/s)
    "ang_vel": ("rad,rad/s", "v"),  # angular rates (rad/s)
}
_HOLD = "roll_pitch_hold"


def fig7_vehicle(vehicle: Any, buoyancy_pct: float = 1.0) -> Any:
    """The vehicle with its displaced volume set so that B = (1 + pct/100) W."""
    return vehicle.with_buoyancy(buoyancy_pct)


@dataclass(frozen=True)
class ROVStudy:
    """Settings of the Fig. 7 study; None keeps the built-in study's value
    (:data:`FIG7_STUDY_FILE`: the paper's settings on the RexROV).

    Attributes
    ----------
    vehicle : str
        Built-in vehicle name or path of a vehicle file (default "rexrov").
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
    distribution : str
        "uniform" (the paper's) or "gaussian".
    attitude_hold : bool or None
        Close a roll-pitch PD loop on the vertical thrusters
        (:class:`sampledyn.models.AttitudeHold`) or not; None: what the study's
        ``per_vehicle`` table says for the vehicle (the BlueROV2 Heavy: yes; every
        other vehicle: no, as in the paper). With the hold the thrusters turn at the
        Fig. 6 rpm plus the loop's correction, and the measured input is that applied
        rpm.
    kp, kd : float or None
        Gains of the hold (N m/rad, N m s/rad); None: the study table's for the
        vehicle (``feedback_tuning``: RexROV 16000 and 7200, BlueROV2 Heavy 40 and 6),
        else the law's defaults (40 and 6).
    rtol : float
        Tolerance of the exact samples (atol the same).
    """

    vehicle: str | None = None
    T: float | None = None
    after: float | None = None
    h_values: tuple[float, ...] | None = None
    noise_pairs: tuple[tuple[float, float], ...] | None = None
    methods: tuple[str, ...] | None = None
    seeds: int | None = None
    base_seed: int | None = None
    buoyancy_pct: float | None = None
    distribution: str | None = None
    attitude_hold: bool | None = None
    kp: float | None = None
    kd: float | None = None
    rtol: float | None = None

    def config(self, base_dir: str | os.PathLike[str] | None = None) -> SweepConfig:
        """The sweep grid of this study (relative vehicle paths resolve against
        ``base_dir``, default the working directory).

        Raises
        ------
        SweepConfigError
            naming a bad setting (a ``ValueError``).
        """
        data: dict[str, Any] = tomllib.loads(FIG7_STUDY_FILE.read_text())
        for key, value in (
            ("vehicle", self.vehicle),
            ("T", self.T),
            ("after", self.after),
            ("h", None if self.h_values is None else list(self.h_values)),
            ("noise", None if self.noise_pairs is None else [list(p) for p in self.noise_pairs]),
            ("methods", None if self.methods is None else list(self.methods)),
            ("seeds", self.seeds),
            ("base_seed", self.base_seed),
            ("buoyancy_pct", self.buoyancy_pct),
            ("distribution", self.distribution),
            ("rtol", self.rtol),
        ):
            if value is not None:
                data[key] = value
        feedback = self._feedback(data)
        if feedback is not None:
            data["feedback"] = feedback
        base = Path.cwd() if base_dir is None else Path(base_dir)
        return SweepConfig.from_mapping(data, base_dir=base)

    def _feedback(self, data: dict[str, Any]) -> Any:
        """The ``feedback`` entry the switches ask for (None: the table decides). Gains
        not given here come from the table's ``feedback_tuning`` for the vehicle."""
        vehicle = str(data["vehicle"])
        table = data.get("per_vehicle", {})
        entry = table.get(vehicle) or table.get(Path(vehicle).stem) or {}
        listed = entry.get("feedback")
        gains = {k: v for k, v in (("kp", self.kp), ("kd", self.kd)) if v is not None}
        if self.attitude_hold is False:
            if gains:
                raise ValueError("`kp`/`kd` are gains of the attitude hold; it is switched off.")
            return "none"
        if self.attitude_hold is None and not gains:
            return None
        if self.attitude_hold is None and (listed is None or listed.get("law") != _HOLD):
            raise ValueError(
                f"`kp`/`kd` are gains of the attitude hold, which {vehicle!r} does not use by "
                "default; switch it on (attitude_hold=True, --attitude-hold)."
            )
        hold = dict(listed) if listed is not None and listed.get("law") == _HOLD else {"law": _HOLD}
        return {**hold, **gains}


def _columns(norm: str, norms: tuple[str, ...]) -> list[tuple[str, str]]:
    """(column, block) pairs a cell of ``norm`` fills."""
    if norm in norms:
        return [(f"pos_{norm}", "eta"), (f"vel_{norm}", "v")]
    kind, _, rest = norm.partition("[")
    units = rest.rstrip("]")
    if kind not in norms:
        return []
    return [(f"{p}_{kind}", b) for p, (u, b) in SPLIT.items() if u == units]


def fig7_rows(cells: list[dict[str, Any]], norms: tuple[str, ...] = NORMS) -> list[dict[str, Any]]:
    """One row per (h, noise pair, seed, method) from the engine's cells, with the
    position and velocity norms ``pos_<norm>``, ``vel_<norm>`` (the paper's: m and rad
    mixed, m/s and rad/s mixed) and, where the study computed them, the same split by
    unit (``lin_pos_``, ``ang_pos_``, ``lin_vel_``, ``ang_vel_<norm>``: m, rad, m/s,
    rad/s); NaN where the cell failed (its message in ``error``)."""
    rows: dict[tuple[Any, ...], dict[str, Any]] = {}
    for c in cells:
        columns = _columns(c["norm"], norms)
        if not columns:
            continue
        key = (c["h"], c["eta_pct"], c["v_pct"], c["seed"], c["method"])
        row = rows.setdefault(
            key,
            {"h": c["h"], "eta_pct": c["eta_pct"], "v_pct": c["v_pct"], "seed": c["seed"],
             "method": c["method"]},
        )  # fmt: skip
        ok = c["status"] == "ok"
        for column, block in columns:
            row[column] = float(c[f"err_{block}"]) if ok else math.nan
        if not ok:
            row["error"] = c.get("error") or "failed"
    split = [f"{p}_{n}" for p in SPLIT for n in norms]
    have = {k for r in rows.values() for k in r}
    order = [f"{q}_{n}" for q in ("pos", "vel") for n in norms] + [k for k in split if k in have]
    return [
        {**{k: r[k] for k in ("h", "eta_pct", "v_pct", "seed", "method")},
         **{k: r.get(k, math.nan) for k in order},
         **({"error": r["error"]} if "error" in r else {})}
        for r in rows.values()
    ]  # fmt: skip


def run_rov_study(
    study: ROVStudy | SweepConfig = ROVStudy(),
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
    if workers is not None and (isinstance(workers, bool) or workers < 1):
        raise ValueError(f"`workers` must be a positive int, got {workers!r}.")
    cfg = study.config() if isinstance(study, ROVStudy) else study
    result = run_study(cfg, store, **backend_options(workers, scheduler, progress))
    norms = tuple(n for n in cfg.norms if n in NORMS) or NORMS
    certificates: dict[float, float] = {}
    motion: dict[float, dict[str, float]] = {}
    for t in sorted(result.trajectories.values(), key=lambda r: r["h"]):
        h = float(t["h"])
        cert = t.get("certificate")
        certificates[h] = math.nan if cert is None else float(cert)
        motion[h] = dict(t.get("summary") or {})
    label = next(iter(result.study.trajectories.values()))["vehicle"]
    return {
        "rows": fig7_rows(result.cells, norms),
        "certificates": certificates,
        "motion": motion,
        "model": label,
        "config": cfg,
        "summary": result.summary,
    }


def summarize(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Mean and standard deviation over seeds, one row per (h, noise pair, method)."""
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
