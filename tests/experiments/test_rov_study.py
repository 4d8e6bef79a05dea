"""The ROV case study: noise, the Fig. 6 input, the forced motion, Fig. 7 machinery."""

import math
import warnings

import numpy as np
import pytest

import sampledyn as sd
from sampledyn._noise import noise_amplitudes
from sampledyn.experiments import ROVStudy
from sampledyn.experiments._rov import fig7_vehicle, run_rov_study
from sampledyn.experiments.sweep._summaries import motion_summary
from sampledyn.report import fig7_table
from sampledyn.report._fig7 import norm_evidence, ratio_phrase
from sampledyn.signals._fig6 import FIG6_TABLE


@pytest.fixture(scope="module")
def vehicle():
    return fig7_vehicle(sd.models.load_vehicle("bluerov2_heavy"), 1.0)


@pytest.fixture(scope="module")
def run(vehicle):
    model = sd.models.AttitudeHold(vehicle)
    signal = sd.signals.fig6_thrusters(vehicle)
    return model, signal, sd.simulate(model, signal, T=300.0, h=0.1)


def test_fig7_vehicle_sets_one_percent_buoyancy(vehicle):
    published = sd.models.load_vehicle("bluerov2_heavy")
    assert vehicle.buoyancy == pytest.approx(1.01 * vehicle.weight, rel=1e-12)
    assert published.volume == 0.0134  # the file keeps the published value


def test_noise_amplitudes_follow_the_paper_references():
    units = ("m",) * 3 + ("rad",) * 3 + ("m/s",) * 3 + ("rad/s",) * 3
    a = noise_amplitudes(units, eta_pct=10.0, v_pct=2.0)
    np.testing.assert_allclose(a[:3], 0.1)
    np.testing.assert_allclose(a[3:6], 0.1 * math.radians(30))
    np.testing.assert_allclose(a[6:9], 0.02)
    np.testing.assert_allclose(a[9:], 0.02 * math.radians(30))
    with pytest.raises(ValueError, match="eta_pct"):
        noise_amplitudes(units, -1.0, 0.0)


def test_add_noise_uniform_levels_streams_and_clean(run):
    _, _, traj = run
    noisy = sd.add_noise(traj, eta_pct=20.0, v_pct=10.0, seed=3)
    assert noisy.clean is traj
    d = noisy.x - traj.x
    a = noise_amplitudes(traj.state_units, 20.0, 10.0)
    assert (np.abs(d) <= a + 1e-15).all()
    # uniform on [-a, a]: standard deviation a / sqrt(3)
    np.testing.assert_allclose(d.std(axis=0) / (a / np.sqrt(3)), 1.0, atol=0.05)
    # Independent streams: the position noise does not depend on the rate level.
    other = sd.add_noise(traj, eta_pct=20.0, v_pct=0.0, seed=3)
    np.testing.assert_array_equal(other.x[:, :6], noisy.x[:, :6])
    np.testing.assert_array_equal(other.x[:, 6:], traj.x[:, 6:])
    # Same seed, same noise; another seed, other noise.
    np.testing.assert_array_equal(sd.add_noise(traj, 20.0, 10.0, seed=3).x, noisy.x)
    assert not np.array_equal(sd.add_noise(traj, 20.0, 10.0, seed=4).x, noisy.x)
    # Noise on noisy data starts again from the clean samples.
    again = sd.add_noise(noisy, 0.0, 0.0, seed=1)
    np.testing.assert_array_equal(again.x, traj.x)


def test_gaussian_noise_has_the_same_spread(run):
    _, _, traj = run
    d = sd.add_noise(traj, 10.0, 10.0, seed=0, distribution="gaussian").x - traj.x
    a = noise_amplitudes(traj.state_units, 10.0, 10.0)
    np.testing.assert_allclose(d.std(axis=0) / (a / np.sqrt(3)), 1.0, atol=0.05)
    assert (np.abs(d) > a).any()  # unbounded, unlike the uniform noise
    with pytest.raises(ValueError, match="distribution"):
        sd.add_noise(traj, 1.0, 1.0, distribution="laplace")


