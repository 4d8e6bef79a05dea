"""The contract every registered method keeps, checked for every name the registry lists.

Nothing here names a method: the rules come from ``available_methods()``, and a test
that makes no sense for a rule is skipped by asking the rule which protocols it
answers (``isinstance(m, Predictor)``, ``NoiseAnalysis``, ``Estimator``) or what it
says (``error_constant`` ...). A new family enters every test by its registry row.
"""

from __future__ import annotations

import math
from fractions import Fraction

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

import sampledyn as sd
from sampledyn.methods import (
    DiscreteTimeSystem,
    Estimator,
    Method,
    NoiseAnalysis,
    Predictor,
    available_methods,
    families,
    get_method,
)
from sampledyn.methods._registry import describe_methods

NAMES = available_methods()
PREDICTORS = [n for n in NAMES if isinstance(get_method(n), Predictor)]
FIXED = [n for n in PREDICTORS if isinstance(get_method(n), NoiseAnalysis)]


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


def test_every_rule_answers_at_least_one_capability():
    # A registered rule predicts, or is a discrete-time system, or both; the estimated
    # rules predict but have neither a noise bound nor a fixed map.
    for name in NAMES:
        m = get_method(name)
        assert isinstance(m, Predictor) or isinstance(m, DiscreteTimeSystem), name
        if isinstance(m, Estimator):
            assert not isinstance(m, NoiseAnalysis | DiscreteTimeSystem), name
    assert set(FIXED) < set(PREDICTORS) < set(NAMES)


def test_registry_holds_the_paper_rules():
    expected = {"E", "T", "Ee", *(f"AB{s}" for s in range(1, 7)), *(f"RK{s}" for s in range(1, 5))}
    expected |= {f"ABe{s}" for s in range(1, 7)}
    assert expected <= set(NAMES) and "ZOH" in NAMES


def test_registry_rejects_a_colliding_family():
    with pytest.raises(ValueError, match="already taken"):
        sd.methods.register_family(
            "X<s>", r"(?:X|AB)(\d+)", sd.AdamsBashforth, "clash", default_max_order=2
        )
    with pytest.raises(ValueError, match="default_max_order"):
        sd.methods.register_family("Y<s>", r"Y(\d+)", sd.AdamsBashforth, "no default")
    assert "X<s>" not in describe_methods()


@pytest.mark.parametrize("name", NAMES)
def test_method_answers_the_protocol(name):
    m = get_method(name)
    assert isinstance(m.family, str) and m.family
    assert m.order is None or (isinstance(m.order, int) and m.order >= 1)
    assert isinstance(m.history, int) and m.history >= 1
    assert isinstance(m.label, str) and m.label
    if not isinstance(m, Predictor):
        assert isinstance(m, DiscreteTimeSystem) and m.order is None  # ZOH: exact
        return
    assert isinstance(m.order, int) and isinstance(m.intersample, bool)
    if isinstance(m, NoiseAnalysis):
        assert isinstance(m.first_order_gain, Fraction) and m.first_order_gain >= 1
    else:  # no bound: the rule is estimated, sensitivity says so by name
        assert isinstance(m, Estimator)
        with pytest.raises(ValueError, match="no noise bound"):
            sd.sensitivity.noise_gain(m, 0.1, np.eye(2))
    w = m.sample_weights
    if w is not None:
        assert len(w) == m.history
        assert math.isclose(float(np.sum(w)), 1.0, rel_tol=0, abs_tol=1e-13)  # consistency
        assert float(np.abs(w).sum()) == pytest.approx(float(m.first_order_gain), rel=1e-14)


# ------------------------------------------------------------------ predictions
@pytest.mark.parametrize("name", PREDICTORS)
def test_shape_and_nan_rows_are_the_history(name, auv_run):
    model, signal, traj = auv_run
    m = get_method(name)
    x_hat = sd.predict(m, model, traj, signal)
    assert x_hat.shape == traj.x.shape
    assert np.isnan(x_hat[: m.history]).all()
    assert np.isfinite(x_hat[m.history :]).all()


