"""advise never dies at a trial period of its own, reports stability and takes
per-state noise levels; trim finds, verifies or refuses (issue 21 items 3, 4, 7)."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import sampledyn as sd
from sampledyn.experiments import trim


@pytest.fixture(scope="module")
def bluerov2():
    """The 6-thruster BlueROV2 of Wu 2018 (the issue's trim and advise findings)."""
    return sd.models.load_vehicle("bluerov2")


def _strong_input(v):
    n = v.n_max
    return sd.signals.Sinusoidal(
        [0.1 * n, 0.1 * n, -0.1 * n, -0.1 * n, -0.1 * n, -0.1 * n],
        [0.3 * n] * 6,
        [0.05, 0.07, 0.06, 0.08, 0.1, 0.09],
        None,
    )


def test_advise_goes_on_where_tustin_fails_at_a_trial_period(bluerov2):
    """Asked about h = 0.1 s, advise tries periods up to 2 s; Tustin's Newton fails at
    1.4 s (a raw ConvergenceError before): its curve and h_max end there, the other
    rules' curves are complete and the notes say so."""
    a = sd.advise(
        bluerov2, 0.1, 1.0, 1.0, methods=("E", "RK4", "T"), validate=False, T=60.0,
        signal=_strong_input(bluerov2), tolerance=0.05,
    )  # fmt: skip
    h_fail, why = a.curves.failed["T"]
    assert h_fail == pytest.approx(1.4) and why.startswith("ConvergenceError")
    t = a.curves.predicted["T"]
    assert np.isnan(t[a.curves.h >= h_fail - 1e-9]).all()
    assert np.isfinite(t[a.curves.h < h_fail - 1e-9]).all()
    assert np.isfinite(a.curves.predicted["RK4"]).all()
    assert a.row("T").failed is None and math.isfinite(a.row("T").predicted_v)
    assert any(n.startswith("T: its curve (and h_max) ends from h = 1.4 s on") for n in a.notes)
    # stability beside h_max: Euler is unstable on the roll oscillation at 0.1 s
    assert a.row("T").h_stable == math.inf and a.row("E").h_stable < 0.1
    assert "h_stab" in a.table()
    # the baselines beside the ranking: kinematics' position block is Euler's
    assert [b.method for b in a.baselines] == ["hold", "kinematics"]
    kin = a.baselines[1]
    assert kin.predicted_eta == pytest.approx(a.row("E").predicted_eta, rel=1e-12)
    assert kin.predicted_v == pytest.approx(a.baselines[0].predicted_v, rel=1e-12)


def test_advise_on_per_state_noise_levels(bluerov2):
    sig = sd.signals.Sinusoidal([300, 300, -300, -300, -200, -200], [200] * 6, [0.05] * 6, None)
    sigma = np.zeros(12)
    sigma[6:] = 2e-3  # rates only, as a motion-capture log's
    a = sd.advise(
        bluerov2, 0.1, 0.0, 0.0, methods=("E", "AB2"), T=10.0, signal=sig, seeds=2,
        noise_levels=sigma,
    )  # fmt: skip
    np.testing.assert_allclose(a.noise_levels, sigma)
    assert math.isnan(a.eta_pct) and "noise per state (std, uniform): u 0.002" in a.table()
    # the Monte Carlo with those levels (uniform, std sigma): the measured rms of the
    # rate block is about sqrt(2 * 6) sigma for a rule at the floor
    assert a.row("E").measured_rms_v == pytest.approx(math.sqrt(12) * 2e-3, rel=0.3)
    with pytest.raises(ValueError, match="`noise_levels` must be 12 standard deviations"):
        sd.advise(bluerov2, 0.1, 0, 0, methods=("E",), signal=sig, noise_levels=[1e-3])


def test_trim_finds_the_hold_the_direct_solve_misses(bluerov2):
    """At 0.5 m/s the direct Gauss-Newton solve runs into the singular pitch (trim
    raised before); the roll-free hold exists and is found and verified."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no warning: a verified trim
        x, u = trim(bluerov2, surge=0.5, depth=5.0, heading=0.5)
    f = bluerov2.f(0.0, x, u)
    assert np.abs(f[2:]).max() < 1e-10
    assert abs(math.degrees(x[4])) <= bluerov2.pitch_limit_deg
    assert (np.abs(u) <= bluerov2.n_max).all()
    assert x[6] == 0.5 and x[2] == 5.0 and x[5] == 0.5


def test_trim_says_so_beyond_the_pitch_limit_and_refuses_without_a_trim(bluerov2):
    x, _ = trim(bluerov2, surge=0.5, depth=5.0, heading=0.5)
    pitch = abs(math.degrees(x[4]))
    with pytest.raises(ValueError, match=r"beyond the limit 10 deg \(the least: theta ="):
        trim(bluerov2, surge=0.5, depth=5.0, heading=0.5, max_pitch_deg=10.0)
    assert pitch > 10.0
    heavy = sd.models.load_vehicle("bluerov2_heavy")
    with pytest.raises(ValueError, match=r"no trim of 'bluerov2_heavy' at surge 1.0 m/s.*"
                       r"smallest \|f\| reached"):  # fmt: skip
        trim(heavy, surge=1.0, depth=5.0, heading=0.5)


def test_trim_keeps_the_direct_solve_where_it_is_level():
    """The over-actuated vehicles hold level: the direct solve's trim (the one every
    closed-loop study is designed at) is returned unchanged."""
    from sampledyn.experiments._closed_loop import _attempt, _set_point, _start_rpm

    for name in ("rexrov", "bluerov2_heavy"):
        v = sd.models.load_vehicle(name)
        x, u = trim(v, 0.5, 5.0, 0.5)
        xd, ud, res = _attempt(v, _set_point(0.5, 5.0, 0.5), _start_rpm(v, 0.5, 5.0, 0.5))
        np.testing.assert_array_equal(x, xd)
        np.testing.assert_array_equal(u, ud)
        assert abs(math.degrees(x[4])) < 0.1


@pytest.mark.slow  # a vehicle's domain maxima for the bound: a long study here
def test_advise_cli_takes_noise_levels_and_newton_options(tmp_path, capsys):
    from sampledyn.cli import main

    args = ["advise", "--vehicle", "bluerov2_heavy", "--methods", "E,T", "--T", "10",
            "--no-validate", "--out", str(tmp_path)]  # fmt: skip
    assert main([*args, "--noise-levels", "u=2e-3,v=2e-3,w=2e-3", "--newton-max-iter", "40"]) == 0
    out = capsys.readouterr().out
    assert "noise per state (std, uniform): u 0.002, v 0.002, w 0.002" in out
    assert "h_stab" in out
    with pytest.raises(SystemExit) as bad:
        main([*args, "--noise-levels", "speed=1"])
    assert bad.value.code == 3
    assert "'speed' is no state of 'bluerov2_heavy'" in capsys.readouterr().err
