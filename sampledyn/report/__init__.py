"""Paper-style tables and matplotlib figures."""

from ._fig7 import fig7_table as fig7_table
from ._sensitivity_figs import sensitivity_report as sensitivity_report
from ._sweep_report import write_report as write_report

__all__ = [
    "fig7_table",
    "sensitivity_report",
    "write_report",
]
