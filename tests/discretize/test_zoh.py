"""ZOH, the exact zero-order hold as a registered rule: its step is the flow over one
interval with the input held, its linearisation the flow's derivative (the variational
equations along the flow; the matrix exponential where df/dx is constant over the
interval)."""

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
from sampledyn.methods._exact import ExactFlow, zoh_matrices
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
    # On a linear model the flow's derivative is the zero-order hold of (A, B) at every
    # point. At the equilibrium x* = -A^-1 B u it is the same block exponential as
    # scipy's cont2discrete(method="zoh") (both call scipy's expm on the same matrix: a
    # few rounding units); off it (the state moves) it is the variational equations
    # integrated at rtol = atol = 1e-12, which leaves 1e-11 over the tens of steps.
    model, A, B = _linear_model()
    h = 0.05
    d = discretize(model, "ZOH", h)
    ad, bd, *_ = cont2discrete((A, B, np.eye(3), np.zeros((3, 2))), h, method="zoh")
    u = np.ones(2)
    Az, Bz = d.linearize(-np.linalg.solve(A, B @ u), u)
    np.testing.assert_allclose(Az, ad, rtol=0, atol=1e-14)
    np.testing.assert_allclose(Bz, bd, rtol=0, atol=1e-14)
    Az, Bz = d.linearize(np.array([0.3, -0.2, 0.1]), u)
    np.testing.assert_allclose(Az, ad, rtol=0, atol=1e-11)
    np.testing.assert_allclose(Bz, bd, rtol=0, atol=1e-11)


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
    # k steps of the held-input flow are the exact samples k steps on (the multistep
    # study's rollout): the 1e-12 per interval tolerance over k = 5 intervals.
    zoh5 = discretize(rexrov, "ZOH", h).rollout(exact, 5)[5:] - exact.x[5:]
    assert np.abs(zoh5).max() <= 1e-9 * scale


def _central_differences(fun, v):
    """d fun / d v by central differences, steps 1e-5 relative: truncation ~1e-10, the
    flow's 1e-12 tolerance over the step ~1e-7 of the entries."""
    cols = []
    for i in range(v.size):
        dv = np.zeros(v.size)
        dv[i] = 1e-5 * max(1.0, abs(v[i]))
        cols.append((fun(v + dv) - fun(v - dv)) / (2 * dv[i]))
    return np.stack(cols, axis=1)


def _off_trim(rexrov):
    """A state and input away from any equilibrium: velocities 0.5 m/s, rad/s off the
    hold's trim, roll and pitch 0.3 rad, the thrusters 300 rpm off."""
    from sampledyn.experiments import trim

    x, u = trim(rexrov, 0.5, 5.0, 0.5)
    rng = np.random.default_rng(0)
    x = x.copy()
    x[6:] += 0.5 * rng.normal(size=6)
    x[3:5] += 0.3
    return x, u + 300.0 * rng.normal(size=u.size)


def _variational_by_scipy(model, x, u, h):
    """(Phi, Gamma) from scipy's DOP853 at rtol = atol = 1e-13 on the state and the
    variational equations Phi' = f_x Phi, Gamma' = f_x Gamma + f_u."""
    from scipy.integrate import solve_ivp

    nx, nu = model.nx, model.nu

    def rhs(t, y):
        M = y[nx:].reshape(nx, nx + nu)
        dM = model.jacobian(t, y[:nx], u) @ M
        dM[:, nx:] += model.input_jacobian(t, y[:nx], u)
        return np.concatenate([model.f(t, y[:nx], u), dM.ravel()])

    y0 = np.concatenate([x, np.hstack([np.eye(nx), np.zeros((nx, nu))]).ravel()])
    sol = solve_ivp(rhs, (0.0, h), y0, method="DOP853", rtol=1e-13, atol=1e-13)
    M = sol.y[nx:, -1].reshape(nx, nx + nu)
    return M[:, :nx], M[:, nx:]


def test_linearisation_is_the_flows_derivative_off_a_trim(rexrov):
    # Off a trim df/dx changes along the interval, so the matrix exponential of the
    # Jacobian at the start is not the flow's derivative (it misses by more than 1e-3
    # of the entries here); the variational equations are. Against scipy's DOP853 on
    # the same equations at 1e-13: 1e-10 of the largest entry (the two integrations'
    # tolerances, 1e-12 and 1e-13, over the interval's steps); against central
    # differences of the compiled step: 1e-6 (their truncation and rounding, above).
    h = 0.1
    x, u = _off_trim(rexrov)
    d = discretize(rexrov, "ZOH", h)
    A, B = d.linearize(x, u)
    As, Bs = _variational_by_scipy(rexrov, x, u, h)
    np.testing.assert_allclose(A, As, rtol=0, atol=1e-10 * np.abs(As).max())
    np.testing.assert_allclose(B, Bs, rtol=0, atol=1e-10 * np.abs(Bs).max())
    Af = _central_differences(lambda zz: d.step(zz, u), x)
    Bf = _central_differences(lambda uu: d.step(x, uu), u)
    np.testing.assert_allclose(A, Af, rtol=0, atol=1e-6 * np.abs(Af).max())
    np.testing.assert_allclose(B, Bf, rtol=0, atol=1e-6 * np.abs(Bf).max())
    Ae, Be = zoh_matrices(rexrov.jacobian(0.0, x, u), rexrov.input_jacobian(0.0, x, u), h)
    assert np.abs(Ae - As).max() > 1e-3 * np.abs(As).max()
    assert np.abs(Be - Bs).max() > 1e-4 * np.abs(Bs).max()


