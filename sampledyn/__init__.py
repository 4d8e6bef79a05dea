"""sampledyn: sampled-data models of vehicle dynamics.

One-step-ahead predictors (Euler, Tustin, Runge-Kutta, Adams-Bashforth) built from
continuous-time vehicle models, run against exact sampled data, with local errors.
"""

from . import methods as methods
from . import models as models
from . import results as results
from . import sensitivity as sensitivity
from . import signals as signals
from ._trajectory import Certificate as Certificate
from ._trajectory import Trajectory as Trajectory
from ._version import __version__ as __version__
from .errors import error_norm as error_norm
from .errors import local_errors as local_errors
from .estimate import EstimatedAdamsBashforth as EstimatedAdamsBashforth
from .estimate import EstimationResult as EstimationResult
from .estimate import estimate as estimate
from .estimate import estimate_and_predict as estimate_and_predict
from .methods import AdamsBashforth as AdamsBashforth
from .methods import Euler as Euler
from .methods import RungeKutta as RungeKutta
from .methods import Tustin as Tustin
from .methods import available_methods as available_methods
from .methods import get_method as get_method
from .noise import add_noise as add_noise
from .predict import predict as predict
from .sensitivity import advise as advise
from .simulate import simulate as simulate

__all__ = [
    "AdamsBashforth",
    "add_noise",
    "advise",
    "Certificate",
    "Euler",
    "EstimatedAdamsBashforth",
    "EstimationResult",
    "RungeKutta",
    "Trajectory",
    "Tustin",
    "available_methods",
    "error_norm",
    "estimate",
    "estimate_and_predict",
    "get_method",
    "local_errors",
    "methods",
    "models",
    "predict",
    "sensitivity",
    "results",
    "signals",
    "simulate",
]
