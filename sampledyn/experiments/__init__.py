"""The paper's case studies as data and functions (Figs. 2-3, Fig. 7)."""

from ._auv import FIG2_METHODS as FIG2_METHODS
from ._auv import FIG3_METHODS as FIG3_METHODS
from ._auv import AUVStudy as AUVStudy
from ._auv import run_auv_study as run_auv_study
from ._rov import NORMS as FIG7_NORMS
from ._rov import ROVStudy as ROVStudy
from ._rov import run_rov_study as run_rov_study
from ._rov import summarize as summarize_rov

__all__ = [
    "FIG2_METHODS",
    "FIG3_METHODS",
    "FIG7_NORMS",
    "AUVStudy",
    "ROVStudy",
    "run_auv_study",
    "run_rov_study",
    "summarize_rov",
]
