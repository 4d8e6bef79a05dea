"""Sampled-data rules: Euler, Tustin, Runge-Kutta, Adams-Bashforth (also with the input
held over the predicted interval, ABu_s, and with its history rebuilt after an input
jump, ABj_s), and the registry of their names.

Every rule answers the questions of the :class:`Method` protocol itself (family,
order, history, prediction, noise gain, prediction Jacobians, error constant, label);
other layers ask it instead of inspecting its class or parsing its name. Each family
registers itself with :func:`register_family`; the estimated rules (Ee, ABe_s) are
registered by :mod:`sampledyn.estimate`.
"""

# isort: off
# Each rule module registers its families on import, and registration order is listing
# order (available_methods, `sampledyn methods`, the figures): E, AB, T, RK, ABu, ABj.
from ._registry import Family as Family
from ._registry import available_methods as available_methods
from ._registry import describe_methods as describe_methods
from ._registry import families as families
from ._registry import get_method as get_method
from ._registry import register_family as register_family
from ._base import FixedRule as FixedRule
from ._base import Method as Method
from ._base import check_gain_args as check_gain_args
from ._base import nan_rows as nan_rows
from ._base import sample_f as sample_f
from ._base import sample_jacobian as sample_jacobian
from ._base import stage_inputs as stage_inputs
from ._base import uniform_step as uniform_step
from ._adams import STABILITY_INTERVAL_MIN as STABILITY_INTERVAL_MIN
from ._adams import AdamsBashforth as AdamsBashforth
from ._adams import Euler as Euler
from ._adams import ab_coefficients as ab_coefficients
from ._adams import ab_error_constant as ab_error_constant
from ._adams import ab_filter as ab_filter
from ._adams import ab_stability_interval as ab_stability_interval
from ._adams import lagged_jacobians as lagged_jacobians
from ._adams import warn_if_unstable as warn_if_unstable
from ._tustin import ConvergenceError as ConvergenceError
from ._tustin import Tustin as Tustin
from ._runge_kutta import TABLEAUX as TABLEAUX
from ._runge_kutta import ButcherTableau as ButcherTableau
from ._runge_kutta import RungeKutta as RungeKutta
from ._held import HeldInputAdamsBashforth as HeldInputAdamsBashforth
from ._jump import JumpAwareAdamsBashforth as JumpAwareAdamsBashforth
# isort: on

__all__ = [
    "STABILITY_INTERVAL_MIN",
    "TABLEAUX",
    "AdamsBashforth",
    "ButcherTableau",
    "ConvergenceError",
    "Euler",
    "Family",
    "FixedRule",
    "HeldInputAdamsBashforth",
    "JumpAwareAdamsBashforth",
    "Method",
    "RungeKutta",
    "Tustin",
    "ab_coefficients",
    "ab_error_constant",
    "ab_filter",
    "ab_stability_interval",
    "available_methods",
    "check_gain_args",
    "describe_methods",
    "families",
    "get_method",
    "lagged_jacobians",
    "nan_rows",
    "register_family",
    "sample_f",
    "sample_jacobian",
    "stage_inputs",
    "uniform_step",
    "warn_if_unstable",
]
