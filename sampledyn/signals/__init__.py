"""Input signals: random multilevel, sinusoidal thruster rpm, zero-order hold."""

from ._base import InputSpec as InputSpec
from ._base import Signal as Signal
from ._multilevel import Multilevel as Multilevel
from ._multilevel import ZeroOrderHold as ZeroOrderHold

__all__ = ["InputSpec", "Multilevel", "Signal", "ZeroOrderHold"]
