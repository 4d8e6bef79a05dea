"""Estimation of model parameters from one-step errors: sd.estimate, Ee, ABe_s."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import sampledyn as sd
from sampledyn.signals import Signal

AUV = sd.models.AUVLike()
NAMES = AUV.param_names
TRUTH = np.array([AUV.params[n] for n in NAMES])
# sin(x)**2 = 1 at the start: delta is excited while x travels towards 0 or pi. From
# x0 = 0 it would stay there (x' = -sin(x)**2 y) and delta would not be identifiable.
X0 = np.array([np.pi / 2, 0.0])
HS = (0.005, 0.01, 0.02)
# The multilevel input holds each level for h_u = 1 s, a multiple of every h in HS.
SIGNAL = sd.signals.Multilevel(low=-10.0, high=10.0, hold=1.0, seed=3)


def _theta(result: sd.EstimationResult) -> np.ndarray:
    return np.array([result.params[n] for n in NAMES])


@pytest.fixture(scope="module")
def runs() -> dict[float, sd.Trajectory]:
    """Exact samples of the AUV-like system, T = 20 s, for each h in HS."""
    return {h: sd.simulate(AUV, SIGNAL, T=20.0, h=h, x0=X0) for h in HS}


@pytest.fixture(scope="module")
def noisy() -> sd.Trajectory:
    """T = 40 s, h = 0.02 s, small uniform noise (half-widths 1e-4 on x, 1e-3 on y)."""
    clean = sd.simulate(AUV, SIGNAL, T=40.0, h=0.02, x0=X0)
    rng = np.random.default_rng(1)
    x = clean.x + rng.uniform(-1.0, 1.0, clean.x.shape) * np.array([1e-4, 1e-3])
    return clean.replace(x=x, clean=clean)


def _slope(errors: list[float]) -> float:
    return float(np.polyfit(np.log(HS), np.log(errors), 1)[0])


def _one_step_errors(result: sd.EstimationResult, data: sd.Trajectory, theta=None) -> np.ndarray:
    """Errors of the velocity y on the result's window, from sd.predict (independent
    of the estimator's own stacking); ``theta`` overrides the estimate."""
    model = (
        result.model if theta is None else AUV.with_params(**dict(zip(NAMES, theta, strict=True)))
    )
    x_hat = sd.predict(result.structure, model, data)
    k = np.rint((result.t - data.t[0]) / data.h).astype(int)
    return (data.x - x_hat)[k, 1]


# ------------------------------------------------------------------ consistency in h


@pytest.mark.parametrize("s", [1, 2, 3, 4])
def test_ab_estimate_error_shrinks_like_h_to_the_s(runs, s):
    # On exact samples the AB_s one-step error is O(h^(s+1)) against regressors of
    # size O(h), so the estimate of theta is off by O(h^s). Windows whose AB history
    # straddles a jump of the input are left out (skip_input_jumps): f jumps with u
    # there and those rows alone would bias every order by O(h) (next test).
    errors = []
    for h in HS:
        res = sd.estimate(AUV, runs[h], f"AB{s}", skip_input_jumps=True)
        errors.append(float(np.linalg.norm(_theta(res) - TRUTH)))
    assert abs(_slope(errors) - s) <= 0.5, (s, errors, _slope(errors))
    if s == 1:
        # Euler's estimate is biased like O(h): far from the truth at h = 0.005 s.
        assert errors[0] > 5e-3


def test_input_jumps_in_the_history_cost_the_order(runs):
    # The same as above without skipping: rows straddling input jumps dominate.
    errors = [
        float(
            np.linalg.norm(_theta(sd.estimate(AUV, runs[h], "AB3", skip_input_jumps=False)) - TRUTH)
        )
        for h in HS
    ]
    assert _slope(errors) < 1.6
    assert errors[0] > 100 * float(
        np.linalg.norm(_theta(sd.estimate(AUV, runs[0.005], "AB3", skip_input_jumps=True)) - TRUTH)
    )


