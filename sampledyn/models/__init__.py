"""Continuous-time vehicle models: ``x' = f(t, x, u)`` with analytic Jacobians."""

from ._attitude_hold import AttitudeHold as AttitudeHold
from ._auv import AUVLike as AUVLike

# numba signatures of compiled right-hand sides, for the simulator's kernels
from ._base import RHS_SIG as RHS_SIG
from ._base import RHS_TYPE as RHS_TYPE
from ._base import RO1 as RO1
from ._base import RO2 as RO2
from ._base import CompiledModel as CompiledModel
from ._base import LinearForm as LinearForm
from ._base import Model as Model
from ._base import readonly as readonly
from ._rigid_body import rotation_jacobian as rotation_jacobian
from ._rigid_body import rotation_jacobian_inverse as rotation_jacobian_inverse
from ._rigid_body import thruster_allocation as thruster_allocation
from ._vehicle import Vehicle as Vehicle
from ._vehicle_file import builtin_vehicles as builtin_vehicles
from ._vehicle_file import load_vehicle as load_vehicle

__all__ = [
    "AUVLike",
    "AttitudeHold",
    "CompiledModel",
    "LinearForm",
    "Model",
    "Vehicle",
    "builtin_vehicles",
    "load_vehicle",
    "rotation_jacobian",
    "rotation_jacobian_inverse",
    "thruster_allocation",
]
