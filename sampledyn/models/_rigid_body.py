"""Vectorised rigid-body and kinematics blocks of the 6-DoF vehicle, eqs. (5)-(7).

Notation (Fossen 2011, *Handbook of Marine Craft Hydrodynamics and Motion Control*):

    eta = (x, y, z, phi, theta, psi)   NED position (m) and ZYX Euler angles (rad)
    v   = (u, v, w, p, q, r)           body linear (m/s) and angular (rad/s) velocity
    S(a) b = a x b                     the skew-symmetric (cross-product) matrix

These NumPy functions work on batches, shape (N, ...), and serve the sensitivity
analysis (eqs. (19)-(23)) and the tests. The compiled right-hand side in
:mod:`sampledyn.models._vehicle_kernels` evaluates the same formulas per state.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..exceptions import SingularPitchError

__all__ = [
    "check_pitch",
    "coriolis_matrix",
    "euler_rate_matrix",
    "restoring_force",
    "rigid_body_mass_matrix",
    "rotation_jacobian",
    "rotation_jacobian_inverse",
    "rotation_matrix",
    "skew",
    "thruster_allocation",
]


def skew(a: Any) -> np.ndarray:
    """Cross-product matrix ``S(a)`` with ``S(a) b = a x b``.

    Parameters
    ----------
    a : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    a = np.asarray(a, dtype=float)
    if a.shape[-1:] != (3,):
        raise ValueError(f"`a` must have shape (..., 3), got {a.shape}.")
    s = np.zeros(a.shape[:-1] + (3, 3))
    s[..., 0, 1] = -a[..., 2]
    s[..., 0, 2] = a[..., 1]
    s[..., 1, 0] = a[..., 2]
    s[..., 1, 2] = -a[..., 0]
    s[..., 2, 0] = -a[..., 1]
    s[..., 2, 1] = a[..., 0]
    return s


def rigid_body_mass_matrix(mass: float, inertia: Any, r_G: Any) -> np.ndarray:
    """Rigid-body inertia matrix ``M_RB`` about the body origin CO (Fossen 2011, eq. 3.44).

        M_RB = [[m I,        -m S(r_G)],
                [m S(r_G),    I_o     ]],   I_o = I_g - m S(r_G)^2

    Parameters
    ----------
    mass : float
        Mass m (kg).
    inertia : array_like, shape (3,) or (3, 3)
        Inertia about the centre of gravity in body axes (kg m^2): the moments
        (I_x, I_y, I_z) of a diagonal tensor, or the full tensor
        ``I_g = [[I_x, -I_xy, -I_xz], [-I_xy, I_y, -I_yz], [-I_xz, -I_yz, I_z]]``
        (Fossen 2011, eq. 3.33; the products I_xy = int x y dm enter with a minus).
    r_G : array_like, shape (3,)
        Centre of gravity in body axes (m).

    Returns
    -------
    ndarray, shape (6, 6)
    """
    s = skew(np.asarray(r_G, dtype=float))
    m_rb = np.zeros((6, 6))
    m_rb[:3, :3] = mass * np.eye(3)
    m_rb[:3, 3:] = -mass * s
    m_rb[3:, :3] = mass * s
    i_g = np.asarray(inertia, dtype=float)
    if i_g.shape == (3,):
        i_g = np.diag(i_g)
    elif i_g.shape != (3, 3):
        raise ValueError(f"`inertia` must have shape (3,) or (3, 3), got {i_g.shape}.")
    m_rb[3:, 3:] = i_g - mass * s @ s
    return m_rb


