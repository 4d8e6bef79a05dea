"""The paper's AUV-like system, eqs. (9)-(10), as a symbolic model.

    y' = alpha y**2 + beta y + gamma y|y| + delta sin(x)**2 + u1      (9)
    x' = -sin(x)**2 y                                                  (10)

x plays a position (the argument of a combined pitch-roll rotation), y a velocity.
The state vector is ordered position first, as for vehicles (eta then v):
``state = (x, y)``. The system has no physical scale of its own; units are nominal.

The equations are the text below, parsed by sympy without evaluation so that the
compiled kernel performs the same floating-point operations in the same order as the
hand-written kernel it replaced (``alpha*y*y``, not ``alpha*y**2``); every derived
object (Jacobian, switching function y of ``y|y|``, the regressors of the four
parameters, which all enter linearly) comes from :class:`SymbolicModel`.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from ._base import CompiledModel, LinearForm
from ._symbolic import SymbolicModel

__all__ = ["AUVLike"]

# (symbol, unit)
_STATES = (("x", "m"), ("y", "m/s"))
_INPUTS = (("u1", "m/s^2"),)
_PARAM_UNITS = {"alpha": "1/m", "beta": "1/s", "gamma": "1/m", "delta": "m/s^2"}
_RHS = (
    "-sin(x)**2*y",  # (10)
    "alpha*y*y + beta*y + gamma*y*Abs(y) + delta*sin(x)**2 + u1",  # (9)
)
# Default initial state: off the equilibrium x = 0 of (10) (there x stays 0 whatever
# the input, the sin(x)**2 terms vanish and delta cannot be estimated); the paper's
# Figs. 2-3 start here too.
_X0 = (1.0, 0.0)


@functools.cache
def _template() -> SymbolicModel:
    import sympy as sp
    from sympy.parsing.sympy_parser import parse_expr

    names = [n for n, _ in _STATES] + [n for n, _ in _INPUTS] + list(_PARAM_UNITS)
    sym = {n: sp.Symbol(n, real=True) for n in names}
    rhs = [parse_expr(text, local_dict=sym, evaluate=False) for text in _RHS]
    defaults = AUVLike().params
    return SymbolicModel(
        [sym[n] for n, _ in _STATES],
        [sym[n] for n, _ in _INPUTS],
        rhs,
        params={sym[n]: defaults[n] for n in _PARAM_UNITS},
        state_units=[u for _, u in _STATES],
        input_units=[u for _, u in _INPUTS],
        param_units=_PARAM_UNITS,
        x0=_X0,
        name="AUV-like system, eqs. (9)-(10)",
    )


@dataclass(frozen=True)
class AUVLike(CompiledModel):
    """AUV-like system of eqs. (9)-(10) with the paper's coefficients as defaults.

    Parameters
    ----------
    alpha : float
        Coriolis-like quadratic coefficient (1/m). Default -0.1.
    beta : float
        Linear drag coefficient (1/s). Default -0.05.
    gamma : float
        Quadratic drag coefficient (1/m). Default -0.2.
    delta : float
        Buoyancy-like coefficient (m/s^2). Default 0.5.

    Notes
    -----
    Default initial state (x, y) = (1, 0): x = 0 is an equilibrium of eq. (10).
    :attr:`symbolic` is the :class:`SymbolicModel` every kernel comes from.
    """

    alpha: float = -0.1
    beta: float = -0.05
    gamma: float = -0.2
    delta: float = 0.5

    nx = 2
    nu = 1
    state_names = tuple(n for n, _ in _STATES)
    state_units = tuple(u for _, u in _STATES)
    input_names = tuple(n for n, _ in _INPUTS)
    input_units = tuple(u for _, u in _INPUTS)
    param_units = _PARAM_UNITS

    def __post_init__(self) -> None:
        for fld in fields(self):
            value = getattr(self, fld.name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ValueError(f"`{fld.name}` must be a finite number, got {value!r}.")
            if not math.isfinite(value):
                raise ValueError(f"`{fld.name}` must be a finite number, got {value!r}.")

    @property
    def symbolic(self) -> SymbolicModel:
        """The symbolic model with these parameter values (built on first use)."""
        sym = self.__dict__.get("_symbolic")
        if sym is None:
            sym = _template().with_params(**self.params)
            object.__setattr__(self, "_symbolic", sym)
        return sym

    def __getstate__(self) -> dict[str, Any]:
        return {fld.name: getattr(self, fld.name) for fld in fields(self)}

    def __setstate__(self, state: dict[str, Any]) -> None:
        for name, value in state.items():
            object.__setattr__(self, name, value)

    @property
    def params(self) -> dict[str, float]:
        """Parameter values by name (units in :attr:`param_units`)."""
        return {fld.name: float(getattr(self, fld.name)) for fld in fields(self)}

    @property
    def param_names(self) -> tuple[str, ...]:
        return tuple(fld.name for fld in fields(self))

    @property
    def kink_states(self) -> tuple[int, ...]:
        """(1,): y|y| is not smooth at y = 0 (found from the expressions)."""
        return self.symbolic.kink_states

    @property
    def kink_inputs(self) -> tuple[int, ...]:
        return self.symbolic.kink_inputs

    @property
    def default_x0(self) -> np.ndarray:
        return np.array(_X0)

    def with_params(self, **values: float) -> AUVLike:
        """The same model with some parameters changed."""
        unknown = set(values) - set(self.param_names)
        if unknown:
            raise TypeError(
                f"unknown parameter(s) {sorted(unknown)}; valid: {list(self.param_names)}."
            )
        return replace(self, **values)

    def kernel(self) -> tuple[Any, np.ndarray]:
        k = self.__dict__.get("_kernel")
        if k is None:
            k = self.symbolic.kernel()
            object.__setattr__(self, "_kernel", k)
        return k

    def jacobian_kernel(self) -> tuple[Any, np.ndarray]:
        return self.symbolic.jacobian_kernel()

    def input_jacobian_kernel(self) -> tuple[Any, np.ndarray]:
        return self.symbolic.input_jacobian_kernel()

    def switch_kernel(self) -> tuple[Any, np.ndarray, np.ndarray]:
        return self.symbolic.switch_kernel()

    def regressors(self, t: Any, x: Any, u: Any) -> LinearForm:
        """Linear-in-parameters form ``f = Phi @ theta + f0`` with theta = (alpha, beta,
        gamma, delta).

        Returns
        -------
        LinearForm with ``phi`` of shape (N, 2, 4) and ``f0`` of shape (N, 2).
        """
        x = np.atleast_2d(np.asarray(x, dtype=float))
        if x.shape[1] != 2:
            raise ValueError(f"`x` must have shape (N, 2), got {x.shape}.")
        u = np.asarray(u, dtype=float).reshape(x.shape[0], 1)
        return self.symbolic.regressors(t, x, u)
