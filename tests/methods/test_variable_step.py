"""Prediction on non-uniform time (issue 11, item 2): the variable-step rules, their
noise gains and linearisations, the time-weighted norms.

Every rule the registry lists that says it predicts on non-uniform time
(``variable_step``) enters each generic test; nothing here names a rule except the
tests of one family's own pieces (the Adams weights, ABj's rebuilt history).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from _method_helpers import (
    PositiveLinear,
    Quadrature,
    auv_smooth_order,
    check_gain_bounds,
    check_jacobians_against_predict,
    make_traj,
    slope,
)
from scipy.linalg import expm
from scipy.optimize import minimize

import sampledyn as sd
from sampledyn._local_errors import error_norms
from sampledyn.methods import (
    Estimator,
    Predictor,
    ab_coefficients,
    available_methods,
    get_method,
    stencil_steps,
)
from sampledyn.methods._adams import ab_gain_factor
from sampledyn.methods._jump import backward_weights, collocation_weights
from sampledyn.methods._nodes import lagrange_integrals, pattern_nodes

PREDICTORS = [n for n in available_methods() if isinstance(get_method(n), Predictor)]
VARIABLE = [
    n
    for n in PREDICTORS
    if get_method(n).variable_step and not isinstance(get_method(n), Estimator)
]

A = np.array([[0.0, 1.0], [-4.0, -0.4]])
B = np.array([0.0, 1.0])


def test_the_registry_has_variable_step_rules_of_every_family():
    assert {get_method(n).family for n in VARIABLE} >= {"AB", "ABu", "ABj", "RK", "T"}
    for name in PREDICTORS:
        m = get_method(name)
        assert isinstance(m.variable_step, bool) and isinstance(m.step_rule, str) and m.step_rule
        if isinstance(m, Estimator):  # regressions on the weights of the actual nodes
            assert m.variable_step


def _random_times(h, duration, seed=0, spread=0.1):
    """Times from 0 with steps h w_n, w_n uniform in [1 - spread, 1 + spread]: with the
    default every ratio of consecutive steps lies in [0.8, 1.25]."""
    w = np.random.default_rng(seed).uniform(1 - spread, 1 + spread, int(duration / h * 1.3) + 8)
    t = np.concatenate([[0.0], np.cumsum(h * w)])
    return t[t <= duration + 1e-12]


def _traj(t, x, u=None, names=None):
    """make_traj with h the median step (the nominal period of a non-uniform log)."""
    return make_traj(t, x, u, names, h=float(np.median(np.diff(t))))


class Linear:
    """x' = A x + B u, exact samples on any time grid under a zero-order-hold input."""

    nx, nu = 2, 1
    state_names, state_units = ("x", "y"), ("", "")
    input_names, input_units = ("u",), ("",)

    def __init__(self, a=A, b=B):
        self.a, self.b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)

    def f(self, t, x, u):
        return np.asarray(x) @ self.a.T + np.asarray(u)[:, :1] * self.b

    def jacobian(self, t, x, u):
        return np.broadcast_to(self.a, (np.shape(x)[0], 2, 2)).copy()

    def samples(self, t, u, x0=(1.0, 0.0)):
        x = np.empty((t.size, 2))
        x[0] = x0
        for k in range(t.size - 1):
            e = expm(self.a * (t[k + 1] - t[k]))
            x[k + 1] = e @ x[k] + np.linalg.solve(self.a, (e - np.eye(2)) @ self.b) * u[k]
        return _traj(t, x, u, names=self.state_names)


# ------------------------------------------------------------------ the Adams weights
@pytest.mark.parametrize("s", range(1, 13))
def test_weights_of_uniform_nodes_are_the_fixed_coefficients(s):
    beta = lagrange_integrals(-np.arange(s, dtype=float)[None, :], 0.0, 1.0)[0]
    exact = np.array([float(a) for a in ab_coefficients(s)])
    assert np.abs(beta - exact).max() <= 64 * np.finfo(float).eps * np.abs(exact).max()
    if s >= 2:  # ABj's collocation weights: backward_weights rows 1..s-1
        c = collocation_weights(-np.arange(s, dtype=float)[None, :])[0]
        ref = np.array(backward_weights(s), dtype=float)[1:]
        assert np.abs(c - ref).max() <= 64 * np.finfo(float).eps * max(1.0, np.abs(ref).max())


