"""Models from sympy expressions: one source, every derived kernel.

A user states the state, input and parameter symbols and the right-hand side
``x' = f(t, x, u; p)`` as sympy expressions. From that one source this module derives

* the compiled kernel ``rhs(t, x, u, p, out)`` that :func:`sampledyn.simulate` and every
  predictor call (the expressions as given: operations run in the order of the
  expression tree, so an expression built unevaluated, e.g. with
  ``parse_expr(..., evaluate=False)``, fixes the floating-point order bit for bit);
* the exact Jacobians ``df/dx`` and ``df/du`` (``sympy.diff``; the Dirac deltas of
  derivatives of ``sign`` and ``Heaviside`` are zero almost everywhere and dropped);
* the switching functions: the argument of every ``Abs``, ``sign`` and ``Heaviside``,
  the pairwise differences of the arguments of ``Max`` and ``Min``, and ``lhs - rhs``
  of every relation in a ``Piecewise`` condition. f is smooth between their zero
  crossings, and the exact simulator ends its internal steps on them;
* for the parameters that enter f linearly, ``f = Phi(t, x, u) theta + f0(t, x, u)``
  (:class:`~sampledyn.models._base.LinearForm`), used by :func:`sampledyn.estimate`.

The kernels are written as Python source by a sympy code printer into the kernel cache
(see :mod:`sampledyn.models._codegen`), keyed by a hash of that source, and compiled by
numba with the explicit kernel signatures and ``cache=True``: a second process loads
them from disk instead of compiling. Parameter values are not part of the code (they
travel in the array ``p``), so :meth:`SymbolicModel.with_params` never recompiles.
"""

from __future__ import annotations

import threading
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any

import numpy as np

from . import _closed_loop, _codegen, _jumps
from ._base import LinearForm, ParameterArrayModel, _as_batch, finite_number

__all__ = ["SymbolicModel"]

_LOCK = threading.RLock()


def _sympy() -> Any:
    import sympy  # imported here: `import sampledyn` must not pay for it

    return sympy


# --------------------------------------------------------------------------- checks
def _as_list(sp: Any, value: Any, argument: str) -> list[Any]:
    if isinstance(value, sp.MatrixBase):
        return list(value)
    if isinstance(value, str | bytes) or not isinstance(value, Iterable):
        raise TypeError(
            f"`{argument}` must be a sequence of sympy symbols or expressions, got "
            f"{type(value).__name__}."
        )
    return list(value)


def _symbols(sp: Any, value: Any, argument: str) -> tuple[Any, ...]:
    out = _as_list(sp, value, argument)
    for i, s in enumerate(out):
        if not isinstance(s, sp.Symbol):
            raise TypeError(
                f"`{argument}[{i}]` must be a sympy Symbol (e.g. sympy.Symbol('x')), got "
                f"{s!r} of type {type(s).__name__}."
            )
    return tuple(out)


def _check_unique(groups: Mapping[str, Sequence[Any]]) -> None:
    seen: dict[str, str] = {}
    for argument, symbols in groups.items():
        for s in symbols:
            if s.name in seen:
                where = seen[s.name]
                raise ValueError(
                    f"symbol name {s.name!r} appears twice (in `{where}` and in "
                    f"`{argument}`); every state, input, parameter and the time need "
                    "their own name."
                )
            seen[s.name] = argument


def _param_values(sp: Any, params: Any) -> tuple[tuple[Any, ...], tuple[float, ...]]:
    if params is None:
        return (), ()
    if not isinstance(params, Mapping):
        raise TypeError(
            "`params` must be a mapping {sympy Symbol: value}, e.g. {alpha: -0.1}, got "
            f"{type(params).__name__}."
        )
    symbols, values = [], []
    for s, v in params.items():
        if not isinstance(s, sp.Symbol):
            raise TypeError(f"`params` keys must be sympy Symbols, got {s!r} ({type(s).__name__}).")
        values.append(finite_number(v, f"params[{s.name}]"))
        symbols.append(s)
    return tuple(symbols), tuple(values)


def _names(value: Any, default: tuple[str, ...], argument: str) -> tuple[str, ...]:
    if value is None:
        return default
    if isinstance(value, str) or not isinstance(value, Iterable):
        raise TypeError(f"`{argument}` must be a sequence of {len(default)} strings.")
    out = tuple(value)
    if len(out) != len(default) or not all(isinstance(n, str) for n in out):
        raise ValueError(
            f"`{argument}` must be {len(default)} strings (one per symbol), got {out!r}."
        )
    return out


