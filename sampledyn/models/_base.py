"""The model protocol and the compiled batch evaluation shared by every model.

A model is continuous-time physics only: ``x' = f(t, x, u; p)``. Each concrete model
provides one numba-compiled *kernel* ``rhs(t, x, u, p, out)`` for a single state;
:func:`sampledyn.simulate` integrates that kernel, and :meth:`Model.f` evaluates the
same kernel over a batch of samples, so there is one source of truth per model.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numba import float64, njit, types

__all__ = [
    "JAC_SIG",
    "RHS_SIG",
    "CompiledModel",
    "LinearForm",
    "Model",
    "batch_eval",
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


@njit(
    float64[:, ::1](RHS_TYPE, RO1, RO2, RO2, RO1),
    cache=True,
)
def _batch_rhs(rhs, t, x, u, p):  # pragma: no cover - compiled
    n, nx = x.shape
    out = np.empty((n, nx))
    for i in range(n):
        rhs(t[i], x[i], u[i], p, out[i])
    return out


@njit(
    float64[:, :, ::1](JAC_TYPE, RO1, RO2, RO2, RO1),
    cache=True,
)
def _batch_jac(jac, t, x, u, p):  # pragma: no cover - compiled
    n, nx = x.shape
    out = np.empty((n, nx, nx))
    for i in range(n):
        jac(t[i], x[i], u[i], p, out[i])
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


def _as_batch(t: Any, x: Any, u: Any, nx: int, nu: int) -> tuple[np.ndarray, ...]:
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
    t = np.ascontiguousarray(np.broadcast_to(np.asarray(t, dtype=float), (n,)))
    return t, x, u, np.array(single)


def batch_eval(kernel: Callable[..., None], p: Any, t: Any, x: Any, u: Any, nx: int, nu: int):
    """Evaluate a compiled ``kernel(t, x, u, p, out)`` on a batch of samples."""
    t, x, u, single = _as_batch(t, x, u, nx, nu)
    out = _batch_rhs(kernel, readonly(t), readonly(x), readonly(u), readonly(p))
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
    """Continuous-time dynamics ``x' = f(t, x, u)``; never a stepping scheme."""

    nx: int
    nu: int
    state_names: tuple[str, ...]
    state_units: tuple[str, ...]
    input_names: tuple[str, ...]
    input_units: tuple[str, ...]

    def f(self, t: Any, x: Any, u: Any) -> np.ndarray:
        """Right-hand side; x shape (N, nx), u shape (N, nu) -> (N, nx)."""
        ...

    def jacobian(self, t: Any, x: Any, u: Any) -> np.ndarray:
        """d f / d x; shape (N, nx, nx)."""
        ...


class CompiledModel:
    """Base class of the built-in models: ``f`` and ``jacobian`` from compiled kernels.

    Subclasses set ``nx``, ``nu``, names and units, and implement :meth:`kernel`
    (returning the compiled rhs and its parameter array) and :meth:`jacobian_kernel`.
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
        raise NotImplementedError

    @property
    def default_x0(self) -> np.ndarray:
        """Initial state used by :func:`sampledyn.simulate` when none is given."""
        return np.zeros(self.nx)

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
        if np.ndim(x) == 1 and np.ndim(t) == 0:
            # One state (e.g. inside an ODE solver): call the kernel directly; the
            # batch path costs ~0.1 ms of dispatch per call.
            xs, us = _single(x, u, self.nx, self.nu)
            out = np.empty(self.nx)
            rhs(float(t), xs, us, readonly(p), out)
            return out
        return batch_eval(rhs, p, t, x, u, self.nx, self.nu)

    def jacobian(self, t: Any, x: Any, u: Any) -> np.ndarray:
        """Analytic Jacobian ``df/dx``, shape (N, nx, nx) (or (nx, nx))."""
        jac, p = self.jacobian_kernel()
        if np.ndim(x) == 1 and np.ndim(t) == 0:
            xs, us = _single(x, u, self.nx, self.nu)
            out = np.empty((self.nx, self.nx))
            jac(float(t), xs, us, readonly(p), out)
            return out
        tt, xx, uu, single = _as_batch(t, x, u, self.nx, self.nu)
        out = _batch_jac(jac, readonly(tt), readonly(xx), readonly(uu), readonly(p))
        return out[0] if single else out
