"""Tests of the 6-DoF vehicle in Fossen form, eqs. (5)-(7), its Jacobians and vehicle files."""

from __future__ import annotations

import warnings
from importlib import resources

import numpy as np
import pytest
from _vehicle_reference import FULL_MATRICES, central_differences, random_states, reference_f
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from sampledyn.models import Vehicle, builtin_vehicles, load_vehicle
from sampledyn.models._rigid_body import (
    check_pitch,
    rotation_jacobian,
    rotation_jacobian_inverse,
    thruster_allocation,
)

BUILTIN_TEXT = (resources.files("sampledyn.models") / "vehicles" / "bluerov2_heavy.toml").read_text(
    encoding="utf-8"
)

OPTIONS = {
    "plain": {},
    "lag": {"thruster_lag": True},
    "current_body": {"current": (0.3, -0.2, 0.1, 0.05, -0.02, 0.01)},
    "current_ned": {"current": (0.3, -0.2, 0.1, 0.0, 0.0, 0.0), "current_frame": "ned"},
    "cable": {"cable_force": (3.0, 1.0, -2.0, 0.1, 0.2, -0.3)},
    "offset_cg": {"r_G": (0.01, -0.02, 0.03), "r_B": (0.02, 0.01, -0.05)},
    "all": {
        "thruster_lag": True,
        "current": (0.1, 0.2, -0.1, 0.02, 0.01, -0.03),
        "cable_force": (-2.0, 0.5, 1.0, 0.0, 0.1, 0.2),
        "r_G": (0.01, 0.0, 0.02),
    },
    "full": FULL_MATRICES,
    "full_lag": {**FULL_MATRICES, "thruster_lag": True, "current": (0.1, 0, 0, 0, 0, 0.02)},
}


@pytest.fixture(scope="module")
def rov() -> Vehicle:
    return load_vehicle("bluerov2_heavy")


# ------------------------------------------------------------------------- the file
def test_builtin_file_gives_published_numbers(rov: Vehicle) -> None:
    assert "bluerov2_heavy" in builtin_vehicles()
    p = rov.params
    # von Benzon et al. 2022, Table A1
    assert p["mass"] == 13.5
    assert (p["Ix"], p["Iy"], p["Iz"]) == (0.26, 0.23, 0.37)
    assert rov.added_mass == (6.36, 7.12, 18.68, 0.189, 0.135, 0.222)
    assert rov.linear_damping == (13.7, 0.0, 33.0, 0.0, 0.8, 0.0)
    assert rov.quadratic_damping == (141.0, 217.0, 190.0, 1.19, 0.47, 1.5)
    assert rov.r_G == (0.0, 0.0, 0.0) and rov.r_B == (0.0, 0.0, -0.01)
    assert p["volume"] == 0.0134 and p["rho"] == 1000.0 and p["g"] == 9.81
    # T200 16 V data: 5.25 kgf at 3533 rpm
    assert rov.n_thrusters == 8 and rov.nu == 8 and rov.nx == 12
    assert p["n_max"] == 3533.0
    assert p["K1"] == pytest.approx(5.25 * 9.80665 / 3533.0**2, rel=1e-4)
    area = np.pi * 0.076**2 / 4
    assert p["K2"] == pytest.approx(np.sqrt(1000.0 * area * p["K1"] / 2), rel=1e-4)
    np.testing.assert_allclose(
        np.diag(rov.mass_matrix), [19.86, 20.62, 32.18, 0.449, 0.365, 0.592], rtol=1e-12
    )
    np.testing.assert_allclose(rov.minv @ rov.mass_matrix, np.eye(6), atol=1e-12)
    assert rov.weight == pytest.approx(13.5 * 9.81)
    assert rov.buoyancy == pytest.approx(1000.0 * 9.81 * 0.0134)
    assert all(s.strip() for s in rov.sources.values())
    assert {"mass", "K1", "K2", "thruster[7].position"} <= set(rov.sources)


def test_state_and_input_layout(rov: Vehicle) -> None:
    assert rov.state_names[:6] == ("x", "y", "z", "phi", "theta", "psi")
    assert rov.state_units[6:12] == ("m/s",) * 3 + ("rad/s",) * 3
    assert rov.input_units == ("rpm",) * 8
    np.testing.assert_array_equal(rov.default_x0, np.zeros(12))
    lagged = rov.with_params(thruster_lag=True)
    assert lagged.nx == 20 and lagged.state_names[12:] == tuple(f"n{i}" for i in range(1, 9))
    np.testing.assert_array_equal(lagged.default_x0, np.zeros(20))


