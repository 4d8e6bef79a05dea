"""The paper's case studies as data and functions (Figs. 2-3, Fig. 7)."""

# The estimation layer registers its rules (Ee, ABe<s>) into the method registry; the
# studies iterate the whole registry.
from .. import estimate as _estimate  # noqa: F401
from ._auv import AUVStudy as AUVStudy
from ._auv import away_from_jumps as away_from_jumps
from ._auv import away_from_kinks as away_from_kinks
from ._auv import fig2_methods as fig2_methods
from ._auv import fig3_methods as fig3_methods
from ._auv import run_auv_study as run_auv_study
from ._closed_loop import ClosedLoopStudy as ClosedLoopStudy
from ._closed_loop import design_lqr as design_lqr
from ._closed_loop import run_closed_loop_study as run_closed_loop_study
from ._closed_loop import summarize_closed_loop as summarize_closed_loop
from ._closed_loop import trim as trim
from ._multistep import MultistepStudy as MultistepStudy
from ._multistep import run_multistep_study as run_multistep_study
from ._multistep import summarize_multistep as summarize_multistep
from ._paper_fig7 import FIG7_NOISE_PAIRS as FIG7_NOISE_PAIRS
from ._paper_fig7 import PAPER_FIG7 as PAPER_FIG7
from ._rov import NORMS as FIG7_NORMS
from ._rov import ROVStudy as ROVStudy
from ._rov import fig7_vehicle as fig7_vehicle
from ._rov import motion_summary as motion_summary
from ._rov import run_rov_study as run_rov_study
from ._rov import summarize as summarize
from ._rov import summarize as summarize_rov

__all__ = [
    "FIG7_NOISE_PAIRS",
    "FIG7_NORMS",
    "PAPER_FIG7",
    "AUVStudy",
    "ClosedLoopStudy",
    "MultistepStudy",
    "ROVStudy",
    "away_from_jumps",
    "away_from_kinks",
    "design_lqr",
    "fig2_methods",
    "fig3_methods",
    "fig7_vehicle",
    "motion_summary",
    "run_auv_study",
    "run_closed_loop_study",
    "run_multistep_study",
    "run_rov_study",
    "summarize",
    "summarize_closed_loop",
    "summarize_multistep",
    "summarize_rov",
    "trim",
]
