"""CasADi expressions of the models and of the discrete-time models built on them.

One source of truth per model, no second hand-written copy:

* symbolic models (:class:`~sampledyn.models.SymbolicModel`, and the AUV-like system,
  which is one): the sympy expressions the compiled kernels are printed from, turned
  into CasADi by ``sympy.lambdify`` with CasADi's functions;
* compiled hand-written kernels (the built-in :class:`~sampledyn.models.Vehicle`, the
  linear feedback of a :class:`~sampledyn.models.ClosedLoop`): the kernel's own Python
  source (``kernel.py_func``, the text numba compiles) run once on CasADi symbols,
  with ``math`` mapped to CasADi and the one data-dependent branch of the vehicle
  kernel, the thruster saturation ``_saturate``, written as ``fmin(fmax(n, -n_max),
  n_max)``. A kernel that branches on a state or input elsewhere is refused with the
  branch named. Nothing is transcribed, so the CasADi function cannot drift from the
  kernel; a test compares both to 1e-12 at random states, saturated inputs included;
* closed loops: the plant's expression at the law's output.

Why not a ``casadi.Callback`` around the compiled kernel: an MPC solver (IPOPT) then
sees a black box without second derivatives and pays a Python call per evaluation;
CasADi expressions give it exact, sparse first and second derivatives.
"""

from __future__ import annotations

import functools
import math
import types
from typing import Any

import numpy as np

from ..models import Model, SymbolicModel

__all__ = ["casadi_rhs", "discrete_function"]


def _casadi() -> Any:
    try:
        import casadi
    except ImportError as exc:  # pragma: no cover - the test extra installs it
        raise ImportError("to_casadi needs CasADi: pip install 'sampledyn[control]'.") from exc
    return casadi


def _math_namespace(ca: Any) -> types.SimpleNamespace:
    return types.SimpleNamespace(
        sin=ca.sin, cos=ca.cos, tan=ca.tan, asin=ca.asin, acos=ca.acos, atan=ca.atan,
        atan2=ca.atan2, sinh=ca.sinh, cosh=ca.cosh, tanh=ca.tanh, exp=ca.exp, log=ca.log,
        sqrt=ca.sqrt, fabs=ca.fabs, floor=ca.floor, ceil=ca.ceil, pi=math.pi, e=math.e,
        copysign=lambda a, b: ca.fabs(a) * ca.sign(b), isnan=lambda a: False,
    )  # fmt: skip


# Data-dependent branches of built-in kernels, by the name of the helper (see the
# module docstring); each is checked against the compiled kernel by the tests.
def _overrides(ca: Any) -> dict[str, Any]:
    return {"_saturate": lambda n, n_max: ca.fmin(ca.fmax(n, -n_max), n_max)}


def _rebound(py_func: Any, ca: Any, memo: dict[int, Any]) -> Any:
    """``py_func`` with its globals re-bound for CasADi symbols (numba helpers it calls
    re-bound the same way, ``math`` -> CasADi)."""
    key = id(py_func)
    if key in memo:
        return memo[key]
    g = dict(py_func.__globals__)
    g["math"] = _math_namespace(ca)
    overrides = _overrides(ca)
    for name, value in py_func.__globals__.items():
        if name in overrides:
            g[name] = overrides[name]
        elif hasattr(value, "py_func") and callable(value):
            g[name] = _LazyRebound(value.py_func, ca, memo)
    fn = types.FunctionType(
        py_func.__code__, g, py_func.__name__, py_func.__defaults__, py_func.__closure__
    )
    memo[key] = fn
    return fn


class _LazyRebound:
    """A numba helper re-bound on its first call (most globals are never called)."""

    def __init__(self, py_func: Any, ca: Any, memo: dict[int, Any]) -> None:
        self.py_func, self.ca, self.memo = py_func, ca, memo

    def __call__(self, *args: Any) -> Any:
        return _rebound(self.py_func, self.ca, self.memo)(*args)


class _Buffer(list):
    """The kernel's ``out`` argument: a list of expressions that has a ``shape``."""

    @property
    def shape(self) -> tuple[int]:
        return (len(self),)


