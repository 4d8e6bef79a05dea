"""sd.discretize: discrete-time models of the rules, their linearisations, the
python-control and CasADi views, and the sampled loop against the exact plant."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

import sampledyn as sd
from sampledyn._discretize import LinearLaw, discretize, run_loop
from sampledyn._discretize._casadi import casadi_rhs
from sampledyn.methods import DiscreteTimeSystem, Predictor, StepProgram
from sampledyn.models import AttitudeHold, AUVLike, SymbolicModel, load_vehicle
from sampledyn.signals import fig6_thrusters


def _is_discrete_time_system(name: str) -> bool:
    """What the rule object says: it is a system z+ = F(z, u) if it states its step
    (the DiscreteTimeSystem protocol of sampledyn.methods)."""
    return isinstance(sd.get_method(name), DiscreteTimeSystem)


# Every registered rule that is a discrete-time system: a new rule enrols itself.
RULES = tuple(n for n in sd.available_methods() if _is_discrete_time_system(n))
OTHERS = tuple(n for n in sd.available_methods() if n not in RULES)
# ... those that also predict on sampled data (ZOH does not: it is a system only) ...
PREDICTORS = tuple(n for n in RULES if isinstance(sd.get_method(n), Predictor))
# ... and those whose step is arithmetic written once (a StepProgram): its linearisation
# is the step's derivative everywhere and CasADi's view the same arithmetic. ZOH's step
# integrates the flow to a tolerance and its linearisation is the flow's derivative at
# a trim only: tests/discretize/test_zoh.py checks both.
PROGRAMS = tuple(n for n in RULES if isinstance(sd.get_method(n).discrete_step, StepProgram))
# A step that integrates the flow (ZOH) takes a DOP853 run per step: slow over a run.
RULES_SLOW_FLOWS = [n if n in PROGRAMS else pytest.param(n, marks=pytest.mark.slow) for n in RULES]


@pytest.fixture(scope="module")
def rexrov():
    return load_vehicle("rexrov").with_buoyancy(1.0)


@pytest.fixture(scope="module")
def measured(rexrov):
    exact = sd.simulate(rexrov, fig6_thrusters(rexrov), 40.0, 0.1, certify=False)
    return sd.add_noise(exact, 2, 2, seed=3)


def _linear_model(seed: int = 0):
    """x' = A x + B u with a random stable A (3 x 3) and B (3 x 2), as a SymbolicModel."""
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(3, 3)) - 3.0 * np.eye(3)
    B = rng.normal(size=(3, 2))
    xs = sp.symbols("x0:3")
    us = sp.symbols("u0:2")
    rhs = [
        sum(sp.Float(A[i, j]) * xs[j] for j in range(3))
        + sum(sp.Float(B[i, j]) * us[j] for j in range(2))
        for i in range(3)
    ]
    return SymbolicModel(xs, us, rhs, name="linear"), A, B


# ------------------------------------------------------------------ the system


@pytest.mark.parametrize("rule", PREDICTORS)
def test_rollout_one_step_is_predict(rexrov, measured, rule):
    """k = 1 equals sd.predict with the input held on the same noisy data: bit for bit
    for the explicit rules (same arithmetic), to Newton's tolerance for Tustin; NaN
    rows alike."""
    d = discretize(rexrov, rule, 0.1)
    got = d.rollout(measured, 1)
    want = sd.predict(rule, rexrov, measured.replace(signal=None))
    np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
    if rule == "T":
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    else:
        np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("rule", RULES_SLOW_FLOWS)
def test_rollout_is_k_steps(rexrov, measured, rule):
    """Row n of rollout(k) is k applications of step from the z of the data at n - k,
    with the measured inputs; rows without history are NaN."""
    d = discretize(rexrov, rule, 0.1)
    k = 5
    got = d.rollout(measured, k)
    first = k + d.history - 1
    assert np.isnan(got[:first]).all() and np.isfinite(got[first:]).all()
    for n in (first, first + 17, measured.n_samples - 1):
        z = d.state_from_data(measured, n - k)
        for j in range(n - k, n):
            z = d.step(z, measured.u[j], measured.t[j])
        np.testing.assert_array_equal(got[n], z[: d.nx])


