"""Honest answers on logs (issue 21): baselines, the noise floor and stability in the
table, failures as rows, estimates on jittered logs with their flags."""

from __future__ import annotations

import math

import numpy as np
import pytest

import sampledyn as sd
from sampledyn._noise import noise_amplitudes
from sampledyn.cli import main
from sampledyn.logs import evaluate_log, log_from_frame, synthetic_log, write_synthetic_log


@pytest.fixture(scope="module")
def heavy():
    return sd.models.load_vehicle("bluerov2_heavy")


@pytest.fixture(scope="module")
def noisy_log(heavy):
    """80 s at 10 Hz with 5 % noise: the noise dominates every one-step error."""
    return log_from_frame(synthetic_log(h=0.1, T=80.0, eta_pct=5.0, v_pct=5.0, seed=3), heavy)


def test_the_table_has_the_baselines_the_noise_levels_and_the_floor(heavy, noisy_log):
    result = evaluate_log(heavy, noisy_log, ["E", "AB2", "AB4", "RK4", "T"])
    names = [r["method"] for r in result.rows]
    assert names[:2] == ["hold", "kinematics"] and names[2:] == ["E", "AB2", "AB4", "RK4", "T"]
    assert [r["kind"] for r in result.rows[:2]] == ["baseline", "baseline"]
    # the noise levels, estimated from the log: 801 samples, spread of sigma about 5 %
    true = noise_amplitudes(heavy.state_units, 5.0, 5.0) / math.sqrt(3)
    np.testing.assert_allclose(result.noise.sigma, true, rtol=0.2)
    # the hold's floor is sqrt(2) sigma per component; every rate block sits at the
    # floor: the table measures the sensor here, and says so
    hold = result.row("hold")
    want = math.sqrt(2 * np.sum(result.noise.sigma[6:] ** 2))
    assert hold["floor_v"] == pytest.approx(want, rel=1e-9)
    for r in result.rows:
        assert r["at_floor_v"] is True, r
    table = result.table()
    assert "hold" in table and "kinematics" in table and "noise (std" in table
    assert "within 1.25x" in table


def test_a_log_beyond_a_rules_stability_warns_about_that_rule(heavy):
    """0.8 s steps: beyond E's, AB2's and RK4's stability along the Heavy's states
    (their largest stable steps are about 0.2, 0.2 and 0.6 s), within Tustin's."""
    data = log_from_frame(synthetic_log(h=0.8, T=80.0, eta_pct=0.1, v_pct=0.1), heavy)
    result = evaluate_log(heavy, data, ["E", "RK4", "T"])
    by_rule = {lim.method: lim for lim in result.stability}
    assert not by_rule["E"].stable and not by_rule["RK4"].stable and by_rule["T"].stable
    assert 0.1 < by_rule["E"].h_stable < 0.4 and math.isinf(by_rule["T"].h_stable)
    text = " ".join(result.warnings)
    assert "E at h = 0.8 s is beyond its stability limit" in text
    assert "RK4 at h = 0.8 s is beyond its stability limit" in text
    assert "largest stable step is" in text and "lambda = " in text
    assert "T at h" not in text
    assert result.row("E")["stable"] is False and result.row("T")["stable"] is True


def test_a_failing_newton_iteration_is_a_row_not_an_abort(heavy, noisy_log):
    result = evaluate_log(heavy, noisy_log, ["E", "T"], newton={"max_iter": 1})
    t = result.row("T")
    assert t["failed"].startswith("ConvergenceError: Tustin's Newton iteration did not")
    assert "--newton-max-iter" in t["failed"]
    assert math.isnan(t["err_v"]) and result.failed == ("T",)
    assert math.isfinite(result.row("E")["err_v"])  # the other rows are complete
    again = evaluate_log(heavy, noisy_log, ["T"], newton={"max_iter": 50, "tol": 1e-10})
    assert again.row("T")["failed"] is None


