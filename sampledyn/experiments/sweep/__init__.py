"""Sweeps at scale: a grid of cells (vehicle x input x h x noise x seed x method x
norm), computed in-process, on local worker processes or on a Dask cluster, and kept
in a resumable SQLite results store. See ``docs/sweeps.md``."""

from ._config import SweepConfig as SweepConfig
from ._config import SweepConfigError as SweepConfigError
from ._config import load_config as load_config
from ._inputs import available_inputs as available_inputs
from ._inputs import build_model as build_model
from ._inputs import register_input as register_input
from ._load import load as load_results
from ._plan import Study as Study
from ._plan import plan_study as plan_study
from ._run import SweepSummary as SweepSummary
from ._run import run_sweep as run_sweep
from ._store import ResultStore as ResultStore

__all__ = [
    "ResultStore",
    "Study",
    "SweepConfig",
    "SweepConfigError",
    "SweepSummary",
    "available_inputs",
    "build_model",
    "load_config",
    "load_results",
    "plan_study",
    "register_input",
    "run_sweep",
]
