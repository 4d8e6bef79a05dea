"""Compiled right-hand side and Jacobians of the 6-DoF vehicle, eqs. (3)-(7), (13)-(18).

One state at a time, scalar code without heap allocation: the same kernel is
called by the exact-sample integrator and, over a batch, by ``Vehicle.f``.

    eta' = J(eta) (v + v_c,body) + v_c,ned                                 (6)
    v'   = M^-1 (-C(v) v - D(v) v + g(eta) + B T(n, v) + tau_c)            (5)
    D(v) = D_l + diag(d_q) |v|       (D_l full 6 x 6, quadratic part diagonal)
    T_i  = K1 n_i |n_i| - K2 v_a,i |n_i|, v_a,i = B[:, i] . v              (7)
    n_i  = sat(u_i) = min(max(u_i, -n_max), n_max)   (thruster saturation)
    n'   = (sat(u) - n) / T_n        (thruster lag, eq. (3); optional)

With the lag option the saturated command drives the lag and the thrust comes from
the lagged rpm (as uuv_simulator's ThrusterPlugin clamps its command before the
rotor dynamics). With a wrench input u = tau enters eq. (5) directly.

The kernels are generated for the vehicle's sparsity pattern, straight-line code with
its structural zeros dropped (:mod:`~sampledyn.models._vehicle_codegen`), compiled on
first use and cached on disk by the hash of their source (the kernel cache of
:mod:`~sampledyn.models._codegen`). All values travel in one float64 array ``p`` with
the layout below (``N`` is the number of thrusters; ``B`` is stored thruster by
thruster, ``B[k, i] = p[_ALLOC + 6 i + k]``; matrices row-major), so vehicles that
differ in values only share their compiled kernels. The kernels read nothing past
``_ALLOC + 6 N``.
"""

from __future__ import annotations

import threading
from types import ModuleType
from typing import Any

import numpy as np

from . import _codegen
from ._vehicle_codegen import OFFSET_NAMES, Structure, vehicle_source

__all__ = ["VehicleKernels", "pack_params"]

# Layout of the parameter array p.
_N = 0  # number of thrusters
_LAG = 1  # 1.0 when the thruster rpm are states (eq. (3)), else 0.0
_TN = 2  # lag time constant T_n (s)
_K1 = 3  # N/rpm^2
_K2 = 4  # N s/(m rpm)
_W = 5  # weight (N)
_BUOY = 6  # buoyancy (N)
_NMAX = 7  # saturation n_max (rpm)
_RG = 8  # r_G (3, m)
_RB = 11  # r_B (3, m)
_DQ = 14  # quadratic damping diag (6)
_TAUC = 20  # cable force (6, body frame)
_VCB = 26  # current added inside J(eta)(v + v_c) (6, body frame)
_VCN = 32  # current added to eta' (6, NED / Euler-rate frame)
_DL = 38  # linear damping D_l row-major (36)
_M = 74  # M row-major (36)
_MINV = 110  # M^-1 row-major (36)
_WRENCH = 146  # 1.0 when the input is the commanded wrench tau itself (nu = 6, N = 0)
_WB = 147  # W - B (N), the heave part of g(eta)
_H = 148  # W r_G - B r_B (3, N m), the lever of the restoring moment
_INVTN = 151  # 1 / T_n (1/s)
_ALLOC = 152  # B (6 N), column i at _ALLOC + 6 i

_OFFSETS = {"K1": _K1, "K2": _K2, "NMAX": _NMAX, "DQ": _DQ, "TAUC": _TAUC, "VCB": _VCB,
            "VCN": _VCN, "DL": _DL, "M": _M, "MINV": _MINV, "WB": _WB, "H": _H,
            "INVTN": _INVTN, "ALLOC": _ALLOC}  # fmt: skip


