"""The paper's 6-DoF vehicle in Fossen form, eqs. (1)-(7), with analytic Jacobians (13)-(18).

    eta' = J(eta) (v + v_c)                                                (6)
    v'   = M^-1 (-C(v) v - D(v) v + g(eta) + tau + tau_c)                  (5)
    tau  = B T,   T_i = K1 n_i |n_i| - K2 v_a,i |n_i|                      (7)
    n_i  = sat(u_i) = min(max(u_i, -n_max), n_max)   (thruster saturation)
    n'   = (sat(n_r) - n) / T_n   (optional thruster lag, eq. (3))

* ``M = M_RB + M_A``: rigid body about the body origin CO (mass, inertia tensor
  about the centre of gravity r_G, with products of inertia) plus the added mass
  M_A, diagonal or a full symmetric 6 x 6 matrix.
* ``C(v) = C_RB(v) + C_A(v)``, both from the 3 x 3 blocks of the symmetric M in
  the skew-symmetric form of Fossen 2011, Theorem 3.2 (eq. 3.46) and eq. 6.43:
  with ``(a, b) = M v``, ``C(v) = [[0, -S(a)], [-S(a), -S(b)]]``; M is linear in
  its parts, so this is C_RB(v) from M_RB plus C_A(v) from the full M_A.
* ``D(v) = D_l + diag(d_q) |v|``: linear damping diagonal or a full 6 x 6 matrix,
  quadratic damping diagonal per degree of freedom (Fossen 2011, ch. 6; as in
  uuv_simulator's ``HMFossen::ComputeDampingMatrix``).
* ``g(eta)`` = restoring force of weight W = m g at r_G and buoyancy B = rho g V at
  r_B, with the paper's sign (added in eq. (5), i.e. minus Fossen's eq. 4.6).
* ``J(eta) = diag(R(Theta), T(Theta))`` with ZYX Euler angles; singular at
  theta = +-90 deg.
* Thrusters: T_i along the unit axis d_i at r_i; the allocation B (6 x N) has
  columns ``[d_i; r_i x d_i]`` and ``v_a,i = B[:, i] . v`` is the thruster's body
  velocity along its axis. The input is the thruster rpm (rev/min), saturated at
  n_max. The inflow term is ``K2 v_a |n|`` (Fossen 2011, eq. 6.116 form
  ``T_|n|Va |n| V_a``): the paper's ``K2 v^T n`` read literally as ``K2 v_a n``
  would make a thruster spinning in reverse *gain* thrust when the vehicle moves
  the way it pushes.

State ``x = (eta, v)`` (12) or ``(eta, v, n)`` (12 + N) with the lag option.

Commanded wrench as the input (``wrench_input=True``): many vehicle stacks log the
body force and moment their controller commanded instead of thruster commands; then
u = tau = (X, Y, Z, K, M, N) (N, N m, body axes; Fossen's names) enters eq. (5)
directly and the thrusters of eq. (7) are bypassed (no saturation, no inflow term).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

from .. import _checks as checks
from ..exceptions import VehicleParameterError
from ._base import JAC_BLOCK_ROWS, CompiledModel, LinearForm, _as_batch, in_row_blocks, readonly
from ._rigid_body import (
    check_pitch,
    coriolis_matrix,
    restoring_force,
    rigid_body_mass_matrix,
    rotation_jacobian,
    thruster_allocation,
)
from ._vehicle_kernels import VehicleKernels, pack_params

__all__ = ["SYMMETRY_RTOL", "AsymmetricPair", "Vehicle", "symmetrized"]

_ETA_NAMES = ("x", "y", "z", "phi", "theta", "psi")
_V_NAMES = ("u", "v", "w", "p", "q", "r")
_ETA_UNITS = ("m", "m", "m", "rad", "rad", "rad")
_V_UNITS = ("m/s", "m/s", "m/s", "rad/s", "rad/s", "rad/s")
# tau of eq. (5) when the wrench is the input (Fossen 2011, Table 2.1: X, Y, Z, K, M, N)
WRENCH_NAMES = ("X", "Y", "Z", "K", "M", "N")
WRENCH_UNITS = ("N", "N", "N", "N m", "N m", "N m")

# Scalar parameter names (Fossen / SNAME notation). The hydrodynamic coefficients are
# stored as positive magnitudes: M_A = diag(X_udot, ...), D_l = diag(X_u, ...),
# D_q = diag(X_uu, ...); Fossen's X_udot, X_u, X_|u|u are minus these. With a full
# M_A or D_l these names are its diagonal entries.
ADDED_MASS_NAMES = ("X_udot", "Y_vdot", "Z_wdot", "K_pdot", "M_qdot", "N_rdot")
LINEAR_DAMPING_NAMES = ("X_u", "Y_v", "Z_w", "K_p", "M_q", "N_r")
QUADRATIC_DAMPING_NAMES = ("X_uu", "Y_vv", "Z_ww", "K_pp", "M_qq", "N_rr")
_ADDED_MASS_UNITS = ("kg",) * 3 + ("kg m^2",) * 3
_LINEAR_UNITS = ("N s/m",) * 3 + ("N m s/rad",) * 3
_QUADRATIC_UNITS = ("N s^2/m^2",) * 3 + ("N m s^2/rad^2",) * 3

QUADRATIC_IS_DIAGONAL = (
    "is diagonal, D_n(v) = diag(d_q) |v| (as in Fossen's and uuv_simulator's models): "
    "give its 6 diagonal entries."
)

# A published symmetric matrix (inertia tensor, added mass) is often symmetric only to
# the digits it is printed with: the pair (i, j), (j, i) is replaced by its mean when
# |A_ij - A_ji| <= SYMMETRY_RTOL max(|A_ij|, |A_ji|), with a warning unless the vehicle
# file declares that pair (see `symmetrized`); a larger difference is refused. 1e-3
# covers rounding in the 4th significant digit.
SYMMETRY_RTOL = 1e-3

# name -> (field, index): an int is entry i of a vector (the diagonal entry (i, i) of
# a matrix); a pair (i, j) is a product of inertia, I_ij = -I_g[i, j] (Fossen 2011,
# eq. 3.33).
_PARAMS: dict[str, tuple[str, int | tuple[int, int] | None]] = {
    "mass": ("mass", None),
    "Ix": ("inertia", 0),
    "Iy": ("inertia", 1),
    "Iz": ("inertia", 2),
    "Ixy": ("inertia", (0, 1)),
    "Ixz": ("inertia", (0, 2)),
    "Iyz": ("inertia", (1, 2)),
    "x_G": ("r_G", 0),
    "y_G": ("r_G", 1),
    "z_G": ("r_G", 2),
    "x_B": ("r_B", 0),
    "y_B": ("r_B", 1),
    "z_B": ("r_B", 2),
    "volume": ("volume", None),
    "rho": ("rho", None),
    "g": ("g", None),
    **{n: ("added_mass", i) for i, n in enumerate(ADDED_MASS_NAMES)},
    **{n: ("linear_damping", i) for i, n in enumerate(LINEAR_DAMPING_NAMES)},
    **{n: ("quadratic_damping", i) for i, n in enumerate(QUADRATIC_DAMPING_NAMES)},
    "K1": ("K1", None),
    "K2": ("K2", None),
    "n_max": ("n_max", None),
    "T_n": ("lag_time_constant", None),
}
PARAM_UNITS: dict[str, str] = {
    "mass": "kg",
    **{n: "kg m^2" for n in ("Ix", "Iy", "Iz", "Ixy", "Ixz", "Iyz")},
    **{n: "m" for n in ("x_G", "y_G", "z_G", "x_B", "y_B", "z_B")},
    "volume": "m^3",
    "rho": "kg/m^3",
    "g": "m/s^2",
    **dict(zip(ADDED_MASS_NAMES, _ADDED_MASS_UNITS, strict=True)),
    **dict(zip(LINEAR_DAMPING_NAMES, _LINEAR_UNITS, strict=True)),
    **dict(zip(QUADRATIC_DAMPING_NAMES, _QUADRATIC_UNITS, strict=True)),
    "K1": "N/rpm^2",
    "K2": "N s/(m rpm)",
    "n_max": "rpm",
    "T_n": "s",
}


def _array(name: str, value: Any, shapes: tuple[tuple[int, ...], ...]) -> np.ndarray:
    """``value`` as a finite float array of one of ``shapes``."""
    want = " or ".join(str(s) for s in shapes)
    try:
        a = np.array(value, dtype=float) if not isinstance(value, str) else None
    except (TypeError, ValueError):
        a = None
    if a is None or a.shape not in shapes:
        got = a.shape if a is not None else repr(value)
        raise VehicleParameterError(name, f"`{name}` must have shape {want}, got {got}.")
    bad = np.argwhere(~np.isfinite(a))
    if bad.size:
        at = ", ".join(str(int(i)) for i in bad[0])
        raise VehicleParameterError(name, f"`{name}[{at}]` must be finite, got {a[tuple(bad[0])]}.")
    big = np.argwhere(np.abs(a) > MAX_PARAMETER)
    if big.size:
        at = ", ".join(str(int(i)) for i in big[0])
        raise VehicleParameterError(name, _too_big(f"{name}[{at}]", a[tuple(big[0])]))
    return a


#: Largest magnitude of a vehicle parameter in SI units: 1e12 kg is a mountain; beyond
#: it the dynamics' products (M v, the weight m g, damping times squared speeds)
#: overflow double precision within a few steps, and the first sign is a NaN state.
MAX_PARAMETER = 1e12


def _too_big(name: str, value: float) -> str:
    return (
        f"`{name}` = {value:.4g} is beyond {MAX_PARAMETER:g} in SI units: no vehicle is that "
        "big, and the dynamics would overflow to NaN; check the unit and the exponent."
    )


def _frozen(a: np.ndarray) -> tuple[Any, ...]:
    """A 1-D or 2-D array as a tuple (of tuples) of floats."""
    if a.ndim == 1:
        return tuple(float(c) for c in a)
    return tuple(tuple(float(c) for c in row) for row in a)


#: An asymmetric pair of a matrix: (i, j, A_ij, A_ji) with i < j (0-based).
AsymmetricPair = tuple[int, int, float, float]


def symmetrized(
    name: str,
    a: np.ndarray,
    *,
    declared: Sequence[AsymmetricPair] | None = None,
    rtol: float = SYMMETRY_RTOL,
    stacklevel: int = 2,
) -> np.ndarray:
    """``a`` made exactly symmetric by the printed-digits rule: a pair (i, j), (j, i)
    with |A_ij - A_ji| <= rtol max(|A_ij|, |A_ji|) is replaced by its mean, (A + A^T)/2.

    Parameters
    ----------
    name : str
        The argument (or field) the matrix came from, named in messages.
    a : ndarray, shape (n, n)
    declared : sequence of (i, j, A_ij, A_ji), optional
        The asymmetric pairs the source of ``a`` is known to have (a vehicle file's
        ``symmetrised`` declaration, i < j, 0-based): averaged without a warning. The
        declaration must be exact: every declared pair holds those two values, and
        ``a`` has no other asymmetric pair. None: every averaged pair is warned about.
    rtol : float
        Relative tolerance, at most :data:`SYMMETRY_RTOL`.

    Returns
    -------
    ndarray, shape (n, n)
        The symmetric matrix (``a`` itself where it was symmetric).

    Raises
    ------
    VehicleParameterError
        Naming the worst pair beyond the tolerance (whether declared or not), a
        declared pair that ``a`` does not hold, or an asymmetric pair a declaration
        leaves out.

    Warns
    -----
    UserWarning
        Without a declaration, naming every pair it averages.
    """
    if not 0 < rtol <= SYMMETRY_RTOL:
        raise ValueError(f"`rtol` must be in (0, {SYMMETRY_RTOL:g}], got {rtol!r}.")
    diff = np.abs(a - a.T)
    scale = np.maximum(np.abs(a), np.abs(a.T))
    rows, cols = np.triu_indices(a.shape[0], 1)
    d, sc = diff[rows, cols], scale[rows, cols]
    beyond = d > rtol * sc
    if beyond.any():
        k = int(np.argmax(np.where(beyond, d / np.where(sc > 0, sc, 1.0), -1.0)))
        i, j = int(rows[k]), int(cols[k])
        raise VehicleParameterError(
            name,
            f"`{name}` must be symmetric: [{i}, {j}] = {a[i, j]:.6g} and [{j}, {i}] = "
            f"{a[j, i]:.6g} differ by {d[k]:.3g} ({d[k] / sc[k]:.2g} relative), more than "
            f"the {rtol:g} relative tolerance for printed digits; correct the matrix.",
        )
    found = {(int(rows[k]), int(cols[k])): k for k in np.flatnonzero(d > 0)}
    if declared is not None:
        _check_declaration(name, a, found, declared)
    elif found:
        shown = "; ".join(
            f"[{i}, {j}] = {a[i, j]:.6g} vs [{j}, {i}] = {a[j, i]:.6g} (difference "
            f"{d[k]:.3g}, {d[k] / sc[k]:.2g} relative)"
            for (i, j), k in found.items()
        )
        warnings.warn(
            f"`{name}` is symmetric only to its printed digits: {shown}; within the "
            f"{rtol:g} relative tolerance, so the mean (A + A^T)/2 is used (a vehicle "
            "file states this with a `symmetrised` declaration, which silences this "
            "warning).",
            UserWarning,
            stacklevel=stacklevel,
        )
    return 0.5 * (a + a.T) if found else a


def _check_declaration(
    name: str,
    a: np.ndarray,
    found: Mapping[tuple[int, int], Any],
    declared: Sequence[AsymmetricPair],
) -> None:
    """The declared asymmetric pairs are exactly those of ``a``, with their values."""
    n = a.shape[0]
    listed = set()
    for i, j, upper, lower in declared:
        if not 0 <= i < j < n:
            raise VehicleParameterError(
                name, f"`{name}`: declared pair [{i}, {j}] must have 0 <= i < j < {n}."
            )
        if (a[i, j], a[j, i]) != (upper, lower):
            raise VehicleParameterError(
                name,
                f"`{name}`: the declared asymmetry [{i}, {j}] = {upper:.6g} vs [{j}, {i}] = "
                f"{lower:.6g} is not in the matrix, which has [{i}, {j}] = {a[i, j]:.6g} and "
                f"[{j}, {i}] = {a[j, i]:.6g}; update the declaration with the matrix.",
            )
        listed.add((i, j))
    missing = sorted(set(found) - listed)
    if missing:
        i, j = missing[0]
        raise VehicleParameterError(
            name,
            f"`{name}` is also asymmetric at [{i}, {j}] = {a[i, j]:.6g} vs [{j}, {i}] = "
            f"{a[j, i]:.6g}, which its declaration does not list; add the pair to it.",
        )


def _scalar(name: str, value: Any, *, positive: bool = False, nonneg: bool = False) -> float:
    check = checks.positive if positive else checks.number
    v = check(value, name, error=VehicleParameterError, types=VehicleParameterError)
    if abs(v) > MAX_PARAMETER:
        raise VehicleParameterError(name, _too_big(name, v))
    if nonneg and v < 0:
        raise VehicleParameterError(name, f"`{name}` must be >= 0, got {v}.")
    return v


def _component(value: Any, idx: int | tuple[int, int]) -> float:
    """Parameter ``idx`` (see ``_PARAMS``) of a vector or matrix field."""
    a = np.asarray(value, dtype=float)
    if isinstance(idx, tuple):
        return 0.0 if a.ndim == 1 else float(-a[idx])
    return float(a[idx] if a.ndim == 1 else a[idx, idx])


def _with_component(value: Any, idx: int | tuple[int, int], new: Any) -> np.ndarray:
    """A copy of a vector or matrix field with parameter ``idx`` set to ``new``."""
    a = np.array(value, dtype=float)
    if isinstance(idx, tuple):
        if a.ndim == 1:
            a = np.diag(a)
        a[idx] = a[idx[::-1]] = -float(new)
    elif a.ndim == 1:
        a[idx] = new
    else:
        a[idx, idx] = new
    return a


def _as_matrix(value: tuple[Any, ...], size: int) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    return np.diag(a) if a.shape == (size,) else a


@dataclass(frozen=True)
class Vehicle(CompiledModel):
    """6-DoF underwater vehicle in Fossen form, eqs. (5)-(7), input = thruster rpm.

    Usually built from a vehicle file by :func:`sampledyn.models.load_vehicle`.
    Array-like arguments are stored as tuples (matrices as tuples of rows); the model
    is immutable and :meth:`with_params` returns a changed copy.

    Parameters
    ----------
    mass : float
        Mass m (kg).
    inertia : array_like, shape (3,) or (3, 3)
        Inertia about the centre of gravity in body axes (kg m^2): the moments
        (I_x, I_y, I_z) of a diagonal tensor, or the full symmetric positive definite
        tensor ``[[I_x, -I_xy, -I_xz], [-I_xy, I_y, -I_yz], [-I_xz, -I_yz, I_z]]``
        (Fossen 2011, eq. 3.33).
    r_G, r_B : array_like, shape (3,)
        Centres of gravity and buoyancy in body axes from the body origin (m).
    volume : float
        Displaced volume V (m^3); buoyancy B = rho g V.
    added_mass : array_like, shape (6,) or (6, 6)
        Added mass M_A, positive magnitudes: ``diag(added_mass)`` or the full
        symmetric matrix (kg, kg m, kg m^2 by block).
    linear_damping : array_like, shape (6,) or (6, 6)
        D_l, ``diag(linear_damping)`` or the full matrix (N s/m, N s/rad, N s,
        N m s/rad by block).
    quadratic_damping : array_like, shape (6,)
        d_q of the diagonal ``D_n(v) = diag(d_q) |v|`` (N s^2/m^2, N m s^2/rad^2).
    thruster_positions, thruster_directions : array_like, shape (N, 3)
        Thruster positions r_i (m) and unit thrust axes d_i (body axes); a positive
        rpm pushes the vehicle along d_i.
    K1 : float
        Thrust coefficient of eq. (7) (N/rpm^2); the paper's matrix is K1 I.
    K2 : float
        Inflow coefficient of eq. (7) (N s/(m rpm)); the paper's matrix is K2 I.
    n_max : float
        Maximum thruster speed (rpm). The thrusters saturate there: the applied rpm
        is ``clip(n, -n_max, n_max)`` (a kink the exact simulator locates), and
        :func:`sampledyn.simulate` warns when the command exceeds it.
    rho : float
        Water density (kg/m^3). Default 1000.
    g : float
        Gravity (m/s^2). Default 9.81.
    lag_time_constant : float
        T_n of the first-order thruster lag (s), used when ``thruster_lag``.
    thruster_lag : bool
        Model eq. (3) as ``n' = (sat(n_r) - n) / T_n`` with the N rpm as extra states;
        off by default (the paper's case study treats it as parasitic).
    current : array_like, shape (6,)
        Constant current v_c (m/s, rad/s). With ``current_frame="body"`` (default)
        it enters as in eq. (6), ``eta' = J(eta)(v + v_c)``: a body-frame velocity.
        With ``"ned"`` it is a constant NED velocity added to eta'
        (``eta' = J(eta) v + v_c``; the angular part is then Euler-angle rates).
        As in the paper, the current does not enter the damping of eq. (5).
    current_frame : {"body", "ned"}
    cable_force : array_like, shape (6,)
        Constant cable force tau_c in body axes (N, N m), eq. (5).
    pitch_limit_deg : float
        ``f`` and ``jacobian`` warn when some |theta| exceeds this (deg). Default 80:
        there 1/cos(theta) = 5.8, and the norms of J and dJ/deta (eqs. (22)-(23))
        make prediction errors grow (the paper advises |theta| well below 40 deg).
    pitch_tolerance_deg : float
        ``f`` and ``jacobian`` raise ValueError when some |theta| is within this of
        90 deg, where J(eta) is singular. Default 0.5 (1/cos(theta) = 115).
    wrench_input : bool
        The input is the commanded wrench tau = (X, Y, Z, K, M, N) of eq. (5) (N,
        N m, body axes), thrusters bypassed (nu = 6); off by default (thruster rpm).
        Not with ``thruster_lag``.
    name : str
        Label.
    sources : mapping, optional
        Where each parameter came from (filled by the vehicle-file loader).

    Raises
    ------
    VehicleParameterError (a ValueError)
        Naming the argument: wrong shape, non-finite value, an inertia tensor or
        M = M_RB + M_A that is not symmetric positive definite, a symmetric matrix
        whose mirror entries differ by more than :data:`SYMMETRY_RTOL` (relative).

    Warns
    -----
    UserWarning
        When ``inertia`` or ``added_mass`` is symmetric only within
        :data:`SYMMETRY_RTOL`: each such pair is replaced by its mean (named in the
        warning) and the symmetric matrix is stored.
    """

    mass: float
    inertia: tuple[Any, ...]
    r_G: tuple[float, ...]
    r_B: tuple[float, ...]
    volume: float
    added_mass: tuple[Any, ...]
    linear_damping: tuple[Any, ...]
    quadratic_damping: tuple[float, ...]
    thruster_positions: tuple[tuple[float, ...], ...]
    thruster_directions: tuple[tuple[float, ...], ...]
    K1: float
    K2: float
    n_max: float
    rho: float = 1000.0
    g: float = 9.81
    lag_time_constant: float = 0.1
    thruster_lag: bool = False
    current: tuple[float, ...] = (0.0,) * 6
    current_frame: str = "body"
    cable_force: tuple[float, ...] = (0.0,) * 6
    pitch_limit_deg: float = 80.0
    pitch_tolerance_deg: float = 0.5
    wrench_input: bool = False
    name: str = "vehicle"
    sources: Mapping[str, str] = field(default_factory=dict, compare=False, repr=False)

    # Derived in __post_init__.
    n_thrusters: int = field(init=False, repr=False, compare=False)
    weight: float = field(init=False, repr=False, compare=False)  # W = m g (N)
    buoyancy: float = field(init=False, repr=False, compare=False)  # B = rho g V (N)
    _M: np.ndarray = field(init=False, repr=False, compare=False)
    _Minv: np.ndarray = field(init=False, repr=False, compare=False)
    _alloc: np.ndarray = field(init=False, repr=False, compare=False)
    _p: np.ndarray = field(init=False, repr=False, compare=False)
    _kernels: VehicleKernels = field(init=False, repr=False, compare=False)

    param_units = PARAM_UNITS

    @property
    def kink_states(self) -> tuple[int, ...]:
        """State indices inside ``|.|`` (damping |v| v; thruster n |n| with lag). The
        complete set of switching values, with the saturation, is
        :meth:`switch_kernel`."""
        lag = tuple(range(12, 12 + self.n_thrusters)) if self.thruster_lag else ()
        return tuple(range(6, 12)) + lag

    @property
    def kink_inputs(self) -> tuple[int, ...]:
        """Input indices inside ``|.|`` (thruster rpm n |n| without the lag option;
        none for a wrench input)."""
        if self.thruster_lag or self.wrench_input:
            return ()
        return tuple(range(self.n_thrusters))

    def __post_init__(self) -> None:
        put = object.__setattr__
        self._check_masses()
        self._check_scalars()
        pos, dirs = self._check_thrusters()
        m_rb = rigid_body_mass_matrix(self.mass, self.inertia_tensor, self.r_G)
        M = m_rb + self.added_mass_matrix
        if not np.allclose(M, M.T, rtol=0.0, atol=1e-12 * np.abs(M).max()):
            raise VehicleParameterError("added_mass", "M = M_RB + M_A is not symmetric.")
        try:
            np.linalg.cholesky(M)
        except np.linalg.LinAlgError:
            raise VehicleParameterError(
                "added_mass",
                "M = M_RB + M_A is not positive definite (eigenvalues "
                f"{np.round(np.linalg.eigvalsh(M), 6).tolist()}); check `added_mass`, "
                "`mass`, `inertia` and `r_G`.",
            ) from None
        minv = np.linalg.inv(M)
        minv = 0.5 * (minv + minv.T)
        alloc = thruster_allocation(pos, dirs)
        n_thr = pos.shape[0]
        W = self.mass * self.g
        Bf = self.rho * self.g * self.volume
        current = np.asarray(self.current)
        zeros = np.zeros(6)
        p = pack_params(
            n_thrusters=0 if self.wrench_input else n_thr,
            lag=self.thruster_lag,
            lag_time_constant=self.lag_time_constant,
            K1=self.K1,
            K2=self.K2,
            n_max=self.n_max,
            W=W,
            B=Bf,
            r_G=np.asarray(self.r_G),
            r_B=np.asarray(self.r_B),
            linear_damping=self.linear_damping_matrix,
            quadratic_damping=np.asarray(self.quadratic_damping),
            cable_force=np.asarray(self.cable_force),
            current_body=current if self.current_frame == "body" else zeros,
            current_ned=current if self.current_frame == "ned" else zeros,
            M=M,
            Minv=minv,
            allocation=alloc[:, :0] if self.wrench_input else alloc,
            wrench_input=self.wrench_input,
        )
        for a in (M, minv, alloc):
            a.setflags(write=False)
        put(self, "_M", M)
        put(self, "_Minv", minv)
        put(self, "_alloc", alloc)
        put(self, "_p", p)
        put(self, "_kernels", VehicleKernels.of(p))
        put(self, "n_thrusters", n_thr)
        put(self, "weight", W)
        put(self, "buoyancy", Bf)
        nx = 12 + (n_thr if self.thruster_lag else 0)
        put(self, "nx", nx)
        lag_names = tuple(f"n{i + 1}" for i in range(n_thr)) if self.thruster_lag else ()
        put(self, "state_names", _ETA_NAMES + _V_NAMES + lag_names)
        put(self, "state_units", _ETA_UNITS + _V_UNITS + ("rpm",) * len(lag_names))
        if self.wrench_input:
            put(self, "nu", 6)
            put(self, "input_names", WRENCH_NAMES)
            put(self, "input_units", WRENCH_UNITS)
        else:
            put(self, "nu", n_thr)
            put(self, "input_names", tuple(f"n_r{i + 1}" for i in range(n_thr)))
            put(self, "input_units", ("rpm",) * n_thr)

    # ------------------------------------------------------------------ attributes

    def _check_masses(self) -> None:
        """Mass, inertia, added mass, damping and the body vectors, checked and frozen
        (a symmetric matrix printed to a few digits is symmetrised, with a warning)."""
        put = object.__setattr__
        put(self, "mass", _scalar("mass", self.mass, positive=True))
        inertia = _array("inertia", self.inertia, ((3,), (3, 3)))
        if inertia.ndim == 1 and inertia.min() <= 0:
            raise VehicleParameterError(
                "inertia", f"`inertia` must be > 0, got {_frozen(inertia)}."
            )
        if inertia.ndim == 2:
            inertia = symmetrized("inertia", inertia, stacklevel=5)
            eig = np.linalg.eigvalsh(inertia)
            if eig.min() <= 0:
                raise VehicleParameterError(
                    "inertia",
                    "`inertia` must be a positive definite tensor, its eigenvalues are "
                    f"{np.round(eig, 6).tolist()} kg m^2.",
                )
        put(self, "inertia", _frozen(inertia))
        added = _array("added_mass", self.added_mass, ((6,), (6, 6)))
        if added.ndim == 2:
            added = symmetrized("added_mass", added, stacklevel=5)
        put(self, "added_mass", _frozen(added))
        put(
            self,
            "linear_damping",
            _frozen(_array("linear_damping", self.linear_damping, ((6,), (6, 6)))),
        )
        if np.shape(self.quadratic_damping) == (6, 6):
            raise VehicleParameterError(
                "quadratic_damping", f"`quadratic_damping` {QUADRATIC_IS_DIAGONAL}"
            )
        for name, size in (
            ("r_G", 3),
            ("r_B", 3),
            ("quadratic_damping", 6),
            ("current", 6),
            ("cable_force", 6),
        ):
            put(self, name, _frozen(_array(name, getattr(self, name), ((size,),))))

    def _check_scalars(self) -> None:
        """The scalar parameters and the switches, checked."""
        put = object.__setattr__
        put(self, "volume", _scalar("volume", self.volume, nonneg=True))
        for name in ("rho", "g", "n_max", "lag_time_constant"):
            put(self, name, _scalar(name, getattr(self, name), positive=True))
        for name in ("K1", "K2"):
            put(self, name, _scalar(name, getattr(self, name)))
        put(self, "pitch_limit_deg", _scalar("pitch_limit_deg", self.pitch_limit_deg))
        put(self, "pitch_tolerance_deg", _scalar("pitch_tolerance_deg", self.pitch_tolerance_deg))
        if not 0 < self.pitch_tolerance_deg < 90 or not 0 < self.pitch_limit_deg < 90:
            raise VehicleParameterError(
                "pitch_limit_deg",
                "`pitch_limit_deg` and `pitch_tolerance_deg` must be in (0, 90) deg, got "
                f"{self.pitch_limit_deg} and {self.pitch_tolerance_deg}.",
            )
        if self.current_frame not in ("body", "ned"):
            raise VehicleParameterError(
                "current_frame",
                f"`current_frame` must be 'body' or 'ned', got {self.current_frame!r}.",
            )
        if not isinstance(self.thruster_lag, bool | np.bool_):
            raise VehicleParameterError(
                "thruster_lag", f"`thruster_lag` must be True or False, got {self.thruster_lag!r}."
            )
        put(self, "thruster_lag", bool(self.thruster_lag))
        if not isinstance(self.wrench_input, bool | np.bool_):
            raise VehicleParameterError(
                "wrench_input", f"`wrench_input` must be True or False, got {self.wrench_input!r}."
            )
        put(self, "wrench_input", bool(self.wrench_input))
        if self.wrench_input and self.thruster_lag:
            raise VehicleParameterError(
                "wrench_input",
                "`wrench_input` bypasses the thrusters, so it cannot have `thruster_lag`; "
                "switch one of them off.",
            )
        put(self, "sources", dict(self.sources))

    def _check_thrusters(self) -> tuple[np.ndarray, np.ndarray]:
        """Thruster positions and unit directions, checked and frozen; returns them as
        arrays (directions normalised)."""
        put = object.__setattr__
        pos = np.asarray(self.thruster_positions, dtype=float)
        dirs = np.asarray(self.thruster_directions, dtype=float)
        if pos.ndim != 2 or pos.shape[1] != 3 or pos.shape[0] < 1:
            raise VehicleParameterError(
                "thruster_positions",
                f"`thruster_positions` must have shape (N, 3) with N >= 1, got {pos.shape}.",
            )
        if dirs.shape != pos.shape:
            raise VehicleParameterError(
                "thruster_directions",
                f"`thruster_directions` must have the shape of `thruster_positions` "
                f"{pos.shape}, got {dirs.shape}.",
            )
        if not (np.isfinite(pos).all() and np.isfinite(dirs).all()):
            raise VehicleParameterError(
                "thruster_positions", "thruster positions and directions must be finite."
            )
        norms = np.linalg.norm(dirs, axis=1)
        bad = np.flatnonzero(np.abs(norms - 1.0) > 1e-3)
        if bad.size:
            i = int(bad[0])
            raise VehicleParameterError(
                "thruster_directions",
                f"`thruster_directions[{i}]` must be a unit vector, its norm is {norms[i]:.6g}; "
                "divide it by its norm.",
            )
        dirs = dirs / norms[:, None]
        put(self, "thruster_positions", tuple(tuple(float(c) for c in r) for r in pos))
        put(self, "thruster_directions", tuple(tuple(float(c) for c in d) for d in dirs))
        return pos, dirs

    @property
    def params(self) -> dict[str, float]:
        """Scalar parameters by name (units in :attr:`param_units`).

        With a full M_A or D_l the hydrodynamic names are its diagonal entries;
        ``Ixy``, ``Ixz``, ``Iyz`` are the products of inertia (Fossen's sign: the
        tensor holds ``-Ixy``), zero for a diagonal inertia.
        """
        out = {}
        for name, (fld, idx) in _PARAMS.items():
            value = getattr(self, fld)
            out[name] = float(value) if idx is None else _component(value, idx)
        return out

    @property
    def param_names(self) -> tuple[str, ...]:
        return tuple(_PARAMS)

    @property
    def param_bounds(self) -> dict[str, tuple[float, float]]:
        """Physical bounds of the parameters whose sign physics fixes: mass, the moments
        of inertia, the volume, rho, g, the thruster coefficients and the diagonal
        added mass and damping (stored as magnitudes, Fossen's X_udot, X_u, X_|u|u
        being minus these) are >= 0. An estimate outside is flagged by
        :func:`sampledyn.estimate` (a negative damping: the fit absorbed noise or
        unmodelled forces)."""
        positive = (
            "mass", "Ix", "Iy", "Iz", "volume", "rho", "g", "K1", "K2", "n_max", "T_n",
            *ADDED_MASS_NAMES, *LINEAR_DAMPING_NAMES, *QUADRATIC_DAMPING_NAMES,
        )  # fmt: skip
        return {n: (0.0, math.inf) for n in positive}

    def with_buoyancy(self, percent: float) -> Vehicle:
        """The same vehicle with its displaced volume set so that the buoyancy is
        ``B = (1 + percent / 100) W`` (the paper's Fig. 7 run uses +1 %).

        Raises
        ------
        VehicleParameterError
            if ``percent`` is not a finite number above -100.
        """
        if isinstance(percent, bool) or not isinstance(percent, int | float | np.number):
            raise VehicleParameterError(
                "buoyancy_pct", f"`buoyancy_pct` must be a number (%), got {percent!r}."
            )
        if not math.isfinite(percent) or percent <= -100:
            raise VehicleParameterError(
                "buoyancy_pct", f"`buoyancy_pct` must be a finite number > -100 %, got {percent}."
            )
        return self.with_params(volume=(1.0 + percent / 100.0) * self.mass / self.rho)

    def with_params(self, **values: Any) -> Vehicle:
        """The same vehicle with some parameters or options changed.

        Accepts the scalar names of :attr:`params` (e.g. ``X_u=10.0``, ``mass=14``,
        ``Ixy=1.4``; a diagonal entry of a full matrix keeps its off-diagonal part)
        and the constructor arguments (e.g. ``thruster_lag=True``,
        ``cable_force=(5, 0, 0, 0, 0, 0)``).
        """
        field_names = {f.name for f in fields(self) if f.init}
        unknown = set(values) - set(_PARAMS) - field_names
        if unknown:
            raise TypeError(
                f"unknown parameter(s) {sorted(unknown)}; valid: {list(_PARAMS)} or the "
                f"constructor arguments {sorted(field_names)}."
            )
        changes: dict[str, Any] = {}
        parts: dict[str, Any] = {}
        for name, value in values.items():
            if name in field_names:
                changes[name] = value
                continue
            fld, idx = _PARAMS[name]
            if idx is None:
                changes[fld] = value
            else:
                parts[fld] = _with_component(parts.get(fld, getattr(self, fld)), idx, value)
        for fld, value in parts.items():
            if fld in changes:
                raise TypeError(f"`{fld}` given both whole and by component.")
            changes[fld] = value
        return replace(self, **changes)

    @property
    def inertia_tensor(self) -> np.ndarray:
        """I_g about the centre of gravity, shape (3, 3) (kg m^2)."""
        return _as_matrix(self.inertia, 3)

    @property
    def added_mass_matrix(self) -> np.ndarray:
        """M_A, shape (6, 6) (kg, kg m, kg m^2)."""
        return _as_matrix(self.added_mass, 6)

    @property
    def linear_damping_matrix(self) -> np.ndarray:
        """D_l, shape (6, 6) (N s/m, N s/rad, N s, N m s/rad)."""
        return _as_matrix(self.linear_damping, 6)

    @property
    def mass_matrix(self) -> np.ndarray:
        """M = M_RB + M_A, shape (6, 6) (kg, kg m, kg m^2)."""
        return np.array(self._M)

    @property
    def minv(self) -> np.ndarray:
        """M^-1, shape (6, 6), computed once."""
        return np.array(self._Minv)

    @property
    def allocation(self) -> np.ndarray:
        """Thrust allocation B, shape (6, N): column i is ``[d_i; r_i x d_i]``."""
        return np.array(self._alloc)

    # --------------------------------------------------------------- model blocks
    def J(self, eta: Any) -> np.ndarray:
        """Kinematic transformation J(eta) of eq. (6), shape (N, 6, 6) (or (6, 6))."""
        eta = np.asarray(eta, dtype=float)
        self._pitch_guard(eta[..., 4])
        return rotation_jacobian(eta, tolerance_deg=self.pitch_tolerance_deg)

    def restoring(self, eta: Any) -> np.ndarray:
        """g(eta) with the sign of eq. (5) (N, N m), shape (N, 6) (or (6,))."""
        return restoring_force(eta, self.weight, self.buoyancy, self.r_G, self.r_B)

    def coriolis(self, v: Any) -> np.ndarray:
        """C(v) = C_RB(v) + C_A(v), shape (N, 6, 6) (or (6, 6)); skew-symmetric."""
        return coriolis_matrix(self._M, v)

    def damping(self, v: Any) -> np.ndarray:
        """D(v) = D_l + diag(d_q) |v|, shape (N, 6, 6) (or (6, 6))."""
        v = np.asarray(v, dtype=float)
        if v.shape[-1:] != (6,) or v.ndim > 2:
            raise ValueError(f"`v` must have shape (N, 6) or (6,), got {v.shape}.")
        quad = np.asarray(self.quadratic_damping) * np.abs(v)
        return self.linear_damping_matrix + quad[..., :, None] * np.eye(6)

    def input_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper limits of the inputs, each shape (nu,) (rpm): the thrusters
        saturate at -n_max and n_max (:func:`sampledyn.simulate` warns beyond them);
        none (+-inf) for a wrench input."""
        limit = np.inf if self.wrench_input else self.n_max
        return np.full(self.nu, -limit), np.full(self.nu, limit)

    def saturate(self, u: Any) -> np.ndarray:
        """The applied rpm ``clip(u, -n_max, n_max)``, the shape of ``u``."""
        return np.clip(np.asarray(u, dtype=float), -self.n_max, self.n_max)

    def thrust(self, x: Any, u: Any) -> np.ndarray:
        """Thruster forces T of eq. (7) (N), shape (N, n_thrusters) (or (n_thrusters,)).

        The rpm are the saturated ``u`` (or the lag states of ``x`` when
        ``thruster_lag``).
        """
        if self.wrench_input:
            raise ValueError(
                "this vehicle's input is the commanded wrench (wrench_input=True): it has "
                "no thruster forces; use with_params(wrench_input=False) for them."
            )
        xb = np.atleast_2d(np.asarray(x, dtype=float))
        if xb.shape[-1] != self.nx:
            raise ValueError(f"`x` must have shape (N, {self.nx}), got {np.shape(x)}.")
        if self.thruster_lag:
            n = xb[:, 12:]
        else:
            n = np.broadcast_to(self.saturate(u), (xb.shape[0], self.nu))
        va = xb[:, 6:12] @ self._alloc
        t = self.K1 * n * np.abs(n) - self.K2 * va * np.abs(n)
        return t[0] if np.ndim(x) == 1 else t

    # -------------------------------------------------------------- compiled model
    def kernel(self) -> tuple[Any, np.ndarray]:
        """The compiled f of one state, generated for this vehicle's sparsity pattern
        (:mod:`sampledyn.models._vehicle_kernels`), and ``p``."""
        return self._kernels.get("rhs"), self._p

    def jacobian_kernel(self) -> tuple[Any, np.ndarray]:
        """The compiled df/dx of one state (generated, as :meth:`kernel`) and ``p``."""
        return self._kernels.get("jac"), self._p

    def input_jacobian_kernel(self) -> tuple[Any, np.ndarray]:
        """The compiled df/du of one state (:meth:`input_jacobian`) and ``p``."""
        return self._kernels.get("jac_u"), self._p

    def check_states(self, x: Any) -> None:
        """Raise if some |theta| is within ``pitch_tolerance_deg`` of 90 deg, warn
        beyond ``pitch_limit_deg`` (as :meth:`f` and :meth:`jacobian` do)."""
        self._guard_x(x)

    def switch_kernel(self) -> tuple[Any, np.ndarray, np.ndarray]:
        """Switching values for :func:`sampledyn.simulate`: ``(sw, p, input_only)``.

        ``sw(t, x, u, p, out)`` writes 6 + 3 N values whose zero crossings are where f
        is not smooth: the body velocities (|v| v), the rpm inside n |n| (lag states,
        or the inputs), and ``u_i - n_max``, ``u_i + n_max`` (saturation).
        ``input_only`` (bool, shape (6 + 3 N,)) marks the values that depend on u only.
        """
        nt = 0 if self.wrench_input else self.n_thrusters
        input_only = np.array(
            [False] * 6 + [not self.thruster_lag] * nt + [True] * (2 * nt), dtype=bool
        )
        return self._kernels.get("sw"), self._p, input_only

    def _pitch_guard(self, theta: Any, stacklevel: int = 3) -> None:
        past, worst = check_pitch(theta, self.pitch_tolerance_deg, self.pitch_limit_deg)
        if past:
            warnings.warn(
                f"pitch |theta| up to {worst:.1f} deg exceeds pitch_limit_deg = "
                f"{self.pitch_limit_deg:g} deg: J(eta) and dJ/deta grow like 1/cos(theta) "
                "(eqs. (22)-(23)), so predictions lose accuracy near theta = +-90 deg.",
                stacklevel=stacklevel,
            )

    def _guard_x(self, x: Any) -> None:
        if (
            type(x) is np.ndarray
            and x.ndim in (1, 2)
            and x.size == self.nx
            and x.shape[-1] == self.nx
            and x.dtype.kind == "f"
        ):
            # One state, (nx,) or (1, nx): its pitch as one float, checked without arrays.
            self._pitch_guard(x.item(4), stacklevel=4)
            return
        xa = np.asarray(x, dtype=float)
        if xa.ndim in (1, 2) and xa.shape[-1] == self.nx:
            self._pitch_guard(xa[..., 4], stacklevel=4)  # the caller of f / jacobian

    def f(self, t: Any, x: Any, u: Any) -> np.ndarray:
        """Right-hand side ``f(t, x, u)``, eqs. (5)-(7) (and (3) with the lag option).

        Parameters
        ----------
        t : float or ndarray, shape (N,)
            Times (s); the vehicle is time-invariant.
        x : ndarray, shape (N, nx) or (nx,)
            States ``(eta, v[, n])``.
        u : ndarray, shape (N, nu) or (nu,)
            Thruster rpm commands (references n_r with the lag option), saturated at
            n_max.

        Returns
        -------
        ndarray, shape (N, nx) (or (nx,))

        Raises
        ------
        ValueError
            If some |theta| is within ``pitch_tolerance_deg`` of 90 deg.
        """
        self._guard_x(x)
        return super().f(t, x, u)

    def jacobian(self, t: Any, x: Any, u: Any) -> np.ndarray:
        """Analytic ``df/dx``, shape (N, nx, nx) (or (nx, nx)), eqs. (13)-(18).

        Rows/columns follow the state ``(eta, v[, n])``: the blocks are
        ``df_eta/deta`` (18), ``df_eta/dv = J(eta)`` (17), ``df_v/deta = M^-1 dg/deta``
        (14), ``df_v/dv`` (13) including ``-M^-1 (D_l + diag(2 d_q |v|))`` and the
        thruster term ``-K2 B diag(|n|) B^T`` (16) at the saturated rpm, and with the
        lag option ``df_v/dn`` and ``-I/T_n``.
        """
        self._guard_x(x)
        return super().jacobian(t, x, u)

    def input_jacobian(self, t: Any, x: Any, u: Any) -> np.ndarray:
        """Analytic ``df/du``, shape (N, nx, nu) (or (nx, nu) for one state).

        Without the lag option column i is ``M^-1 B[:, i] (2 K1 |n_i| - K2 v_a,i
        sign(n_i))`` in the v rows (the derivative of eq. (7)); with it the only
        non-zero entry is ``d n_i'/d u_i = 1/T_n``. Both are multiplied by the
        saturation's slope: 1 for |u_i| <= n_max, 0 beyond (the one-sided value at
        the corner). Units: (m/s^2, rad/s^2 or rpm/s) per rpm.

        Parameters
        ----------
        t : float or ndarray, shape (N,)
            Times (s); unused (time-invariant).
        x : ndarray, shape (N, nx) or (nx,)
        u : ndarray, shape (N, nu) or (nu,)

        Raises
        ------
        ValueError
            For wrong shapes, or some |theta| within ``pitch_tolerance_deg`` of 90 deg.
        """
        self._guard_x(x)
        tt, xx, uu, single = _as_batch(t, x, u, self.nx, self.nu)
        check_pitch(xx[:, 4], self.pitch_tolerance_deg)
        batch = self._kernels.get("batch_jac_u")
        out = in_row_blocks(
            batch, readonly(tt), readonly(xx), readonly(uu), self._p, JAC_BLOCK_ROWS
        )
        return out[0] if single else out

    def jac_v_v(self, t: Any, x: Any, u: Any) -> np.ndarray:
        """df_v/dv, eq. (13) with (16); shape (N, 6, 6)."""
        return self.jacobian(t, x, u)[..., 6:12, 6:12]

    def jac_v_eta(self, t: Any, x: Any, u: Any) -> np.ndarray:
        """df_v/deta = M^-1 dg/deta, eq. (14); shape (N, 6, 6)."""
        return self.jacobian(t, x, u)[..., 6:12, 0:6]

    def jac_eta_v(self, t: Any, x: Any, u: Any) -> np.ndarray:
        """df_eta/dv = J(eta), eq. (17); shape (N, 6, 6)."""
        return self.jacobian(t, x, u)[..., 0:6, 6:12]

    def jac_eta_eta(self, t: Any, x: Any, u: Any) -> np.ndarray:
        """df_eta/deta = d(J(eta)(v + v_c))/deta, eq. (18); shape (N, 6, 6)."""
        return self.jacobian(t, x, u)[..., 0:6, 0:6]

    # ---------------------------------------------------------------- estimation
    def regressors(self, t: Any, x: Any, u: Any) -> LinearForm:
        """``f = Phi @ theta + f0`` with theta = the 12 diagonal damping coefficients.

        theta = (X_u, Y_v, Z_w, K_p, M_q, N_r, X_uu, Y_vv, Z_ww, K_pp, M_qq, N_rr).
        Since ``f_v = M^-1(... - D_l v - diag(d_q) |v| v)``, the v rows of Phi are
        ``-M^-1 diag(v)`` and ``-M^-1 diag(|v| v)``; the eta (and lag) rows are zero.
        f0 is f of the same vehicle with the diagonal of D_l and d_q set to zero (the
        off-diagonal part of a full D_l stays in f0).

        Returns
        -------
        LinearForm with ``phi`` of shape (N, nx, 12) and ``f0`` of shape (N, nx).
        """
        xb = np.atleast_2d(np.asarray(x, dtype=float))
        if xb.ndim != 2 or xb.shape[1] != self.nx:
            raise ValueError(f"`x` must have shape (N, {self.nx}), got {np.shape(x)}.")
        d_l = np.asarray(self.linear_damping, dtype=float)
        off_diagonal = d_l - np.diag(np.diag(d_l)) if d_l.ndim == 2 else np.zeros(6)
        undamped = self.with_params(linear_damping=off_diagonal, quadratic_damping=(0.0,) * 6)
        f0 = np.atleast_2d(undamped.f(t, xb, u))
        v = xb[:, 6:12]
        phi = np.zeros((xb.shape[0], self.nx, 12))
        phi[:, 6:12, :6] = -self._Minv[None, :, :] * v[:, None, :]
        phi[:, 6:12, 6:] = -self._Minv[None, :, :] * (np.abs(v) * v)[:, None, :]
        names = LINEAR_DAMPING_NAMES + QUADRATIC_DAMPING_NAMES
        units = _LINEAR_UNITS + _QUADRATIC_UNITS
        return LinearForm(names, units, phi, f0)
