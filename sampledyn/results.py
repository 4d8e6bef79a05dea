"""Read a results store written by ``sampledyn sweep`` (see ``docs/sweeps.md``).

>>> import sampledyn as sd
>>> df = sd.results.load("results.db")                       # doctest: +SKIP
>>> df.groupby(["h", "eta_pct", "v_pct", "method"])["err_eta"].mean()   # doctest: +SKIP
"""

from .experiments.sweep import ResultStore as ResultStore
from .experiments.sweep import load_results as load

__all__ = ["ResultStore", "load"]