def test_residuals_are_the_one_step_errors_of_predict(runs):
    data = runs[0.02]
    res = sd.estimate(AUV, data, "AB3", skip_input_jumps=True)
    assert res.components == ("y",)  # x' = -sin(x)^2 y holds no parameter
    np.testing.assert_allclose(res.residuals[:, 0], _one_step_errors(res, data), atol=1e-12)
    assert res.residual_norm == pytest.approx(np.linalg.norm(res.residuals), rel=1e-12)
    assert res.n_samples == res.t.size == res.n_rows
    assert set(res.std_errors) == set(NAMES) and res.condition_number < 100
    assert res.units["beta"] == "1/s" and res.structure == "AB3" and res.p == 2


class _NoRegressors:
    """The AUV-like model without ``regressors``: forces the least_squares path."""

    def __init__(self, model: sd.models.AUVLike) -> None:
        self._m = model

    def __getattr__(self, name: str):
        if name == "regressors":
            raise AttributeError(name)
        return getattr(self._m, name)

    def with_params(self, **values: float) -> _NoRegressors:
        return _NoRegressors(self._m.with_params(**values))


def test_least_squares_path_agrees_with_the_linear_one(runs):
    data = runs[0.02]
    start = AUV.with_params(alpha=-0.2, beta=0.0, gamma=-0.1, delta=0.3)
    lin = sd.estimate(start, data, "AB2", skip_input_jumps=True)
    nonlin = sd.estimate(_NoRegressors(start), data, "AB2", skip_input_jumps=True)
    assert lin.solver == "lstsq" and nonlin.solver == "least_squares"
    np.testing.assert_allclose(_theta(nonlin), _theta(lin), rtol=1e-7, atol=1e-9)
    for n in NAMES:
        assert nonlin.std_errors[n] == pytest.approx(lin.std_errors[n], rel=1e-3)


@pytest.mark.parametrize(("structure", "tol"), [("RK4", 1e-6), ("RK2", 1e-3), ("T", 1e-3)])
def test_runge_kutta_and_tustin_structures(runs, structure, tol):
    # f enters RK_s and T nonlinearly: least_squares from a wrong start. The input
    # is held between samples, so neither needs skip_input_jumps.
    start = AUV.with_params(alpha=-0.2, beta=0.0, gamma=-0.1, delta=0.3)
    res = sd.estimate(start, runs[0.02], structure)
    assert res.solver == "least_squares" and res.converged
    assert np.linalg.norm(_theta(res) - TRUTH) < tol
    with pytest.raises(ValueError, match="p=2"):
        sd.estimate(start, runs[0.02], structure, p=1)


def test_params_selects_the_free_parameters(runs):
    data = runs[0.01]
    wrong_delta = AUV.with_params(delta=0.4)
    res = sd.estimate(wrong_delta, data, "AB4", params=("alpha", "beta", "gamma"))
    assert set(res.params) == {"alpha", "beta", "gamma"}
    assert res.model.params["delta"] == 0.4  # fixed at the model's value
    only_beta = sd.estimate(AUV, data, "AB4", params="beta", skip_input_jumps=True)
    assert only_beta.params["beta"] == pytest.approx(-0.05, abs=1e-6)
    # A wrong fixed delta is absorbed by the free ones: they move away from the truth.
    assert abs(res.params["beta"] + 0.05) > 1e3 * abs(only_beta.params["beta"] + 0.05)
    with pytest.raises(ValueError, match="unknown parameter"):
        sd.estimate(AUV, data, "AB2", params=("beta", "drag"))


# ------------------------------------------------------------------ measurement noise


