"""The model protocol and the compiled batch evaluation shared by every model.

A model is continuous-time physics only: ``x' = f(t, x, u; p)``. Each concrete model
provides one numba-compiled *kernel* ``rhs(t, x, u, p, out)`` for a single state;
:func:`sampledyn.simulate` integrates that kernel, and :meth:`Model.f` evaluates the
same kernel over a batch of samples, so there is one source of truth per model.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numba import float64, njit, types

from ..exceptions import JacobianUnavailableError
from ._codegen import batch_functions

__all__ = [
    "BATCH_JAC_SIG",
    "BATCH_RHS_SIG",
    "JAC_SIG",
    "RHS_SIG",
    "CompiledModel",
    "LinearForm",
    "Model",
    "ParameterArrayModel",
    "batch_eval",
    "finite_number",
    "index_switch",
]

# Every compiled kernel has one of these explicit signatures. Functions that take a
# kernel as an argument then see a plain function-pointer type, which numba can cache
# on disk; with a dispatcher type the cache key changes from one process to the next
# and every run recompiles (numba issues 6251, 6772).
# Inputs are read-only arrays (a mutable array converts to one for free), outputs
# mutable; all C-contiguous float64.
RO1 = types.Array(float64, 1, "C", readonly=True)
RO2 = types.Array(float64, 2, "C", readonly=True)
RO3 = types.Array(float64, 3, "C", readonly=True)
RHS_SIG = types.void(float64, RO1, RO1, RO1, float64[::1])
JAC_SIG = types.void(float64, RO1, RO1, RO1, float64[:, ::1])
RHS_TYPE = types.FunctionType(RHS_SIG)
JAC_TYPE = types.FunctionType(JAC_SIG)
# Batch evaluators bound to one kernel: batch(t (N,), x (N, nx), u (N, nu), p) -> out.
BATCH_RHS_SIG = float64[:, ::1](RO1, RO2, RO2, RO1)
BATCH_JAC_SIG = float64[:, :, ::1](RO1, RO2, RO2, RO1)


# Fallback batch evaluators taking the kernel as a function pointer (for kernels that
# cannot be bound as a global, e.g. FunctionModel's). Compiled, or loaded from numba's
# cache, on first use only: most processes never need them.
@njit(cache=True)
def _batch_rhs_any(rhs, t, x, u, p):  # pragma: no cover - compiled
    n, nx = x.shape
    out = np.empty((n, nx))
    for i in range(n):
        rhs(t[i], x[i], u[i], p, out[i])
    return out


@njit(cache=True)
def _batch_matrix_any(jac, t, x, u, p, rows, cols):  # pragma: no cover - compiled
    n = x.shape[0]
    out = np.empty((n, rows, cols))
    for i in range(n):
        jac(t[i], x[i], u[i], p, out[i])
    return out


def _compiled(dispatcher: Any, sig: Any) -> Any:
    if not dispatcher.signatures:
        dispatcher.compile(sig)
        dispatcher.disable_compile()
    return dispatcher


_BATCH_RHS_ANY_SIG = float64[:, ::1](RHS_TYPE, RO1, RO2, RO2, RO1)
_BATCH_MATRIX_ANY_SIG = float64[:, :, ::1](JAC_TYPE, RO1, RO2, RO2, RO1, types.int64, types.int64)


def _batch_rhs(rhs: Any, t: Any, x: Any, u: Any, p: Any) -> np.ndarray:
    """``rhs`` over a batch, the kernel passed as a function pointer; shape (N, nx)."""
    return _compiled(_batch_rhs_any, _BATCH_RHS_ANY_SIG)(rhs, t, x, u, p)


def _batch_matrix(jac: Any, t: Any, x: Any, u: Any, p: Any, rows: int, cols: int) -> np.ndarray:
    """``jac`` over a batch, the kernel passed as a function pointer; (N, rows, cols)."""
    return _compiled(_batch_matrix_any, _BATCH_MATRIX_ANY_SIG)(jac, t, x, u, p, rows, cols)


@njit(cache=True)  # compiled for RHS_SIG on first use (switch_kernel())
def index_switch(t, x, u, sp, out):  # pragma: no cover - compiled
    """Switching values picked from the state and input: sp = [ns, i..., nu, j...]."""
    ns = int(sp[0])
    for k in range(ns):
        out[k] = x[int(sp[1 + k])]
    nu = int(sp[1 + ns])
    for k in range(nu):
        out[ns + k] = u[int(sp[2 + ns + k])]


# Rows per call of a compiled batch evaluator: a call over more (5 M samples) would
# keep Python, and with it Ctrl-C and SIGTERM, waiting for seconds; each block is
# about 0.3 s of a 12-state vehicle's f (0.14 us a row) or Jacobian (0.8 us).
RHS_BLOCK_ROWS = 1 << 21
JAC_BLOCK_ROWS = 1 << 18


def in_row_blocks(batch: Any, t: Any, x: Any, u: Any, p: Any, rows: int) -> np.ndarray:
    """``batch(t, x, u, p)`` over the rows of x, in blocks of ``rows`` rows (the same
    numbers; copied into one result only when there is more than one block)."""
    n = x.shape[0]
    if n <= rows:
        return batch(t, x, u, p)
    first = batch(t[:rows], x[:rows], u[:rows], p)
    out = np.empty((n, *first.shape[1:]))
    out[:rows] = first
    for a in range(rows, n, rows):
        out[a : a + rows] = batch(t[a : a + rows], x[a : a + rows], u[a : a + rows], p)
    return out


def readonly(a: Any) -> np.ndarray:
    """A read-only, C-contiguous float64 view (copies only if needed)."""
    a = np.ascontiguousarray(a, dtype=float)
    if a.flags.writeable:
        a = a.view()
        a.setflags(write=False)
    return a


def _single(x: Any, u: Any, nx: int, nu: int) -> tuple[np.ndarray, np.ndarray]:
    xs = np.ascontiguousarray(x, dtype=float)
    us = np.ascontiguousarray(u, dtype=float).reshape(-1)
    if xs.shape != (nx,):
        raise ValueError(f"`x` must have shape (N, {nx}) or ({nx},), got {xs.shape}.")
    if us.shape != (nu,):
        raise ValueError(f"`u` must have shape ({nu},) for a single state, got {np.shape(u)}.")
    return xs, us


def _is_f64(a: Any, ndim: int) -> bool:
    return (
        type(a) is np.ndarray and a.ndim == ndim and a.dtype == np.float64 and a.flags.c_contiguous
    )


def _as_batch(
    t: Any, x: Any, u: Any, nx: int, nu: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, Any]:
    if _is_f64(x, 2) and _is_f64(u, 2) and x.shape[1] == nx and u.shape == (x.shape[0], nu):
        # Fast path (a batch as the predictors pass it): no conversion.
        n = x.shape[0]
        if _is_f64(t, 1) and t.shape == (n,):
            return t, x, u, np.False_
        return np.full(n, float(t)) if np.ndim(t) == 0 else _times(t, n), x, u, np.False_
    x = np.ascontiguousarray(x, dtype=float)
    single = x.ndim == 1
    if single:
        x = x[None, :]
    if x.ndim != 2 or x.shape[1] != nx:
        raise ValueError(f"`x` must have shape (N, {nx}) or ({nx},), got {np.shape(x)}.")
    n = x.shape[0]
    u = np.ascontiguousarray(u, dtype=float)
    if u.ndim <= 1 and nu == 1 and u.size == n:
        u = u.reshape(n, 1)
    elif u.ndim == 1 and u.shape[0] == nu:
        u = np.broadcast_to(u, (n, nu)).copy()
    if u.shape != (n, nu):
        raise ValueError(f"`u` must have shape ({n}, {nu}), got {u.shape}.")
    return _times(t, n), x, u, np.array(single)


def _times(t: Any, n: int) -> np.ndarray:
    return np.ascontiguousarray(np.broadcast_to(np.asarray(t, dtype=float), (n,)))


def batch_eval(kernel: Callable[..., None], p: Any, t: Any, x: Any, u: Any, nx: int, nu: int):
    """Evaluate a compiled ``kernel(t, x, u, p, out)`` (out shape (nx,)) on a batch of
    samples; returns shape (N, nx) (or (nx,) for a single state)."""
    t, x, u, single = _as_batch(t, x, u, nx, nu)
    batch = batch_functions(kernel, "rhs")
    if batch is not None:
        out = in_row_blocks(batch, t, x, u, _params(p), RHS_BLOCK_ROWS)
    else:
        out = in_row_blocks(
            lambda *a: _batch_rhs(kernel, *(readonly(v) for v in a)), t, x, u, p, RHS_BLOCK_ROWS
        )
    return out[0] if single else out


class LinearForm:
    """``f(t, x, u) = Phi(t, x, u) @ theta + f0(t, x, u)`` for a model linear in theta.

    Attributes
    ----------
    names : tuple of str
        Parameter names, in the order of theta.
    units : tuple of str
        Their units.
    phi : ndarray, shape (N, nx, n_theta)
        Regressors.
    f0 : ndarray, shape (N, nx)
        The part of f that does not depend on theta.
    """

    def __init__(
        self, names: tuple[str, ...], units: tuple[str, ...], phi: np.ndarray, f0: np.ndarray
    ) -> None:
        self.names = names
        self.units = units
        self.phi = phi
        self.f0 = f0


@runtime_checkable
class Model(Protocol):
    """Continuous-time dynamics ``x' = f(t, x, u)``; never a stepping scheme: what the
    simulator, the rules, the analysis and the experiments ask of a model (the type of
    their ``model`` arguments). :class:`CompiledModel`, the base of every built-in and
    user model, answers it; a model of your own subclasses it (``kernel`` and
    ``jacobian_kernel`` are the compiled right-hand side and Jacobian)."""

    @property
    def nx(self) -> int:
        """Number of states."""
        ...

    @property
    def nu(self) -> int:
        """Number of inputs."""
        ...

    @property
    def state_names(self) -> tuple[str, ...]:
        """Names of the states."""
        ...

    @property
    def state_units(self) -> tuple[str, ...]:
        """Units of the states ("m", "rad", "m/s", "rad/s", ...)."""
        ...

    @property
    def input_names(self) -> tuple[str, ...]:
        """Names of the inputs."""
        ...

    @property
    def input_units(self) -> tuple[str, ...]:
        """Units of the inputs."""
        ...

    @property
    def default_x0(self) -> np.ndarray:
        """Initial state used when none is given, shape (nx,)."""
        ...

    def f(self, t: Any, x: Any, u: Any) -> np.ndarray:
        """Right-hand side; x shape (N, nx), u shape (N, nu) -> (N, nx)."""
        ...

    def jacobian(self, t: Any, x: Any, u: Any) -> np.ndarray:
        """d f / d x; shape (N, nx, nx)."""
        ...

    def input_jacobian(self, t: Any, x: Any, u: Any) -> np.ndarray:
        """d f / d u; shape (N, nx, nu)."""
        ...

    def kernel(self) -> tuple[Callable[..., None], Any]:
        """The compiled ``rhs(t, x, u, p, out)`` and its parameters ``p``."""
        ...

    def jacobian_kernel(self) -> tuple[Callable[..., None], Any]:
        """The compiled ``jac(t, x, u, p, out)`` and ``p``."""
        ...

    def input_jacobian_kernel(self) -> tuple[Callable[..., None], Any]:
        """The compiled ``jac_u(t, x, u, p, out)`` and ``p``."""
        ...

    def switch_kernel(self) -> tuple[Any, np.ndarray, np.ndarray]:
        """The switching values whose zero crossings are the kinks of f."""
        ...

    def check_states(self, x: Any) -> None:
        """Raise (or warn) for states outside the model's domain."""
        ...


