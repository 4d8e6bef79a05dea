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
import sys
import types
from typing import TYPE_CHECKING, Any

from ._version import __version__ as __version__

# Public name -> module that defines it (None: the name is a subpackage or module).
_EXPORTS: dict[str, str | None] = {
    "AdamsBashforth": ".methods",
    "Certificate": "._trajectory",
    "NumericalError": "._trajectory",
    "EstimatedAdamsBashforth": ".estimate",
    "EstimationResult": ".estimate",
    "Euler": ".methods",
    "RungeKutta": ".methods",
    "Trajectory": "._trajectory",
    "Tustin": ".methods",
    "add_noise": ".noise",
    "advise": ".experiments",
    "available_methods": ".methods",
    "discretize": ".discretize",
    "error_norm": ".errors",
    "estimate": ".estimate",
    "estimate_and_predict": ".estimate",
    "experiments": None,
    "logs": None,
    "get_method": ".methods",
    "local_errors": ".errors",
    "methods": None,
    "models": None,
    "predict": ".predict",
    "report": None,
    "results": None,
    "sensitivity": None,
    "signals": None,
    "simulate": ".simulate",
}

__all__ = sorted(_EXPORTS)

if TYPE_CHECKING:
    from . import experiments as experiments
    from . import logs as logs
    from . import methods as methods
    from . import models as models
    from . import report as report
    from . import results as results
    from . import sensitivity as sensitivity
    from . import signals as signals
    from ._trajectory import Certificate as Certificate
    from ._trajectory import NumericalError as NumericalError
    from ._trajectory import Trajectory as Trajectory
    from .discretize import discretize as discretize
    from .errors import error_norm as error_norm
    from .errors import local_errors as local_errors
    from .estimate import EstimatedAdamsBashforth as EstimatedAdamsBashforth
    from .estimate import EstimationResult as EstimationResult
    from .estimate import estimate as estimate
    from .estimate import estimate_and_predict as estimate_and_predict
    from .experiments import advise as advise
    from .methods import AdamsBashforth as AdamsBashforth
    from .methods import Euler as Euler
    from .methods import RungeKutta as RungeKutta
    from .methods import Tustin as Tustin
    from .methods import available_methods as available_methods
    from .methods import get_method as get_method
    from .noise import add_noise as add_noise
    from .predict import predict as predict
    from .simulate import simulate as simulate


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


class _Facade(types.ModuleType):
    """Keeps ``sampledyn.simulate``, ``.predict`` and ``.estimate`` the functions when
    their modules are imported (the import system sets a package attribute per
    submodule; the eager package overwrote them with the functions likewise)."""

    def __setattr__(self, name: str, value: Any) -> None:
        if isinstance(value, types.ModuleType) and _EXPORTS.get(name) == f".{name}":
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Facade
