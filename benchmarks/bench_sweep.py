"""Sweep benchmark: scaling from 1 to 2 worker processes, and the cost of the store.

Run:  python benchmarks/bench_sweep.py [--T 600] [--repeat 3] [--dask] [--json PATH]

A 1,000-cell sweep of the AUV-like system (eqs. (9)-(10)): 4 sampling periods x 50
measured trajectories (8 noise pairs, 7 seeds; the noise-free pair once) x 5 methods
(AB1-AB4, RK4). It runs with ``--workers 1`` and ``--workers 2`` into fresh stores
(best of ``--repeat``, interleaved), after a warm-up sweep in this process so that numba's
compilation is not timed (the workers fork from this process and inherit it).

Reported:
* speed-up of 2 workers over 1 (target >= 1.7 on a machine with >= 2 free cores);
* store overhead: the time the client spent claiming cells and writing the store,
  per cell, over the compute time of a cell on its worker (target < 5 %); and the same
  for a bare write of 1,000 rows in the batches the sweep uses;
* with ``--dask``: the same sweep on a Dask ``LocalCluster`` of 2 worker processes x 1
  thread started by ``sampledyn.experiments.sweep.local_cluster`` (without the nanny's
  ``MALLOC_TRIM_THRESHOLD_``), and, for comparison, on a plain ``LocalCluster`` with it,
  as ratios to ``--workers 2`` (interleaved, best of ``--repeat``).
"""

from __future__ import annotations

import argparse
import os
import sqlite3
import sys
import tempfile
import time
from pathlib import Path

from _rows import row, write_json

from sampledyn.experiments.sweep import local_cluster, run_sweep
from sampledyn.experiments.sweep._run import SweepSummary
from sampledyn.experiments.sweep._store import ResultStore

CONFIG = """\
vehicle = "auv_like"
input = {{ name = "multilevel", hold = 0.1, seed = 0 }}
x0 = [1.0, 0.0]
T = {T}
after = {after}
h = [0.005, 0.01, 0.02, 0.05]
methods = ["AB1", "AB2", "AB3", "AB4", "RK4"]
eta_pct = [0, 2, 10, 20]
v_pct = [0, 10]
seeds = 7
norm = "rms"
"""


def _rows(db: Path) -> dict[str, tuple[float, float, float]]:
    with sqlite3.connect(db) as conn:
        return {r[0]: r[1:] for r in conn.execute("SELECT key, err_eta, err_v, err_all FROM cells")}


def _timed(cfg: Path, folder: Path, repeat: int) -> dict[int, tuple[float, SweepSummary, Path]]:
    """Best of ``repeat`` runs for 1 and 2 workers, interleaved (1, 2, 1, 2, ...) so a
    change of the machine's load hits both alike."""
    best: dict[int, tuple[float, SweepSummary, Path]] = {}
    for i in range(repeat):
        for workers in (1, 2):
            db = folder / f"w{workers}_{i}.db"
            load = os.getloadavg()[0]
            s = run_sweep(cfg, db, workers=workers)
            print(
                f"  run {i + 1}, {workers} worker(s): {s.wall_seconds:6.2f} s "
                f"(load average before: {load:.2f})",
                flush=True,
            )
            if workers not in best or s.wall_seconds < best[workers][0]:
                best[workers] = (s.wall_seconds, s, db)
    return best


def _dask_ratios(cfg: Path, folder: Path, repeat: int) -> dict[str, float]:
    """Best wall time of the sweep on two Dask clusters over ``--workers 2``."""
    import dask
    from distributed import LocalCluster

    kw = {"host": "127.0.0.1", "dashboard_address": None}
    plain_env = {"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": 65536}
    with (
        local_cluster(2, **kw) as ours,
        dask.config.set(plain_env),
        LocalCluster(n_workers=2, threads_per_worker=1, **kw) as plain,
    ):
        best: dict[str, float] = {}
        for i in range(repeat):
            for name, where in (
                ("workers", {"workers": 2}),
                ("local_cluster", {"scheduler": ours.scheduler_address}),
                ("plain LocalCluster", {"scheduler": plain.scheduler_address}),
            ):
                s = run_sweep(cfg, folder / f"d_{name}_{i}.db", **where)
                print(f"  run {i + 1}, {name}: {s.wall_seconds:6.2f} s", flush=True)
                best[name] = min(best.get(name, float("inf")), s.wall_seconds)
    return {k: v / best["workers"] for k, v in best.items() if k != "workers"}