def coriolis_matrix(M: Any, v: Any) -> np.ndarray:
    """Coriolis-centripetal matrix ``C(v)`` built from the blocks of a symmetric M.

    Fossen 2011, eqs. 3.46 and 6.43: with ``(a, b) = M v``,

        C(v) = [[0,      -S(a)],
                [-S(a),  -S(b)]],

    which is skew-symmetric for every v. Applied to ``M = M_RB + M_A`` it gives
    ``C_RB(v) + C_A(v)``.

    Parameters
    ----------
    M : array_like, shape (6, 6)
        Symmetric inertia matrix.
    v : array_like, shape (N, 6) or (6,)
        Body velocities.

    Returns
    -------
    ndarray, shape (N, 6, 6) (or (6, 6) for a single v)
    """
    M = np.asarray(M, dtype=float)
    v = np.asarray(v, dtype=float)
    single = v.ndim == 1
    v = np.atleast_2d(v)
    if v.shape[-1] != 6 or v.ndim != 2:
        raise ValueError(f"`v` must have shape (N, 6) or (6,), got {v.shape}.")
    mv = v @ M.T
    sa = skew(mv[:, :3])
    sb = skew(mv[:, 3:])
    c = np.zeros((v.shape[0], 6, 6))
    c[:, :3, 3:] = -sa
    c[:, 3:, :3] = -sa
    c[:, 3:, 3:] = -sb
    return c[0] if single else c


def rotation_matrix(phi: Any, theta: Any, psi: Any) -> np.ndarray:
    """Body-to-NED rotation ``R(Theta) = R_z(psi) R_y(theta) R_x(phi)`` (Fossen 2011, eq. 2.18).

    Parameters
    ----------
    phi, theta, psi : float or ndarray, shape (N,)
        Roll, pitch, yaw (rad).

    Returns
    -------
    ndarray, shape (N, 3, 3) (or (3, 3) for scalars)
    """
    phi, theta, psi = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (phi, theta, psi)))
    cf, sf = np.cos(phi), np.sin(phi)
    ct, st = np.cos(theta), np.sin(theta)
    cp, sp = np.cos(psi), np.sin(psi)
    r = np.empty(phi.shape + (3, 3))
    r[..., 0, 0] = cp * ct
    r[..., 0, 1] = -sp * cf + cp * st * sf
    r[..., 0, 2] = sp * sf + cp * cf * st
    r[..., 1, 0] = sp * ct
    r[..., 1, 1] = cp * cf + sf * st * sp
    r[..., 1, 2] = -cp * sf + st * sp * cf
    r[..., 2, 0] = -st
    r[..., 2, 1] = ct * sf
    r[..., 2, 2] = ct * cf
    return r


def euler_rate_matrix(phi: Any, theta: Any) -> np.ndarray:
    """``T(Theta)``: body angular rates to ZYX Euler-angle rates (Fossen 2011, eq. 2.29).

        T = [[1, sin(phi) tan(theta), cos(phi) tan(theta)],
             [0, cos(phi),            -sin(phi)          ],
             [0, sin(phi)/cos(theta), cos(phi)/cos(theta)]]

    Singular at theta = +-90 deg.

    Returns
    -------
    ndarray, shape (N, 3, 3) (or (3, 3) for scalars)
    """
    phi, theta = np.broadcast_arrays(np.asarray(phi, dtype=float), np.asarray(theta, dtype=float))
    cf, sf = np.cos(phi), np.sin(phi)
    ct, tt = np.cos(theta), np.tan(theta)
    t = np.zeros(phi.shape + (3, 3))
    t[..., 0, 0] = 1.0
    t[..., 0, 1] = sf * tt
    t[..., 0, 2] = cf * tt
    t[..., 1, 1] = cf
    t[..., 1, 2] = -sf
    t[..., 2, 1] = sf / ct
    t[..., 2, 2] = cf / ct
    return t


