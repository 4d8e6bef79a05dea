"""The experiment layer: one engine (:mod:`sampledyn.experiments.sweep`: plan, one
cell function, backends, store) and the studies built on it, the paper's Figs. 2-3
and 7, the Monte Carlo of :func:`advise`, the bound validation
(:func:`monte_carlo_check`, :func:`inertia_sensitivity`, :func:`sensitivity_study`)
and the controller studies (:func:`run_closed_loop_study`,
:func:`run_multistep_study`, whose cells are of the kinds ``closed_loop`` and
``multistep`` registered here)."""

from ._advise import DEFAULT_METHODS as DEFAULT_METHODS
from ._advise import TIE as TIE
from ._advise import Advice as Advice
from ._advise import AdviceRow as AdviceRow
from ._advise import advise as advise
from ._advise import default_input as default_input
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
from ._closed_loop import ClosedLoopCells as ClosedLoopCells
from ._closed_loop import ClosedLoopStudy as ClosedLoopStudy
from ._closed_loop import design_lqr as design_lqr
from ._closed_loop import run_closed_loop_study as run_closed_loop_study
from ._closed_loop import summarize_closed_loop as summarize_closed_loop
from ._closed_loop import trim as trim
from ._multistep import MULTISTEP as MULTISTEP
from ._multistep import MultistepCells as MultistepCells
from ._multistep import MultistepStudy as MultistepStudy
from ._multistep import run_multistep_study as run_multistep_study
from ._multistep import summarize_multistep as summarize_multistep
from ._paper_fig7 import FIG7_NOISE_PAIRS as FIG7_NOISE_PAIRS
from ._paper_fig7 import PAPER_FIG7 as PAPER_FIG7
from ._rov import FIG7_STUDY_FILE as FIG7_STUDY_FILE
from ._rov import NORMS as FIG7_NORMS
from ._rov import ROVStudy as ROVStudy
from ._rov import fig7_rows as fig7_rows
from ._rov import fig7_vehicle as fig7_vehicle
from ._rov import run_rov_study as run_rov_study
from ._rov import summarize as summarize
from ._rov import summarize as summarize_rov
from ._sensitivity import SensitivityStudy as SensitivityStudy
from ._sensitivity import sensitivity_study as sensitivity_study
from .sweep import away_from_jumps as away_from_jumps
from .sweep import away_from_kinks as away_from_kinks
from .sweep import fastest_time_constant as fastest_time_constant
from .sweep import motion_summary as motion_summary
from .sweep import run_study as run_study

__all__ = [
    "CLOSED_LOOP",
    "DEFAULT_METHODS",
    "FIG7_NOISE_PAIRS",
    "FIG7_NORMS",
    "FIG7_STUDY_FILE",
    "MULTISTEP",
    "PAPER_FIG7",
    "TIE",
    "AUVStudy",
    "Advice",
    "AdviceRow",
    "InertiaSensitivity",
    "MonteCarloRow",
    "ClosedLoopCells",
    "ClosedLoopStudy",
    "MultistepCells",
    "MultistepStudy",
    "ROVStudy",
    "SensitivityStudy",
    "advise",
    "auv_config",
    "away_from_jumps",
    "away_from_kinks",
    "default_input",
    "fastest_time_constant",
    "design_lqr",
    "fig2_methods",
    "fig3_methods",
    "fig7_rows",
    "fig7_vehicle",
    "inertia_sensitivity",
    "measure_noisy",
    "monte_carlo_check",
    "motion_summary",
    "reference_samples",
    "run_auv_study",
    "run_closed_loop_study",
    "run_multistep_study",
    "run_rov_study",
    "run_study",
    "sensitivity_study",
    "summarize",
    "summarize_closed_loop",
    "summarize_multistep",
    "summarize_rov",
    "trim",
]