@pytest.mark.parametrize("s", [1, 2, 3, 4, 6, 8])
def test_lagrange_integrals_are_exact_on_polynomials_of_degree_below_s(s):
    rng = np.random.default_rng(s)
    steps = rng.uniform(0.8, 1.25, (50, s))
    tau, _ = pattern_nodes(steps)  # nodes 0, -h_{n-1}/h_n, ... on random steps
    lo, hi = rng.uniform(-3, 0, 50), rng.uniform(0, 1.5, 50)
    w = lagrange_integrals(tau, lo, hi)
    for degree in range(s):
        p = np.polynomial.Polynomial(rng.uniform(-2, 2, degree + 1))
        exact = p.integ()(hi) - p.integ()(lo)
        terms = w * p(tau)  # rounding relative to the terms summed (extrapolation cancels)
        scale = np.abs(terms).sum(axis=1)
        assert (np.abs(terms.sum(axis=1) - exact) <= 1e-14 * s * scale + 1e-15).all()


# ------------------------------------------------------------------ every variable-step rule
@pytest.mark.parametrize("name", VARIABLE)
def test_exact_on_polynomials_below_the_order_on_random_nodes(name):
    m = get_method(name)
    rng = np.random.default_rng(m.order)
    model = Quadrature(rng.uniform(-2, 2, m.order))  # degree s - 1
    t = _random_times(0.1, 2.0, seed=m.order)
    traj = _traj(t, model.exact(t))
    x_hat = m.predict(model, traj)
    scale = np.abs(traj.x).max()
    np.testing.assert_allclose(x_hat[m.history :], traj.x[m.history :], atol=1e-12 * scale)


def test_the_random_grids_have_step_ratios_in_the_brief():
    for h in (0.16, 0.08, 0.04, 0.02, 0.01):
        r = np.diff(_random_times(h, 2.0))
        ratio = r[1:] / r[:-1]
        assert 0.8 <= ratio.min() and ratio.max() <= 1.25 and ratio.std() > 0.05


@pytest.mark.parametrize("name", VARIABLE)
def test_local_error_slope_on_random_steps_against_closed_form(name):
    # x' = A x, exact samples by expm on random steps (ratios in [0.8, 1.25]): the
    # largest local error after t = 1 falls like h^(s+1).
    m = get_method(name)
    s = m.order
    hs = np.array([0.08, 0.04, 0.02, 0.01]) if s < 5 else np.array([0.16, 0.08, 0.04, 0.02])
    errs = []
    for h in hs:
        t = _random_times(h, 2.0)
        traj = Linear().samples(t, np.zeros(t.size))
        e = sd.local_errors(m.predict(Linear(), traj), traj)
        errs.append(sd.error_norm(e, t, kind="max", after=1.0))
    fitted = slope(hs, np.array(errs))
    assert abs(fitted - (s + 1)) <= 0.3, (name, fitted, errs)


@pytest.mark.parametrize("name", VARIABLE)
def test_local_error_slope_on_random_steps_against_scipy(name):
    # The smooth stretch of the AUV-like system (constant input, velocity > 0),
    # reference by SciPy's DOP853 at rtol 1e-13 on the random stamps.
    s = get_method(name).order
    hs = np.array([0.04, 0.02, 0.01]) if s < 5 else np.array([0.08, 0.04, 0.02])
    fitted, errs = auv_smooth_order(name, lambda h: _random_times(h, 1.2, seed=1), hs)
    assert abs(fitted - (s + 1)) <= 0.35, (name, fitted, errs)