def test_with_params_returns_new_model(rov: Vehicle) -> None:
    changed = rov.with_params(X_u=20.0, Iz=0.5, mass=14.0)
    assert changed.linear_damping[0] == 20.0 and changed.inertia[2] == 0.5
    assert changed.mass == 14.0 and rov.mass == 13.5 and rov.linear_damping[0] == 13.7
    assert changed.mass_matrix[0, 0] == pytest.approx(14.0 + 6.36)
    assert changed != rov and rov.with_params() == rov
    with pytest.raises(TypeError, match="X_uuu"):
        rov.with_params(X_uuu=1.0)
    with pytest.raises(TypeError, match="linear_damping"):
        rov.with_params(linear_damping=(1.0,) * 6, X_u=2.0)


def test_products_of_inertia_by_name(rov: Vehicle) -> None:
    # Fossen 2011, eq. 3.33: the tensor holds -I_xy, -I_xz, -I_yz off the diagonal
    assert rov.params["Ixy"] == 0.0 and np.ndim(rov.inertia) == 1
    tilted = rov.with_params(Ixy=0.01, Iyz=-0.02, Iz=0.4)
    np.testing.assert_array_equal(
        tilted.inertia_tensor, [[0.26, -0.01, 0.0], [-0.01, 0.23, 0.02], [0.0, 0.02, 0.4]]
    )
    assert (tilted.params["Ixy"], tilted.params["Iyz"], tilted.params["Ixz"]) == (0.01, -0.02, 0)
    np.testing.assert_allclose(
        tilted.mass_matrix[3:, 3:], tilted.inertia_tensor + np.diag(rov.added_mass[3:])
    )
    # a diagonal entry of a full matrix keeps the off-diagonal part
    full = rov.with_params(**FULL_MATRICES)
    changed = full.with_params(X_u=20.0, Z_wdot=19.0)
    assert changed.linear_damping_matrix[0, 0] == 20.0 and changed.params["X_u"] == 20.0
    assert changed.added_mass_matrix[2, 2] == 19.0
    off = ~np.eye(6, dtype=bool)
    np.testing.assert_array_equal(
        changed.linear_damping_matrix[off], full.linear_damping_matrix[off]
    )
    np.testing.assert_array_equal(changed.added_mass_matrix[off], full.added_mass_matrix[off])


def test_damping_matrix(rov: Vehicle) -> None:
    full = rov.with_params(**FULL_MATRICES)
    v = np.array([0.3, -0.2, 0.1, 0.5, -0.4, 0.2])
    expected = np.array(FULL_MATRICES["linear_damping"]) + np.diag(
        np.array(rov.quadratic_damping) * np.abs(v)
    )
    np.testing.assert_array_equal(full.damping(v), expected)
    assert full.damping(np.stack([v, v])).shape == (2, 6, 6)


def test_printed_digit_asymmetry_is_averaged_with_a_warning(rov: Vehicle) -> None:
    added = np.diag(rov.added_mass)
    added[1, 3], added[3, 1] = -0.35, -0.3502  # 5.7e-4 relative: within 1e-3
    with pytest.warns(UserWarning, match=r"`added_mass`.*\[1, 3\] = -0.35 vs \[3, 1\] = -0.3502"):
        model = rov.with_params(added_mass=added)
    assert model.added_mass_matrix[1, 3] == model.added_mass_matrix[3, 1] == 0.5 * (-0.35 - 0.3502)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # stored symmetric: no second warning
        model.with_params(X_u=1.0)
    added[3, 1] = -0.36  # 2.8e-2 relative: refused, naming the pair
    with pytest.raises(ValueError, match=r"`added_mass` must be symmetric: \[1, 3\]"):
        rov.with_params(added_mass=added)


@pytest.mark.parametrize(
    ("argument", "value", "match"),
    [
        ("inertia", ((0.26, 0.3, 0), (0.3, 0.23, 0), (0, 0, 0.37)), "positive definite"),
        ("inertia", ((0.26, 0.0), (0.0, 0.23)), r"shape \(3,\) or \(3, 3\)"),
        ("added_mass", np.ones((6, 5)), r"shape \(6,\) or \(6, 6\)"),
        ("linear_damping", np.eye(6) * np.nan, r"`linear_damping\[0, 0\]` must be finite"),
        ("quadratic_damping", np.eye(6), "diagonal"),
        ("added_mass", -40.0 * np.eye(6), "not positive definite"),
    ],
)
def test_bad_matrix_arguments_name_the_argument(rov, argument, value, match) -> None:
    with pytest.raises(ValueError, match=match) as info:
        rov.with_params(**{argument: value})
    assert f"`{argument}" in str(info.value)


# ---------------------------------------------------------------------- invariants
def _rexrov() -> Vehicle:
    return load_vehicle("rexrov")


INVARIANT_MODELS = (
    load_vehicle("bluerov2_heavy"),
    load_vehicle("bluerov2_heavy", r_G=(0.02, -0.01, 0.05)),
    load_vehicle("bluerov2_heavy", **FULL_MATRICES),
    _rexrov(),
)