def _run_kernel(kernel: Any, p: Any, t: Any, x: Any, u: Any, n_out: int) -> Any:
    """``kernel(t, x, u, p, out)`` run on CasADi symbols; returns out as a column."""
    ca = _casadi()
    py_func = getattr(kernel, "py_func", None)
    if py_func is None:
        raise TypeError(f"{kernel!r} is not a numba kernel with Python source (py_func).")
    fn = _rebound(py_func, ca, {})
    out = _Buffer([ca.SX(0.0)] * n_out if isinstance(x, ca.SX) else [ca.MX(0.0)] * n_out)
    plist = [float(v) for v in np.asarray(p, dtype=float)]
    xs = [x[i] for i in range(x.shape[0])]
    us = [u[i] for i in range(u.shape[0])]
    try:
        fn(t, xs, us, plist, out)
    except RuntimeError as exc:
        if "bool" in str(exc) or "truth" in str(exc).lower() or "symbolic" in str(exc):
            raise ValueError(
                f"kernel {py_func.__qualname__} branches on a state or input (an `if` or "
                "`min`/`max` on them), which CasADi symbols cannot take; give the model as "
                f"a sampledyn.models.SymbolicModel instead. ({exc})"
            ) from None
        raise
    return ca.vertcat(*out)


def _sympy_rhs(model: SymbolicModel, x: Any, u: Any) -> Any:
    """CasADi expression of a symbolic model's f at the model's parameter values."""
    import sympy as sp

    ca = _casadi()
    e = model.expressions
    if e.get("time") is not None:
        raise ValueError(
            f"{model.name!r} depends on time explicitly; to_casadi supports "
            "time-invariant models (F(z, u))."
        )
    values = model.params
    subs = {s: values[s.name] for s in e["params"]}
    rhs = [_branching_calls(sp, sp.sympify(r).subs(subs)) for r in e["rhs"]]

    def fmax(*a: Any) -> Any:
        return functools.reduce(ca.fmax, a)

    def fmin(*a: Any) -> Any:
        return functools.reduce(ca.fmin, a)

    def heaviside(a: Any, h0: Any = 0.5) -> Any:
        return ca.if_else(a > 0, 1.0, ca.if_else(a < 0, 0.0, h0))

    names = {
        "Abs": ca.fabs, "abs": ca.fabs, "sign": ca.sign, "Heaviside": heaviside,
        "Max": fmax, "Min": fmin, "max": fmax, "min": fmin,
        "_IfElse": ca.if_else, "_And": _fold(ca.logic_and), "_Or": _fold(ca.logic_or),
        "_Not": ca.logic_not,
    }  # fmt: skip
    fn = sp.lambdify([*e["states"], *e["inputs"]], rhs, modules=[names, ca])
    out = fn(*[x[i] for i in range(x.shape[0])], *[u[i] for i in range(u.shape[0])])
    return ca.vertcat(*[ca.SX(v) if isinstance(v, int | float) else v for v in out])


def _fold(op: Any) -> Any:
    def fold(*a: Any) -> Any:
        return functools.reduce(op, a)

    return fold


def _branching_calls(sp: Any, e: Any) -> Any:
    """``e`` with every ``Piecewise`` as nested ``_IfElse(cond, then, else)`` calls and
    its logic as ``_And``/``_Or``/``_Not`` calls, which the CasADi namespace maps to
    ``casadi.if_else`` and ``casadi.logic_*``: Python's ``if`` and ``and`` cannot take
    CasADi symbols. A Piecewise without a True branch is NaN where no condition holds
    (as sympy's)."""
    names = {sp.And: "_And", sp.Or: "_Or", sp.Not: "_Not"}

    def logic(c: Any) -> Any:
        if c is sp.true or c is sp.false:
            return sp.Integer(1 if c is sp.true else 0)
        for kind, name in names.items():
            if isinstance(c, kind):
                return sp.Function(name)(*[logic(a) for a in c.args])
        return c

    def piecewise(node: Any) -> Any:
        out = sp.nan
        for value, cond in reversed(node.args):
            out = value if cond is sp.true else sp.Function("_IfElse")(logic(cond), value, out)
        return out

    return e.replace(lambda n: isinstance(n, sp.Piecewise), piecewise)


