"""Every rule answers its own stability function or region (issue 21 item 3)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

import sampledyn as sd
from sampledyn.methods import (
    Stability,
    ab_stability_interval,
    available_methods,
    get_method,
    largest_stable_steps,
)

# The bisection stops at a relative 2^-32 of the exit point: that is the tolerance.
REL = 2.0**-30


@pytest.mark.parametrize("name", available_methods())
def test_every_rule_answers_its_amplification(name):
    m = get_method(name)
    assert isinstance(m, Stability)
    z = np.array([0.0, -1e-3, -1e-3 + 1e-3j])
    amp = m.amplification(z)
    assert amp.shape == z.shape
    # consistency: |R(0)| = 1, and a small damped step contracts (every rule is stable
    # near 0 on the left half-plane's interior)
    assert amp[0] == pytest.approx(1.0, abs=1e-12)
    assert (amp[1:] < 1.0).all()


@pytest.mark.parametrize("s", range(1, 7))
def test_adams_bashforth_real_interval_is_two_over_a_s(s):
    """On the negative real axis AB_s leaves its region at z = -2 / a_s (the module
    docstring of _adams; the root zeta = -1 there): the scan of the characteristic
    polynomial's roots finds the same point."""
    h = largest_stable_steps(get_method(f"AB{s}"), np.array([-1.0]))[0]
    assert h == pytest.approx(ab_stability_interval(s), rel=REL)


def test_runge_kutta_and_euler_against_closed_forms():
    lam = np.array([-1.0, 1j, -0.3 + 2j])
    # Euler: |1 + h lambda| <= 1  <=>  h <= -2 Re(lambda) / |lambda|^2
    e = largest_stable_steps(get_method("E"), lam)
    np.testing.assert_allclose(e, [2.0, 0.0, 0.6 / abs(lam[2]) ** 2], rtol=REL)
    # RK4 on the real axis: the root of |R(-x)| = 1 (scipy's brentq at 1e-14), on the
    # imaginary axis 2 sqrt(2); RK3 on the imaginary axis sqrt(3)
    r4 = np.poly1d([1 / 24, -1 / 6, 1 / 2, -1, 1])  # R(-x)
    x4 = brentq(lambda x: r4(x) - 1.0, 2.0, 3.0, xtol=1e-14)
    h4 = largest_stable_steps(get_method("RK4"), np.array([-1.0, 1j]))
    np.testing.assert_allclose(h4, [x4, 2 * math.sqrt(2)], rtol=REL)
    h3 = largest_stable_steps(get_method("RK3"), np.array([1j]))
    np.testing.assert_allclose(h3, [math.sqrt(3)], rtol=REL)


def test_rk_stability_polynomials_are_the_truncated_exponential():
    from fractions import Fraction

    for s in range(1, 5):
        coeffs = get_method(f"RK{s}").stability_polynomial
        assert coeffs == tuple(Fraction(1, math.factorial(j)) for j in range(s + 1))


def test_a_stable_rules_are_stable_at_every_step_on_damped_modes():
    lam = np.array([-1.0, -1e3 + 1e3j, -1e-9 + 5j])
    for name in ("T", "ZOH"):
        assert np.isinf(largest_stable_steps(get_method(name), lam)).all()


def test_ab3_imaginary_segment_matches_a_brute_force_root_scan():
    """AB3 covers a segment of the imaginary axis (about 0.72, Hairer & Wanner II, Fig.
    V.1.1): np.roots on a fine grid of iy finds the first y where a root leaves the
    unit disc, to the grid's spacing."""
    a = [float(c) for c in sd.AdamsBashforth(3).coefficients]
    ys = np.arange(0.01, 1.0, 1e-4)
    worst = [
        max(abs(np.roots([1, -1 - 1j * y * a[0], -1j * y * a[1], -1j * y * a[2]]))) for y in ys
    ]
    first = ys[np.argmax(np.array(worst) > 1 + 1e-12)]
    h = largest_stable_steps(get_method("AB3"), np.array([1j]))[0]
    assert abs(h - first) <= 1e-4


def test_variants_share_the_adams_region():
    lam = np.array([-1.0, -0.2 + 1j])
    ref = largest_stable_steps(get_method("AB3"), lam)
    for name in ("ABu3", "ABj3", "ABe3"):
        np.testing.assert_array_equal(largest_stable_steps(get_method(name), lam), ref)
