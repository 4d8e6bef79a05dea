"""Models check what they are given (shapes, parameters, pitch near 90 deg), and a
closed loop's Jacobian is the chain rule through its plant."""

from __future__ import annotations

import numpy as np
import pytest

import sampledyn as sd


@pytest.fixture
def model():
    return sd.models.AUVLike()


def test_model_f_shape_errors(model):
    with pytest.raises(ValueError, match=r"`x` must have shape \(N, 2\)"):
        model.f(0.0, np.zeros((4, 3)), np.zeros((4, 1)))
    with pytest.raises(ValueError, match="`u` must have shape"):
        model.f(0.0, np.zeros((4, 2)), np.zeros((5, 1)))


def test_model_parameters_validated():
    with pytest.raises(ValueError, match="`alpha`"):
        sd.models.AUVLike(alpha=float("nan"))
    with pytest.raises(TypeError, match="unknown parameter"):
        sd.models.AUVLike().with_params(zeta=1.0)


def test_pitch_check_of_a_batch_is_the_full_check():
    """The shortcut (every |theta| clearly below both thresholds) gives the answer of the
    full check; near and past the thresholds the full check runs."""
    from sampledyn.models._rigid_body import _pitch_verdict, check_pitch

    def full(theta, tol, limit):
        c = np.abs(np.cos(theta))
        worst = int(np.argmin(c))
        return _pitch_verdict(float(c[worst]), float(theta[worst]), worst, tol, limit)

    rng = np.random.default_rng(11)
    for scale in (0.1, 0.5, 1.2, 1.39, 1.4, 1.5):
        for _ in range(50):
            theta = rng.uniform(-scale, scale, 64)
            for tol, limit in ((0.5, 80.0), (0.5, None), (10.0, 85.0)):
                try:
                    want = full(theta, tol, limit)
                except ValueError as exc:
                    with pytest.raises(ValueError) as got:
                        check_pitch(theta, tol, limit)
                    assert str(got.value) == str(exc)
                    continue
                assert check_pitch(theta, tol, limit) == want


def test_closed_loop_jacobian_is_the_chain_rule_through_the_plant_bit_for_bit():
    veh = sd.models.load_vehicle("bluerov2_heavy")
    hold = sd.models.AttitudeHold(veh)
    assert hold._jacobian_parts() is not None  # the plant has compiled Jacobian kernels
    rng = np.random.default_rng(2)
    x = rng.normal(size=(300, 12)) * 0.2
    u = rng.uniform(-1.5, 1.5, (300, 8)) * veh.n_max  # saturated rpm included
    t = np.zeros(300)

    def by_hand(tt, xx, rr):
        ua = hold.applied_input(tt, xx, rr)
        f_u = veh.input_jacobian(tt, xx, ua)
        k_x = np.broadcast_to(hold.law.gain, (xx.shape[0], 8, 12)).copy()
        return veh.jacobian(tt, xx, ua) + f_u @ k_x, f_u

    want, f_u = by_hand(t, x, u)
    assert np.array_equal(hold.jacobian(t, x, u), want)
    assert np.array_equal(hold.input_jacobian(t, x, u), f_u @ np.eye(8))
    for i in (0, 7, 299):  # one state, and a batch of one
        assert np.array_equal(hold.jacobian(0.0, x[i], u[i]), want[i])
        assert np.array_equal(hold.jacobian(t[:1], x[i : i + 1], u[i : i + 1])[0], want[i])
    # the plant's pitch check still applies
    bad = x[0].copy()
    bad[4] = np.radians(89.8)
    with pytest.raises(ValueError, match="pitch angle"):
        hold.jacobian(0.0, bad, u[0])
    # the vehicle's input Jacobian kernel is its input_jacobian
    jac_u, p = veh.input_jacobian_kernel()
    out = np.empty((12, 8))
    from sampledyn.models._base import readonly

    jac_u(0.0, readonly(x[3]), readonly(u[3]), readonly(p), out)
    assert np.array_equal(out, veh.input_jacobian(0.0, x[3], u[3]))