# ------------------------------------------------------------------------ printing
def _printer_class(sp: Any) -> Any:
    from sympy.printing.pycode import PythonCodePrinter

    class KernelPrinter(PythonCodePrinter):
        """Python source numba compiles: symbols as array reads, exact floats."""

        def __init__(self, names: Mapping[Any, str], hoisted: Mapping[Any, str]) -> None:
            super().__init__({"order": "none", "fully_qualified_modules": True, "strict": False})
            self._names = names
            self._hoisted = hoisted
            self.unsupported: list[Any] = []

        def _print(self, expr: Any, **kwargs: Any) -> str:
            name = self._hoisted.get(expr)
            if name is not None:
                return name
            return super()._print(expr, **kwargs)

        def _print_Symbol(self, expr: Any) -> str:
            try:
                return self._names[expr]
            except KeyError:  # caught earlier; defensive
                raise ValueError(f"undeclared symbol {expr} in a generated kernel.") from None

        _print_Dummy = _print_Symbol

        def _print_not_supported(self, expr: Any) -> str:
            self.unsupported.append(expr)
            return str(super()._print_not_supported(expr))

        def _print_Float(self, expr: Any) -> str:
            return repr(float(expr))

        def _print_Heaviside(self, expr: Any) -> str:
            arg = self._print(expr.args[0])
            h0 = expr.args[1] if len(expr.args) > 1 else sp.S.Half
            return f"(1.0 if {arg} > 0 else (0.0 if {arg} < 0 else {float(h0)!r}))"

        def _print_sign(self, expr: Any) -> str:
            arg = self._print(expr.args[0])
            return f"(1.0 if {arg} > 0 else (-1.0 if {arg} < 0 else 0.0))"

    return KernelPrinter


def _function_atoms(sp: Any, exprs: Sequence[Any]) -> list[Any]:
    """Applied functions (sin, Abs, ...) in the expressions, innermost first, each once,
    in a deterministic order (tree order, not hash order)."""
    seen: dict[Any, int] = {}
    for e in exprs:
        for node in sp.postorder_traversal(e):
            if isinstance(node, sp.Function) and not isinstance(node, sp.Piecewise):
                seen.setdefault(node, len(seen))
    return list(seen)


def _print_checked(printer: Any, expr: Any, where: str) -> str:
    printer.unsupported.clear()
    text = printer.doprint(expr)
    if printer.unsupported:
        bad = sorted({type(e).__name__ for e in printer.unsupported})
        raise ValueError(
            f"`{where}` uses {bad}, which sampledyn cannot compile (supported: arithmetic, "
            "powers, the functions of Python's math module, Abs, sign, Heaviside, Max, "
            "Min and Piecewise)."
        )
    return text


def _kernel(name: str, body: list[str]) -> str:
    lines = [
        "",
        "",
        '@njit(cache=CACHE, error_model="numpy")',
        f"def {name}(t, x, u, p, out):  # pragma: no cover - compiled",
    ]
    lines += ["    " + b for b in body] or ["    pass"]
    return "\n".join(lines)


def _rhs_body(sp: Any, printer_cls: Any, names: Mapping[Any, str], rhs: Sequence[Any]):
    """The rhs as given: applied functions computed once each (same values), the
    arithmetic printed in the order of the expression tree."""
    atoms = _function_atoms(sp, rhs)
    hoisted: dict[Any, str] = {}
    body = []
    for k, atom in enumerate(atoms):
        printer = printer_cls(names, hoisted)
        where = next(f"rhs[{i}]" for i, e in enumerate(rhs) if e.has(atom))
        body.append(f"_f{k} = {_print_checked(printer, atom, where)}")
        hoisted[atom] = f"_f{k}"
    printer = printer_cls(names, hoisted)
    for i, e in enumerate(rhs):
        body.append(f"out[{i}] = {_print_checked(printer, e, f'rhs[{i}]')}")
    return body


def _cse_body(
    sp: Any, printer_cls: Any, names: Mapping[Any, str], targets: list[tuple[str, Any]]
) -> list[str]:
    """Assignments ``target = expr`` with common subexpressions computed once."""
    exprs = [e for _, e in targets]
    if not exprs:
        return []
    temps = sp.numbered_symbols("_c", cls=sp.Dummy)
    replacements, reduced = sp.cse(exprs, symbols=temps)
    local = dict(names)
    body = []
    for k, (sym, e) in enumerate(replacements):
        printer = printer_cls(local, {})
        body.append(f"_c{k} = {_print_checked(printer, e, 'derived kernel')}")
        local[sym] = f"_c{k}"
    printer = printer_cls(local, {})
    for (target, _), e in zip(targets, reduced, strict=True):
        text = _print_checked(printer, e, "derived kernel")
        if e.is_number:
            text = repr(float(e))
        body.append(f"{target} = {text}")
    return body


