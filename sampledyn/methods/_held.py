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
from ..models import Model
from ._adams import AdamsRule, fill_lagged, lagged_jacobians
from ._base import fixed_step, nan_rows, sample_f, sample_jacobian, uniform_stencils
from ._program import Combination, Stage, StepProgram

__all__ = ["JACOBIAN_CHUNK_BYTES", "HeldHistoryRule", "HeldInputAdamsBashforth", "held_history"]

# Size (bytes) of the largest array of one block of prediction Jacobians, ABj's forward
# derivatives through the sweeps, (rows, s, s, nx, nx): the rows are linearised block
# by block, so the memory beyond the (N, s, nx, nx) result stays near 4.4 times this
# whatever N (35 MiB measured for ABj6 on a 12-state vehicle, against 113 KiB per
# sample, 5.6 GB at N = 5e4, with all rows at once).
JACOBIAN_CHUNK_BYTES = 8 * 2**20


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


@dataclass(frozen=True)
class HeldHistoryRule(AdamsRule):
    """What ABu_s and ABj_s share: the AB_s weights on an f-history taken at the input
    held over the predicted interval (:meth:`_history`, which ABj_s rebuilds after a
    jump); prediction, its Jacobians and truncation differences."""

    FAMILY: ClassVar[str] = "ABu"

    def _history(
        self,
        model: Model,
        data: Trajectory,
        cache: Any,
        h: float | None,
        rows: tuple[int, int],
        derivatives: bool,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None]:
        """The f-history of the predictions of rows s + lo .. s + hi - 1 (``rows`` =
        (lo, hi); N > s), ``(g, rebuilt, d, jac)``.

        g, shape (hi - lo, s, nx): ``g[r, i] = f(t_{n-i}, x_{n-i}, u_n)``, n = s - 1 + lo + r.
        jac, shape (hi - lo, s, nx, nx): df/dx at the same points (with ``derivatives``).
        rebuilt, d: where a subclass rebuilds the history (indices into g) and, there,
        the derivatives ``d[r, j, l] = dg_j / dx_{n-l}``; none here. ``h`` is
        :func:`fixed_step` of the data (None on a non-uniform grid).
        """
        s = self.order
        first, stop = s - 1 + rows[0], s - 1 + rows[1]
        f = sample_f(model, data, cache)
        g = np.stack([held_history(model.f, f, data, first, i, stop) for i in range(s)], 1)
        jac = None
        if derivatives:
            j = sample_jacobian(model, data, cache)
            jac = np.stack(
                [held_history(model.jacobian, j, data, first, i, stop) for i in range(s)], 1
            )
        return g, np.zeros(0, dtype=np.int64), None, jac

    def predict(
        self,
        model: Model,
        data: Trajectory,
        signal: Any = None,
        *,
        cache: dict[Any, Any] | None = None,
    ) -> np.ndarray:
        """One-step-ahead predictions, shape (N, nx), NaN in the first s rows; on a
        non-uniform grid with the weights of the actual nodes (:meth:`step_weights`).

        ``signal`` is not used: the input over the interval is the held sample u_n.
        """
        s, n = self.order, data.n_samples
        out = nan_rows(data, (data.nx,))
        if n <= s:
            return out
        h = fixed_step(data)
        hw = self.step_weights(data, h)
        g = self._history(model, data, cache, h, (0, n - s), derivatives=False)[0]
        acc = np.array(data.x[s - 1 : n - 1], dtype=float)
        for k in range(s):
            acc += hw[:, k, None] * g[:, k]
        out[s:] = acc
        return out

    def prediction_jacobians(
        self,
        model: Model,
        data: Trajectory,
        signal: Any = None,
        *,
        cache: dict[Any, Any] | None = None,
    ) -> np.ndarray:
        """``Phi_{k,0} = I + h a_0 F(x_{k-1}, u_{k-1})``, ``Phi_{k,i} = h a_i
        F(x_{k-1-i}, u_{k-1})``, shape (N, s, nx, nx) (``h_n beta_{n,i}`` in place of
        ``h a_i`` on a non-uniform grid); where a subclass rebuilds the history,
        ``Phi_{k,l} = [l = 0] I + h sum_j a_j dg_j / dx_{k-1-l}``.

        Computed in blocks of rows (:data:`JACOBIAN_CHUNK_BYTES`): memory beyond the
        result is bounded whatever N.
        """
        s, n, nx = self.order, data.n_samples, data.nx
        if n <= s:
            return lagged_jacobians([], self.weights, n, nx)
        h = fixed_step(data)
        hw = self.step_weights(data, h)
        phi = nan_rows(data, (s, nx, nx))
        block = max(1, JACOBIAN_CHUNK_BYTES // (8 * s * s * nx * nx))
        for lo in range(0, n - s, block):
            hi = min(lo + block, n - s)
            _, rebuilt, d, jac = self._history(model, data, cache, h, (lo, hi), derivatives=True)
            assert jac is not None
            out = phi[s + lo : s + hi]
            fill_lagged(out, [jac[:, i] for i in range(s)], hw[lo:hi])
            if rebuilt.size and d is not None:
                if h is not None:
                    rows = h * np.einsum("j,rjlab->rlab", self.weights, d)
                else:
                    rows = np.einsum("rj,rjlab->rlab", hw[lo:hi][rebuilt], d)
                rows[:, 0] += np.eye(nx)
                out[rebuilt] = rows
        return phi

    def truncation_differences(
        self,
        model: Model,
        data: Trajectory,
        signal: Any = None,
        *,
        cache: dict[Any, Any] | None = None,
    ) -> np.ndarray:
        """``nabla^s`` of ``t -> f(t, x(t), u_n)`` at t_n, for n = s..N-1, shape (M, nx):
        every n on a uniform grid, else those whose s steps back all equal ``data.h``."""
        s = self.order
        f = sample_f(model, data, cache)
        oldest_first = [held_history(model.f, f, data, s, i) for i in range(s, -1, -1)]
        d = np.diff(np.stack(oldest_first), n=s, axis=0)[0]
        return d if fixed_step(data) is not None else d[uniform_stencils(data, s)]


@dataclass(frozen=True)
class HeldInputAdamsBashforth(HeldHistoryRule):
    """ABu_s: Adams-Bashforth of order s with the f-history taken at the current input.

    Attributes
    ----------
    order : int
        s >= 1; ABu1 is Euler. Orders above 6 warn (as AB_s).
    coefficients : tuple of Fraction
        a_0..a_{s-1} of AB_s, newest first.
    """

    @property
    def discrete_step(self) -> StepProgram:
        """z = (x_n, x_{n-1}, ..., x_{n-s+1}), the past states (the f-history is taken at
        the current input, so it cannot be stored): ``x_{n+1} = x_n + sum_i (h a_i)
        f(t_n - i h, x_{n-i}, u_n)``, in the order of :meth:`predict`, then the states
        shifted by one."""
        s, w = self.order, [float(v) for v in self.weights]
        return StepProgram(
            self.name,
            tuple(("x", i) for i in range(s)),
            tuple(Stage(float(-i), ("z", i)) for i in range(s)),
            Combination(("z", 0), tuple((w[i], ("k", i)) for i in range(s))),
            tuple(("z", i) for i in range(s - 1)),
        )