def test_noise_bias_is_the_errors_in_variables_bias():
    # Uniform noise on the states biases the p = 2 estimate for long records by the
    # errors-in-variables bias documented in sd.estimate: the noise of sample k-1 is
    # in both the increment x_k - x_{k-1} and the newest regressor, which gives
    # -(a_0 sigma_y^2 / h) M^-1 E[dPhi/dy] (grows like 1/h), plus the attenuation
    # -sigma^2 M^-1 sum a_i^2 E[dPhi dPhi^T] theta. Measured here (AB2, h = 0.05 s,
    # T = 4000 s, half-widths 0.02 on x and 0.1 on y): beta +0.0127 (25 % of
    # |beta|), alpha -0.0015, gamma -0.0042, within 5 % of the formula over seeds.
    # delta is only excited in the first seconds (x settles at 0 or pi), so it has
    # a large variance and is left out. The reference is the estimate on the exact
    # samples, which holds the O(h^2) discretisation bias of AB2 at this h.
    h, s = 0.05, 2
    clean = sd.simulate(AUV, SIGNAL, T=4000.0, h=h, x0=X0, certify=False)
    ax, ay = 0.02, 0.1
    rng = np.random.default_rng(0)
    x = clean.x + rng.uniform(-1.0, 1.0, clean.x.shape) * np.array([ax, ay])
    est = sd.estimate(AUV, clean.replace(x=x, clean=clean), f"AB{s}")
    ref = sd.estimate(AUV, clean, f"AB{s}")
    measured_bias = _theta(est) - _theta(ref)

    a = sd.AdamsBashforth(s).weights
    k = np.arange(s, clean.n_samples)
    pos, vel = clean.x[:, 0], clean.x[:, 1]
    phi = AUV.regressors(clean.t, clean.x, clean.u).phi[:, 1, :]
    psi = sum(a[i] * phi[k - 1 - i] for i in range(s))
    m = psi.T @ psi / k.size
    zero = np.zeros_like(vel)
    dphi_y = np.stack([2 * vel, np.ones_like(vel), 2 * np.abs(vel), zero], axis=1)
    dphi_x = np.stack([zero, zero, zero, np.sin(2 * pos)], axis=1)

    def outer(d: np.ndarray, rows: np.ndarray) -> np.ndarray:
        return np.einsum("ni,nj->ij", d[rows], d[rows]) / rows.size

    sx2, sy2 = ax**2 / 3, ay**2 / 3
    attenuation = sum(
        a[i] ** 2 * (sy2 * outer(dphi_y, k - 1 - i) + sx2 * outer(dphi_x, k - 1 - i))
        for i in range(s)
    )
    predicted = -np.linalg.solve(
        m, (a[0] * sy2 / h) * dphi_y[k - 1].mean(axis=0) + attenuation @ TRUTH
    )
    np.testing.assert_allclose(measured_bias[:3], predicted[:3], rtol=0.2)
    assert measured_bias[1] > 0.2 * abs(TRUTH[1])  # a real bias, a fifth of beta
    assert abs(measured_bias[3]) < 4 * est.std_errors["delta"]


# ------------------------------------------------------------------ l_p norms


def test_l1_ignores_outliers_that_ruin_least_squares(noisy):
    rng = np.random.default_rng(7)
    bad = rng.choice(np.arange(10, noisy.n_samples - 10), size=8, replace=False)
    x = noisy.x.copy()
    x[bad, 1] += 3.0  # sensor glitches on the velocity
    glitchy = noisy.replace(x=x)
    l2 = sd.estimate(AUV, glitchy, "AB2", p=2, skip_input_jumps=True)
    l1 = sd.estimate(AUV, glitchy, "AB2", p=1, skip_input_jumps=True)
    l1_clean = sd.estimate(AUV, noisy, "AB2", p=1, skip_input_jumps=True)
    rel = lambda r: np.abs(_theta(r) / TRUTH - 1)  # noqa: E731
    assert rel(l2).max() > 0.3  # least squares is ruined
    assert rel(l1).max() < 0.05  # l1 is not
    np.testing.assert_allclose(_theta(l1), _theta(l1_clean), rtol=2e-3)
    assert l1.solver == "linprog-highs" and l1.std_errors is None


