"""ZOH, the exact zero-order hold as a registered rule: its step is the flow over one
interval with the input held, its linearisation the matrix exponential."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from scipy.linalg import expm
from scipy.signal import cont2discrete

import sampledyn as sd
from sampledyn._discretize import discretize
from sampledyn.experiments._auv import fig2_methods, fig3_methods
from sampledyn.methods import DiscreteTimeSystem, Predictor, get_method
from sampledyn.methods._exact import zoh_matrices
from sampledyn.models import SymbolicModel, load_vehicle


def _linear_model(seed: int = 0):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(3, 3)) - 3.0 * np.eye(3)
    B = rng.normal(size=(3, 2))
    xs, us = sp.symbols("x0:3"), sp.symbols("u0:2")
    rhs = [
        sum(sp.Float(A[i, j]) * xs[j] for j in range(3))
        + sum(sp.Float(B[i, j]) * us[j] for j in range(2))
        for i in range(3)
    ]
    return SymbolicModel(xs, us, rhs, name="linear"), A, B


@pytest.fixture(scope="module")
def rexrov():
    return load_vehicle("rexrov").with_buoyancy(1.0)


def test_zoh_is_a_discrete_time_system_and_no_predictor():
    m = get_method("ZOH")
    assert isinstance(m, DiscreteTimeSystem) and not isinstance(m, Predictor)
    assert (m.family, m.order, m.history) == ("ZOH", None, 1)
    assert "ZOH" not in fig2_methods() + fig3_methods()
    model, _, _ = _linear_model()
    data = sd.Trajectory(
        t=0.1 * np.arange(5), x=np.zeros((5, 3)), u=np.zeros((5, 2)), h=0.1,
        state_names=model.state_names, state_units=model.state_units,
    )  # fmt: skip
    with pytest.raises(ValueError, match="'ZOH' does not predict on sampled data"):
        sd.predict("ZOH", model, data)
    with pytest.raises(ValueError, match="no noise bound"):
        sd.sensitivity.noise_gain("ZOH", 0.1, np.eye(2))


def test_linearisation_is_scipys_zero_order_hold():
    # The same block exponential as scipy's cont2discrete(method="zoh"): equal to a
    # few rounding units of the entries (both call scipy's expm on the same matrix).
    model, A, B = _linear_model()
    h = 0.05
    Az, Bz = discretize(model, "ZOH", h).linearize(np.array([0.3, -0.2, 0.1]), np.ones(2))
    ad, bd, *_ = cont2discrete((A, B, np.eye(3), np.zeros((3, 2))), h, method="zoh")
    np.testing.assert_allclose(Az, ad, rtol=0, atol=1e-14)
    np.testing.assert_allclose(Bz, bd, rtol=0, atol=1e-14)


def test_step_is_the_exact_flow_on_a_linear_model():
    # x+ = e^{Ah} x + int e^{As} ds B u in closed form; the compiled flow integrates with
    # rtol = atol = 1e-12, so 1e-10 relative leaves two decades for the error control.
    model, A, B = _linear_model(1)
    h = 0.2
    d = discretize(model, "ZOH", h)
    ad, bd = zoh_matrices(A, B, h)
    rng = np.random.default_rng(2)
    for _ in range(3):
        x, u = rng.normal(size=3), rng.normal(size=2)
        exact = ad @ x + bd @ u
        np.testing.assert_allclose(d.step(x, u), exact, rtol=1e-10, atol=1e-12)
    z0, u = rng.normal(size=3), rng.normal(size=(6, 2))
    run = d.simulate(z0, u)
    for k in range(6):
        np.testing.assert_allclose(run[k + 1], ad @ run[k] + bd @ u[k], rtol=1e-10, atol=1e-12)
    assert abs(expm(A * h)[0, 0] - ad[0, 0]) == 0.0


def test_rollout_reproduces_the_exact_samples_of_a_held_input(rexrov):
    # Exact samples under an input held between samples: ZOH's one-step rollout is the
    # simulator's flow again (both at tolerance 1e-12 per interval), where RK4 at the
    # same h errs by its local error.
    h, n = 0.1, 60
    rpm = np.random.default_rng(0).uniform(-600, 600, size=(n + 1, rexrov.nu))
    signal = sd.signals.ZeroOrderHold(h * np.arange(n + 1), rpm)
    exact = sd.simulate(rexrov, signal, T=n * h, h=h)
    zoh = discretize(rexrov, "ZOH", h).rollout(exact, 1)[1:] - exact.x[1:]
    rk4 = discretize(rexrov, "RK4", h).rollout(exact, 1)[1:] - exact.x[1:]
    scale = np.abs(exact.x).max()
    assert np.abs(zoh).max() <= 1e-9 * scale
    assert np.abs(rk4).max() > 1e3 * np.abs(zoh).max()


def test_linearisation_is_the_flows_derivative_at_a_trim(rexrov):
    # At the trim of a hold only the horizontal positions move, and they enter no
    # equation: df/dx is constant along the motion, so the flow's derivative is exactly
    # the block exponential. Central differences of the compiled flow (eps 1e-5
    # relative: truncation ~1e-10, the flow's 1e-12 tolerance over eps ~1e-7) agree.
    from sampledyn.experiments import trim

    h = 0.1
    x, u = trim(rexrov, 0.5, 5.0, 0.5)
    d = discretize(rexrov, "ZOH", h)
    A, B = d.linearize(x, u)

    def fd(fun, v):
        cols = []
        for i in range(v.size):
            dv = np.zeros(v.size)
            dv[i] = 1e-5 * max(1.0, abs(v[i]))
            cols.append((fun(v + dv) - fun(v - dv)) / (2 * dv[i]))
        return np.stack(cols, axis=1)

    np.testing.assert_allclose(fd(lambda zz: d.step(zz, u), x), A, rtol=0, atol=1e-6)
    np.testing.assert_allclose(
        fd(lambda uu: d.step(x, uu), u), B, rtol=0, atol=1e-6 * np.abs(B).max()
    )


def test_casadi_view_integrates_the_same_flow():
    # CVODES at rtol = atol = 1e-12 against the compiled flow at the same tolerance.
    pytest.importorskip("casadi")
    model, _, _ = _linear_model(3)
    d = discretize(model, "ZOH", 0.1)
    F = d.to_casadi()
    x, u = np.array([0.2, -0.4, 1.0]), np.array([0.3, -0.1])
    np.testing.assert_allclose(np.array(F(x, u)).ravel(), d.step(x, u), rtol=1e-9, atol=1e-11)
