"""Right-hand sides that jump across a switching surface: what f is on the surface.

A model whose f jumps where a switching value g(t, x, u) changes sign (``sign``,
``Heaviside``, ``Piecewise`` of a state) provides, besides f itself:

* a **branch kernel** ``branch(t, x, u, q, out)``: f of one side of every jump, the
  side s_j = -1 or +1 of jump j read from ``q[n_params + j]`` (q: the parameters,
  then the sides). Off the surfaces it equals f on the side the state is on; on a
  surface it is the limit from the side chosen;
* the **gradients** of its switching values, ``grad(t, x, u, p, out)`` with rows
  ``(dg/dx (nx), dg/dt, dg/du (nu))``, out shape (n_sw, nx + 1 + nu);
* which switching values are jumps (``sw_info``: the position of each one's side in
  q, -1 for a kink, and whether it depends on the input).

On a surface, the side the motion takes follows from the normal speeds of the two
branches, sigma_-+ = dg/dx f_-+ + dg/dt (+ dg/du du/dt): :func:`decide` (the rule
of Filippov's theory as the event-driven method of Piiroinen and Kuznetsov, ACM
Trans. Math. Softw. 34(3), 2008, applies it), and where both sides push onto the
surface (or both away), Filippov's sliding vector, the convex combination of the two
branches whose normal speed is zero (:func:`sliding_weight`). The simulator
(:mod:`sampledyn._integrator`) integrates with these; a model's own ``f`` uses them
at a state exactly on one surface (:data:`SURFACE_RHS`), so that the value a formula
gives there (``sign(0) = 0``, ``Heaviside(0) = 1/2``) is never used as a vector field.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numba import njit

if TYPE_CHECKING:
    from ._base import Model

__all__ = [
    "SURFACE_RHS",
    "decide",
    "refuse_jumps",
    "sliding_weight",
    "surface_at",
    "surface_source",
]


@njit(inline="always")
def decide(s_lo, s_hi):  # pragma: no cover - compiled
    """What the normal speeds of the two sides of a surface mean for the motion on
    it: +1 or -1 it enters that side (a crossing), 0 it slides (both push onto the
    surface), 2 both push it away (repelling: the solution is not unique), 3 both
    are tangent (nothing changes). Speeds within 1e-12 of the sum of their
    magnitudes count as zero."""
    tol = 1e-12 * (abs(s_lo) + abs(s_hi))
    lo = 0 if abs(s_lo) <= tol else (1 if s_lo > 0.0 else -1)
    hi = 0 if abs(s_hi) <= tol else (1 if s_hi > 0.0 else -1)
    if lo == 1 and hi == -1:
        return 0
    if lo == -1 and hi == 1:
        return 2
    if lo + hi > 0:
        return 1
    if lo + hi < 0:
        return -1
    return 3


@njit(inline="always")
def sliding_weight(s_lo, s_hi):  # pragma: no cover - compiled
    """a in f_s = (1 - a) f_- + a f_+, the Filippov combination with zero normal speed
    (Utkin's equivalent control): a = sigma_- / (sigma_- - sigma_+)."""
    den = s_lo - s_hi
    return 0.5 if den == 0.0 else s_lo / den


# f of a model with jumps, from its branch kernel: the sides from the signs of the
# switching values; on one surface (a value exactly zero) the side the motion takes,
# or the sliding vector (with du/dt = 0: f(t, x, u) does not know the input's rate);
# on two at once NaN (the intersection is not solved).
SURFACE_RHS = """
_branch = njit(inline="always", error_model="numpy")(_branch_k.py_func)
_switch = njit(inline="always", error_model="numpy")(_switch_k.py_func)
_switch_grad = njit(inline="always", error_model="numpy")(_switch_grad_k.py_func)
_JUMPS = {jumps}


@njit(cache=CACHE, error_model="numpy")
def rhs(t, x, u, p, out):  # pragma: no cover - compiled
    g = stack_buffer({n_sw})
    _switch(t, x, u, p, g)
    q = stack_buffer({n_q})
    for i in range({n_p}):
        q[i] = p[i]
    on = -1
    for j in range({n_jumps}):
        v = g[_JUMPS[j]]
        q[{n_p} + j] = 1.0 if v > 0.0 else -1.0
        if v == 0.0:
            on = {n_jumps} if on >= 0 else j
    if on < 0:
        _branch(t, x, u, q, out)
        return
    if on == {n_jumps}:
        out[:] = np.nan
        return
    nx = x.shape[0]
    k = _JUMPS[on]
    F = np.empty((2, nx))
    G = np.empty(({n_sw}, nx + 1 + u.shape[0]))
    q[{n_p} + on] = -1.0
    _branch(t, x, u, q, F[0])
    q[{n_p} + on] = 1.0
    _branch(t, x, u, q, F[1])
    _switch_grad(t, x, u, p, G)
    s_lo = G[k, nx]
    s_hi = G[k, nx]
    for i in range(nx):
        s_lo += G[k, i] * F[0, i]
        s_hi += G[k, i] * F[1, i]
    d = decide(s_lo, s_hi)
    a = sliding_weight(s_lo, s_hi)
    for i in range(nx):
        if d == 1 or d == -1:
            out[i] = F[(d + 1) // 2, i]
        else:
            out[i] = F[0, i] + a * (F[1, i] - F[0, i])
"""


def surface_source(jumps: tuple[int, ...], n_sw: int, n_p: int) -> str:
    """:data:`SURFACE_RHS` for jumps at switching values ``jumps`` (indices), ``n_sw``
    switching values and ``n_p`` parameters. The module it goes into defines
    ``_branch_k``, ``_switch_k``, ``_switch_grad_k``, ``decide``, ``sliding_weight``,
    ``stack_buffer``, ``np``, ``njit`` and ``CACHE``."""
    return SURFACE_RHS.format(
        jumps=repr(tuple(int(k) for k in jumps)),
        n_sw=max(int(n_sw), 1),
        n_q=int(n_p) + len(jumps),
        n_p=int(n_p),
        n_jumps=len(jumps),
    )


def surface_at(model: Model, t: float, x: Any, u: Any) -> str | None:
    """The switching surface of a jump of f that (t, x, u) lies on, as text, or None.

    On the surface f has no derivative (it jumps), so df/dx does not exist there. A
    switching value within 1e-12 max(1, |x|, |u|) of zero counts (the rounding of a
    state computed to lie on it)."""
    get = getattr(model, "jump_kernel", None)
    jumps = get() if get is not None else None
    if jumps is None:
        return None
    sw, sp, _ = model.switch_kernel()
    x = np.ascontiguousarray(x, dtype=float)
    u = np.ascontiguousarray(u, dtype=float).reshape(-1)
    g = np.empty(jumps[3].shape[0])
    sw(float(t), x, u, np.asarray(sp, dtype=float), g)
    scale = max(1.0, float(np.abs(x).max(initial=0.0)), float(np.abs(u).max(initial=0.0)))
    names = model.switching_names() if hasattr(model, "switching_names") else ()
    for k in np.flatnonzero(jumps[3][:, 0] >= 0):
        if abs(g[k]) <= 1e-12 * scale:
            return str(names[k]) if k < len(names) else f"g[{k}]"
    return None


def refuse_jumps(model: Model, argument: str, why: str) -> None:
    """Raise ValueError if ``model``'s f jumps (it has a branch kernel): for consumers
    that integrate or compose f without its branches; ``why`` says what they lack and
    what to use instead."""
    get = getattr(model, "jump_kernel", None)
    if get is not None and get() is not None:
        name = getattr(model, "name", type(model).__name__)
        raise ValueError(
            f"`{argument}` {name!r} has an f that jumps (sign, Heaviside or Piecewise of a "
            f"state): {why}"
        )