def test_fig6_mapping_pushes_the_labelled_way(vehicle):
    sig = sd.signals.fig6_thrusters(vehicle)
    d = np.asarray(vehicle.thruster_directions)
    vertical = np.abs(d[:, 2]) > 0.9
    assert vertical.sum() == 4
    # Mean thrust direction of each thruster: sign(n0) * d.
    push = np.sign(sig.offset)[:, None] * d
    rows = iter(FIG6_TABLE)
    for i in list(np.flatnonzero(vertical)) + list(np.flatnonzero(~vertical)):
        _, mean, label, sin_pct, f_hz = next(rows)
        assert abs(sig.offset[i]) == pytest.approx(abs(mean) / 100 * vehicle.n_max)
        assert abs(sig.amp[i, 0]) == pytest.approx(sin_pct / 100 * vehicle.n_max)
        assert sig.freq_hz[i, 0] == f_hz
        if label == "up":
            assert push[i, 2] < 0  # towards -z (NED): up
        elif label == "down":
            assert push[i, 2] > 0
        else:
            assert push[i, 0] > 0  # forward


def test_forced_motion_looks_like_the_papers(run, vehicle):
    model, _, traj = run
    late = traj.t >= 100.0
    motion = motion_summary(traj)
    assert traj.certificate.max_error < 1e-10
    assert traj.x[late, 6].mean() > 0.2  # forward navigation, m/s
    assert -0.2 < (traj.x[-1, 2] - traj.x[100, 2]) / (traj.t[-1] - traj.t[100]) < 0.0  # ascent
    assert motion["max_abs_pitch_deg"] < 25.0  # |theta| well below 40 deg
    assert motion["max_abs_roll_deg"] < 25.0
    applied = model.applied_rpm(traj.x, traj.u)
    assert np.abs(applied).max() < vehicle.n_max  # the hold never saturates


def test_open_loop_fig6_input_pitches_the_bluerov2_over(vehicle):
    # The finding behind the attitude hold: 4 thrusters pushing forward 8.5 cm below
    # the centre of gravity give a pitch moment the 1 cm righting arm cannot hold.
    signal = sd.signals.fig6_thrusters(vehicle)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        traj = sd.simulate(vehicle, signal, T=60.0, h=0.1, certify=False)
    assert np.degrees(np.abs(traj.x[:, 4])).max() > 40.0
    thrust = vehicle.thrust(np.zeros(12), signal(np.array([0.0]))[0])
    pitch_moment = (vehicle.allocation @ thrust)[4]
    righting = vehicle.weight * 0.01
    assert abs(pitch_moment) > righting


def test_attitude_hold_switches_and_law(run):
    model, signal, traj = run
    k = 1234
    x, u = traj.x[k], traj.u[k]
    applied = model.applied_rpm(x, u)[0]
    # The law as a composition: n = n_ref + G x, with G only on (phi, theta, p, q).
    np.testing.assert_allclose(applied, u + model.gains @ x[[3, 4, 9, 10]], rtol=1e-14)
    # The closed loop is the vehicle driven by the applied rpm, bit for bit.
    assert np.array_equal(model.f(traj.t[k], x, u), model.vehicle.f(traj.t[k], x, applied))
    # Switching values: the vehicle's own (velocities in |v| v, rpm in n |n|, ...) at
    # the applied rpm.
    sw, sp, input_only = model.switch_kernel()
    vsw, vsp, v_only = model.vehicle.switch_kernel()
    assert input_only.shape == v_only.shape
    out, ref = np.empty(input_only.size), np.empty(v_only.size)
    sw(traj.t[k], x, u, sp, out)
    vsw(traj.t[k], x, applied, vsp, ref)
    np.testing.assert_array_equal(out, ref)
    np.testing.assert_array_equal(out[:6], x[6:12])
    assert not input_only.any()  # through the loop, every value depends on the state
    with pytest.raises(ValueError, match="kp"):
        sd.models.AttitudeHold(model.vehicle, kp=0.0)


