"""Paper-style tables and matplotlib figures."""

from ._auv_figs import plot_error_vs_order as plot_error_vs_order
from ._tables import format_grid as format_grid
from ._tables import write_csv as write_csv

__all__ = ["format_grid", "plot_error_vs_order", "write_csv"]
