"""Thruster saturation: the applied rpm is clip(n, -n_max, n_max), a kink the exact
simulator locates, and simulate warns for how long the command exceeded n_max."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import sampledyn as sd
from sampledyn.models import Vehicle, load_vehicle
from sampledyn.signals import Sinusoidal

F_HZ = 0.2
# thrusters 1 and 5 swing past n_max = 3533 rpm, the others stay inside
OFFSET = np.array([1000.0, 0.0, 0.0, 0.0, 1500.0, 300.0, 0.0, -200.0])
AMP = np.array([3000.0, 0.0, 0.0, 0.0, 2500.0, 400.0, 0.0, 1000.0])


@pytest.fixture(scope="module")
def rov() -> Vehicle:
    return load_vehicle("bluerov2_heavy")


def swing() -> Sinusoidal:
    return Sinusoidal(OFFSET, AMP, np.full(8, F_HZ))


def test_applied_rpm_is_clipped(rov: Vehicle) -> None:
    x = np.zeros(12)
    x[6:12] = [0.3, -0.1, 0.2, 0.1, -0.2, 0.05]
    u = np.array([5000.0, -9000.0, 100.0, 3533.0, -3533.0, 0.0, 2000.0, -4000.0])
    clipped = np.clip(u, -rov.n_max, rov.n_max)
    np.testing.assert_array_equal(rov.saturate(u), clipped)
    np.testing.assert_array_equal(rov.f(0.0, x, u), rov.f(0.0, x, clipped))
    np.testing.assert_array_equal(rov.jacobian(0.0, x, u), rov.jacobian(0.0, x, clipped))
    np.testing.assert_array_equal(rov.thrust(x, u), rov.thrust(x, clipped))
    lo, hi = rov.input_limits()
    np.testing.assert_array_equal(hi, np.full(8, rov.n_max))
    np.testing.assert_array_equal(lo, -hi)
    # with the lag the saturated command drives the rpm states, eq. (3)
    lagged = rov.with_params(thruster_lag=True, T_n=0.2)
    xl = np.concatenate([x, np.full(8, 1000.0)])
    np.testing.assert_allclose(lagged.f(0.0, xl, u)[12:], (clipped - 1000.0) / 0.2)


def test_switching_values_include_the_saturation_corners(rov: Vehicle) -> None:
    sw, p, input_only = rov.switch_kernel()
    x = np.arange(12.0)
    u = np.linspace(-4000.0, 4000.0, 8)
    out = np.empty(6 + 24)
    sw(0.0, x, u, p, out)
    np.testing.assert_array_equal(out[:6], x[6:12])
    np.testing.assert_array_equal(out[6:14], u)
    np.testing.assert_array_equal(out[14:22], u - rov.n_max)
    np.testing.assert_array_equal(out[22:], u + rov.n_max)
    np.testing.assert_array_equal(input_only, [False] * 6 + [True] * 24)


def test_simulate_warns_for_how_long_the_command_exceeded(rov: Vehicle) -> None:
    with pytest.warns(UserWarning, match="saturates") as record:
        sd.simulate(rov, swing(), 10.0, 0.1, certify=False)
    (message,) = [str(w.message) for w in record]
    # closed form: n_r5 = 1500 + 2500 sin(w t) is the longer excursion and contains
    # n_r1's (both exceed where sin is above 0.8132 resp. 0.8443, in phase)
    s5 = (rov.n_max - 1500.0) / 2500.0
    first = math.asin(s5) / (2 * math.pi * F_HZ)
    total = 2 * (math.pi - 2 * math.asin(s5)) / (2 * math.pi * F_HZ)  # two periods
    got_total = float(message.split(" for ")[1].split(" s ")[0])
    got_first = float(message.split("first at t = ")[1].split(" s")[0])
    assert got_total == pytest.approx(total, rel=1e-3)
    assert got_first == pytest.approx(first, abs=1e-3)
    assert "n_r1" in message and "n_r5" in message and "n_r8" not in message
    # inside the limits: no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sd.simulate(rov.with_params(n_max=6000.0), swing(), 10.0, 0.1, certify=False)


@pytest.mark.parametrize("rtol", [1e-12, 1e-13])
def test_saturated_run_is_exact_across_the_kink(rov: Vehicle, rtol: float) -> None:
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", "the input leaves", UserWarning)
        saturated = sd.simulate(rov, swing(), 10.0, 0.1, rtol=rtol, atol=rtol)
    free = sd.simulate(rov.with_params(n_max=6000.0), swing(), 10.0, 0.1, rtol=rtol, atol=rtol)
    assert not np.array_equal(saturated.x, free.x)
    # certified to the level of the run that never saturates
    cert = saturated.certificate.per_interval
    assert cert.max() < rtol and cert.max() < 3.0 * free.certificate.per_interval.max()

    # the interval where n_r5 reaches n_max, against scipy integrating the two smooth
    # pieces on either side of the closed-form crossing time
    tc = math.asin((rov.n_max - 1500.0) / 2500.0) / (2 * math.pi * F_HZ)
    n = int(tc / 0.1)
    t0, t1 = saturated.t[n], saturated.t[n + 1]
    assert t0 < tc < t1
    # no other kink inside: velocities and rpm keep their signs
    assert (np.sign(saturated.x[n, 6:12]) == np.sign(saturated.x[n + 1, 6:12])).all()
    assert (np.sign(swing()(np.array([t0]))) == np.sign(swing()(np.array([t1])))).all()

    def f(t: float, x: np.ndarray) -> np.ndarray:
        return rov.f(t, x, swing()(np.array([t]))[0])

    def scipy_flow(tol: float) -> np.ndarray:
        mid = solve_ivp(f, (t0, tc), saturated.x[n], method="DOP853", rtol=tol, atol=tol)
        return solve_ivp(f, (tc, t1), mid.y[:, -1], method="DOP853", rtol=tol, atol=tol).y[:, -1]

    error = np.abs(saturated.x[n + 1] - scipy_flow(1e-14)) / saturated.certificate.scale
    # the certificate of the crossing interval bounds the true flow error ...
    assert error.max() <= 2.0 * cert[n] + 1e-15
    if rtol == 1e-13:  # ... and at rtol 1e-13 the samples match scipy at rtol 1e-13
        ref = scipy_flow(1e-13)
        scale = saturated.certificate.scale
        np.testing.assert_array_less(np.abs(saturated.x[n + 1] - ref), 1e-13 * scale)


class _WithoutSaturationKinks:
    """The vehicle seen by the simulator without its saturation corners: only the
    |v| v and n |n| kinks (``kink_states`` / ``kink_inputs``)."""

    def __init__(self, vehicle: Vehicle) -> None:
        self.vehicle = vehicle
        for name in ("nx", "nu", "state_names", "state_units", "input_names", "input_units"):
            setattr(self, name, getattr(vehicle, name))
        self.default_x0 = vehicle.default_x0
        self.kink_states = vehicle.kink_states
        self.kink_inputs = vehicle.kink_inputs

    def kernel(self):
        return self.vehicle.kernel()


def test_locating_the_saturation_is_what_certifies_the_run(rov: Vehicle) -> None:
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", "the input leaves", UserWarning)
        located = sd.simulate(rov, swing(), 10.0, 0.1)
    blind = sd.simulate(_WithoutSaturationKinks(rov), swing(), 10.0, 0.1)
    # stepping over the corner of clip(n) blindly costs about three orders of magnitude
    assert blind.certificate.per_interval.max() > 100 * located.certificate.per_interval.max()
    assert located.certificate.steps.sum() < blind.certificate.steps.sum()