def _rhs_expression(model: Model, x: Any, u: Any) -> Any:
    symbolic = getattr(model, "symbolic", None)  # AUVLike: a SymbolicModel inside
    if isinstance(symbolic, SymbolicModel):
        return _sympy_rhs(symbolic, x, u)
    if isinstance(model, SymbolicModel):
        return _sympy_rhs(model, x, u)
    plant, law = getattr(model, "plant", None), getattr(model, "law", None)
    if plant is not None and law is not None:  # ClosedLoop: f(x, kappa(x, r))
        kernel, q = law.kernel()
        applied = _run_kernel(kernel, q, 0.0, x, u, int(law.nu))
        return _rhs_expression(plant, x, applied)
    kernel, p = model.kernel()
    return _run_kernel(kernel, p, 0.0, x, u, int(model.nx))


def casadi_rhs(model: Model) -> Any:
    """``casadi.Function`` f(x, u) -> x' of a continuous-time model (SX).

    Supported: symbolic models (from their sympy expressions: ``Piecewise`` as
    ``casadi.if_else``, ``sign`` and ``Heaviside`` with their values at zero as the
    formula gives them), the AUV-like system,
    vehicles and other hand-written kernels without branches on x or u (from the
    kernel's own source), closed loops of those with a linear feedback.

    Raises
    ------
    ValueError
        for a time-varying symbolic model, or a kernel that branches on a state or
        input (named).
    """
    ca = _casadi()
    x = ca.SX.sym("x", int(model.nx))
    u = ca.SX.sym("u", int(model.nu))
    return ca.Function("f", [x, u], [_rhs_expression(model, x, u)], ["x", "u"], ["xdot"])


class _Solvers:
    """What a rule's vector step may ask of CasADi: the root of an implicit stage
    (Newton ``rootfinder``, MX) and the exact flow over one interval (``integrator``,
    CVODES)."""

    def __init__(self, ca: Any, dm: Any, f: Any, z: Any, u: Any) -> None:
        self.ca, self.dm, self.f, self.z, self.u = ca, dm, f, z, u

    def implicit(self, residual: Any, guess: Any) -> Any:
        ca, nx = self.ca, self.dm.nx
        x1 = ca.MX.sym("x1", nx)
        g = ca.Function("residual", [x1, self.z, self.u], [residual(x1)])
        solver = ca.rootfinder(
            f"{self.dm.method.name}_newton", "newton", g, {"abstol": 1e-14, "max_iter": 50}
        )
        return solver(guess, self.z, self.u)

    def flow(self, x0: Any, u: Any, h: float) -> Any:
        ca, dm = self.ca, self.dm
        x = ca.MX.sym("x", dm.nx)
        p = ca.MX.sym("p", dm.nu)
        tol = {"abstol": 1e-12, "reltol": 1e-12}
        ode = {"x": x, "p": p, "ode": self.f(x, p)}
        run = ca.integrator(f"{dm.method.name}_flow", "cvodes", ode, 0.0, float(h), tol)
        return run(x0=x0, p=u)["xf"]


def discrete_function(dm: Any) -> Any:
    """``casadi.Function`` F(z, u) -> z+ of a DiscreteModel, from the rule's step
    (``discrete_step.blocks``) on the model's CasADi f. Explicit rules give an SX
    function; Tustin's implicit step is a Newton ``rootfinder`` (MX), exact to its
    tolerance (1e-14) and differentiable by the implicit function theorem; ZOH's exact
    flow a CVODES ``integrator`` (MX, rtol = atol = 1e-12)."""
    ca = _casadi()
    f = casadi_rhs(dm.model)
    nx, nu, core = dm.nx, dm.nu, len(dm.layout) * dm.nx
    symbolic_only = dm.step_data.kernels == frozenset({"rhs"})
    sym = ca.SX.sym if symbolic_only else ca.MX.sym
    z = sym("z", dm.nz)
    u = sym("u", nu)
    blocks = [z[b * nx : (b + 1) * nx] for b in range(len(dm.layout))]
    applied = z[core:] if dm.delay else u
    solvers = _Solvers(ca, dm, f, z, u)
    new = dm.step_data.blocks(lambda t, xb, ub: f(xb, ub), 0.0, blocks, applied, dm.h, solvers)
    parts = list(new) + ([u] if dm.delay else [])
    name = f"{dm.method.name}_h{dm.h:g}".replace(".", "p")
    return ca.Function(name, [z, u], [ca.vertcat(*parts)], ["z", "u"], ["z_next"])
