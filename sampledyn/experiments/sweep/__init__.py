"""Sweeps at scale: a grid of cells (vehicle x input x h x noise x seed x method x
norm), planned lazily, computed in-process, on local worker processes or on a Dask
cluster, and kept in a resumable SQLite results store that concurrent runs share.
See ``docs/sweeps.md``."""

from ._backends import DASK_WORKER_ENVIRON as DASK_WORKER_ENVIRON
from ._backends import check_dask_workers as check_dask_workers
from ._backends import local_cluster as local_cluster
from ._backends import worker_init as worker_init
from ._config import DEFAULT_MAX_CELLS as DEFAULT_MAX_CELLS
from ._config import NoiseGrid as NoiseGrid
from ._config import SweepConfig as SweepConfig
from ._config import SweepConfigError as SweepConfigError
from ._config import load_config as load_config
from ._inputs import available_inputs as available_inputs
from ._inputs import build_model as build_model
from ._inputs import register_input as register_input
from ._plan import Study as Study
from ._plan import plan_study as plan_study
from ._run import LEASE_SECONDS as LEASE_SECONDS
from ._run import SweepSummary as SweepSummary
from ._run import check_grid_size as check_grid_size
from ._run import run_sweep as run_sweep
from ._store import APPLICATION_ID as APPLICATION_ID
from ._store import NotAStoreError as NotAStoreError
from ._store import ResultStore as ResultStore
from ._store import load_results as load_results

__all__ = [
    "APPLICATION_ID",
    "DASK_WORKER_ENVIRON",
    "DEFAULT_MAX_CELLS",
    "LEASE_SECONDS",
    "NoiseGrid",
    "NotAStoreError",
    "ResultStore",
    "Study",
    "SweepConfig",
    "SweepConfigError",
    "SweepSummary",
    "available_inputs",
    "build_model",
    "check_dask_workers",
    "check_grid_size",
    "load_config",
    "load_results",
    "local_cluster",
    "plan_study",
    "register_input",
    "run_sweep",
    "worker_init",
]
