"""Tustin (trapezoid, implicit): x_{n+1} = x_n + h/2 (f(t_n, x_n, u) + f(t_{n+1}, x_{n+1}, u)).

Solved for every interval at once, h_n = t_{n+1} - t_n per interval, by a simplified
Newton iteration (Hairer & Wanner, Solving ODEs II, Sec. IV.8): the iteration matrix
``I - h_n/2 F`` is built from the model's analytic Jacobian F at the Euler predictor
and factored (LU with partial pivoting, compiled) once per interval, then reused;
each iteration costs one batch f and a triangular solve per interval. An interval
whose update fails to halve from one iteration to the next gets a fresh Jacobian and
LU at its current iterate (a full Newton step), so the iteration keeps Newton's
robustness. Each interval stops on its own test: the update's size
``q = max_i |dx_i| / (1 + |x_i|)`` is <= tol, or the error it leaves, estimated from the
contraction of the last two updates, is (Hairer & Wanner, Solving ODEs II, Sec. IV.8).
Either way the prediction is the trapezoid solution to within ``tol (1 + |x_i|)``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from fractions import Fraction
from typing import Any

import numpy as np
from numba import njit

from .. import _checks as checks
from .._trajectory import Trajectory
from ..exceptions import ArgumentError, ConvergenceError
from ..models import Model
from ._base import FixedRule, check_gain_args, check_ratio, grid_steps, nan_rows, stage_inputs
from ._program import Combination, Stage, StepProgram
from ._stability import rational_amplification

__all__ = ["NEWTON_BLOCK", "Tustin"]

# Intervals solved together: the LU factors of a block (NEWTON_BLOCK x nx x nx floats,
# 2.4 MB for nx = 12) stay in cache across its iterations instead of streaming the
# factors of every interval through memory once per iteration.
NEWTON_BLOCK = 2048


@dataclass(frozen=True)
class Tustin(FixedRule):
    """Trapezoid rule (bilinear transform), order 2, implicit.

    Parameters
    ----------
    tol : float
        Newton stops when every update satisfies |dx_i| <= tol * (1 + |x_i|).
    max_iter : int
        Newton iterations before :class:`ConvergenceError` is raised, 1 to
        :data:`sampledyn._checks.MAX_NEWTON_ITER` (1000; more raises
        :class:`~sampledyn.exceptions.ArgumentError`).
    """

    tol: float = 1e-12
    max_iter: int = 25
    name: str = "T"
    order: int = 2

    def __post_init__(self) -> None:
        checks.positive(self.tol, "tol")
        checks.count(self.max_iter, "max_iter")
        if self.max_iter > checks.MAX_NEWTON_ITER:
            raise ArgumentError(
                "max_iter",
                f"`max_iter` = {self.max_iter} Newton iterations is more than "
                f"{checks.MAX_NEWTON_ITER}: Newton converges quadratically, so an iteration "
                "not converged by then will not converge; use a smaller h or another rule.",
            )

    def with_newton(self, tol: float | None = None, max_iter: int | None = None) -> Tustin:
        """A copy with other Newton options (None keeps the current one)."""
        return replace(
            self,
            tol=self.tol if tol is None else float(tol),
            max_iter=self.max_iter if max_iter is None else int(max_iter),
        )

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

    @property
    def step_rule(self) -> str:
        return "step h_n = t_n+1 - t_n per interval"

    def predict(
        self,
        model: Model,
        data: Trajectory,
        signal: Any = None,
        *,
        cache: dict[Any, Any] | None = None,
    ) -> np.ndarray:
        """One-step-ahead predictions, shape (N, nx), NaN in row 0; the input over
        ``[t_n, t_{n+1}]`` is the held sample, or ``signal`` at both ends (its left
        limit at t_{n+1}) when given. On a non-uniform grid each interval has its own
        step h_n = t_{n+1} - t_n.

        Raises
        ------
        ConvergenceError
            if the Newton iteration does not converge on some interval.
        """
        out = nan_rows(data, (data.nx,))
        if data.n_samples < 2:
            return out
        h, steps = grid_steps(data)
        t0 = data.t[:-1]
        t1 = t0 + h if h is not None else data.t[1:]
        x0 = data.x[:-1]
        u1 = stage_inputs(data, signal, 1.0, None if h is not None else steps)
        f0 = np.require(model.f(t0, x0, data.u[:-1]), dtype=float, requirements="C")
        x = x0 + steps[:, None] * f0  # Euler predictor
        out[1:] = self._newton(model, t1, x0, u1, f0, x, steps)
        return out

    def _newton(
        self,
        model: Model,
        t1: np.ndarray,
        x0: np.ndarray,
        u1: np.ndarray,
        f0: np.ndarray,
        x: np.ndarray,
        h: np.ndarray,
    ) -> np.ndarray:
        """Solve ``x - x0 - h_n/2 (f0 + f(t1, x, u1)) = 0`` per interval from ``x`` (the
        predictor, updated in place), block by block of :data:`NEWTON_BLOCK` intervals
        (the factors of a block stay in cache across its iterations); shape (M, nx)."""
        m = x.shape[0]
        for lo in range(0, m, NEWTON_BLOCK):
            hi = min(lo + NEWTON_BLOCK, m)
            bad = self._newton_block(model, *(a[lo:hi] for a in (t1, x0, u1, f0, x, h)))
            if bad is not None:
                n = lo + int(bad[0])
                raise ConvergenceError(
                    f"Tustin's Newton iteration did not converge in {self.max_iter} "
                    f"iterations on {bad.size} of the {hi - lo} intervals {lo}..{hi - 1} "
                    f"(first: n={n}, t={t1[n] - h[n]:g} s, h_n={h[n]:g} s). The step may be "
                    "too large for the model's stiffness there; raise the iterations or the "
                    "tolerance (sampledyn.methods.Tustin(max_iter=..., tol=...), the `newton` "
                    "argument of evaluate_log / advise, --newton-max-iter / --newton-tol of "
                    "`sampledyn evaluate` and `advise`), or use a smaller h."
                )
        return x

    def _newton_block(self, model: Model, *block: np.ndarray) -> np.ndarray | None:
        """:meth:`_newton` on one block ``(t1, x0, u1, f0, x, h)`` (``x`` updated in
        place); None, or the indices of the intervals that did not converge."""
        t1, x0, u1, f0, x, h = block
        m, nx = x.shape
        lu = np.empty((m, nx, nx))
        perm = np.empty((m, nx), dtype=np.int64)
        prev = np.full(m, np.inf)  # size of each interval's last update
        active = np.arange(m)
        refresh = active
        for it in range(self.max_iter):
            if refresh.size == m:
                _factor(_c(model.jacobian(t1, x, u1)), h, refresh, lu, perm)
            elif refresh.size:
                jac = model.jacobian(t1[refresh], x[refresh], u1[refresh])
                _factor(_c(jac), h, refresh, lu, perm)
                prev[refresh] = np.inf  # no contraction estimate across a new Jacobian
            if active.size == m:
                f1 = _c(model.f(t1, x, u1))
            else:
                f1 = _c(model.f(t1[active], x[active], u1[active]))
            done = np.empty(active.size, dtype=np.bool_)
            slow = np.empty(active.size, dtype=np.bool_)
            left = self.max_iter - 1 - it
            _chord(x, x0, f0, f1, lu, perm, h, active, self.tol, left, prev, done, slow)
            refresh = active[slow & ~done]
            active = active[~done]
            if active.size == 0:
                return None
        return active

    def amplification(self, z: Any) -> np.ndarray:
        """``|R(z)| = |(1 + z/2) / (1 - z/2)|`` at each z = h lambda: <= 1 on the whole
        left half-plane (A-stable), so every step is stable on a mode with Re lambda <= 0."""
        return rational_amplification((1.0, 0.5), (1.0, -0.5), z)

    def noise_gain(self, h: float, lipschitz: Any, ratio: float = 1.0) -> np.ndarray:
        """The implicit solution moves by ``d = delta + (h/2) L (delta + d)``, so
        ``G = h L (I - h L / 2)^-1`` (scalar: ``z / (1 - z/2)``); every entry is inf
        when the spectral radius of ``h L / 2`` is >= 1.

        A one-step rule whose gain grows with the step: on a non-uniform grid h = the
        largest step bounds every interval, and ``ratio`` does not enter."""
        h, L = check_gain_args(h, lipschitz)
        check_ratio(ratio)
        half = 0.5 * h * L
        if max(abs(np.linalg.eigvals(half))) >= 1.0:
            return np.full(L.shape, np.inf)
        return h * L @ np.linalg.inv(np.eye(L.shape[0]) - half)

    def prediction_jacobians(
        self,
        model: Model,
        data: Trajectory,
        signal: Any = None,
        *,
        cache: dict[Any, Any] | None = None,
    ) -> np.ndarray:
        """``d x_hat[k] / d x[k-1] = (I - h/2 F(x_hat_k))^-1 (I + h/2 F(x_{k-1}))``
        (h_n per interval on a non-uniform grid), shape (N, 1, nx, nx)."""
        phi = nan_rows(data, (1, data.nx, data.nx))
        if data.n_samples < 2:
            return phi
        h, steps = grid_steps(data)
        hh = steps[:, None, None]
        x_hat = self.predict(model, data, signal)
        eye = np.eye(data.nx)
        f0 = np.asarray(model.jacobian(data.t[:-1], data.x[:-1], data.u[:-1]))
        u1 = stage_inputs(data, signal, 1.0, None if h is not None else steps)
        f1 = np.asarray(model.jacobian(data.t[1:], x_hat[1:], u1))
        phi[1:, 0] = np.linalg.solve(eye - 0.5 * hh * f1, eye + 0.5 * hh * f0)
        return phi

    # ---- discrete-time state-space form (used by sampledyn.discretize) ----------

    @property
    def discrete_step(self) -> StepProgram:
        """z = x_n, the input held: the trapezoid as a two-stage diagonally implicit
        program, ``k_0 = f(t_n, x_n, u)`` and x_{n+1} solving ``x = x_n + h (k_0 / 2 +
        f(t_n + h, x, u) / 2)`` by Newton's method with the model's Jacobian from the
        Euler predictor (``tol``, ``max_iter`` as :meth:`predict`). Its linearisation is
        ``A = (I - h/2 F_1)^-1 (I + h/2 F_0)``, ``B = (I - h/2 F_1)^-1 h/2 (G_0 + G_1)``:
        on a linear model the bilinear (Tustin) map."""
        half = Combination(("z", 0), ((0.5, ("k", 0)),), True)
        return StepProgram(
            "Tustin",
            (("x", 0),),
            (Stage(0.0, ("z", 0)), Stage(1.0, half, implicit=0.5)),
            ("y", 1),
            tol=float(self.tol),
            max_iter=int(self.max_iter),
        )


@njit(cache=True)
def _factor(jac, h, rows, lu, perm):  # pragma: no cover - compiled
    """For r = rows[i]: ``P (I - h_r/2 jac[i]) = L U`` with partial pivoting, in lu[r]:
    L (unit diagonal) below the diagonal, U above it and 1 / U_kk on it; perm[r, k] is
    the original row in place k (the residual is gathered in that order)."""
    nx = jac.shape[1]
    for i in range(rows.shape[0]):
        r = rows[i]
        A = lu[r]
        half = 0.5 * h[r]
        for a in range(nx):
            perm[r, a] = a
            for b in range(nx):
                A[a, b] = -half * jac[i, a, b]
            A[a, a] += 1.0
        for k in range(nx):
            p = k
            big = abs(A[k, k])
            for a in range(k + 1, nx):
                if abs(A[a, k]) > big:
                    big = abs(A[a, k])
                    p = a
            if p != k:
                perm[r, k], perm[r, p] = perm[r, p], perm[r, k]
                for b in range(nx):
                    A[k, b], A[p, b] = A[p, b], A[k, b]
            inv = 1.0 / A[k, k]  # inf for a singular matrix: the iteration then fails
            for a in range(k + 1, nx):
                A[a, k] *= inv
                lak = A[a, k]
                if lak != 0.0:
                    for b in range(k + 1, nx):
                        A[a, b] -= lak * A[k, b]
            A[k, k] = inv


def _c(a: Any) -> np.ndarray:
    """A C-ordered float64 array (no copy when it already is one)."""
    return np.require(a, dtype=float, requirements="C")


# Safety factor on the estimated error left by an update (Hairer & Wanner's kappa):
# the contraction estimate theta comes from two updates only.
_KAPPA = 0.1


@njit(cache=True)
def _chord(x, x0, f0, f1, lu, perm, h, active, tol, left, prev, done, slow):  # pragma: no cover
    """One simplified-Newton update of the intervals ``active`` (f1[i] = f at x[active[i]]):
    ``x += dx``, ``dx = -LU^-1 (x - x0 - h/2 (f0 + f1))``, and its tests, with the size
    ``q = max_i |dx_i| / (1 + |x_i|)`` and the contraction ``theta = q / q_prev``:

    * done[i] if ``q <= tol``, or if ``theta < 1`` and the error left after the
      update, about ``theta / (1 - theta) q``, is <= kappa tol, kappa = 0.1 (Hairer &
      Wanner, Solving ODEs II, Sec. IV.8, eq. (8.13));
    * slow[i] if ``theta > 1/2``, or if ``theta^left q`` (the size after the ``left``
      iterations that remain) would still exceed kappa tol: the interval's Jacobian is
      renewed;
    * an update with ``theta >= 1`` (the chord iteration diverging there) is not
      applied: the interval gets a fresh Jacobian at its current iterate instead.
    """
    nx = x.shape[1]
    g = np.empty(nx)
    for i in range(active.shape[0]):
        r = active[i]
        half = 0.5 * h[r]
        A = lu[r]
        for a in range(nx):  # the residual in pivot order, then L y = P b, U dx = y
            p = perm[r, a]
            g[a] = -(x[r, p] - x0[r, p] - half * (f0[r, p] + f1[i, p]))
        for a in range(1, nx):
            acc = g[a]
            for b in range(a):
                acc -= A[a, b] * g[b]
            g[a] = acc
        for a in range(nx - 1, -1, -1):
            acc = g[a]
            for b in range(a + 1, nx):
                acc -= A[a, b] * g[b]
            g[a] = acc * A[a, a]
        q = 0.0
        for c in range(nx):
            e = abs(g[c]) / (1.0 + abs(x[r, c] + g[c]))
            if not (e <= q):  # NaN propagates
                q = e
        theta = q / prev[r]  # 0 on the first update (prev = inf): no estimate yet
        if not (theta < 1.0):
            # The chord update grows (or is NaN): it is not applied; the interval gets
            # a fresh Jacobian at its current iterate, i.e. a full Newton step next.
            done[i] = False
            slow[i] = True
            continue
        for c in range(nx):
            x[r, c] += g[c]
        done[i] = q <= tol or (0.0 < theta < 1.0 and theta * q <= _KAPPA * tol * (1.0 - theta))
        # Renew the Jacobian where the chord iteration contracts slowly, or too slowly
        # to reach the tolerance within the iterations left (Hairer & Wanner's test).
        slow[i] = not (theta <= 0.5) or (
            not done[i] and theta**left * q > _KAPPA * tol * (1.0 - theta)
        )
        prev[r] = q
