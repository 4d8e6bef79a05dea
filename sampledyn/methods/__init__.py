"""Sampled-data rules: Euler, Tustin, Runge-Kutta, Adams-Bashforth (also with the input
held over the predicted interval, ABu_s, and with its history rebuilt after an input
jump, ABj_s), the exact zero-order hold ZOH, and the registry of their names.

Every rule answers the questions of small runtime-checkable protocols itself:
:class:`Method` (name, family, order, history, label), :class:`Predictor`
(prediction on uniform and non-uniform time), :class:`NoiseAnalysis` (noise gain,
prediction Jacobians, error constant), :class:`Estimator` (Ee, ABe_s) and
:class:`Stability` (its stability function or region, ``amplification(z)``) and
:class:`DiscreteTimeSystem` (its step as data, :class:`StepProgram`, from which the
compiled step, the vector blocks and the linearisation are derived); other layers
ask it with ``isinstance`` instead of inspecting its class or parsing its name. The
registry (:data:`BUILT_IN`) lists every family, the estimated ones (defined in
:mod:`sampledyn._estimate`) as lazy entries.
"""

# isort: off
from ._registry import Family as Family
from ._registry import available_methods as available_methods
from ._registry import families as families
from ._registry import get_method as get_method
from ._registry import get_predictor as get_predictor
from ._registry import register_family as register_family
from ._base import DiscreteStep as DiscreteStep
from ._base import DiscreteTimeSystem as DiscreteTimeSystem
from ._base import Estimator as Estimator
from ._base import FixedRule as FixedRule
from ._base import Method as Method
from ._base import NoiseAnalysis as NoiseAnalysis
from ._base import Predictor as Predictor
from ._base import Stability as Stability
from ._base import stencil_steps as stencil_steps
from ._stability import largest_stable_steps as largest_stable_steps
from ._program import Combination as Combination
from ._program import Stage as Stage
from ._program import StepProgram as StepProgram
from ._adams import AdamsBashforth as AdamsBashforth
from ._adams import Euler as Euler
from ._adams import ab_coefficients as ab_coefficients
from ._adams import ab_stability_interval as ab_stability_interval
from ._tustin import Tustin as Tustin
from ._runge_kutta import ButcherTableau as ButcherTableau
from ._runge_kutta import RungeKutta as RungeKutta
from ._held import HeldInputAdamsBashforth as HeldInputAdamsBashforth
from ._jump import JumpAwareAdamsBashforth as JumpAwareAdamsBashforth
from ._exact import ExactHold as ExactHold
# isort: on

__all__ = [
    "AdamsBashforth",
    "ButcherTableau",
    "Combination",
    "DiscreteStep",
    "DiscreteTimeSystem",
    "Estimator",
    "Euler",
    "ExactHold",
    "Family",
    "FixedRule",
    "HeldInputAdamsBashforth",
    "JumpAwareAdamsBashforth",
    "Method",
    "NoiseAnalysis",
    "Predictor",
    "RungeKutta",
    "Stage",
    "Stability",
    "StepProgram",
    "Tustin",
    "ab_coefficients",
    "ab_stability_interval",
    "available_methods",
    "families",
    "get_method",
    "get_predictor",
    "largest_stable_steps",
    "register_family",
    "stencil_steps",
]
