"""Straight-line source of the vehicle kernels for one sparsity pattern.

The vehicle's f, df/dx, df/du and switching values (eqs. (3), (5)-(7), (13)-(18), as
documented in :mod:`sampledyn.models._vehicle_kernels`) are written out term by term
for one :class:`Structure`: which entries of M, M^-1, D_l, d_q, the allocation B, the
restoring moment, the current and the cable force are non-zero, how many thrusters,
whether the rpm lag and the wrench input are on. A structural zero writes no code:
the RexROV's diagonal D_l is 6 products instead of 36, a thruster column without a
heave component has no heave term, a vehicle without current or cable has no
additions for them, and no loop, branch on an option or index arithmetic is left.

The values themselves stay in the parameter array ``p`` (the layout of
:mod:`~sampledyn.models._vehicle_kernels`), read at fixed offsets: every vehicle with
the same pattern shares one compiled module, so :meth:`Vehicle.with_params` (the
estimators' iterates, sweeps over buoyancy or a damping coefficient) recompiles
nothing unless a value becomes or stops being exactly zero. Folding the values into
the code as well would compile one module per parameter value (about a second each)
for a few nanoseconds per f (a load from ``p`` costs what a constant does).

Each expression keeps the order of operations of the generic kernel it replaced
(the terms of ``M v``, ``D_l v``, ``B T`` and ``M^-1 r`` summed left to right, the
cross products as in Fossen's C(v) v), less the terms that are zero, so f is the same
to rounding of the dropped ``+ 0.0``: identical but for the sign of a zero.

This module writes text only; :mod:`~sampledyn.models._vehicle_kernels` compiles it
through the kernel cache (:mod:`~sampledyn.models._codegen`), keyed by the hash of
the source.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

__all__ = ["Structure", "vehicle_source"]


@dataclass(frozen=True)
class Structure:
    """Which entries of the parameter array are non-zero (the sparsity pattern).

    Attributes
    ----------
    n_thrusters : int
        Thrusters in the kernel (0 with a wrench input).
    lag : bool
        Thruster rpm are states, eq. (3).
    wrench : bool
        The input is the commanded wrench tau.
    mass, minv, damping : tuple of tuple of bool, shape (6, 6)
        Non-zero entries of M, M^-1 and D_l.
    quadratic, cable, current_body, current_ned : tuple of bool, shape (6,)
        Non-zero entries of d_q, tau_c and the two currents.
    moment : tuple of bool, shape (3,)
        Non-zero entries of h = W r_G - B r_B (the restoring moment's lever).
    heave : bool
        W - B is non-zero.
    k1, k2 : bool
        K1 and K2 are non-zero.
    allocation : tuple of tuple of bool, shape (N, 6)
        Non-zero entries of each column of B (thruster by thruster).
    offsets : tuple of int
        Where each block starts in ``p``: the slots of
        :mod:`~sampledyn.models._vehicle_kernels`, by name (see ``OFFSET_NAMES``).
    """

    n_thrusters: int
    lag: bool
    wrench: bool
    mass: tuple[tuple[bool, ...], ...]
    minv: tuple[tuple[bool, ...], ...]
    damping: tuple[tuple[bool, ...], ...]
    quadratic: tuple[bool, ...]
    cable: tuple[bool, ...]
    current_body: tuple[bool, ...]
    current_ned: tuple[bool, ...]
    moment: tuple[bool, ...]
    heave: bool
    k1: bool
    k2: bool
    allocation: tuple[tuple[bool, ...], ...]
    offsets: tuple[int, ...]

    @property
    def nx(self) -> int:
        return 12 + (self.n_thrusters if self.lag else 0)

    @property
    def nu(self) -> int:
        return 6 if self.wrench else self.n_thrusters

    def slot(self, name: str, k: int = 0) -> str:
        """``p[i]`` of entry ``k`` of block ``name``."""
        return f"p[{self.offsets[OFFSET_NAMES.index(name)] + k}]"


# The blocks of p the generated code reads (offsets in Structure.offsets).
OFFSET_NAMES = ("K1", "K2", "NMAX", "DQ", "TAUC", "VCB", "VCN", "DL", "M", "MINV", "WB", "H",
                "INVTN", "ALLOC")  # fmt: skip


# ------------------------------------------------------------------- expressions
@dataclass(frozen=True)
class _E:
    """An expression's text and its outermost operation: ``atom`` (a name, a call, a
    literal, a parenthesised group), ``prod`` (``*``, ``/``, unary minus) or ``sum``.
    Structural zeros are ``None``, never an ``_E``."""

    text: str
    kind: str = "atom"


Ex = _E | None


def _operand(e: _E, *, right_of_product: bool = False) -> str:
    """``e`` as an operand: a sum is parenthesised (the tree fixes the rounding), and
    so is a product on the right of a product (a * (b * c) is not (a * b) * c)."""
    if e.kind == "sum" or (right_of_product and e.kind == "prod"):
        return f"({e.text})"
    return e.text


def add(a: Ex, b: Ex) -> Ex:
    if a is None:
        return b
    if b is None:
        return a
    return _E(f"{a.text} + {_operand(b)}", "sum")


def sub(a: Ex, b: Ex) -> Ex:
    if b is None:
        return a
    if a is None:
        return neg(b)
    return _E(f"{a.text} - {_operand(b)}", "sum")


def neg(a: Ex) -> Ex:
    """-a (exact: negation does not round, so -(x - y) and -x + y are equal)."""
    if a is None:
        return None
    if a.text.startswith("-") and a.kind == "atom":
        return _E(a.text[1:], "atom")
    return _E(f"-{_operand(a)}", "prod")


def mul(a: Ex, b: Ex) -> Ex:
    if a is None or b is None:
        return None
    return _E(f"{_operand(a)} * {_operand(b, right_of_product=True)}", "prod")


def total(terms: Iterable[Ex]) -> Ex:
    """t0 + t1 + ... left to right, zeros left out."""
    out: Ex = None
    for t in terms:
        out = add(out, t)
    return out


def name(text: str) -> _E:
    return _E(text)


def text(e: Ex) -> str:
    """The source of ``e`` ("0.0" for a structural zero)."""
    return "0.0" if e is None else e.text


class _Writer:
    """Lines of one function body; locals named once, zeros never assigned."""

    def __init__(self) -> None:
        self.lines: list[str] = []

    def let(self, var: str, e: Ex) -> Ex:
        """``var = e`` (nothing for a zero); the name, or None."""
        if e is None:
            return None
        if e.kind == "atom":
            return e  # a name or p[i]: no copy
        self.lines.append(f"    {var} = {e.text}")
        return name(var)

    def put(self, target: str, e: Ex) -> None:
        """``target = e``; a zero writes 0.0."""
        self.lines.append(f"    {target} = {text(e)}")

    def raw(self, line: str) -> None:
        self.lines.append(f"    {line}")


def _entry(s: Structure, block: str, mask: Sequence[Sequence[bool]], i: int, j: int) -> Ex:
    return name(s.slot(block, 6 * i + j)) if mask[i][j] else None


def _vec(s: Structure, block: str, mask: Sequence[bool], k: int) -> Ex:
    return name(s.slot(block, k)) if mask[k] else None


def _alloc(s: Structure, i: int, k: int) -> Ex:
    """B[k, i] (thruster i's column)."""
    return name(s.slot("ALLOC", 6 * i + k)) if s.allocation[i][k] else None


def dense(mask: Iterable[Iterable[bool]]) -> bool:
    """No entry is zero: the product is then written as a loop of six, which LLVM
    unrolls into the same straight line, since numba compiles the term-by-term text
    (about a millisecond per operation) more slowly than the loop."""
    flat = [bool(b) for row in mask for b in row]
    return bool(flat) and all(flat)


# ------------------------------------------------------------------ shared pieces
V = tuple(name(n) for n in ("vu", "vv", "vw", "vp", "vq", "vr"))
_TRIG = (
    "    cf = math.cos(x[3])",
    "    sf = math.sin(x[3])",
    "    ct = math.cos(x[4])",
    "    st = math.sin(x[4])",
    "    cp = math.cos(x[5])",
    "    sp = math.sin(x[5])",
)
_VELOCITIES = tuple(f"    {v.text} = x[{6 + k}]" for k, v in enumerate(V))


def _relative(w: _Writer, s: Structure) -> list[Ex]:
    """w = v + v_c,body (the velocity J(eta) acts on, eq. (6))."""
    out = []
    for k in range(6):
        e = add(V[k], _vec(s, "VCB", s.current_body, k))
        out.append(e if e is V[k] else w.let(f"w{k}", e))
    return out


def _rotation(c: dict[str, _E]) -> list[list[Ex]]:
    """R(Theta) of eq. (6) (ZYX Euler angles), the generic kernel's expressions."""
    cf, sf, ct, st, cp, sp = (c[k] for k in ("cf", "sf", "ct", "st", "cp", "sp"))
    return [
        [mul(cp, ct), add(mul(neg(sp), cf), mul(mul(cp, st), sf)),
         add(mul(sp, sf), mul(mul(cp, cf), st))],
        [mul(sp, ct), add(mul(cp, cf), mul(mul(sf, st), sp)),
         add(mul(neg(cp), sf), mul(mul(st, sp), cf))],
        [neg(st), mul(ct, sf), mul(ct, cf)],
    ]  # fmt: skip


_C = {k: name(k) for k in ("cf", "sf", "ct", "st", "cp", "sp", "tt", "ict")}


_AB = ("a0", "a1", "a2", "b0", "b1", "b2")


def _mass_times_v(w: _Writer, s: Structure) -> list[Ex]:
    """(a, b) = M v: a = M[0:3] v, b = M[3:6] v (C(v) v = [w x a; v_lin x a + w x b])."""
    if dense(s.mass):
        at = s.offsets[OFFSET_NAMES.index("M")]
        w.lines += [f"    {n} = 0.0" for n in _AB]
        w.raw("for j in range(6):")
        w.raw("    vj = x[6 + j]")
        w.lines += [f"        {n} += p[{at + 6 * r} + j] * vj" for r, n in enumerate(_AB)]
        return [name(n) for n in _AB]
    ab = []
    for r in range(6):
        e = total(mul(_entry(s, "M", s.mass, r, j), V[j]) for j in range(6))
        ab.append(w.let(_AB[r], e))
    return ab


def _restoring_terms(s: Structure, k: tuple[Ex, Ex, Ex]) -> list[Ex]:
    """g with the sign of eq. (5): [(W - B) k; h x k], h = W r_G - B r_B, for the
    direction ``k`` (the unit vector k(eta), or a derivative of it)."""
    wb = name(s.slot("WB")) if s.heave else None
    hx, hy, hz = (name(s.slot("H", i)) if s.moment[i] else None for i in range(3))
    kx, ky, kz = k
    return [
        mul(wb, kx),
        mul(wb, ky),
        mul(wb, kz),
        sub(mul(hy, kz), mul(hz, ky)),
        sub(mul(hz, kx), mul(hx, kz)),
        sub(mul(hx, ky), mul(hy, kx)),
    ]


def _coriolis(ab: Sequence[Ex]) -> list[Ex]:
    """C(v) v = [w x a; v_lin x a + w x b] (Fossen 2011, eq. 3.46), row by row; with
    ``ab`` a column of M instead of M v, the same rows are that column of
    [S(w) M_top; S(v_lin) M_top + S(w) M_bot] (the Jacobian's Coriolis part)."""
    a0, a1, a2, b0, b1, b2 = ab
    vu, vv, vw, vp, vq, vr = V
    return [
        sub(mul(vq, a2), mul(vr, a1)),
        sub(mul(vr, a0), mul(vp, a2)),
        sub(mul(vp, a1), mul(vq, a0)),
        sub(add(sub(mul(vv, a2), mul(vw, a1)), mul(vq, b2)), mul(vr, b1)),
        sub(add(sub(mul(vw, a0), mul(vu, a2)), mul(vr, b0)), mul(vp, b2)),
        sub(add(sub(mul(vu, a1), mul(vv, a0)), mul(vp, b1)), mul(vq, b0)),
    ]


def _damping(s: Structure, k: int) -> Ex:
    """Row k of D(v) v = d_q |v| v + D_l v."""
    v = V[k]
    quad = mul(mul(_vec(s, "DQ", s.quadratic, k), name(f"abs({v.text})")), v)
    return total([quad, *(mul(_entry(s, "DL", s.damping, k, j), V[j]) for j in range(6))])


Column = Callable[[int], Ex]  # k -> B[k, i] of the thruster in hand (None: a zero)


@dataclass(frozen=True)
class _Run:
    """Thrusters start..stop-1, neighbours whose columns of B have the same zeros."""

    start: int
    stop: int
    pattern: tuple[bool, ...]


def _runs(s: Structure) -> list[_Run]:
    """The thrusters in order, grouped into runs of one zero pattern (e.g. the
    horizontal and the vertical thrusters of a vectored frame)."""
    runs: list[_Run] = []
    for i, pattern in enumerate(s.allocation):
        if runs and runs[-1].pattern == pattern and runs[-1].stop == i:
            runs[-1] = _Run(runs[-1].start, i + 1, pattern)
        else:
            runs.append(_Run(i, i + 1, tuple(pattern)))
    return runs


def _each_thruster(w: _Writer, s: Structure, run: _Run, indent: str) -> tuple[str, Column, str]:
    """Open the code of one run: a loop over its thrusters (more than one), or none.

    Returns the thruster index (source text), B[k, i] as a function of k (None for a
    zero of the run's pattern) and the indent of the body."""
    if run.stop - run.start == 1:
        i = run.start
        return str(i), (lambda k: _alloc(s, i, k)), indent
    w.raw(f"{indent}for i in range({run.start}, {run.stop}):")
    w.raw(f"{indent}    o = {s.offsets[OFFSET_NAMES.index('ALLOC')]} + 6 * i")
    return "i", (lambda k: name(f"p[o + {k}]") if run.pattern[k] else None), indent + "    "


def _shift(base: int, i: str) -> str:
    """``base + i`` as source (folded for a literal thruster index)."""
    return str(base + int(i)) if i.isdigit() else f"{base} + {i}"


def _rpm(s: Structure, i: str) -> str:
    """The applied rpm of thruster i: the lag state, or the saturated input."""
    return f"x[{_shift(12, i)}]" if s.lag else f"_saturate(u[{i}], {s.slot('NMAX')})"


def _inflow(w: _Writer, s: Structure, col: Column, indent: str) -> Ex:
    """v_a,i = B[:, i] . v (None without the inflow term, K2 = 0)."""
    if not s.k2:
        return None
    w.raw(f"{indent}va = {text(total(mul(col(k), V[k]) for k in range(6)))}")
    return name("va")


def _minv_times(w: _Writer, s: Structure, r: Sequence[Ex]) -> None:
    """out[6:12] = M^-1 r."""
    if dense(s.minv):
        w.raw("for k in range(6):")
        w.raw(f"    o = {s.offsets[OFFSET_NAMES.index('MINV')]} + 6 * k")
        row = total(mul(name(f"p[o + {j}]" if j else "p[o]"), r[j]) for j in range(6))
        w.raw(f"    out[6 + k] = {text(row)}")
        return
    for k in range(6):
        w.put(f"out[{6 + k}]", total(mul(_entry(s, "MINV", s.minv, k, j), r[j]) for j in range(6)))


def _minv_in_place(w: _Writer, s: Structure, first: int, stop: str) -> None:
    """out[6:12, c] = M^-1 out[6:12, c] for the columns c in [first, stop): the v rows
    of a Jacobian hold M (d v'/d.) there; one loop over the columns, the product
    written out once (zeros of M^-1 dropped), instead of once per column."""
    w.raw(f"for c in range({first}, {stop}):")
    for k in range(6):
        w.raw(f"    q{k} = out[{6 + k}, c]")
    q = [name(f"q{k}") for k in range(6)]
    if dense(s.minv):
        w.raw("    for k in range(6):")
        w.raw(f"        o = {s.offsets[OFFSET_NAMES.index('MINV')]} + 6 * k")
        row = total(mul(name(f"p[o + {j}]" if j else "p[o]"), q[j]) for j in range(6))
        w.raw(f"        out[6 + k, c] = {text(row)}")
        return
    for k in range(6):
        e = total(mul(_entry(s, "MINV", s.minv, k, j), q[j]) for j in range(6))
        w.raw(f"    out[{6 + k}, c] = {text(e)}")


# ------------------------------------------------------------------------------ f
def _rhs(s: Structure) -> list[str]:
    w = _Writer()
    w.lines += [*_TRIG, "    tt = st / ct", *_VELOCITIES]
    c = _C
    wv = _relative(w, s)
    rot = _rotation(c)
    for k in range(3):
        e = total(mul(rot[k][j], wv[j]) for j in range(3))
        w.put(f"out[{k}]", add(e, _vec(s, "VCN", s.current_ned, k)))
    euler = [
        add(add(wv[3], mul(mul(c["sf"], c["tt"]), wv[4])), mul(mul(c["cf"], c["tt"]), wv[5])),
        sub(mul(c["cf"], wv[4]), mul(c["sf"], wv[5])),
        _E(f"({text(add(mul(c['sf'], wv[4]), mul(c['cf'], wv[5])))}) / ct", "prod"),
    ]
    for k in range(3):
        w.put(f"out[{3 + k}]", add(euler[k], _vec(s, "VCN", s.current_ned, 3 + k)))

    ab = _mass_times_v(w, s)
    g = _restoring_terms(s, (neg(c["st"]), mul(c["ct"], c["sf"]), mul(c["ct"], c["cf"])))
    cor = _coriolis(ab)
    r: list[Ex] = []
    for k in range(6):
        e = add(add(neg(cor[k]), g[k]), _vec(s, "TAUC", s.cable, k))
        e = sub(e, _damping(s, k))
        if s.wrench:
            e = add(e, name(f"u[{k}]"))
        r.append(e)
    if s.n_thrusters:
        for k in range(6):
            w.put(f"r{k}", r[k])
        _thrust(w, s)
        r = [name(f"r{k}") for k in range(6)]
    _minv_times(w, s, [w.let(f"r{k}", r[k]) for k in range(6)])
    if s.lag:
        w.raw(f"for i in range({s.n_thrusters}):")
        w.raw(f"    out[12 + i] = (_saturate(u[i], {s.slot('NMAX')}) - x[12 + i]) * "
              f"{s.slot('INVTN')}")  # fmt: skip
    return w.lines


def _thrust(w: _Writer, s: Structure) -> None:
    """r += B T, T_i = K1 n_i |n_i| - K2 v_a,i |n_i|, eq. (7), thruster by thruster."""
    k1 = name(s.slot("K1")) if s.k1 else None
    k2 = name(s.slot("K2")) if s.k2 else None
    n, an = name("n"), name("an")
    for run in _runs(s):
        i, col, ind = _each_thruster(w, s, run, "")
        w.raw(f"{ind}n = {_rpm(s, i)}")
        w.raw(f"{ind}an = abs(n)")
        va = _inflow(w, s, col, ind)
        w.raw(f"{ind}T = {text(sub(mul(mul(k1, n), an), mul(mul(k2, va), an)))}")
        for k in range(6):
            if col(k) is not None:
                w.raw(f"{ind}r{k} += {text(col(k))} * T")


# ------------------------------------------------------------------------ df / dx
def _jac(s: Structure) -> list[str]:
    w = _Writer()
    w.lines += [
        "    for i in range(out.shape[0]):",
        "        for j in range(out.shape[1]):",
        "            out[i, j] = 0.0",
        *_TRIG,
        "    tt = st / ct",
        "    ict = 1.0 / ct",
        *_VELOCITIES,
    ]
    c = _C
    wv = _relative(w, s)
    _jac_kinematics(w, c, wv)
    _jac_restoring(w, s, c)
    ab = _mass_times_v(w, s)
    for j in range(6):
        _jac_velocity_column(w, s, ab, j)
    for run in _runs(s) if s.k2 else ():
        _jac_inflow(w, s, run)
    for run in _runs(s) if s.lag else ():
        i, col, ind = _each_thruster(w, s, run, "")
        _thrust_slope(w, s, col, ind, f"x[{_shift(12, i)}]", _shift(12, i))
        w.raw(f"{ind}out[{_shift(12, i)}, {_shift(12, i)}] = -{s.slot('INVTN')}")
    _minv_in_place(w, s, 3, "NX")
    return w.lines


def _jac_kinematics(w: _Writer, c: dict[str, _E], wv: list[Ex]) -> None:
    """d f_eta / d v = J(eta), eq. (17), and d f_eta / d eta, eq. (18)."""
    cf, sf, ct, st, cp, sp = (c[k] for k in ("cf", "sf", "ct", "st", "cp", "sp"))
    tt, ict = c["tt"], c["ict"]
    rot = _rotation(c)
    for k in range(3):
        for j in range(3):
            w.put(f"out[{k}, {6 + j}]", rot[k][j])
    w.put("out[3, 9]", name("1.0"))
    for target, e in (
        ("out[3, 10]", mul(sf, tt)), ("out[3, 11]", mul(cf, tt)), ("out[4, 10]", cf),
        ("out[4, 11]", neg(sf)), ("out[5, 10]", mul(sf, ict)), ("out[5, 11]", mul(cf, ict)),
    ):  # fmt: skip
        w.put(target, e)
    w0, w1, w2, _, w4, w5 = wv
    rows = {
        # d R / d phi
        "out[0, 3]": add(mul(add(mul(sp, sf), mul(mul(cp, cf), st)), w1),
                         mul(sub(mul(sp, cf), mul(mul(cp, sf), st)), w2)),
        "out[1, 3]": add(mul(add(mul(neg(cp), sf), mul(mul(cf, st), sp)), w1),
                         mul(sub(mul(neg(cp), cf), mul(mul(st, sp), sf)), w2)),
        "out[2, 3]": sub(mul(mul(ct, cf), w1), mul(mul(ct, sf), w2)),
        # d R / d theta
        "out[0, 4]": add(add(mul(mul(neg(cp), st), w0), mul(mul(mul(cp, ct), sf), w1)),
                         mul(mul(mul(cp, cf), ct), w2)),
        "out[1, 4]": add(add(mul(mul(neg(sp), st), w0), mul(mul(mul(sf, ct), sp), w1)),
                         mul(mul(mul(ct, sp), cf), w2)),
        "out[2, 4]": sub(sub(mul(neg(ct), w0), mul(mul(st, sf), w1)), mul(mul(st, cf), w2)),
        # d R / d psi
        "out[0, 5]": add(add(mul(mul(neg(sp), ct), w0),
                             mul(sub(mul(neg(cp), cf), mul(mul(sp, st), sf)), w1)),
                         mul(sub(mul(cp, sf), mul(mul(sp, cf), st)), w2)),
        "out[1, 5]": add(add(mul(mul(cp, ct), w0),
                             mul(add(mul(neg(sp), cf), mul(mul(sf, st), cp)), w1)),
                         mul(add(mul(sp, sf), mul(mul(st, cp), cf)), w2)),
        # d T / d phi
        "out[3, 3]": sub(mul(mul(cf, tt), w4), mul(mul(sf, tt), w5)),
        "out[4, 3]": sub(mul(neg(sf), w4), mul(cf, w5)),
        "out[5, 3]": mul(sub(mul(cf, w4), mul(sf, w5)), ict),
    }  # fmt: skip
    for target, e in rows.items():
        w.put(target, e)
    w.raw("ict2 = ict * ict")
    rate = add(mul(sf, w4), mul(cf, w5))
    w.put("out[3, 4]", mul(rate, name("ict2")))
    w.put("out[5, 4]", mul(mul(rate, st), name("ict2")))


def _jac_restoring(w: _Writer, s: Structure, c: dict[str, _E]) -> None:
    """d f_v / d eta = M^-1 d g / d eta, eq. (14): columns phi and theta."""
    cf, sf, ct, st = (c[k] for k in ("cf", "sf", "ct", "st"))
    for col, k in (
        (3, (None, mul(ct, cf), neg(mul(ct, sf)))),  # dk/dphi = (0, ct cf, -ct sf)
        (4, (neg(ct), mul(neg(st), sf), mul(neg(st), cf))),  # dk/dtheta
    ):
        for j, e in enumerate(_restoring_terms(s, k)):
            if e is not None:
                w.put(f"out[{6 + j}, {col}]", e)


def _jac_inflow(w: _Writer, s: Structure, run: _Run) -> None:
    """d tau / dv = -K2 B diag(|n|) B^T, eq. (16), added to the v rows."""
    i, col, ind = _each_thruster(w, s, run, "")
    w.raw(f"{ind}kn = -{s.slot('K2')} * abs({_rpm(s, i)})")
    for j in range(6):
        if col(j) is None:
            continue
        w.raw(f"{ind}sj = kn * {text(col(j))}")
        for k in range(6):
            if col(k) is not None:
                w.raw(f"{ind}out[{6 + k}, {6 + j}] += {text(col(k))} * sj")


def _thrust_slope(w: _Writer, s: Structure, col: Column, ind: str, rpm: str, column: str) -> None:
    """out[6:12, column] = B[:, i] dT_i/dn, dT/dn = 2 K1 |n| - K2 v_a sign(n) (M^-1
    applied later)."""
    w.raw(f"{ind}m = {rpm}")
    w.raw(f"{ind}sg = 1.0 if m > 0 else (-1.0 if m < 0 else 0.0)")
    k1 = name(s.slot("K1")) if s.k1 else None
    k2 = name(s.slot("K2")) if s.k2 else None
    va = _inflow(w, s, col, ind)
    slope = sub(mul(mul(name("2.0"), k1), name("abs(m)")), mul(mul(k2, va), name("sg")))
    w.raw(f"{ind}sl = {text(slope)}")
    for k in range(6):
        if col(k) is not None:
            w.raw(f"{ind}out[{6 + k}, {column}] = {text(col(k))} * sl")


# The derivative of C(v) v through the explicit v_lin / w factors (e_j x a, e_j x b):
# column j -> [(row, sign, "a"|"b", index)].
_EXTRA = {
    0: ((4, -1, 0, 2), (5, 1, 0, 1)),
    1: ((3, 1, 0, 2), (5, -1, 0, 0)),
    2: ((3, -1, 0, 1), (4, 1, 0, 0)),
    3: ((1, -1, 0, 2), (2, 1, 0, 1), (4, -1, 1, 2), (5, 1, 1, 1)),
    4: ((0, 1, 0, 2), (2, -1, 0, 0), (3, 1, 1, 2), (5, -1, 1, 0)),
    5: ((0, -1, 0, 1), (1, 1, 0, 0), (3, -1, 1, 1), (4, 1, 1, 0)),
}


def _jac_velocity_column(w: _Writer, s: Structure, ab: list[Ex], j: int) -> None:
    """Column j of d f_v / d v = -M^-1 (d(C v)/dv + D_l + diag(2 d_q |v|) + K2 B
    diag(|n|) B^T), eqs. (13) and (16)."""
    m = [_entry(s, "M", s.mass, r, j) for r in range(6)]
    d = _coriolis(m)  # C(v) applied to a column of M: the same cross products
    for row, sign, which, idx in _EXTRA[j]:
        term = ab[3 * which + idx]
        d[row] = add(d[row], term) if sign > 0 else sub(d[row], term)
    col = [sub(neg(d[k]), _entry(s, "DL", s.damping, k, j)) for k in range(6)]
    dq = _vec(s, "DQ", s.quadratic, j)
    col[j] = sub(col[j], mul(mul(name("2.0"), dq), name(f"abs({V[j].text})")))
    for k in range(6):
        if col[k] is not None:
            w.put(f"out[{6 + k}, {6 + j}]", col[k])


# ------------------------------------------------------------------------ df / du
def _jac_u(s: Structure) -> list[str]:
    w = _Writer()
    w.lines += [
        "    for i in range(out.shape[0]):",
        "        for j in range(out.shape[1]):",
        "            out[i, j] = 0.0",
    ]
    if s.wrench:  # df_v / dtau = M^-1
        for k in range(6):
            for j in range(6):
                if s.minv[k][j]:
                    w.put(f"out[{6 + k}, {j}]", _entry(s, "MINV", s.minv, k, j))
        return w.lines
    if s.lag:  # d n_i' / d u_i = 1/T_n on [-n_max, n_max]
        for i in range(s.n_thrusters):
            w.raw(f"if abs(u[{i}]) <= {s.slot('NMAX')}:")
            w.raw(f"    out[{12 + i}, {i}] = {s.slot('INVTN')}")
        return w.lines
    w.lines += _VELOCITIES
    for run in _runs(s):
        ti, col, ind = _each_thruster(w, s, run, "")
        w.raw(f"{ind}if abs(u[{ti}]) <= {s.slot('NMAX')}:")
        _thrust_slope(w, s, col, ind + "    ", f"u[{ti}]", ti)
    _minv_in_place(w, s, 0, "NU")
    return w.lines


# --------------------------------------------------------------- switching values
def _switch(s: Structure) -> list[str]:
    """The body velocities (|v| v), the rpm inside n |n|, u_i -+ n_max (saturation)."""
    nt = s.n_thrusters
    lines = [f"    out[{k}] = x[{6 + k}]" for k in range(6)]
    for i in range(nt):
        lines.append(f"    out[{6 + i}] = {f'x[{12 + i}]' if s.lag else f'u[{i}]'}")
        lines.append(f"    out[{6 + nt + i}] = u[{i}] - {s.slot('NMAX')}")
        lines.append(f"    out[{6 + 2 * nt + i}] = u[{i}] + {s.slot('NMAX')}")
    return lines


# ------------------------------------------------------------------------- module
_HEADER = '''\
# Generated by sampledyn (sampledyn.models._vehicle_codegen) for one sparsity pattern
# of the vehicle's parameters; the values are read from p. Do not edit.
import math

import numpy as np
from numba import njit

from sampledyn.models._base import BATCH_JAC_SIG, BATCH_RHS_SIG, JAC_SIG, RHS_SIG

CACHE = _SAMPLEDYN_CACHE
NX = {nx}
NU = {nu}


@njit(inline="always", error_model="numpy")
def _saturate(n, n_max):
    """min(max(n, -n_max), n_max), the thruster saturation (NaN stays NaN); as
    conditional expressions, which compile without branches."""
    m = n_max if n > n_max else n
    return -n_max if m < -n_max else m
'''

_FUNCTION = '''

@njit(cache=CACHE, error_model="numpy")
def {name}(t, x, u, p, out):
    """{doc}"""
{body}
'''

# f over a batch is f's body once more with every state, input and output indexed by
# the row (no per-row array views, whose reference counts cost more than a call);
# the Jacobians call theirs per row (half the compile time, and they are not what the
# studies spend their time in).
_BATCH_RHS = """

@njit(cache=CACHE, error_model="numpy")
def batch_rhs(t, x, u, p):
    rows = x.shape[0]
    out = np.empty((rows, NX))
    for row_ in range(rows):
{body}
    return out
"""

_BATCH = """

@njit(cache=CACHE, error_model="numpy")
def batch_{name}(t, x, u, p):
    rows = x.shape[0]
    out = np.empty((rows, {shape}))
    for row_ in range(rows):
        {name}(t[row_], x[row_], u[row_], p, out[row_])
    return out
"""


def _by_row(lines: list[str]) -> str:
    """f's body for row ``row_`` of batch arrays x, u, out."""
    return "\n".join("    " + re.sub(r"\b(x|u|out)\[", r"\1[row_, ", line) for line in lines)


_SIGNATURES = """

SIGNATURES = {
    "rhs": RHS_SIG,
    "jac": JAC_SIG,
    "jac_u": JAC_SIG,
    "sw": RHS_SIG,
    "batch_rhs": BATCH_RHS_SIG,
    "batch_jac": BATCH_JAC_SIG,
    "batch_jac_u": BATCH_JAC_SIG,
}
"""


def vehicle_source(s: Structure) -> str:
    """The generated module of pattern ``s``: ``rhs``, ``jac``, ``jac_u``, ``sw``
    (``f(t, x, u, p, out)``, the kernel signatures of :mod:`sampledyn.models._base`),
    ``batch_rhs``, ``batch_jac``, ``batch_jac_u`` over a batch, and ``SIGNATURES``."""
    parts = [_HEADER.format(nx=s.nx, nu=s.nu)]
    bodies = {"rhs": _rhs(s), "jac": _jac(s), "jac_u": _jac_u(s), "sw": _switch(s)}
    for fname, doc in (
        ("rhs", "x' = f(t, x, u; p), eqs. (3), (5)-(7)."),
        ("jac", "df/dx, eqs. (13)-(18)."),
        ("jac_u", "df/du."),
        ("sw", "Switching values: zero where f is not smooth."),
    ):
        parts.append(_FUNCTION.format(name=fname, doc=doc, body="\n".join(bodies[fname])))
    parts.append(_BATCH_RHS.format(body=_by_row(bodies["rhs"])))
    for fname, shape in (("jac", "NX, NX"), ("jac_u", "NX, NU")):
        parts.append(_BATCH.format(name=fname, shape=shape))
    parts.append(_SIGNATURES)
    return "".join(parts)
