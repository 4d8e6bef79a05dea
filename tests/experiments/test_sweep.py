"""Sweeps: the grid file, cell keys, the results store and resuming."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

import numpy as np
import pytest
from _sweep_helpers import rows, write_sweep

import sampledyn as sd
import sampledyn._version
from sampledyn.cli import main
from sampledyn.cli._status import EXIT_FILE
from sampledyn.exceptions import SweepConfigError
from sampledyn.experiments.sweep import load_config, run_sweep
from sampledyn.experiments.sweep._compute import compute_chunk, simulate_trajectory
from sampledyn.experiments.sweep._plan import plan_study


def test_grid_counts_cells_and_runs_noise_free_pair_once(tmp_path):
    cfg = load_config(write_sweep(tmp_path / "s.toml", seeds=3))
    study = plan_study(cfg)
    # per h: (0,0) with 1 seed + 3 noisy pairs x 3 seeds = 10 groups, x 4 methods
    assert len(study.cells) == 2 * 10 * 4
    assert len({c.key for c in study.cells}) == len(study.cells)
    assert len(study.trajectories) == 2
    assert {c.seed for c in study.cells if (c.eta_pct, c.v_pct) == (0, 0)} == {0}


@pytest.mark.parametrize(
    ("change", "key"),
    [
        ({"h": "[0.03]"}, "h"),  # does not divide T
        ({"norm": '"l3"'}, "norm"),
        ({"methods": '["AB0"]'}, "methods"),
        ({"after": 30.0}, "after"),
        ({"eta": "[-1]"}, "eta_pct"),
        ({"seeds": 0}, "seeds"),
    ],
)
def test_bad_grid_entries_are_named(tmp_path, change, key):
    with pytest.raises(SweepConfigError) as exc:
        load_config(write_sweep(tmp_path / "s.toml", **change))
    assert exc.value.key == key
    assert f"`{key}`" in str(exc.value)


def test_a_rule_that_does_not_predict_is_refused_by_the_prediction_grid(tmp_path):
    """ZOH is registered (a discrete-time system), but a prediction cell needs a
    predictor: the grid refuses it, naming `methods` once and the reason."""
    with pytest.raises(SweepConfigError) as exc:
        load_config(write_sweep(tmp_path / "s.toml", methods='["AB2", "ZOH"]'))
    assert exc.value.key == "methods"
    message = str(exc.value)
    assert "'ZOH' does not predict on sampled data" in message
    assert message.count("`methods`") == 1 and "`method`" not in message


def test_unknown_key_and_unknown_input_are_named(tmp_path):
    p = write_sweep(tmp_path / "s.toml")
    p.write_text(p.read_text() + "sead = 3\n")
    with pytest.raises(SweepConfigError, match="unknown key `sead`"):
        load_config(p)
    p.write_text(
        p.read_text().replace('name = "multilevel"', 'name = "chirp"').replace("sead = 3\n", "")
    )
    with pytest.raises(SweepConfigError, match="unknown input 'chirp'.*fig6.*multilevel"):
        load_config(p)


def test_keys_change_with_version_norm_and_input(tmp_path, monkeypatch):
    base = {c.key for c in plan_study(load_config(write_sweep(tmp_path / "a.toml"))).cells}
    other_norm = plan_study(load_config(write_sweep(tmp_path / "b.toml", norm='"max"')))
    assert base.isdisjoint(c.key for c in other_norm.cells)
    p = write_sweep(tmp_path / "c.toml")
    p.write_text(p.read_text().replace("seed = 3", "seed = 4"))  # another input realisation
    assert base.isdisjoint(c.key for c in plan_study(load_config(p)).cells)
    monkeypatch.setattr(sampledyn._version, "__version__", "999.0")
    new_version = plan_study(load_config(write_sweep(tmp_path / "d.toml")))
    assert base.isdisjoint(c.key for c in new_version.cells)
    assert json.loads(new_version.cells[0].config)["version"] == "999.0"


def test_cell_values_match_the_library_pipeline(tmp_path):
    """A stored number is what predict + local_errors + error_norm give by hand."""
    cfg = load_config(write_sweep(tmp_path / "s.toml", h="[0.02]", methods='["AB2", "RK4"]'))
    study = plan_study(cfg)
    cell = next(c for c in study.cells if c.method == "RK4" and c.eta_pct == 2 and c.v_pct == 5)
    sim = simulate_trajectory(study.setup, study.sim_of(cell.traj_key))[cell.traj_key]
    [chunk] = [c for c in study.chunks([cell], 1)]
    [row] = compute_chunk(study.setup, sim, chunk).rows
    model, signal = study.setup.model, study.setup.signal
    traj = sd.simulate(model, signal, T=cfg.T, h=0.02, x0=cfg.x0)
    measured = sd.add_noise(traj, 2.0, 5.0, np.random.SeedSequence([0, cell.seed]))
    err = sd.local_errors(sd.predict("RK4", model, measured, signal), measured)
    assert row["values"]["err_eta"] == sd.error_norm(err, measured.t, "rms", cfg.after, [0])
    assert row["values"]["err_v"] == sd.error_norm(err, measured.t, "rms", cfg.after, [1])


def test_rerun_computes_nothing_and_a_bigger_grid_only_the_new_cells(tmp_path):
    db = tmp_path / "r.db"
    first = run_sweep(write_sweep(tmp_path / "s.toml"), db)
    assert first.computed == first.planned == 2 * 7 * 4 and first.failed == 0
    before = rows(db, "key, run_id, computed_at, err_eta")
    again = run_sweep(write_sweep(tmp_path / "s.toml"), db)
    assert (again.computed, again.skipped) == (0, first.planned)
    more = run_sweep(
        write_sweep(tmp_path / "s.toml", methods='["AB1", "AB2", "AB3", "AB4", "RK4"]'), db
    )
    assert more.computed == 2 * 7 * 1 and more.skipped == first.planned
    after = rows(db, "key, run_id, computed_at, err_eta")
    assert {k: after[k] for k in before} == before  # old rows untouched
    df = sd.results.load(db)
    assert len(df) == len(after) == 70 and df["key"].is_unique
    assert set(df["method"]) == {"AB1", "AB2", "AB3", "AB4", "RK4"}
    assert str(df["computed_at"].dtype).startswith("datetime64")
    runs = sd.results.load(db, "runs")
    assert list(runs["status"]) == ["complete", "complete"]  # the no-op rerun adds no run
    with sqlite3.connect(db) as conn:
        assert conn.execute("PRAGMA journal_mode").fetchone()[0] == "wal"


def test_failed_cells_are_stored_with_their_error_and_retried_on_request(tmp_path):
    """AB6 has no prediction in a window of 2 samples: an error row, not a crash; a
    rerun keeps it unless retry_failed."""
    p = write_sweep(tmp_path / "s.toml", T=0.5, after=0.4, h="[0.1]", methods='["AB1", "AB6"]')
    db = tmp_path / "r.db"
    s = run_sweep(p, db)
    assert (s.computed, s.failed) == (14, 7)
    bad = sd.results.load(db, status="error")
    assert set(bad["method"]) == {"AB6"} and bad["error"].str.contains("no samples").all()
    assert bad["err_eta"].isna().all()
    assert run_sweep(p, db).computed == 0
    assert run_sweep(p, db, retry_failed=True).computed == 7
    assert sd.results.load(db)["key"].is_unique


def test_failed_exact_samples_fail_their_cells_only(tmp_path, monkeypatch):
    import sampledyn.experiments.sweep._compute as compute
    from sampledyn.exceptions import IntegrationError

    real = compute.simulate

    def flaky(model, signal, T, h, **kw):
        if h == 0.01:
            raise IntegrationError("step size underflow at t = 1.23 s")
        return real(model, signal, T=T, h=h, **kw)

    monkeypatch.setattr(compute, "simulate", flaky)
    db = tmp_path / "r.db"
    # 0.025 s is no multiple of 0.01 s: simulated on its own; 0.02 s is taken from 0.01 s.
    s = run_sweep(write_sweep(tmp_path / "s.toml", h="[0.01, 0.02, 0.025]"), db)
    assert (s.computed, s.failed) == (84, 56)
    df = sd.results.load(db)
    bad = df[df["status"] == "error"]
    assert set(bad["h"]) == {0.01, 0.02} and bad["error"].str.contains("underflow").all()
    assert (df.loc[df["h"] == 0.025, "status"] == "ok").all()


def test_multiples_of_h_are_subsampled_from_one_simulation(tmp_path):
    """h = 0.02 s is every second sample of the run at 0.01 s (one simulation), and
    its cells equal those computed on that subsample by hand."""
    cfg = load_config(write_sweep(tmp_path / "s.toml", h="[0.02, 0.01]", methods='["AB2"]'))
    study = plan_study(cfg)
    assert len(study.trajectories) == 2 and len(study.sims) == 1
    [sim] = study.sims.values()
    assert sim.h == 0.01 and [(h, k) for _key, h, k in sim.members] == [(0.01, 1), (0.02, 2)]
    bundle = simulate_trajectory(study.setup, sim)
    fine = sd.simulate(study.setup.model, study.setup.signal, T=cfg.T, h=0.01, x0=cfg.x0)
    coarse = bundle[sim.members[1][0]].traj
    np.testing.assert_array_equal(coarse.x, fine.x[::2])
    assert coarse.h == pytest.approx(0.02)
    assert bundle[sim.members[1][0]].meta["certificate"] == pytest.approx(
        fine.subsample(2).certificate.max_error, rel=1e-12
    )


def test_fig6_rov_cells_run_with_short_T(tmp_path):
    p = tmp_path / "rov.toml"
    p.write_text(
        'vehicle = "bluerov2_heavy"\nbuoyancy_pct = 1.0\ninput = "fig6"\nT = 2.0\nafter = 0.5\n'
        'h = [0.1]\norders = [1, 4]\nnoise = [[0, 0], [2, 2]]\nseeds = 2\nnorm = "l2_over_n"\n'
    )
    db = tmp_path / "r.db"
    s = run_sweep(p, db)
    assert (s.computed, s.failed) == (6, 0)
    df = sd.results.load(db)
    assert (df["err_eta"] > 0).all() and (df["err_v"] > 0).all()
    assert set(df["order"]) == {1, 4}
    traj = sd.results.load(db, "trajectories")
    assert len(traj) == 1 and traj["certificate"].iloc[0] < 1e-8


def test_cli_sweep_and_results_exports(tmp_path, capsys):
    cfg = write_sweep(tmp_path / "s.toml", h="[0.02]")
    db = tmp_path / "r.db"
    assert main(["sweep", str(cfg), "--store", str(db), "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "28 cells" in out and "28 computed" in out
    assert main(["sweep", str(cfg), "--store", str(db), "--no-progress"]) == 0
    assert "28 already stored, 0 computed" in capsys.readouterr().out
    assert main(["results", str(db), "--format", "csv", "--out", str(tmp_path / "r.csv")]) == 0
    assert main(["results", str(db), "--format", "parquet", "--out", str(tmp_path / "r.pq")]) == 0
    import pandas as pd

    # round_trip: the parser that reads back the written digits exactly (pandas < 2.2's
    # default one may not), so the CSV is compared with the Parquet bit for bit
    a = pd.read_csv(tmp_path / "r.csv", float_precision="round_trip")
    b = pd.read_parquet(tmp_path / "r.pq")
    assert len(a) == len(b) == 28
    assert np.array_equal(
        a.sort_values("key")["err_v"].to_numpy(), b.sort_values("key")["err_v"].to_numpy()
    )
    capsys.readouterr()
    assert main(["results", str(db), "--format", "table"]) == 0
    assert "AB4" in capsys.readouterr().out
    with pytest.raises(SystemExit) as exc:
        main(["results", str(tmp_path / "none.db")])
    assert exc.value.code == EXIT_FILE and "none.db" in capsys.readouterr().err
    assert not (tmp_path / "none.db").exists()


def test_vehicle_file_keys_follow_its_content_not_its_folder(tmp_path):
    builtin = Path(sd.models.__file__).parent / "vehicles" / "bluerov2_heavy.toml"
    text = builtin.read_text()
    keys = []
    for folder, body in (
        ("a", text),
        ("b", text),
        ("c", text.replace("value = 13.5", "value = 14.0")),
    ):
        d = tmp_path / folder
        d.mkdir()
        (d / "my_rov.toml").write_text(body)
        (d / "s.toml").write_text(
            'vehicle = "my_rov.toml"\ninput = "fig6"\nT = 1.0\nafter = 0.5\nh = [0.1]\n'
            'methods = ["AB1"]\nseeds = 1\n'
        )
        study = plan_study(load_config(d / "s.toml"))
        assert json.loads(study.cells[0].config)["vehicle"] == "my_rov.toml"
        keys.append({c.key for c in study.cells})
    assert keys[0] == keys[1]  # moved: same cells
    assert keys[0].isdisjoint(keys[2])  # another mass: other cells
