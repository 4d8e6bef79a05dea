"""Tustin (trapezoid, implicit): x_{n+1} = x_n + h/2 (f(t_n, x_n, u) + f(t_{n+1}, x_{n+1}, u)).

Solved for every interval at once by a batched Newton iteration with the model's
analytic Jacobian.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .._trajectory import Trajectory
from ._base import stage_inputs

__all__ = ["ConvergenceError", "Tustin"]


class ConvergenceError(RuntimeError):
    """An implicit rule's Newton iteration did not converge."""


@dataclass(frozen=True)
class Tustin:
    """Trapezoid rule (bilinear transform), order 2, implicit.

    Parameters
    ----------
    tol : float
        Newton stops when every update satisfies |dx_i| <= tol * (1 + |x_i|).
    max_iter : int
        Newton iterations before :class:`ConvergenceError` is raised.
    """

    tol: float = 1e-12
    max_iter: int = 25
    name: str = "T"
    order: int = 2

    def __post_init__(self) -> None:
        if not (self.tol > 0):
            raise ValueError(f"`tol` must be positive, got {self.tol}.")
        if self.max_iter < 1:
            raise ValueError(f"`max_iter` must be >= 1, got {self.max_iter}.")

    @property
    def history(self) -> int:
        return 1

    def predict(self, model: Any, data: Trajectory, signal: Any = None) -> np.ndarray:
        """One-step-ahead predictions; the input over ``[t_n, t_{n+1}]`` is the held
        sample, or ``signal`` at both ends (its left limit at t_{n+1}) when given."""
        h = data.h
        t0, t1 = data.t[:-1], data.t[:-1] + h
        x0 = data.x[:-1]
        u0 = data.u[:-1]
        u1 = stage_inputs(data, signal, 1.0)
        f0 = model.f(t0, x0, u0)
        x = x0 + h * f0  # Euler predictor as the starting guess
        eye = np.eye(data.nx)
        converged = np.zeros(x0.shape[0], dtype=bool)
        for _ in range(self.max_iter):
            g = x - x0 - 0.5 * h * (f0 + model.f(t1, x, u1))
            jac = eye - 0.5 * h * model.jacobian(t1, x, u1)
            dx = np.linalg.solve(jac, -g[..., None])[..., 0]
            x = x + dx
            converged = (np.abs(dx) <= self.tol * (1.0 + np.abs(x))).all(axis=1)
            if converged.all():
                break
        if not converged.all():
            bad = np.flatnonzero(~converged)
            raise ConvergenceError(
                f"Tustin's Newton iteration did not converge in {self.max_iter} iterations "
                f"on {bad.size} of {converged.size} intervals (first: n={bad[0]}, "
                f"t={t0[bad[0]]:g} s). The step h={h} s may be too large for the model's "
                "stiffness there; raise `max_iter` or `tol`, or use a smaller h."
            )
        out = np.full(data.x.shape, np.nan)
        out[1:] = x
        return out