@pytest.mark.parametrize("name", PREDICTORS)
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
    three = make_traj(traj.t, np.zeros((traj.n_samples, 3)), traj.u)
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
        traj = make_traj(t, model.flow(t, x0))
        e = sd.local_errors(sd.predict(name, model, traj), traj)
        errs.append(sd.error_norm(e, t, kind="max", after=1.0))
    return np.array(errs)


@pytest.mark.parametrize("name", FIXED)
def test_local_error_order_against_closed_form(name, damped_oscillator):
    s = get_method(name).order
    hs = np.array([0.08, 0.04, 0.02, 0.01]) if s < 5 else np.array([0.16, 0.08, 0.04, 0.02])
    fitted = slope(hs, _closed_form_errors(name, damped_oscillator, hs))
    assert abs(fitted - (s + 1)) <= 0.3, (name, fitted)


@pytest.mark.parametrize("name", FIXED)
def test_local_error_order_against_scipy(name):
    # Smooth stretch of the AUV-like system: constant input, velocity kept positive.
    s = get_method(name).order
    hs = np.array([0.04, 0.02, 0.01]) if s < 5 else np.array([0.08, 0.04, 0.02])
    fitted, errs = auv_smooth_order(name, lambda h: h * np.arange(int(round(1.2 / h)) + 1), hs)
    assert abs(fitted - (s + 1)) <= 0.35, (name, fitted, errs)


@pytest.mark.parametrize("name", FIXED)
def test_exact_on_polynomials_below_the_order(name):
    # A rule of order s integrates polynomials of degree < s exactly.
    m = get_method(name)
    rng = np.random.default_rng(m.order)
    model = Quadrature(rng.uniform(-2, 2, m.order))  # degree s - 1
    t = 0.1 * np.arange(20)
    traj = make_traj(t, model.exact(t))
    x_hat = m.predict(model, traj)
    scale = np.abs(traj.x).max()
    np.testing.assert_allclose(x_hat[m.history :], traj.x[m.history :], atol=1e-12 * scale)


@pytest.mark.parametrize("name", [n for n in FIXED if get_method(n).error_constant is not None])
def test_error_constant_is_the_local_error_on_a_polynomial(name):
    # x' = t^s gives x^{(s+1)} = s!, so the local error is exactly C h^{s+1} s!.
    m = get_method(name)
    s = m.order
    model = Quadrature([0.0] * s + [1.0])
    h = 0.05
    t = h * np.arange(12)
    traj = make_traj(t, model.exact(t))
    err = (traj.x - m.predict(model, traj))[m.history :, 0]
    expected = float(m.error_constant) * h ** (s + 1) * math.factorial(s)
    np.testing.assert_allclose(err, expected, rtol=1e-7)


# ------------------------------------------------------------------ linearisation, gains
@pytest.mark.parametrize("name", FIXED)
def test_prediction_jacobians_are_derivatives_of_predict(name, auv_run):
    model, signal, traj = auv_run
    check_jacobians_against_predict(get_method(name), model, traj, signal)


@pytest.mark.parametrize("name", FIXED)
def test_noise_gain_bounds_the_prediction_jacobians(name):
    # For x' = A x + b u with A >= 0 elementwise, L = A is exact: on every row the gain
    # bounds sum_i |Phi_i - [i = 0] I| (the increment's true response to the noise),
    # and it agrees with the worst row to first order in h L (equal where the rule's
    # coefficients keep their sign). The input jumps, so every kind of row occurs. A
    # perturbation inside the box never moves an increment by more than G |delta|.
    m = get_method(name)
    a = PositiveLinear.a
    h = 0.1
    t = h * np.arange(40)
    u = np.repeat(np.random.default_rng(1).uniform(-1, 1, 5), 8)  # held longer than s
    traj = make_traj(t, np.stack([np.exp(0.1 * t), np.cos(t)], axis=1), u)
    gain = m.noise_gain(h, a)
    totals = check_gain_bounds(m, traj, gain)
    assert (gain <= totals.max(axis=0) * (1 + 2 * h * a.max() * m.history)).all()


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