# -------------------------------------------------------------------- derivation
def _switching(sp: Any, g: Any) -> Any:
    """A switching function in its one form up to sign (-g if sympy can extract a
    minus sign from g)."""
    g = sp.sympify(g)
    return -g if g.could_extract_minus_sign() else g


def _kinks(sp: Any, exprs: Sequence[Any], variables: set[Any]) -> tuple[list[Any], set[Any]]:
    """Switching functions of every non-smooth node, each once (up to sign), and
    those across which f may jump: the arguments of ``sign`` and ``Heaviside`` and
    the relations of ``Piecewise`` conditions (``Abs``, ``Max`` and ``Min`` are
    continuous: kinks only)."""
    found: dict[Any, None] = {}
    jumps: set[Any] = set()

    def add(g: Any, jump: bool) -> None:
        g = sp.sympify(g)
        if not (g.free_symbols & variables):
            return  # constant in time: never crosses
        g = _switching(sp, g)
        found.setdefault(g, None)
        if jump:
            jumps.add(g)

    def relations(cond: Any) -> None:
        if isinstance(cond, sp.core.relational.Relational):
            add(cond.lhs - cond.rhs, True)
        elif isinstance(cond, sp.logic.boolalg.BooleanFunction):
            for c in cond.args:
                relations(c)

    for e in exprs:
        for node in sp.preorder_traversal(e):
            if isinstance(node, sp.Piecewise):
                for _, cond in node.args:
                    relations(cond)
            else:
                for g, jump in _node_switching(sp, node):
                    add(g, jump)
    return list(found), jumps


def _node_switching(sp: Any, node: Any) -> list[tuple[Any, bool]]:
    """(switching function, f jumps across it) of one non-smooth node other than
    Piecewise: the argument of Abs (a kink), sign and Heaviside (jumps), the pairwise
    differences of the arguments of Max and Min (kinks)."""
    if isinstance(node, sp.Abs | sp.sign | sp.Heaviside):
        return [(node.args[0], not isinstance(node, sp.Abs))]
    if isinstance(node, sp.Max | sp.Min):
        a = node.args
        return [(a[i] - a[j], False) for i in range(len(a)) for j in range(i + 1, len(a))]
    return []


def _branches(sp: Any, e: Any, real: Mapping[Any, Any], sides: Mapping[Any, Any]) -> Any:
    """``e`` on one side of every jump: ``sign``, ``Heaviside`` and the relations of
    ``Piecewise`` conditions whose switching function g is a jump are replaced by the
    side symbol s of g (+-1): sign(+-g) = +-s, Heaviside(+-g) = (1 +- s)/2, g > 0 (or
    >=) is s > 0, g < 0 (or <=) is s < 0, g = 0 is false, g != 0 true. So the formula's
    value on the surface itself never enters a branch."""

    def side(a: Any) -> Any:
        g = sp.sympify(a).xreplace(real).doit()
        if g in sides:
            return sides[g]
        if -g in sides:
            return -sides[-g]
        return None

    def branch_sign(node: Any) -> Any:
        s = side(node.args[0])
        return node if s is None else s

    def branch_heaviside(node: Any) -> Any:
        s = side(node.args[0])
        return node if s is None else (1 + s) / 2

    def branch_relation(node: Any) -> Any:
        rel = sp.core.relational
        s = side(node.lhs - node.rhs)
        if s is None:
            return node
        if isinstance(node, rel.Equality):
            return sp.false
        if isinstance(node, rel.Unequality):
            return sp.true
        return s > 0 if isinstance(node, rel.GreaterThan | rel.StrictGreaterThan) else s < 0

    e = e.replace(lambda n: isinstance(n, sp.sign), branch_sign)
    e = e.replace(lambda n: isinstance(n, sp.Heaviside), branch_heaviside)
    return e.replace(lambda n: isinstance(n, sp.core.relational.Relational), branch_relation)


def _linear_params(sp: Any, f: Sequence[Any], params: Sequence[Any]) -> list[int]:
    """Indices of parameters that enter f linearly (jointly: no products of them)."""
    chosen: list[int] = []
    for k, th in enumerate(params):
        d1 = [sp.diff(e, th) for e in f]
        if all(d == 0 for d in d1):
            continue  # f does not depend on it
        if any(sp.diff(d, th) != 0 for d in d1):
            continue
        if any(sp.diff(d, params[j]) != 0 for d in d1 for j in chosen):
            continue
        chosen.append(k)
    return chosen


