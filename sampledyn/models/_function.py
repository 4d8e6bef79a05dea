"""Models from a plain numba-compilable Python function (no sympy).

The function is compiled for the project's kernel signature, so the exact simulator
and every predictor call it as they call the built-in kernels. Nothing is derived from
it: the Jacobian is the user's (``jac=``) or absent, and then everything that needs
one (Tustin, sensitivity bounds, Jacobian maxima, closed-loop Jacobians) raises
:class:`~sampledyn.exceptions.JacobianUnavailableError` saying how to supply it; nothing
silently falls back to finite differences.

The compiled kernels live in this process only (a function defined in a script or a
notebook cannot be found again by a later process): a FunctionModel compiles once per
process, typically under a second. :class:`~sampledyn.models.SymbolicModel` kernels are
cached on disk.
"""

from __future__ import annotations

import inspect
import re
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from numba import njit
from numba.core.errors import NumbaError

from ..exceptions import JacobianUnavailableError
from . import _closed_loop, _codegen, _jumps
from ._base import JAC_SIG, RHS_SIG, ParameterArrayModel

__all__ = ["FunctionModel"]

_SENTINEL = -1.2345678901234567e300  # "not written" marker for the construction check


def _py_func(fn: Any, argument: str) -> Callable[..., Any]:
    py = getattr(fn, "py_func", fn)
    if not callable(py):
        raise TypeError(f"`{argument}` must be a function, got {type(fn).__name__}.")
    return py


def _arity(py: Callable[..., Any], argument: str) -> int:
    try:
        params = inspect.signature(py).parameters.values()
    except (TypeError, ValueError):
        raise TypeError(f"`{argument}` must be a Python function numba can compile.") from None
    n = sum(1 for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD))
    if n not in (4, 5):
        raise TypeError(
            f"`{argument}` must take (t, x, u, p, out) and write into out, or take "
            f"(t, x, u, p) and return the array; it takes {n} positional arguments."
        )
    return n


def _compile(fn: Any, argument: str, shape: str, sig: Any) -> Any:
    """``fn`` compiled as a kernel ``k(t, x, u, p, out)`` with signature ``sig``."""
    py = _py_func(fn, argument)
    try:
        if _arity(py, argument) == 5:
            return njit(sig, error_model="numpy")(py)
        inner = njit(inline="always", error_model="numpy")(py)
        if sig is RHS_SIG:

            def vector(t, x, u, p, out):  # pragma: no cover - compiled
                d = inner(t, x, u, p)
                if len(d) != out.shape[0]:  # flagged by the construction check
                    out[:] = _SENTINEL
                    return
                for i in range(out.shape[0]):
                    out[i] = d[i]

            return njit(sig, error_model="numpy")(vector)

        def matrix(t, x, u, p, out):  # pragma: no cover - compiled
            d = inner(t, x, u, p)
            if d.shape[0] != out.shape[0] or d.shape[1] != out.shape[1]:
                out[:, :] = _SENTINEL
                return
            for i in range(out.shape[0]):
                for j in range(out.shape[1]):
                    out[i, j] = d[i, j]

        return njit(sig, error_model="numpy")(matrix)
    except NumbaError as err:
        text = re.sub(r"\x1b\[[0-9;]*m", "", str(err)).strip().splitlines()
        detail = " ".join(line.strip() for line in text[:4])
        raise TypeError(
            f"`{argument}` could not be compiled by numba as {argument}(t: float, x: array "
            f"(nx,), u: array (nu,), p: array (n_params,), out: array {shape}) (or the "
            f"same without `out`, returning it): {detail}"
        ) from None


def _checked_call(kernel: Any, argument: str, shape: tuple[int, ...], args: tuple) -> None:
    out = np.full(shape, _SENTINEL)
    try:
        kernel(*args, out)
    except (IndexError, ValueError) as err:
        raise ValueError(f"`{argument}` failed at the default state: {err}") from None
    missed = np.argwhere(out == _SENTINEL)
    if missed.size:
        where = ", ".join(str(int(i)) for i in missed[0])
        raise ValueError(
            f"`{argument}` did not write out[{where}], or returned an array of another "
            f"shape: it must give every entry of shape {shape}."
        )


