"""Explicit Runge-Kutta rules of order 1-4 as exact, self-checking Butcher tableaux.

A tableau is drawn as::

    c_1 | a_11 ... a_1s
     :  |  :         :
    c_s | a_s1 ... a_ss
    ----+--------------
        | b_1  ...  b_s

``k_i = f(t_n + c_i h, x_n + h sum_j a_ij k_j, u(t_n + c_i h))`` and
``x_{n+1} = x_n + h sum_i b_i k_i`` (eq. (8)).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from functools import lru_cache
from typing import Any

import numpy as np
from numba import njit

from .._trajectory import Trajectory
from ..models import Model
from ..models._base import readonly
from ._base import (
    FixedRule,
    check_gain_args,
    check_ratio,
    grid_steps,
    nan_rows,
    sample_f,
    stage_inputs,
)
from ._program import Combination, Stage, StepProgram, stage_jacobians
from ._stability import polynomial_amplification

__all__ = ["RK_BLOCK", "TABLEAUX", "ButcherTableau", "RungeKutta"]

# Intervals whose stages are computed together: the stage values of a block (a few
# (RK_BLOCK, nx) arrays, 0.2 MB each for nx = 12) stay in cache from one stage to the
# next instead of streaming every stage through memory.
RK_BLOCK = 2048

F = Fraction


def _order_conditions(a: tuple, b: tuple, c: tuple) -> int:
    """Highest p <= 4 for which every rooted-tree order condition holds exactly."""
    s = len(b)

    def dot(u, v):
        return sum((ui * vi for ui, vi in zip(u, v, strict=True)), F(0))

    def amul(v):
        return tuple(dot(a[i], v) for i in range(s))

    ones = (F(1),) * s
    c2 = tuple(ci * ci for ci in c)
    ac = amul(c)
    conditions = {
        1: [(dot(b, ones), F(1))],
        2: [(dot(b, c), F(1, 2))],
        3: [(dot(b, c2), F(1, 3)), (dot(b, ac), F(1, 6))],
        4: [
            (dot(b, tuple(ci**3 for ci in c)), F(1, 4)),
            (dot(b, tuple(ci * aci for ci, aci in zip(c, ac, strict=True))), F(1, 8)),
            (dot(b, amul(c2)), F(1, 12)),
            (dot(b, amul(ac)), F(1, 24)),
        ],
    }
    order = 0
    for p in (1, 2, 3, 4):
        if all(lhs == rhs for lhs, rhs in conditions[p]):
            order = p
        else:
            break
    return order


@dataclass(frozen=True)
class ButcherTableau:
    """An explicit Butcher tableau with exact entries; checks itself when built.

    Raises ``ValueError`` if the tableau is not explicit, if a row sum differs from
    its c, or if the order conditions do not give the declared ``order``.
    """

    a: tuple[tuple[Fraction, ...], ...]
    b: tuple[Fraction, ...]
    c: tuple[Fraction, ...]
    order: int

    def __post_init__(self) -> None:
        s = len(self.b)
        if len(self.c) != s or len(self.a) != s or any(len(r) != s for r in self.a):
            raise ValueError(f"tableau needs an {s}x{s} `a`, and `b`, `c` of length {s}.")
        for i, row in enumerate(self.a):
            if any(row[j] != 0 for j in range(i, s)):
                raise ValueError(f"row {i} of `a` is not strictly lower triangular (explicit).")
            if sum(row, F(0)) != self.c[i]:
                raise ValueError(f"row {i} of `a` sums to {sum(row, F(0))}, c[{i}] = {self.c[i]}.")
        computed = _order_conditions(self.a, self.b, self.c)
        if computed != self.order:
            raise ValueError(
                f"tableau declared order {self.order}, order conditions give {computed}."
            )

    @property
    def stages(self) -> int:
        return len(self.b)


def _tab(a: list[list[Any]], b: list[Any], c: list[Any], order: int) -> ButcherTableau:
    return ButcherTableau(
        a=tuple(tuple(F(v) for v in row) for row in a),
        b=tuple(F(v) for v in b),
        c=tuple(F(v) for v in c),
        order=order,
    )


TABLEAUX: dict[int, ButcherTableau] = {
    # Forward Euler.
    1: _tab([[0]], [1], [0], 1),
    # Heun's second-order method (explicit trapezoid).
    2: _tab([[0, 0], [1, 0]], [F(1, 2), F(1, 2)], [0, 1], 2),
    # Kutta's third-order method.
    3: _tab(
        [[0, 0, 0], [F(1, 2), 0, 0], [-1, 2, 0]], [F(1, 6), F(2, 3), F(1, 6)], [0, F(1, 2), 1], 3
    ),
    # The classical fourth-order method.
    4: _tab(
        [[0, 0, 0, 0], [F(1, 2), 0, 0, 0], [0, F(1, 2), 0, 0], [0, 0, 1, 0]],
        [F(1, 6), F(1, 3), F(1, 3), F(1, 6)],
        [0, F(1, 2), F(1, 2), 1],
        4,
    ),
}


@dataclass(frozen=True)
class RungeKutta(FixedRule):
    """Explicit Runge-Kutta rule of order 1-4 (RK1 is Euler).

    Stage inputs between samples come from the ``signal`` given to :meth:`predict`
    (intersampling); without one, the sampled input is held.
    """

    order: int
    name: str = ""
    tableau: ButcherTableau = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if isinstance(self.order, bool) or not isinstance(self.order, int | np.integer):
            raise TypeError(f"order `s` must be an int, got {type(self.order).__name__}.")
        if self.order not in TABLEAUX:
            raise ValueError(
                f"Runge-Kutta order `s` must be one of {sorted(TABLEAUX)}, got {self.order}."
            )
        object.__setattr__(self, "tableau", TABLEAUX[int(self.order)])
        if not self.name:
            object.__setattr__(self, "name", f"RK{self.order}")

    @property
    def family(self) -> str:
        return "RK"

    @property
    def history(self) -> int:
        return 1

    @property
    def intersample(self) -> bool:
        """True if a stage evaluates f inside the interval (some c_i > 0)."""
        return any(c != 0 for c in self.tableau.c)

    @property
    def sample_weights(self) -> np.ndarray | None:
        """(b_1,) for a one-stage tableau at c = 0 (Euler), else None."""
        tab = self.tableau
        return np.array([float(tab.b[0])]) if tab.stages == 1 and tab.c[0] == 0 else None

    @property
    def first_order_gain(self) -> Fraction:
        """sum |b_i| (= 1 for the built-in tableaux)."""
        return sum((abs(b) for b in self.tableau.b), Fraction(0))

    @property
    def error_constant(self) -> Fraction | None:
        """``1/2 - sum_i b_i c_i`` for order 1 (1/2 for Euler), whose leading error has the
        single elementary differential f' f; None for s >= 2, where it is a sum over
        several elementary differentials with different weights (Hairer, Norsett &
        Wanner, Solving ODEs I, Sec. II.2)."""
        if self.tableau.order != 1:
            return None
        return Fraction(1, 2) - sum(
            (b * c for b, c in zip(self.tableau.b, self.tableau.c, strict=True)), Fraction(0)
        )

    @property
    def step_rule(self) -> str:
        return "step h_n = t_n+1 - t_n per interval"

    @property
    def stability_polynomial(self) -> tuple[Fraction, ...]:
        """Coefficients of the stability function ``R(z) = 1 + sum_j (b^T A^(j-1) 1)
        z^j``, z^0 first, exact (an explicit tableau: a polynomial of degree s; 1, 1,
        1/2, 1/6, 1/24 for the classical RK4)."""
        return _stability_polynomial(self.tableau)

    def amplification(self, z: Any) -> np.ndarray:
        """|R(z)| at each z = h lambda (:attr:`stability_polynomial`)."""
        return polynomial_amplification(self.stability_polynomial, z)

    def predict(
        self,
        model: Model,
        data: Trajectory,
        signal: Any = None,
        *,
        cache: dict[Any, Any] | None = None,
    ) -> np.ndarray:
        """One-step-ahead predictions, all intervals at once (one batch f per stage),
        shape (N, nx), NaN in row 0; on a non-uniform grid each interval with its own
        step h_n = t_{n+1} - t_n (stages at t_n + c_i h_n).

        The intervals go in blocks of :data:`RK_BLOCK`; the stage points and the
        increment are formed by one compiled pass each (:func:`_combine`), in the order
        of the numpy expressions ``x_n + sum_j (h a_ij) k_j`` and ``x_n + h sum_i b_i k_i``
        (so blocks change no result).

        With a ``cache``, a first stage at the sample itself (c_1 = 0, the classical
        tableaux) is f at the samples, taken from (or put into) the cache that the
        Adams rules share (:func:`sample_f`): the same numbers, one f evaluation per
        sample fewer when a study predicts with both.
        """
        tab = self.tableau
        if data.n_samples < 2:
            return nan_rows(data, (data.nx,))
        h, rows = grid_steps(data)
        t0, x0 = data.t[:-1], data.x[:-1]
        cs = [float(c) for c in tab.c]
        times = {c: t0 + c * rows for c in set(cs)}
        inputs = {
            c: stage_inputs(data, signal, c, None if h is not None else rows) for c in set(cs)
        }
        a = [readonly([float(v) for v in tab.a[i][:i]]) for i in range(tab.stages)]
        b = readonly([float(v) for v in tab.b])
        x0, rows = readonly(x0), readonly(rows)  # views of these stay read-only: no copies
        # k_1 = f(t_n, x_n, u_n) at c_1 = 0 (t_n + 0 h_n is t_n, the input the sampled one)
        at_samples = sample_f(model, data, cache) if cache is not None and cs[0] == 0.0 else None
        out = np.empty(data.x.shape)
        out[0] = np.nan
        point = np.empty((min(RK_BLOCK, rows.size), data.nx))  # stage points, reused
        for lo in range(0, rows.size, RK_BLOCK):
            blk = slice(lo, min(lo + RK_BLOCK, rows.size))
            xb, hb, pb = x0[blk], rows[blk], point[: blk.stop - lo]
            ks: list[np.ndarray] = []
            for i in range(tab.stages):
                if i == 0 and at_samples is not None:
                    ks.append(readonly(at_samples[blk]))  # read only: not copied
                    continue
                xi = _combine(xb, hb, a[i], ks, pb, False, tab.stages) if a[i].any() else xb
                ks.append(readonly(model.f(times[cs[i]][blk], xi, inputs[cs[i]][blk])))
            _combine(xb, hb, b, ks, out[1 + lo : 1 + blk.stop], True, tab.stages)
        return out

    def noise_gain(self, h: float, lipschitz: Any, ratio: float = 1.0) -> np.ndarray:
        """``G = h sum_i |b_i| K_i`` with ``K_i = L (I + h sum_j |a_ij| K_j)``: stage i
        moves by at most ``K_i delta``. For a scalar L and the classical RK4 this is
        ``z + z^2/2 + ... + z^4/4!`` (z = h L), about ``h L`` whatever the order.

        A one-step rule: on a non-uniform grid each interval has this gain at its own
        step, which grows with the step, so h = the largest step bounds them all and
        ``ratio`` does not enter."""
        h, L = check_gain_args(h, lipschitz)
        check_ratio(ratio)
        tab = self.tableau
        eye = np.eye(L.shape[0])
        ks: list[np.ndarray] = []
        for i in range(tab.stages):
            acc = eye.copy()
            for j in range(i):
                if tab.a[i][j] != 0:
                    acc = acc + h * abs(float(tab.a[i][j])) * ks[j]
            ks.append(L @ acc)
        return h * sum(
            (abs(float(b)) * k for b, k in zip(tab.b, ks, strict=True)), np.zeros_like(L)
        )

    def prediction_jacobians(
        self,
        model: Model,
        data: Trajectory,
        signal: Any = None,
        *,
        cache: dict[Any, Any] | None = None,
    ) -> np.ndarray:
        """``d x_hat[k] / d x[k-1]`` through the stages of eq. (8), with the stage
        inputs :meth:`predict` uses (h_n per interval on a non-uniform grid): the
        forward mode of :attr:`discrete_step` over every interval at once
        (:func:`~sampledyn.methods._program.stage_jacobians`); shape (N, 1, nx, nx)."""
        phi = nan_rows(data, (1, data.nx, data.nx))
        if data.n_samples < 2:
            return phi
        h, steps = grid_steps(data)

        def inputs(c: float) -> np.ndarray:
            return stage_inputs(data, signal, c, None if h is not None else steps)

        phi[1:, 0] = stage_jacobians(
            self.discrete_step, model, data.t[:-1], data.x[:-1], steps, inputs
        )
        return phi

    # ---- discrete-time state-space form (used by sampledyn.discretize) ----------

    @property
    def discrete_step(self) -> StepProgram:
        """z = x_n, the input held: the stages of eq. (8) from the tableau, ``y_i = x_n +
        sum_j (h a_ij) k_j`` (a_ij != 0) and ``x_{n+1} = x_n + h sum_i b_i k_i``, in the
        order of :meth:`predict`'s compiled passes."""
        tab = self.tableau
        stages = []
        for i in range(tab.stages):
            terms = tuple((float(a), ("k", j)) for j, a in enumerate(tab.a[i][:i]) if a != 0)
            point: Any = Combination(("z", 0), terms) if terms else ("z", 0)
            stages.append(Stage(float(tab.c[i]), point))
        update = Combination(
            ("z", 0), tuple((float(b), ("k", i)) for i, b in enumerate(tab.b)), True
        )
        return StepProgram(self.name, (("x", 0),), tuple(stages), update)


