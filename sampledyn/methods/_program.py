"""A rule's discrete-time step as data, and everything derived from it in one place.

The rules built of f evaluations (E, AB_s, ABu_s, RK_s, Tustin) write their step
z_{n+1} = F(z_n, u_n) once, as a :class:`StepProgram` made from their coefficients
or tableau:

* ``layout``: the blocks of z (each nx long): ("x", lag) the state lag samples back,
  ("f", lag) f at that sample with its input;
* ``stages``: f evaluations ``k_i = f(t + c_i h, y_i, u)`` (u held over the interval),
  each at a point ``y_i`` that is a block of z or a :class:`Combination` of blocks and
  earlier stages; a stage with ``implicit = gamma > 0`` solves ``y_i = point + h gamma
  f(t + c_i h, y_i, u)`` by Newton's method with the model's Jacobian (a diagonally
  implicit stage, e.g. Tustin's end point);
* ``update``: x_{n+1}; ``carry``: the other blocks of z_{n+1}.

A value is referred to as ("z", b) (block b of z), ("k", i) (f of stage i) or
("y", i) (the point of stage i). From the program this module derives, with the same
floating-point operations in the same order wherever they are executed:

* :meth:`StepProgram.source`: the numba source of ``step(t, z, u, p, h, out)``
  (and ``step_f``, the step given f at x_n), compiled by :func:`sampledyn.discretize`
  against the model's kernel;
* :meth:`StepProgram.blocks`: the step in vector arithmetic (numpy arrays or CasADi
  symbols);
* :meth:`StepProgram.linearize`: (A_d, B_d), exact, forward mode through the stages
  from the model's df/dx and df/du; :func:`stage_jacobians` the same over many
  sampling intervals at once (the one-step rules' ``prediction_jacobians``);
* :meth:`StepProgram.steady_state`: z of a constant history.

So a rule states its arithmetic once; its ``predict`` (vectorised over the samples,
on uniform and non-uniform time) is the only other place, and a test checks that
one step of the compiled program from sampled data is that prediction, bit for bit.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..exceptions import ConvergenceError
from ..models import Model

__all__ = ["Combination", "Stage", "StepProgram", "stage_jacobians"]

Ref = tuple[str, int]


@dataclass(frozen=True)
class Combination:
    """``base + sum_j (h c_j) v_j`` (``outside`` False: each coefficient scaled by h,
    summed in order onto the base) or ``base + h sum_j c_j v_j`` (``outside`` True:
    the sum first, from 0, then scaled by h once). ``terms`` are (c_j, ref) pairs."""

    base: Ref
    terms: tuple[tuple[float, Ref], ...] = ()
    outside: bool = False


@dataclass(frozen=True)
class Stage:
    """``k = f(t + c h, y, u)`` at ``y = point``, or with ``implicit = gamma > 0`` at
    the y solving ``y = point + h gamma f(t + c h, y, u)`` (point then an ``outside``
    :class:`Combination`, or a block of z); Newton starts from the Euler predictor
    ``base + (c h) k_0``."""

    c: float
    point: Ref | Combination
    implicit: float = 0.0


@dataclass(frozen=True)
class StepProgram:
    """A discrete-time step z+ = F(z, u) built of f evaluations (see the module
    docstring). ``name`` is the rule's, for messages; ``tol`` and ``max_iter`` the
    Newton settings of implicit stages (every update ``|dx_i| <= tol (1 + |x_i|)``).

    Raises
    ------
    ValueError
        if a reference points at a block or stage that does not exist (yet), or an
        implicit stage lacks an explicit first stage to start from.
    """

    name: str
    layout: tuple[tuple[str, int], ...]
    stages: tuple[Stage, ...]
    update: Ref | Combination
    carry: tuple[Ref, ...] = ()
    tol: float = 1e-12
    max_iter: int = 25

    def __post_init__(self) -> None:
        nb = len(self.layout)
        if not nb or self.layout[0] != ("x", 0):
            raise ValueError(f"{self.name}: z must start with the state, ('x', 0).")
        if len(self.carry) != nb - 1:
            raise ValueError(f"{self.name}: `carry` needs {nb - 1} blocks, got {len(self.carry)}.")
        for i, st in enumerate(self.stages):
            self._check(st.point, i, f"stage {i}")
            if st.implicit:
                first = self.stages[0]
                if i == 0 or first.implicit or not isinstance(self._point(st), Combination):
                    raise ValueError(
                        f"{self.name}: implicit stage {i} needs an explicit stage 0 (its "
                        "Newton predictor) and an `outside` Combination as its point."
                    )
        for ref in (self.update, *self.carry):
            self._check(ref, len(self.stages), "update")

    def _check(self, ref: Ref | Combination, stage: int, where: str) -> None:
        refs = [ref] if not isinstance(ref, Combination) else [ref.base, *(r for _, r in ref.terms)]
        for kind, idx in refs:
            limit = len(self.layout) if kind == "z" else stage
            if kind not in ("z", "k", "y") or not 0 <= idx < limit:
                raise ValueError(
                    f"{self.name}: {where} refers to ({kind!r}, {idx}), which does not exist."
                )

    def _point(self, st: Stage) -> Ref | Combination:
        """An implicit stage's point as a Combination (a bare block: no terms)."""
        if st.implicit and not isinstance(st.point, Combination):
            return Combination(st.point, (), True)
        return st.point

    # ---- what the step needs --------------------------------------------------------

    @property
    def kernels(self) -> frozenset[str]:
        """ "rhs", and "jac" when a stage is implicit (Newton with df/dx)."""
        return frozenset({"rhs", "jac"} if any(s.implicit for s in self.stages) else {"rhs"})

    @property
    def takes_f0(self) -> bool:
        """True if z holds f blocks and the first stage is f at x_n itself: the source
        then also defines ``step_f(t, z, f0, u, p, h, out)`` (a rollout over sampled
        data takes f0 from one table of f at the samples)."""
        first = self.stages[0] if self.stages else None
        return (
            any(kind == "f" for kind, _ in self.layout)
            and first is not None
            and first.c == 0.0
            and first.point == ("z", 0)
            and not first.implicit
        )

    @property
    def history(self) -> int:
        """Samples z spans: the largest lag plus one."""
        return max(lag for _, lag in self.layout) + 1

    # ---- the compiled step ---------------------------------------------------------

    def source(self) -> str:
        """numba source of ``step(t, z, u, p, h, out)`` (globals ``rhs``, ``jac``, ``np``,
        ``CACHE``, ``njit``): NaN in ``out`` where an implicit stage does not converge."""
        nb = len(self.layout)
        head = f"NB = {nb}\nTOL = {float(self.tol)!r}\nMAX_ITER = {int(self.max_iter)}\n\n\n"
        deco = '@njit(cache=CACHE, error_model="numpy")\n'
        if self.takes_f0:
            first = self._stage_code(0)
            rest = self._body(start=1)
            return (
                head + deco + "def step(t, z, u, p, h, out):\n    nx = z.shape[0] // NB\n"
                + first + "    step_f(t, z, k0, u, p, h, out)\n\n\n"
                + '@njit(inline="always", error_model="numpy")\n'
                + "def step_f(t, z, k0, u, p, h, out):\n    nx = z.shape[0] // NB\n" + rest
            )  # fmt: skip
        return (
            head
            + deco
            + "def step(t, z, u, p, h, out):\n    nx = z.shape[0] // NB\n"
            + self._body(0)
        )

    def _used_later(self, kind: str, i: int) -> bool:
        refs: list[Ref] = []
        for item in [*(s.point for s in self.stages[i + 1 :]), self.update, *self.carry]:
            refs += (
                [item.base, *(r for _, r in item.terms)]
                if isinstance(item, Combination)
                else [item]
            )
        return (kind, i) in refs

    def _body(self, start: int) -> str:
        code = "".join(self._stage_code(i) for i in range(start, len(self.stages)))
        code += self._assign("out", 0, self.update)
        for b, ref in enumerate(self.carry, start=1):
            code += self._assign("out", b, ref)
        return code

    def _time(self, c: float) -> str:
        return "t" if c == 0.0 else f"t + {float(c)!r} * h"

    def _at(self, ref: Ref) -> str:
        """The source of entry j of a referenced value."""
        kind, idx = ref
        if kind == "z":
            return "z[j]" if idx == 0 else f"z[{idx} * nx + j]"
        if (
            kind == "y"
            and not isinstance(self.stages[idx].point, Combination)
            and not self.stages[idx].implicit
        ):
            return self._at(self.stages[idx].point)  # type: ignore[arg-type]
        return f"{kind}{idx}[j]"

    def _expr(self, comb: Combination, indent: str) -> str:
        """Lines computing ``v`` = entry j of ``comb`` (in the order of the docstring)."""
        if not comb.outside:
            lines = [f"v = {self._at(comb.base)}"]
            lines += [f"v += (h * {float(c)!r}) * {self._at(r)}" for c, r in comb.terms]
        else:
            lines = ["acc = 0.0"] + [f"acc += {float(c)!r} * {self._at(r)}" for c, r in comb.terms]
            lines.append(f"v = {self._at(comb.base)} + h * acc")
        return "".join(f"{indent}{line}\n" for line in lines)

    def _assign(self, target: str, block: int, item: Ref | Combination) -> str:
        dest = f"{target}[j]" if block == 0 else f"{target}[{block} * nx + j]"
        if isinstance(item, Combination):
            return "    for j in range(nx):\n" + self._expr(item, " " * 8) + f"        {dest} = v\n"
        return f"    for j in range(nx):\n        {dest} = {self._at(item)}\n"

    def _stage_code(self, i: int) -> str:
        st = self.stages[i]
        time = self._time(st.c)
        code = f"    k{i} = np.empty(nx)\n"
        if st.implicit:
            return code + self._implicit_code(i)
        if isinstance(st.point, Combination):
            code += f"    y{i} = np.empty(nx)\n" + self._assign(f"y{i}", 0, st.point)
            return code + f"    rhs({time}, y{i}, u, p, k{i})\n"
        kind, idx = st.point
        if kind == "z":
            arg = "z" if len(self.layout) == 1 else f"z[{idx} * nx : {idx + 1} * nx]"
        else:
            arg = f"{kind}{idx}"
        return code + f"    rhs({time}, {arg}, u, p, k{i})\n"

    def _implicit_code(self, i: int) -> str:
        st = self.stages[i]
        point = self._point(st)
        assert isinstance(point, Combination)
        gamma = float(st.implicit)
        step0 = "h" if st.c == 1.0 else f"({float(st.c)!r} * h)"
        terms = " + ".join(
            [f"{float(c)!r} * {self._at(r)}" for c, r in point.terms] + [f"{gamma!r} * k{i}[j]"]
        )
        lines = [
            f"y{i} = np.empty(nx)",
            "J = np.empty((nx, nx))",
            "g = np.empty(nx)",
            "for j in range(nx):",
            f"    y{i}[j] = {self._at(point.base)} + {step0} * k0[j]",
            f"t{i} = {self._time(st.c)}",
            "ok = False",
            "for _ in range(MAX_ITER):",
            f"    rhs(t{i}, y{i}, u, p, k{i})",
            f"    jac(t{i}, y{i}, u, p, J)",
            "    for j in range(nx):",
            f"        g[j] = -(y{i}[j] - {self._at(point.base)} - h * ({terms}))",
            f"    M = -{gamma!r} * h * J",
            "    for j in range(nx):",
            "        M[j, j] += 1.0",
            "    dx = np.linalg.solve(M, g)",
            "    ok = True",
            "    for j in range(nx):",
            f"        y{i}[j] += dx[j]",
            f"        if abs(dx[j]) > TOL * (1.0 + abs(y{i}[j])):",
            "            ok = False",
            "    if ok:",
            "        break",
            "if not ok:",
            "    for j in range(nx):",
            f"        y{i}[j] = np.nan",
        ]
        if self._used_later("k", i):
            lines.append(f"rhs(t{i}, y{i}, u, p, k{i})")
        return "".join(f"    {line}\n" for line in lines)

    # ---- vector arithmetic ---------------------------------------------------------

    def blocks(
        self, f: Any, t: Any, blocks: list[Any], u: Any, h: float, solver: Any = None
    ) -> list[Any]:
        """z+ from the blocks of z in vector arithmetic (numpy arrays or CasADi
        symbols), ``f(t, x, u)`` the model's f; an implicit stage asks
        ``solver.implicit(residual, guess)`` for the root (e.g. CasADi's rootfinder).

        Raises
        ------
        ValueError
            for an implicit step without a ``solver``.
        """
        vals: dict[Ref, Any] = {("z", b): blk for b, blk in enumerate(blocks)}

        def combine(comb: Combination) -> Any:
            if not comb.outside:
                out = vals[comb.base]
                for c, r in comb.terms:
                    out = out + (h * float(c)) * vals[r]
                return out
            acc = None
            for c, r in comb.terms:
                acc = float(c) * vals[r] if acc is None else acc + float(c) * vals[r]
            return vals[comb.base] if acc is None else vals[comb.base] + h * acc

        for i, st in enumerate(self.stages):
            ti = t if st.c == 0.0 else t + float(st.c) * h
            point = self._point(st)
            if st.implicit:
                if solver is None:
                    raise ValueError(
                        f"{self.name} is implicit: a `solver` with implicit(residual, guess) "
                        "is needed."
                    )
                assert isinstance(point, Combination)
                base, gamma = vals[point.base], float(st.implicit)

                def residual(x: Any, point: Combination = point, ti: Any = ti, gamma=gamma) -> Any:
                    acc = None
                    for c, r in point.terms:
                        acc = float(c) * vals[r] if acc is None else acc + float(c) * vals[r]
                    last = gamma * f(ti, x, u)
                    return x - vals[point.base] - h * (last if acc is None else acc + last)

                guess = base + (h if st.c == 1.0 else float(st.c) * h) * vals[("k", 0)]
                y = solver.implicit(residual, guess)
            else:
                y = combine(point) if isinstance(point, Combination) else vals[point]
            vals[("y", i)] = y
            vals[("k", i)] = f(ti, y, u)
        items = [self.update, *self.carry]
        return [combine(it) if isinstance(it, Combination) else vals[it] for it in items]

    # ---- linearisation -------------------------------------------------------------

    def linearize(
        self,
        model: Model,
        t: float,
        z: np.ndarray,
        u: np.ndarray,
        h: float,
        solver: Any = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """(A_d, B_d) = (dF/dz, dF/du) at (z, u), shapes (nz, nz) and (nz, nu): forward
        mode through the stages with the model's exact df/dx = F_i and df/du = G_i at
        each stage (``dk_i = F_i dy_i``, ``dk_i/du = F_i dy_i/du + G_i``; an implicit
        stage ``(I - h gamma F_i) dy_i = d point + h gamma G_i du``). ``solver`` is not
        used (the stages are f evaluations).

        Raises
        ------
        ConvergenceError
            if an implicit stage's Newton iteration does not converge.
        """
        nx, nu = int(model.nx), int(model.nu)
        z = np.asarray(z, dtype=float)
        u = np.asarray(u, dtype=float)
        nz = len(self.layout) * nx
        vals: dict[Ref, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        for b in range(len(self.layout)):
            dz = np.zeros((nx, nz))
            dz[:, b * nx : (b + 1) * nx] = np.eye(nx)
            vals[("z", b)] = (z[b * nx : (b + 1) * nx], dz, np.zeros((nx, nu)))
        _forward(self, model, float(t), h, h, lambda c: u, vals, nx, want_u=True)
        rows = [_value(it, vals, h, h) for it in (self.update, *self.carry)]
        return np.vstack([r[1] for r in rows]), np.vstack([r[2] for r in rows])

    def steady_state(
        self, model: Model, x: np.ndarray, u: np.ndarray, t: float = 0.0
    ) -> np.ndarray:
        """z of a constant history at (x, u): x in every state block, f(t, x, u) in
        every f block (zero at an equilibrium), shape (nz,)."""
        x = np.asarray(x, dtype=float)
        if all(kind == "x" for kind, _ in self.layout):
            return np.tile(x, len(self.layout)) if len(self.layout) > 1 else np.array(x)
        f = np.asarray(model.f(float(t), x, u), dtype=float)
        return np.concatenate([x if kind == "x" else f for kind, _ in self.layout])


def _value(item: Ref | Combination, vals: dict[Ref, Any], hv: Any, hm: Any) -> tuple[Any, Any, Any]:
    """(value, d/dz, d/du) of a reference or a combination; ``hv`` and ``hm`` are h
    shaped to scale vectors and matrices (a float, or per row (R, 1) and (R, 1, 1))."""
    if not isinstance(item, Combination):
        return vals[item]
    base = vals[item.base]
    if not item.outside:
        v, dz, du = base
        for c, r in item.terms:
            w = vals[r]
            v = v + (hv * float(c)) * w[0]
            dz = dz + (hm * float(c)) * w[1]
            du = None if du is None else du + (hm * float(c)) * w[2]
        return v, dz, du
    if not item.terms:
        return base
    sums: list[Any] = [None, None, None]
    for c, r in item.terms:
        for n, part in enumerate(vals[r]):
            if part is not None:
                sums[n] = float(c) * part if sums[n] is None else sums[n] + float(c) * part
    v = base[0] + hv * sums[0]
    dz = base[1] + hm * sums[1]
    du = None if base[2] is None else base[2] + hm * sums[2]
    return v, dz, du


def _forward(
    prog: StepProgram,
    model: Model,
    t: Any,
    hv: Any,
    hm: Any,
    inputs: Callable[[float], Any],
    vals: dict[Ref, Any],
    nx: int,
    want_u: bool,
) -> None:
    """Every stage's (value, d/dz, d/du) into ``vals``; arrays with a leading row axis
    R (t shape (R,), h per row) or without (one point). ``inputs(c)`` is the input of
    a stage at offset c (held: the same for every c)."""
    for i, st in enumerate(prog.stages):
        ti = t if st.c == 0.0 else t + float(st.c) * (hv if np.ndim(hv) == 0 else hv[:, 0])
        ui = inputs(float(st.c))
        point = prog._point(st)
        if st.implicit:
            assert isinstance(point, Combination)
            y, dy, dyu = _implicit(prog, model, st, point, ti, ui, hv, hm, vals, nx, want_u)
        else:
            y, dy, dyu = _value(point, vals, hv, hm)
        F = np.asarray(model.jacobian(ti, y, ui), dtype=float)
        k = np.asarray(model.f(ti, y, ui), dtype=float)
        dk = F @ dy
        dku = F @ dyu + np.asarray(model.input_jacobian(ti, y, ui), dtype=float) if want_u else None
        vals[("y", i)] = (y, dy, dyu)
        vals[("k", i)] = (k, dk, dku)


def _implicit(
    prog: StepProgram,
    model: Model,
    st: Stage,
    point: Combination,
    ti: float,
    u: Any,
    h: float,
    hm: float,
    vals: dict[Ref, Any],
    nx: int,
    want_u: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """An implicit stage at one point: y by Newton (as the compiled step), then
    ``dy = (I - h gamma F_y)^-1 (d base + h (sum_j c_j dv_j + gamma G_y du))``."""
    if np.ndim(h) != 0:
        raise ValueError(f"{prog.name}: implicit stages are linearised at one point only.")
    gamma = float(st.implicit)
    eye = np.eye(nx)
    base = vals[point.base]

    def summed(n: int, last: Any) -> Any:
        acc = None
        for c, r in point.terms:
            acc = float(c) * vals[r][n] if acc is None else acc + float(c) * vals[r][n]
        if last is None:
            return acc
        return gamma * last if acc is None else acc + gamma * last

    step0 = h if st.c == 1.0 else float(st.c) * h
    y = base[0] + step0 * vals[("k", 0)][0]
    for _ in range(prog.max_iter):
        g = y - base[0] - h * summed(0, np.asarray(model.f(ti, y, u)))
        dx = np.linalg.solve(eye - (gamma * h) * np.asarray(model.jacobian(ti, y, u)), -g)
        y = y + dx
        if (np.abs(dx) <= prog.tol * (1.0 + np.abs(y))).all():
            break
    else:
        raise ConvergenceError(
            f"{prog.name}'s Newton iteration did not converge in {prog.max_iter} iterations "
            f"at t={ti - step0:g} s; use a smaller h or raise `max_iter`."
        )
    lhs = eye - (gamma * h) * np.asarray(model.jacobian(ti, y, u), dtype=float)
    rz = summed(1, None)
    dy = np.linalg.solve(lhs, base[1] if rz is None else base[1] + h * rz)
    dyu = None
    if want_u:
        gy = np.asarray(model.input_jacobian(ti, y, u), dtype=float)
        dyu = np.linalg.solve(lhs, base[2] + h * summed(2, gy))
    return y, dy, dyu


def stage_jacobians(
    prog: StepProgram,
    model: Model,
    t0: np.ndarray,
    x0: np.ndarray,
    steps: np.ndarray,
    inputs: Callable[[float], np.ndarray],
) -> np.ndarray:
    """``d x_{n+1} / d x_n`` over many intervals at once, shape (R, nx, nx): the forward
    mode of :meth:`StepProgram.linearize` on rows (t0 (R,), x0 (R, nx), each with its
    step, shape (R,)), ``inputs(c)`` the stage inputs at t_n + c h_n, shape (R, nu).
    For explicit programs whose z is the state alone (the one-step rules)."""
    if len(prog.layout) != 1 or any(s.implicit for s in prog.stages):
        raise ValueError(f"{prog.name}: stage_jacobians needs an explicit one-block program.")
    rows, nx = x0.shape
    eye = np.broadcast_to(np.eye(nx), (rows, nx, nx)).copy()
    vals: dict[Ref, Any] = {("z", 0): (x0, eye, None)}
    _forward(prog, model, t0, steps[:, None], steps[:, None, None], inputs, vals, nx, want_u=False)
    return np.asarray(_value(prog.update, vals, steps[:, None], steps[:, None, None])[1])
