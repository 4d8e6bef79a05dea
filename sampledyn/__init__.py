"""sampledyn: sampled-data models of vehicle dynamics.

One-step-ahead predictors (Euler, Tustin, Runge-Kutta, Adams-Bashforth) built from
continuous-time vehicle models, run against exact sampled data, with local errors;
after the paper "On the Adequacy of Adams-Bashforth Sampled-Data Models for
Characterizing Complex Underwater-Vehicle Dynamics with Noisy Measurements".

The names below load on first use, so ``import sampledyn`` (and the ``sampledyn``
command, which speaks before the numerical kernels load or compile) is instant.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from ._version import __version__ as __version__

# Public name -> module that defines it (None: the name is a subpackage or module).
# Each name is one thing: the modules behind the functions are private (``_simulate``,
# ``_predict``, ``_estimate``, ``_discretize``, ...), so ``sampledyn.discretize`` is the
# function, whatever was imported before.
_EXPORTS: dict[str, str | None] = {
    "AdamsBashforth": ".methods",
    "Certificate": "._trajectory",
    "DiscreteModel": "._discretize",
    "EstimatedAdamsBashforth": "._estimate",
    "EstimationResult": "._estimate",
    "Euler": ".methods",
    "LinearLaw": "._discretize",
    "RungeKutta": ".methods",
    "Trajectory": "._trajectory",
    "Tustin": ".methods",
    "add_noise": "._noise",
    "advise": ".experiments",
    "available_methods": ".methods",
    "discretize": "._discretize",
    "error_norm": "._local_errors",
    "estimate": "._estimate",
    "estimate_and_predict": "._estimate",
    "estimate_noise": "._noise",
    "exceptions": None,
    "experiments": None,
    "get_baseline": "._baselines",
    "get_method": ".methods",
    "local_errors": "._local_errors",
    "logs": None,
    "memory_limit": "._checks",
    "methods": None,
    "models": None,
    "predict": "._predict",
    "report": None,
    "results": None,
    "run_loop": "._discretize",
    "sensitivity": None,
    "signals": None,
    "simulate": "._simulate",
}

__all__ = sorted(_EXPORTS)

if TYPE_CHECKING:
    from . import exceptions as exceptions
    from . import experiments as experiments
    from . import logs as logs
    from . import methods as methods
    from . import models as models
    from . import report as report
    from . import results as results
    from . import sensitivity as sensitivity
    from . import signals as signals
    from ._baselines import get_baseline as get_baseline
    from ._checks import memory_limit as memory_limit
    from ._discretize import DiscreteModel as DiscreteModel
    from ._discretize import LinearLaw as LinearLaw
    from ._discretize import discretize as discretize
    from ._discretize import run_loop as run_loop
    from ._estimate import EstimatedAdamsBashforth as EstimatedAdamsBashforth
    from ._estimate import EstimationResult as EstimationResult
    from ._estimate import estimate as estimate
    from ._estimate import estimate_and_predict as estimate_and_predict
    from ._local_errors import error_norm as error_norm
    from ._local_errors import local_errors as local_errors
    from ._noise import add_noise as add_noise
    from ._noise import estimate_noise as estimate_noise
    from ._predict import predict as predict
    from ._simulate import simulate as simulate
    from ._trajectory import Certificate as Certificate
    from ._trajectory import Trajectory as Trajectory
    from .experiments import advise as advise
    from .methods import AdamsBashforth as AdamsBashforth
    from .methods import Euler as Euler
    from .methods import RungeKutta as RungeKutta
    from .methods import Tustin as Tustin
    from .methods import available_methods as available_methods
    from .methods import get_method as get_method


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'sampledyn' has no attribute {name!r}")
    source = _EXPORTS[name]
    if source is None:
        value: Any = importlib.import_module(f".{name}", __name__)
    else:
        value = getattr(importlib.import_module(source, __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_EXPORTS})
