"""Real ``sampledyn sweep`` processes under faults: the workers of a killed parent die
with it; SIGTERM and Ctrl-C stop a run like an interruption (finished cells kept, run
marked "interrupted", workers gone, exit status 143 / 130); two sweeps on one store
split the cells and report truthfully."""

from __future__ import annotations

import os
import signal
import sys

import pytest
from _faults import (
    SLOW_GRID_CELLS,
    children,
    error_lines,
    kill_all,
    query,
    start,
    still_alive,
    wait_for_cells,
    wait_for_children,
    write_grid,
)

from sampledyn.cli._status import EXIT_INTERRUPTED, EXIT_TERMINATED

pytestmark = [
    pytest.mark.slow,  # real processes, signals and kills
    pytest.mark.skipif(
        not sys.platform.startswith("linux"), reason="process trees are read from /proc"
    ),
]


def _sweep(tmp_path, *extra):
    cfg = write_grid(tmp_path / "grid.toml", T=300.0)
    db = tmp_path / "r.db"
    return db, start("sweep", str(cfg), "--store", str(db), "--no-progress", *extra)


def test_workers_die_with_a_parent_killed_by_sigkill(tmp_path):
    db, proc = _sweep(tmp_path, "--workers", "2")
    workers: list[int] = []
    try:
        workers = wait_for_children(proc.pid, 2, timeout=120)
        wait_for_cells(db, 10, proc, timeout=120)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
        left = still_alive(workers, timeout=10)
        assert left == [], f"workers {left} outlived their killed parent"
    finally:
        kill_all([proc.pid, *workers])
        proc.communicate()
    # The killed run never finished; a rerun takes over its claims at once (its
    # process is gone) and completes the grid.
    assert query(db, "SELECT status FROM runs") == [("running",)]
    rerun = start(
        "sweep", str(tmp_path / "grid.toml"), "--store", str(db), "--no-progress", "--workers", "2"
    )
    out, err = rerun.communicate(timeout=300)
    assert rerun.returncode == 0, err
    assert query(db, "SELECT COUNT(DISTINCT key), COUNT(*) FROM cells") == [
        (SLOW_GRID_CELLS, SLOW_GRID_CELLS)
    ]
    assert sorted(r[0] for r in query(db, "SELECT status FROM runs")) == ["abandoned", "complete"]
    assert query(db, "SELECT COUNT(*) FROM claims") == [(0,)]


@pytest.mark.parametrize(
    ("sig", "status", "word"),
    [(signal.SIGTERM, EXIT_TERMINATED, "terminated"), (signal.SIGINT, EXIT_INTERRUPTED, "Ctrl-C")],
)
def test_sigterm_and_ctrl_c_interrupt_the_run_and_stop_the_workers(tmp_path, sig, status, word):
    db, proc = _sweep(tmp_path, "--workers", "2")
    workers: list[int] = []
    try:
        workers = wait_for_children(proc.pid, 2, timeout=120)
        kept = wait_for_cells(db, 10, proc, timeout=120)
        if sig == signal.SIGINT:
            os.killpg(proc.pid, sig)  # a terminal's Ctrl-C reaches the whole group
        else:
            os.kill(proc.pid, sig)
        out, err = proc.communicate(timeout=60)
        left = still_alive(workers, timeout=10)
    finally:
        kill_all([proc.pid, *workers])
    assert proc.returncode == status
    # one line, besides the compile notice of a run that compiled (cli._main)
    lines = error_lines(err)
    assert len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith("sampledyn: error: ") and word in lines[0]
    assert str(db) in lines[0]  # where the finished cells are
    assert left == [] and children(proc.pid) == []
    [(run_status, computed)] = query(db, "SELECT status, computed FROM runs")
    assert run_status == "interrupted"
    stored = query(db, "SELECT COUNT(*) FROM cells")[0][0]
    assert stored >= kept and computed == stored  # every finished cell kept and counted
    assert query(db, "SELECT COUNT(*) FROM claims") == [(0,)]


def test_two_concurrent_sweeps_split_the_grid_and_report_truthfully(tmp_path):
    cfg = write_grid(tmp_path / "grid.toml", T=600.0)  # long enough to overlap
    db = tmp_path / "shared.db"
    procs = [start("sweep", str(cfg), "--store", str(db), "--no-progress") for _ in range(2)]
    outs = [p.communicate(timeout=600) for p in procs]
    for p, (_, err) in zip(procs, outs, strict=True):
        assert p.returncode == 0, err
    keys, rows = query(db, "SELECT COUNT(DISTINCT key), COUNT(*) FROM cells")[0]
    assert keys == rows == SLOW_GRID_CELLS
    runs = query(db, "SELECT run_id, planned, skipped, elsewhere, computed, duplicates FROM runs")
    assert len(runs) == 2
    by_run = dict(query(db, "SELECT run_id, COUNT(*) FROM cells GROUP BY run_id"))
    for run_id, planned, skipped, elsewhere, computed, duplicates in runs:
        assert planned == SLOW_GRID_CELLS
        # each cell of the grid is accounted for exactly once by each run ...
        assert skipped + elsewhere + computed + duplicates == planned
        # ... and a run's "computed" is what it stored
        assert computed == by_run.get(run_id, 0)
    computed = [r[4] for r in runs]
    assert sum(computed) == SLOW_GRID_CELLS  # nothing computed twice
    assert min(computed) > 0  # the work was split
    for out, _ in outs:
        assert "being computed by other runs" in out
