"""Baselines, the noise estimator and the noise floor (issue 21 items 1, 2)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import sampledyn as sd
from sampledyn._baselines import BASELINES, get_baseline
from sampledyn._noise import difference_weights, estimate_noise, noise_amplitudes
from sampledyn.sensitivity import gentle_input, noise_floor_squares


@pytest.fixture(scope="module")
def heavy():
    return sd.models.load_vehicle("bluerov2_heavy")


@pytest.fixture(scope="module")
def run(heavy):
    """1000 s of the Heavy under the gentle input at 20 Hz: 20 000 samples."""
    return sd.simulate(heavy, gentle_input(heavy), T=1000.0, h=0.05, certify=False)


def test_hold_and_kinematics_predict_as_defined(heavy, run):
    data = run.subsample(20)  # 1 s: the baselines at a step where they differ a lot
    hold = get_baseline("hold").predict(heavy, data)
    np.testing.assert_array_equal(hold[1:], data.x[:-1])
    assert np.isnan(hold[0]).all()
    kin = get_baseline("kinematics").predict(heavy, data)
    euler = sd.predict("E", heavy, data)
    # positions and angles: Euler's (it is the kinematics (6) for a vehicle); rates held
    np.testing.assert_allclose(kin[1:, :6], euler[1:, :6], rtol=1e-14, atol=1e-14)
    np.testing.assert_array_equal(kin[1:, 6:], data.x[:-1, 6:])
    assert tuple(BASELINES) == ("hold", "kinematics")
    with pytest.raises(ValueError, match="baselines are hold, kinematics"):
        get_baseline("zero")


def test_difference_weights_annihilate_polynomials_and_have_unit_norm():
    rng = np.random.default_rng(3)
    t = np.sort(rng.uniform(0, 1, (50, 6)), axis=1)  # jittered nodes, k = 5
    c = difference_weights(t)
    np.testing.assert_allclose(np.linalg.norm(c, axis=1), 1.0, rtol=1e-14)
    for deg in range(5):
        vals = (c * (3.0 + t) ** deg).sum(axis=1)
        assert np.abs(vals).max() < 1e-9 * 4.0**deg
    # uniform nodes: (-1)^j binom(k, j) / sqrt(binom(2k, k))
    u = difference_weights(np.arange(5.0)[None, :])[0]
    want = np.array([1, -4, 6, -4, 1]) / math.sqrt(70)
    np.testing.assert_allclose(np.abs(u), np.abs(want), rtol=1e-14)


@pytest.mark.parametrize("pct", [0.1, 1.0])
def test_noise_levels_estimated_within_the_sampling_spread(run, pct):
    """Known uniform noise (std a / sqrt(3)) on a smooth 20 Hz run: the estimate is
    within 5 % of it in every state. The spread of the estimate of sigma over 19 996
    overlapping windows is about 1.4 %; 5 % is 3.5 of it."""
    measured = sd.add_noise(run, pct, pct, seed=7)
    est = estimate_noise(measured)
    true = noise_amplitudes(run.state_units, pct, pct) / math.sqrt(3)
    np.testing.assert_allclose(est.sigma, true, rtol=0.05)
    assert est.resolved.all()
    # the signal alone gives below 5 % of the smallest level: its bias on sigma^2
    # (added in quadrature) is below 0.25 % here
    clean = estimate_noise(run)
    assert (clean.sigma < 0.05 * true).all()


def test_noise_estimated_on_jittered_stamps(heavy):
    """Stamps 0.1 s apart, each moved by up to 20 ms: the divided differences of the
    actual nodes estimate the noise as on a grid (4000 samples: spread about 3 %)."""
    fine = sd.simulate(heavy, gentle_input(heavy), T=400.0, h=0.01, certify=False)
    rng = np.random.default_rng(5)
    at = 10 * np.arange(1, 3999) + rng.integers(-2, 3, 3998)
    data = fine.replace(t=fine.t[at], x=fine.x[at], u=fine.u[at], h=0.1, certificate=None)
    assert not data.on_uniform_grid
    measured = sd.add_noise(data, 1.0, 1.0, seed=4)
    est = estimate_noise(measured)
    true = noise_amplitudes(data.state_units, 1.0, 1.0) / math.sqrt(3)
    np.testing.assert_allclose(est.sigma, true, rtol=0.1)


def test_windows_across_input_jumps_are_left_out():
    """The AUV-like rate's derivative jumps with the multilevel input: differences
    across a jump measure the jump (7x the noise here), the others the noise."""
    auv = sd.models.AUVLike()
    sig = sd.signals.Multilevel(low=-10, high=10, hold=0.5, seed=0, nu=1)
    measured = sd.add_noise(sd.simulate(auv, sig, 200.0, 0.05), 1.0, 1.0, seed=2)
    est = estimate_noise(measured)
    true = noise_amplitudes(measured.state_units, 1.0, 1.0) / math.sqrt(3)
    assert est.across_jumps > 0
    np.testing.assert_allclose(est.sigma, true, rtol=0.08)


def test_noise_floor_of_the_hold_is_sqrt2_sigma_and_rules_match_monte_carlo(heavy, run):
    """The floor is the expected noise part of the one-step error: sqrt(2) sigma per
    component for the hold (Phi = I); for E and AB4 the mean square of 200 noise-only
    error draws (errors with noise minus without, same samples) within 5 % (the
    spread of a mean of 200 x 400 squares is below 1 %)."""
    data = run.subsample(4)  # 0.2 s
    data = data.replace(t=data.t[:401], x=data.x[:401], u=data.u[:401], signal=None)
    sigma = noise_amplitudes(data.state_units, 1.0, 1.0) / math.sqrt(3)
    hold = noise_floor_squares(get_baseline("hold"), heavy, data, sigma)
    np.testing.assert_allclose(hold[1:], np.broadcast_to(2 * sigma**2, hold[1:].shape))
    rng = np.random.default_rng(11)
    for name in ("E", "AB4"):
        rule = sd.get_method(name)
        floor = noise_floor_squares(rule, heavy, data, sigma)
        clean_err = data.x - rule.predict(heavy, data)
        acc = np.zeros_like(data.x)
        for _ in range(200):
            noisy = data.replace(x=data.x + rng.normal(size=data.x.shape) * sigma)
            e = noisy.x - rule.predict(heavy, noisy) - clean_err
            acc += e * e
        rows = ~np.isnan(floor).any(axis=1)
        got = np.nanmean(acc[rows] / 200, axis=0)
        np.testing.assert_allclose(got, floor[rows].mean(axis=0), rtol=0.05)
