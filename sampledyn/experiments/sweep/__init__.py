"""The experiment engine: a study is a grid of cells (model x input x h x noise x
seed x method x norm), planned lazily, computed by one cell function in-process, on
local worker processes or on a Dask cluster, and kept in a resumable SQLite results
store that concurrent runs share (or in memory). Exact samples are computed once per
(model, input, T, h), and once for every h that is a multiple of another. Every
study of the package runs on it: sweeps, Figs. 2, 3 and 7, the Monte Carlo of
``advise``, the bound validation and the controller studies (closed loop,
multistep), whose cells are of another kind (:class:`CellKind`: what is shared per
trajectory and what one cell computes). See ``docs/sweeps.md``."""

from ._backends import DASK_WORKER_ENVIRON as DASK_WORKER_ENVIRON
from ._backends import check_dask_workers as check_dask_workers
from ._backends import local_cluster as local_cluster
from ._backends import retain_freed_memory as retain_freed_memory
from ._backends import worker_init as worker_init
from ._cells import CellKind as CellKind
from ._cells import Chunk as Chunk
from ._cells import Setup as Setup
from ._cells import SimPlan as SimPlan
from ._cells import available_cell_kinds as available_cell_kinds
from ._cells import get_cell_kind as get_cell_kind
from ._cells import register_cell_kind as register_cell_kind
from ._cells import warning_text as warning_text
from ._cells import worker_name as worker_name
from ._compute import CELL_ERRORS as CELL_ERRORS
from ._compute import ChunkResult as ChunkResult
from ._compute import SimResult as SimResult
from ._compute import exact_samples as exact_samples
from ._compute import prediction_inputs as prediction_inputs
from ._compute import simulate_trajectory as simulate_trajectory
from ._config import DEFAULT_MAX_CELLS as DEFAULT_MAX_CELLS
from ._config import NoiseGrid as NoiseGrid
from ._config import SweepConfig as SweepConfig
from ._config import SweepConfigError as SweepConfigError
from ._config import check_time_grid as check_time_grid
from ._config import load_config as load_config
from ._inputs import build_model as build_model
from ._norms import NormSpec as NormSpec
from ._norms import available_masks as available_masks
from ._norms import away_from_jumps as away_from_jumps
from ._norms import away_from_kinks as away_from_kinks
from ._norms import parse_norm as parse_norm
from ._norms import smooth_history as smooth_history
from ._plan import Study as Study
from ._plan import plan_study as plan_study
from ._prediction import PREDICTION as PREDICTION
from ._prediction import PredictionCells as PredictionCells
from ._run import LEASE_SECONDS as LEASE_SECONDS
from ._run import StudyResult as StudyResult
from ._run import SweepSummary as SweepSummary
from ._run import backend_options as backend_options
from ._run import check_grid_size as check_grid_size
from ._run import run_study as run_study
from ._run import run_sweep as run_sweep
from ._store import APPLICATION_ID as APPLICATION_ID
from ._store import CELL_COLUMNS as CELL_COLUMNS
from ._store import NotAStoreError as NotAStoreError
from ._store import ResultStore as ResultStore
from ._store import inspect_store as inspect_store
from ._store import load_results as load_results
from ._summaries import SUMMARIES as SUMMARIES
from ._summaries import fastest_time_constant as fastest_time_constant
from ._summaries import motion_summary as motion_summary

__all__ = [
    "APPLICATION_ID",
    "CELL_COLUMNS",
    "CELL_ERRORS",
    "CellKind",
    "Chunk",
    "PREDICTION",
    "PredictionCells",
    "ChunkResult",
    "Setup",
    "SimPlan",
    "SimResult",
    "available_cell_kinds",
    "get_cell_kind",
    "register_cell_kind",
    "simulate_trajectory",
    "warning_text",
    "worker_name",
    "DASK_WORKER_ENVIRON",
    "DEFAULT_MAX_CELLS",
    "LEASE_SECONDS",
    "SUMMARIES",
    "NoiseGrid",
    "NormSpec",
    "NotAStoreError",
    "ResultStore",
    "Study",
    "StudyResult",
    "SweepConfig",
    "SweepConfigError",
    "SweepSummary",
    "available_masks",
    "backend_options",
    "away_from_jumps",
    "away_from_kinks",
    "build_model",
    "check_time_grid",
    "exact_samples",
    "check_dask_workers",
    "check_grid_size",
    "fastest_time_constant",
    "inspect_store",
    "load_config",
    "load_results",
    "local_cluster",
    "retain_freed_memory",
    "motion_summary",
    "parse_norm",
    "smooth_history",
    "plan_study",
    "prediction_inputs",
    "run_study",
    "run_sweep",
    "worker_init",
]