def _names(value: Any, n: int, default: Sequence[str], argument: str) -> tuple[str, ...]:
    if value is None:
        return tuple(default)
    out = tuple(value) if not isinstance(value, str) else (value,)
    if len(out) != n or not all(isinstance(s, str) for s in out):
        raise ValueError(f"`{argument}` must be {n} strings, got {value!r}.")
    return out


class FunctionModel(ParameterArrayModel):
    """A model from a numba-compilable function ``f(t, x, u, p, out)``.

    Parameters
    ----------
    f : function
        Either ``f(t, x, u, p, out)`` writing x' into ``out`` (shape (nx,)), or
        ``f(t, x, u, p)`` returning it as an array of shape (nx,). t is a float, x, u
        and p read-only float64 arrays of shapes (nx,), (nu,) and (n_params,). numba's
        nopython subset (math, numpy scalar functions, loops) applies.
    nx, nu : int
        Numbers of states and inputs.
    jac : function, optional
        ``jac(t, x, u, p, out)`` writing df/dx (out shape (nx, nx)), or returning it.
        Without it, :meth:`jacobian` raises :class:`JacobianUnavailableError`.
    input_jac : function, optional
        ``input_jac(t, x, u, p, out)`` writing df/du (out shape (nx, nu)), or returning
        it; closed loops around this model need it for their Jacobian.
    params : mapping {name: float}, optional
        Parameter values, passed to the functions as ``p`` in this order;
        :meth:`with_params` changes them without recompiling.
    kink_states, kink_inputs : sequence of int
        States and inputs whose zero crossings are kinks of f (inside ``|.|``): the
        exact simulator ends its steps there.
    switching : function, optional
        ``switching(t, x, u, p, out)`` writing m switching values g (out shape (m,),
        m = ``len(switching_names)``): f is smooth between their zero crossings, and
        the exact simulator ends its steps on them (instead of ``kink_states`` and
        ``kink_inputs``).
    switching_names : sequence of str
        One name per switching value, for messages (required with ``switching``).
    jumps : sequence of int
        The switching values across which f itself jumps (a ``math.copysign``, an
        ``if`` on the state): f must then compute the branch of each side and read
        the side s_j = -1 or +1 of jump j (in the order of ``jumps``) from
        ``p[n_params + j]``, never from the sign of the switching value itself; the
        simulator crosses and slides (Filippov) as for a
        :class:`~sampledyn.models.SymbolicModel`. Needs ``switching_jacobian``.
        Without a declaration, an f that jumps stalls the simulator, which then
        stops with an error saying to declare it.
    switching_jacobian : function, optional
        ``switching_jacobian(t, x, u, p, out)`` writing the gradients of the
        switching values, out shape (m, nx + 1 + nu): columns dg/dx, dg/dt, dg/du.
    state_names, state_units, input_names, input_units : sequence of str, optional
    param_units : mapping {name: str}, optional
    x0 : array_like, shape (nx,), optional
        Default initial state (default zeros).
    name : str

    Raises
    ------
    TypeError
        If a function does not compile for the kernel signature (numba's message is
        included) or takes the wrong number of arguments.
    ValueError
        Bad sizes, names, indices or parameter values; a function that leaves an entry
        of ``out`` unwritten or returns the wrong shape at ``x0``.
    """

    def __init__(
        self,
        f: Any,
        nx: int,
        nu: int,
        jac: Any = None,
        *,
        input_jac: Any = None,
        params: Mapping[str, float] | None = None,
        kink_states: Sequence[int] = (),
        kink_inputs: Sequence[int] = (),
        switching: Any = None,
        switching_names: Sequence[str] | None = None,
        jumps: Sequence[int] = (),
        switching_jacobian: Any = None,
        state_names: Sequence[str] | None = None,
        state_units: Sequence[str] | None = None,
        input_names: Sequence[str] | None = None,
        input_units: Sequence[str] | None = None,
        param_units: Mapping[str, str] | None = None,
        x0: Any = None,
        name: str = "function model",
    ) -> None:
        for arg, value, low in (("nx", nx, 1), ("nu", nu, 0)):
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < low:
                raise ValueError(f"`{arg}` must be an integer >= {low}, got {value!r}.")
        self.nx, self.nu = int(nx), int(nu)
        params = dict(params or {})
        not_names = [key for key in params if not isinstance(key, str)]
        if not_names:
            raise TypeError(f"`params` keys must be names (str), got {not_names[0]!r}.")
        self._set_params(tuple(params), tuple(params.values()), param_units, x0, self.nx)
        self.state_names = _names(state_names, self.nx, [f"x{i}" for i in range(nx)], "state_names")
        self.state_units = _names(state_units, self.nx, [""] * self.nx, "state_units")
        self.input_names = _names(input_names, self.nu, [f"u{j}" for j in range(nu)], "input_names")
        self.input_units = _names(input_units, self.nu, [""] * self.nu, "input_units")
        for arg, idx, size in (("kink_states", kink_states, nx), ("kink_inputs", kink_inputs, nu)):
            bad = [i for i in idx if not (isinstance(i, int | np.integer) and 0 <= i < size)]
            if bad:
                raise ValueError(f"`{arg}` must hold indices in [0, {size}), got {bad}.")
        self.kink_states = tuple(int(i) for i in kink_states)
        self.kink_inputs = tuple(int(j) for j in kink_inputs)
        self.name = str(name)
        self._switching = _Switching.check(
            self, switching, switching_names, jumps, switching_jacobian
        )

        nxs = f"({nx},)"
        self._rhs = _compile(f, "f", nxs, RHS_SIG)
        if self._switching is not None:
            self._switching.compile(self)
            self._branch, self._rhs = self._rhs, self._switching.surface_rhs(self)
        self._jac = None if jac is None else _compile(jac, "jac", f"({nx}, {nx})", JAC_SIG)
        self._jac_u = (
            None
            if input_jac is None
            else _compile(input_jac, "input_jac", f"({nx}, {nu})", JAC_SIG)
        )
        args = (0.0, self._x0, np.zeros(self.nu), self._p)
        if self._switching is not None:
            self._switching.check_calls(self, args)
        _checked_call(self._rhs, "f", (self.nx,), args)
        if self._jac is not None:
            _checked_call(self._jac, "jac", (self.nx, self.nx), args)
        if self._jac_u is not None:
            _checked_call(self._jac_u, "input_jac", (self.nx, self.nu), args)

    def kernel(self) -> tuple[Any, np.ndarray]:
        return self._rhs, self._p

    def switch_kernel(self) -> tuple[Any, np.ndarray, np.ndarray]:
        """The declared ``switching`` values (or, without, those of ``kink_states``
        and ``kink_inputs``)."""
        sw = self._switching
        if sw is None:
            return super().switch_kernel()
        return sw.kernel, self._p, np.zeros(len(sw.names), dtype=np.bool_)

    def switching_names(self) -> tuple[str, ...]:
        """Names of the switching values, in the order of the switching kernel's
        outputs (the declared ones, or the states and inputs inside ``|.|``)."""
        sw = self._switching
        if sw is None:
            names = [self.state_names[i] for i in self.kink_states]
            return tuple(names + [self.input_names[j] for j in self.kink_inputs])
        return sw.names

    def jump_kernel(self) -> tuple[Any, Any, np.ndarray, np.ndarray] | None:
        """The declared jumps for :func:`sampledyn.simulate` (see
        :meth:`sampledyn.models.SymbolicModel.jump_kernel`), or None."""
        sw = self._switching
        if sw is None or not sw.jumps:
            return None
        info = np.full((len(sw.names), 2), -1, dtype=np.int64)
        info[:, 1] = 0
        for j, k in enumerate(sw.jumps):
            # whether g depends on u is not known: the sides are checked wherever the
            # input jumps (only where g changed there)
            info[k] = (self._p.size + j, 1)
        q = np.concatenate([self._p, np.ones(len(sw.jumps))])
        return self._branch, sw.gradient, q, info

    def jacobian_kernel(self) -> tuple[Any, np.ndarray]:
        if self._jac is None:
            raise self._missing(
                "Jacobian", "jac", "df/dx", (self.nx, self.nx),
                "derives it exactly. Tustin (T), the sensitivity bounds, Jacobian maxima and "
                "closed-loop Jacobians need it",
            )  # fmt: skip
        return self._jac, self._p

    def input_jacobian_kernel(self) -> tuple[Any, np.ndarray]:
        if self._jac_u is None:
            raise self._missing(
                "input Jacobian", "input_jac", "df/du", (self.nx, self.nu),
                "derives it too. Closed loops around the model need it for their Jacobian",
            )  # fmt: skip
        return self._jac_u, self._p

    def _missing(
        self, what: str, argument: str, symbol: str, shape: tuple[int, int], why: str
    ) -> JacobianUnavailableError:
        return JacobianUnavailableError(
            f"FunctionModel {self.name!r} has no {what}: pass `{argument}=`, a "
            f"numba-compilable {argument}(t, x, u, p, out) writing {symbol} into out of shape "
            f"{shape} (or returning it), or define the model with "
            f"sampledyn.models.SymbolicModel, which {why}; sampledyn never falls back to "
            "finite differences."
        )

    def __repr__(self) -> str:
        return (
            f"FunctionModel(name={self.name!r}, nx={self.nx}, nu={self.nu}, params={self.params})"
        )


