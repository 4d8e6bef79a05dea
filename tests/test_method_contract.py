"""The contract every registered method keeps, checked for every name the registry lists.

Nothing here names a method: the rules come from ``available_methods()``, and a test
that makes no sense for a rule is skipped by asking the rule (``estimates_params``,
``error_constant`` ...). A new family enters every test by registering itself.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import sampledyn as sd
import sampledyn.estimate  # noqa: F401 - registers the estimated rules (Ee, ABe_s)
from sampledyn.methods import Method, available_methods, families, get_method

NAMES = available_methods()
FIXED = [n for n in NAMES if not get_method(n).estimates_params]


def _traj(t, x, u=None, names=None):
    x = np.asarray(x, dtype=float).reshape(t.size, -1)
    u = np.zeros((t.size, 1)) if u is None else np.asarray(u, dtype=float).reshape(t.size, -1)
    names = names or tuple(f"x{i}" for i in range(x.shape[1]))
    return sd.Trajectory(
        t=t, x=x, u=u, h=float(t[1] - t[0]), state_names=names, state_units=("",) * len(names)
    )


def _slope(hs, errs):
    return float(np.polyfit(np.log(hs), np.log(errs), 1)[0])


@pytest.fixture(scope="module")
def auv_run():
    model = sd.models.AUVLike()
    signal = sd.signals.Multilevel(hold=0.05, seed=3)
    traj = sd.simulate(model, signal, T=4.0, h=0.01, x0=np.array([1.0, 0.5]))
    return model, signal, traj


# ------------------------------------------------------------------ the registry itself
def test_registry_lists_each_name_once_and_every_name_resolves():
    assert len(NAMES) == len(set(NAMES))
    for name in NAMES:
        m = get_method(name)
        assert m.name == name
        assert isinstance(m, Method)
    # every family lists 1..default_max_order (or its single rule)
    for fam in families():
        expected = fam.names()
        assert set(expected) <= set(NAMES)
        if fam.ordered:
            assert [get_method(n).order for n in expected] == list(
                range(1, fam.default_max_order + 1)
            )


def test_registry_holds_the_paper_rules():
    expected = {"E", "T", "Ee", *(f"AB{s}" for s in range(1, 7)), *(f"RK{s}" for s in range(1, 5))}
    expected |= {f"ABe{s}" for s in range(1, 7)}
    assert expected <= set(NAMES)


def test_registry_rejects_a_colliding_family():
    with pytest.raises(ValueError, match="already taken"):
        sd.methods.register_family(
            "X<s>", r"(?:X|AB)(\d+)", sd.AdamsBashforth, "clash", default_max_order=2
        )
    with pytest.raises(ValueError, match="default_max_order"):
        sd.methods.register_family("Y<s>", r"Y(\d+)", sd.AdamsBashforth, "no default")
    assert "X<s>" not in sd.methods.describe_methods()


@pytest.mark.parametrize("name", NAMES)
def test_method_answers_the_protocol(name):
    m = get_method(name)
    assert isinstance(m.family, str) and m.family
    assert isinstance(m.order, int) and m.order >= 1
    assert isinstance(m.history, int) and m.history >= 1
    assert isinstance(m.label, str) and m.label
    assert isinstance(m.intersample, bool) and isinstance(m.estimates_params, bool)
    if m.estimates_params:
        assert m.first_order_gain is None and m.error_constant is None
        with pytest.raises(ValueError, match="no noise gain"):
            m.noise_gain(0.1, np.eye(2))
    else:
        assert isinstance(m.first_order_gain, Fraction) and m.first_order_gain >= 1
    w = m.sample_weights
    if w is not None:
        assert len(w) == m.history
        assert math.isclose(float(np.sum(w)), 1.0, rel_tol=0, abs_tol=1e-13)  # consistency
        assert float(np.abs(w).sum()) == pytest.approx(float(m.first_order_gain), rel=1e-14)


# ------------------------------------------------------------------ predictions
@pytest.mark.parametrize("name", NAMES)
def test_shape_and_nan_rows_are_the_history(name, auv_run):
    model, signal, traj = auv_run
    m = get_method(name)
    x_hat = sd.predict(m, model, traj, signal)
    assert x_hat.shape == traj.x.shape
    assert np.isnan(x_hat[: m.history]).all()
    assert np.isfinite(x_hat[m.history :]).all()


@pytest.mark.parametrize("name", NAMES)
def test_bad_input_is_named(name, auv_run):
    model, signal, traj = auv_run
    t = traj.t.copy()
    t[40:] += 0.004
    if get_method(name).variable_step:  # predicts on the actual steps
        assert np.isfinite(sd.predict(name, model, traj.replace(t=t))[40:]).all()
        t[40] = t[39]
        with pytest.raises(ValueError, match=r"must increase strictly: t\[40\]"):
            sd.predict(name, model, traj.replace(t=t))
    else:
        with pytest.raises(ValueError, match=r"not uniformly sampled.*0\.004 s from h"):
            sd.predict(name, model, traj.replace(t=t))
    x = traj.x.copy()
    x[17, 1] = np.nan
    with pytest.raises(ValueError, match="n=17"):
        sd.predict(name, model, traj.replace(x=x))
    three = _traj(traj.t, np.zeros((traj.n_samples, 3)), traj.u)
    with pytest.raises(ValueError, match="nx=3"):
        sd.predict(name, model, three)


@pytest.mark.parametrize("name", FIXED)
def test_cache_changes_nothing(name, auv_run):
    model, signal, traj = auv_run
    m = get_method(name)
    cache: dict = {}
    first = m.predict(model, traj, signal, cache=cache)
    np.testing.assert_array_equal(first, m.predict(model, traj, signal))
    np.testing.assert_array_equal(first, m.predict(model, traj, signal, cache=cache))


class _Counting:
    """The AUV-like model, counting evaluations of f on all N samples at once."""

    def __init__(self, model, n):
        self.model, self.n, self.full_calls = model, n, 0
        for attr in ("nx", "nu", "state_names", "state_units", "input_names", "input_units"):
            setattr(self, attr, getattr(model, attr))

    def f(self, t, x, u):
        if np.shape(x)[0] == self.n:
            self.full_calls += 1
        return self.model.f(t, x, u)

    def jacobian(self, t, x, u):
        return self.model.jacobian(t, x, u)


def test_one_cache_evaluates_f_at_the_samples_once(auv_run):
    model, signal, traj = auv_run
    counting = _Counting(model, traj.n_samples)
    cache: dict = {}
    filters = [n for n in FIXED if get_method(n).sample_weights is not None]
    assert len(filters) >= 6
    for name in filters:
        get_method(name).predict(counting, traj, signal, cache=cache)
    assert counting.full_calls == 1


@pytest.mark.parametrize("name", [n for n in FIXED if get_method(n).sample_weights is not None])
def test_sample_weights_are_the_prediction(name, auv_run):
    model, signal, traj = auv_run
    m = get_method(name)
    w, h = m.sample_weights, traj.h
    f = model.f(traj.t, traj.x, traj.u)
    x_hat = m.predict(model, traj, signal)
    for k in range(m.history, traj.n_samples, 29):
        naive = traj.x[k - 1] + h * sum(w[i] * f[k - 1 - i] for i in range(len(w)))
        np.testing.assert_allclose(x_hat[k], naive, rtol=1e-13, atol=1e-15)


# ------------------------------------------------------------------ order
def _closed_form_errors(name, model, hs):
    x0 = np.array([1.0, 0.0])
    errs = []
    for h in hs:
        t = h * np.arange(int(round(2.0 / h)) + 1)
        traj = _traj(t, model.flow(t, x0))
        e = sd.local_errors(sd.predict(name, model, traj), traj)
        errs.append(sd.error_norm(e, t, kind="max", after=1.0))
    return np.array(errs)


@pytest.mark.parametrize("name", FIXED)
def test_local_error_order_against_closed_form(name, damped_oscillator):
    s = get_method(name).order
    hs = np.array([0.08, 0.04, 0.02, 0.01]) if s < 5 else np.array([0.16, 0.08, 0.04, 0.02])
    slope = _slope(hs, _closed_form_errors(name, damped_oscillator, hs))
    assert abs(slope - (s + 1)) <= 0.3, (name, slope)


@pytest.mark.parametrize("name", FIXED)
def test_local_error_order_against_scipy(name):
    # Smooth stretch of the AUV-like system: constant input, velocity kept positive.
    model = sd.models.AUVLike()
    s = get_method(name).order
    u = 3.0
    hs = np.array([0.04, 0.02, 0.01]) if s < 5 else np.array([0.08, 0.04, 0.02])
    errs = []
    for h in hs:
        t = h * np.arange(int(round(1.2 / h)) + 1)
        sol = solve_ivp(
            lambda tt, x: model.f(tt, x, np.array([u])),
            (0, t[-1]),
            [0.8, 1.0],
            method="DOP853",
            t_eval=t,
            rtol=1e-13,
            atol=1e-14,
        )
        traj = _traj(t, sol.y.T, np.full(t.size, u), model.state_names)
        assert (traj.x[:, 1] > 0).all()
        e = sd.local_errors(sd.predict(name, model, traj), traj)
        errs.append(sd.error_norm(e, t, kind="max", after=0.5))
    slope = _slope(hs, np.array(errs))
    assert abs(slope - (s + 1)) <= 0.35, (name, slope, errs)


class _Quadrature:
    """x' = p(t): every rule becomes a quadrature rule for p."""

    nx, nu = 1, 1
    state_names, state_units = ("x",), ("",)
    input_names, input_units = ("u",), ("",)

    def __init__(self, coeffs):
        self.p = np.polynomial.Polynomial(coeffs)

    def f(self, t, x, u):
        return np.broadcast_to(self.p(np.asarray(t, dtype=float)), (np.shape(x)[0],))[
            :, None
        ].copy()

    def jacobian(self, t, x, u):
        return np.zeros((np.shape(x)[0], 1, 1))

    def exact(self, t):
        return self.p.integ()(t)