def check_pitch(
    theta: Any, tolerance_deg: float, limit_deg: float | None = None
) -> tuple[bool, float]:
    """Check pitch angles against the Euler-angle singularity at theta = +-90 deg.

    Raises :class:`SingularPitchError` (a ValueError) when some ``|theta|`` is within
    ``tolerance_deg`` of 90 deg (modulo 180 deg). Returns ``(past_limit, worst_deg)``:
    whether some ``|theta|`` exceeds ``limit_deg`` (the caller warns) and the worst
    angle in degrees.

    ``theta`` is array_like (rad, any shape), or one Python float: a single state, as a
    controller stepping a model from Python passes it, is checked with ``math`` and no
    temporary arrays (about 0.5 us instead of 3.7), with the same verdict and message.
    """
    if type(theta) is float and math.isfinite(theta):
        return _pitch_verdict(abs(math.cos(theta)), theta, 0, tolerance_deg, limit_deg)
    theta = np.asarray(theta, dtype=float)
    if theta.ndim != 1:  # (a column of a batch of states is 1-D already: not copied)
        theta = theta.ravel()
    if theta.size == 0:
        return False, 0.0
    # Every |theta| clearly below both thresholds (the usual case, e.g. each stage of a
    # prediction): |cos| is smallest at the largest |theta| (cos is even and decreasing
    # on [0, 90 deg]), so that one angle decides, without an array of cosines.
    # NaN or inf make the comparison false and take the full check below.
    big = max(float(theta.max()), -float(theta.min()))
    clear = min(90.0 - tolerance_deg, 90.0 if limit_deg is None else limit_deg)
    if big < math.radians(clear) - 1e-6:
        return _pitch_verdict(abs(math.cos(big)), big, 0, tolerance_deg, limit_deg)
    c = np.abs(np.cos(theta))
    if np.isnan(c).any():  # a NaN pitch (its f is NaN anyway) must not hide another row
        if np.isnan(c).all():
            return False, 0.0
        c = np.where(np.isnan(c), np.inf, c)
    worst = int(np.argmin(c))
    return _pitch_verdict(float(c[worst]), float(theta[worst]), worst, tolerance_deg, limit_deg)


def _pitch_verdict(
    c: float, theta: float, sample: int, tolerance_deg: float, limit_deg: float | None
) -> tuple[bool, float]:
    """:func:`check_pitch` for the worst sample, ``c = |cos(theta)|``."""
    worst_deg = math.degrees(math.acos(min(1.0, c)))
    if c < math.sin(math.radians(tolerance_deg)):
        raise SingularPitchError(
            f"pitch angle theta = {math.degrees(theta):.4g} deg (sample {sample}) is within "
            f"{tolerance_deg:g} deg of +-90 deg, where the Euler-angle kinematics J(eta) of "
            "eq. (6) is singular (T(Theta) has 1/cos(theta)). Keep |theta| away from 90 deg, "
            "or lower the vehicle's `pitch_tolerance_deg` if you accept huge J.",
            theta,
            sample,
            tolerance_deg,
        )
    past = limit_deg is not None and c < math.cos(math.radians(limit_deg))
    return past, worst_deg


def _eta_batch(eta: Any) -> tuple[np.ndarray, bool]:
    eta = np.asarray(eta, dtype=float)
    single = eta.ndim == 1
    eta = np.atleast_2d(eta)
    if eta.ndim != 2 or eta.shape[1] != 6:
        raise ValueError(f"`eta` must have shape (N, 6) or (6,), got {np.shape(eta)}.")
    return eta, single


def rotation_jacobian(eta: Any, *, tolerance_deg: float = 0.5) -> np.ndarray:
    """``J(eta) = diag(R(Theta), T(Theta))`` of eq. (6) (Fossen 2011, eq. 2.40).

    Parameters
    ----------
    eta : array_like, shape (N, 6) or (6,)
        Positions (m) and ZYX Euler angles (rad); only the angles matter.
    tolerance_deg : float
        Raise ValueError when some |theta| is within this many degrees of 90 deg.

    Returns
    -------
    ndarray, shape (N, 6, 6) (or (6, 6) for a single eta)
    """
    eta, single = _eta_batch(eta)
    check_pitch(eta[:, 4], tolerance_deg)
    j = np.zeros((eta.shape[0], 6, 6))
    j[:, :3, :3] = rotation_matrix(eta[:, 3], eta[:, 4], eta[:, 5])
    j[:, 3:, 3:] = euler_rate_matrix(eta[:, 3], eta[:, 4])
    return j[0] if single else j


