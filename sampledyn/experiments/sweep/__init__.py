"""The experiment engine: a study is a grid of cells (model x input x h x noise x
seed x method x norm), planned lazily, computed by one cell function in-process, on
local worker processes or on a Dask cluster, and kept in a resumable SQLite results
store that concurrent runs share (or in memory). Exact samples are computed once per
(model, input, T, h), and once for every h that is a multiple of another. Every
study of the package runs on it: sweeps, Figs. 2, 3 and 7, the Monte Carlo of
``advise``, the bound validation and the controller studies (closed loop,
multistep), whose cells are of another kind (:class:`CellKind`: what is shared per
trajectory and what one cell computes). See ``docs/sweeps.md``."""

from ._backends import local_cluster as local_cluster
from ._cells import CellKind as CellKind
from ._cells import Setup as Setup
from ._cells import register_cell_kind as register_cell_kind
from ._compute import exact_samples as exact_samples
from ._compute import prediction_inputs as prediction_inputs
from ._config import SweepConfig as SweepConfig
from ._config import check_time_grid as check_time_grid
from ._config import load_config as load_config
from ._norms import away_from_jumps as away_from_jumps
from ._norms import away_from_kinks as away_from_kinks
from ._norms import smooth_history as smooth_history
from ._run import run_sweep as run_sweep

__all__ = [
    "CellKind",
    "Setup",
    "SweepConfig",
    "away_from_jumps",
    "away_from_kinks",
    "check_time_grid",
    "exact_samples",
    "load_config",
    "local_cluster",
    "prediction_inputs",
    "register_cell_kind",
    "run_sweep",
    "smooth_history",
]