@pytest.mark.parametrize("name", FIXED)
def test_exact_on_polynomials_below_the_order(name):
    # A rule of order s integrates polynomials of degree < s exactly.
    m = get_method(name)
    rng = np.random.default_rng(m.order)
    model = _Quadrature(rng.uniform(-2, 2, m.order))  # degree s - 1
    t = 0.1 * np.arange(20)
    traj = _traj(t, model.exact(t))
    x_hat = m.predict(model, traj)
    scale = np.abs(traj.x).max()
    np.testing.assert_allclose(x_hat[m.history :], traj.x[m.history :], atol=1e-12 * scale)


@pytest.mark.parametrize("name", [n for n in FIXED if get_method(n).error_constant is not None])
def test_error_constant_is_the_local_error_on_a_polynomial(name):
    # x' = t^s gives x^{(s+1)} = s!, so the local error is exactly C h^{s+1} s!.
    m = get_method(name)
    s = m.order
    model = _Quadrature([0.0] * s + [1.0])
    h = 0.05
    t = h * np.arange(12)
    traj = _traj(t, model.exact(t))
    err = (traj.x - m.predict(model, traj))[m.history :, 0]
    expected = float(m.error_constant) * h ** (s + 1) * math.factorial(s)
    np.testing.assert_allclose(err, expected, rtol=1e-7)


