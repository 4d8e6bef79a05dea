"""Tustin (trapezoid, implicit): x_{n+1} = x_n + h/2 (f(t_n, x_n, u) + f(t_{n+1}, x_{n+1}, u)).

Solved for every interval at once by a batched Newton iteration with the model's
analytic Jacobian.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from .._trajectory import Trajectory
from ._base import FixedRule, check_gain_args, nan_rows, stage_inputs, uniform_step
from ._registry import register_family

__all__ = ["ConvergenceError", "Tustin"]


class ConvergenceError(RuntimeError):
    """An implicit rule's Newton iteration did not converge."""


# z = x_n, the input held; Newton with the model's Jacobian as in Tustin.predict.
_T_STEP = """
TOL = {tol!r}
MAX_ITER = {max_iter}


@njit(cache=CACHE, error_model="numpy")
def step(t, z, u, p, h, out):
    nx = z.shape[0]
    f0 = np.empty(nx)
    f1 = np.empty(nx)
    J = np.empty((nx, nx))
    x = np.empty(nx)
    g = np.empty(nx)
    rhs(t, z, u, p, f0)
    for j in range(nx):
        x[j] = z[j] + h * f0[j]
    t1 = t + h
    ok = False
    for _ in range(MAX_ITER):
        rhs(t1, x, u, p, f1)
        jac(t1, x, u, p, J)
        for j in range(nx):
            g[j] = -(x[j] - z[j] - 0.5 * h * (f0[j] + f1[j]))
        M = -0.5 * h * J
        for j in range(nx):
            M[j, j] += 1.0
        dx = np.linalg.solve(M, g)
        ok = True
        for j in range(nx):
            x[j] += dx[j]
            if abs(dx[j]) > TOL * (1.0 + abs(x[j])):
                ok = False
        if ok:
            break
    for j in range(nx):
        out[j] = x[j] if ok else np.nan
"""


