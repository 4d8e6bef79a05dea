"""Frames of logged poses and velocities, converted to the model's (Fossen 2011).

The model's frames: world NED (x north, y east, z down), body FRD (x forward, y
starboard, z down), attitude as ZYX Euler angles (phi, theta, psi) with the rotation
from body to world R = Rz(psi) Ry(theta) Rx(phi) (Fossen, *Handbook of Marine Craft
Hydrodynamics and Motion Control*, 2011, eqs. (2.18)-(2.19)); linear and angular
velocities (u, v, w, p, q, r) in the body frame.

ROS (REP 103, REP 105): world ENU (x east, y north, z up), body FLU (x forward, y
left, z up), orientation a unit quaternion (x, y, z, w) rotating body to world;
``nav_msgs/Odometry`` gives the twist in the child (body) frame.

    p_NED = E p_ENU,            E = [[0, 1, 0], [1, 0, 0], [0, 0, -1]]
    R_NED,FRD = E R_ENU,FLU F,  F = diag(1, -1, -1)   (F = F^T = F^-1)
    v_FRD = F v_FLU,  omega_FRD = F omega_FLU
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "BODY_FRAMES",
    "WORLD_FRAMES",
    "euler_zyx",
    "quaternion_matrix",
    "rotation_zyx",
    "to_ned_frd",
    "twist_frame_fit",
]

# Matrix taking coordinates in each frame to NED / FRD.
WORLD_FRAMES = {
    "ned": np.eye(3),
    "enu": np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]),
}
BODY_FRAMES = {"frd": np.eye(3), "flu": np.diag([1.0, -1.0, -1.0])}


def quaternion_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices of unit quaternions ``q`` = (x, y, z, w), shape (N, 4) ->
    (N, 3, 3); each quaternion is normalised first (ROS messages are float64 but not
    always of unit length)."""
    q = np.asarray(q, dtype=float)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    x, y, z, w = q.T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=1,
    )


def euler_zyx(R: np.ndarray) -> np.ndarray:
    """ZYX Euler angles (phi, theta, psi) (rad) of body-to-world rotations R,
    shape (N, 3, 3) -> (N, 3); theta in [-pi/2, pi/2], phi and psi in (-pi, pi]
    (Fossen 2011, eq. (2.18))."""
    phi = np.arctan2(R[:, 2, 1], R[:, 2, 2])
    theta = -np.arcsin(np.clip(R[:, 2, 0], -1.0, 1.0))
    psi = np.arctan2(R[:, 1, 0], R[:, 0, 0])
    return np.column_stack([phi, theta, psi])


def rotation_zyx(phi: np.ndarray, theta: np.ndarray, psi: np.ndarray) -> np.ndarray:
    """R = Rz(psi) Ry(theta) Rx(phi), body to world, shape (N, 3, 3)."""
    cf, sf = np.cos(phi), np.sin(phi)
    ct, st = np.cos(theta), np.sin(theta)
    cp, sp = np.cos(psi), np.sin(psi)
    return np.stack(
        [
            np.stack([cp * ct, -sp * cf + cp * st * sf, sp * sf + cp * cf * st], -1),
            np.stack([sp * ct, cp * cf + sf * st * sp, -cp * sf + st * sp * cf], -1),
            np.stack([-st, ct * sf, ct * cf], -1),
        ],
        axis=1,
    )


def to_ned_frd(
    position: np.ndarray,
    R: np.ndarray,
    linear: np.ndarray,
    angular: np.ndarray,
    *,
    world: str,
    body: str,
    twist_in_world: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """eta = (x, y, z, phi, theta, psi) in NED and v = (u, v, w, p, q, r) in FRD.

    Parameters
    ----------
    position : ndarray, shape (N, 3)
        Position in the ``world`` frame (m).
    R : ndarray, shape (N, 3, 3)
        Rotation from the ``body`` frame to the ``world`` frame.
    linear, angular : ndarray, shape (N, 3)
        Velocities (m/s, rad/s), in the body frame, or in the world frame if
        ``twist_in_world``.
    world : {"enu", "ned"}
    body : {"flu", "frd"}

    Returns
    -------
    eta, v : ndarray, shape (N, 6) each
    """
    E = WORLD_FRAMES[world]
    F = BODY_FRAMES[body]
    R_nb = E @ R @ F
    if twist_in_world:
        # world-frame twist -> NED -> body FRD: v_b = R_nb^T E v_w
        lin_b = np.einsum("nji,nj->ni", R_nb, linear @ E.T)
        ang_b = np.einsum("nji,nj->ni", R_nb, angular @ E.T)
    else:
        lin_b = linear @ F.T
        ang_b = angular @ F.T
    eta = np.column_stack([position @ E.T, euler_zyx(R_nb)])
    return eta, np.column_stack([lin_b, ang_b])


def twist_frame_fit(
    t: np.ndarray,
    position: np.ndarray,
    R: np.ndarray,
    linear: np.ndarray,
    *,
    world: str,
    body: str,
) -> tuple[float, float, float]:
    """How well the logged position increments fit the kinematics (6) under the two
    readings of a logged linear twist: in the body frame (p' = R_NED,FRD F v) and in
    the world frame (p' = E v).

    Parameters as :func:`to_ned_frd` (``linear`` as logged), ``t`` the stamps (s).
    Returns (rms residual of the body reading, of the world reading, rms of the
    increments) in m: the residual of step n is p_n+1 - p_n - (t_n+1 - t_n)/2 (p'_n +
    p'_n+1) (the trapezoidal rule, exact to O(h^3) per step for a smooth motion).
    """
    E = WORLD_FRAMES[world]
    F = BODY_FRAMES[body]
    p = position @ E.T
    dp = np.diff(p, axis=0)
    dt = np.diff(t)[:, None]
    R_nb = E @ R @ F

    def residual(rate: np.ndarray) -> float:
        r = dp - 0.5 * dt * (rate[:-1] + rate[1:])
        return float(np.sqrt(np.mean(np.sum(r * r, axis=1))))

    body_rate = np.einsum("nij,nj->ni", R_nb, linear @ F.T)
    world_rate = linear @ E.T
    return (
        residual(body_rate),
        residual(world_rate),
        float(np.sqrt(np.mean(np.sum(dp * dp, axis=1)))),
    )
