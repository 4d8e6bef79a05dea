"""Independent references for the vehicle tests: eqs. (5)-(7) in plain NumPy from
textbook formulas, central differences, random states."""

from __future__ import annotations

import numpy as np

from sampledyn.models import Vehicle

# Full-matrix options of the BlueROV2 Heavy (not a published vehicle: products of
# inertia, a coupled symmetric M_A and a non-symmetric D_l, to exercise every entry).
FULL_MATRICES = {
    "inertia": ((0.26, -0.012, 0.02), (-0.012, 0.23, -0.006), (0.02, -0.006, 0.37)),
    "added_mass": (
        (6.36, 0.1, -0.3, 0.02, 0.4, -0.05),
        (0.1, 7.12, 0.2, -0.35, 0.03, 0.15),
        (-0.3, 0.2, 18.68, 0.04, -0.6, 0.02),
        (0.02, -0.35, 0.04, 0.189, 0.005, 0.01),
        (0.4, 0.03, -0.6, 0.005, 0.135, -0.004),
        (-0.05, 0.15, 0.02, 0.01, -0.004, 0.222),
    ),
    "linear_damping": (
        (13.7, 0.5, -1.0, 0.1, 0.8, 0.0),
        (-0.4, 2.0, 0.3, -0.6, 0.0, 0.2),
        (1.2, 0.0, 33.0, 0.0, -0.9, 0.1),
        (0.0, 0.3, 0.0, 0.5, 0.02, 0.01),
        (0.5, 0.0, -0.7, -0.01, 0.8, 0.0),
        (0.0, 0.1, 0.05, 0.0, 0.03, 0.4),
    ),
    "r_G": (0.01, -0.005, 0.02),
}


def random_states(
    model: Vehicle, n: int, seed: int, rpm_frac: float = 0.85
) -> tuple[np.ndarray, np.ndarray]:
    """States with |theta| < 60 deg, velocities of order 0.5, rpm within
    +-rpm_frac n_max (+-3003 rpm on the BlueROV2 Heavy)."""
    rng = np.random.default_rng(seed)
    eta = np.column_stack(
        [
            rng.normal(0.0, 5.0, (n, 3)),
            rng.uniform(-1.0, 1.0, (n, 1)),
            rng.uniform(-1.0, 1.0, (n, 1)),
            rng.uniform(-np.pi, np.pi, (n, 1)),
        ]
    )
    v = rng.normal(0.0, 0.5, (n, 6))
    lim = rpm_frac * model.n_max
    lag = rng.uniform(-lim, lim, (n, model.nx - 12))
    u = rng.uniform(-lim, lim, (n, model.nu))
    return np.column_stack([eta, v, lag]), u


# ------------------------------------------------------------------ independent reference
def _S(a: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def reference_f(model: Vehicle, x: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Eqs. (5)-(7) in plain NumPy from textbook formulas (Fossen 2011), one state.

    Uses the velocity-independent C_RB parametrization (Fossen eq. 3.60), C_A of a
    diagonal M_A (eq. 6.43 written out), restoring forces from rotating the weight and
    buoyancy vectors, and thruster forces summed one by one with np.cross.
    """
    phi, theta, psi = x[3:6]
    nu1, nu2 = x[6:9], x[9:12]
    rx = np.array([[1, 0, 0], [0, np.cos(phi), -np.sin(phi)], [0, np.sin(phi), np.cos(phi)]])
    ry = np.array(
        [[np.cos(theta), 0, np.sin(theta)], [0, 1, 0], [-np.sin(theta), 0, np.cos(theta)]]
    )
    rz = np.array([[np.cos(psi), -np.sin(psi), 0], [np.sin(psi), np.cos(psi), 0], [0, 0, 1]])
    R = rz @ ry @ rx
    T = np.array(
        [
            [1, np.sin(phi) * np.tan(theta), np.cos(phi) * np.tan(theta)],
            [0, np.cos(phi), -np.sin(phi)],
            [0, np.sin(phi) / np.cos(theta), np.cos(phi) / np.cos(theta)],
        ]
    )
    m = model.mass
    rg = np.array(model.r_G)
    rb = np.array(model.r_B)
    inertia = np.array(model.inertia)
    Ig = np.diag(inertia) if inertia.ndim == 1 else inertia
    Io = Ig - m * _S(rg) @ _S(rg)
    MRB = np.block([[m * np.eye(3), -m * _S(rg)], [m * _S(rg), Io]])
    added = np.array(model.added_mass)
    MA = np.diag(added) if added.ndim == 1 else added
    M = MRB + MA
    CRB = np.block([[m * _S(nu2), -m * _S(nu2) @ _S(rg)], [m * _S(rg) @ _S(nu2), -_S(Io @ nu2)]])
    # Fossen eq. 6.43 with the four blocks of a full M_A
    A11, A12, A21, A22 = MA[:3, :3], MA[:3, 3:], MA[3:, :3], MA[3:, 3:]
    a1 = A11 @ nu1 + A12 @ nu2
    a2 = A21 @ nu1 + A22 @ nu2
    CA = np.block([[np.zeros((3, 3)), -_S(a1)], [-_S(a1), -_S(a2)]])
    v = x[6:12]
    lin = np.array(model.linear_damping)
    D = (np.diag(lin) if lin.ndim == 1 else lin) + np.diag(
        np.array(model.quadratic_damping) * np.abs(v)
    )
    W = m * model.g
    B = model.rho * model.g * model.volume
    fg = R.T @ np.array([0.0, 0.0, W])
    fb = R.T @ np.array([0.0, 0.0, -B])
    g = np.concatenate([fg + fb, np.cross(rg, fg) + np.cross(rb, fb)])
    n = x[12:] if model.thruster_lag else np.clip(u, -model.n_max, model.n_max)
    tau = np.zeros(6)
    omega = nu2
    for i, (r_i, d_i) in enumerate(
        zip(model.thruster_positions, model.thruster_directions, strict=True)
    ):
        r_i = np.array(r_i)
        d_i = np.array(d_i)
        va = (nu1 + np.cross(omega, r_i)) @ d_i
        thrust = model.K1 * n[i] * abs(n[i]) - model.K2 * va * abs(n[i])
        tau += np.concatenate([thrust * d_i, np.cross(r_i, thrust * d_i)])
    tau_c = np.array(model.cable_force)
    vdot = np.linalg.solve(M, -(CRB + CA) @ v - D @ v + g + tau + tau_c)
    vc = np.array(model.current)
    J = np.block([[R, np.zeros((3, 3))], [np.zeros((3, 3)), T]])
    etadot = J @ (v + vc) if model.current_frame == "body" else J @ v + vc
    u_applied = np.clip(u, -model.n_max, model.n_max)
    ndot = (u_applied - x[12:]) / model.lag_time_constant if model.thruster_lag else np.zeros(0)
    return np.concatenate([etadot, vdot, ndot])


def central_differences(model: Vehicle, x: np.ndarray, u: np.ndarray, wrt: str = "x") -> np.ndarray:
    """df/dx (shape (nx, nx)) or, with ``wrt="u"``, df/du (shape (nx, nu)), one state;
    steps 1e-6 relative."""
    z = np.array(x if wrt == "x" else u, dtype=float)

    def f(zz: np.ndarray) -> np.ndarray:
        return model.f(0.0, zz, u) if wrt == "x" else model.f(0.0, x, zz)

    jac = np.empty((model.nx, z.size))
    for j in range(z.size):
        e = np.zeros(z.size)
        e[j] = 1e-6 * max(1.0, abs(z[j]))
        jac[:, j] = (f(z + e) - f(z - e)) / (2 * e[j])
    return jac