def test_the_cli_prints_every_row_and_exits_7_when_one_failed(tmp_path, capsys):
    log = write_synthetic_log(tmp_path / "log.csv", T=20.0, eta_pct=5.0, v_pct=5.0)
    args = ["evaluate", "--data", str(log), "--vehicle", "bluerov2_heavy", "--methods", "E,T"]
    assert main([*args, "--newton-max-iter", "1"]) == 7
    out = capsys.readouterr().out
    assert "failed: ConvergenceError" in out and "\nE " in out and "\nhold " in out
    assert main([*args, "--newton-max-iter", "60"]) == 0
    with pytest.raises(SystemExit) as refused:  # before any work
        main([*args, "--newton-tol", "0"])
    assert refused.value.code == 3
    assert "--newton-tol: `tol` must be a finite number > 0" in capsys.readouterr().err


def test_estimates_on_a_jittered_log_every_one_printed_with_its_flags(tmp_path, capsys):
    """--estimate on a jittered log (refused before: a uniform grid only), three rules
    asked, three estimates printed; an estimate of negative damping is flagged (!)."""
    log = write_synthetic_log(
        tmp_path / "jit.csv", h=0.1, T=40.0, eta_pct=2.0, v_pct=2.0, jitter=0.01, clock=1e-3
    )
    args = ["evaluate", "--data", str(log), "--vehicle", "bluerov2_heavy", "--methods", "E"]
    assert main([*args, "--estimate", "Ee,ABe2,ABe3"]) == 0
    out = capsys.readouterr().out
    assert out.count("estimate, l_2 norm") == 3
    assert "(!) outside the model's physical bounds" in out


def test_flags_of_the_result_follow_the_physics_and_the_standard_errors(heavy, noisy_log):
    result = evaluate_log(heavy, noisy_log, ["ABe2"])
    est = result.estimation
    assert est is not None and len(result.estimations) == 1
    for name, value in est.params.items():
        flags = est.flags.get(name, ())
        assert ("bounds" in flags) == (value < 0), name  # damping magnitudes are >= 0
        assert ("loose" in flags) == (not est.std_errors[name] < abs(value)), name
    assert any("bounds" in f for f in est.flags.values())  # noise fitted: some negative
    assert est.bounds["K_pp"] == (0.0, math.inf)


def test_estimate_leaves_out_samples_straddling_input_jumps_by_default():
    """Exact samples of the AUV-like model under a multilevel input: AB4's history
    over a jump is wrong by O(h jump); those rows are left out by default, and the
    estimate is the truth to the O(h^4) bias of AB4 (delta = 0.5)."""
    auv = sd.models.AUVLike()
    sig = sd.signals.Multilevel(low=-10, high=10, hold=0.5, seed=0, nu=1)
    traj = sd.simulate(auv, sig, 100.0, 0.05)
    default = sd.estimate(auv, traj, structure="AB4")
    assert default.left_out > 0
    assert default.params["delta"] == pytest.approx(0.5, abs=5e-3)
    every = sd.estimate(auv, traj, structure="AB4", skip_input_jumps=False)
    assert every.left_out == 0 and abs(every.params["delta"] - 0.5) > 0.1
    # a continuously varying input leaves nothing out
    smooth = sd.simulate(auv, sd.signals.Sinusoidal([0.0], [5.0], [0.3], None), 100.0, 0.05)
    assert sd.estimate(auv, smooth, structure="AB4").left_out == 0


def test_estimate_on_jittered_exact_samples_matches_the_uniform_grid():
    """AB2 regressions with the weights of the actual nodes: on exact samples at
    jittered stamps (up to 20 % of h) the estimate is the grid's to 2e-3 (both carry
    AB2's O(h^2) bias, 0.012 on beta here); RK4, fitted through its predictions on the
    actual steps with the input between samples, is the truth to 1e-5."""
    auv = sd.models.AUVLike()
    sig = sd.signals.Sinusoidal([0.0], [5.0], [0.3], None)
    fine = sd.simulate(auv, sig, 100.0, 0.005)
    rng = np.random.default_rng(2)
    at = 10 * np.arange(1, 1999) + rng.integers(-2, 3, 1998)
    jit = fine.replace(t=fine.t[at], x=fine.x[at], u=fine.u[at], h=0.05, certificate=None)
    grid = fine.subsample(10)
    a = sd.estimate(auv, jit, structure="AB2").params
    b = sd.estimate(auv, grid, structure="AB2").params
    rk = sd.estimate(auv, jit, structure="RK4", signal=sig).params
    for name, truth in auv.params.items():
        assert abs(a[name] - b[name]) < 2e-3, name
        assert rk[name] == pytest.approx(truth, abs=1e-5), name
