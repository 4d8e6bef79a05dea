"""Closed loops as compositions: a plant model and a continuous feedback law.

    x' = f(t, x, u),   u = kappa(t, x, r)     =>     x' = F(t, x, r) = f(t, x, kappa(t, x, r))

The closed loop is a model whose input is the reference r. Its kernel is generated
(and cached on disk, see :mod:`sampledyn.models._codegen`) from the plant's and the
law's kernels, which it calls as globals: the plant knows nothing about any
controller. Its Jacobian is exact by the chain rule,

    dF/dx = f_x + f_u kappa_x,      dF/dr = f_u kappa_r,

from the plant's ``jacobian`` and ``input_jacobian`` and the law's ``state_jacobian``
and ``reference_jacobian``. Its switching functions are the plant's, evaluated at the
applied input u = kappa(t, x, r), followed by the law's.

(A sampled digital controller, whose output is held between samples, is a different
composition: it is not a continuous-time model.)
"""

from __future__ import annotations

import threading
from types import ModuleType
from typing import Any

import numpy as np
from numba import njit, types
from numba.core.errors import TypingError
from numba.extending import intrinsic

from ..exceptions import JacobianUnavailableError
from . import _codegen
from ._base import JAC_BLOCK_ROWS, RHS_SIG, CompiledModel, LinearForm, _as_batch, _compiled
from ._jumps import refuse_jumps

__all__ = ["ClosedLoop", "FeedbackLaw", "LinearFeedback", "stack_buffer"]


@intrinsic
def stack_buffer(typingctx: Any, size: Any) -> Any:
    """A float64 work array of a literal ``size`` on the stack of the calling kernel
    (no heap allocation, no reference counting: a closed-loop kernel computes its
    plant input there on every call)."""
    if not isinstance(size, types.IntegerLiteral):
        raise TypingError(f"stack_buffer needs a literal integer size, got {size}.")
    n = max(int(size.literal_value), 1)
    retty = types.Array(types.float64, 1, "C")

    def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
        from numba.core import cgutils
        from numba.np.arrayobj import make_array, populate_array

        intp = types.intp
        data = cgutils.alloca_once(
            builder, context.get_value_type(types.float64), size=context.get_constant(intp, n)
        )
        ary = make_array(retty)(context, builder)
        populate_array(
            ary,
            data=data,
            shape=cgutils.pack_array(builder, [context.get_constant(intp, n)]),
            strides=cgutils.pack_array(builder, [context.get_constant(intp, 8)]),
            itemsize=context.get_constant(intp, 8),
            meminfo=None,
        )
        return ary._getvalue()

    return retty(size), codegen


@njit(cache=True, error_model="numpy")  # compiled for RHS_SIG on first use (kernel())
def linear_feedback(t, x, r, q, out):  # pragma: no cover - compiled
    """u = r + K x with K stored by its non-zero columns: q = [m, j_1..j_m, K[:, j]
    row-major (nu x m)]. Terms are added in increasing column order."""
    m = int(q[0])
    for i in range(out.shape[0]):
        v = r[i]
        row = 1 + m + i * m
        for k in range(m):
            v += q[row + k] * x[int(q[1 + k])]
        out[i] = v


class FeedbackLaw:
    """A continuous feedback law ``u = kappa(t, x, r)`` for :class:`ClosedLoop`.

    Subclasses set ``nx`` (plant states read), ``nr`` (references), ``nu`` (plant
    inputs produced) and implement :meth:`kernel`, :meth:`state_jacobian` and
    :meth:`reference_jacobian`; a law with kinks also :meth:`switch_kernel`.
    """

    nx: int
    nr: int
    nu: int
    reference_names: tuple[str, ...] | None = None
    reference_units: tuple[str, ...] | None = None

    def kernel(self) -> tuple[Any, np.ndarray]:
        """The compiled ``law(t, x, r, q, out)`` (out shape (nu,)) and its ``q``."""
        raise NotImplementedError

    def state_jacobian(self, t: Any, x: Any, r: Any) -> np.ndarray:
        """d kappa / dx, shape (N, nu, nx)."""
        raise NotImplementedError

    def reference_jacobian(self, t: Any, x: Any, r: Any) -> np.ndarray:
        """d kappa / dr, shape (N, nu, nr)."""
        raise NotImplementedError

    def switch_kernel(self) -> tuple[Any, np.ndarray, np.ndarray] | None:
        """Switching values of the law's kinks, as :meth:`CompiledModel.switch_kernel`;
        None for a smooth law."""
        return None