@settings(max_examples=60, deadline=None)
@given(arrays(np.float64, 6, elements=st.floats(-5.0, 5.0)))
def test_coriolis_is_skew_symmetric(v: np.ndarray) -> None:
    # C(v) = C_RB(v) + C_A(v) from the full M (Fossen 2011, eqs. 3.46 and 6.43)
    for model in INVARIANT_MODELS:
        C = model.coriolis(v)
        np.testing.assert_array_equal(C, -C.T)
        # no power: v^T C(v) v = 0
        scale = np.abs(model.mass_matrix).max()
        assert abs(v @ C @ v) <= 1e-13 * scale * (1.0 + v @ v) ** 1.5
        # C(v) v is the Coriolis term of f: the kernel's v' at zero damping, thrust and
        # restoring force is -M^-1 C(v) v
        bare = model.with_params(
            linear_damping=(0.0,) * 6,
            quadratic_damping=(0.0,) * 6,
            volume=model.mass / model.rho,
            r_B=model.r_G,
        )
        x = np.concatenate([np.zeros(6), v])
        np.testing.assert_allclose(
            bare.f(0.0, x, np.zeros(model.nu))[6:],
            -model.minv @ C @ v,
            rtol=1e-12,
            atol=1e-12 * (1.0 + np.abs(model.minv @ C @ v).max()),
        )


def test_mass_matrix_is_symmetric_positive_definite() -> None:
    for model in INVARIANT_MODELS:
        M = model.mass_matrix
        np.testing.assert_array_equal(M, M.T)
        assert np.linalg.eigvalsh(M).min() > 0
        np.testing.assert_allclose(model.minv @ M, np.eye(6), atol=1e-12)
        # M_RB + M_A with the tensor about the CG shifted to the origin (Fossen eq. 3.44)
        assert M[0, 0] == pytest.approx(model.mass + model.added_mass_matrix[0, 0])
        np.testing.assert_array_equal(model.added_mass_matrix, model.added_mass_matrix.T)


@settings(max_examples=60, deadline=None)
@given(
    st.floats(-np.pi, np.pi),
    st.floats(-1.45, 1.45),
    st.floats(-np.pi, np.pi),
)
def test_rotation_jacobian_inverse(phi: float, theta: float, psi: float) -> None:
    eta = np.array([1.0, 2.0, 3.0, phi, theta, psi])
    J = rotation_jacobian(eta)
    Jinv = rotation_jacobian_inverse(eta)
    np.testing.assert_allclose(Jinv @ J, np.eye(6), atol=1e-9 / np.cos(theta) ** 2)
    R = J[:3, :3]
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0)


def test_rotation_jacobian_is_vectorised() -> None:
    rng = np.random.default_rng(3)
    eta = rng.uniform(-1.0, 1.0, (7, 6))
    batch = rotation_jacobian(eta)
    assert batch.shape == (7, 6, 6)
    for i in range(7):
        np.testing.assert_array_equal(batch[i], rotation_jacobian(eta[i]))


# ---------------------------------------------------------------- f and Jacobians
@pytest.mark.parametrize("option", sorted(OPTIONS))
def test_f_matches_independent_numpy_reference(option: str) -> None:
    model = load_vehicle("bluerov2_heavy", **OPTIONS[option])
    x, u = random_states(model, 20, seed=11)
    f = model.f(0.0, x, u)
    assert f.shape == (20, model.nx)
    for i in range(20):
        np.testing.assert_allclose(f[i], reference_f(model, x[i], u[i]), rtol=1e-10, atol=1e-10)
    # a single state gives a single row
    np.testing.assert_allclose(model.f(0.0, x[0], u[0]), f[0], rtol=0, atol=0)


def test_resting_vehicle_sinks_slowly(rov: Vehicle) -> None:
    # W - B = 0.98 N > 0 and CB above CG: sinks, no rotation at theta = phi = 0
    f = rov.f(0.0, np.zeros(12), np.zeros(8))
    np.testing.assert_allclose(f[:6], 0.0, atol=0)
    assert f[8] == pytest.approx((rov.weight - rov.buoyancy) / rov.mass_matrix[2, 2])
    np.testing.assert_allclose(f[[6, 7, 9, 10, 11]], 0.0, atol=1e-15)
    # rolled: the righting moment opposes phi
    tilted = rov.f(0.0, np.array([0, 0, 0, 0.2, 0, 0, 0, 0, 0, 0, 0, 0.0]), np.zeros(8))
    assert tilted[9] < 0


@pytest.mark.parametrize("option", sorted(OPTIONS))
def test_jacobian_matches_central_differences(option: str) -> None:
    model = load_vehicle("bluerov2_heavy", **OPTIONS[option])
    x, u = random_states(model, 6, seed=5)
    jac = model.jacobian(0.0, x, u)
    assert jac.shape == (6, model.nx, model.nx)
    for i in range(6):
        fd = central_differences(model, x[i], u[i])
        scale = np.abs(fd).max()
        np.testing.assert_allclose(jac[i], fd, rtol=1e-6, atol=1e-6 * scale)