def _jump_kernels(
    sp: Any,
    printer: Any,
    names: dict[Any, str],
    real: Mapping[Any, Any],
    f_given: list[Any],
    kinks: list[Any],
    jumps: tuple[int, ...],
    xs: list[Any],
    us: list[Any],
    time: Any,
    n_p: int,
) -> tuple[list[str], list[str]]:
    """The kernels of a model with jumps (see :mod:`sampledyn.models._jumps`): the
    branch kernel (the sides read from ``p[NP + j]``), the gradients of the switching
    functions (rows dg/dx, dg/dt, dg/du) and f, the branch of the sides the state is
    on, with the Filippov selection on a surface (the second list: after ``sw``)."""
    sides = {}
    for j, k in enumerate(jumps):
        s = sp.Dummy(f"side{j}", real=True)
        names[s] = f"p[{n_p + j}]"
        sides[kinks[k]] = s
    branch = [_branches(sp, e, real, sides) for e in f_given]
    t_real = real[time] if time is not None else None
    grad = [
        [sp.diff(g, x) for x in xs]
        + [sp.diff(g, t_real) if t_real is not None else sp.S.Zero]
        + [sp.diff(g, u) for u in us]
        for g in kinks
    ]
    grad = [[e.replace(sp.DiracDelta, lambda *a: sp.S.Zero) for e in row] for row in grad]
    targets = [(f"out[{i}, {j}]", e) for i, row in enumerate(grad) for j, e in enumerate(row)]
    imports = [
        _codegen.object_import_line(_jumps.__name__, name, name)
        for name in ("decide", "sliding_weight")
    ]
    imports.append(
        _codegen.object_import_line(_closed_loop.__name__, "stack_buffer", "stack_buffer")
    )
    kernels = [
        _kernel("branch", _rhs_body(sp, printer, names, branch)),
        _kernel("swjac", _cse_body(sp, printer, names, targets)),
    ]
    tail = [
        "\n\n" + "\n".join(str(line) for line in imports),
        "_branch_k = branch\n_switch_k = sw\n_switch_grad_k = swjac",
        _jumps.surface_source(jumps, len(kinks), n_p),
    ]
    return kernels, tail


@dataclass
class _Code:
    """Everything derived from the expressions; shared by ``with_params`` copies."""

    source: str
    nx: int
    nu: int
    n_params: int
    switch_input_only: tuple[bool, ...]
    kink_states: tuple[int, ...]
    kink_inputs: tuple[int, ...]
    jumps: tuple[int, ...]  # switching values across which f jumps
    jump_inputs: tuple[bool, ...]  # per jump: its switching function depends on u
    linear: tuple[int, ...]
    expressions: dict[str, Any]  # sympy objects, for users
    module: ModuleType | None = field(default=None, repr=False)

    def load(self) -> ModuleType:
        if self.module is None:
            with _LOCK:
                if self.module is None:
                    module = _codegen.load_module(self.source, kind="symbolic")
                    for name in ("rhs", "jac", "jac_u", "reg", "reg0"):
                        _codegen.register_batch(getattr(module, name), module, f"batch_{name}")
                    self.module = module
        return self.module

    def kernel(self, name: str) -> Any:
        return _codegen.compiled(self.load(), name)

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state["module"] = None  # reloaded from the source in the other process
        return state


_HEADER = """# Generated by sampledyn.models.SymbolicModel; do not edit (the file name is the
# hash of this text).
import math

import numpy as np
from numba import njit

from sampledyn.models._base import BATCH_JAC_SIG, BATCH_RHS_SIG, JAC_SIG, RHS_SIG

CACHE = _SAMPLEDYN_CACHE
"""

_DERIVED: dict[Any, _Code] = {}