class LinearFeedback(FeedbackLaw):
    """``u = r + K x``: linear state feedback added to a reference of the plant input.

    Parameters
    ----------
    gain : array_like, shape (nu, nx)
        K, in plant-input units per state unit.
    reference_names, reference_units : sequence of str, optional
        Names and units of r (default: the plant's input names with ``_ref``, the
        plant's input units).
    """

    def __init__(
        self,
        gain: Any,
        *,
        reference_names: Any = None,
        reference_units: Any = None,
    ) -> None:
        k = np.array(gain, dtype=float)
        if k.ndim != 2 or k.size == 0:
            raise ValueError(f"`gain` must have shape (nu, nx), got {np.shape(gain)}.")
        if not np.isfinite(k).all():
            raise ValueError("`gain` must be finite.")
        k.setflags(write=False)
        self.gain = k
        self.nu, self.nx = k.shape
        self.nr = self.nu
        self.reference_names = None if reference_names is None else tuple(reference_names)
        self.reference_units = None if reference_units is None else tuple(reference_units)
        cols = np.flatnonzero((k != 0).any(axis=0))
        q = np.concatenate([[cols.size], cols, k[:, cols].ravel()]).astype(float)
        q.setflags(write=False)
        self._q = q
        self._eye = np.eye(self.nu)
        self._eye.setflags(write=False)

    def kernel(self) -> tuple[Any, np.ndarray]:
        return _compiled(linear_feedback, RHS_SIG), self._q

    def state_jacobian(self, t: Any, x: Any, r: Any) -> np.ndarray:
        """K for every state, shape (N, nu, nx) (read-only: K is constant)."""
        return _constant_rows(self.gain, x)

    def reference_jacobian(self, t: Any, x: Any, r: Any) -> np.ndarray:
        """I for every state, shape (N, nu, nr) (read-only)."""
        return _constant_rows(self._eye, x)


def _constant_rows(matrix: np.ndarray, x: Any) -> np.ndarray:
    """``matrix`` (read-only, 2-D) for each of the N states of ``x`` ((N, nx) or
    (nx,)): a read-only array of shape (N, *matrix.shape), a view without copies."""
    if type(x) is np.ndarray and x.ndim == 2:
        n = x.shape[0]
    else:
        n = np.atleast_2d(np.asarray(x, dtype=float)).shape[0]
    if n == 1:
        return matrix[None]
    return np.broadcast_to(matrix, (n, *matrix.shape))


_HEADER = """# Generated by sampledyn.models.ClosedLoop; do not edit (the file name is the hash
# of this text).
import numpy as np
from numba import njit

from sampledyn.models import _codegen
from sampledyn.models._base import BATCH_RHS_SIG, RHS_SIG

CACHE = _SAMPLEDYN_CACHE
"""

# p = [len(p_plant), len(q), p_plant..., q...];
# s = [len(s_plant), len(q), n switching values of the plant, s_plant..., q..., s_law...].
_BODY = """
NU = {nu}
_plant = njit(inline="always", error_model="numpy")(_plant_rhs.py_func)
_plant_switch = njit(inline="always", error_model="numpy")(_plant_sw.py_func)
_law = njit(inline="always", error_model="numpy")(_law_kernel.py_func)
{law_sw_inline}

@njit(cache=CACHE, error_model="numpy")
def rhs(t, x, r, p, out):  # pragma: no cover - compiled
    n_p = int(p[0])
    n_q = int(p[1])
    u = stack_buffer(NU)
    _law(t, x, r, p[2 + n_p:2 + n_p + n_q], u)
    _plant(t, x, u, p[2:2 + n_p], out)


@njit(cache=CACHE, error_model="numpy")
def sw(t, x, r, s, out):  # pragma: no cover - compiled
    n_s = int(s[0])
    n_q = int(s[1])
    n_sw = int(s[2])
    u = stack_buffer(NU)
    _law(t, x, r, s[3 + n_s:3 + n_s + n_q], u)
    _plant_switch(t, x, u, s[3:3 + n_s], out[:n_sw])
{law_sw_call}


@njit(cache=CACHE, error_model="numpy")
def law(t, x, r, p, out):  # pragma: no cover - compiled
    n_p = int(p[0])
    n_q = int(p[1])
    _law(t, x, r, p[2 + n_p:2 + n_p + n_q], out)
"""