def test_jacobian_blocks(rov: Vehicle) -> None:
    x, u = random_states(rov, 4, seed=8)
    jac = rov.jacobian(0.0, x, u)
    np.testing.assert_allclose(rov.jac_eta_v(0.0, x, u), rov.J(x[:, :6]), rtol=1e-15, atol=1e-15)
    np.testing.assert_array_equal(rov.jac_v_v(0.0, x, u), jac[:, 6:, 6:])
    np.testing.assert_array_equal(rov.jac_eta_eta(0.0, x, u), jac[:, :6, :6])
    # eq. (14): df_v/deta = M^-1 dg/deta, and g depends on phi and theta only
    jve = rov.jac_v_eta(0.0, x, u)
    np.testing.assert_array_equal(jve[:, :, [0, 1, 2, 5]], 0.0)
    step = 1e-6
    for i in range(4):
        for k in (3, 4):
            e = np.zeros(6)
            e[k] = step
            dg = (rov.restoring(x[i, :6] + e) - rov.restoring(x[i, :6] - e)) / (2 * step)
            np.testing.assert_allclose(jve[i, :, k], rov.minv @ dg, rtol=1e-6, atol=1e-9)


def test_thruster_term_of_the_velocity_jacobian(rov: Vehicle) -> None:
    # eq. (16): the thrusters add -M^-1 K2 B diag(n) B^T to df_v/dv
    x, u = random_states(rov, 3, seed=9)
    with_thrust = rov.jac_v_v(0.0, x, u)
    without = rov.jac_v_v(0.0, x, np.zeros_like(u))
    B = rov.allocation
    for i in range(3):
        expected = -rov.K2 * rov.minv @ B @ np.diag(np.abs(u[i])) @ B.T
        np.testing.assert_allclose(with_thrust[i] - without[i], expected, atol=1e-12)


@pytest.mark.parametrize("option", ["plain", "lag", "all", "full", "full_lag", "rexrov"])
def test_input_jacobian_matches_central_differences(option: str) -> None:
    model = _rexrov() if option == "rexrov" else load_vehicle("bluerov2_heavy", **OPTIONS[option])
    # up to 1.3 n_max: some commands saturate, where df/du must vanish
    x, u = random_states(model, 8, seed=14, rpm_frac=1.3)
    jac = model.input_jacobian(0.0, x, u)
    assert jac.shape == (8, model.nx, model.nu)
    saturated = np.abs(u) > model.n_max
    assert saturated.any() and (~saturated).any()
    for i in range(8):
        fd = central_differences(model, x[i], u[i], wrt="u")
        scale = np.abs(fd).max()
        np.testing.assert_allclose(jac[i], fd, rtol=1e-6, atol=1e-7 * scale)
        np.testing.assert_array_equal(jac[i][:, saturated[i]], 0.0)
    np.testing.assert_array_equal(model.input_jacobian(0.0, x[0], u[0]), jac[0])
    if not model.thruster_lag:  # eq. (7): column i = M^-1 B_i (2 K1 |n| - K2 v_a sign n)
        va = x[:, 6:12] @ model.allocation
        slope = (2 * model.K1 * np.abs(u) - model.K2 * va * np.sign(u)) * ~saturated
        expected = np.einsum("ab,bj,nj->naj", model.minv, model.allocation, slope)
        np.testing.assert_allclose(jac[:, 6:12], expected, rtol=1e-12, atol=1e-15)
        np.testing.assert_array_equal(jac[:, :6], 0.0)


# ------------------------------------------------------------------ thrusters
def test_allocation_columns_from_geometry(rov: Vehicle) -> None:
    B = rov.allocation
    assert B.shape == (6, 8)
    for i, (r, d) in enumerate(zip(rov.thruster_positions, rov.thruster_directions, strict=True)):
        np.testing.assert_allclose(B[:3, i], d, atol=0)
        np.testing.assert_allclose(B[3:, i], np.cross(r, d), atol=1e-15)
    np.testing.assert_allclose(
        B, thruster_allocation(rov.thruster_positions, rov.thruster_directions)
    )


def test_pure_surge_and_heave_combinations(rov: Vehicle) -> None:
    B = rov.allocation
    surge = B @ np.array([1.0, 1.0, -1.0, -1.0, 0.0, 0.0, 0.0, 0.0])
    assert surge[0] == pytest.approx(4 / np.sqrt(2))
    np.testing.assert_allclose(surge[[1, 2, 3, 5]], 0.0, atol=1e-15)
    # the horizontal thrusters sit 8.5 cm below the origin: surge thrust pitches up
    assert surge[4] == pytest.approx(4 / np.sqrt(2) * 0.085)
    heave = B @ np.array([0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0])
    np.testing.assert_allclose(heave, [0, 0, -4, 0, 0, 0], atol=1e-15)
    yaw = B @ np.array([-1.0, 1.0, 1.0, -1.0, 0, 0, 0, 0])
    np.testing.assert_allclose(yaw[:5], 0.0, atol=1e-15)
    assert yaw[5] == pytest.approx(4 * (0.156 + 0.111) / np.sqrt(2))