@runtime_checkable
class ParametricModel(Model, Protocol):
    """A model with named parameters (what estimation asks): their values, their
    names, and a copy with other values."""

    @property
    def params(self) -> dict[str, float]:
        """Parameter values by name."""
        ...

    @property
    def param_names(self) -> tuple[str, ...]:
        """Parameter names, in the order of the parameter array."""
        ...

    def with_params(self, **values: Any) -> Any:
        """The same model with some parameter values changed."""
        ...


class CompiledModel:
    """Base class of the compiled models: ``f`` and ``jacobian`` from compiled kernels.

    Subclasses set ``nx``, ``nu``, names and units, and implement :meth:`kernel`
    (returning the compiled rhs and its parameter array) and :meth:`jacobian_kernel`;
    optionally :meth:`input_jacobian_kernel`, and ``kink_states`` / ``kink_inputs``
    (indices inside ``|.|``) or their own :meth:`switch_kernel`.

    ``f`` and ``jacobian`` evaluate a batch through an evaluator bound to the kernel
    (see :func:`sampledyn.models._codegen.batch_functions`), so a call from Python
    costs about a microsecond of dispatch, whatever the batch size.
    """

    nx: int
    nu: int
    state_names: tuple[str, ...]
    state_units: tuple[str, ...]
    input_names: tuple[str, ...]
    input_units: tuple[str, ...]

    def kernel(self) -> tuple[Callable[..., None], Any]:
        """The compiled ``rhs(t, x, u, p, out)`` and its parameters ``p``."""
        raise NotImplementedError

    def jacobian_kernel(self) -> tuple[Callable[..., None], Any]:
        """The compiled ``jac(t, x, u, p, out)`` (out shape (nx, nx)) and ``p``."""
        raise JacobianUnavailableError(f"{type(self).__name__} has no compiled Jacobian kernel.")

    def input_jacobian_kernel(self) -> tuple[Callable[..., None], Any]:
        """The compiled ``jac_u(t, x, u, p, out)`` (out shape (nx, nu)) and ``p``."""
        raise JacobianUnavailableError(
            f"{type(self).__name__} has no input Jacobian df/du; closed loops around it "
            "need one for their exact Jacobian (define the model with "
            "sampledyn.models.SymbolicModel, or give FunctionModel an `input_jac`)."
        )

    def switch_kernel(self) -> tuple[Any, np.ndarray, np.ndarray]:
        """Switching values whose zero crossings are the kinks of f.

        Returns
        -------
        (sw, sp, input_only)
            A compiled ``sw(t, x, u, sp, out)``, its parameters, and one bool per value:
            True where the value depends on the input only. This default picks the
            states ``kink_states`` and inputs ``kink_inputs`` (the arguments of
            ``|.|`` terms).
        """
        states = tuple(int(i) for i in getattr(self, "kink_states", ()))
        inputs = tuple(int(j) for j in getattr(self, "kink_inputs", ()))
        sp = np.array([len(states), *states, len(inputs), *inputs], dtype=float)
        input_only = np.array([False] * len(states) + [True] * len(inputs), dtype=np.bool_)
        return _compiled(index_switch, RHS_SIG), sp, input_only

    @property
    def default_x0(self) -> np.ndarray:
        """Initial state used by :func:`sampledyn.simulate` when none is given."""
        return np.zeros(self.nx)

    def check_states(self, x: Any) -> None:
        """Raise (or warn) for states outside the model's domain, as ``f`` and
        ``jacobian`` do before they evaluate; the default accepts every state.
        Composite models (:class:`~sampledyn.models.ClosedLoop`) call it when they
        evaluate this model's kernels themselves. ``x`` shape (N, nx) or (nx,)."""

    def f(self, t: Any, x: Any, u: Any) -> np.ndarray:
        """Right-hand side ``f(t, x, u)``.

        Parameters
        ----------
        t : float or ndarray, shape (N,)
            Times (s).
        x : ndarray, shape (N, nx) or (nx,)
            States.
        u : ndarray, shape (N, nu) or (nu,)
            Inputs.

        Returns
        -------
        ndarray, shape (N, nx) (or (nx,) for a single state)
        """
        rhs, p = self.kernel()
        # Fast paths for float64 arrays of the right shapes (numba's dispatcher refuses
        # anything else with a TypeError, and then the general path converts).
        if type(x) is np.ndarray and type(u) is np.ndarray:
            shape = x.shape
            if type(t) is float and shape == (self.nx,) and u.shape == (self.nu,):
                out = np.empty(self.nx)
                try:
                    rhs(t, x, u, p, out)
                    return out
                except TypeError:
                    pass
            elif (
                len(shape) == 2
                and shape[1] == self.nx
                and u.shape == (shape[0], self.nu)
                and type(t) is np.ndarray
                and t.shape == (shape[0],)
            ):
                batch = batch_functions(rhs, "rhs")
                if batch is not None:
                    try:
                        return in_row_blocks(batch, t, x, u, p, RHS_BLOCK_ROWS)
                    except TypeError:
                        pass
        if np.ndim(x) == 1 and np.ndim(t) == 0:
            xs, us = _single(x, u, self.nx, self.nu)
            out = np.empty(self.nx)
            rhs(float(t), xs, us, _params(p), out)
            return out
        return batch_eval(rhs, p, t, x, u, self.nx, self.nu)

    def jacobian(self, t: Any, x: Any, u: Any) -> np.ndarray:
        """Exact Jacobian ``df/dx``, shape (N, nx, nx) (or (nx, nx)).

        Raises
        ------
        JacobianUnavailableError
            If the model has no Jacobian kernel.
        """
        jac, p = self.jacobian_kernel()
        return self._matrix(jac, "jac", p, t, x, u, self.nx)

    def input_jacobian(self, t: Any, x: Any, u: Any) -> np.ndarray:
        """Exact input Jacobian ``df/du``, shape (N, nx, nu) (or (nx, nu)).

        Raises
        ------
        JacobianUnavailableError
            If the model has no input-Jacobian kernel.
        """
        jac, p = self.input_jacobian_kernel()
        return self._matrix(jac, "jac_u", p, t, x, u, self.nu)

    def _matrix(self, kernel: Any, kind: str, p: Any, t: Any, x: Any, u: Any, cols: int):
        if np.ndim(x) == 1 and np.ndim(t) == 0:
            xs, us = _single(x, u, self.nx, self.nu)
            out = np.empty((self.nx, cols))
            kernel(float(t), xs, us, _params(p), out)
            return out
        tt, xx, uu, single = _as_batch(t, x, u, self.nx, self.nu)
        batch = batch_functions(kernel, "jac") if kind == "jac" else None
        if batch is None:
            batch = _registered(kernel)
        if batch is not None:
            out = in_row_blocks(batch, tt, xx, uu, _params(p), JAC_BLOCK_ROWS)
        else:

            def block(tb: Any, xb: Any, ub: Any, pb: Any) -> np.ndarray:
                rd = readonly
                return _batch_matrix(kernel, rd(tb), rd(xb), rd(ub), rd(pb), self.nx, cols)

            out = in_row_blocks(block, tt, xx, uu, p, JAC_BLOCK_ROWS)
        return out[0] if single else out