def pack_params(
    *,
    n_thrusters: int,
    lag: bool,
    lag_time_constant: float,
    K1: float,
    K2: float,
    n_max: float,
    W: float,
    B: float,
    r_G: np.ndarray,
    r_B: np.ndarray,
    linear_damping: np.ndarray,
    quadratic_damping: np.ndarray,
    cable_force: np.ndarray,
    current_body: np.ndarray,
    current_ned: np.ndarray,
    M: np.ndarray,
    Minv: np.ndarray,
    allocation: np.ndarray,
    wrench_input: bool = False,
) -> np.ndarray:
    """The parameter array ``p`` of the kernels (read-only copy).

    ``linear_damping`` is the full D_l, shape (6, 6); ``quadratic_damping`` the
    diagonal d_q, shape (6,). With ``wrench_input`` the thrusters are bypassed: the
    six inputs are tau of eq. (5) (N, N m, body axes) and ``n_thrusters`` must be 0.
    ``W - B``, ``W r_G - B r_B`` and ``1 / T_n`` are stored too (computed here once,
    in the order the kernels used to compute them per state).
    """
    if wrench_input and n_thrusters:
        raise ValueError("`wrench_input` bypasses the thrusters: pack n_thrusters = 0.")
    p = np.zeros(_ALLOC + 6 * n_thrusters)
    p[_WRENCH] = 1.0 if wrench_input else 0.0
    p[_N] = n_thrusters
    p[_LAG] = 1.0 if lag else 0.0
    p[_TN] = lag_time_constant
    p[_K1] = K1
    p[_K2] = K2
    p[_NMAX] = n_max
    p[_W] = W
    p[_BUOY] = B
    p[_RG : _RG + 3] = r_G
    p[_RB : _RB + 3] = r_B
    p[_DQ : _DQ + 6] = quadratic_damping
    p[_TAUC : _TAUC + 6] = cable_force
    p[_VCB : _VCB + 6] = current_body
    p[_VCN : _VCN + 6] = current_ned
    p[_DL : _DL + 36] = np.asarray(linear_damping, dtype=float).reshape(36)
    p[_M : _M + 36] = np.asarray(M, dtype=float).reshape(36)
    p[_MINV : _MINV + 36] = np.asarray(Minv, dtype=float).reshape(36)
    p[_WB] = W - B
    p[_H : _H + 3] = [W * p[_RG + i] - B * p[_RB + i] for i in range(3)]
    p[_INVTN] = 1.0 / lag_time_constant
    p[_ALLOC : _ALLOC + 6 * n_thrusters] = np.asarray(allocation, dtype=float).T.ravel()
    p.setflags(write=False)
    return p


def structure(p: np.ndarray) -> Structure:
    """The sparsity pattern of a packed ``p`` (what the generated code depends on)."""
    nz = p != 0.0
    nt = int(p[_N])

    def square(at: int) -> tuple[tuple[bool, ...], ...]:
        return tuple(tuple(bool(b) for b in nz[at + 6 * i : at + 6 * i + 6]) for i in range(6))

    def vector(at: int, size: int = 6) -> tuple[bool, ...]:
        return tuple(bool(b) for b in nz[at : at + size])

    return Structure(
        n_thrusters=nt,
        lag=bool(p[_LAG] > 0.5),
        wrench=bool(p[_WRENCH] > 0.5),
        mass=square(_M),
        minv=square(_MINV),
        damping=square(_DL),
        quadratic=vector(_DQ),
        cable=vector(_TAUC),
        current_body=vector(_VCB),
        current_ned=vector(_VCN),
        moment=vector(_H, 3),
        heave=bool(nz[_WB]),
        k1=bool(nz[_K1]),
        k2=bool(nz[_K2]),
        allocation=tuple(vector(_ALLOC + 6 * i) for i in range(nt)),
        offsets=tuple(_OFFSETS[n] for n in OFFSET_NAMES),
    )


_LOCK = threading.Lock()
_HANDLES: dict[Structure, VehicleKernels] = {}


class VehicleKernels:
    """The generated kernels of one sparsity pattern, compiled on first use.

    One per pattern and process (:meth:`of`); pickled as the pattern, so a worker
    process loads (or compiles) its own. Each accessor returns the numba dispatcher
    compiled for the kernel signatures of :mod:`sampledyn.models._base`.
    """

    def __init__(self, pattern: Structure) -> None:
        self.pattern = pattern
        self._module: ModuleType | None = None

    @classmethod
    def of(cls, p: np.ndarray) -> VehicleKernels:
        """The kernels for the pattern of ``p`` (shared by every vehicle with it)."""
        pattern = structure(p)
        with _LOCK:
            handle = _HANDLES.get(pattern)
            if handle is None:
                handle = _HANDLES[pattern] = cls(pattern)
        return handle

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        return _handle, (self.pattern,)

    @property
    def source(self) -> str:
        """The generated Python source."""
        return vehicle_source(self.pattern)

    @property
    def module(self) -> ModuleType:
        """The generated module (written to the kernel cache and imported once)."""
        if self._module is None:
            with _LOCK:
                if self._module is None:
                    module = _codegen.load_module(self.source, kind="vehicle")
                    for kernel in ("rhs", "jac", "jac_u"):
                        _codegen.register_batch(getattr(module, kernel), module, f"batch_{kernel}")
                    self._module = module
        return self._module

    def get(self, kernel: str) -> Any:
        """Kernel ``rhs``, ``jac``, ``jac_u``, ``sw`` (or a ``batch_*``), compiled."""
        return _codegen.compiled(self.module, kernel)


def _handle(pattern: Structure) -> VehicleKernels:
    with _LOCK:
        handle = _HANDLES.get(pattern)
        if handle is None:
            handle = _HANDLES[pattern] = VehicleKernels(pattern)
    return handle