def test_free_run_is_repeated_step(rexrov, measured):
    d = discretize(rexrov, "AB4", 0.1)
    z0 = d.state_from_data(measured, 10)
    run = d.simulate(z0, measured.u[10:30], measured.t[10])
    z = z0
    for j in range(20):
        z = d.step(z, measured.u[10 + j], measured.t[10 + j])
        np.testing.assert_array_equal(run[j + 1], z)


def test_layouts_and_sizes(rexrov):
    assert discretize(rexrov, "AB4", 0.1).layout == (("x", 0), ("f", 1), ("f", 2), ("f", 3))
    assert discretize(rexrov, "ABu3", 0.1).layout == (("x", 0), ("x", 1), ("x", 2))
    for rule in ("E", "RK4", "T"):
        d = discretize(rexrov, rule, 0.1)
        assert d.layout == (("x", 0),) and d.nz == 12
    assert discretize(rexrov, "AB4", 0.1).nz == 48
    assert discretize(rexrov, "AB4", 0.1, delay=True).nz == 48 + 8


def test_every_kind_of_rule_is_enrolled():
    """The families the docs name as discrete-time systems are among the enrolled rules
    (the enrolment asks the objects; this guards against it enrolling nothing)."""
    families = {sd.get_method(n).family for n in RULES}
    assert {"AB", "ABu", "RK", "T", "ZOH"} <= families and "E" in RULES
    assert "ABj3" in OTHERS and set(PROGRAMS) <= set(PREDICTORS)


@pytest.mark.parametrize("rule", OTHERS)
def test_every_rule_that_is_no_discrete_time_system_is_refused(rexrov, rule):
    with pytest.raises(ValueError, match=f"`method` {rule!r}"):
        discretize(rexrov, rule, 0.1)


def test_rules_without_a_state_space_form_are_refused(rexrov):
    with pytest.raises(ValueError, match="ABj3.*input changed inside the history"):
        discretize(rexrov, "ABj3", 0.1)
    for name in ("Ee", "ABe2"):
        with pytest.raises(ValueError, match="estimates the model's parameters"):
            discretize(rexrov, name, 0.1)
    hold = AttitudeHold(load_vehicle("bluerov2_heavy"))
    with pytest.raises(ValueError, match="compiled Jacobian kernel"):
        discretize(hold, "T", 0.1).step(np.zeros(12), np.zeros(8))
    with pytest.raises(ValueError, match="h"):
        discretize(rexrov, "E", 0.0)


def test_bad_arguments_name_themselves(rexrov, measured):
    d = discretize(rexrov, "AB2", 0.1)
    with pytest.raises(ValueError, match="`z` must have shape \\(24,\\)"):
        d.step(np.zeros(12), np.zeros(8))
    with pytest.raises(ValueError, match="`k`"):
        d.rollout(measured, 0)
    with pytest.raises(ValueError, match="h=0.2"):
        discretize(rexrov, "AB2", 0.2).rollout(measured, 1)


# ------------------------------------------------------------ linearisation


def test_linearize_euler_tustin_rk4_on_a_linear_model():
    """E: (I + hA, hB); T: the bilinear map (scipy's cont2discrete 'bilinear'); RK4: the
    4th-order Taylor series of the zero-order-hold map (and within O(h^5) of scipy's
    'zoh')."""
    from math import factorial

    from scipy.signal import cont2discrete

    model, A, B = _linear_model()
    h = 0.05
    x, u = np.array([0.3, -0.2, 0.1]), np.array([0.5, -1.0])
    C, D = np.eye(3), np.zeros((3, 2))
    Ae, Be = discretize(model, "E", h).linearize(x, u)
    np.testing.assert_allclose(Ae, np.eye(3) + h * A, rtol=0, atol=1e-15)
    np.testing.assert_allclose(Be, h * B, rtol=0, atol=1e-15)
    ad, bd, *_ = cont2discrete((A, B, C, D), h, method="euler")
    np.testing.assert_allclose(Ae, ad, rtol=0, atol=1e-15)
    At, Bt = discretize(model, "T", h).linearize(x, u)
    ad, bd, *_ = cont2discrete((A, B, C, D), h, method="bilinear")
    np.testing.assert_allclose(At, ad, rtol=0, atol=1e-14)
    np.testing.assert_allclose(Bt, bd, rtol=0, atol=1e-14)
    Ar, Br = discretize(model, "RK4", h).linearize(x, u)
    taylor_a = sum(np.linalg.matrix_power(h * A, k) / factorial(k) for k in range(5))
    taylor_b = sum(h**k * np.linalg.matrix_power(A, k - 1) @ B / factorial(k) for k in range(1, 5))
    np.testing.assert_allclose(Ar, taylor_a, rtol=0, atol=1e-15)
    np.testing.assert_allclose(Br, taylor_b, rtol=0, atol=1e-15)
    az, bz, *_ = cont2discrete((A, B, C, D), h, method="zoh")
    gap = np.abs(Ar - az).max()
    assert 0 < gap < (h * np.abs(np.linalg.eigvals(A)).max()) ** 5


