"""Input signals: random multilevel, sinusoidal thruster rpm, zero-order hold; the
named inputs of sweep files and studies (:data:`INPUTS`)."""

from ._base import Signal as Signal
from ._fig6 import fig6_thrusters as fig6_thrusters
from ._multilevel import Multilevel as Multilevel
from ._multilevel import ZeroOrderHold as ZeroOrderHold
from ._names import INPUTS as INPUTS
from ._sinusoid import Sinusoidal as Sinusoidal

__all__ = [
    "INPUTS",
    "Multilevel",
    "Signal",
    "Sinusoidal",
    "ZeroOrderHold",
    "fig6_thrusters",
]