# The plant's Jacobians at the applied input, for dF/dx = f_x + f_u kappa_x (the
# product is formed by numpy, as before: the same numbers).
_JAC_BODY = """
NU = {nu}
_plant_jac = njit(inline="always", error_model="numpy")(_plant_jac_k.py_func)
_plant_jac_u = njit(inline="always", error_model="numpy")(_plant_jac_u_k.py_func)
_law = njit(inline="always", error_model="numpy")(_law_kernel.py_func)


@njit(cache=CACHE, error_model="numpy")
def jacobian_parts(t, x, r, p):  # pragma: no cover - compiled
    n_p = int(p[0])
    n_q = int(p[1])
    n, nx = x.shape
    f_x = np.empty((n, nx, nx))
    f_u = np.empty((n, nx, NU))
    u = stack_buffer(NU)
    for i in range(n):
        _law(t[i], x[i], r[i], p[2 + n_p:2 + n_p + n_q], u)
        _plant_jac(t[i], x[i], u, p[2:2 + n_p], f_x[i])
        _plant_jac_u(t[i], x[i], u, p[2:2 + n_p], f_u[i])
    return f_x, f_u
"""


def _jacobian_source(plant_jac: Any, plant_jac_u: Any, law: Any, nu: int):
    """Source (and in-process globals, as :func:`_composition_source`) of
    ``jacobian_parts(t, x, r, p) -> (f_x, f_u)`` over a batch."""
    kernels = {
        "_plant_jac_k": plant_jac,
        "_plant_jac_u_k": plant_jac_u,
        "_law_kernel": law,
        "stack_buffer": stack_buffer,
    }
    lines = {
        name: _codegen.import_line(k, name) for name, k in kernels.items() if name != "stack_buffer"
    }
    lines["stack_buffer"] = _codegen.object_import_line(__name__, "stack_buffer", "stack_buffer")
    body = _JAC_BODY.format(nu=nu)
    if all(line is not None for line in lines.values()):
        imports = "\n".join(str(line) for line in lines.values())
        return _HEADER + imports + "\n" + body, None
    return _HEADER + body, kernels


def _composition_source(plant_rhs: Any, plant_sw: Any, law: Any, law_sw: Any, nu: int):
    """The generated source and, if some kernel cannot be imported by name, the
    globals to run it with in this process only."""
    kernels = {
        "_plant_rhs": plant_rhs,
        "_plant_sw": plant_sw,
        "_law_kernel": law,
        "stack_buffer": stack_buffer,
    }
    if law_sw is not None:
        kernels["_law_sw"] = law_sw
    lines = {
        name: _codegen.import_line(k, name) for name, k in kernels.items() if name != "stack_buffer"
    }
    lines["stack_buffer"] = _codegen.object_import_line(__name__, "stack_buffer", "stack_buffer")
    body = _BODY.format(
        nu=nu,
        law_sw_inline=(
            '_law_switch = njit(inline="always", error_model="numpy")(_law_sw.py_func)'
            if law_sw is not None
            else ""
        ),
        law_sw_call=(
            "    _law_switch(t, x, r, s[3 + n_s + n_q:], out[n_sw:])" if law_sw is not None else ""
        ),
    )
    batch = _codegen.BATCH_TEMPLATE.format(name="rhs", kernel="rhs", shape="x.shape[1]")
    batch += _codegen.BATCH_TEMPLATE.format(name="law", kernel="law", shape="NU")
    table = (
        "\nSIGNATURES = {\n    'rhs': RHS_SIG,\n    'sw': RHS_SIG,\n    'law': RHS_SIG,\n"
        "    'batch_rhs': BATCH_RHS_SIG,\n    'batch_law': BATCH_RHS_SIG,\n}\n"
    )
    if all(line is not None for line in lines.values()):
        imports = "\n".join(str(line) for line in lines.values())
        return _HEADER + imports + "\n" + body + batch + table, None
    return _HEADER + body + batch + table, kernels