@pytest.mark.parametrize("name", VARIABLE)
def test_variable_step_code_equals_the_fixed_rule_on_a_uniform_grid(name):
    # The same uniform stamps, once with h = the step (fixed-step code) and once with
    # a nominal h that does not match them (so the rule takes the actual steps).
    model, signal = sd.models.AUVLike(), None
    traj = sd.simulate(model, sd.signals.Multilevel(hold=0.05, seed=3), T=2.0, h=0.01)
    m = get_method(name)
    fixed = m.predict(model, traj, signal)
    actual = m.predict(model, traj.replace(h=0.0101), signal)
    np.testing.assert_allclose(actual, fixed, rtol=1e-13, atol=1e-13 * np.abs(traj.x).max())
    phi_fixed = m.prediction_jacobians(model, traj, signal)
    phi_actual = m.prediction_jacobians(model, traj.replace(h=0.0101), signal)
    np.testing.assert_allclose(phi_actual, phi_fixed, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("name", VARIABLE)
def test_prediction_jacobians_are_derivatives_of_predict_on_random_steps(name):
    model = sd.models.AUVLike()
    signal = sd.signals.Multilevel(hold=0.05, seed=3)
    base = sd.simulate(model, signal, T=4.0, h=0.01, x0=np.array([1.0, 0.5]))
    t = base.t + np.random.default_rng(2).uniform(-0.002, 0.002, base.n_samples)
    t[0] = 0.0
    traj = base.replace(t=t)  # the states need not be exact at t for this test
    check_jacobians_against_predict(get_method(name), model, traj, every=37)


@pytest.mark.parametrize("name", VARIABLE)
def test_noise_gain_with_the_step_ratio_bounds_every_row(name):
    # x' = a x + b u with a >= 0 elementwise (L = a exactly), random steps, an input
    # that jumps: the gain at (largest step, largest stencil step ratio) bounds the
    # increment's response on every row, and a perturbation's effect.
    m = get_method(name)
    a = PositiveLinear.a
    t = _random_times(0.1, 4.0, seed=5, spread=0.2)
    u = np.repeat(np.random.default_rng(1).uniform(-1, 1, t.size // 8 + 1), 8)[: t.size]
    traj = _traj(t, np.stack([np.exp(0.1 * t), np.cos(t)], axis=1), u)
    h_max, ratio = stencil_steps(traj, m.history)
    assert ratio > 1.0 or m.history == 1
    check_gain_bounds(m, traj, m.noise_gain(h_max, a, ratio), perturbations=5)
    # ratio 1 is the uniform gain; the gain grows with the ratio
    np.testing.assert_array_equal(m.noise_gain(0.1, a, 1.0), m.noise_gain(0.1, a))
    assert (m.noise_gain(0.1, a, 1.5) >= m.noise_gain(0.1, a) * (1 - 1e-12)).all()
    with pytest.raises(ValueError, match="step `ratio` must be a finite number >= 1"):
        m.noise_gain(0.1, a, 0.5)


@pytest.mark.parametrize("s", [2, 3, 4, 5, 6])
@pytest.mark.parametrize("ratio", [1.25, 2.0, 4.0])
def test_the_ab_gain_is_largest_at_a_corner_of_the_step_box(s, ratio):
    # sup over step patterns in [1/ratio, 1]^s of h_n sum |beta_{n,i}|: random interior
    # patterns and local maximisation from random starts never exceed the corners.
    def gain(steps):
        tau, hn = pattern_nodes(np.atleast_2d(steps))
        return hn * np.abs(lagrange_integrals(tau, 0.0, 1.0)).sum(axis=1)

    top = ab_gain_factor(s, ratio)
    rng = np.random.default_rng(s)
    assert gain(rng.uniform(1 / ratio, 1, (20000, s))).max() <= top * (1 + 1e-12)
    for _ in range(8):
        res = minimize(
            lambda z: -gain(z)[0],
            rng.uniform(1 / ratio, 1, s),
            bounds=[(1 / ratio, 1.0)] * s,
            method="L-BFGS-B",
        )
        assert -res.fun <= top * (1 + 1e-9)
    assert ab_gain_factor(s, 1.0) == pytest.approx(float(sd.AdamsBashforth(s).a_s), rel=1e-13)


def test_time_must_increase_for_every_rule():
    model = sd.models.AUVLike()
    traj = sd.simulate(model, sd.signals.Multilevel(hold=0.05, seed=3), T=1.0, h=0.01)
    t = traj.t.copy()
    t[30] = t[29] - 1e-3
    for name in VARIABLE:
        with pytest.raises(ValueError, match=r"must increase strictly: t\[30\]"):
            sd.predict(name, model, traj.replace(t=t))


# ------------------------------------------------------------------ ABj across jumps
@pytest.mark.parametrize("s", [2, 3, 4])
def test_abj_keeps_its_order_across_jumps_on_random_steps(s):
    # The largest error over the predictions whose history holds an input jump falls
    # like h^(s+1) on random steps too (the collocation weights of the actual nodes).
    hs = np.array([0.02, 0.01, 0.005, 0.0025])
    errs = []
    for h in hs:
        t = _random_times(h, 3.0, seed=3)
        levels = np.random.default_rng(0).uniform(-10, 10, 20)
        u = levels[np.floor(t / 0.2 + 1e-9).astype(int)]
        traj = Linear().samples(t, u)
        e = np.linalg.norm(traj.x - get_method(f"ABj{s}").predict(Linear(), traj), axis=1)
        hist = np.zeros(t.size, dtype=bool)
        for k in range(s + 1, t.size):
            hist[k] = np.unique(u[k - s : k]).size > 1
        errs.append(np.nanmax(e[hist]))
    assert abs(slope(hs, np.array(errs)) - (s + 1)) < 0.35


def test_abj_jacobians_go_in_bounded_blocks(monkeypatch):
    # The input changes at every sample, so every prediction rebuilds its history:
    # blocks of a few rows give the same Jacobians and keep the working memory near
    # the block size, not the (rows, s, s, nx, nx) of all rows at once.
    import tracemalloc

    import sampledyn.methods._held as held

    plant = Linear()
    t = 0.01 * np.arange(1500)
    u = np.sin(3 * t) + 0.1 * np.random.default_rng(0).standard_normal(t.size)
    traj = plant.samples(t, u)
    m = get_method("ABj6")
    whole = m.prediction_jacobians(plant, traj)
    row_bytes = 8 * 6 * 6 * 2 * 2
    monkeypatch.setattr(held, "JACOBIAN_CHUNK_BYTES", 16 * row_bytes)
    tracemalloc.start()
    blocks = m.prediction_jacobians(plant, traj)
    peak = tracemalloc.get_traced_memory()[1] - blocks.nbytes
    tracemalloc.stop()
    np.testing.assert_array_equal(blocks, whole)
    all_rows = traj.n_samples * row_bytes  # d for every row at once, 0.43 MB here
    assert peak < all_rows / 4, (peak, all_rows)


# ------------------------------------------------------------------ norms
def test_norms_are_unchanged_on_a_uniform_grid():
    rng = np.random.default_rng(0)
    t = 0.1 * np.arange(200)
    e = rng.standard_normal((200, 3))
    e[:4] = np.nan
    sq = (e[4:] ** 2).sum(axis=1)
    got = error_norms(e, t)
    assert got["rms"] == float(np.sqrt(sq.sum() / sq.size))
    assert got["mean"] == float(np.sqrt(sq).mean())
    assert got["l2"] == float(np.sqrt(sq.sum()))
    assert got["l2_over_n"] == float(np.sqrt(sq.sum()) / sq.size)
    assert got["max"] == float(np.sqrt(sq.max()))


def test_norms_weight_each_sample_by_its_step_on_non_uniform_time():
    rng = np.random.default_rng(1)
    t = np.cumsum(np.concatenate([[0.0], rng.uniform(0.05, 0.15, 99)]))
    e = rng.standard_normal((100, 2))
    e[0] = np.nan
    span = np.diff(t)  # sample n spans [t_{n-1}, t_n]
    sq = (e[1:] ** 2).sum(axis=1)
    w = span / span.mean()
    got = error_norms(e, t)
    assert got["rms"] == pytest.approx(math.sqrt((span * sq).sum() / span.sum()), rel=1e-13)
    assert got["mean"] == pytest.approx((span * np.sqrt(sq)).sum() / span.sum(), rel=1e-13)
    assert got["l2"] == pytest.approx(math.sqrt((w * sq).sum()), rel=1e-13)
    assert got["l2_over_n"] == pytest.approx(math.sqrt((w * sq).sum()) / 99, rel=1e-13)
    assert got["max"] == float(np.sqrt(sq.max()))


def test_a_bridged_interval_counts_for_the_time_it_spans():
    # One interval of 4 h with error e counts like 4 intervals of h with error e.
    t_bridged = 0.1 * np.array([0, 1, 2, 6, 7, 8], dtype=float)
    e_bridged = np.array([np.nan, 1.0, 1.0, 3.0, 1.0, 1.0])
    t_full = 0.1 * np.arange(9, dtype=float)
    e_full = np.array([np.nan, 1.0, 1.0, 3.0, 3.0, 3.0, 3.0, 1.0, 1.0])
    for kind in ("rms", "mean"):
        assert sd.error_norm(e_bridged, t_bridged, kind) == pytest.approx(
            sd.error_norm(e_full, t_full, kind), rel=1e-14
        )


# ------------------------------------------------------------------ evaluate on real clocks
@pytest.fixture(scope="module")
def jittered_log():
    """The evaluate example's vehicle and input, 10 Hz with +-0.5 ms jitter on a 0.25 ms
    clock, exact samples at the logged stamps (no measurement noise)."""
    from sampledyn.logs import log_from_frame, synthetic_log

    vehicle = sd.models.load_vehicle("bluerov2_heavy")
    frame = synthetic_log(T=20.0, jitter=5e-4, clock=2.5e-4, eta_pct=0.0, v_pct=0.0)
    return vehicle, frame, log_from_frame(frame, vehicle)


def test_evaluate_on_a_jittered_log_orders_the_rules(jittered_log):
    from dataclasses import replace

    from sampledyn.logs import evaluate_log

    vehicle, _, data = jittered_log
    off = np.abs(data.traj.t - 0.1 * np.arange(data.traj.n_samples))
    assert 4.9e-4 < off.max() < 5.1e-4  # stamps n h +- 0.5 ms
    rules = ["E", "AB2", "AB3", "AB4"]
    logged = evaluate_log(vehicle, data, rules, after=2.0, baselines=False)
    assert logged.notes[0].startswith("time base: the logged time stamps (jittered")
    err = [r["err_eta"] for r in logged.rows]
    assert err[0] > 3 * err[1] > 9 * err[2] > 18 * err[3], err  # each order gains
    # the same samples snapped to t = n h: the order comparison is lost
    snapped = replace(data, traj=data.traj.replace(t=0.1 * np.arange(data.traj.n_samples)))
    flat = evaluate_log(vehicle, snapped, rules, after=2.0, baselines=False)
    assert flat.notes[0].startswith("time base: a uniform grid")
    snap = [r["err_eta"] for r in flat.rows]
    assert snap[3] > 4 * err[3] and snap[3] > 0.6 * snap[2], (err, snap)


def test_a_bridged_log_is_predicted_on_its_logged_times(vehicle, frame):
    from sampledyn.logs import evaluate_log, log_from_frame

    dropped = frame.drop(index=[100, 250, 251, 252]).reset_index(drop=True)
    data = log_from_frame(dropped, vehicle, gaps="bridge", max_missing=3)
    tr = data.traj
    big = np.flatnonzero(np.diff(tr.t) > 0.15)
    np.testing.assert_allclose(np.diff(tr.t)[big], [0.2, 0.4], rtol=1e-9)
    f = vehicle.f(tr.t, tr.x, tr.u)
    for name in ("E", "AB2", "RK4"):
        x_hat = sd.predict(name, vehicle, tr)
        assert np.isfinite(x_hat[get_method(name).history :]).all()
        if name == "E":  # across each gap: one Euler step of the gap's length
            for n in big:
                np.testing.assert_allclose(
                    x_hat[n + 1], tr.x[n] + (tr.t[n + 1] - tr.t[n]) * f[n], rtol=1e-13
                )
    result = evaluate_log(vehicle, data, ["E", "AB2", "RK4"], baselines=False)
    assert result.notes[0].startswith("time base: the logged time stamps (2 bridged gap(s))")
    assert all(r["samples"] == tr.n_samples - get_method(r["method"]).history for r in result.rows)


def test_the_noise_bound_takes_the_step_ratio_of_its_samples():
    # assemble_bound on non-uniform samples asks the rule for its gain at the largest
    # step and the largest stencil ratio; on uniform samples it is the uniform gain.
    from types import SimpleNamespace

    from sampledyn.sensitivity._bound import assemble_bound

    lip = SimpleNamespace(lipschitz=np.array([[0.2, 1.0], [0.3, 0.8]]))
    amp = np.full(12, 1e-3)
    t = _random_times(0.1, 3.0, seed=4, spread=0.2)
    jittered = _traj(t, np.zeros((t.size, 12)))
    uniform = jittered.replace(t=0.1 * np.arange(t.size), h=0.1)
    for name in ("AB4", "ABj3", "RK4", "T"):
        m = get_method(name)
        h_max, ratio = stencil_steps(jittered, m.history)
        b = assemble_bound(name, 0.1, 1, 1, amp, lip, lip, (0.0, 0.0), samples=jittered)
        np.testing.assert_array_equal(b.gain, m.noise_gain(h_max, lip.lipschitz, ratio))
        same = assemble_bound(name, 0.1, 1, 1, amp, lip, lip, (0.0, 0.0), samples=uniform)
        np.testing.assert_array_equal(same.gain, m.noise_gain(0.1, lip.lipschitz))
    assert (
        assemble_bound("AB4", 0.1, 1, 1, amp, lip, lip, (0.0, 0.0), samples=jittered).gain
        > assemble_bound("AB4", 0.1, 1, 1, amp, lip, lip, (0.0, 0.0), samples=uniform).gain
    ).all()
