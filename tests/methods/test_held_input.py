"""Adams-Bashforth with the input held over the predicted interval: ABu_s, and ABj_s,
which also rebuilds its history after an input jump."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm

import sampledyn as sd
from sampledyn.experiments._auv import fig2_methods
from sampledyn.methods import ab_coefficients, available_methods, get_method
from sampledyn.methods._jump import backward_weights

A = np.array([[0.0, 1.0], [-4.0, -0.4]])
B = np.array([0.0, 1.0])


class LinearPlant:
    """x' = A x + B u, exact samples under a zero-order-hold input by the matrix
    exponential (no integrator in the reference)."""

    nx, nu = 2, 1
    state_names, state_units = ("x", "y"), ("m", "m/s")
    input_names, input_units = ("u",), ("",)

    def f(self, t, x, u):
        return np.asarray(x) @ A.T + np.asarray(u)[:, :1] * B

    def jacobian(self, t, x, u):
        return np.broadcast_to(A, (np.shape(x)[0], 2, 2)).copy()

    def samples(self, h, hold, T, seed=0):
        """Exact samples at period h of a random level held for ``hold`` seconds."""
        n = int(round(T / h)) + 1
        t = h * np.arange(n)
        levels = np.random.default_rng(seed).uniform(-10, 10, int(T / hold) + 2)
        u = levels[np.floor(t / hold + 1e-9).astype(int)]
        e = expm(A * h)
        g = np.linalg.solve(A, (e - np.eye(2)) @ B)
        x = np.empty((n, 2))
        x[0] = (1.0, 0.0)
        for k in range(n - 1):
            x[k + 1] = e @ x[k] + g * u[k]
        return sd.Trajectory(
            t=t, x=x, u=u[:, None], h=h, state_names=self.state_names, state_units=self.state_units
        )


def test_abu_is_registered_and_listed():
    names = available_methods()
    assert {f"ABu{s}" for s in range(1, 7)} <= set(names)
    m = get_method("ABu3")
    assert (m.name, m.family, m.order, m.history, m.intersample) == ("ABu3", "ABu", 3, 3, False)
    assert m.first_order_gain == sd.AdamsBashforth(3).a_s
    assert {f"ABu{s}" for s in range(1, 7)} <= set(fig2_methods())


@pytest.mark.parametrize("s", range(1, 7))
def test_abu_equals_ab_under_a_constant_input(s):
    plant = LinearPlant()
    data = plant.samples(0.01, hold=100.0, T=2.0)  # one level throughout
    np.testing.assert_allclose(
        get_method(f"ABu{s}").predict(plant, data),
        get_method(f"AB{s}").predict(plant, data),
        rtol=1e-14,
        atol=1e-15,
    )


@pytest.mark.parametrize("s", [2, 4, 6])
def test_abu_uses_the_current_input_over_the_history(s):
    plant = LinearPlant()
    data = plant.samples(0.01, hold=0.03, T=1.0)
    x_hat = get_method(f"ABu{s}").predict(plant, data)
    a = [float(c) for c in ab_coefficients(s)]
    for k in range(s, data.n_samples, 7):
        n = k - 1
        u_n = np.full((s, 1), data.u[n, 0])
        past = np.arange(n, n - s, -1)
        f = plant.f(data.t[past], data.x[past], u_n)
        naive = data.x[n] + data.h * sum(a[i] * f[i] for i in range(s))
        np.testing.assert_allclose(x_hat[k], naive, rtol=1e-13, atol=1e-14)


def test_abu_evaluates_f_only_where_the_input_changed():
    plant = LinearPlant()
    data = plant.samples(0.01, hold=0.05, T=2.0)
    calls: list[int] = []

    class Counting(LinearPlant):
        def f(self, t, x, u):
            calls.append(np.shape(x)[0])
            return super().f(t, x, u)

    s = 4
    get_method(f"ABu{s}").predict(Counting(), data)
    u = data.u[:, 0]
    n = np.arange(s - 1, data.n_samples - 1)
    moved = sum(int((u[n - i] != u[n]).sum()) for i in range(1, s))
    assert calls[0] == data.n_samples  # f at the samples, once
    assert sum(calls[1:]) == moved and 0 < moved < (s - 1) * n.size


def _jump_errors(name, hs, hold=0.1):
    """Largest local error over the samples whose history holds an input jump."""
    plant = LinearPlant()
    out = []
    for h in hs:
        data = plant.samples(h, hold=hold, T=4.0)
        m = get_method(name)
        e = np.linalg.norm(data.x - m.predict(plant, data), axis=1)
        u = data.u[:, 0]
        # samples k whose prediction history u[k-s..k-1] is not constant
        hist = np.zeros(data.n_samples, dtype=bool)
        for k in range(m.history + 1, data.n_samples):
            hist[k] = np.unique(u[k - m.history : k]).size > 1
        out.append(np.nanmax(e[hist]))
    return np.array(out)


@pytest.mark.parametrize("s", [2, 3, 4])
def test_a_jump_costs_ab_one_order_of_h_and_abu_two(s):
    # Fixed hold h_u = 0.1 s, h -> 0: after a jump AB_s extrapolates it (error O(h)),
    # ABu_s does not, but its history moved under the old input (error O(h^2)).
    hs = np.array([0.02, 0.01, 0.005, 0.0025])
    ab = np.polyfit(np.log(hs), np.log(_jump_errors(f"AB{s}", hs)), 1)[0]
    abu = np.polyfit(np.log(hs), np.log(_jump_errors(f"ABu{s}", hs)), 1)[0]
    assert abs(ab - 1.0) < 0.15, ab
    assert abs(abu - 2.0) < 0.15, abu


def test_abu_reaches_the_bounds_and_the_cli(capsys):
    from sampledyn.cli import main

    L = np.array([[0.1, 1.0], [2.0, 3.0]])
    np.testing.assert_array_equal(
        sd.sensitivity.noise_gain("ABu4", 0.1, L), sd.sensitivity.noise_gain("AB4", 0.1, L)
    )
    assert sd.sensitivity.error_constant("ABu4") == sd.sensitivity.error_constant("AB4")
    assert main(["methods"]) == 0
    out = capsys.readouterr().out
    assert "ABu<s>" in out and "ABu6" in out


# ---------------------------------------------------------------------------- ABj_s
@pytest.mark.parametrize("s", range(1, 8))
def test_backward_weights_integrate_polynomials_exactly(s):
    from fractions import Fraction as F

    c = backward_weights(s)
    for j in range(s):
        assert sum(c[j]) == j  # the integral of 1 over [-j, 0]
        for degree in range(s):  # the integral of tau^d over [-j, 0]
            exact = -(F(-j) ** (degree + 1)) / (degree + 1)
            assert sum(c[j][k] * F(-k) ** degree for k in range(s)) == exact


@pytest.mark.parametrize("s", range(1, 7))
def test_abj_equals_ab_under_a_constant_input(s):
    plant = LinearPlant()
    data = plant.samples(0.01, hold=100.0, T=2.0)
    np.testing.assert_allclose(
        get_method(f"ABj{s}").predict(plant, data),
        get_method(f"AB{s}").predict(plant, data),
        rtol=1e-14,
        atol=1e-15,
    )


def test_abj_is_registered_and_in_fig2():
    m = get_method("ABj4")
    assert (m.family, m.order, m.history, m.sample_weights) == ("ABj", 4, 4, None)
    assert {f"ABj{s}" for s in range(1, 7)} <= set(fig2_methods())


@pytest.mark.parametrize("s", [2, 3, 4, 5])
def test_abj_keeps_its_order_across_jumps(s):
    # Linear plant, exact samples by expm, hold 0.1 s: the largest error over the
    # predictions whose history holds a jump falls like h^(s+1) (ABu_s: h^2).
    hs = np.array([0.02, 0.01, 0.005, 0.0025]) if s < 5 else np.array([0.04, 0.02, 0.01, 0.005])
    slope = np.polyfit(np.log(hs), np.log(_jump_errors(f"ABj{s}", hs, hold=0.2)), 1)[0]
    assert abs(slope - (s + 1)) < 0.35, slope


class Pendulum:
    """Smooth and nonlinear: x' = y, y' = -sin x - 0.3 y + 0.5 u (1 + 0.3 cos x)."""

    nx, nu = 2, 1
    state_names, state_units = ("x", "y"), ("rad", "rad/s")

    def f(self, t, x, u):
        x, u = np.atleast_2d(x), np.atleast_2d(u)
        drive = 0.5 * u[:, 0] * (1.0 + 0.3 * np.cos(x[:, 0]))
        return np.stack([x[:, 1], -np.sin(x[:, 0]) - 0.3 * x[:, 1] + drive], axis=1)

    def jacobian(self, t, x, u):
        x, u = np.atleast_2d(x), np.atleast_2d(u)
        jac = np.zeros((x.shape[0], 2, 2))
        jac[:, 0, 1] = 1.0
        jac[:, 1, 0] = -np.cos(x[:, 0]) - 0.15 * u[:, 0] * np.sin(x[:, 0])
        jac[:, 1, 1] = -0.3
        return jac


def _pendulum(h, hold=0.4, duration=6.0):
    plant = Pendulum()
    n = int(round(duration / h)) + 1
    t = h * np.arange(n)
    u = np.random.default_rng(0).uniform(-3, 3, int(duration / hold) + 2)[
        np.floor(t / hold + 1e-9).astype(int)
    ]
    x = np.empty((n, 2))
    x[0] = (0.5, 0.0)
    for k in range(n - 1):
        sol = solve_ivp(
            lambda _t, z, uk=u[k]: plant.f(0.0, z, np.array([[uk]]))[0],
            (0.0, h),
            x[k],
            method="DOP853",
            rtol=1e-13,
            atol=1e-15,
        )
        x[k + 1] = sol.y[:, -1]
    return plant, sd.Trajectory(
        t=t, x=x, u=u[:, None], h=h, state_names=("x", "y"), state_units=("rad", "rad/s")
    )


def test_abj_keeps_order_three_across_jumps_on_a_nonlinear_plant():
    hs = np.array([0.04, 0.02, 0.01])
    errs = {"ABj3": [], "ABu3": []}
    for h in hs:
        plant, data = _pendulum(h)
        hist = np.array([np.unique(data.u[k - 3 : k]).size > 1 for k in range(data.n_samples)])
        hist[:4] = False
        for name in errs:
            e = np.linalg.norm(data.x - get_method(name).predict(plant, data), axis=1)
            errs[name].append(e[hist].max())
    assert abs(np.polyfit(np.log(hs), np.log(errs["ABj3"]), 1)[0] - 4.0) < 0.3
    assert abs(np.polyfit(np.log(hs), np.log(errs["ABu3"]), 1)[0] - 2.0) < 0.3


def test_after_a_jump_abj_passes_noise_like_euler():
    # The rebuilt history depends on x_n alone to first order: at a jump the noise
    # gain is h L (Euler), not h a_s L; the rule's bound covers both kinds of rows.
    plant = LinearPlant()
    data = plant.samples(0.01, hold=0.1, T=1.0)
    m = get_method("ABj4")
    phi = m.prediction_jacobians(plant, data)
    u = data.u[:, 0]
    eye = np.eye(2)
    for k in range(5, data.n_samples):
        total = sum(np.abs(phi[k, i] - (eye if i == 0 else 0)) for i in range(4))
        if np.unique(u[k - 4 : k]).size > 1:
            np.testing.assert_allclose(total, 0.01 * np.abs(A), rtol=0.05, atol=2e-4)
        else:
            np.testing.assert_allclose(total, 0.01 * float(m.first_order_gain) * np.abs(A))