class ClosedLoop(CompiledModel):
    """A plant model closed by a continuous feedback law; its input is the reference.

    Parameters
    ----------
    plant : CompiledModel
        Any compiled model (:class:`SymbolicModel`, :class:`Vehicle`,
        :class:`FunctionModel`, ...).
    law : FeedbackLaw
        ``u = kappa(t, x, r)`` with ``law.nx == plant.nx`` and ``law.nu == plant.nu``.
    name : str, optional
        Label (default: the plant's name with " + feedback").

    Notes
    -----
    :meth:`applied_input` gives the plant input the law applies, what a log records.
    :meth:`jacobian` is exact when the plant has ``input_jacobian`` (df/du); otherwise
    it raises :class:`JacobianUnavailableError` (no finite differences).
    """

    def __init__(self, plant: Any, law: FeedbackLaw, *, name: str | None = None) -> None:
        for attr in ("kernel", "nx", "nu"):
            if not hasattr(plant, attr):
                raise TypeError(
                    f"`plant` must be a compiled sampledyn model (with `{attr}`), got "
                    f"{type(plant).__name__}."
                )
        if not isinstance(law, FeedbackLaw):
            raise TypeError(
                f"`law` must be a sampledyn.models.FeedbackLaw, got {type(law).__name__}."
            )
        if law.nx != plant.nx or law.nu != plant.nu:
            raise ValueError(
                f"`law` maps {law.nx} states to {law.nu} inputs, the plant has "
                f"nx={plant.nx} and nu={plant.nu}."
            )
        refuse_jumps(
            plant, "plant", "a ClosedLoop does not carry the plant's branches of f, so its "
            "simulation could not cross or slide; write the loop as one SymbolicModel (the "
            "law substituted for the input).",
        )  # fmt: skip
        self.plant = plant
        self.law = law
        self._name = name
        self._module: ModuleType | None = None
        self._lock = threading.Lock()

    # The model protocol: states of the plant, inputs = references.
    @property
    def nx(self) -> int:  # type: ignore[override]
        return int(self.plant.nx)

    @property
    def nu(self) -> int:  # type: ignore[override]
        return int(self.law.nr)

    @property
    def state_names(self) -> tuple[str, ...]:  # type: ignore[override]
        return tuple(self.plant.state_names)

    @property
    def state_units(self) -> tuple[str, ...]:  # type: ignore[override]
        return tuple(self.plant.state_units)

    @property
    def input_names(self) -> tuple[str, ...]:  # type: ignore[override]
        if self.law.reference_names is not None:
            return tuple(self.law.reference_names)
        return tuple(f"{n}_ref" for n in self.plant.input_names)

    @property
    def input_units(self) -> tuple[str, ...]:  # type: ignore[override]
        if self.law.reference_units is not None:
            return tuple(self.law.reference_units)
        return tuple(self.plant.input_units)

    @property
    def name(self) -> str:
        if self._name is not None:
            return self._name
        return f"{getattr(self.plant, 'name', type(self.plant).__name__)} + feedback"

    @property
    def default_x0(self) -> np.ndarray:
        return np.asarray(self.plant.default_x0, dtype=float).copy()

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state["_module"] = None
        state.pop("_kernel_memo", None)
        state.pop("_parts_memo", None)
        del state["_lock"]
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._lock = threading.Lock()

    # ------------------------------------------------------------------ kernels
    def _load(self) -> ModuleType:
        if self._module is None:
            with self._lock:
                if self._module is None:
                    plant_rhs, _ = self.plant.kernel()
                    plant_sw, _, _ = self.plant.switch_kernel()
                    law_k, _ = self.law.kernel()
                    law_sw = self.law.switch_kernel()
                    source, injected = _composition_source(
                        plant_rhs, plant_sw, law_k, None if law_sw is None else law_sw[0],
                        int(self.plant.nu),
                    )  # fmt: skip
                    module = _codegen.load_module(source, kind="closed_loop", globals_=injected)
                    _codegen.register_batch(module.rhs, module, "batch_rhs")
                    _codegen.register_batch(module.law, module, "batch_law")
                    self._module = module
        return self._module

    def _p(self) -> np.ndarray:
        pp = np.asarray(self.plant.kernel()[1], dtype=float).ravel()
        q = np.asarray(self.law.kernel()[1], dtype=float).ravel()
        p = np.concatenate([[pp.size, q.size], pp, q])
        p.setflags(write=False)
        return p

    def kernel(self) -> tuple[Any, np.ndarray]:
        """The composed kernel ``F(t, x, r, p, out)`` and ``p = [len(p_plant), len(q),
        p_plant, q]``."""
        k = self.__dict__.get("_kernel_memo")
        if k is None:
            k = (_codegen.compiled(self._load(), "rhs"), self._p())
            self.__dict__["_kernel_memo"] = k
        return k

    def switch_kernel(self) -> tuple[Any, np.ndarray, np.ndarray]:
        """The plant's switching values at the applied input, then the law's."""
        _, sp_plant, only_plant = self.plant.switch_kernel()
        sp_plant = np.asarray(sp_plant, dtype=float).ravel()
        q = np.asarray(self.law.kernel()[1], dtype=float).ravel()
        n_sw = np.asarray(only_plant).size
        law_sw = self.law.switch_kernel()
        parts: list[Any] = [[sp_plant.size, q.size, n_sw], sp_plant, q]
        flags = [np.zeros(n_sw, dtype=bool)]  # through the law, the plant's depend on x
        if law_sw is not None:
            parts.append(np.asarray(law_sw[1], dtype=float).ravel())
            flags.append(np.asarray(law_sw[2], dtype=bool))
        sp = np.concatenate(parts)
        sp.setflags(write=False)
        return _codegen.compiled(self._load(), "sw"), sp, np.concatenate(flags)

    def applied_input(self, t: Any, x: Any, r: Any) -> np.ndarray:
        """The plant input the law applies, ``u = kappa(t, x, r)`` (what a log records).

        Parameters
        ----------
        t : float or ndarray, shape (N,)
        x : ndarray, shape (N, nx) or (nx,)
        r : ndarray, shape (N, nr) or (nr,)

        Returns
        -------
        ndarray, shape (N, nu_plant) (or (nu_plant,))
        """
        _, p = self.kernel()
        tt, xx, rr, single = _as_batch(t, x, r, self.nx, self.nu)
        batch = _codegen.batch_functions(self._load().law, None)
        out = batch(tt, xx, rr, p)
        return out[0] if single else out

    # ----------------------------------------------------------------- Jacobians
    def _plant_input_jacobian(self, t: Any, x: Any, u: Any) -> np.ndarray:
        fn = getattr(self.plant, "input_jacobian", None)
        try:
            if fn is None:
                raise JacobianUnavailableError("")
            return np.asarray(fn(t, x, u))
        except JacobianUnavailableError:
            raise JacobianUnavailableError(
                f"the closed loop's Jacobian df/dx + df/du dkappa/dx needs the plant's input "
                f"Jacobian df/du, and {type(self.plant).__name__} has none: give the plant "
                "an `input_jacobian(t, x, u)` of shape (N, nx, nu) (SymbolicModel derives "
                "it; FunctionModel takes `input_jac=`). sampledyn does not use finite "
                "differences."
            ) from None

    def _jacobian_parts(self) -> Any:
        """The compiled ``jacobian_parts(t, x, r, p) -> (f_x, f_u)``: the plant's
        Jacobians at the applied input in one call; None if the plant has no compiled
        Jacobian kernels (or they take other parameters than its right-hand side)."""
        memo = self.__dict__.get("_parts_memo")
        if memo is not None:
            return memo[0]
        parts = None
        try:
            jac, p_jac = self.plant.jacobian_kernel()
            jac_u, p_jac_u = self.plant.input_jacobian_kernel()
        except JacobianUnavailableError:
            jac = None
        if jac is not None:
            p_rhs = np.asarray(self.plant.kernel()[1])
            if np.array_equal(p_rhs, np.asarray(p_jac)) and np.array_equal(
                p_rhs, np.asarray(p_jac_u)
            ):
                law_k, _ = self.law.kernel()
                source, injected = _jacobian_source(jac, jac_u, law_k, int(self.plant.nu))
                module = _codegen.load_module(source, kind="closed_loop_jac", globals_=injected)
                parts = module.jacobian_parts
        self.__dict__["_parts_memo"] = (parts,)
        return parts

    def _plant_jacobians(self, t: Any, x: Any, r: Any) -> tuple[np.ndarray, np.ndarray]:
        """(f_x, f_u) of the plant at the applied input, shapes (N, nx, nx), (N, nx, nu)."""
        parts = self._jacobian_parts()
        if parts is None:
            ua = self.applied_input(t, x, r)
            f_u = self._plant_input_jacobian(t, x, ua)
            return np.asarray(self.plant.jacobian(t, x, ua)), f_u
        check = getattr(self.plant, "check_states", None)
        if check is not None:
            check(x)  # what the plant's own jacobian checks (a vehicle's pitch)
        p, rows = self.kernel()[1], JAC_BLOCK_ROWS
        if x.shape[0] <= rows:
            return parts(t, x, r, p)
        # in blocks, so that Ctrl-C and SIGTERM act between them (the same numbers)
        blocks = [parts(t[a : a + rows], x[a : a + rows], r[a : a + rows], p)
                  for a in range(0, x.shape[0], rows)]  # fmt: skip
        return np.concatenate([b[0] for b in blocks]), np.concatenate([b[1] for b in blocks])

    def _batch(self, t: Any, x: Any, r: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, Any]:
        """(t, x, r) as a batch, and whether it was one state: one float64 state
        (stepping a model from Python) becomes a batch of one without copies."""
        if (
            type(t) is float
            and type(x) is np.ndarray
            and type(r) is np.ndarray
            and x.shape == (self.nx,)
            and r.shape == (self.nu,)
            and x.dtype == np.float64
            and r.dtype == np.float64
        ):
            return np.array([t]), x.reshape(1, -1), r.reshape(1, -1), True
        return _as_batch(t, x, r, self.nx, self.nu)

    def jacobian(self, t: Any, x: Any, u: Any) -> np.ndarray:
        """Exact ``dF/dx = f_x + f_u kappa_x`` at the applied input; shape (N, nx, nx)
        (or (nx, nx)).

        The plant's f_x and f_u come from one compiled call when the plant has
        compiled Jacobian kernels (about 5 us for one state from Python, against 35 us
        through the plant's methods); the product and sum are numpy's in both cases.

        Raises
        ------
        JacobianUnavailableError
            If the plant has no ``input_jacobian``.
        """
        tt, xx, rr, single = self._batch(t, x, u)
        f_x, f_u = self._plant_jacobians(tt, xx, rr)
        k_x = np.asarray(self.law.state_jacobian(tt, xx, rr))
        out = f_x + f_u @ k_x
        return out[0] if single else out

    def input_jacobian(self, t: Any, x: Any, u: Any) -> np.ndarray:
        """Exact ``dF/dr = f_u kappa_r``; shape (N, nx, nr) (or (nx, nr))."""
        tt, xx, rr, single = self._batch(t, x, u)
        parts = self._jacobian_parts()
        if parts is None:
            ua = self.applied_input(tt, xx, rr)
            f_u = self._plant_input_jacobian(tt, xx, ua)
        else:
            f_u = self._plant_jacobians(tt, xx, rr)[1]
        out = f_u @ np.asarray(self.law.reference_jacobian(tt, xx, rr))
        return out[0] if single else out

    # --------------------------------------------------------- plant parameters
    @property
    def params(self) -> dict[str, float]:
        """The plant's parameters (the law's gains are not model parameters)."""
        return dict(self.plant.params)

    @property
    def param_names(self) -> tuple[str, ...]:
        return tuple(self.plant.param_names)

    @property
    def param_units(self) -> dict[str, str]:
        return dict(getattr(self.plant, "param_units", {}) or {})

    def with_params(self, **values: Any) -> ClosedLoop:
        """The same law around the plant with some parameters changed."""
        return ClosedLoop(self.plant.with_params(**values), self.law, name=self._name)

    def regressors(self, t: Any, x: Any, u: Any) -> LinearForm:
        """The plant's linear-in-parameters form at the applied input (the law does
        not depend on the plant's parameters, so they still enter linearly)."""
        fn = getattr(self.plant, "regressors", None)
        if fn is None:
            raise NotImplementedError(f"{type(self.plant).__name__} has no regressors.")
        tt, xx, rr, _ = _as_batch(t, x, u, self.nx, self.nu)
        return fn(tt, xx, self.applied_input(tt, xx, rr))