class ParameterArrayModel(CompiledModel):
    """A compiled model whose parameters travel in one array ``p`` (the order of
    :attr:`param_names`) and whose default initial state is given: the base of the
    user-defined models. :meth:`with_params` copies the model, sharing its compiled
    kernels, with other values in ``p``; nothing is recompiled."""

    _param_names: tuple[str, ...]
    _p: np.ndarray
    _x0: np.ndarray
    param_units: dict[str, str]

    def _set_params(
        self, names: tuple[str, ...], values: Any, units: Any, x0: Any, nx: int
    ) -> None:
        """Check and store the parameters (names, values, units by name) and x0."""
        self._param_names = tuple(names)
        self._p = _frozen(
            [finite_number(v, f"params[{n}]") for n, v in zip(names, values, strict=True)]
        )
        units = dict(units or {})
        unknown = set(units) - set(self._param_names)
        if unknown:
            raise ValueError(
                f"`param_units` names unknown parameter(s) {sorted(unknown)}; parameters: "
                f"{list(self._param_names)}."
            )
        self.param_units = {n: str(units.get(n, "")) for n in self._param_names}
        x0a = np.zeros(nx) if x0 is None else np.array(x0, dtype=float)
        if x0a.shape != (nx,) or not np.isfinite(x0a).all():
            raise ValueError(f"`x0` must be {nx} finite numbers, got {x0!r}.")
        self._x0 = _frozen(x0a)

    @property
    def params(self) -> dict[str, float]:
        """Parameter values by name (units in :attr:`param_units`)."""
        return dict(zip(self._param_names, (float(v) for v in self._p), strict=True))

    @property
    def param_names(self) -> tuple[str, ...]:
        return self._param_names

    @property
    def param_bounds(self) -> dict[str, tuple[float, float]]:
        """Physical bounds (lo, hi) of parameters, by name: an estimate outside them
        contradicts the physics (e.g. a negative damping) and is flagged by
        :func:`sampledyn.estimate`. Only the parameters declared."""
        return dict(getattr(self, "_bounds", {}))

    def _set_bounds(self, bounds: Any) -> None:
        """Check and store ``bounds``: {name or Symbol: (lo, hi)}, lo < hi (either may be
        +-inf)."""
        out: dict[str, tuple[float, float]] = {}
        for key, pair in dict(bounds or {}).items():
            name = str(getattr(key, "name", key))
            if name not in self._param_names:
                raise ValueError(
                    f"`param_bounds` names {name!r}, not a parameter; parameters: "
                    f"{list(self._param_names)}."
                )
            try:
                lo, hi = (float(v) for v in pair)
            except (TypeError, ValueError):
                raise ValueError(
                    f"`param_bounds[{name!r}]` must be a pair (lo, hi), got {pair!r}; e.g. "
                    "(0, inf) for a damping."
                ) from None
            if not lo < hi:
                raise ValueError(f"`param_bounds[{name!r}]` needs lo < hi, got ({lo}, {hi}).")
            out[name] = (lo, hi)
        self._bounds = out

    @property
    def default_x0(self) -> np.ndarray:
        return self._x0.copy()

    def with_params(self, **values: float) -> Any:
        """The same model with some parameter values changed (no recompilation).

        Raises
        ------
        TypeError
            For a name that is not a parameter.
        ValueError
            For a value that is not a finite number.
        """
        unknown = set(values) - set(self._param_names)
        if unknown:
            raise TypeError(
                f"unknown parameter(s) {sorted(unknown)}; valid: {list(self._param_names)}."
            )
        p = np.array(self._p)
        for name, v in values.items():
            p[self._param_names.index(name)] = finite_number(v, name)
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        new._p = _frozen(p)
        return new


def finite_number(value: Any, argument: str) -> float:
    """``value`` as a finite float (sympy and numpy numbers accepted), or an error
    naming ``argument``."""
    if value is None:
        raise ValueError(f"`{argument}` has no value; give every parameter a number.")
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        try:
            value = float(value)
        except (TypeError, ValueError):
            raise TypeError(
                f"`{argument}` must be a real number, got {value!r} ({type(value).__name__})."
            ) from None
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"`{argument}` must be finite, got {v}.")
    return v


def _frozen(values: Any) -> np.ndarray:
    p = np.array(values, dtype=float).reshape(-1)
    p.setflags(write=False)
    return p


def _registered(kernel: Any) -> Any:
    """A registered batch evaluator of ``kernel`` (generated modules register theirs)."""
    return batch_functions(kernel, None)


def _params(p: Any) -> np.ndarray:
    return p if _is_f64(p, 1) else np.ascontiguousarray(p, dtype=float)