def test_linearisation_is_the_flows_derivative_at_a_trim(rexrov):
    # At the trim of a hold only the horizontal positions move, and they enter no
    # equation: df/dx is constant along the motion, so the flow's derivative is exactly
    # the block exponential, which linearize returns (the same arithmetic as
    # zoh_matrices, bit for bit in this run). The variational equations agree to
    # 1e-11 (their integration at 1e-12), and so do central differences (1e-6, above).
    from sampledyn._discretize._model import _CompiledFlows
    from sampledyn.experiments import trim

    h = 0.1
    x, u = trim(rexrov, 0.5, 5.0, 0.5)
    d = discretize(rexrov, "ZOH", h)
    A, B = d.linearize(x, u)
    Ae, Be = zoh_matrices(rexrov.jacobian(0.0, x, u), rexrov.input_jacobian(0.0, x, u), h)
    assert np.array_equal(A, Ae) and np.array_equal(B, Be)
    Av, Bv = _CompiledFlows(d).flow_jacobian(0.0, x, u, h, 1e-12, 1e-12)
    np.testing.assert_allclose(Av, A, rtol=0, atol=1e-11 * np.abs(A).max())
    np.testing.assert_allclose(Bv, B, rtol=0, atol=1e-11 * np.abs(B).max())
    Af = _central_differences(lambda zz: d.step(zz, u), x)
    Bf = _central_differences(lambda uu: d.step(x, uu), u)
    np.testing.assert_allclose(Af, A, rtol=0, atol=1e-6)
    np.testing.assert_allclose(Bf, B, rtol=0, atol=1e-6 * np.abs(B).max())


def test_jacobian_that_changes_only_in_time_or_away_from_the_point():
    # Two models with f = 0 in the states df/dx depends on at the start, where the
    # start alone would pass for a trim; the end of the interval tells. In closed form
    # (the variational integration at 1e-12: 1e-11):
    # x' = -(1 + t) x at the equilibrium x = 0: Phi = exp(-(h + ((t+h)^2 - t^2) / 2));
    # x0' = 1, x1' = x0^2 + u at x0 = 0: d x1(h) / d x0 = h^2 (df/dx is zero there).
    ts, x, u = sp.symbols("t"), sp.symbols("x0:2"), sp.symbols("u0:1")
    h, t0 = 0.3, 0.4
    timed = SymbolicModel(x[:1], u, [-(1 + ts) * x[0] + 0 * u[0]], time=ts, name="timed")
    A, B = discretize(timed, "ZOH", h).linearize(np.zeros(1), np.zeros(1), t=t0)
    exact = np.exp(-(h + ((t0 + h) ** 2 - t0**2) / 2))
    np.testing.assert_allclose(A, [[exact]], rtol=0, atol=1e-11)
    assert abs(exact - np.exp(-(1 + t0) * h)) > 1e-2
    drift = SymbolicModel(x, u, [sp.Integer(1), x[0] ** 2 + u[0]], name="drift")
    A, B = discretize(drift, "ZOH", h).linearize(np.zeros(2), np.zeros(1))
    np.testing.assert_allclose(A, [[1.0, 0.0], [h**2, 1.0]], rtol=0, atol=1e-11)
    np.testing.assert_allclose(B, [[0.0], [h]], rtol=0, atol=1e-11)


def test_exact_linearisation_needs_the_integrator():
    model, _, _ = _linear_model()
    with pytest.raises(ValueError, match="a `solver` with flow"):
        ExactFlow().linearize(model, 0.0, np.zeros(3), np.zeros(2), 0.1)


def test_casadi_view_integrates_the_same_flow():
    # CVODES at rtol = atol = 1e-12 against the compiled flow at the same tolerance.
    pytest.importorskip("casadi")
    model, _, _ = _linear_model(3)
    d = discretize(model, "ZOH", 0.1)
    F = d.to_casadi()
    x, u = np.array([0.2, -0.4, 1.0]), np.array([0.3, -0.1])
    np.testing.assert_allclose(np.array(F(x, u)).ravel(), d.step(x, u), rtol=1e-9, atol=1e-11)


def test_casadi_view_has_the_same_derivative_off_a_trim(rexrov):
    # CasADi differentiates its CVODES integrator (forward sensitivities under the
    # same error control, reltol = abstol = 1e-12): against linearize off a trim,
    # 1e-9 in A (entries of order 1: CVODES's global error) and 1e-11 in B (entries
    # ~1e-6 per rpm, where the absolute tolerance 1e-12 per step sets the digits).
    ca = pytest.importorskip("casadi")
    h = 0.1
    x, u = _off_trim(rexrov)
    d = discretize(rexrov, "ZOH", h)
    A, B = d.linearize(x, u)
    F = d.to_casadi()
    z, v = ca.MX.sym("z", d.nz), ca.MX.sym("u", d.nu)
    jac = ca.Function("dF", [z, v], [ca.jacobian(F(z, v), z), ca.jacobian(F(z, v), v)])
    Ac, Bc = (np.array(m) for m in jac(x, u))
    np.testing.assert_allclose(Ac, A, rtol=0, atol=1e-9)
    np.testing.assert_allclose(Bc, B, rtol=0, atol=1e-11)
