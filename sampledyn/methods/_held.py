"""Adams-Bashforth with the input held over the predicted interval, ABu_s.

    x_{n+1} = x_n + h * sum_{i=0}^{s-1} a_i f(t_{n-i}, x_{n-i}, u_n)

The f-history is evaluated at the past states with the input u_n that is applied over
[t_n, t_{n+1}) (a_i the AB_s coefficients). This is the prediction a digital controller
needs ("what if I apply u_n now?"), and it does not extrapolate an input jump the way
AB_s does (AB_s uses f(x_{n-i}, u_{n-i}), so a jump of u inside its history enters the
prediction as O(h |du|)). It does not keep order s across a jump either: the past
states moved under the old input, so the derivative of t -> f(x(t), u_n) jumps by
``f_x (f(x_n, u_n) - f(x_n, u_{n-1}))`` at t_n and the local error after a jump is
O(h^2 |du|) whatever s. Where u is constant over the history ABu_s is AB_s exactly.

f at the samples is shared with AB_s (``cache``); f(t_{n-i}, x_{n-i}, u_n) is evaluated
only where u_{n-i} differs from u_n.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from .._trajectory import Trajectory
from ._adams import AdamsRule, lagged_jacobians
from ._base import nan_rows, sample_f, sample_jacobian, uniform_step
from ._registry import register_family

__all__ = ["HeldInputAdamsBashforth", "held_history"]


def held_history(
    fn: Callable[..., Any],
    at_samples: np.ndarray,
    data: Trajectory,
    first: int,
    lag: int,
    stop: int | None = None,
) -> np.ndarray:
    """``fn(t_{n-lag}, x_{n-lag}, u_n)`` for n = first .. stop - 1 (default N - 1),
    shape (stop - first, ...).

    ``at_samples`` is ``fn(t_k, x_k, u_k)`` for every sample; it is reused where
    u_{n-lag} = u_n and ``fn`` is called, in one batch, only where they differ.
    """
    n = np.arange(first, data.n_samples if stop is None else stop)
    src = n - lag
    out = np.array(at_samples[src], dtype=float)
    if lag:
        moved = (data.u[src] != data.u[n]).any(axis=1)
        if moved.any():
            k, j = src[moved], n[moved]
            out[moved] = fn(data.t[k], data.x[k], data.u[j])
    return out


# z = (x_n, x_{n-1}, ..., x_{n-s+1}); the arithmetic of predict.
_ABU_STEP = """
S = {s}
_W = np.array({w!r})


@njit(cache=CACHE, error_model="numpy")
def step(t, z, u, p, h, out):
    nx = z.shape[0] // S
    g = np.empty(nx)
    for j in range(nx):
        out[j] = z[j]
    for i in range(S):
        rhs(t - i * h, z[i * nx : (i + 1) * nx], u, p, g)
        c = h * _W[i]
        for j in range(nx):
            out[j] += c * g[j]
    for i in range(S - 1, 0, -1):
        for j in range(nx):
            out[i * nx + j] = z[(i - 1) * nx + j]
