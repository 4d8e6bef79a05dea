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

from dataclasses import dataclass
from fractions import Fraction
from functools import lru_cache
from typing import Any, ClassVar

import numpy as np

from .._trajectory import Trajectory
from ..models import Model
from ._base import check_gain_args, check_ratio, fixed_step, sample_f, uniform_stencils
from ._held import HeldHistoryRule
from ._nodes import corner_patterns, history_nodes, lagrange_integrals, pattern_nodes

__all__ = ["JumpAwareAdamsBashforth", "backward_weights", "collocation_weights"]


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
class JumpAwareAdamsBashforth(HeldHistoryRule):
    """ABj_s: ABu_s with the f-history rebuilt where it holds an input jump.

    Attributes
    ----------
    order : int
        s >= 1; ABj1 is Euler. Orders above 6 warn (as AB_s).
    coefficients : tuple of Fraction
        a_0..a_{s-1} of AB_s, newest first.
    """

    FAMILY: ClassVar[str] = "ABj"

    #: Why ABj_s is no discrete-time system (it has no ``discrete_step``).
    no_discrete_step: ClassVar[str] = (
        "its f-history is rebuilt (an implicit sweep) only where the input changed inside "
        "the history, a switch on past inputs: z+ = F(z, u) would not be one smooth map, "
        "and it has no Jacobian across a jump. Use ABu<s> (the same rule where the input "
        "is constant over the history) or AB<s>"
    )

    # -- the rule --------------------------------------------------------------------

    def _history(
        self,
        model: Model,
        data: Trajectory,
        cache: Any,
        h: float | None,
        rows: tuple[int, int],
        derivatives: bool,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None]:
        """ABu_s's history, rebuilt (see the module docstring) on the predictions whose
        history holds an input change; with ``derivatives`` also d there, forward mode
        through the sweeps. On a non-uniform grid (``h`` None) the collocation weights
        are those of the actual nodes (:func:`collocation_weights`)."""
        g, _, _, jac = super()._history(model, data, cache, h, rows, derivatives)
        s = self.order
        n = np.arange(s - 1 + rows[0], s - 1 + rows[1])
        moved = np.zeros(n.size, dtype=bool)
        for i in range(1, s):
            moved |= (data.u[n - i] != data.u[n]).any(axis=1)
        rebuilt = np.flatnonzero(moved)
        d = None
        if jac is not None:
            d = np.zeros((rebuilt.size, s, s, data.nx, data.nx))
            for i in range(s):
                d[:, i, i] = jac[rebuilt, i]
        if rebuilt.size == 0:
            return g, rebuilt, d, jac
        nn = n[rebuilt]
        step: Any  # h, or h_n per rebuilt row shaped to broadcast over the sweep
        if h is not None:
            c = np.array(backward_weights(s), dtype=float)[1:]  # rows j = 1..s-1
            spec, step = "jk,", h
        else:
            tau, hn = history_nodes(data.t, s, nn)
            c = collocation_weights(tau)
            spec, step = "rjk,", hn[:, None, None]
        xn, un = data.x[nn], data.u[nn]
        tj = data.t[nn[:, None] - np.arange(1, s)[None, :]].reshape(-1)  # t_{n-j}
        uj = np.repeat(un, s - 1, axis=0)
        gm = g[rebuilt]
        eye = np.eye(data.nx)
        for _ in range(s - 1):
            y = (xn[:, None, :] - step * np.einsum(spec + "rkx->rjx", c, gm)).reshape(-1, data.nx)
            if d is not None:
                dstep = step if h is not None else step[..., None, None]
                dy = -dstep * np.einsum(spec + "rklab->rjlab", c, d)
                dy[:, :, 0] += eye
                jy = np.asarray(model.jacobian(tj, y, uj)).reshape(rebuilt.size, s - 1, *eye.shape)
                d[:, 1:] = np.einsum("rjab,rjlbc->rjlac", jy, dy)
            gm = gm.copy()
            gm[:, 1:] = np.asarray(model.f(tj, y, uj)).reshape(rebuilt.size, s - 1, data.nx)
        g[rebuilt] = gm
        return g, rebuilt, d, jac

    def noise_gain(self, h: float, lipschitz: Any, ratio: float = 1.0) -> np.ndarray:
        """The larger of AB_s's ``h a_s L`` (rows whose history holds no jump) and the
        gain of a rebuilt history, ``h L + h sum_{j>=1} |a_j| E_j`` (it is Euler's
        ``h L`` to first order: after the sweeps the history depends on x_n alone).

        E_j bounds the change of ``g_j - g_0`` per unit of noise: ``2 L`` at the start
        (ABu's history), then, sweep by sweep, ``E_j = h L (j L + sum_{k>=1} |c_jk| E_k)``
        (``y_j - x_n = -h (j g_0 + sum_k c_jk (g_k - g_0))``, as ``sum_k c_jk = j``).

        With ``ratio`` > 1 (non-uniform steps up to h within that factor in a stencil)
        the same recursion runs on every corner step pattern (the actual nodes'
        ``beta_j``, ``c_jk`` and ``|tau_j|`` in place of ``a_j``, ``c_jk`` and j, the
        predicted step h_n <= h) and G is the entrywise largest.
        """
        h, L = check_gain_args(h, lipschitz)
        s = self.order
        if check_ratio(ratio) == 1.0:
            c = np.abs(np.array(backward_weights(s), dtype=float))
            e = [2.0 * L] * s  # e[0] unused: g_0 - g_0 = 0
            for _ in range(s - 1):
                e = [e[0]] + [
                    h * L @ (j * L + sum((c[j, k] * e[k] for k in range(1, s)), np.zeros_like(L)))
                    for j in range(1, s)
                ]
            w = np.abs(self.weights)
            jump = h * L + h * sum((w[j] * e[j] for j in range(1, s)), np.zeros_like(L))
            return np.maximum(h * float(self.a_s) * L, jump)
        tau, hn = pattern_nodes(corner_patterns(s, check_ratio(ratio)))
        beta = np.abs(lagrange_integrals(tau, 0.0, 1.0))
        cp = np.abs(collocation_weights(tau))  # (P, s - 1, s), rows j = 1..s-1
        hl = (h * hn)[:, None, None] * L  # h_n L, (P, k, k)
        ep = [np.broadcast_to(2.0 * L, hl.shape)] * s
        for _ in range(s - 1):
            ep = [ep[0]] + [
                hl
                @ (
                    -tau[:, j, None, None] * L
                    + sum((cp[:, j - 1, k, None, None] * ep[k] for k in range(1, s)), 0 * hl)
                )
                for j in range(1, s)
            ]
        jump = hl + sum(
            (beta[:, j, None, None] * (h * hn)[:, None, None] * ep[j] for j in range(1, s)), 0 * hl
        )
        plain = beta.sum(axis=1)[:, None, None] * hl
        return np.maximum(plain, jump).max(axis=0)

    def truncation_differences(
        self,
        model: Model,
        data: Trajectory,
        signal: Any = None,
        *,
        cache: dict[Any, Any] | None = None,
    ) -> np.ndarray:
        """``nabla^s f`` along the samples whose difference stencil holds no input
        change (there the rule is AB_s) and, on a non-uniform grid, whose s steps all
        equal ``data.h``; shape (M, nx)."""
        s = self.order
        d = np.diff(sample_f(model, data, cache), n=s, axis=0)
        u = data.u
        same = np.ones(d.shape[0], dtype=bool)
        for i in range(1, s + 1):
            same &= (u[s - i : u.shape[0] - i] == u[s:]).all(axis=1)
        if fixed_step(data) is None:
            same &= uniform_stencils(data, s)
        return d[same]


def collocation_weights(tau: np.ndarray) -> np.ndarray:
    """``c[r, j - 1, k]``: integral over [tau_j, 0] of the Lagrange basis polynomial of
    node k on the nodes ``tau[r]`` (:func:`history_nodes`), j = 1..s-1; shape
    (R, s - 1, s). On a uniform grid these are :func:`backward_weights` rows 1..s-1."""
    rows, s = tau.shape
    out = np.empty((rows, s - 1, s))
    for j in range(1, s):
        out[:, j - 1] = lagrange_integrals(tau, tau[:, j], 0.0)
    return out
