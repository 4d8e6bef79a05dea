"""The paper's AUV-like system, eqs. (9)-(10).

    y' = alpha y**2 + beta y + gamma y|y| + delta sin(x)**2 + u1      (9)
    x' = -sin(x)**2 y                                                  (10)

x plays a position (the argument of a combined pitch-roll rotation), y a velocity.
The state vector is ordered position first, as for vehicles (eta then v):
``state = (x, y)``. The system has no physical scale of its own; units are nominal.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np
from numba import njit

from ._base import JAC_SIG, RHS_SIG, CompiledModel, LinearForm

__all__ = ["AUVLike"]


@njit(RHS_SIG, cache=True)
def _auv_rhs(t, x, u, p, out):  # pragma: no cover - compiled
    alpha, beta, gamma, delta = p[0], p[1], p[2], p[3]
    pos = x[0]
    vel = x[1]
    s2 = math.sin(pos) ** 2
    out[0] = -s2 * vel
    out[1] = alpha * vel * vel + beta * vel + gamma * vel * abs(vel) + delta * s2 + u[0]


@njit(JAC_SIG, cache=True)
def _auv_jac(t, x, u, p, out):  # pragma: no cover - compiled
    alpha, beta, gamma, delta = p[0], p[1], p[2], p[3]
    pos = x[0]
    vel = x[1]
    s2x = math.sin(2.0 * pos)  # d sin(x)^2 / dx
    out[0, 0] = -s2x * vel
    out[0, 1] = -(math.sin(pos) ** 2)
    out[1, 0] = delta * s2x
    out[1, 1] = 2.0 * alpha * vel + beta + 2.0 * gamma * abs(vel)


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
    """

    alpha: float = -0.1
    beta: float = -0.05
    gamma: float = -0.2
    delta: float = 0.5

    nx = 2
    nu = 1
    state_names = ("x", "y")
    state_units = ("m", "m/s")
    input_names = ("u1",)
    input_units = ("m/s^2",)
    # y|y| is not smooth at y = 0: the simulator ends its steps there.
    kink_states = (1,)
    kink_inputs = ()
    param_units = {"alpha": "1/m", "beta": "1/s", "gamma": "1/m", "delta": "m/s^2"}

    def __post_init__(self) -> None:
        for fld in fields(self):
            value = getattr(self, fld.name)
            if not isinstance(value, int | float) or not math.isfinite(value):
                raise ValueError(f"`{fld.name}` must be a finite number, got {value!r}.")

    @property
    def params(self) -> dict[str, float]:
        """Parameter values by name (units in :attr:`param_units`)."""
        return {fld.name: float(getattr(self, fld.name)) for fld in fields(self)}

    @property
    def param_names(self) -> tuple[str, ...]:
        return tuple(fld.name for fld in fields(self))

    def with_params(self, **values: float) -> AUVLike:
        """The same model with some parameters changed."""
        unknown = set(values) - set(self.param_names)
        if unknown:
            raise TypeError(
                f"unknown parameter(s) {sorted(unknown)}; valid: {list(self.param_names)}."
            )
        return replace(self, **values)

    def _p(self) -> np.ndarray:
        return np.array([self.alpha, self.beta, self.gamma, self.delta])

    def kernel(self) -> tuple[Any, np.ndarray]:
        return _auv_rhs, self._p()

    def jacobian_kernel(self) -> tuple[Any, np.ndarray]:
        return _auv_jac, self._p()

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
        pos, vel = x[:, 0], x[:, 1]
        s2 = np.sin(pos) ** 2
        phi = np.zeros((x.shape[0], 2, 4))
        phi[:, 1, 0] = vel * vel
        phi[:, 1, 1] = vel
        phi[:, 1, 2] = vel * np.abs(vel)
        phi[:, 1, 3] = s2
        f0 = np.stack([-s2 * vel, u[:, 0]], axis=1)
        units = tuple(self.param_units[n] for n in self.param_names)
        return LinearForm(self.param_names, units, phi, f0)
