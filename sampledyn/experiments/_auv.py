"""The AUV-like case study of section 4 (Figs. 2 and 3), a built-in study of the engine.

For each input hold ratio h_u/h, exact samples of eqs. (9)-(10) are simulated under a
random multilevel input (levels uniform in [-10, 10]); every method's one-step-ahead
predictor is fed with those samples and its local errors are measured after the
transient, over all samples and over the samples away from input jumps (and from the
velocity's zero crossings).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from .. import _checks as checks
from ..exceptions import ArgumentError
from ._studies import StudyDefinition

if TYPE_CHECKING:
    from ..models import Model

__all__ = [
    "FIG2",
    "FIG3",
    "AUVStudy",
    "auv_config",
    "fig2_methods",
    "fig3_methods",
    "run_auv_study",
]

#: The masked norms of Figs. 2-3 and their columns in the rows.
MASKED_NORMS = {"rms@away_from_jumps": "rms_away_from_jumps", "rms@smooth": "rms_smooth"}


def _multistep(fam: Any) -> bool:
    """A family of orders with a member that uses more than one past sample."""
    from ..methods import get_method

    return fam.ordered and any(get_method(n).history > 1 for n in fam.names())


def _predictors(fam: Any) -> bool:
    """A family whose rules predict on sampled data (not ZOH, a discrete-time system)."""
    from ..methods import Predictor, get_method

    return isinstance(get_method(fam.names()[0]), Predictor)


def _families() -> tuple[Any, ...]:
    """The registered families of predictors (the figures iterate the whole registry)."""
    from ..methods import families

    return tuple(fam for fam in families() if _predictors(fam))


def fig2_methods() -> tuple[str, ...]:
    """Fig. 2's rules: every registered multistep family of predictors (AB_s, ABu_s,
    ABe_s, ...), orders 1 to the family's default largest one, in registration order."""
    return tuple(n for fam in _families() if _multistep(fam) for n in fam.names())


def fig3_methods() -> tuple[str, ...]:
    """Fig. 3's rules: every registered single predictor (E, T, Ee, ...) and every
    one-step family of orders (RK_s), in registration order."""
    return tuple(n for fam in _families() if not _multistep(fam) for n in fam.names())


def _auv_like() -> Any:
    from ..models import AUVLike

    return AUVLike()


@dataclass(frozen=True)
class AUVStudy:
    """Settings of the AUV-like study (the grid values are checked by the engine's
    :class:`~sampledyn.experiments.sweep.SweepConfig`, the rest here).

    Attributes
    ----------
    methods : tuple of str
        Registry names (default :func:`fig2_methods`).
    ratios : tuple of int
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
    norm : str
        The norm of the first panel and table (:data:`sampledyn._local_errors.ERROR_NORMS`).
    low, high : float
        Range of the input levels.
    x0 : tuple of float
        Initial state (x, y).
    model : Model
        The model (default the AUV-like system).
    """

    methods: tuple[str, ...] = field(default_factory=fig2_methods)
    ratios: tuple[int, ...] = (1, 2, 5, 10, 20, 50, 100)
    h: float = 0.01
    T: float = 200.0
    after: float = 20.0
    seed: int = 0
    norm: str = "rms"
    low: float = -10.0
    high: float = 10.0
    x0: tuple[float, float] = (1.0, 0.0)
    model: Model = field(default_factory=_auv_like)

    def __post_init__(self) -> None:
        from .._local_errors import ERROR_NORMS

        for r in self.ratios:
            checks.count(r, "ratios", types=ArgumentError)
        checks.count(self.seed, "seed", what="the multilevel input's", least=0)
        if self.norm not in ERROR_NORMS:
            raise ValueError(f"`norm` must be one of {', '.join(ERROR_NORMS)}, got {self.norm!r}.")


