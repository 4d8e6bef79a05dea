"""The experiment layer: one engine (:mod:`sampledyn.experiments.sweep`: plan, one
cell function, backends, store) and the studies built on it. The studies of
``sampledyn reproduce`` are plug-ins (:data:`STUDIES`, :class:`StudyDefinition`): the
paper's Figs. 2-3 (:class:`AUVStudy`) and 7 (:class:`ROVStudy`) and the controller
studies (:class:`ClosedLoopStudy`, :class:`MultistepStudy`, whose cells are of the
kinds ``closed_loop`` and ``multistep``). Also on the engine: the Monte Carlo of
:func:`advise` and the bound validation (:func:`monte_carlo_check`,
:func:`inertia_sensitivity`, :func:`sensitivity_study`).

The names load on first use: importing this package (or its light study registry,
:mod:`._studies`) does not load the numerical kernels.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

# Public name -> module that defines it.
_EXPORTS: dict[str, str] = {
    **dict.fromkeys(("DEFAULT_METHODS", "TIE", "Advice", "AdviceRow", "advise",
                     "default_input"), "._advise"),
    **dict.fromkeys(("AUVStudy", "FIG2", "FIG3", "auv_config", "fig2_methods",
                     "fig3_methods", "run_auv_study"), "._auv"),
    **dict.fromkeys(("InertiaSensitivity", "MonteCarloRow", "inertia_sensitivity",
                     "measure_noisy", "monte_carlo_check", "reference_samples"), "._bounds"),
    **dict.fromkeys(("CLOSED_LOOP", "CLOSED_LOOP_STUDY", "ClosedLoopCells", "ClosedLoopStudy",
                     "design_lqr", "run_closed_loop_study", "summarize_closed_loop", "trim"),
                    "._closed_loop"),
    **dict.fromkeys(("MULTISTEP", "MULTISTEP_STUDY", "MultistepCells", "MultistepStudy",
                     "run_multistep_study", "summarize_multistep"), "._multistep"),
    **dict.fromkeys(("FIG7_NOISE_PAIRS", "PAPER_FIG7"), "._paper_fig7"),
    **dict.fromkeys(("FIG7", "FIG7_NORMS", "FIG7_STUDY_FILE", "ROVStudy", "fig7_rows",
                     "fig7_vehicle", "run_rov_study", "summarize_rov"), "._rov"),
    **dict.fromkeys(("SensitivityStudy", "sensitivity_study"), "._sensitivity"),
    **dict.fromkeys(("SHARED", "STUDIES", "Option", "StudyDefinition", "StudyEntry",
                     "StudyOutput", "Take", "available_studies", "get_study",
                     "register_study"), "._studies"),
    **dict.fromkeys(("away_from_jumps", "away_from_kinks", "fastest_time_constant",
                     "motion_summary", "run_study"), ".sweep"),
}  # fmt: skip

__all__ = sorted(_EXPORTS)

if TYPE_CHECKING:
    from ._advise import DEFAULT_METHODS as DEFAULT_METHODS
    from ._advise import TIE as TIE
    from ._advise import Advice as Advice
    from ._advise import AdviceRow as AdviceRow
    from ._advise import advise as advise
    from ._advise import default_input as default_input
    from ._auv import FIG2 as FIG2
    from ._auv import FIG3 as FIG3
    from ._auv import AUVStudy as AUVStudy
    from ._auv import auv_config as auv_config
    from ._auv import fig2_methods as fig2_methods
    from ._auv import fig3_methods as fig3_methods
    from ._auv import run_auv_study as run_auv_study
    from ._bounds import InertiaSensitivity as InertiaSensitivity
    from ._bounds import MonteCarloRow as MonteCarloRow
    from ._bounds import inertia_sensitivity as inertia_sensitivity
    from ._bounds import measure_noisy as measure_noisy
    from ._bounds import monte_carlo_check as monte_carlo_check
    from ._bounds import reference_samples as reference_samples
    from ._closed_loop import CLOSED_LOOP as CLOSED_LOOP
    from ._closed_loop import CLOSED_LOOP_STUDY as CLOSED_LOOP_STUDY
    from ._closed_loop import ClosedLoopCells as ClosedLoopCells
    from ._closed_loop import ClosedLoopStudy as ClosedLoopStudy
    from ._closed_loop import design_lqr as design_lqr
    from ._closed_loop import run_closed_loop_study as run_closed_loop_study
    from ._closed_loop import summarize_closed_loop as summarize_closed_loop
    from ._closed_loop import trim as trim
    from ._multistep import MULTISTEP as MULTISTEP
    from ._multistep import MULTISTEP_STUDY as MULTISTEP_STUDY
    from ._multistep import MultistepCells as MultistepCells
    from ._multistep import MultistepStudy as MultistepStudy
    from ._multistep import run_multistep_study as run_multistep_study
    from ._multistep import summarize_multistep as summarize_multistep
    from ._paper_fig7 import FIG7_NOISE_PAIRS as FIG7_NOISE_PAIRS
    from ._paper_fig7 import PAPER_FIG7 as PAPER_FIG7
    from ._rov import FIG7 as FIG7
    from ._rov import FIG7_NORMS as FIG7_NORMS
    from ._rov import FIG7_STUDY_FILE as FIG7_STUDY_FILE
    from ._rov import ROVStudy as ROVStudy
    from ._rov import fig7_rows as fig7_rows
    from ._rov import fig7_vehicle as fig7_vehicle
    from ._rov import run_rov_study as run_rov_study
    from ._rov import summarize_rov as summarize_rov
    from ._sensitivity import SensitivityStudy as SensitivityStudy
    from ._sensitivity import sensitivity_study as sensitivity_study
    from ._studies import SHARED as SHARED
    from ._studies import STUDIES as STUDIES
    from ._studies import Option as Option
    from ._studies import StudyDefinition as StudyDefinition
    from ._studies import StudyEntry as StudyEntry
    from ._studies import StudyOutput as StudyOutput
    from ._studies import Take as Take
    from ._studies import available_studies as available_studies
    from ._studies import get_study as get_study
    from ._studies import register_study as register_study
    from .sweep import away_from_jumps as away_from_jumps
    from .sweep import away_from_kinks as away_from_kinks
    from .sweep import fastest_time_constant as fastest_time_constant
    from .sweep import motion_summary as motion_summary
    from .sweep import run_study as run_study


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'sampledyn.experiments' has no attribute {name!r}")
    value = getattr(importlib.import_module(_EXPORTS[name], __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_EXPORTS})