def rotation_jacobian_inverse(eta: Any, *, tolerance_deg: float = 0.5) -> np.ndarray:
    """``J(eta)^-1 = diag(R^T, T^-1)`` in closed form (Fossen 2011, eq. 2.30).

        T^-1 = [[1, 0,         -sin(theta)         ],
                [0, cos(phi),  cos(theta) sin(phi) ],
                [0, -sin(phi), cos(theta) cos(phi) ]]

    Returns
    -------
    ndarray, shape (N, 6, 6) (or (6, 6) for a single eta)
    """
    eta, single = _eta_batch(eta)
    check_pitch(eta[:, 4], tolerance_deg)
    phi, theta = eta[:, 3], eta[:, 4]
    j = np.zeros((eta.shape[0], 6, 6))
    j[:, :3, :3] = np.swapaxes(rotation_matrix(phi, theta, eta[:, 5]), -1, -2)
    j[:, 3, 3] = 1.0
    j[:, 3, 5] = -np.sin(theta)
    j[:, 4, 4] = np.cos(phi)
    j[:, 4, 5] = np.cos(theta) * np.sin(phi)
    j[:, 5, 4] = -np.sin(phi)
    j[:, 5, 5] = np.cos(theta) * np.cos(phi)
    return j[0] if single else j


def restoring_force(eta: Any, W: float, B: float, r_G: Any, r_B: Any) -> np.ndarray:
    """Hydrostatic restoring force ``g(eta)`` with the sign of eq. (5).

    The paper adds g in eq. (5), so this is the generalized force *on* the vehicle,
    i.e. minus Fossen's g(eta) (Fossen 2011, eq. 4.6, which is subtracted). With
    ``k = (-sin theta, cos theta sin phi, cos theta cos phi)`` (the NED down axis in
    body coordinates):

        g(eta) = [(W - B) k;  (W r_G - B r_B) x k]

    Parameters
    ----------
    eta : array_like, shape (N, 6) or (6,)
    W, B : float
        Weight m g and buoyancy rho g V (N).
    r_G, r_B : array_like, shape (3,)
        Centres of gravity and buoyancy in body axes (m).

    Returns
    -------
    ndarray, shape (N, 6) (or (6,))
    """
    eta, single = _eta_batch(eta)
    phi, theta = eta[:, 3], eta[:, 4]
    k = np.stack([-np.sin(theta), np.cos(theta) * np.sin(phi), np.cos(theta) * np.cos(phi)], axis=1)
    h = W * np.asarray(r_G, dtype=float) - B * np.asarray(r_B, dtype=float)
    g = np.concatenate([(W - B) * k, np.cross(np.broadcast_to(h, k.shape), k)], axis=1)
    return g[0] if single else g


def thruster_allocation(positions: Any, directions: Any) -> np.ndarray:
    """Thrust allocation matrix B (6 x N): column i is ``[d_i; r_i x d_i]``.

    A thrust T_i (N) along the unit direction d_i applied at r_i (body axes, m) gives
    the generalized force ``B[:, i] T_i`` (N, N m). Also, ``B[:, i] . v`` is the
    body velocity of the thruster along its axis, ``(v_lin + omega x r_i) . d_i``.

    Parameters
    ----------
    positions : array_like, shape (N, 3)
    directions : array_like, shape (N, 3)
        Unit vectors.

    Returns
    -------
    ndarray, shape (6, N)
    """
    r = np.asarray(positions, dtype=float)
    d = np.asarray(directions, dtype=float)
    if r.ndim != 2 or r.shape[1] != 3 or d.shape != r.shape:
        raise ValueError(
            "`positions` and `directions` must both have shape (N, 3), got "
            f"{r.shape} and {d.shape}."
        )
    return np.concatenate([d, np.cross(r, d)], axis=1).T