def derive(
    states: Any, inputs: Any, rhs: Any, params: Any, time: Any
) -> tuple[_Code, tuple[Any, ...], tuple[float, ...]]:
    """Check the arguments of :class:`SymbolicModel` and derive (or reuse) its code.

    Returns the code, the parameter symbols and their values.
    """
    sp = _sympy()
    states = _symbols(sp, states, "states")
    inputs = _symbols(sp, inputs, "inputs")
    if not states:
        raise ValueError("`states` is empty: a model needs at least one state.")
    if time is not None and not isinstance(time, sp.Symbol):
        raise TypeError(f"`time` must be a sympy Symbol or None, got {time!r}.")
    p_syms, p_vals = _param_values(sp, params)
    _check_unique(
        {
            "states": states,
            "inputs": inputs,
            "params": p_syms,
            "time": () if time is None else (time,),
        }
    )
    exprs = _as_list(sp, rhs, "rhs")
    if len(exprs) != len(states):
        raise ValueError(
            f"`rhs` has {len(exprs)} expressions for {len(states)} states; give one "
            "derivative per state, in the order of `states`."
        )
    f_given = []
    for i, e in enumerate(exprs):
        if isinstance(e, str):
            raise TypeError(
                f"`rhs[{i}]` is a string; build it from the symbols (or parse it with "
                "sympy.parse_expr) so that every symbol is declared."
            )
        try:
            e = sp.sympify(e, strict=True)
        except sp.SympifyError:
            raise TypeError(
                f"`rhs[{i}]` must be a sympy expression or a number, got {e!r}."
            ) from None
        if not isinstance(e, sp.Expr):
            raise TypeError(f"`rhs[{i}]` must be a scalar sympy expression, got {e!r}.")
        f_given.append(e)
    declared = set(states) | set(inputs) | set(p_syms) | ({time} if time is not None else set())
    for i, e in enumerate(f_given):
        extra = e.free_symbols - declared
        if extra:
            names = sorted(s.name for s in extra)
            raise ValueError(
                f"`rhs[{i}]` uses undeclared symbol(s) {names}; declare each as a state, an "
                "input, a parameter with its value in `params`, or the time (`time=`)."
            )
        bad = [type(a).__name__ for a in e.atoms(sp.Derivative, sp.Integral)]
        bad += [type(a).__name__ for a in e.atoms(sp.core.function.AppliedUndef)]
        if bad:
            raise ValueError(
                f"`rhs[{i}]` contains {sorted(set(bad))}; f must be an explicit expression "
                "of the time, states, inputs and parameters."
            )
        if e.has(sp.I) or e.has(sp.zoo) or e.has(sp.nan):
            raise ValueError(f"`rhs[{i}]` is not a real finite expression: {e}.")

    # The key keeps the order of unevaluated arguments (it is the order of evaluation).
    key = (states, inputs, p_syms, time, tuple(sp.srepr(e, order="none") for e in f_given))
    with _LOCK:
        code = _DERIVED.get(key)
        if code is None:
            code = _build(sp, states, inputs, p_syms, time, f_given)
            _DERIVED[key] = code
    return code, p_syms, p_vals