def test_thrust_law(rov: Vehicle) -> None:
    n = np.full(8, 3533.0)
    at_rest = rov.thrust(np.zeros(12), n)
    np.testing.assert_allclose(at_rest, rov.K1 * 3533.0**2)
    assert at_rest[0] == pytest.approx(51.48, rel=1e-3)  # 5.25 kgf
    # moving along thruster 1's axis at 0.5 m/s lowers its thrust by K2 * 0.5 * n
    x = np.zeros(12)
    x[6:9] = 0.5 * np.array(rov.thruster_directions[0])
    moving = rov.thrust(x, n)
    assert moving[0] == pytest.approx(at_rest[0] - rov.K2 * 0.5 * 3533.0)
    assert moving[4] == pytest.approx(at_rest[4])


def test_thruster_lag_states(rov: Vehicle) -> None:
    lagged = rov.with_params(thruster_lag=True, T_n=0.2)
    x = np.zeros(20)
    x[12:] = 1000.0
    u = np.full(8, 3000.0)
    f = lagged.f(0.0, x, u)
    np.testing.assert_allclose(f[12:], (3000.0 - 1000.0) / 0.2)
    # the thrust comes from the lagged rpm, not from the reference
    np.testing.assert_allclose(f[6:12], rov.f(0.0, x[:12], np.full(8, 1000.0))[6:12], atol=1e-14)


