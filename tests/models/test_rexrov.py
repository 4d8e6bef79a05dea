"""The built-in RexROV (uuv_simulator, after the SF 30k of Berg 2012): published numbers,
the ROS-to-FRD conversion, the thruster allocation of its thruster manager, the Fig. 6
input on its thrusters, and its open-loop motion."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _vehicle_reference import central_differences, random_states, reference_f

import sampledyn as sd
from sampledyn.models import Vehicle, builtin_vehicles, load_vehicle
from sampledyn.signals import fig6_thrusters
from sampledyn.signals._fig6 import FIG6_TABLE

# uuv_simulator, uuv_control/uuv_thruster_manager/config/rexrov/TAM.yaml: the thrust
# allocation in the ROS base_link frame (x forward, y left, z up), rows X Y Z K M N,
# one column per thruster id 0-7.
TAM_YAML = np.array(
    [
        [0.15974268848446743, 0.15974268848446743, -0.1597424266785477, -0.1597424266785477,
         0.7071068613706476, 0.7071068613706476, -0.7071065406341925, -0.7071065406341925],
        [-0.2136101154609486, 0.2136101154609486, -0.21360976537047976, 0.21360976537047976,
         0.7071067010024383, -0.7071067010024383, 0.7071070217388206, -0.7071070217388206],
        [0.9637701967007046, 0.9637701967007046, 0.9637703176884092, 0.9637703176884092,
         0.0, 0.0, 0.0, 0.0],
        [0.4352320257020549, -0.4352320257020549, 0.43523188102298654, -0.43523188102298654,
         -0.09121676442931455, 0.09121676442931455, -0.09121680580430785, 0.09121680580430785],
        [0.9430934973994073, 0.9430934973994073, -0.9430934667380183, -0.9430934667380183,
         0.09121678511681354, 0.09121678511681354, -0.09121674374181084, -0.09121674374181084],
        [0.13688862492470316, -0.13688862492470316, -0.1368884005748274, 0.1368884005748274,
         -0.6487987634902757, 0.6487987634902757, 0.6487987335687417, -0.6487987335687417],
    ]
)  # fmt: skip

# uuv_simulator rexrov.gazebo.xacro, added_mass as printed (FRD, see the vehicle file).
ADDED_MASS_XACRO = np.array(
    [
        [779.79, -6.8773, -103.32, 8.5426, -165.54, -7.8033],
        [-6.8773, 1222, 51.29, 409.44, -5.8488, 62.726],
        [-103.32, 51.29, 3659.9, 6.1112, -386.42, 10.774],
        [8.5426, 409.44, 6.1112, 534.9, -10.027, 21.019],
        [-165.54, -5.8488, -386.42, -10.027, 842.69, -1.1162],
        [-7.8033, 62.726, 10.775, 21.019, -1.1162, 224.32],
    ]
)

FLU = np.diag([1.0, -1.0, -1.0])  # rotation by pi about x: ROS base_link <-> FRD


@pytest.fixture(scope="module")
def rexrov() -> Vehicle:
    return load_vehicle("rexrov")


def test_published_numbers(rexrov: Vehicle) -> None:
    assert "rexrov" in builtin_vehicles()
    p = rexrov.params
    assert p["mass"] == 1862.87 and p["volume"] == 1.83826 and p["rho"] == 1028.0
    # rexrov_base.xacro: ixx 525.39 iyy 794.20 izz 691.23 ixy 1.44 ixz 33.41 iyz 2.6 in
    # FLU; I_FRD = T I_FLU T, T = diag(1, -1, -1)
    i_flu = np.array([[525.39, 1.44, 33.41], [1.44, 794.20, 2.6], [33.41, 2.6, 691.23]])
    np.testing.assert_array_equal(rexrov.inertia_tensor, FLU @ i_flu @ FLU)
    assert (p["Ixy"], p["Ixz"], p["Iyz"]) == (1.44, 33.41, -2.6)  # Fossen's products
    # centre of buoyancy 0.3 m above the CG (cob = 0 0 0.3 in FLU)
    assert rexrov.r_G == (0.0, 0.0, 0.0) and rexrov.r_B == (0.0, 0.0, -0.3)
    # the full added-mass matrix, its one printed-digit asymmetry averaged
    np.testing.assert_array_equal(
        rexrov.added_mass_matrix, 0.5 * (ADDED_MASS_XACRO + ADDED_MASS_XACRO.T)
    )
    np.testing.assert_array_equal(
        rexrov.added_mass_matrix[~np.eye(6, dtype=bool) & (ADDED_MASS_XACRO == ADDED_MASS_XACRO.T)],
        ADDED_MASS_XACRO[~np.eye(6, dtype=bool) & (ADDED_MASS_XACRO == ADDED_MASS_XACRO.T)],
    )
    assert np.count_nonzero(ADDED_MASS_XACRO != ADDED_MASS_XACRO.T) == 2  # the (2, 5) pair
    # damping: the plugin uses D = -(xacro values)
    assert rexrov.linear_damping == (74.82, 69.48, 728.4, 268.8, 309.77, 105.0)
    assert rexrov.quadratic_damping == (748.22, 992.53, 1821.01, 672.0, 774.44, 523.27)
    # M = M_RB + M_A is symmetric positive definite, with every coupling kept
    M = rexrov.mass_matrix
    assert np.linalg.eigvalsh(M).min() > 900.0
    assert np.count_nonzero(M[~np.eye(6, dtype=bool)]) == 30
    assert all(s.strip() for s in rexrov.sources.values())


def test_buoyancy_as_published(rexrov: Vehicle) -> None:
    # (rho V - m) / m from the published numbers: 1.44 % buoyant
    published = (1028.0 * 1.83826 - 1862.87) / 1862.87
    assert rexrov.buoyancy / rexrov.weight - 1.0 == pytest.approx(published, rel=1e-12)
    assert round(100 * published, 2) == 1.44
    f = rexrov.f(0.0, np.zeros(12), np.zeros(8))
    assert f[8] < 0  # rises at rest (z down)


def test_thruster_coefficients(rexrov: Vehicle) -> None:
    # rotor constant 0.00031 N/(rad/s)^2, omega = 2 pi n / 60
    assert rexrov.K1 == pytest.approx(0.00031 * (math.pi / 30) ** 2, rel=1e-7)
    # n_max from the thruster manager's 2000 N: 2540 rad/s, about 24,250 rpm
    omega_max = math.sqrt(2000.0 / 0.00031)
    assert rexrov.n_max == pytest.approx(omega_max * 30 / math.pi, abs=0.01)
    assert rexrov.K1 * rexrov.n_max**2 == pytest.approx(2000.0, rel=1e-6)
    assert rexrov.K2 == 0.0 and rexrov.lag_time_constant == 0.05
    at_max = rexrov.thrust(np.zeros(12), np.full(8, 2 * rexrov.n_max))
    np.testing.assert_allclose(at_max, 2000.0, rtol=1e-6)  # saturated at n_max


def test_allocation_matches_the_thruster_manager(rexrov: Vehicle) -> None:
    # TAM.yaml is in the ROS base_link frame: B_FLU = diag(T, T) B_FRD
    t6 = np.kron(np.eye(2), FLU)
    np.testing.assert_allclose(t6 @ rexrov.allocation, TAM_YAML, rtol=0, atol=3e-7)
    # the vertical thrusters push up with a positive command
    assert (rexrov.allocation[2, :4] < -0.96).all()


def test_fig6_rows_on_the_rexrov_thrusters(rexrov: Vehicle) -> None:
    signal = fig6_thrusters(rexrov)
    # rows 1-4 (up, up, down, down) -> T1-T4, the tilted verticals (uuv ids 0-3, the
    # rear pair first); rows 5-8 (forward) -> T5-T8 (ids 4-7)
    n_max = rexrov.n_max
    np.testing.assert_allclose(np.abs(signal.offset) / n_max, [abs(r[1]) / 100 for r in FIG6_TABLE])
    np.testing.assert_allclose(np.abs(signal.amp[:, 0]) / n_max, [r[3] / 100 for r in FIG6_TABLE])
    np.testing.assert_array_equal(signal.freq_hz[:, 0], [r[4] for r in FIG6_TABLE])
    # each row's mean pushes the way its label says (thrust ~ n |n| along d_i)
    force = rexrov.allocation[:3] * np.sign(signal.offset)
    want = {"up": (2, -1.0), "down": (2, 1.0), "forward": (0, 1.0)}
    for i, row in enumerate(FIG6_TABLE):
        axis, sign = want[row[2]]
        assert sign * force[axis, i] > 0.7, (i, row)


def test_f_and_jacobian_against_references(rexrov: Vehicle) -> None:
    for model in (rexrov, rexrov.with_params(thruster_lag=True, r_G=(0.01, -0.02, 0.05))):
        x, u = random_states(model, 6, seed=31, rpm_frac=1.2)
        f = model.f(0.0, x, u)
        jac = model.jacobian(0.0, x, u)
        for i in range(6):
            np.testing.assert_allclose(f[i], reference_f(model, x[i], u[i]), rtol=1e-10, atol=1e-10)
            fd = central_differences(model, x[i], u[i])
            np.testing.assert_allclose(jac[i], fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max())


def test_open_loop_fig6_motion_stays_in_the_papers_region(rexrov: Vehicle) -> None:
    # Fig. 7 set-up: open loop, +1 % buoyancy. The first 300 s hold the whole run's
    # largest pitch (20.7 deg up to T = 1000 s, see the README), at a fraction of the cost.
    vehicle = rexrov.with_params(volume=1.01 * rexrov.mass / rexrov.rho)
    exact = sd.simulate(vehicle, fig6_thrusters(vehicle), 300.0, 0.1, rtol=1e-11, atol=1e-11)
    theta = np.degrees(np.abs(exact.x[:, 4])).max()
    phi = np.degrees(np.abs(exact.x[:, 3])).max()
    assert 5.0 < theta < 40.0 and phi < 40.0
    assert exact.x[exact.t > 100, 6].mean() > 0.3  # it does make way forward
    assert exact.certificate.per_interval.max() < 1e-11
