"""One experiment engine: the paper's studies, advise's Monte Carlo and sweeps plan
cells and compute them with the same cell function.

* ``reproduce fig7`` and ``sweep examples/sweep_fig7.toml`` give the same cells, bit
  for bit, and ``reproduce fig7 --store`` resumes after SIGKILL;
* Figs. 2-3 give the numbers of the code before the engine (a CSV it wrote);
* one simulation serves every h that is a multiple of another;
* in a closed loop, rules that use samples only predict with the plant and the applied
  input, rules that evaluate f between samples with the loop and the reference;
* ``advise`` works on the RexROV and on a user model (REMUS), and refuses clearly.
"""

from __future__ import annotations

import csv
import importlib.util
import math
import os
import sqlite3
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from _numbers import AUV_CERTIFICATE_BOUND, assert_rows_close, auv_tolerance, read_rows
from _sweep_helpers import kill_when_stored, write_sweep

import sampledyn as sd
from sampledyn.cli import main
from sampledyn.experiments import ROVStudy, run_study
from sampledyn.experiments._rov import FIG7_STUDY_FILE
from sampledyn.experiments.sweep import load_config
from sampledyn.experiments.sweep._plan import plan_study

ROOT = Path(__file__).resolve().parents[2]
DATA = Path(__file__).parent / "data"
EXAMPLE = ROOT / "examples" / "sweep_fig7.toml"
SHORT = {"T": "20.0", "after": "5.0", "seeds": "2"}


def _cells(db: Path) -> dict[str, tuple]:
    with sqlite3.connect(f"file:{db}?mode=ro", uri=True) as conn:
        return {
            r[0]: r[1:]
            for r in conn.execute("SELECT key, err_eta, err_v, err_all, status FROM cells")
        }


def _shorten(text: str, values: dict[str, str]) -> str:
    lines = []
    for line in text.splitlines():
        key = line.split("=")[0].strip()
        lines.append(f"{key} = {values[key]}" if key in values and "=" in line else line)
    return "\n".join(lines) + "\n"


def test_example_sweep_is_the_built_in_fig7_study():
    example = load_config(EXAMPLE)
    built_in = load_config(FIG7_STUDY_FILE)
    assert example.as_dict() == built_in.as_dict()
    assert example.vehicle == "rexrov" and example.feedback is None  # the paper: open loop
    # The BlueROV2 Heavy gets its hold from the study's per-vehicle table, not from code.
    blue = ROVStudy(vehicle="bluerov2_heavy").config()
    assert blue.feedback == {"law": "roll_pitch_hold", "kp": 40.0, "kd": 6.0, "n_lin_frac": 0.3}
    assert ROVStudy(vehicle="bluerov2_heavy", attitude_hold=False).config().feedback is None
    held = ROVStudy(vehicle="rexrov", attitude_hold=True, hold_gains=(9000.0, 7200.0)).config()
    assert held.feedback["law"] == "roll_pitch_hold" and held.feedback["kp"] == 9000.0
    with pytest.raises(ValueError, match="attitude hold"):
        ROVStudy(vehicle="rexrov", hold_gains=(1.0, 1.0)).config()