def test_linf_minimises_the_largest_error(noisy):
    res = sd.estimate(AUV, noisy, "AB2", p=math.inf, skip_input_jumps=True)
    e = _one_step_errors(res, noisy)
    assert np.abs(e).max() == pytest.approx(res.residual_norm, rel=1e-9)
    ls = sd.estimate(AUV, noisy, "AB2", p=2, skip_input_jumps=True)
    assert np.abs(_one_step_errors(res, noisy, _theta(ls))).max() >= res.residual_norm
    rng = np.random.default_rng(3)
    se = np.array([ls.std_errors[n] for n in NAMES])
    for _ in range(20):
        theta = _theta(res) + se * rng.normal(size=4) * 0.1
        assert np.abs(_one_step_errors(res, noisy, theta)).max() >= res.residual_norm * (1 - 1e-7)


@pytest.mark.parametrize("p", [1.5, 3.0])
def test_irls_converges_to_the_lp_minimum(noisy, p):
    kw = {"skip_input_jumps": True}
    res = sd.estimate(AUV, noisy, "AB2", p=p, **kw)
    assert res.solver == "irls" and res.converged and res.iterations < 100

    def objective(theta: np.ndarray) -> float:
        return float(np.sum(np.abs(_one_step_errors(res, noisy, theta)) ** p))

    own = objective(_theta(res))
    assert own ** (1 / p) == pytest.approx(res.residual_norm, rel=1e-9)
    for other_p in (1, 2, math.inf):
        other = sd.estimate(AUV, noisy, "AB2", p=other_p, **kw)
        assert own <= objective(_theta(other)) * (1 + 1e-9), other_p
    rng = np.random.default_rng(5)
    se = np.array([res.std_errors[n] for n in NAMES]) if res.std_errors else 1e-4 * TRUTH
    for _ in range(10):
        assert own <= objective(_theta(res) + 0.01 * np.abs(se) * rng.normal(size=4)) * (1 + 1e-9)


# ------------------------------------------------------------------ excitation checks


def test_rank_deficiency_names_delta():
    # From x0 = 0 the position stays at 0, sin(x)^2 = 0: delta has no regressor.
    data = sd.simulate(AUV, SIGNAL, T=10.0, h=0.02, x0=np.zeros(2), certify=False)
    assert np.all(data.x[:, 0] == 0.0)
    with pytest.raises(ValueError, match=r"delta not identifiable"):
        sd.estimate(AUV, data, "AB2")
    res = sd.estimate(AUV, data, "AB2", params=("alpha", "beta", "gamma"), skip_input_jumps=True)
    assert abs(res.params["beta"] + 0.05) < 1e-2  # fixing delta makes the rest estimable


def test_rank_deficiency_names_collinear_parameters():
    # With u >= 0 the velocity never turns negative: y^2 = y|y|, alpha and gamma
    # are only identifiable as their sum.
    sig = sd.signals.Multilevel(low=0.5, high=10.0, hold=1.0, seed=1)
    data = sd.simulate(AUV, sig, T=10.0, h=0.02, x0=X0, certify=False)
    assert data.x[:, 1].min() >= 0.0
    with pytest.raises(ValueError, match=r"parameters alpha, gamma not identifiable"):
        sd.estimate(AUV, data, "AB2")


def test_bad_conditioning_warns_with_the_number(runs):
    with pytest.warns(UserWarning, match=r"condition number \d"):
        sd.estimate(AUV, runs[0.02], "AB2", cond_warn=2.0)


def test_too_few_samples(runs):
    short = runs[0.02]
    with pytest.raises(ValueError, match="too few samples"):
        sd.estimate(AUV, short, "AB2", after=float(short.t[-3]))
    tiny = sd.Trajectory(short.t[:5], short.x[:5], short.u[:5], short.h, ("x", "y"), ("m", "m/s"))
    with pytest.raises(ValueError, match="too few samples"):
        sd.estimate(AUV, tiny, "AB2")


