"""Paper-style tables and matplotlib figures."""

from ._auv_figs import plot_error_vs_order as plot_error_vs_order
from ._closed_loop import closed_loop_table as closed_loop_table
from ._closed_loop import multistep_table as multistep_table
from ._closed_loop import plot_closed_loop as plot_closed_loop
from ._closed_loop import plot_multistep as plot_multistep
from ._fig7 import fig7_table as fig7_table
from ._fig7 import norm_evidence as norm_evidence
from ._fig7 import plot_fig7 as plot_fig7
from ._fig7 import ratio_phrase as ratio_phrase
from ._sensitivity_figs import plot_boundary_map as plot_boundary_map
from ._sensitivity_figs import plot_crossing as plot_crossing
from ._sensitivity_figs import plot_inertia as plot_inertia
from ._sensitivity_figs import plot_noise_growth as plot_noise_growth
from ._sensitivity_figs import plot_pitch as plot_pitch
from ._sensitivity_figs import plot_tightness as plot_tightness
from ._sensitivity_figs import sensitivity_report as sensitivity_report
from ._sweep_report import MANIFEST as MANIFEST
from ._sweep_report import REPORT_FILES as REPORT_FILES
from ._sweep_report import ReportFiles as ReportFiles
from ._sweep_report import write_report as write_report
from ._tables import format_grid as format_grid
from ._tables import write_csv as write_csv

__all__ = [
    "MANIFEST",
    "REPORT_FILES",
    "ReportFiles",
    "closed_loop_table",
    "fig7_table",
    "format_grid",
    "multistep_table",
    "norm_evidence",
    "plot_boundary_map",
    "plot_crossing",
    "plot_closed_loop",
    "plot_error_vs_order",
    "plot_multistep",
    "plot_fig7",
    "plot_inertia",
    "plot_noise_growth",
    "plot_pitch",
    "plot_tightness",
    "ratio_phrase",
    "sensitivity_report",
    "write_csv",
    "write_report",
]
