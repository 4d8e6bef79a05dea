"""Adams-Bashforth with the input held and the history rebuilt after an input jump, ABj_s.

Over [t_n, t_{n+1}) the input is the held sample u_n, so the exact increment is the
integral of g(t) = f(t, y(t), u_n) along the flow y of the *current* input through
y(t_n) = x_n. AB_s needs g at t_{n-i}, i < s. Where u was u_n over the whole history,
g(t_{n-i}) = f(t_{n-i}, x_{n-i}, u_n) and the rule is AB_s (and ABu_s) exactly. After
an input jump the measured past states moved under another input, and ABu_s's
f(x_{n-i}, u_n) misses g by O(i h |du|): a local error O(h^2 |du|) whatever s.

ABj_s rebuilds that history: the points y_j = y(t_{n-j}) of the held-input flow,
backwards from x_n, solve the collocation equations

    y_j = x_n - h sum_{k<s} c_jk g_k,   g_k = f(t_{n-k}, y_k, u_n),   y_0 = x_n,

with ``c_jk`` the integral over [-j, 0] of the Lagrange basis polynomial of node -k on
the nodes 0, -1, ..., -(s-1) (time in units of h; exact fractions). They are solved
by s - 1 fixed-point sweeps started from ABu_s's history (error O(h |du|)); each
sweep gains one power of h, so the history is exact to O(h^s) and the local error is
O(h^{s+1}) across jumps too (measured: slopes s + 1 on a smooth model). Then
``x_{n+1} = x_n + h sum_k a_k g_k`` with the AB_s coefficients a_k.

Cost: f at the samples (shared with AB_s through ``cache``), plus, on each prediction
whose history holds an input change, (s - 1) evaluations for the held history and
(s - 1)^2 for the sweeps. Where the input changes at every sample this is a one-step
method of about s^2 evaluations per step; RK_s then costs less. The sweeps contract
when ``h L (s - 1)`` is well below 1 (L = ||df/dx||).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from functools import lru_cache
from typing import Any

import numpy as np

from .._trajectory import Trajectory
from ._adams import ab_coefficients, ab_error_constant, lagged_jacobians, warn_if_unstable
from ._base import (
    FixedRule,
    check_gain_args,
    nan_rows,
    sample_f,
    sample_jacobian,
    uniform_step,
)
from ._held import held_history
from ._registry import register_family

__all__ = ["JumpAwareAdamsBashforth", "backward_weights"]


@lru_cache(maxsize=32)
def backward_weights(s: int) -> tuple[tuple[Fraction, ...], ...]:
    """``c[j][k]``: integral over [-j, 0] of the Lagrange basis polynomial of node -k on
    the nodes 0, -1, ..., -(s-1), exact; row j integrates the interpolant of
    g(-0), ..., g(-(s-1)) back from 0 to -j."""
    rows = []
    basis = []
    for k in range(s):
        poly = [Fraction(1)]  # lowest degree first
        for m in range(s):
            if m != k:  # times (tau + m) / (m - k)
                nxt = [Fraction(0)] * (len(poly) + 1)
                for d, c in enumerate(poly):
                    nxt[d] += c * Fraction(m, m - k)
                    nxt[d + 1] += c / (m - k)
                poly = nxt
        basis.append(poly)
    for j in range(s):
        # int_{-j}^{0} p = -P(-j) with P the antiderivative vanishing at 0
        rows.append(
            tuple(
                -sum((c / (d + 1) * Fraction(-j) ** (d + 1) for d, c in enumerate(p)), Fraction(0))
                for p in basis
            )
        )
    return tuple(rows)


@dataclass(frozen=True)
class JumpAwareAdamsBashforth(FixedRule):
    """ABj_s: AB_s with the input held and the f-history rebuilt after an input jump.

    Attributes
    ----------
    order : int
        s >= 1; ABj1 is Euler. Orders above 6 warn (as AB_s).
    coefficients : tuple of Fraction
        a_0..a_{s-1} of AB_s, newest first.
    """

    order: int
    name: str = ""
    coefficients: tuple[Fraction, ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "coefficients", ab_coefficients(self.order))
        if not self.name:
            object.__setattr__(self, "name", f"ABj{self.order}")
        warn_if_unstable(self.order, self.name)

    @property
    def family(self) -> str:
        return "ABj"

    @property
    def history(self) -> int:
        return self.order

    @property
    def intersample(self) -> bool:
        """False: the input over the interval is the held sample u_n."""
        return False

    @property
    def sample_weights(self) -> None:
        return None

    @property
    def weights(self) -> np.ndarray:
        return np.array([float(a) for a in self.coefficients])

    @property
    def first_order_gain(self) -> Fraction:
        """a_s = sum |a_i|, as for AB_s."""
        return sum((abs(a) for a in self.coefficients), Fraction(0))

    @property
    def error_constant(self) -> Fraction:
        """gamma_s of AB_s (on the rebuilt history after a jump)."""
        return ab_error_constant(self.order)

    # -- the rule --------------------------------------------------------------------

    def _history(
        self, model: Any, data: Trajectory, cache: Any, derivatives: bool
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None]:
        """``(g, rows, D, lagged)`` for the predictions of rows s..N-1: g (N-s, s, nx) the
        history the rule uses; rows the indices (into g) rebuilt after a jump; with
        ``derivatives``, D (len(rows), s, s, nx, nx) = dg_j / dx_{n-l} there and lagged
        (N-s, s, nx, nx) = df/dx at the held history elsewhere."""
        s, n_s, h = self.order, data.n_samples, data.h
        n = np.arange(s - 1, n_s - 1)
        f = sample_f(model, data, cache)
        g = np.stack([held_history(model.f, f, data, s - 1, i, n_s - 1) for i in range(s)], 1)
        moved = np.zeros(n.size, dtype=bool)
        for i in range(1, s):
            moved |= (data.u[n - i] != data.u[n]).any(axis=1)
        rows = np.flatnonzero(moved)
        lagged = d = None
        if derivatives:
            jac = sample_jacobian(model, data, cache)
            lagged = np.stack(
                [held_history(model.jacobian, jac, data, s - 1, i, n_s - 1) for i in range(s)], 1
            )
            d = np.zeros((rows.size, s, s, data.nx, data.nx))
            for i in range(s):
                d[:, i, i] = lagged[rows, i]
        if rows.size == 0:
            return g, rows, d, lagged
        c = np.array(backward_weights(s), dtype=float)[1:]  # rows j = 1..s-1
        nn = n[rows]
        xn, un = data.x[nn], data.u[nn]
        past = nn[:, None] - np.arange(1, s)[None, :]  # sample indices n - j
        tj = data.t[past].reshape(-1)
        uj = np.repeat(un, s - 1, axis=0)
        gm = g[rows]
        eye = np.eye(data.nx)
        for _ in range(s - 1):
            y = xn[:, None, :] - h * np.einsum("jk,rkx->rjx", c, gm)
            flat = y.reshape(-1, data.nx)
            if d is not None:
                dy = -h * np.einsum("jk,rklab->rjlab", c, d)
                dy[:, :, 0] += eye
                jy = np.asarray(model.jacobian(tj, flat, uj)).reshape(rows.size, s - 1, *eye.shape)
                d[:, 1:] = np.einsum("rjab,rjlbc->rjlac", jy, dy)
            gm = gm.copy()
            gm[:, 1:] = np.asarray(model.f(tj, flat, uj)).reshape(rows.size, s - 1, data.nx)
        g[rows] = gm
        return g, rows, d, lagged

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

    def noise_gain(self, h: float, lipschitz: Any) -> np.ndarray:
        """The larger of AB_s's ``h a_s L`` (rows whose history holds no jump) and the
        gain of a rebuilt history, ``h L + h sum_{j>=1} |a_j| E_j`` (it is Euler's
        ``h L`` to first order: after the sweeps the history depends on x_n alone).

        E_j bounds the change of ``g_j - g_0`` per unit of noise: ``2 L`` at the start
        (ABu's history), then, sweep by sweep, ``E_j = h L (j L + sum_{k>=1} |c_jk| E_k)``
        (``y_j - x_n = -h (j g_0 + sum_k c_jk (g_k - g_0))``, as ``sum_k c_jk = j``).
        """
        h, L = check_gain_args(h, lipschitz)
        s = self.order
        c = np.abs(np.array(backward_weights(s), dtype=float))
        e = [2.0 * L] * s  # e[0] unused: g_0 - g_0 = 0
        for _ in range(s - 1):
            e = [e[0]] + [
                h * L @ (j * L + sum((c[j, k] * e[k] for k in range(1, s)), np.zeros_like(L)))
                for j in range(1, s)
            ]
        w = np.abs(self.weights)
        jump = h * L + h * sum((w[j] * e[j] for j in range(1, s)), np.zeros_like(L))
        return np.maximum(h * float(self.first_order_gain) * L, jump)

    def prediction_jacobians(
        self,
        model: Any,
        data: Trajectory,
        signal: Any = None,
        *,
        cache: dict[Any, Any] | None = None,
    ) -> np.ndarray:
        """``d x_hat[k] / d x[k-1-l] = [l = 0] I + h sum_j a_j dg_j / dx[k-1-l]``, forward
        mode through the sweeps where the history is rebuilt; shape (N, s, nx, nx)."""
        h = uniform_step(data, self.name)
        s, n = self.order, data.n_samples
        if n <= s:
            return lagged_jacobians([], h, self.weights, n, data.nx)
        _, rows, d, lagged = self._history(model, data, cache, derivatives=True)
        assert d is not None and lagged is not None
        phi = lagged_jacobians([lagged[:, i] for i in range(s)], h, self.weights, n, data.nx)
        if rows.size:
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
        """``nabla^s f`` along the samples whose difference stencil holds no input
        change (there the rule is AB_s), shape (M, nx)."""
        s = self.order
        d = np.diff(sample_f(model, data, cache), n=s, axis=0)
        u = data.u
        same = np.ones(d.shape[0], dtype=bool)
        for i in range(1, s + 1):
            same &= (u[s - i : u.shape[0] - i] == u[s:]).all(axis=1)
        return d[same]


register_family(
    "ABj<s>",
    r"ABj(\d+)",
    JumpAwareAdamsBashforth,
    "Adams-Bashforth with the input held and the f-history rebuilt after an input jump "
    "(order s across jumps), s >= 1",
    default_max_order=6,
)