# ------------------------------------------------------------------ linearisation, gains
@pytest.mark.parametrize("name", FIXED)
def test_prediction_jacobians_are_derivatives_of_predict(name, auv_run):
    model, signal, traj = auv_run
    m = get_method(name)
    phi = m.prediction_jacobians(model, traj, signal)
    n, nx = traj.x.shape
    assert phi.shape == (n, m.history, nx, nx)
    assert np.isnan(phi[: m.history]).all() and np.isfinite(phi[m.history :]).all()
    # samples away from y = 0 (the kink of y|y|), several per hold period
    picks = [
        k for k in range(10, n - m.history - 1, 23) if np.abs(traj.x[k : k + 8, 1]).min() > 0.05
    ]
    assert len(picks) >= 5
    for k in picks:
        for j in range(nx):
            eps = 1e-6 * (1.0 + abs(traj.x[k, j]))
            xp, xm = traj.x.copy(), traj.x.copy()
            xp[k, j] += eps
            xm[k, j] -= eps
            dp = m.predict(model, traj.replace(x=xp), signal)
            dm = m.predict(model, traj.replace(x=xm), signal)
            for i in range(m.history):
                row = k + 1 + i  # x[k] is lag i of the prediction of x[k + 1 + i]
                fd = (dp[row] - dm[row]) / (2 * eps)
                np.testing.assert_allclose(phi[row, i, :, j], fd, rtol=1e-6, atol=1e-8)