def _bare_store_cost(folder: Path, cells_per_batch: int) -> float:
    """Seconds per cell to write 1,000 cells in batches of ``cells_per_batch``."""
    record = {
        "key": "",
        "run_id": "r",
        "computed_at": 0.0,
        "status": "ok",
        "version": "0",
        "vehicle": "auv_like",
        "h": 0.01,
        "method": "AB4",
        "err_eta": 1e-3,
        "err_v": 1e-3,
        "err_all": 1e-3,
        "seconds": 0.01,
        "config": "{" + "x" * 300 + "}",
    }
    with ResultStore(folder / "bare.db") as st:
        t0 = time.perf_counter()
        for b in range(0, 1000, cells_per_batch):
            st.write([{**record, "key": f"{b}-{i}"} for i in range(cells_per_batch)])
        return (time.perf_counter() - t0) / 1000


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--T", type=float, default=600.0, help="duration of each run (s)")
    ap.add_argument("--repeat", type=int, default=3, help="runs per worker count (best taken)")
    ap.add_argument("--dask", action="store_true", help="also compare Dask LocalClusters")
    ap.add_argument("--json", help="write the issue 14 rows here")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        cfg = folder / "bench.toml"
        cfg.write_text(CONFIG.format(T=args.T, after=args.T / 10))
        warm = folder / "warm.toml"
        warm.write_text(CONFIG.format(T=1.0, after=0.1))
        run_sweep(warm, folder / "warm.db")  # compile here, not in the timed runs

        best = _timed(cfg, folder, args.repeat)
        (t1, s1, db1), (t2, s2, db2) = best[1], best[2]
        assert s1.planned == 1000 and s1.computed == s2.computed == 1000, (s1, s2)
        same = _rows(db1) == _rows(db2)
        speedup = t1 / t2
        per_cell_compute = s1.compute_seconds / s1.computed
        overhead_run = max(s1.store_overhead, s2.store_overhead)
        per_write = _bare_store_cost(folder, cells_per_batch=5 * 2)
        overhead_bare = per_write / per_cell_compute
        ratios = _dask_ratios(cfg, folder, args.repeat) if args.dask else {}

    print(f"machine: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}")
    print(f"sweep: 1000 cells, T = {args.T:g} s, h in (0.005, 0.01, 0.02, 0.05) s")
    print(
        f"  1 worker : {t1:7.2f} s  (cells {s1.compute_seconds:.2f} s of compute, exact "
        f"samples {s1.simulate_seconds:.2f} s, store {s1.store_seconds:.3f} s)"
    )
    print(
        f"  2 workers: {t2:7.2f} s  (cells {s2.compute_seconds:.2f} s of compute, exact "
        f"samples {s2.simulate_seconds:.2f} s, store {s2.store_seconds:.3f} s)"
    )
    print(f"  rows of the two runs identical: {same}")
    print(f"speed-up 2 workers / 1 worker: {speedup:.2f}x  (target >= 1.7x)")
    print(
        f"store overhead per cell, in the runs: {100 * overhead_run:.3f} % of a cell's compute "
        f"({1e3 * per_cell_compute:.2f} ms)  (target < 5 %)"
    )
    print(
        f"store overhead per cell, bare writes: {1e6 * per_write:.1f} us = "
        f"{100 * overhead_bare:.3f} % of a cell's compute"
    )
    for name, ratio in ratios.items():
        print(f"Dask {name} (2 x 1 thread) / --workers 2: {ratio:.2f}x  (target <= 1.15x)")
    rows = [
        row("sweep, 2 workers / 1 worker (1,000 cells)", speedup, f"{speedup:.2f}x speed-up",
            ">= 1.7x with 2 free cores", None, rows_identical=same),
    ]  # fmt: skip
    if "local_cluster" in ratios:
        r = ratios["local_cluster"]
        rows.insert(0, row(
            "Dask LocalCluster (2 x 1 thread) / `--workers 2`, same 1,000-cell sweep", r,
            f"{r:.2f}x", "<= 1.15x", r <= 1.15,
            plain_local_cluster=ratios.get("plain LocalCluster"),
        ))  # fmt: skip
    write_json(args.json, "bench_sweep", rows, rows_identical=same)
    ok = same and speedup >= 1.7 and overhead_run < 0.05
    print("PASS" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