def _fd(fun, v, eps):
    cols = []
    for i in range(v.size):
        dv = np.zeros(v.size)
        dv[i] = eps * max(1.0, abs(v[i]))
        cols.append((fun(v + dv) - fun(v - dv)) / (2 * dv[i]))
    return np.stack(cols, axis=1)


@pytest.mark.parametrize("rule", PROGRAMS)
@pytest.mark.parametrize("delay", [False, True])
def test_linearize_against_central_differences(rexrov, measured, rule, delay):
    """(A_d, B_d) from the analytic Jacobians against central differences of step, on
    the RexROV away from kinks (velocities and rpm non-zero, not saturated)."""
    d = discretize(rexrov, rule, 0.1, delay=delay)
    z = d.state_from_data(measured.clean, 200)
    u = measured.u[200]
    A, B = d.linearize(z, u)
    A_fd = _fd(lambda zz: d.step(zz, u), z, 1e-6)
    B_fd = _fd(lambda uu: d.step(z, uu), u, 1e-6)
    scale_a = np.abs(A).max()
    np.testing.assert_allclose(A, A_fd, rtol=0, atol=2e-7 * scale_a)
    np.testing.assert_allclose(B, B_fd, rtol=0, atol=2e-7 * np.abs(B).max())


@pytest.mark.parametrize("rule", RULES)
def test_steady_state_is_a_fixed_point(rule):
    """At an equilibrium (x*, u*) of a linear model the z of a constant history is a
    fixed point of every rule's step."""
    model, A, B = _linear_model(1)
    u = np.array([0.4, -0.7])
    x = -np.linalg.solve(A, B @ u)
    d = discretize(model, rule, 0.1)
    z = d.steady_state(x, u)
    np.testing.assert_allclose(d.step(z, u), z, rtol=0, atol=1e-13)


@pytest.mark.parametrize("rule", PREDICTORS)
def test_noise_gain_is_the_prediction_jacobian(rule):
    """On constant data at an equilibrium, the noise gain's first block row is the
    rule's own prediction Jacobian d x_hat / d x_{n-i} (methods' prediction_jacobians)."""
    model, A, B = _linear_model(2)
    u = np.array([0.4, -0.7])
    x = -np.linalg.solve(A, B @ u)
    n = 12
    data = sd.Trajectory(
        t=0.1 * np.arange(n), x=np.tile(x, (n, 1)), u=np.tile(u, (n, 1)), h=0.1,
        state_names=("a", "b", "c"), state_units=("", "", ""),
    )  # fmt: skip
    d = discretize(model, rule, 0.1)
    G = d.noise_gain(d.steady_state(x, u), u)
    phi = sd.get_method(rule).prediction_jacobians(model, data)[-1]  # (history, nx, nx)
    want = np.hstack(list(phi))
    np.testing.assert_allclose(G[:3], want, rtol=1e-12, atol=1e-14)


# ------------------------------------------------------------------ ecosystem


def test_to_control_simulates_like_rollout(rexrov, measured):
    control = pytest.importorskip("control")
    d = discretize(rexrov, "AB4", 0.1)
    sys = d.to_control()
    assert sys.dt == 0.1 and sys.nstates == 48 and sys.ninputs == 8 and sys.noutputs == 12
    m, K = 30, 8
    z0 = d.state_from_data(measured, m)
    T = measured.t[m : m + K + 1]
    resp = control.input_output_response(sys, T, measured.u[m : m + K + 1].T, X0=z0)
    for j in range(1, K + 1):
        np.testing.assert_allclose(
            resp.outputs[:, j], d.rollout(measured, j)[m + j], rtol=1e-14, atol=1e-14
        )