def auv_config(study: AUVStudy) -> Any:
    """The study as a grid of the engine (a checked
    :class:`~sampledyn.experiments.sweep.SweepConfig`): one multilevel input per h_u/h,
    no noise, the norms of :data:`sampledyn._local_errors.ERROR_NORMS` and the two masked rms."""
    from .._local_errors import ERROR_NORMS
    from .sweep import SweepConfig

    inputs = tuple(
        {"name": "multilevel", "low": study.low, "high": study.high,
         "hold": ratio * study.h, "seed": study.seed}
        for ratio in study.ratios
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


class AUVStudies(StudyDefinition):
    """Figs. 2 and 3 (the same study; ``methods`` default to each figure's rules)."""

    settings_type = AUVStudy

    def __init__(self, name: str, default_methods: Any) -> None:
        self.name = name
        self._default_methods = default_methods

    def settings(self, **values: Any) -> AUVStudy:
        values.setdefault("methods", self._default_methods())
        return AUVStudy(**values)

    def configs(self, settings: AUVStudy) -> tuple[Any, ...]:
        return (auv_config(settings),)

    def rows(self, settings: AUVStudy, results: Sequence[Any]) -> list[dict[str, Any]]:
        """One row per (hold ratio, method) (see :func:`run_auv_study`)."""
        from ..methods import get_predictor

        (result,) = results
        rows: dict[tuple[str, str], dict[str, Any]] = {}
        for c in result.cells:
            tconf = result.study.trajectories[c["traj_key"]]
            key = (c["traj_key"], c["method"])
            if key not in rows:
                method = get_predictor(c["method"])
                ratio = int(round(tconf["input"]["hold"] / settings.h))
                rows[key] = {"hold_ratio": ratio, "method": method.name, "order": int(method.order)}
            row = rows[key]
            column = MASKED_NORMS.get(c["norm"], c["norm"])
            ok = c["status"] == "ok"
            row[column] = float(c["err_all"]) if ok else math.nan
            if not ok:
                row.setdefault("_notes", []).append(f"{column}: {c['error']}")
        out = []
        for (traj_key, _m), row in rows.items():
            t = result.trajectories[traj_key]
            notes = row.pop("_notes", [])
            row.update(
                h=settings.h, T=settings.T, after=settings.after, seed=settings.seed,
                certificate=float(t["certificate"]), tau_min=float(t["summary"]["tau_min"]),
                notes="; ".join(notes),
            )  # fmt: skip
            out.append(row)
        return out


#: The registered studies ``reproduce fig2`` and ``fig3``.
FIG2 = AUVStudies("fig2", fig2_methods)
FIG3 = AUVStudies("fig3", fig3_methods)


def run_auv_study(
    study: AUVStudy | None = None,
    *,
    progress: bool = False,
    store: Any = None,
    workers: int | None = None,
) -> list[dict[str, Any]]:
    """Local-error norms of every method for every h_u/h.

    Parameters
    ----------
    study : AUVStudy
        Default ``AUVStudy()`` (Fig. 2's rules).
    progress : bool
        Show a progress bar.
    store : path, optional
        Results store (resumable); default: in this process.
    workers : int, optional
        Local worker processes (default: in this process).

    Returns
    -------
    list of dict, one per (hold ratio, method), with keys ``hold_ratio``, ``method``,
    ``order``, the norms of :data:`sampledyn._local_errors.ERROR_NORMS` (over both states,
    t >= after), ``rms_away_from_jumps`` (rms over the samples whose prediction
    history holds no input jump; NaN when h_u/h is too short to have any),
    ``rms_smooth`` (same, also away from zero crossings of the model's kink states), ``h``,
    ``T``, ``after``, ``seed``, ``certificate`` (max scaled
    per-interval flow error of the samples), ``tau_min`` (fastest local time
    constant, s) and ``notes`` (why a norm is NaN, "" otherwise).
    """
    settings = AUVStudy() if study is None else study
    return FIG2.run(settings, store=store, workers=workers, progress=progress).rows
