"""What a run lets its caller overlap with the cells: ``on_start`` (called once the
workers compute), and the keys of the planned cells listed once (``run_study``
returns the cells in plan order without listing the grid again)."""

from __future__ import annotations

from _sweep_helpers import write_sweep

from sampledyn.experiments.sweep import load_config, run_sweep
from sampledyn.experiments.sweep._plan import plan_study
from sampledyn.experiments.sweep._run import run_study


def test_on_start_is_called_once_when_cells_are_computed_and_not_when_none_are(tmp_path):
    db = tmp_path / "r.db"
    calls: list[int] = []
    first = run_sweep(write_sweep(tmp_path / "s.toml"), db, on_start=lambda: calls.append(1))
    assert first.computed == first.planned > 0 and calls == [1]
    again = run_sweep(write_sweep(tmp_path / "s.toml"), db, on_start=lambda: calls.append(2))
    assert again.computed == 0 and calls == [1]  # nothing to compute: nothing to overlap


def test_on_start_runs_after_the_local_workers_forked(tmp_path, monkeypatch):
    """A thread started by ``on_start`` is not copied into a worker: the workers have
    forked (and computed nothing yet) when it is called."""
    import sampledyn.experiments.sweep._run as run_mod

    seen = {}
    real = run_mod.start_pool

    def start_pool(*args, **kwargs):
        pool = real(*args, **kwargs)
        seen["pool"] = True
        return pool

    monkeypatch.setattr(run_mod, "start_pool", start_pool)

    def on_start():
        seen["started with a pool"] = seen.get("pool", False)

    summary = run_sweep(write_sweep(tmp_path / "s.toml"), None, workers=2, on_start=on_start)
    assert summary.computed == summary.planned and seen["started with a pool"]


def test_run_study_returns_the_cells_in_plan_order_from_parallel_workers(tmp_path):
    cfg = load_config(write_sweep(tmp_path / "s.toml", seeds=3))
    result = run_study(cfg, workers=2, groups_per_chunk=1)
    planned = [c.key for c in plan_study(cfg).iter_cells()]
    assert [c["key"] for c in result.cells] == planned
    stored = run_study(cfg, tmp_path / "r.db", workers=2, groups_per_chunk=1)
    assert [c["key"] for c in stored.cells] == planned
    again = run_study(cfg, tmp_path / "r.db")  # nothing to compute: read in plan order
    assert [c["key"] for c in again.cells] == planned and again.summary.computed == 0