def test_to_control_linear_is_ready_for_dlqr(rexrov):
    control = pytest.importorskip("control")
    from sampledyn.experiments import trim

    x, u = trim(rexrov, 0.5, 5.0, 0.5)
    d = discretize(rexrov, "RK4", 0.1)
    lin = d.to_control(x0=x, u0=u)
    A, B = d.linearize(d.steady_state(x, u), u)
    np.testing.assert_array_equal(lin.A, A)
    np.testing.assert_array_equal(lin.B, B)
    keep = list(range(2, 12))  # x and y are neutral integrators
    K, _, E = control.dlqr(A[np.ix_(keep, keep)], B[keep], np.eye(10), np.eye(8) * 1e-8)
    assert np.abs(E).max() < 1


@pytest.mark.parametrize("rule", PROGRAMS)
@pytest.mark.parametrize("delay", [False, True])
def test_to_casadi_equals_step(rexrov, rule, delay):
    """F(z, u) of CasADi equals step to 1e-12 (relative to the state's size) at random
    states, saturated thrusters included."""
    pytest.importorskip("casadi")
    d = discretize(rexrov, rule, 0.1, delay=delay)
    F = d.to_casadi()
    rng = np.random.default_rng(4)
    for _ in range(5):
        x = rng.normal(size=12) * np.r_[np.ones(3), 0.3 * np.ones(3), np.ones(6)]
        u = rng.uniform(-1.3, 1.3, 8) * rexrov.n_max
        z = d.steady_state(x, u) * (1 + 0.01 * rng.normal(size=d.nz))
        got = np.asarray(F(z, u)).ravel()
        want = d.step(z, u)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * max(1.0, np.abs(want).max()))


def test_casadi_rhs_of_every_builtin_model(rexrov):
    """f as CasADi equals the compiled f to 1e-12 for the vehicle (saturated inputs
    included), the AUV-like symbolic model and the attitude-hold closed loop."""
    pytest.importorskip("casadi")
    rng = np.random.default_rng(5)
    hold = AttitudeHold(load_vehicle("bluerov2_heavy"))
    for model, scale in ((rexrov, rexrov.n_max), (hold, 4000.0), (AUVLike(), 2.0)):
        f = casadi_rhs(model)
        for _ in range(20):
            x = rng.normal(size=model.nx) * 0.4
            u = rng.uniform(-1.2, 1.2, model.nu) * scale
            want = model.f(0.0, x, u)
            got = np.asarray(f(x, u)).ravel()
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * max(1, np.abs(want).max()))
    d = discretize(AUVLike(), "AB3", 0.05)
    z = d.steady_state(np.array([0.3, -0.2]), np.array([0.4]))
    np.testing.assert_allclose(
        np.asarray(d.to_casadi()(z, 0.4)).ravel(), d.step(z, np.array([0.4])), atol=1e-14
    )


# ------------------------------------------------------------------ the loop


def test_closed_loop_tracks_as_the_design_predicts(rexrov):
    """Noise-free, tiny h: the LQR (designed on RK4) run on the exact nonlinear plant
    follows the linear closed-loop prediction on the exact zero-order-hold model, and
    the gap is second order in the initial error (it falls 4x when that halves)."""
    from sampledyn.experiments import trim
    from sampledyn.experiments._closed_loop import design_lqr

    h = 0.02
    x, u = trim(rexrov, 0.5, 5.0, 0.5)
    design = design_lqr(rexrov, "RK4", h, x, u)
    Az, Bz = discretize(rexrov, "ZOH", h).linearize(x, u)  # the exact ZOH, checked in test_zoh
    K = design.law.gain
    Acl = Az + Bz @ K
    gaps = []
    for size in (0.1, 0.05):
        e0 = np.zeros(12)
        e0[2], e0[5] = size, 0.5 * size
        run = run_loop(rexrov, design.law, 20.0, h, x + e0)
        err = run.exact.x - x
        err[:, :2] -= run.exact.t[:, None] * (x[6] * np.array([np.cos(x[5]), np.sin(x[5])]))
        lin = np.empty_like(err)
        lin[0] = e0
        for n in range(1, lin.shape[0]):
            lin[n] = Acl @ lin[n - 1]
        gaps.append(np.abs(err[:, 2:] - lin[:, 2:]).max() / size)
        # converged to the set point at the rate the design predicts
        assert np.abs(err[-1, 2:]).max() <= 1.5 * np.abs(lin[-1, 2:]).max()
        assert np.abs(err[-1, 2:]).max() < 2e-3 * size
    assert gaps[0] < 0.05
    assert 1.6 < gaps[0] / gaps[1] < 2.5  # gap/size linear in size: the gap is quadratic


