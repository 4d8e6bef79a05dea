"""Discrete-time models of the sampled-data rules, and the loop of a digital controller.

:func:`discretize` turns a model and a rule (E, AB_s, ABu_s, RK_s, T, ZOH) into a
discrete-time system z+ = F(z, u) (:class:`DiscreteModel`: ``step``, ``rollout``,
``linearize``, ``steady_state``, ``noise_gain``, ``to_control``, ``to_casadi``).
:func:`run_loop` runs a digital controller against the exact plant (input held
between samples, optionally one sample late); :class:`LinearLaw` is a state-feedback
law given as data, evaluated in compiled code. :func:`casadi_rhs` is a model's f as a
CasADi function.
"""

from ._loop import LinearLaw as LinearLaw
from ._loop import run_loop as run_loop
from ._model import DiscreteModel as DiscreteModel
from ._model import discretize as discretize

__all__ = [
    "DiscreteModel",
    "LinearLaw",
    "discretize",
    "run_loop",
]
