"""The AUV-like case study of section 4 (Figs. 2 and 3), a built-in study of the engine.

For each input hold ratio h_u/h, exact samples of eqs. (9)-(10) are simulated under a
random multilevel input (levels uniform in [-10, 10]); every method's one-step-ahead
predictor is fed with those samples and its local errors are measured after the
transient, over all samples and over the samples away from input jumps (and from the
velocity's zero crossings).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ERROR_NORMS
from ..methods import Predictor, families, get_method, get_predictor
from ..models import AUVLike
from .sweep import SweepConfig, check_time_grid, fastest_time_constant, run_study

__all__ = [
    "AUVStudy",
    "auv_config",
    "fastest_time_constant",
    "fig2_methods",
    "fig3_methods",
    "run_auv_study",
]

#: The masked norms of Figs. 2-3 and their columns in the rows.
MASKED_NORMS = {"rms@away_from_jumps": "rms_away_from_jumps", "rms@smooth": "rms_smooth"}


def _multistep(fam: Any) -> bool:
    """A family of orders with a member that uses more than one past sample."""
    return fam.ordered and any(get_method(n).history > 1 for n in fam.names())


def _predictors(fam: Any) -> bool:
    """A family whose rules predict on sampled data (not ZOH, a discrete-time system)."""
    return isinstance(get_method(fam.names()[0]), Predictor)


def fig2_methods() -> tuple[str, ...]:
    """Fig. 2's rules: every registered multistep family of predictors (AB_s, ABu_s,
    ABe_s, ...), orders 1 to the family's default largest one, in registration order."""
    return tuple(
        n for fam in families() if _predictors(fam) and _multistep(fam) for n in fam.names()
    )


def fig3_methods() -> tuple[str, ...]:
    """Fig. 3's rules: every registered single predictor (E, T, Ee, ...) and every
    one-step family of orders (RK_s), in registration order."""
    return tuple(
        n for fam in families() if _predictors(fam) and not _multistep(fam) for n in fam.names()
    )


@dataclass(frozen=True)
class AUVStudy:
    """Settings of the AUV-like study.

    Attributes
    ----------
    methods : tuple of str
        Registry names (default :func:`fig2_methods`).
    hold_ratios : tuple of int
        h_u / h values, one curve each.
    h : float
        Sampling period (s). The default 0.01 s is about 1/30 of the fastest local time
        constant of (9)-(10) under |u| <= 10 (reported by :func:`fastest_time_constant`).
    T : float
        Duration of each run (s).
    after : float
        Errors are measured on t >= after (s), past the transient from x0 = 0.
    seed : int
        Seed of the multilevel input.
    x0 : tuple of float
        Initial state (x, y).
    """

    methods: tuple[str, ...] = field(default_factory=fig2_methods)
    hold_ratios: tuple[int, ...] = (1, 2, 5, 10, 20, 50, 100)
    h: float = 0.01
    T: float = 200.0
    after: float = 20.0
    seed: int = 0
    low: float = -10.0
    high: float = 10.0
    x0: tuple[float, float] = (1.0, 0.0)
    model: Any = field(default_factory=AUVLike)

    def __post_init__(self) -> None:
        if not (isinstance(self.h, int | float) and np.isfinite(self.h) and self.h > 0):
            raise ValueError(f"sampling period `h` must be > 0 s, got {self.h}.")
        for r in self.hold_ratios:
            if not isinstance(r, int | np.integer) or r < 1:
                raise ValueError(f"`hold_ratios` must be positive integers, got {r!r}.")
        check_time_grid(self.T, self.after, self.h)
        if (
            isinstance(self.seed, bool)
            or not isinstance(self.seed, int | np.integer)
            or self.seed < 0
        ):
            raise ValueError(
                f"`seed` (--seed) of the multilevel input must be an int >= 0, got {self.seed!r}."
            )


def auv_config(study: AUVStudy) -> SweepConfig:
    """The study as a grid of the engine: one multilevel input per h_u/h, no noise, the
    norms of :data:`sampledyn.errors.ERROR_NORMS` and the two masked rms."""
    inputs = tuple(
        {"name": "multilevel", "low": study.low, "high": study.high,
         "hold": ratio * study.h, "seed": study.seed}
        for ratio in study.hold_ratios
    )  # fmt: skip
    return SweepConfig(
        vehicle=str(getattr(study.model, "name", "auv_like")),
        inputs=inputs,
        T=study.T,
        after=study.after,
        h=(study.h,),
        methods=tuple(study.methods),
        noise=((0.0, 0.0),),
        seeds=(0,),
        norms=(*ERROR_NORMS, *MASKED_NORMS),
        x0=tuple(study.x0),
        summaries=("tau_min",),
        model=study.model,
    )


def run_auv_study(
    study: AUVStudy = AUVStudy(),
    *,
    progress: bool = False,
    store: Any = None,
    workers: int | None = None,
) -> list[dict[str, Any]]:
    """Local-error norms of every method for every h_u/h.

    Parameters
    ----------
    study : AUVStudy
    progress : bool
        Show a progress bar.
    store : path, optional
        Results store (resumable); default: in this process.
    workers : int, optional
        Local worker processes (default: in this process).

    Returns
    -------
    list of dict, one per (hold ratio, method), with keys ``hold_ratio``, ``method``,
    ``order``, the norms of :data:`sampledyn.errors.ERROR_NORMS` (over both states,
    t >= after), ``rms_away_from_jumps`` (rms over the samples whose prediction
    history holds no input jump; NaN when h_u/h is too short to have any),
    ``rms_smooth`` (same, also away from zero crossings of the model's kink states), ``h``,
    ``T``, ``after``, ``seed``, ``certificate`` (max scaled
    per-interval flow error of the samples), ``tau_min`` (fastest local time
    constant, s) and ``notes`` (why a norm is NaN, "" otherwise).
    """
    cfg = auv_config(study)
    options: dict[str, Any] = {"progress": progress}
    if workers is not None and workers > 1:
        options["workers"] = workers
    result = run_study(cfg, store, **options)
    trajs = result.trajectories
    rows: dict[tuple[str, str], dict[str, Any]] = {}
    for c in result.cells:
        tconf = result.study.trajectories[c["traj_key"]]
        ratio = int(round(tconf["input"]["hold"] / study.h))
        key = (c["traj_key"], c["method"])
        if key not in rows:
            method = get_predictor(c["method"])
            rows[key] = {"hold_ratio": ratio, "method": method.name, "order": int(method.order)}
        row = rows[key]
        column = MASKED_NORMS.get(c["norm"], c["norm"])
        ok = c["status"] == "ok"
        row[column] = float(c["err_all"]) if ok else float("nan")
        if not ok:
            row.setdefault("_notes", []).append(f"{column}: {c['error']}")
    out = []
    for (traj_key, _m), row in rows.items():
        t = trajs[traj_key]
        notes = row.pop("_notes", [])
        row.update(
            h=study.h,
            T=study.T,
            after=study.after,
            seed=study.seed,
            certificate=float(t["certificate"]),
            tau_min=float(t["summary"]["tau_min"]),
            notes="; ".join(notes),
        )
        out.append(row)
    return out