def _build(
    sp: Any,
    states: tuple[Any, ...],
    inputs: tuple[Any, ...],
    params: tuple[Any, ...],
    time: Any,
    f_given: list[Any],
) -> _Code:
    nx, nu, n_p = len(states), len(inputs), len(params)
    # Derivations use real symbols (d|y|/dy = sign(y) only for real y); the printed
    # rhs keeps the user's symbols and order.
    real = {s: sp.Symbol(s.name, real=True) for s in (*states, *inputs, *params)}
    if time is not None:
        real[time] = sp.Symbol(time.name, real=True)
    xs = [real[s] for s in states]
    us = [real[s] for s in inputs]
    ps = [real[s] for s in params]
    f = [e.xreplace(real).doit() for e in f_given]

    def no_delta(e: Any) -> Any:
        return e.replace(sp.DiracDelta, lambda *a: sp.S.Zero)

    jac = [[no_delta(sp.diff(e, x)) for x in xs] for e in f]
    jac_u = [[no_delta(sp.diff(e, u)) for u in us] for e in f]
    variables = set(xs) | set(us) | ({real[time]} if time is not None else set())
    kinks, jump_set = _kinks(sp, f, variables)
    # A jump that depends on no state is a jump of the input only: f(t, x, u(t))
    # then jumps in time, which integrating across the located instant handles (a
    # kink of the integrand); only surfaces in the state need branches.
    jumps = tuple(k for k, g in enumerate(kinks) if g in jump_set and g.free_symbols & set(xs))
    input_only = tuple(bool(g.free_symbols & variables <= set(us)) for g in kinks)
    kink_states = tuple(i for i, x in enumerate(xs) if x in kinks)
    kink_inputs = tuple(j for j, u in enumerate(us) if u in kinks)
    linear = _linear_params(sp, f, ps)
    reg = [[sp.diff(e, ps[k]) for k in linear] for e in f]
    reg0 = [e.xreplace({ps[k]: 0 for k in linear}) for e in f]

    names: dict[Any, str] = {}
    for group, arr in ((states, "x"), (inputs, "u"), (params, "p")):
        for i, s in enumerate(group):
            names[s] = names[real[s]] = f"{arr}[{i}]"
    if time is not None:
        names[time] = names[real[time]] = "t"
    printer = _printer_class(sp)

    def matrix(rows: list[list[Any]]) -> list[tuple[str, Any]]:
        return [(f"out[{i}, {j}]", e) for i, row in enumerate(rows) for j, e in enumerate(row)]

    if jumps:
        rhs_parts, tail = _jump_kernels(
            sp, printer, names, real, f_given, kinks, jumps, xs, us, time, n_p
        )
    else:
        rhs_parts, tail = [_kernel("rhs", _rhs_body(sp, printer, names, f_given))], []
    parts = [
        _HEADER,
        f"NX = {nx}\nNU = {nu}\nNP = {n_p}\nNSW = {len(kinks)}\nNLIN = {len(linear)}",
        *rhs_parts,
        _kernel("jac", _cse_body(sp, printer, names, matrix(jac))),
        _kernel("jac_u", _cse_body(sp, printer, names, matrix(jac_u))),
        _kernel(
            "sw", _cse_body(sp, printer, names, [(f"out[{k}]", g) for k, g in enumerate(kinks)])
        ),
        _kernel("reg", _cse_body(sp, printer, names, matrix(reg))),
        _kernel(
            "reg0", _cse_body(sp, printer, names, [(f"out[{i}]", e) for i, e in enumerate(reg0)])
        ),
        *tail,
    ]
    for name, shape in (
        ("rhs", "NX"),
        ("jac", "NX, NX"),
        ("jac_u", "NX, NU"),
        ("reg", "NX, NLIN"),
        ("reg0", "NX"),
    ):
        parts.append(_codegen.BATCH_TEMPLATE.format(name=name, kernel=name, shape=shape))
    parts.append(
        "\nSIGNATURES = {\n"
        '    "rhs": RHS_SIG,\n    "jac": JAC_SIG,\n    "jac_u": JAC_SIG,\n    "sw": RHS_SIG,\n'
        '    "reg": JAC_SIG,\n    "reg0": RHS_SIG,\n    "batch_rhs": BATCH_RHS_SIG,\n'
        '    "batch_jac": BATCH_JAC_SIG,\n    "batch_jac_u": BATCH_JAC_SIG,\n'
        '    "batch_reg": BATCH_JAC_SIG,\n    "batch_reg0": BATCH_RHS_SIG,\n'
        + ('    "branch": RHS_SIG,\n    "swjac": JAC_SIG,\n' if jumps else "")
        + "}\n"
    )
    source = "\n".join(parts)
    expressions = {
        "rhs": tuple(f_given),
        "jacobian": sp.Matrix(jac) if nx else sp.Matrix(),
        "input_jacobian": sp.Matrix(nx, nu, [e for row in jac_u for e in row]),
        "kinks": tuple(kinks),
        "jumps": tuple(kinks[k] for k in jumps),
        "linear_params": tuple(params[k] for k in linear),
        # the symbols of f(t, x, u; p), in the order of t, x, u and the parameter array
        "states": tuple(states),
        "inputs": tuple(inputs),
        "params": tuple(params),
        "time": time,
    }
    return _Code(
        source=source,
        nx=nx,
        nu=nu,
        n_params=n_p,
        switch_input_only=input_only,
        kink_states=kink_states,
        kink_inputs=kink_inputs,
        jumps=jumps,
        jump_inputs=tuple(bool(kinks[k].free_symbols & set(us)) for k in jumps),
        linear=tuple(linear),
        expressions=expressions,
    )