class _Switching:
    """A FunctionModel's declared switching values and jumps (checked, compiled)."""

    def __init__(self, function: Any, names: tuple[str, ...], jumps: tuple[int, ...], jac: Any):
        self.function, self.names, self.jumps, self.jac = function, names, jumps, jac
        self.kernel: Any = None
        self.gradient: Any = None

    @classmethod
    def check(
        cls, model: Any, function: Any, names: Any, jumps: Any, jac: Any
    ) -> _Switching | None:
        jumps = tuple(jumps)
        if function is None:
            if jumps or jac is not None or names is not None:
                raise ValueError(
                    "`jumps`, `switching_names` and `switching_jacobian` need `switching=`, "
                    "the function that writes the switching values."
                )
            return None
        if model.kink_states or model.kink_inputs:
            raise ValueError(
                "give either `switching=` or `kink_states`/`kink_inputs`, not both (add the "
                "kinks to the switching values)."
            )
        if names is None or isinstance(names, str) or not all(isinstance(n, str) for n in names):
            raise ValueError(
                "`switching_names` must name each switching value (a sequence of str; its "
                f"length is their number), got {names!r}."
            )
        names = tuple(names)
        bad = [k for k in jumps if not (isinstance(k, int | np.integer) and 0 <= k < len(names))]
        if bad or len(set(jumps)) != len(jumps):
            raise ValueError(
                f"`jumps` must hold distinct indices in [0, {len(names)}) (one per switching "
                f"value across which f jumps), got {list(jumps)}."
            )
        if jumps and jac is None:
            raise ValueError(
                "`jumps` needs `switching_jacobian=`, writing dg/dx, dg/dt, dg/du of the "
                f"switching values (out shape ({len(names)}, nx + 1 + nu)): the simulator "
                "decides crossing or sliding from the normal speeds."
            )
        return cls(function, names, tuple(int(k) for k in jumps), jac)

    def compile(self, model: Any) -> None:
        m = len(self.names)
        self.kernel = _compile(self.function, "switching", f"({m},)", RHS_SIG)
        if self.jac is not None:
            shape = f"({m}, {model.nx + 1 + model.nu})"
            self.gradient = _compile(self.jac, "switching_jacobian", shape, JAC_SIG)

    def surface_rhs(self, model: Any) -> Any:
        """f of the model: its branches at the sides the state is on, the Filippov
        selection on a surface (:data:`sampledyn.models._jumps.SURFACE_RHS`); the
        branch kernel itself without jumps."""
        if not self.jumps:
            return model._rhs
        source = (
            "import numpy as np\nfrom numba import njit\n"
            "from sampledyn.models._base import RHS_SIG\n\nCACHE = _SAMPLEDYN_CACHE\n"
            + _jumps.surface_source(self.jumps, len(self.names), model._p.size)
            + "\nSIGNATURES = {'rhs': RHS_SIG}\n"
        )
        module = _codegen.load_module(
            source,
            kind="function_jumps",
            globals_={
                "_branch_k": model._rhs,
                "_switch_k": self.kernel,
                "_switch_grad_k": self.gradient,
                "decide": _jumps.decide,
                "sliding_weight": _jumps.sliding_weight,
                "stack_buffer": _closed_loop.stack_buffer,
            },
        )
        return _codegen.compiled(module, "rhs")

    def check_calls(self, model: Any, args: tuple) -> None:
        m = len(self.names)
        _checked_call(self.kernel, "switching", (m,), args)
        if self.gradient is not None:
            _checked_call(self.gradient, "switching_jacobian", (m, model.nx + 1 + model.nu), args)
        if self.jumps:
            q = np.concatenate([model._p, np.ones(len(self.jumps))])
            _checked_call(model._branch, "f", (model.nx,), (*args[:3], q))