# ------------------------------------------------------------------- estimation
@pytest.mark.parametrize("option", ["plain", "lag", "all", "full", "full_lag"])
def test_regressors_reproduce_f(option: str) -> None:
    model = load_vehicle("bluerov2_heavy", **OPTIONS[option])
    x, u = random_states(model, 30, seed=21)
    lf = model.regressors(0.0, x, u)
    assert lf.names[:2] == ("X_u", "Y_v") and lf.names[6] == "X_uu" and len(lf.names) == 12
    assert lf.phi.shape == (30, model.nx, 12) and lf.f0.shape == (30, model.nx)
    theta = np.array([model.params[name] for name in lf.names])
    np.testing.assert_allclose(lf.phi @ theta + lf.f0, model.f(0.0, x, u), rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(lf.phi[:, :6], 0.0)
    # changing theta in the linear form equals changing the model
    theta2 = theta * 1.5 + 1.0
    changed = model.with_params(**dict(zip(lf.names, theta2, strict=True)))
    np.testing.assert_allclose(
        lf.phi @ theta2 + lf.f0, changed.f(0.0, x, u), rtol=1e-12, atol=1e-12
    )


# ----------------------------------------------------------------- pitch singularity
def test_pitch_at_90_degrees_raises(rov: Vehicle) -> None:
    x = np.zeros((3, 12))
    x[1, 4] = np.pi / 2
    with pytest.raises(ValueError, match="theta"):
        rov.f(0.0, x, np.zeros((3, 8)))
    with pytest.raises(ValueError, match="singular"):
        rov.jacobian(0.0, x, np.zeros((3, 8)))
    x[1, 4] = -np.pi / 2 + 1e-3
    with pytest.raises(ValueError, match="theta"):
        rov.f(0.0, x, np.zeros((3, 8)))
    with pytest.raises(ValueError, match="theta"):
        rov.J(x[:, :6])


def test_a_nan_pitch_does_not_hide_a_singular_one(rov: Vehicle) -> None:
    x = np.zeros((3, 12))
    x[0, 4] = np.nan
    x[2, 4] = np.pi / 2
    with pytest.raises(ValueError, match=r"sample 2"):
        rov.f(0.0, x, np.zeros((3, 8)))


def test_pitch_past_limit_warns(rov: Vehicle) -> None:
    x = np.zeros((2, 12))
    x[1, 4] = np.radians(85.0)
    with pytest.warns(UserWarning, match="pitch_limit_deg"):
        rov.f(0.0, x, np.zeros((2, 8)))
    x[1, 4] = np.radians(40.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rov.f(0.0, x, np.zeros((2, 8)))
    strict = rov.with_params(pitch_limit_deg=30.0)
    with pytest.warns(UserWarning, match="pitch"):
        strict.jacobian(0.0, x, np.zeros((2, 8)))


def _pitch_outcome(fn):
    """What a pitch check does: ('raise', message), ('warn', message, filename) or
    ('ok',)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            fn()
        except ValueError as err:
            return ("raise", str(err))
    pitch = [w for w in caught if "pitch" in str(w.message)]
    if pitch:
        assert len(pitch) == 1 and pitch[0].category is UserWarning
        return ("warn", str(pitch[0].message), pitch[0].filename)
    return ("ok",)


@pytest.mark.parametrize(
    "theta_deg", [0.0, -40.0, 79.9, 80.5, -85.0, 89.4, 89.6, -89.9, 90.0, 170.0, 269.7, 400.0]
)
def test_pitch_check_of_one_state_is_the_batch_check(rov: Vehicle, theta_deg: float) -> None:
    # One state, (12,) or (1, 12), is checked on a float with math (the fast path of
    # f / jacobian from Python); it must raise and warn exactly as the batch check does,
    # with the warning pointing at the caller. Reference: the state as row 0 of a batch
    # of two whose other row is level (the array path, sample 0 the worst).
    x = np.zeros(12)
    x[4] = np.radians(theta_deg)
    u = np.zeros(8)
    two = np.vstack([x, np.zeros(12)])
    for call in (rov.f, rov.jacobian, rov.input_jacobian):
        want = _pitch_outcome(lambda call=call: call(0.0, two, np.zeros((2, 8))))
        for xs, us, t in ((x, u, 0.0), (x[None, :], u[None, :], np.zeros(1))):
            got = _pitch_outcome(lambda call=call, xs=xs, us=us, t=t: call(t, xs, us))
            assert got == want, (call.__name__, xs.shape)
        got32 = _pitch_outcome(lambda call=call: call(0.0, x.astype(np.float32), u))
        assert got32[0] == want[0]
    if want[0] == "warn":
        assert want[2] == __file__  # stacklevel: the user's call, not the library


def test_pitch_check_of_a_float_is_the_array_check() -> None:
    # Near both thresholds (0.5 deg from 90 deg, and 80 deg), to the last bits.
    rng = np.random.default_rng(7)
    edges = np.radians([89.5, 90.5, -89.5, 80.0, -80.0, 100.0, 269.5])
    thetas = np.concatenate(
        [
            rng.uniform(-7.0, 7.0, 2000),
            (edges[:, None] + np.arange(-20, 21)[None, :] * 1e-16).ravel(),
            (edges[:, None] * (1.0 + np.arange(-8, 9)[None, :] * 2.0**-52)).ravel(),
            [np.nan, 0.0, -0.0],
        ]
    )
    for theta in thetas:
        one = _pitch_outcome(lambda th=float(theta): check_pitch(th, 0.5, 80.0))
        arr = _pitch_outcome(lambda th=theta: check_pitch(np.array([th]), 0.5, 80.0))
        assert one == arr, theta
        if one[0] == "ok":
            assert check_pitch(float(theta), 0.5, 80.0) == check_pitch(np.array([theta]), 0.5, 80.0)
    with np.errstate(invalid="ignore"):  # not finite: the array path (NaN, no error)
        for bad in (np.inf, -np.inf):
            assert check_pitch(float(bad), 0.5, 80.0) == check_pitch(np.array([bad]), 0.5, 80.0)


# ------------------------------------------------------------------- bad inputs
def write(tmp_path, text: str):
    path = tmp_path / "vehicle.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_user_file_by_path(tmp_path) -> None:
    path = write(tmp_path, BUILTIN_TEXT.replace("value = 13.5", "value = 15.0"))
    model = load_vehicle(path, thruster_lag=True)
    assert model.mass == 15.0 and model.thruster_lag
    assert load_vehicle(str(path)).mass == 15.0


@pytest.mark.parametrize(
    ("old", "new", "field"),
    [
        # missing field
        ('mass = { value = 13.5, unit = "kg", source = "vB22 Table A1" }\n', "", "rigid_body.mass"),
        # negative mass
        ("value = 13.5,", "value = -13.5,", "rigid_body.mass"),
        # unknown key
        (
            "[rigid_body]\n",
            '[rigid_body]\nmasss = { value = 1.0, unit = "kg", source = "x" }\n',
            "rigid_body.masss",
        ),
        # M not positive definite: a negative added mass larger than the mass
        ("value = [6.36, 7.12,", "value = [-30.0, 7.12,", "hydrodynamics.added_mass"),
        # wrong unit
        ('unit = "kg/m^3"', 'unit = "g/cm^3"', "environment.rho"),
        # missing unit
        (', unit = "m^3", source', ", source", "rigid_body.volume"),
        # direction not a unit vector
        ("value = [0.0, 0.0, -1.0]", "value = [0.0, 0.0, -2.0]", "thruster.direction"),
        # negative damping
        ("value = [13.7,", "value = [-13.7,", "hydrodynamics.linear_damping"),
        # unknown top-level table
        ("[environment]\n", "[environmnt]\n", "environmnt"),
    ],
)
def test_bad_vehicle_file_names_the_field(tmp_path, old: str, new: str, field: str) -> None:
    assert old in BUILTIN_TEXT
    path = write(tmp_path, BUILTIN_TEXT.replace(old, new, 1))
    with pytest.raises(ValueError, match=f"`{field}"):
        load_vehicle(path)


def test_unknown_builtin_name() -> None:
    with pytest.raises(ValueError, match="bluerov2_heavy"):
        load_vehicle("bluerov3")


def test_bad_constructor_arguments_name_the_argument(rov: Vehicle) -> None:
    with pytest.raises(ValueError, match="`mass`"):
        rov.with_params(mass=-1.0)
    with pytest.raises(ValueError, match="`inertia`"):
        rov.with_params(Ix=0.0)
    with pytest.raises(ValueError, match="`current_frame`"):
        rov.with_params(current_frame="ecef")
    with pytest.raises(ValueError, match="`thruster_directions"):
        rov.with_params(thruster_directions=((1.0, 1.0, 0.0),) * 8)
    with pytest.raises(ValueError, match="`x`"):
        rov.f(0.0, np.zeros((2, 11)), np.zeros((2, 8)))
    with pytest.raises(ValueError, match="`u`"):
        rov.f(0.0, np.zeros((2, 12)), np.zeros((2, 7)))


# ------------------------------------------------------------- full-matrix files
REXROV_TEXT = (resources.files("sampledyn.models") / "vehicles" / "rexrov.toml").read_text(
    encoding="utf-8"
)
_DL_FULL = (
    "linear_damping = { value = [[13.7, 0, 0, 0, 0, 0], [0, 1.0, 0, 0, 0, 0], "
    "[0, 0, 33.0, 0, 0, 0], [0, 0, 0, 0.1, 0, 0], [0, 0, 0, 0, 0.8, 0], "
    '[0, 0, 0, 0, 0, 0.1]], unit = ["N s/m", "N s/rad", "N s", "N m s/rad"], source = "test" }'
)


def test_full_matrix_file_loads(tmp_path) -> None:
    start = BUILTIN_TEXT.index("linear_damping = {")
    end = BUILTIN_TEXT.index("\n", start)
    text = BUILTIN_TEXT[:start] + _DL_FULL + BUILTIN_TEXT[end:]
    model = load_vehicle(write(tmp_path, text))
    assert np.shape(model.linear_damping) == (6, 6)
    np.testing.assert_array_equal(
        model.linear_damping_matrix, np.diag([13.7, 1.0, 33.0, 0.1, 0.8, 0.1])
    )


@pytest.mark.parametrize(
    ("old", "new", "match"),
    [
        # beyond the printed-digits tolerance: refused, naming the field and the pair
        ("10.775, 21.019", "10.875, 21.019", r"`hydrodynamics.added_mass`.*\[2, 5\] = 10.774"),
        # M not positive definite
        ("[779.79,", "[-3000.0,", r"`hydrodynamics.added_mass`.*not positive definite"),
        # wrong shape: a row of 5
        ("-7.8033, 62.726, 10.775,", "62.726, 10.775,", r"`hydrodynamics.added_mass`.*6 x 6"),
        # non-finite entry
        ("409.44, -5.8488", "nan, -5.8488", r"`hydrodynamics.added_mass\[1\]\[3\]`.*finite"),
        # wrong block units
        (
            'unit = ["kg", "kg m", "kg m", "kg m^2"]',
            'unit = ["kg", "kg", "kg", "kg m^2"]',
            "blocks",
        ),
        # inertia tensor not positive definite
        ("[-1.44, 794.20, 2.6]", "[-1.44, -794.20, 2.6]", r"`rigid_body.inertia`.*positive def"),
        # inertia beyond the symmetry tolerance
        ("[-1.44, 794.20, 2.6]", "[-1.54, 794.20, 2.6]", r"`rigid_body.inertia`.*\[0, 1\]"),
    ],
)
def test_bad_matrix_file_names_the_field(tmp_path, old: str, new: str, match: str) -> None:
    assert old in REXROV_TEXT
    path = write(tmp_path, REXROV_TEXT.replace(old, new, 1))
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", "vehicle file", UserWarning)
        with pytest.raises(ValueError, match=match):
            load_vehicle(path)


@pytest.mark.parametrize(
    ("replace_with", "match"),
    [
        # damping that feeds energy in: symmetric part not positive semi-definite
        (_DL_FULL.replace("[0, 1.0, 0, 0, 0, 0]", "[40.0, 1.0, 0, 0, 0, 0]"), "dissipate"),
        # quadratic damping is diagonal
        (
            _DL_FULL.replace("linear_damping", "quadratic_damping").replace(
                '["N s/m", "N s/rad", "N s", "N m s/rad"]', '"N s^2/m^2"'
            ),
            "diagonal",
        ),
    ],
)
def test_bad_damping_matrix_names_the_field(tmp_path, replace_with: str, match: str) -> None:
    key = replace_with.split(" =")[0]
    start = BUILTIN_TEXT.index(f"{key} = {{")
    end = BUILTIN_TEXT.index("\n", start)
    path = write(tmp_path, BUILTIN_TEXT[:start] + replace_with + BUILTIN_TEXT[end:])
    with pytest.raises(ValueError, match=rf"`hydrodynamics.{key}`.*{match}"):
        load_vehicle(path)


_DECLARATION = ', symmetrised = { rule = "mean", rtol = 1e-3, pairs = [[2, 5, 10.774, 10.775]] }'


def test_declared_asymmetry_loads_silently() -> None:
    """The RexROV file states its source's printed-digit asymmetry and the rule: no
    warning, and the matrix is the declared mean."""
    assert _DECLARATION in REXROV_TEXT
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model = load_vehicle("rexrov")
    assert model.added_mass_matrix[2, 5] == model.added_mass_matrix[5, 2] == 0.5 * (10.774 + 10.775)


def test_undeclared_asymmetry_warns_naming_field_and_pair(tmp_path) -> None:
    path = write(tmp_path, REXROV_TEXT.replace(_DECLARATION, ""))
    with pytest.warns(UserWarning) as record:
        model = load_vehicle(path)
    messages = [str(w.message) for w in record]
    assert len(messages) == 1
    assert "field `hydrodynamics.added_mass`" in messages[0]
    assert "[2, 5] = 10.774 vs [5, 2] = 10.775 (difference 0.001, 9.3e-05 relative)" in messages[0]
    assert "`symmetrised` declaration" in messages[0]  # says how to state it
    assert model.added_mass_matrix[2, 5] == model.added_mass_matrix[5, 2] == 0.5 * (10.774 + 10.775)
    # the same matrix as with the declaration, to the last bit
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        np.testing.assert_array_equal(
            model.added_mass_matrix, load_vehicle("rexrov").added_mass_matrix
        )


@pytest.mark.parametrize(
    ("old", "new", "match"),
    [
        # the matrix changed, the declaration did not
        ("10.775, 21.019", "10.7751, 21.019", r"declared asymmetry \[2, 5\] = 10.774 vs"),
        # a second asymmetric pair (within the tolerance) that is not declared
        ("[-7.8033, 62.726,", "[-7.8034, 62.726,", r"also asymmetric at \[0, 5\]"),
        # beyond the tolerance: refused whatever the declaration says
        ("10.775, 21.019", "10.875, 21.019", r"must be symmetric: \[2, 5\]"),
        # a tighter declared tolerance than the pair's 9.3e-5
        ('"mean", rtol = 1e-3,', '"mean", rtol = 1e-5,', r"more than the 1e-05 relative tol"),
        (
            '"mean", rtol = 1e-3,',
            '"mean", rtol = 1e-2,',
            r"symmetrised.rtol`: must be in \(0, 0.001",
        ),
        ('rule = "mean", rtol', 'rule = "upper", rtol', r"symmetrised.rule`: must be one of"),
        ("[[2, 5, 10.774, 10.775]]", "[[5, 2, 10.775, 10.774]]", r"0 <= i < j < 6"),
        ("[[2, 5, 10.774, 10.775]]", "[[2, 5, 10.774]]", r"pairs\[0\]`: must be \[i, j"),
        ("[[2, 5, 10.774, 10.775]]", "[[2, 5, 10.774, 10.775], [0, 1, 1.0, 1.0]]", "not asym"),
    ],
)
def test_bad_symmetrised_declaration_is_refused(tmp_path, old: str, new: str, match: str) -> None:
    assert old in REXROV_TEXT
    path = write(tmp_path, REXROV_TEXT.replace(old, new, 1))
    with pytest.raises(ValueError, match=r"field `hydrodynamics.added_mass.*" + match):
        load_vehicle(path)


def test_symmetrised_declaration_only_on_symmetric_matrices(tmp_path) -> None:
    start = BUILTIN_TEXT.index("linear_damping = {")
    end = BUILTIN_TEXT.index("\n", start)
    line = BUILTIN_TEXT[start:end].rstrip("} ") + _DECLARATION + " }"
    with pytest.raises(ValueError, match="`hydrodynamics.linear_damping`.*applies to"):
        load_vehicle(write(tmp_path, BUILTIN_TEXT[:start] + line + BUILTIN_TEXT[end:]))
    start = BUILTIN_TEXT.index("added_mass = {")
    end = BUILTIN_TEXT.index("\n", start)
    line = BUILTIN_TEXT[start:end].rstrip("} ") + _DECLARATION + " }"
    with pytest.raises(ValueError, match="`hydrodynamics.added_mass`.*this is a diagonal"):
        load_vehicle(write(tmp_path, BUILTIN_TEXT[:start] + line + BUILTIN_TEXT[end:]))