@lru_cache(maxsize=16)
def _stability_polynomial(tab: ButcherTableau) -> tuple[Fraction, ...]:
    """:attr:`RungeKutta.stability_polynomial` of a tableau."""
    s = tab.stages
    v = [Fraction(1)] * s  # A^(j-1) 1, starting at j = 1
    coeffs = [Fraction(1)]
    for _ in range(s):
        coeffs.append(sum((b * vi for b, vi in zip(tab.b, v, strict=True)), Fraction(0)))
        v = [sum((tab.a[i][k] * v[k] for k in range(s)), Fraction(0)) for i in range(s)]
    while len(coeffs) > 1 and coeffs[-1] == 0:
        coeffs.pop()
    return tuple(coeffs)


def _combine(
    x0: np.ndarray,
    h: np.ndarray,
    coeffs: np.ndarray,
    ks: list[np.ndarray],
    out: np.ndarray,
    scale_sum: bool,
    stages: int,
) -> np.ndarray:
    """One compiled pass over the intervals: ``x0 + sum_j (h_n c_j) k_j`` (stage points;
    zero c_j skipped) or, with ``scale_sum``, ``x0 + h_n sum_j c_j k_j`` (the
    increment), written into ``out``, shape (N - 1, nx), and returned.

    Every array read-only (:func:`~sampledyn.models.readonly`); ``ks`` (the first
    len(coeffs) stages) goes to the compiled pass as a tuple of ``stages`` arrays,
    padded with its first: one specialisation per number of stages, not one per stage
    and per array flag."""
    padded = (*ks, *(ks[0],) * (stages - len(ks)))
    _combine_rows(x0, h, coeffs, padded, out, scale_sum)
    return out


@njit(cache=True)
def _combine_rows(x0, h, coeffs, ks, out, scale_sum):  # pragma: no cover - compiled
    # Term by term over whole arrays (j outer), each element summed in the order j =
    # 0, 1, ... as the numpy expressions do, so the results are the same bits.
    n, nx = x0.shape
    for r in range(n):
        for c in range(nx):
            out[r, c] = 0.0 if scale_sum else x0[r, c]
    for j in range(coeffs.shape[0]):
        w = coeffs[j]
        if w == 0.0 and not scale_sum:
            continue
        k = ks[j]
        for r in range(n):
            wr = w if scale_sum else h[r] * w
            for c in range(nx):
                out[r, c] += wr * k[r, c]
    if scale_sum:
        for r in range(n):
            for c in range(nx):
                out[r, c] = x0[r, c] + h[r] * out[r, c]
