"""Sampled-data rules: Euler, Tustin, Runge-Kutta and Adams-Bashforth."""

from ._adams import AdamsBashforth as AdamsBashforth
from ._adams import Euler as Euler
from ._adams import ab_coefficients as ab_coefficients
from ._adams import ab_filter as ab_filter
from ._base import Method as Method
from ._registry import available_methods as available_methods
from ._registry import describe_methods as describe_methods
from ._registry import get_method as get_method
from ._registry import register_family as register_family
from ._runge_kutta import TABLEAUX as TABLEAUX
from ._runge_kutta import ButcherTableau as ButcherTableau
from ._runge_kutta import RungeKutta as RungeKutta
from ._tustin import ConvergenceError as ConvergenceError
from ._tustin import Tustin as Tustin

__all__ = [
    "TABLEAUX",
    "AdamsBashforth",
    "ButcherTableau",
    "ConvergenceError",
    "Euler",
    "Method",
    "RungeKutta",
    "Tustin",
    "ab_coefficients",
    "ab_filter",
    "available_methods",
    "describe_methods",
    "get_method",
    "register_family",
]