def test_nan_names_the_sample(runs):
    x = runs[0.02].x.copy()
    x[17, 1] = np.nan
    with pytest.raises(ValueError, match="n=17"):
        sd.estimate(AUV, runs[0.02].replace(x=x), "AB2")


def test_bad_arguments(runs):
    data = runs[0.02]
    with pytest.raises(ValueError, match="`p` must be >= 1"):
        sd.estimate(AUV, data, "AB2", p=0.5)
    with pytest.raises(ValueError, match="fixed rule"):
        sd.estimate(AUV, data, "ABe2")
    with pytest.raises(ValueError, match="unknown method"):
        sd.estimate(AUV, data, "XY2")
    with pytest.raises(ValueError, match="Adams-Bashforth"):
        sd.estimate(AUV, data, "RK4", free_weights=True)
    with pytest.raises(ValueError, match="p=2"):
        sd.estimate(AUV, data, "AB2", p=1, free_weights=True)
    with pytest.raises(ValueError, match="component_scale"):
        sd.estimate(AUV, data, "AB2", component_scale="unit")


# ------------------------------------------------------------------ free weights


def test_free_weights_absorb_input_jumps():
    # h_u = h: the input jumps at every sample, so f jumps too and the fixed AB_4
    # interpolation is wrong by O(h * jump). Free weights fall back to ~Euler.
    h = 0.02
    sig = sd.signals.Multilevel(low=-10.0, high=10.0, hold=h, seed=2)
    data = sd.simulate(AUV, sig, T=20.0, h=h, x0=X0, certify=False)
    fixed = sd.estimate(AUV, data, "AB4")
    weights_only = sd.estimate(AUV, data, "AB4", params=(), free_weights=True)
    joint = sd.estimate(AUV, data, "AB4", free_weights=True)
    assert weights_only.residual_norm < fixed.residual_norm / 50
    assert joint.residual_norm <= weights_only.residual_norm * (1 + 1e-9)
    assert weights_only.weights[0] == pytest.approx(1.0, abs=0.05)
    assert np.abs(weights_only.weights[1:]).max() < 0.05
    x_hat, res = sd.estimate_and_predict(AUV, data, "AB4", free_weights=True)
    k = np.rint((res.t - data.t[0]) / h).astype(int)
    np.testing.assert_allclose((data.x - x_hat)[k], res.residuals, atol=1e-12)


def test_free_weights_on_smooth_data_stay_consistent(runs):
    # Between input jumps f is smooth: the fitted weights still sum to ~1 (the rule
    # stays consistent) but individually are poorly determined (large condition).
    data = runs[0.02]
    fixed = sd.estimate(AUV, data, "AB4", skip_input_jumps=True)
    free = sd.estimate(AUV, data, "AB4", free_weights=True, skip_input_jumps=True)
    assert free.weights.sum() == pytest.approx(1.0, abs=1e-3)
    assert free.condition_number > 100 * fixed.condition_number
    assert free.residual_norm <= fixed.residual_norm
    assert free.weight_std_errors is not None and free.weight_std_errors.shape == (4,)
    for p in (1, math.inf):
        r = sd.estimate(AUV, data, "AB2", p=p, params=(), free_weights=True, skip_input_jumps=True)
        assert r.weights.sum() == pytest.approx(1.0, abs=1e-2)


# ------------------------------------------------------------------ registry


