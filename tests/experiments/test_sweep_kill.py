"""Kill a real sweep with SIGKILL mid-run, then rerun it: nothing finished is lost or
recomputed, nothing is corrupted, and the result equals an uninterrupted run."""

from __future__ import annotations

import sqlite3
import subprocess
import sys

import pytest
from _sweep_helpers import kill_when_stored, rows, write_sweep

from sampledyn.experiments.sweep import load_config, run_sweep
from sampledyn.experiments.sweep._plan import plan_study

pytestmark = pytest.mark.slow  # a real process, SIGKILLed

# 92 groups of 5 methods, each about 10 ms: a few seconds of work.
HEAVY = {
    "T": 150.0,
    "after": 20.0,
    "h": "[0.005, 0.01]",
    "methods": '["AB1", "AB2", "AB3", "AB4", "RK4"]',
    "eta": "[0, 1, 2, 5]",
    "v": "[0, 1, 2, 5]",
    "seeds": 3,
}
COLUMNS = "key, run_id, computed_at, err_eta, err_v, err_all, status"


@pytest.mark.skipif(sys.platform == "win32", reason="SIGKILL is POSIX")
def test_sigkill_mid_sweep_then_rerun_resumes(tmp_path):
    cfg = write_sweep(tmp_path / "s.toml", **HEAVY)
    total = len(plan_study(load_config(cfg)).cells)
    db = tmp_path / "r.db"
    cmd = [
        sys.executable,
        "-m",
        "sampledyn.cli",
        "sweep",
        str(cfg),
        "--store",
        str(db),
        "--no-progress",
    ]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    kill_when_stored(proc, db, 10, timeout=120)

    with sqlite3.connect(db) as conn:
        assert conn.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
        [(run_status,)] = conn.execute("SELECT status FROM runs").fetchall()
    assert run_status == "running"  # killed: never marked complete
    finished = rows(db, COLUMNS)
    assert 10 <= len(finished) < total, "kill landed before/after the run; tune HEAVY"
    assert {r[-1] for r in finished.values()} == {"ok"}

    resumed = run_sweep(cfg, db)
    assert resumed.skipped == len(finished)
    assert resumed.computed == total - len(finished)
    after = rows(db, COLUMNS)
    assert len(after) == total  # every cell once (key is the primary key)
    assert {k: after[k] for k in finished} == finished  # same run id, time and numbers
    assert {after[k][0] for k in set(after) - set(finished)} == {resumed.run_id}

    clean = tmp_path / "clean.db"
    run_sweep(cfg, clean)
    values = "key, err_eta, err_v, err_all"
    assert rows(db, values) == rows(clean, values)
