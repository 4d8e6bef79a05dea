"""Continuous-time models ``x' = f(t, x, u)`` with exact Jacobians.

Built-in: the paper's AUV-like system and Fossen-form vehicles (from vehicle files).
Your own: :class:`SymbolicModel` (sympy expressions; every derived kernel cached on
disk) or :class:`FunctionModel` (a numba-compilable function). Closed loops:
:class:`ClosedLoop` (a plant and a continuous feedback law).
"""

from ._attitude_hold import AttitudeHold as AttitudeHold
from ._attitude_hold import roll_pitch_hold as roll_pitch_hold
from ._auv import AUVLike as AUVLike

# numba signatures of compiled right-hand sides, for the simulator's kernels
from ._base import CompiledModel as CompiledModel
from ._base import Model as Model
from ._closed_loop import ClosedLoop as ClosedLoop
from ._closed_loop import FeedbackLaw as FeedbackLaw
from ._closed_loop import LinearFeedback as LinearFeedback
from ._codegen import cache_dir as cache_dir
from ._function import FunctionModel as FunctionModel
from ._names import FEEDBACK_LAWS as FEEDBACK_LAWS
from ._names import MODELS as MODELS
from ._symbolic import SymbolicModel as SymbolicModel
from ._vehicle import Vehicle as Vehicle
from ._vehicle_file import builtin_vehicles as builtin_vehicles
from ._vehicle_file import load_vehicle as load_vehicle

__all__ = [
    "AUVLike",
    "AttitudeHold",
    "ClosedLoop",
    "CompiledModel",
    "FEEDBACK_LAWS",
    "FeedbackLaw",
    "FunctionModel",
    "LinearFeedback",
    "MODELS",
    "Model",
    "SymbolicModel",
    "Vehicle",
    "builtin_vehicles",
    "cache_dir",
    "load_vehicle",
    "roll_pitch_hold",
]
