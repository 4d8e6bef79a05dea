"""Sampled-data rules: Euler, Tustin, Runge-Kutta, Adams-Bashforth (also with the input
held over the predicted interval, ABu_s, and with its history rebuilt after an input
jump, ABj_s), the exact zero-order hold ZOH, and the registry of their names.

Every rule answers the questions of small runtime-checkable protocols itself:
:class:`Method` (name, family, order, history, label), :class:`Predictor`
(prediction on uniform and non-uniform time), :class:`NoiseAnalysis` (noise gain,
prediction Jacobians, error constant), :class:`Estimator` (Ee, ABe_s) and
:class:`DiscreteTimeSystem` (its step as data, :class:`StepProgram`, from which the
compiled step, the vector blocks and the linearisation are derived); other layers
ask it with ``isinstance`` instead of inspecting its class or parsing its name. The
registry (:data:`BUILT_IN`) lists every family, the estimated ones (defined in
:mod:`sampledyn.estimate`) as lazy entries.
"""

# isort: off
from ._registry import BUILT_IN as BUILT_IN
from ._registry import Family as Family
from ._registry import available_methods as available_methods
from ._registry import describe_methods as describe_methods
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
from ._base import check_gain_args as check_gain_args
from ._base import check_ratio as check_ratio
from ._base import fixed_step as fixed_step
from ._base import grid_steps as grid_steps
from ._base import nan_rows as nan_rows
from ._base import sample_f as sample_f
from ._base import sample_jacobian as sample_jacobian
from ._base import stage_inputs as stage_inputs
from ._base import stencil_steps as stencil_steps
from ._base import time_steps as time_steps
from ._base import uniform_grid as uniform_grid
from ._base import uniform_step as uniform_step
from ._program import Combination as Combination
from ._program import ConvergenceError as ConvergenceError
from ._program import Stage as Stage
from ._program import StepProgram as StepProgram
from ._nodes import MAX_GAIN_ORDER as MAX_GAIN_ORDER
from ._nodes import lagrange_integrals as lagrange_integrals
from ._adams import STABILITY_INTERVAL_MIN as STABILITY_INTERVAL_MIN
from ._adams import AdamsBashforth as AdamsBashforth
from ._adams import Euler as Euler
from ._adams import ab_coefficients as ab_coefficients
from ._adams import ab_error_constant as ab_error_constant
from ._adams import ab_filter as ab_filter
from ._adams import ab_filter_steps as ab_filter_steps
from ._adams import ab_gain_factor as ab_gain_factor
from ._adams import ab_stability_interval as ab_stability_interval
from ._adams import lagged_jacobians as lagged_jacobians
from ._adams import warn_if_unstable as warn_if_unstable
from ._tustin import Tustin as Tustin
from ._runge_kutta import TABLEAUX as TABLEAUX
from ._runge_kutta import ButcherTableau as ButcherTableau
from ._runge_kutta import RungeKutta as RungeKutta
from ._held import HeldInputAdamsBashforth as HeldInputAdamsBashforth
from ._jump import JumpAwareAdamsBashforth as JumpAwareAdamsBashforth
from ._jump import collocation_weights as collocation_weights
from ._exact import ExactHold as ExactHold
from ._exact import zoh_matrices as zoh_matrices
# isort: on

__all__ = [
    "BUILT_IN",
    "MAX_GAIN_ORDER",
    "STABILITY_INTERVAL_MIN",
    "TABLEAUX",
    "AdamsBashforth",
    "ButcherTableau",
    "Combination",
    "ConvergenceError",
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
    "StepProgram",
    "Tustin",
    "ab_coefficients",
    "ab_error_constant",
    "ab_filter",
    "ab_filter_steps",
    "ab_gain_factor",
    "ab_stability_interval",
    "available_methods",
    "check_gain_args",
    "check_ratio",
    "collocation_weights",
    "describe_methods",
    "families",
    "fixed_step",
    "get_method",
    "get_predictor",
    "grid_steps",
    "lagged_jacobians",
    "lagrange_integrals",
    "nan_rows",
    "register_family",
    "sample_f",
    "sample_jacobian",
    "stage_inputs",
    "stencil_steps",
    "time_steps",
    "uniform_grid",
    "uniform_step",
    "warn_if_unstable",
    "zoh_matrices",
]