def test_compiled_law_equals_a_python_controller(rexrov):
    """The LinearLaw evaluated in compiled code gives the run a Python callable with
    the same law gives (noise included), for a history rule (AB2: z holds f at the
    previous measured sample)."""
    from sampledyn.experiments import trim
    from sampledyn.experiments._closed_loop import design_lqr

    x, u = trim(rexrov, 0.5, 5.0, 0.5)
    design = design_lqr(rexrov, "AB2", 0.5, x, u)
    law = design.law
    d = law.design
    x0 = x.copy()
    x0[2] -= 0.3
    a = run_loop(rexrov, law, 30.0, 0.5, x0, noise=(2, 2), seed=7)
    lo, hi = law.limits
    past: list[tuple[np.ndarray, np.ndarray]] = []

    def controller(t, y):
        if past:
            y_prev, u_prev = past[-1]
            z = np.concatenate([y, rexrov.f(0.0, y_prev, u_prev)])
            cmd = np.clip(law.u_ref + law.gain @ (z - law.z_ref), lo, hi)
        else:
            cmd = np.clip(law.u_ref, lo, hi)
        past.append((y, cmd))
        return cmd

    b = run_loop(rexrov, controller, 30.0, 0.5, x0, noise=(2, 2), seed=7)
    assert d.layout == (("x", 0), ("f", 1))
    np.testing.assert_allclose(a.command, b.command, rtol=1e-10, atol=1e-9 * rexrov.n_max)
    np.testing.assert_allclose(a.exact.x, b.exact.x, rtol=1e-9, atol=1e-9)


def test_delay_applies_the_previous_command(rexrov):
    calls = []

    def controller(t, y):
        calls.append(t)
        return np.full(8, 100.0 * (len(calls)))

    run = run_loop(rexrov, controller, 1.0, 0.5, np.zeros(12), delay=True)
    np.testing.assert_array_equal(run.command[:, 0], [100.0, 200.0, 300.0])
    np.testing.assert_array_equal(run.exact.u[:2, 0], [100.0, 100.0])


def test_law_refuses_a_wrong_gain(rexrov):
    d = discretize(rexrov, "AB2", 0.1)
    with pytest.raises(ValueError, match=r"`gain` must have shape \(8, 24\), got \(8, 12\)"):
        LinearLaw(d, np.zeros((8, 12)), np.zeros(24), np.zeros(8))


# ------------------------------------------------------------------ the studies


@pytest.mark.slow
def test_reproduce_closed_loop_and_multistep(tmp_path):
    from sampledyn.cli import main

    out = tmp_path / "cl"
    assert main(["reproduce", "closed-loop", "--T", "20", "--after", "5", "--seeds", "1",
                 "--h", "0.5", "--vehicle", "rexrov", "--methods", "ZOH,RK4",
                 "--out", str(out), "--no-progress", "-q"]) == 0  # fmt: skip
    text = (out / "closed_loop.md").read_text()
    assert "| rexrov | 0.5 | RK4 | 20/20 |" in text
    assert (out / "closed_loop.png").stat().st_size > 10_000
    out = tmp_path / "ms"
    assert main(["reproduce", "multistep", "--T", "30", "--after", "10", "--seeds", "1",
                 "--h", "0.5", "--methods", "E,RK4", "--out", str(out), "--no-progress",
                 "-q"]) == 0  # fmt: skip
    assert "| 0.5 | 0/0 | RK4 |" in (out / "multistep.md").read_text()