# --------------------------------------------------------------------------- model
class SymbolicModel(ParameterArrayModel):
    """A model ``x' = f(t, x, u; p)`` given as sympy expressions.

    Parameters
    ----------
    states : sequence of sympy.Symbol, length nx
        State symbols, in the order of the state vector.
    inputs : sequence of sympy.Symbol, length nu
        Input symbols.
    rhs : sequence of sympy expressions, length nx
        ``f``: the derivative of each state. May use the states, inputs, parameters and
        the time symbol, numbers, arithmetic and powers, the functions of Python's
        ``math`` module (sin, exp, sqrt, atan2, ...), ``Abs``, ``sign``, ``Heaviside``,
        ``Max``, ``Min`` and ``Piecewise``.
    params : mapping {sympy.Symbol: float}, optional
        Parameter symbols and their values (units in ``param_units``). Values travel in
        an array at run time: :meth:`with_params` changes them without recompiling.
    time : sympy.Symbol, optional
        The time symbol, if f depends on time explicitly.
    state_names, input_names : sequence of str, optional
        Default: the symbol names.
    state_units, input_units : sequence of str, optional
        Default: "" (unspecified).
    param_units : mapping {name: str}, optional
        Units of parameters, by symbol name.
    param_bounds : mapping {Symbol or name: (lo, hi)}, optional
        Physical bounds of parameters (e.g. ``{c: (0, math.inf)}`` for a damping): an
        estimate outside them is flagged (:attr:`EstimationResult.flags`).
    x0 : array_like, shape (nx,), optional
        Default initial state of :func:`sampledyn.simulate`. Default zeros: choose one
        that is not an equilibrium if the model should move without input.
    name : str
        Label.

    Raises
    ------
    TypeError
        A state or input that is not a Symbol, an ``rhs`` entry that is not an
        expression, ``params`` that is not a mapping of Symbols.
    ValueError
        ``rhs`` of the wrong length, undeclared symbols in ``rhs`` (the message names
        them), a parameter without a finite value, duplicate symbol names, functions
        that cannot be compiled, names or units of the wrong length.

    Notes
    -----
    Derived objects: :attr:`expressions` (``rhs``, ``jacobian``, ``input_jacobian``,
    ``kinks``, ``linear_params``), the kernels (:meth:`kernel`,
    :meth:`jacobian_kernel`, :meth:`input_jacobian_kernel`, :meth:`switch_kernel`),
    :meth:`regressors`, and :attr:`kink_states` / :attr:`kink_inputs` (the states and
    inputs that are themselves switching functions, e.g. y in y|y|).

    Examples
    --------
    >>> import sympy as sp
    >>> x, v, u, c = sp.symbols("x v u c")
    >>> m = SymbolicModel([x, v], [u], [v, -c * v * sp.Abs(v) + u], params={c: 0.5})
    >>> m.expressions["kinks"]
    (v,)
    """

    def __init__(
        self,
        states: Any,
        inputs: Any,
        rhs: Any,
        params: Mapping[Any, float] | None = None,
        *,
        time: Any = None,
        state_names: Sequence[str] | None = None,
        state_units: Sequence[str] | None = None,
        input_names: Sequence[str] | None = None,
        input_units: Sequence[str] | None = None,
        param_units: Mapping[str, str] | None = None,
        param_bounds: Mapping[Any, Any] | None = None,
        x0: Any = None,
        name: str = "symbolic model",
    ) -> None:
        code, p_syms, p_vals = derive(states, inputs, rhs, params, time)
        st = tuple(s.name for s in _symbols(_sympy(), states, "states"))
        it = tuple(s.name for s in _symbols(_sympy(), inputs, "inputs"))
        self._code = code
        self._kernels: dict[str, Any] = {}  # compiled kernels by name (memo)
        self.nx = code.nx
        self.nu = code.nu
        self.state_names = _names(state_names, st, "state_names")
        self.state_units = _names(state_units, ("",) * code.nx, "state_units")
        self.input_names = _names(input_names, it, "input_names")
        self.input_units = _names(input_units, ("",) * code.nu, "input_units")
        names = tuple(s.name for s in p_syms)
        self._set_params(names, p_vals, param_units, x0, code.nx)
        self._set_bounds(param_bounds)
        self.name = str(name)

    # ----------------------------------------------------------------- attributes
    @property
    def expressions(self) -> dict[str, Any]:
        """The sympy objects: ``rhs`` (as given), ``jacobian`` (nx x nx Matrix),
        ``input_jacobian`` (nx x nu), ``kinks`` (switching functions),
        ``linear_params`` (the parameters :meth:`regressors` is linear in), and the
        symbols ``states``, ``inputs``, ``params`` (in the order of the parameter
        array) and ``time`` (or None)."""
        return dict(self._code.expressions)

    @property
    def kink_states(self) -> tuple[int, ...]:
        """States that are switching functions themselves (e.g. y in y|y|)."""
        return self._code.kink_states

    @property
    def kink_inputs(self) -> tuple[int, ...]:
        """Inputs that are switching functions themselves."""
        return self._code.kink_inputs

    @property
    def source_file(self) -> str:
        """Path of the generated kernel module in the kernel cache."""
        return str(self._code.load().__file__)

    def __repr__(self) -> str:
        return (
            f"SymbolicModel(name={self.name!r}, states={list(self.state_names)}, "
            f"inputs={list(self.input_names)}, params={self.params})"
        )

    # -------------------------------------------------------------------- kernels
    def _kernel(self, name: str) -> Any:
        k = self._kernels.get(name)
        if k is None:
            k = self._kernels[name] = self._code.kernel(name)
        return k

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state["_kernels"] = {}
        return state

    def kernel(self) -> tuple[Any, np.ndarray]:
        return self._kernel("rhs"), self._p

    def jacobian_kernel(self) -> tuple[Any, np.ndarray]:
        return self._kernel("jac"), self._p

    def input_jacobian_kernel(self) -> tuple[Any, np.ndarray]:
        return self._kernel("jac_u"), self._p

    def switch_kernel(self) -> tuple[Any, np.ndarray, np.ndarray]:
        """Switching functions of every ``Abs``, ``sign``, ``Heaviside``, ``Max``,
        ``Min`` and ``Piecewise`` in f (see :attr:`expressions` ``["kinks"]``)."""
        input_only = np.array(self._code.switch_input_only, dtype=np.bool_)
        return self._kernel("sw"), self._p, input_only

    def jump_kernel(self) -> tuple[Any, Any, np.ndarray, np.ndarray] | None:
        """The kernels of f's jumps for :func:`sampledyn.simulate`, or None if f has
        none (see :mod:`sampledyn.models._jumps`).

        Returns
        -------
        (branch, grad, q, sw_info)
            The branch kernel, the gradient kernel of the switching functions
            (out shape (n_sw, nx + 1 + nu)), a writable copy of the parameters with
            one side (+1) per jump appended, and ``sw_info`` (n_sw, 2) int: the
            position of each switching value's side in q (-1: a kink) and 1 where a
            jump's switching function depends on the input.
        """
        code = self._code
        if not code.jumps:
            return None
        n_sw = len(code.switch_input_only)
        info = np.full((n_sw, 2), -1, dtype=np.int64)
        info[:, 1] = 0
        for j, k in enumerate(code.jumps):
            info[k] = (self._p.size + j, int(code.jump_inputs[j]))
        q = np.concatenate([self._p, np.ones(len(code.jumps))])
        return self._kernel("branch"), self._kernel("swjac"), q, info

    def switching_names(self) -> tuple[str, ...]:
        """The switching functions as text, in the order of :meth:`switch_kernel`."""
        return tuple(str(g) for g in self._code.expressions["kinks"])

    def regressors(self, t: Any, x: Any, u: Any) -> LinearForm:
        """``f = Phi @ theta + f0`` for the parameters f is linear in.

        theta is :attr:`expressions` ``["linear_params"]`` (declared order); Phi is
        df/dtheta and f0 is f with those parameters set to zero.

        Returns
        -------
        LinearForm with ``phi`` of shape (N, nx, n_theta) and ``f0`` of shape (N, nx).

        Raises
        ------
        NotImplementedError
            If no parameter enters f linearly (:func:`sampledyn.estimate` then fits
            the parameters by nonlinear least squares).
        """
        if not self._code.linear:
            raise NotImplementedError(f"no parameter of {self.name!r} enters f linearly.")
        names = tuple(self._param_names[k] for k in self._code.linear)
        n_lin = len(names)
        phi = self._matrix(self._kernel("reg"), "reg", self._p, t, x, u, n_lin)
        reg0 = self._kernel("reg0")
        f0 = self._matrix_rhs(reg0, t, x, u)
        phi = np.asarray(phi).reshape(-1, self.nx, n_lin)
        f0 = np.asarray(f0).reshape(-1, self.nx)
        units = tuple(self.param_units[n] for n in names)
        return LinearForm(names, units, phi, f0)

    def _matrix_rhs(self, kernel: Any, t: Any, x: Any, u: Any) -> np.ndarray:
        tt, xx, uu, _ = _as_batch(t, x, u, self.nx, self.nu)
        batch = _codegen.batch_functions(kernel, None)
        return batch(tt, xx, uu, self._p)

    def jacobian(self, t: Any, x: Any, u: Any) -> np.ndarray:
        """Exact ``df/dx`` (``sympy.diff`` of f), shape (N, nx, nx) (or (nx, nx)).

        Where f jumps (``sign``, ``Heaviside``, ``Piecewise`` of a state) this is the
        Jacobian of the branch of the side the state is on (the Dirac deltas of the
        jump dropped): across the switching surface f has no Jacobian, and a
        linearisation on it is refused (:meth:`sampledyn.discretize.DiscreteModel.linearize`).
        """
        return super().jacobian(t, x, u)

    def input_jacobian(self, t: Any, x: Any, u: Any) -> np.ndarray:
        """Exact ``df/du``, shape (N, nx, nu) (or (nx, nu))."""
        return super().input_jacobian(t, x, u)
