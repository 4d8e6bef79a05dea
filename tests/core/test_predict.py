import numpy as np
import pytest

import sampledyn as sd
from sampledyn.exceptions import ConvergenceError


@pytest.fixture(scope="module")
def auv_run():
    model = sd.models.AUVLike()
    signal = sd.signals.Multilevel(hold=0.05, seed=3)
    traj = sd.simulate(model, signal, T=5.0, h=0.01, x0=np.array([1.0, 0.0]))
    return model, signal, traj


@pytest.mark.parametrize("s", [1, 2, 3, 5])
def test_ab_filter_matches_naive_loop(s, auv_run):
    model, _, traj = auv_run
    x_hat = sd.predict(f"AB{s}", model, traj)
    a = sd.AdamsBashforth(s).weights
    f = model.f(traj.t, traj.x, traj.u)
    assert np.isnan(x_hat[:s]).all()
    for k in range(s, traj.n_samples, 37):
        naive = traj.x[k - 1] + traj.h * sum(a[i] * f[k - 1 - i] for i in range(s))
        np.testing.assert_allclose(x_hat[k], naive, rtol=1e-13, atol=1e-15)


def test_euler_ab1_rk1_agree(auv_run):
    model, _, traj = auv_run
    e = sd.predict("E", model, traj)
    np.testing.assert_allclose(sd.predict("AB1", model, traj), e, rtol=0, atol=0)
    np.testing.assert_allclose(sd.predict("RK1", model, traj), e, rtol=1e-14, atol=1e-15)


def test_rk_with_held_signal_equals_without(auv_run):
    # A multilevel input is constant on each interval: intersampling changes nothing.
    model, signal, traj = auv_run
    np.testing.assert_allclose(
        sd.predict("RK4", model, traj, signal=signal), sd.predict("RK4", model, traj), rtol=1e-14
    )


def test_rk_stage_input_uses_left_limit():
    sig = sd.signals.Multilevel(hold=0.1, seed=0)
    t0 = np.array([0.0, 0.1])
    # At tau = h the held part is still the level of the interval's start.
    np.testing.assert_array_equal(sig.intersample(t0, 0.1), sig(t0))


def test_tustin_matches_closed_form_on_linear_system(damped_oscillator):
    model = damped_oscillator
    h = 0.05
    t = h * np.arange(41)
    x = model.flow(t, np.array([1.0, -0.5]))
    traj = sd.Trajectory(
        t=t, x=x, u=np.zeros((41, 1)), h=h, state_names=("a", "b"), state_units=("", "")
    )
    x_hat = sd.predict("T", model, traj)
    eye = np.eye(2)
    step = np.linalg.solve(eye - 0.5 * h * model.a, eye + 0.5 * h * model.a)
    np.testing.assert_allclose(x_hat[1:], x[:-1] @ step.T, rtol=1e-12, atol=1e-14)


class _Stiff:
    nx = 1
    nu = 1
    state_names = ("x",)
    state_units = ("",)
    input_names = ("u",)
    input_units = ("",)

    def f(self, t, x, u):
        return -(np.asarray(x) ** 3) * 1e3

    def jacobian(self, t, x, u):
        return -3e3 * np.asarray(x)[:, :, None] ** 2


def test_tustin_reports_nonconvergence():
    h = 1.0
    t = h * np.arange(5)
    traj = sd.Trajectory(
        t=t, x=np.full((5, 1), 50.0), u=np.zeros((5, 1)), h=h, state_names=("x",), state_units=("",)
    )
    with pytest.raises(ConvergenceError, match="did not converge"):
        sd.predict(sd.Tustin(max_iter=3), _Stiff(), traj)


def test_predict_rejects_nan_naming_sample(auv_run):
    model, _, traj = auv_run
    x = traj.x.copy()
    x[17, 1] = np.nan
    bad = traj.replace(x=x)
    with pytest.raises(ValueError, match="n=17"):
        sd.predict("AB2", model, bad)
    x[17, 1] = np.inf
    with pytest.raises(ValueError, match="NaN or inf"):
        sd.predict("E", model, traj.replace(x=x))


def test_predict_rejects_wrong_model_shape(auv_run, damped_oscillator):
    _, _, traj = auv_run
    three = sd.Trajectory(
        t=traj.t,
        x=np.zeros((traj.n_samples, 3)),
        u=traj.u,
        h=traj.h,
        state_names=("a", "b", "c"),
        state_units=("", "", ""),
    )
    with pytest.raises(ValueError, match="nx=3"):
        sd.predict("E", sd.models.AUVLike(), three)


def test_predict_steps_each_interval_on_non_uniform_time(auv_run):
    # Euler across a longer step uses that step; a time that goes back is refused.
    model, _, traj = auv_run
    t = traj.t.copy()
    t[10:] += 0.003
    x_hat = sd.predict("E", model, traj.replace(t=t))
    f = model.f(t, traj.x, traj.u)
    np.testing.assert_allclose(x_hat[10], traj.x[9] + (t[10] - t[9]) * f[9], rtol=1e-14)
    np.testing.assert_allclose(x_hat[11], traj.x[10] + (t[11] - t[10]) * f[10], rtol=1e-14)
    t[5] = t[4] - 0.001
    with pytest.raises(ValueError, match=r"`data.t` must increase strictly: t\[5\]"):
        sd.predict("E", model, traj.replace(t=t))


def test_model_jacobian_matches_finite_differences():
    model = sd.models.AUVLike()
    rng = np.random.default_rng(1)
    x = rng.uniform(-3, 3, (20, 2))
    x[:, 1] += np.sign(x[:, 1]) * 0.1  # stay off the y = 0 kink
    u = rng.uniform(-10, 10, (20, 1))
    jac = model.jacobian(0.0, x, u)
    eps = 1e-6
    for j in range(2):
        dx = np.zeros(2)
        dx[j] = eps
        fd = (model.f(0.0, x + dx, u) - model.f(0.0, x - dx, u)) / (2 * eps)
        np.testing.assert_allclose(jac[:, :, j], fd, rtol=1e-7, atol=1e-8)


def test_linear_form_reproduces_f():
    model = sd.models.AUVLike(alpha=-0.3, beta=0.1, gamma=-0.7, delta=1.5)
    rng = np.random.default_rng(2)
    x = rng.normal(size=(50, 2))
    u = rng.normal(size=(50, 1))
    lf = model.regressors(0.0, x, u)
    theta = np.array([model.params[n] for n in lf.names])
    np.testing.assert_allclose(lf.phi @ theta + lf.f0, model.f(0.0, x, u), rtol=1e-13, atol=1e-14)