@pytest.mark.slow
def test_reproduce_fig7_and_the_sweep_file_agree_bit_for_bit(tmp_path, capsys):
    a, b = tmp_path / "reproduce.db", tmp_path / "sweep.db"
    args = ["--T", SHORT["T"], "--after", SHORT["after"], "--seeds", SHORT["seeds"]]
    out = tmp_path / "out"
    assert main(["reproduce", "fig7", *args, "--store", str(a), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    n_norms = len(load_config(EXAMPLE).norms)
    total = 2 * (1 + 11 * 2) * 5 * n_norms  # h x (noise-free + 11 pairs x 2 seeds) x ...
    assert "rexrov: open loop" in printed and f"{total} computed" in printed
    short = tmp_path / "sweep_fig7.toml"
    short.write_text(_shorten(EXAMPLE.read_text(), SHORT))
    assert main(["sweep", str(short), "--store", str(b), "--workers", "2"]) == 0
    ours, theirs = _cells(a), _cells(b)
    assert len(ours) == total and ours.keys() == theirs.keys()
    assert ours == theirs  # every number, bit for bit
    assert {r[3] for r in ours.values()} == {"ok"}
    # The CSV of reproduce holds the stored numbers.
    with (out / "fig7_runs.csv").open() as fh:
        runs = list(csv.DictReader(fh))
    assert len(runs) == 2 * (1 + 11 * 2) * 5
    stored = sorted(v[0] for v in ours.values())
    assert all(float(r["pos_l2_over_n"]) in set(stored) for r in runs)
    # and `sampledyn report` renders the store
    assert main(["report", str(a), "--out", str(tmp_path / "report")]) == 0
    capsys.readouterr()
    assert (tmp_path / "report" / "index.html").exists()


@pytest.mark.slow
@pytest.mark.skipif(sys.platform == "win32", reason="SIGKILL is POSIX")
def test_reproduce_fig7_store_resumes_after_sigkill(tmp_path, capsys):
    db = tmp_path / "fig7.db"
    args = ["reproduce", "fig7", "--T", "600", "--after", "100", "--seeds", "3"]
    args += ["--methods", "AB1,AB4,RK4", "--store", str(db), "--workers", "1"]
    total = 2 * (1 + 11 * 3) * 3 * len(load_config(EXAMPLE).norms)
    cmd = [sys.executable, "-m", "sampledyn.cli", *args, "--out", str(tmp_path / "a")]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    kill_when_stored(proc, db, 20)
    finished = _cells(db)
    assert 20 <= len(finished) < total, "the kill landed before or after the run"
    assert main([*args, "--out", str(tmp_path / "b")]) == 0
    printed = capsys.readouterr().out
    # The rerun computed only the rest and found the killed run's cells.
    assert f"{total - len(finished)} computed, {len(finished)} found stored" in printed
    after = _cells(db)
    assert len(after) == total and {k: after[k] for k in finished} == finished
    # Same numbers as a run that was never killed.
    assert main([*args[:-4], "--workers", "1", "--out", str(tmp_path / "c")]) == 0
    capsys.readouterr()
    for name in ("fig7_runs.csv", "fig7.csv"):
        assert (tmp_path / "b" / name).read_text() == (tmp_path / "c" / name).read_text()


@pytest.mark.parametrize("figure", ["fig2", "fig3"])
def test_fig2_fig3_numbers_are_those_of_the_code_before_the_engine(tmp_path, figure, capsys):
    """The CSV written by ``reproduce`` before the engine existed (commit 8d32ba0, same
    options, another machine): every AB, ABu, ABj, ABe, T, RK, E, Ee row, every column,
    to the tolerances of ``_numbers.auv_tolerance`` (names and flags exactly)."""
    args = ["--T", "30", "--after", "5", "--ratios", "1,2,10,50", "--out", str(tmp_path)]
    assert main(["reproduce", figure, *args]) == 0
    printed = capsys.readouterr().out
    before = read_rows(DATA / f"{figure}_pre_engine.csv")
    now = {(r["hold_ratio"], r["method"]): r for r in read_rows(tmp_path / f"{figure}.csv")}
    assert len(now) == len(before) > 0
    # the fixture's columns, in its row order
    new = [{k: now[(r["hold_ratio"], r["method"])][k] for k in r} for r in before]
    assert_rows_close(new, before, auv_tolerance, bounds=AUV_CERTIFICATE_BOUND,
                      label=lambda r: f"{r['method']} h_u/h={r['hold_ratio']}")  # fmt: skip
    # A masked norm without samples is explained, not a bare nan.
    assert "n/a (rms_away_from_jumps, h_u/h = 1, 2)" in printed
    assert " nan" not in printed


def test_one_simulation_serves_every_multiple_of_h(monkeypatch):
    import sampledyn.experiments.sweep._compute as compute

    calls = []
    real = compute.simulate

    def counted(*args, **kwargs):
        calls.append(kwargs["h"])
        return real(*args, **kwargs)

    monkeypatch.setattr(compute, "simulate", counted)
    cfg = replace(
        load_config(FIG7_STUDY_FILE), T=10.0, after=2.0, seeds=range(1), noise=((0.0, 0.0),)
    )
    result = run_study(cfg)
    assert calls == [0.1]  # h = 0.5 s is every fifth sample of the run at 0.1 s
    certs = {t["h"]: t["certificate"] for t in result.trajectories.values()}
    assert set(certs) == {0.1, 0.5} and max(certs.values()) < 1e-10
    assert all(t["summary"]["max_abs_pitch_deg"] > 0 for t in result.trajectories.values())


def test_closed_loop_rules_predict_with_the_plant_or_the_loop():
    """In a closed loop (BlueROV2 Heavy + roll-pitch hold) AB2 predicts with the plant
    and the applied rpm (what a log records), RK4 with the loop and the reference rpm
    between samples; the stored numbers are those of this hand computation."""
    cfg = replace(
        ROVStudy(vehicle="bluerov2_heavy").config(),
        T=20.0,
        after=5.0,
        h=(0.1,),
        methods=("AB2", "RK4"),
        noise=((2.0, 2.0),),
        seeds=(1,),
        norms=("rms",),
    )
    result = run_study(cfg)
    loop = plan_study(cfg).setup.model
    assert isinstance(loop, sd.models.AttitudeHold)
    sig = sd.signals.fig6_thrusters(loop.plant)
    exact = sd.simulate(loop, sig, T=20.0, h=0.1, rtol=cfg.rtol, atol=cfg.rtol)
    applied = loop.applied_input(exact.t, exact.x, exact.u)
    log = exact.replace(u=applied, input_names=loop.plant.input_names)
    measured = sd.add_noise(log, 2.0, 2.0, np.random.SeedSequence([0, 1]))
    by_method = {c["method"]: c for c in result.cells}
    ab = sd.local_errors(sd.predict("AB2", loop.plant, measured), measured)
    rk = sd.local_errors(sd.predict("RK4", loop, measured.replace(u=exact.u), signal=sig), measured)
    for name, err in (("AB2", ab), ("RK4", rk)):
        assert by_method[name]["err_eta"] == sd.error_norm(err, measured.t, "rms", 5.0, slice(0, 6))
        assert by_method[name]["err_v"] == sd.error_norm(err, measured.t, "rms", 5.0, slice(6, 12))
    # The other way round gives other numbers: the rule is what decides.
    wrong = sd.local_errors(sd.predict("AB2", loop, measured.replace(u=exact.u)), measured)
    assert by_method["AB2"]["err_v"] != sd.error_norm(wrong, measured.t, "rms", 5.0, slice(6, 12))


def test_norms_masks_and_units():
    from sampledyn.experiments.sweep._norms import parse_norm

    assert parse_norm("rms").text == "rms"
    spec = parse_norm("noise:max [rad] @ pitch_deg(35, 45)")
    assert spec.text == "noise:max[rad]@pitch_deg(35,45)" and spec.part == "noise"
    assert parse_norm("exceeds(0.1,2)").counts
    for bad, word in (
        ("l3", "unknown kind"),
        ("rms@nowhere", "unknown mask"),
        ("rms[kg]", "units"),
        ("exceeds(1)", "2 numbers"),
        ("max(1)", "no arguments"),
    ):
        with pytest.raises(ValueError, match=word):
            parse_norm(bad)


# -------------------------------------------------------------------------- advise
def test_advise_on_the_rexrov():
    rexrov = sd.models.load_vehicle("rexrov")
    adv = sd.advise(rexrov, 0.1, 2.0, 2.0, ("E", "AB2", "AB4", "RK4"), T=20.0, seeds=2,
                    samples=500, tolerance=0.2)  # fmt: skip
    assert adv.vehicle == "rexrov" and adv.jacobians is not None and not adv.notes
    for r in adv.rows:
        assert r.measured_eta <= r.bound_eta and r.measured_v <= r.bound_v  # bound holds
        assert math.isfinite(r.predicted_eta) and r.measured_rank is not None
        assert r.h_max_guaranteed is not None
    # The heavy vehicle's damping makes E as good as anything at 2 % noise.
    assert "E" in adv.near_best


def _remus():
    spec = importlib.util.spec_from_file_location("user_model", ROOT / "examples/user_model.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.remus


def test_advise_on_a_user_model_split_by_units():
    remus = _remus()
    sig = sd.signals.Sinusoidal(
        offset=[3.86, 0.0],
        amplitude=[[0.3, 0.0], [np.radians(3.0), np.radians(1.5)]],
        frequency_hz=[[0.05, 0.0], [0.02, 0.11]],
    )
    adv = sd.advise(remus, 0.1, 1.0, 1.0, ("E", "AB2", "RK4"), signal=sig, T=30.0, seeds=2)
    assert adv.domain is None and adv.jacobians is None
    assert any("no guaranteed bound" in n for n in adv.notes) and "n/a" in adv.table()
    for r in adv.rows:
        assert math.isnan(r.bound_eta) and r.h_max_guaranteed is None
        # first order in the noise, an upper estimate of the measured largest errors
        assert r.measured_eta <= r.predicted_eta and r.measured_v <= r.predicted_v
    with pytest.raises(ValueError, match="no default input"):
        sd.advise(remus, 0.1, 1.0, 1.0, ("E",), T=10.0, seeds=1)


def _cooling(t, x, u, p, out):
    out[0] = -x[0] + u[0]


def _cooling_jac(t, x, u, p, out):
    out[0, 0] = -1.0


def test_advise_refuses_models_it_cannot_split_and_layouts_without_a_default():
    temp = sd.models.FunctionModel(_cooling, 1, 1, _cooling_jac, state_units=("degC",))
    with pytest.raises(ValueError, match="state 0 has unit 'degC'"):
        sd.advise(temp, 0.1, 1.0, 1.0, ("E",))
    lag = sd.models.load_vehicle("bluerov2_heavy").with_params(thruster_lag=True)
    with pytest.raises(ValueError, match="thruster_lag"):
        sd.advise(lag, 0.1, 1.0, 1.0, ("E",))
    auv = sd.models.AUVLike()  # states m and m/s: advisable, but no thrusters
    with pytest.raises(ValueError, match="give the input"):
        sd.advise(auv, 0.1, 1.0, 1.0, ("E",))


@pytest.mark.slow
def test_cli_advise_takes_the_input(tmp_path, capsys):
    args = ["advise", "--vehicle", "rexrov", "--h", "0.1", "--T", "10", "--seeds", "1"]
    args += ["--methods", "E,AB2", "--out", str(tmp_path), "--no-validate"]
    assert main([*args, "--input", '{ name = "gentle", scale = 0.3 }']) == 0
    assert "rexrov: h = 0.1 s" in capsys.readouterr().out
    from sampledyn.cli._status import EXIT_BAD_VALUE

    with pytest.raises(SystemExit) as exc:
        main([*args, "--input", "chirp"])
    assert exc.value.code == EXIT_BAD_VALUE
    assert "--input" in capsys.readouterr().err


def test_warm_up_of_the_cells_runs_the_first_group_on_a_short_case(tmp_path, monkeypatch):
    """What a local pool compiles beside the first simulation: the chunk's first group,
    with the chunk's rules and norms, on 20 samples of the chunk's own period (taken from
    the simulation's period, as the real samples are), errors counted over the last 10
    (after every rule's history, as in a study: the one-pass norms, not the fallback).
    The samples are stand-ins, the input's with the state held at x0: nothing is
    simulated (on a first run the integrator is still compiling elsewhere)."""
    from sampledyn.experiments.sweep import _compute, _prediction

    study = plan_study(load_config(write_sweep(tmp_path / "s.toml", h="[0.01, 0.02]")))
    chunk = next(c for c in study.chunks(study.cells, 2) if c.h == 0.02)
    sim = study.sims[chunk.sim_key]
    assert sim.h == 0.01  # h = 0.02 takes every second sample of it
    seen = []
    simulated = []
    monkeypatch.setattr(_prediction, "compute_chunk", lambda *a: seen.append(a))
    monkeypatch.setattr(_compute, "exact_samples", lambda *a: simulated.append(a))
    study.setup.kind.warm_up_cells(study.setup, sim, chunk)
    assert simulated == []
    ((short, shared, part),) = seen
    assert short.after == pytest.approx(10 * 2 * 0.01) and short.T == pytest.approx(20 * 2 * 0.01)
    assert shared.traj.n_samples == 21 and np.allclose(np.diff(shared.traj.t), 0.02)
    assert shared.traj.on_uniform_grid  # the rules' fixed-step code, as on exact samples
    x0 = study.setup.model.default_x0 if study.setup.x0 is None else study.setup.x0
    np.testing.assert_array_equal(shared.traj.x, np.tile(x0, (21, 1)))
    signal = study.setup.signals[sim.input_index]
    np.testing.assert_array_equal(shared.traj.u, signal(shared.traj.t))
    assert part.groups == chunk.groups[:1] and part.traj_key == chunk.traj_key

    def fails(*_a):
        raise RuntimeError("not a cell's failure")

    monkeypatch.setattr(_prediction, "compute_chunk", fails)
    study.setup.kind.warm_up_cells(study.setup, sim, chunk)  # left to the cells to report
    monkeypatch.setattr(_prediction, "_stand_in", fails)
    study.setup.kind.warm_up_cells(study.setup, sim, chunk)  # so is a stand-in's failure
