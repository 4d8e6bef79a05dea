"""Input signals: random multilevel, sinusoidal thruster rpm, zero-order hold; the
named inputs of sweep files and studies (:data:`INPUTS`)."""

from ._base import InputSpec as InputSpec
from ._base import Signal as Signal
from ._fig6 import FIG6_TABLE as FIG6_TABLE
from ._fig6 import fig6_thrusters as fig6_thrusters
from ._fig6 import thruster_roles as thruster_roles
from ._multilevel import Multilevel as Multilevel
from ._multilevel import ZeroOrderHold as ZeroOrderHold
from ._names import INPUTS as INPUTS
from ._names import input_for as input_for
from ._sinusoid import Sinusoidal as Sinusoidal

__all__ = [
    "FIG6_TABLE",
    "INPUTS",
    "input_for",
    "InputSpec",
    "fig6_thrusters",
    "thruster_roles",
    "Multilevel",
    "Signal",
    "Sinusoidal",
    "ZeroOrderHold",
]
