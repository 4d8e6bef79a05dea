"""The named inputs, in one table.

A sweep file or a study names its input by a string (``input = "fig6"``) or a table
(``{ name = "multilevel", hold = 0.1 }``), so that it follows the library: ``"fig6"``
is whatever :func:`sampledyn.signals.fig6_thrusters` maps onto the vehicle today. An
entry builds the signal for a model: ``factory(model, **parameters)``. The inputs of
the sensitivity analysis (``gentle``, ``pitch``) are listed here and imported from
:mod:`sampledyn.sensitivity` on first use. Add an input with ``INPUTS.register``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from .._named import NamedTable
from ._base import Signal
from ._fig6 import fig6_thrusters
from ._multilevel import Multilevel
from ._sinusoid import Sinusoidal

if TYPE_CHECKING:  # signals do not import the models at run time
    from ..models import Model

__all__ = ["INPUTS", "input_for"]


def _multilevel(model: Model, low: float, high: float, hold: float, seed: int) -> Signal:
    return Multilevel(low=low, high=high, hold=hold, seed=seed, nu=int(model.nu))


def _sinusoidal(
    model: Model, offset: Any, amplitude: Any, frequency_hz: Any, phase_rad: Any
) -> Any:
    nu = int(model.nu)
    return Sinusoidal(
        [0.0] * nu if offset is None else offset,
        [0.0] * nu if amplitude is None else amplitude,
        [0.0] * nu if frequency_hz is None else frequency_hz,
        phase_rad,
        names=tuple(model.input_names),
        units=tuple(getattr(model, "input_units", ()) or ()),
    )


#: Input name -> ``factory(model, **parameters)``, with every parameter's default.
INPUTS = NamedTable("input")
INPUTS.register("fig6", fig6_thrusters, "the paper's Fig. 6 thruster rpm, mapped onto the vehicle")
INPUTS.register(
    "gentle",
    "sampledyn.sensitivity:gentle_input",
    "the Fig. 6 thruster rpm with every mean and sinusoid times `scale` (keeps a light "
    "vehicle's attitude in range; sampledyn.sensitivity.gentle_input)",
    {"scale": 0.2},
)
INPUTS.register(
    "pitch",
    "sampledyn.sensitivity:pitch_input",
    "a slow nose-up / nose-down sweep by the vertical thrusters "
    "(sampledyn.sensitivity.pitch_input)",
    {"pitch_frac": 0.2, "period_s": 50.0, "excitation_frac": 0.1},
)
INPUTS.register(
    "sinusoidal",
    _sinusoidal,
    "offset + sum of sinusoids per input channel (lists of length nu, or nu lists of K "
    "sinusoids), input units and Hz",
    {"offset": None, "amplitude": None, "frequency_hz": None, "phase_rad": None},
)
INPUTS.register(
    "multilevel",
    _multilevel,
    "random multilevel input (section 4.1): levels uniform in [low, high] held for `hold` s",
    {"low": -10.0, "high": 10.0, "hold": 0.1, "seed": 0},
)


def input_for(spec: Mapping[str, Any], model: Model) -> Any:
    """The signal of the input ``spec`` (``{"name": ..., **parameters}``, checked against
    :data:`INPUTS`) for ``model`` (the plant: a closed loop's reference has the plant's
    input channels).

    Raises
    ------
    ValueError
        for an unknown input or parameter (listing the valid ones).
    """
    return INPUTS.build(spec, model)