def test_state_from_history_equals_state_from_data(rexrov, measured):
    for rule in ("AB4", "ABu3", "RK4"):
        d = discretize(rexrov, rule, 0.1)
        n = 20
        idx = n - np.arange(d.history)
        z = d.state_from_history(measured.x[idx], measured.u[idx], t=measured.t[n])
        np.testing.assert_array_equal(z, d.state_from_data(measured, n))


def test_envelope_stops_a_diverging_loop(rexrov):
    from sampledyn.exceptions import EnvelopeExceeded

    lo = np.full(12, -np.inf)
    hi = np.full(12, np.inf)
    lo[2], hi[2] = -1.0, 1.0  # depth within 1 m of the surface start

    def full_down(t, y):
        return np.full(8, rexrov.n_max) * np.sign(rexrov.allocation[2])  # all push +z

    with pytest.raises(
        EnvelopeExceeded, match=r"left the state envelope at t=[\d.]+ s \(z = 1\.\d+\)"
    ):
        run_loop(rexrov, full_down, 60.0, 0.5, np.zeros(12), envelope=(lo, hi))


def test_noise_gain_feeds_dlqe(rexrov):
    """A Kalman filter for the AB2 model from its noise gain: python-control's dlqe
    accepts (A_d, G, C) and returns a stable estimator."""
    control = pytest.importorskip("control")
    from sampledyn._noise import noise_amplitudes
    from sampledyn.experiments import trim

    x, u = trim(rexrov, 0.5, 5.0, 0.5)
    d = discretize(rexrov, "AB2", 0.1)
    z = d.steady_state(x, u)
    A, _ = d.linearize(z, u)
    G = d.noise_gain(z, u)
    assert G.shape == (d.nz, d.history * d.nx)
    keep = [b * 12 + i for b in range(2) for i in range(2, 12)]
    gk = [lag * 12 + i for lag in range(2) for i in range(2, 12)]
    a = noise_amplitudes(rexrov.state_units, 2, 2)[2:]
    QN = np.kron(np.eye(2), np.diag(a**2 / 3))
    C = d.output_matrix()[2:][:, keep]
    L, _, E = control.dlqe(A[np.ix_(keep, keep)], G[np.ix_(keep, gk)], C, QN, np.diag(a**2 / 3))
    assert L.shape == (len(keep), 10) and np.abs(E).max() < 1


def _spring(t, x, u, p, out):
    out[0] = x[1]
    out[1] = -p[0] * x[0] - p[1] * x[1] + u[0]


@pytest.mark.slow
def test_function_model_kernels_compile_in_process():
    """A FunctionModel's kernel cannot be imported by name: the discrete model is
    compiled in this process with the kernel injected, and steps like RK4 by hand."""
    from sampledyn.models import FunctionModel

    model = FunctionModel(_spring, 2, 1, params={"k": 4.0, "c": 0.3})
    d = discretize(model, "RK4", 0.1)
    z, u, h = np.array([1.0, -0.5]), np.array([0.2]), 0.1

    def f(x):
        return np.array([x[1], -4.0 * x[0] - 0.3 * x[1] + u[0]])

    k1 = f(z)
    k2 = f(z + h / 2 * k1)
    k3 = f(z + h / 2 * k2)
    k4 = f(z + h * k3)
    np.testing.assert_allclose(d.step(z, u), z + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4), rtol=1e-15)


def test_an_operating_point_that_is_not_finite_is_refused_by_name():
    """A NaN (or inf) operating point gave an A matrix full of NaN without a word."""
    dm = discretize(AUVLike(), "AB4", 0.01)
    x, u = np.array([1.0, 0.0]), np.array([0.5])
    z = dm.steady_state(x, u)
    with pytest.raises(ValueError, match=r"operating point `z` must be finite; z\[1\] = nan"):
        dm.linearize(np.where(np.arange(z.size) == 1, np.nan, z), u)
    with pytest.raises(ValueError, match=r"operating point `u` must be finite; u\[0\] = inf"):
        dm.linearize(z, np.array([np.inf]))
    with pytest.raises(ValueError, match=r"operating point `x` must be finite"):
        dm.steady_state(np.array([np.nan, 0.0]), u)