"""


@dataclass(frozen=True)
class HeldInputAdamsBashforth(AdamsRule):
    """ABu_s: Adams-Bashforth of order s with the f-history taken at the current input.

    Attributes
    ----------
    order : int
        s >= 1; ABu1 is Euler. Orders above 6 warn (as AB_s).
    coefficients : tuple of Fraction
        a_0..a_{s-1} of AB_s, newest first.
    """

    FAMILY: ClassVar[str] = "ABu"

    def _history(
        self, model: Any, data: Trajectory, cache: Any, derivatives: bool
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None]:
        """The f-history of the predictions of rows s..N-1 (N > s), ``(g, rows, d, jac)``.

        g, shape (N - s, s, nx): ``g[r, i] = f(t_{n-i}, x_{n-i}, u_n)``, n = r + s - 1.
        jac, shape (N - s, s, nx, nx): df/dx at the same points (with ``derivatives``).
        rows, d: where a subclass rebuilds the history (indices into g) and, there, the
        derivatives ``d[r, j, l] = dg_j / dx_{n-l}``; none here.
        """
        s, n = self.order, data.n_samples
        f = sample_f(model, data, cache)
        g = np.stack([held_history(model.f, f, data, s - 1, i, n - 1) for i in range(s)], 1)
        jac = None
        if derivatives:
            j = sample_jacobian(model, data, cache)
            jac = np.stack(
                [held_history(model.jacobian, j, data, s - 1, i, n - 1) for i in range(s)], 1
            )
        return g, np.zeros(0, dtype=np.int64), None, jac

    def predict(
        self,
        model: Any,
        data: Trajectory,
        signal: Any = None,
        *,
        cache: dict[Any, Any] | None = None,
    ) -> np.ndarray:
        """One-step-ahead predictions, shape (N, nx), NaN in the first s rows.

        ``signal`` is not used: the input over the interval is the held sample u_n.
        """
        h = uniform_step(data, self.name)
        s, n = self.order, data.n_samples
        out = nan_rows(data, (data.nx,))
        if n <= s:
            return out
        g = self._history(model, data, cache, derivatives=False)[0]
        acc = np.array(data.x[s - 1 : n - 1], dtype=float)
        for k, w in enumerate(self.weights):
            acc += (h * w) * g[:, k]
        out[s:] = acc
        return out

    def prediction_jacobians(
        self,
        model: Any,
        data: Trajectory,
        signal: Any = None,
        *,
        cache: dict[Any, Any] | None = None,
    ) -> np.ndarray:
        """``Phi_{k,0} = I + h a_0 F(x_{k-1}, u_{k-1})``, ``Phi_{k,i} = h a_i
        F(x_{k-1-i}, u_{k-1})``, shape (N, s, nx, nx); where a subclass rebuilds the
        history, ``Phi_{k,l} = [l = 0] I + h sum_j a_j dg_j / dx_{k-1-l}``."""
        h = uniform_step(data, self.name)
        s, n = self.order, data.n_samples
        if n <= s:
            return lagged_jacobians([], h, self.weights, n, data.nx)
        _, rows, d, jac = self._history(model, data, cache, derivatives=True)
        assert jac is not None
        phi = lagged_jacobians([jac[:, i] for i in range(s)], h, self.weights, n, data.nx)
        if rows.size and d is not None:
            rebuilt = h * np.einsum("j,rjlab->rlab", self.weights, d)
            rebuilt[:, 0] += np.eye(data.nx)
            phi[s + rows] = rebuilt
        return phi

    def truncation_differences(
        self,
        model: Any,
        data: Trajectory,
        signal: Any = None,
        *,
        cache: dict[Any, Any] | None = None,
    ) -> np.ndarray:
        """``nabla^s`` of ``t -> f(t, x(t), u_n)`` at t_n, for n = s..N-1, shape (N - s, nx)."""
        s = self.order
        f = sample_f(model, data, cache)
        oldest_first = [held_history(model.f, f, data, s, i) for i in range(s, -1, -1)]
        return np.diff(np.stack(oldest_first), n=s, axis=0)[0]

    # ---- discrete-time state-space form (used by sampledyn.discretize) ----------

    @property
    def state_layout(self) -> tuple[tuple[str, int], ...]:
        """The discrete state z = (x_n, x_{n-1}, ..., x_{n-s+1}): the past states (the
        f-history is taken at the current input, so it cannot be stored)."""
        return tuple(("x", i) for i in range(self.order))

    def step_source(self) -> str:
        """numba source of ``step(t, z, u, p, h, out)`` (globals ``rhs``, ``np``), the
        arithmetic of :meth:`predict`."""
        return _ABU_STEP.format(s=self.order, w=[float(w) for w in self.weights])

    def step_blocks(self, f: Any, t: Any, blocks: list[Any], u: Any, h: float, implicit=None):
        """z+ from the blocks of z in vector arithmetic (numpy or CasADi): x_{n+1} =
        x_n + h sum_i a_i f(t_{n-i}, x_{n-i}, u_n), then the states shifted by one."""
        w = self.weights
        x = blocks[0]
        for i in range(self.order):
            x = x + (h * w[i]) * f(t - i * h, blocks[i], u)
        return [x, *blocks[:-1]]

    def linearize(self, model: Any, t: float, z: np.ndarray, u: np.ndarray, h: float):
        """(A_d, B_d), shapes (s nx, s nx) and (s nx, nu): first block row
        ``[I + h a_0 F_0, h a_1 F_1, ...]`` with ``F_i = df/dx(x_{n-i}, u_n)`` and
        ``B = h sum_i a_i df/du(x_{n-i}, u_n)``; the older states shift."""
        nx, s, w = model.nx, self.order, self.weights
        xs = np.asarray(z, dtype=float).reshape(s, nx)
        ts = float(t) - h * np.arange(s)
        us = np.broadcast_to(np.asarray(u, dtype=float), (s, model.nu))
        F = np.asarray(model.jacobian(ts, xs, us), dtype=float)
        G = np.asarray(model.input_jacobian(ts, xs, us), dtype=float)
        A = np.zeros((s * nx, s * nx))
        for i in range(s):
            A[:nx, i * nx : (i + 1) * nx] = (h * w[i]) * F[i]
        A[:nx, :nx] += np.eye(nx)
        for i in range(1, s):
            A[i * nx : (i + 1) * nx, (i - 1) * nx : i * nx] = np.eye(nx)
        B = np.zeros((s * nx, model.nu))
        B[:nx] = h * np.einsum("i,iab->ab", w, G)
        return A, B

    def steady_state(self, model: Any, x: np.ndarray, u: np.ndarray, t: float = 0.0):
        """z of a constant history at (x, u): (x, ..., x)."""
        return np.tile(np.asarray(x, dtype=float), self.order)


register_family(
    "ABu<s>",
    r"ABu(\d+)",
    HeldInputAdamsBashforth,
    "Adams-Bashforth with the input held over the predicted interval (f-history at u_n), s >= 1",
    default_max_order=6,
)
