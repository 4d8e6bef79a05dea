"""The commanded wrench as the input of eq. (5) (issue 20, item 5), and the built-in
6-thruster BlueROV2 (ArduSub's vectored frame)."""

from __future__ import annotations

import numpy as np
import pytest

import sampledyn as sd
from sampledyn.logs._ardupilot import FRAMES, motor_signs


def test_a_wrench_input_is_the_thrusters_tau():
    """f(x, tau) of the wrench vehicle equals f(x, n) of the thruster vehicle with
    tau = B T(n, v) (eqs. (5), (7)); df/dtau = M^-1 in the v rows."""
    v = sd.models.load_vehicle("bluerov2_heavy")
    w = sd.models.load_vehicle("bluerov2_heavy", wrench_input=True)
    assert (w.nu, w.input_names, w.input_units) == (
        6,
        ("X", "Y", "Z", "K", "M", "N"),
        ("N",) * 3 + ("N m",) * 3,
    )
    rng = np.random.default_rng(1)
    x = rng.normal(size=(20, 12)) * 0.3
    n = rng.uniform(-3000, 3000, size=(20, 8))
    tau = v.thrust(x, n) @ v.allocation.T
    # the same sum in another order: rounding of the 6 sums (|f| ~ 1e2, eps 2e-16)
    np.testing.assert_allclose(w.f(0.0, x, tau), v.f(0.0, x, n), rtol=0, atol=1e-12)
    jac = w.input_jacobian(0.0, x[0], tau[0])
    np.testing.assert_array_equal(jac[:6], 0.0)
    np.testing.assert_allclose(jac[6:], v.minv, rtol=0, atol=0)
    lo, hi = w.input_limits()
    assert np.isinf(lo).all() and np.isinf(hi).all()
    with pytest.raises(ValueError, match="no thruster forces"):
        w.thrust(x, tau)
    with pytest.raises(ValueError, match="cannot have `thruster_lag`"):
        v.with_params(wrench_input=True, thruster_lag=True)


def test_a_wrench_vehicle_simulates_and_predicts():
    w = sd.models.load_vehicle("bluerov2_heavy", wrench_input=True)
    c = np.arange(0.0, 4.01, 0.5)
    tau = np.column_stack([5 + 0 * c, 0 * c, -1 + 0 * c, 0 * c, 0 * c, 0.3 * np.sin(c)])
    traj = sd.simulate(w, sd.signals.ZeroOrderHold(c, tau), T=4.0, h=0.1)
    assert traj.x[-1, 6] > 0.05  # 5 N forward: the surge speed builds up
    err = sd.local_errors(sd.predict(sd.get_method("RK4"), w, traj), traj)
    assert np.nanmax(np.abs(err)) < 1e-6  # RK4's O(h^5) truncation on a smooth flow


def test_bluerov2_is_ardusubs_vectored_frame():
    v = sd.models.load_vehicle("bluerov2")
    assert v.nu == 6 and v.mass == pytest.approx(11.5)  # Wu 2018
    # every motor of ArduSub's vectored frame acts like the file's thruster of its
    # number, pushing the other way for a positive output (as the Heavy's)
    np.testing.assert_array_equal(motor_signs(v, FRAMES[1][1], "test"), -np.ones(6))
    heavy = sd.models.load_vehicle("bluerov2_heavy")
    np.testing.assert_array_equal(motor_signs(heavy, FRAMES[2][1], "test"), -np.ones(8))
    # the vertical pair gives roll and heave, no pitch (ArduSub mixes none into it)
    B = v.allocation
    np.testing.assert_allclose(B[4, 4:], 0.0, atol=1e-15)
    assert B[3, 4] == -B[3, 5] != 0
