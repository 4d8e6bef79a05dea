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
from ._base import JAC_SIG as JAC_SIG
from ._base import JAC_TYPE as JAC_TYPE
from ._base import RHS_SIG as RHS_SIG
from ._base import RHS_TYPE as RHS_TYPE
from ._base import RO1 as RO1
from ._base import RO2 as RO2
from ._base import CompiledModel as CompiledModel
from ._base import JacobianUnavailableError as JacobianUnavailableError
from ._base import LinearForm as LinearForm
from ._base import Model as Model
from ._base import index_switch as index_switch
from ._base import readonly as readonly
from ._closed_loop import ClosedLoop as ClosedLoop
from ._closed_loop import FeedbackLaw as FeedbackLaw
from ._closed_loop import LinearFeedback as LinearFeedback
from ._codegen import cache_dir as cache_dir
from ._codegen import import_line as kernel_import_line
from ._codegen import load_module as load_generated_module
from ._function import FunctionModel as FunctionModel
from ._jumps import decide as decide
from ._jumps import refuse_jumps as refuse_jumps
from ._jumps import sliding_weight as sliding_weight
from ._jumps import surface_at as jump_surface_at
from ._names import FEEDBACK_LAWS as FEEDBACK_LAWS
from ._names import MODELS as MODELS
from ._names import close_loop as close_loop
from ._names import is_model_file as is_model_file
from ._names import model_from_name as model_from_name
from ._names import model_names as model_names
from ._rigid_body import SingularPitchError as SingularPitchError
from ._rigid_body import rotation_jacobian as rotation_jacobian
from ._rigid_body import rotation_jacobian_inverse as rotation_jacobian_inverse
from ._rigid_body import thruster_allocation as thruster_allocation
from ._symbolic import SymbolicModel as SymbolicModel
from ._vehicle import Vehicle as Vehicle
from ._vehicle_file import builtin_vehicles as builtin_vehicles
from ._vehicle_file import load_vehicle as load_vehicle

__all__ = [
    "FEEDBACK_LAWS",
    "MODELS",
    "AUVLike",
    "AttitudeHold",
    "ClosedLoop",
    "CompiledModel",
    "FeedbackLaw",
    "FunctionModel",
    "JacobianUnavailableError",
    "LinearFeedback",
    "LinearForm",
    "Model",
    "SingularPitchError",
    "SymbolicModel",
    "Vehicle",
    "builtin_vehicles",
    "cache_dir",
    "close_loop",
    "is_model_file",
    "kernel_import_line",
    "load_generated_module",
    "jump_surface_at",
    "load_vehicle",
    "refuse_jumps",
    "model_from_name",
    "model_names",
    "roll_pitch_hold",
    "rotation_jacobian",
    "rotation_jacobian_inverse",
    "thruster_allocation",
]
