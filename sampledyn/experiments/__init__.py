"""The paper's case studies as data and functions (Figs. 2-3, Fig. 7)."""

from ._auv import AUVStudy as AUVStudy
from ._auv import run_auv_study as run_auv_study

__all__ = ["AUVStudy", "run_auv_study"]