@dataclass(frozen=True)
class Tustin(FixedRule):
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
    def family(self) -> str:
        return "T"

    @property
    def history(self) -> int:
        return 1

    @property
    def intersample(self) -> bool:
        """True: f is evaluated at t_{n+1}, with the input there."""
        return True

    @property
    def first_order_gain(self) -> Fraction:
        return Fraction(1)

    @property
    def error_constant(self) -> Fraction:
        """-1/12: the trapezoid's local error is ``-h^3/12 x^(3) + O(h^4)``."""
        return Fraction(-1, 12)

    def predict(
        self,
        model: Any,
        data: Trajectory,
        signal: Any = None,
        *,
        cache: dict[Any, Any] | None = None,
    ) -> np.ndarray:
        """One-step-ahead predictions, shape (N, nx), NaN in row 0; the input over
        ``[t_n, t_{n+1}]`` is the held sample, or ``signal`` at both ends (its left
        limit at t_{n+1}) when given.

        Raises
        ------
        ConvergenceError
            if Newton's iteration does not converge on some interval.
        """
        h = uniform_step(data, self.name)
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
        out = nan_rows(data, (data.nx,))
        out[1:] = x
        return out

    def noise_gain(self, h: float, lipschitz: Any) -> np.ndarray:
        """The implicit solution moves by ``d = delta + (h/2) L (delta + d)``, so
        ``G = h L (I - h L / 2)^-1`` (scalar: ``z / (1 - z/2)``); every entry is inf
        when the spectral radius of ``h L / 2`` is >= 1."""
        h, L = check_gain_args(h, lipschitz)
        half = 0.5 * h * L
        if max(abs(np.linalg.eigvals(half))) >= 1.0:
            return np.full(L.shape, np.inf)
        return h * L @ np.linalg.inv(np.eye(L.shape[0]) - half)

    def prediction_jacobians(
        self,
        model: Any,
        data: Trajectory,
        signal: Any = None,
        *,
        cache: dict[Any, Any] | None = None,
    ) -> np.ndarray:
        """``d x_hat[k] / d x[k-1] = (I - h/2 F(x_hat_k))^-1 (I + h/2 F(x_{k-1}))``,
        shape (N, 1, nx, nx)."""
        h = uniform_step(data, self.name)
        x_hat = self.predict(model, data, signal)
        eye = np.eye(data.nx)
        f0 = np.asarray(model.jacobian(data.t[:-1], data.x[:-1], data.u[:-1]))
        u1 = stage_inputs(data, signal, 1.0)
        f1 = np.asarray(model.jacobian(data.t[1:], x_hat[1:], u1))
        phi = nan_rows(data, (1, data.nx, data.nx))
        phi[1:, 0] = np.linalg.solve(eye - 0.5 * h * f1, eye + 0.5 * h * f0)
        return phi

    # ---- discrete-time state-space form (used by sampledyn.discretize) ----------

    @property
    def state_layout(self) -> tuple[tuple[str, int], ...]:
        """z = x_n: one block, the state."""
        return (("x", 0),)

    def step_source(self) -> str:
        """numba source of ``step(t, z, u, p, h, out)`` (globals ``rhs``, ``jac``,
        ``np``): the Newton iteration of :meth:`predict` for one interval, input held;
        NaN where it does not converge."""
        return _T_STEP.format(tol=float(self.tol), max_iter=int(self.max_iter))

    def step_blocks(self, f: Any, t: Any, blocks: list[Any], u: Any, h: float, implicit=None):
        """x_{n+1} solving ``x - x_n - h/2 (f(t_n, x_n, u) + f(t_n + h, x, u)) = 0``:
        ``implicit(residual, guess)`` is the caller's root finder (e.g. CasADi's)."""
        if implicit is None:
            raise ValueError("Tustin is implicit: `implicit(residual, guess)` is needed.")
        x0 = blocks[0]
        f0 = f(t, x0, u)
        return [implicit(lambda x: x - x0 - (0.5 * h) * (f0 + f(t + h, x, u)), x0 + h * f0)]

    def linearize(self, model: Any, t: float, z: np.ndarray, u: np.ndarray, h: float):
        """(A_d, B_d) of the trapezoid step, shapes (nx, nx), (nx, nu): with x_{n+1}
        solved by Newton, ``A = (I - h/2 F_1)^-1 (I + h/2 F_0)`` and ``B = (I - h/2
        F_1)^-1 h/2 (G_0 + G_1)`` (F, G: df/dx, df/du at either end). On a linear
        model this is the bilinear (Tustin) map."""
        x0 = np.asarray(z, dtype=float)
        u = np.asarray(u, dtype=float)
        t0, t1 = float(t), float(t) + h
        eye = np.eye(model.nx)
        f0 = np.asarray(model.f(t0, x0, u), dtype=float)
        x = x0 + h * f0
        for _ in range(self.max_iter):
            g = x - x0 - 0.5 * h * (f0 + model.f(t1, x, u))
            dx = np.linalg.solve(eye - 0.5 * h * model.jacobian(t1, x, u), -g)
            x = x + dx
            if (np.abs(dx) <= self.tol * (1.0 + np.abs(x))).all():
                break
        else:
            raise ConvergenceError(
                f"Tustin's Newton iteration did not converge in {self.max_iter} iterations "
                f"at t={t0:g} s; use a smaller h or raise `max_iter`."
            )
        lhs = eye - 0.5 * h * np.asarray(model.jacobian(t1, x, u), dtype=float)
        A = np.linalg.solve(lhs, eye + 0.5 * h * np.asarray(model.jacobian(t0, x0, u)))
        G = np.asarray(model.input_jacobian(t0, x0, u)) + np.asarray(model.input_jacobian(t1, x, u))
        return A, np.linalg.solve(lhs, 0.5 * h * G)

    def steady_state(self, model: Any, x: np.ndarray, u: np.ndarray, t: float = 0.0):
        """z = x."""
        return np.array(x, dtype=float)


register_family("T", r"T", Tustin, "Tustin, implicit trapezoid")
