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
from typing import Any

import numpy as np

from .._trajectory import Trajectory
from ._base import stage_inputs

__all__ = ["ButcherTableau", "RungeKutta", "TABLEAUX"]

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
class RungeKutta:
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
    def history(self) -> int:
        return 1

    def predict(self, model: Any, data: Trajectory, signal: Any = None) -> np.ndarray:
        """One-step-ahead predictions, all intervals at once (one batch f per stage)."""
        tab = self.tableau
        h = data.h
        t0 = data.t[:-1]
        x0 = data.x[:-1]
        ks: list[np.ndarray] = []
        for i in range(tab.stages):
            xi = x0.copy()
            for j in range(i):
                if tab.a[i][j] != 0:
                    xi += (h * float(tab.a[i][j])) * ks[j]
            ci = float(tab.c[i])
            ks.append(model.f(t0 + ci * h, xi, stage_inputs(data, signal, ci)))
        out = np.full(data.x.shape, np.nan)
        incr = sum(float(bi) * k for bi, k in zip(tab.b, ks, strict=True))
        out[1:] = x0 + h * incr
        return out