@pytest.mark.parametrize("name", FIXED)
def test_noise_gain_bounds_the_prediction_jacobians(name):
    # For x' = A x + b u with A >= 0 elementwise, L = A is exact: on every row the gain
    # bounds sum_i |Phi_i - [i = 0] I| (the increment's true response to the noise),
    # and it agrees with the worst row to first order in h L (equal where the rule's
    # coefficients keep their sign). The input jumps, so every kind of row occurs.
    m = get_method(name)
    a = np.array([[0.3, 0.5], [0.2, 0.4]])
    b = np.array([0.0, 1.0])

    class Linear:
        nx, nu = 2, 1
        state_names, state_units = ("x1", "x2"), ("", "")

        def f(self, t, x, u):
            return np.asarray(x) @ a.T + np.asarray(u)[:, :1] * b

        def jacobian(self, t, x, u):
            return np.broadcast_to(a, (np.shape(x)[0], 2, 2)).copy()

    h = 0.1
    t = h * np.arange(40)
    u = np.repeat(np.random.default_rng(1).uniform(-1, 1, 5), 8)  # held longer than s
    traj = _traj(t, np.stack([np.exp(0.1 * t), np.cos(t)], axis=1), u)
    phi = m.prediction_jacobians(Linear(), traj)
    eye = np.eye(2)
    rows = range(m.history, t.size)
    totals = np.array(
        [sum(np.abs(phi[k, i] - (eye if i == 0 else 0.0)) for i in range(m.history)) for k in rows]
    )
    gain = m.noise_gain(h, a)
    assert (totals <= gain * (1 + 1e-12)).all()
    assert (gain <= totals.max(axis=0) * (1 + 2 * h * a.max() * m.history)).all()
    # a perturbation inside the box never moves an increment by more than G |delta|
    rng = np.random.default_rng(0)
    base = m.predict(Linear(), traj)
    for _ in range(10):
        d = rng.uniform(-1e-3, 1e-3, traj.x.shape)
        moved = m.predict(Linear(), traj.replace(x=traj.x + d))
        for k in rows:
            incr = np.abs(moved[k] - d[k - 1] - base[k])  # P(x~) - P(x)
            box = np.abs(d[k - m.history : k]).max(axis=0)
            assert (incr <= gain @ box * (1 + 1e-9) + 1e-15).all()


@pytest.mark.parametrize("name", FIXED)
def test_noise_gain_rejects_bad_arguments(name):
    m = get_method(name)
    for bad in (np.array([[-1.0, 0.0], [0.0, 1.0]]), np.ones((2, 3)), np.full((2, 2), np.inf)):
        with pytest.raises(ValueError, match="lipschitz"):
            m.noise_gain(0.1, bad)
    for h in (0.0, -0.1, float("nan")):
        with pytest.raises(ValueError, match="`h`"):
            m.noise_gain(h, np.eye(2))
    # first order: G = c h L + O((h L)^2)
    g = m.noise_gain(1e-7, np.eye(2))
    np.testing.assert_allclose(g / 1e-7, float(m.first_order_gain) * np.eye(2), rtol=1e-5)


@pytest.mark.parametrize("name", FIXED)
def test_short_data_give_only_nan_rows(name, auv_run):
    model, signal, traj = auv_run
    m = get_method(name)
    short = traj.replace(t=traj.t[: m.history], x=traj.x[: m.history], u=traj.u[: m.history])
    assert np.isnan(m.predict(model, short, signal)).all()
    phi = m.prediction_jacobians(model, short, signal)
    assert phi.shape == (m.history, m.history, 2, 2) and np.isnan(phi).all()