def test_attitude_hold_jacobian_is_the_chain_rule(run):
    model, signal, traj = run
    k = 1234
    x, u = traj.x[k], traj.u[k]
    try:
        jac = model.jacobian(traj.t[k], x, u)
    except sd.exceptions.JacobianUnavailableError:
        pytest.skip("Vehicle.input_jacobian (df/du) is not in this branch yet")
    step = 1e-6 * np.maximum(1.0, np.abs(x))
    fd = np.empty_like(jac)
    for j in range(model.nx):
        e = np.zeros(model.nx)
        e[j] = step[j]
        fd[:, j] = (model.f(traj.t[k], x + e, u) - model.f(traj.t[k], x - e, u)) / (2 * step[j])
    np.testing.assert_allclose(jac, fd, rtol=1e-6, atol=1e-7 * np.abs(jac).max())


def test_subsample_keeps_exact_samples(run):
    model, signal, traj = run
    coarse = sd.simulate(model, signal, T=300.0, h=0.5)
    sub = traj.subsample(5)
    assert sub.h == pytest.approx(0.5)
    np.testing.assert_allclose(sub.t, coarse.t, atol=1e-9)
    scale = np.maximum(1.0, np.abs(coarse.x).max(axis=0))
    assert (np.abs(sub.x - coarse.x) / scale).max() < 1e-9
    assert sub.certificate.per_interval.shape == (coarse.n_samples - 1,)
    with pytest.raises(ValueError, match="`k`"):
        traj.subsample(0)


def test_ratio_phrase_matches_the_papers_wording():
    assert ratio_phrase(1.6e-5, 2.1e-7) == "AB1 ~ 76xAB4"
    assert ratio_phrase(1.3e-4, 1.3e-4) == "AB1 ~ AB4"
    assert ratio_phrase(1.2e-4, 4.3e-4) == "3.6xAB1 ~ AB4"


def _fake_summary(norm_factor):
    # Rows whose l2/N is the paper's number times a factor; rms = l2/N * sqrt(N).
    from sampledyn.experiments._paper_fig7 import PAPER_FIG7

    rows = []
    for (h, e, v), ((p1, p4), (v1, v4)) in PAPER_FIG7.items():
        n = 4000 / h
        for m, pos, vel in (("AB1", p1, v1), ("AB4", p4, v4)):
            rows.append({
                "h": h, "eta_pct": e, "v_pct": v, "method": m,
                "pos_l2_over_n": pos * norm_factor, "vel_l2_over_n": vel * norm_factor,
                "pos_rms": pos * norm_factor * math.sqrt(n),
                "vel_rms": vel * norm_factor * math.sqrt(n),
            })  # fmt: skip
    return rows


def test_norm_evidence_identifies_the_norm():
    ev = norm_evidence(_fake_summary(1.0))
    assert ev["l2_over_n"]["geo_mean_ratio"] == pytest.approx(1.0)
    assert ev["rms"]["geo_mean_ratio"] > 50
    table = fig7_table(_fake_summary(1.0))
    assert "AB1 ~ 76xAB4 (1.6e-05, 2.1e-07)" in table


@pytest.mark.slow
def test_small_rov_study_is_the_same_in_one_or_two_processes():
    study = ROVStudy(T=40.0, after=10.0, seeds=2, noise_pairs=((0, 0), (10, 2)),
                     methods=("AB1", "AB4", "RK4"))  # fmt: skip
    one = run_rov_study(study, workers=1)
    two = run_rov_study(study, workers=2)
    assert one["rows"] == two["rows"]
    assert len(one["rows"]) == 2 * (1 + 2) * 3
    assert one["certificates"][0.1] == pytest.approx(two["certificates"][0.1])
    assert max(one["certificates"].values()) < 1e-10
    clean = {(r["h"], r["method"]): r for r in one["rows"] if r["eta_pct"] == 0}
    # Without noise, AB4 beats AB1 at h = 0.1 s (local error O(h^5) against O(h^2)).
    assert clean[(0.1, "AB4")]["pos_l2_over_n"] < clean[(0.1, "AB1")]["pos_l2_over_n"] / 3
