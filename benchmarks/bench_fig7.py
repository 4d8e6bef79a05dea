"""Where the time of ``reproduce fig7`` goes: simulate, predict, norms, store, figure.

Run:  python benchmarks/bench_fig7.py [--T 5000] [--seeds 10] [--vehicle rexrov]

The Fig. 7 study runs in this process on the experiment engine (one worker, so every
phase is timed where it runs), with a results store in a temporary folder; the time
spent in the engine's simulation, in the rules' predictions, in the norms and in the
store is summed by wrapping those functions, the figure and the CSV are timed around
their calls. The rest (noise, planning, keys, bookkeeping) is the remainder of the
wall time. Noisy on a shared machine: compare phases within one run.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path
from typing import Any

import sampledyn.experiments.sweep._compute as compute
import sampledyn.experiments.sweep._store as store
from sampledyn.experiments import ROVStudy, run_rov_study, summarize_rov
from sampledyn.report import plot_fig7, write_csv

PHASES: dict[str, float] = {"simulate": 0.0, "predict": 0.0, "norms": 0.0, "store": 0.0}


def _timed(owner: Any, name: str, phase: str) -> None:
    real = getattr(owner, name)

    def wrapper(*args: Any, **kwargs: Any) -> Any:
        t0 = time.perf_counter()
        try:
            return real(*args, **kwargs)
        finally:
            PHASES[phase] += time.perf_counter() - t0

    setattr(owner, name, wrapper)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--T", type=float, default=5000.0)
    ap.add_argument("--after", type=float, default=1000.0)
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--vehicle", default="rexrov")
    args = ap.parse_args()
    _timed(compute, "exact_samples", "simulate")
    _timed(compute, "predict", "predict")
    _timed(compute, "measure", "norms")
    _timed(store.ResultStore, "write", "store")
    _timed(store.ResultStore, "claim", "store")
    study = ROVStudy(vehicle=args.vehicle, T=args.T, after=args.after, seeds=args.seeds)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        result = run_rov_study(study, store=Path(tmp) / "fig7.db", workers=1)
        t_engine = time.perf_counter() - t0
        t1 = time.perf_counter()
        summary = summarize_rov(result["rows"])
        write_csv(result["rows"], Path(tmp) / "fig7_runs.csv")
        write_csv(summary, Path(tmp) / "fig7.csv")
        t_csv = time.perf_counter() - t1
        t2 = time.perf_counter()
        plot_fig7(summary, Path(tmp) / "fig7.png", title="bench")
        t_fig = time.perf_counter() - t2
    total = t_engine + t_csv + t_fig
    rest = t_engine - sum(PHASES.values())
    print(
        f"reproduce fig7 phases: {result['model']}, T = {args.T:g} s, {args.seeds} seeds, "
        f"{result['summary'].planned} cells, one process"
    )
    print("| phase | seconds | share |")
    print("|---|---|---|")
    rows = [*PHASES.items(), ("noise, keys, bookkeeping", rest), ("summary + CSV", t_csv)]
    rows.append(("figure", t_fig))
    for name, sec in rows:
        print(f"| {name} | {sec:.2f} | {100 * sec / total:.0f} % |")
    print(f"| total | {total:.2f} | 100 % |")


if __name__ == "__main__":
    main()