def test_estimated_methods_in_the_registry(runs):
    data = runs[0.02]
    abe3 = sd.get_method("ABe3")
    ee = sd.get_method("Ee")
    assert (abe3.order, abe3.name, ee.order, ee.name) == (3, "ABe3", 1, "Ee")
    with pytest.raises(dataclasses.FrozenInstanceError):
        abe3.p = 1.0  # type: ignore[misc]
    x_hat = sd.predict("ABe3", AUV, data)
    est = abe3.estimate(AUV, data)
    np.testing.assert_array_equal(x_hat, sd.predict("AB3", est.model, data))
    assert np.isnan(x_hat[:3]).all() and np.isfinite(x_hat[3:]).all()
    x_hat2, est2 = sd.estimate_and_predict(AUV, data, "AB1")
    np.testing.assert_array_equal(sd.predict("Ee", AUV, data), x_hat2)
    late = sd.EstimatedAdamsBashforth(2, after_fraction=0.5)
    assert late.estimate(AUV, data).t[0] >= 10.0
    with pytest.raises(ValueError, match="after_fraction"):
        sd.EstimatedAdamsBashforth(2, after_fraction=1.5)


# ------------------------------------------------------------------ the ROV


class _Fig6Thrusters(Signal):
    """Thruster rpm of the paper's Fig. 6: mean + sinusoid, in % of n_max."""

    def __init__(self, n_max: float) -> None:
        self.nu = 8
        mean = np.array([-5, -5, 10, 10, 45, 50, -50, -45]) / 100 * n_max
        amp = np.array([30, 30, 15, 15, 25, 25, 25, 25]) / 100 * n_max
        freq = np.array([0.30, 0.20, 0.15, 0.25, 0.30, 0.25, 0.15, 0.20])
        self._arrays = (mean, amp[:, None], freq[:, None], np.zeros((8, 1)))

    def _sinusoids(self):
        return self._arrays


@pytest.mark.filterwarnings("ignore:pitch")  # the Fig. 6 run pitches beyond 80 deg
def test_rov_damping_recovered_from_exact_samples():
    models = pytest.importorskip("sampledyn.models")
    if not hasattr(models, "load_vehicle"):
        pytest.skip("sampledyn.models.load_vehicle is not available yet")
    rov = models.load_vehicle("bluerov2_heavy")
    data = sd.simulate(rov, _Fig6Thrusters(rov.params["n_max"]), T=60.0, h=0.025, certify=False)
    lin = rov.regressors(data.t[:1], data.x[:1], data.u[:1]).names
    assert len(lin) == 12
    truth = np.array([rov.params[n] for n in lin])
    size = np.maximum(np.abs(truth), 1.0)  # some coefficients are 0 (SI units)
    ab4 = sd.estimate(rov, data, "AB4")
    ab1 = sd.estimate(rov, data, "AB1")
    assert set(ab4.params) == set(lin) and ab4.components == ("u", "v", "w", "p", "q", "r")
    err4 = np.abs(np.array([ab4.params[n] for n in lin]) - truth) / size
    err1 = np.abs(np.array([ab1.params[n] for n in lin]) - truth) / size
    assert err4.max() < 5e-3, dict(zip(lin, err4, strict=True))
    assert err1.max() > 100 * err4.max()  # Euler's O(h) bias
    assert ab4.condition_number < 1e3


def test_printed_estimate_marks_terms_the_data_hardly_excite():
    """A parameter whose standard error reaches its magnitude is marked (*) with a note;
    the others are not."""
    import dataclasses

    model = sd.models.AUVLike()
    traj = sd.simulate(model, sd.signals.Multilevel(-10.0, 10.0, hold=0.05, seed=0), T=40.0,
                       h=0.01)  # fmt: skip
    res = sd.estimate(model, traj, structure="AB2", after=2.0)
    names = list(res.params)
    se = {n: abs(v) * 0.01 for n, v in res.params.items()}
    se[names[0]] = 2.0 * abs(res.params[names[0]])
    text = str(dataclasses.replace(res, std_errors=se))
    marked = [line for line in text.splitlines() if line.endswith("(*)")]
    assert len(marked) == 1 and marked[0].lstrip().startswith(f"{names[0]} =")
    assert "hardly excites" in text
    assert "(*)" not in str(dataclasses.replace(res, std_errors={n: 0.0 for n in names}))
