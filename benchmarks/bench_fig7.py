"""``sampledyn reproduce fig7`` end to end: wall time in a fresh process, and where it goes.

Run:  python benchmarks/bench_fig7.py [--runs 3] [--compare DIR] [--baseline DIR]
      [--also-bluerov2] [--in-process] [--json PATH]

Issue 14's row "``reproduce fig7``, 10 seeds, warm cache, fresh process" (target <= 6 s
on a quiet machine). The command is run as a user runs it, with its defaults (the
RexROV open loop, T = 5000 s, 10 seeds, 6,660 cells, 2 local worker processes):

* **wall**: ``--runs`` timed runs of ``python -m sampledyn.cli -q reproduce fig7`` in
  fresh processes after one untimed run that fills the caches ("warm cache": numba's
  kernel cache and Python's bytecode cache; this benchmark lets Python write its
  bytecode even where ``PYTHONDONTWRITEBYTECODE`` is set); the minimum and the median,
  with the load average before each run. With ``--also-bluerov2`` the BlueROV2 Heavy +
  hold runs interleaved with it (the old default).
* **phases**: one more run with time stamps (the same command, inside this script):
  start-up (interpreter, imports, options, plan), pool start (kernels loaded, workers
  forked), the exact samples on a worker, the cells on the two workers (CPU seconds
  per worker), collecting the results, and the output (summary, CSVs, figure, tables).
* ``--compare DIR``: the CSVs written must equal those in DIR byte for byte (e.g. the
  output of the main branch): a speed-up must not change a number.
* ``--baseline DIR``: the same command from another checkout (e.g. ``git archive`` of
  main), timed interleaved with this one (same load).
* ``--in-process``: the older one-process table (the engine in this process, chunks as
  two workers get them): CPU seconds in simulate, predict, norms, store, the rest.
"""

from __future__ import annotations

import argparse
import filecmp
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from _rows import row, write_json

REPO = Path(__file__).resolve().parents[1]
TARGET_S = 6.0


def _env(checkout: Path = REPO) -> dict[str, str]:
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # warm cache: keep the bytecode
    env["PYTHONPATH"] = str(checkout)
    return env


def _command(out: Path, extra: list[str]) -> list[str]:
    return [sys.executable, "-m", "sampledyn.cli", "-q", "reproduce", "fig7", "--out", str(out),
            *extra]  # fmt: skip


def wall_runs(
    runs: int, variants: dict[str, tuple[Path, list[str]]], tmp: Path
) -> dict[str, list[tuple]]:
    """(seconds, load before) of each timed run, variants (checkout, extra options)
    interleaved."""
    for name, (checkout, extra) in variants.items():  # fill the caches, untimed
        subprocess.run(_command(tmp / f"warm_{name}", extra), env=_env(checkout), check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=tmp)  # fmt: skip
    times: dict[str, list[tuple]] = {name: [] for name in variants}
    for i in range(runs):
        for name, (checkout, extra) in variants.items():
            load = os.getloadavg()[0]
            t0 = time.perf_counter()
            subprocess.run(_command(tmp / f"{name}_{i}", extra), env=_env(checkout), check=True,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                           cwd=tmp)  # fmt: skip
            times[name].append((time.perf_counter() - t0, load))
            print(f"  run {i + 1} {name}: {times[name][-1][0]:.2f} s (load {load:.2f})",
                  flush=True)  # fmt: skip
    return times


# ------------------------------------------------------------------ the timed phases


def _child_timeline(argv: list[str]) -> None:
    """Inside the timeline run: install the time stamps, run the CLI, write them."""
    t_zero = float(os.environ["BENCH_T0"])
    log = Path(os.environ["BENCH_LOG"])
    marks: dict[str, float] = {}

    def mark(name: str) -> None:
        marks.setdefault(name, time.time() - t_zero)

    import sampledyn.experiments._rov as experiments
    import sampledyn.experiments.sweep._compute as compute
    import sampledyn.experiments.sweep._prediction as prediction
    import sampledyn.experiments.sweep._run as run_mod

    def logged(fn: Any, label: str) -> Any:
        def wrapper(*a: Any, **k: Any) -> Any:
            w0, c0 = time.time() - t_zero, time.process_time()
            out = fn(*a, **k)
            with log.open("a") as fh:
                fh.write(json.dumps([os.getpid(), label, w0, time.time() - t_zero,
                                     time.process_time() - c0]) + "\n")  # fmt: skip
            return out

        wrapper.__qualname__ = fn.__qualname__  # pickled by name to the workers
        wrapper.__module__ = fn.__module__
        return wrapper

    compute.simulate_trajectory = logged(compute.simulate_trajectory, "simulate")
    compute.compute_chunk = logged(compute.compute_chunk, "cells")
    prediction.simulate_trajectory = compute.simulate_trajectory  # the cell kind calls them
    prediction.compute_chunk = compute.compute_chunk
    real_start = run_mod.start_pool

    def start_pool(*a: Any, **k: Any) -> Any:
        mark("plan done")
        pool = real_start(*a, **k)
        mark("pool started")
        return pool

    run_mod.start_pool = start_pool
    real_study = experiments.run_rov_study

    def run_rov_study(*a: Any, **k: Any) -> Any:
        out = real_study(*a, **k)
        mark("engine done")
        return out

    experiments.run_rov_study = run_rov_study
    mark("imports done")
    from sampledyn.cli import main

    c0 = time.process_time()
    main(argv)
    mark("done")
    marks["main process CPU"] = time.process_time() - c0
    with log.open("a") as fh:
        fh.write(json.dumps(["marks", marks]) + "\n")


def timeline(tmp: Path, extra: list[str]) -> dict[str, Any]:
    """One run with time stamps; the phase table's numbers."""
    log = tmp / "timeline.jsonl"
    env = _env() | {"BENCH_LOG": str(log)}
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), str(Path(__file__).parent)])
    env["BENCH_T0"] = repr(time.time())
    done = subprocess.run(
        [sys.executable, __file__, "--child-timeline", "--", "-q", "reproduce", "fig7",
         "--out", str(tmp / "timeline"), *extra],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    if done.returncode != 0:
        raise RuntimeError(f"the timeline run failed:\n{done.stderr}")
    marks: dict[str, float] = {}
    tasks = []
    for line in log.read_text().splitlines():
        item = json.loads(line)
        if item[0] == "marks":
            marks = item[1]
        else:
            tasks.append(item)
    sims = [t for t in tasks if t[1] == "simulate"]
    cells = [t for t in tasks if t[1] == "cells"]
    workers = sorted({t[0] for t in cells})
    return {
        "marks": marks,
        "simulate": (min(t[2] for t in sims), max(t[3] for t in sims), sum(t[4] for t in sims)),
        "cells": (min(t[2] for t in cells), max(t[3] for t in cells)),
        "cells_cpu": {w: sum(t[4] for t in cells if t[0] == w) for w in workers},
        "chunks": len(cells),
    }


def phase_table(tl: dict[str, Any]) -> list[str]:
    m = tl["marks"]
    sim0, sim1, sim_cpu = tl["simulate"]
    c0, c1 = tl["cells"]
    cpu = tl["cells_cpu"]
    rows = [
        ("start-up: interpreter, imports, options, plan", 0.0, m["plan done"], ""),
        ("pool: kernels loaded, 2 workers forked", m["plan done"], m["pool started"], ""),
        ("exact samples (one worker; certified)", sim0, sim1, f"{sim_cpu:.2f} s CPU"),
        (f"cells ({tl['chunks']} tasks on {len(cpu)} workers)", c0, c1,
         " + ".join(f"{v:.2f}" for v in cpu.values()) + " s CPU"),
        ("results collected", c1, m["engine done"], ""),
        ("output: summary, CSVs, figure, tables", m["engine done"], m["done"], ""),
    ]  # fmt: skip
    lines = ["| phase | from (s) | to (s) | wall (s) | CPU |", "|---|---|---|---|---|"]
    for name, a, b, note in rows:
        lines.append(f"| {name} | {a:.2f} | {b:.2f} | {b - a:.2f} | {note} |")
    lines.append(
        f"| total (main process {m['main process CPU']:.2f} s CPU) | 0.00 | {m['done']:.2f} | "
        f"{m['done']:.2f} | |"
    )
    return lines


# ------------------------------------------------------------- one process, by function


def in_process(seeds: int) -> None:
    """CPU seconds by function in this process (chunks as two workers get them)."""
    import sampledyn.experiments.sweep._compute as compute
    import sampledyn.experiments.sweep._store as store
    from sampledyn.experiments import ROVStudy
    from sampledyn.experiments.sweep._plan import plan_study
    from sampledyn.experiments.sweep._run import _groups_per_chunk, run_study

    phases = {"simulate": 0.0, "predict": 0.0, "norms": 0.0, "noise": 0.0, "store": 0.0}

    def timed(owner: Any, name: str, phase: str) -> None:
        real = getattr(owner, name)

        def wrapper(*args: Any, **kwargs: Any) -> Any:
            t0 = time.process_time()
            try:
                return real(*args, **kwargs)
            finally:
                phases[phase] += time.process_time() - t0

        setattr(owner, name, wrapper)

    timed(compute, "exact_samples", "simulate")
    timed(compute, "predict", "predict")
    timed(compute, "measure", "norms")
    timed(compute, "add_noise", "noise")
    timed(store.ResultStore, "write", "store")
    config = ROVStudy(seeds=seeds).config()
    study = plan_study(config)
    chunk = _groups_per_chunk(study.groups_per_trajectory, 2)
    run_study(ROVStudy(T=20.0, after=5.0, seeds=1).config())  # load the kernels
    for k in phases:
        phases[k] = 0.0
    c0 = time.process_time()
    run_study(config, groups_per_chunk=chunk)
    total = time.process_time() - c0
    print(f"\nOne process, {study.n_cells} cells, {chunk} groups per chunk: CPU seconds")
    print("| phase | CPU (s) | share |\n|---|---|---|")
    rest = total - sum(phases.values())
    for name, sec in [*phases.items(), ("local errors, bookkeeping", rest), ("total", total)]:
        print(f"| {name} | {sec:.2f} | {100 * sec / total:.0f} % |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--runs", type=int, default=3, help="timed fresh-process runs")
    ap.add_argument("--also-bluerov2", action="store_true",
                    help="also time the BlueROV2 Heavy + hold, interleaved")  # fmt: skip
    ap.add_argument("--compare", type=Path, help="folder whose fig7*.csv must be equal")
    ap.add_argument("--baseline", type=Path,
                    help="another checkout (e.g. main), timed interleaved")  # fmt: skip
    ap.add_argument("--in-process", action="store_true", help="also the one-process table")
    ap.add_argument("--seeds", type=int, default=10, help="seeds (--in-process only)")
    ap.add_argument("--json", help="write the table row here")
    ap.add_argument("--child-timeline", action="store_true", help=argparse.SUPPRESS)
    args, rest = ap.parse_known_args()
    if args.child_timeline:
        _child_timeline([a for a in rest if a != "--"])
        return
    variants: dict[str, tuple[Path, list[str]]] = {"rexrov": (REPO, [])}
    if args.also_bluerov2:
        variants["bluerov2_heavy + hold"] = (REPO, ["--vehicle", "bluerov2_heavy"])
    if args.baseline is not None:
        variants["rexrov, baseline"] = (args.baseline.resolve(), [])
        if args.also_bluerov2:
            variants["bluerov2_heavy + hold, baseline"] = (
                args.baseline.resolve(),
                ["--vehicle", "bluerov2_heavy"],
            )
    with tempfile.TemporaryDirectory() as tmpname:
        tmp = Path(tmpname)
        print("reproduce fig7 (defaults: RexROV open loop, 10 seeds, 2 workers), fresh processes")
        times = wall_runs(args.runs, variants, tmp)
        same = None
        if args.compare is not None:
            same = all(
                filecmp.cmp(tmp / f"rexrov_{i}" / f, args.compare / f, shallow=False)
                for i in range(args.runs)
                for f in ("fig7.csv", "fig7_runs.csv")
            )
        tl = timeline(tmp, [])
    rows = []
    for name, got in times.items():
        secs = [s for s, _ in got]
        loads = [ld for _, ld in got]
        print(
            f"{name}: min {min(secs):.2f} s, median {statistics.median(secs):.2f} s over "
            f"{len(secs)} runs (load average {min(loads):.2f}-{max(loads):.2f})"
        )
        if name == "rexrov":
            rows.append(row(
                "`reproduce fig7`, 10 seeds, warm cache, fresh process (RexROV, 2 workers)",
                min(secs), f"{min(secs):.1f} s (median {statistics.median(secs):.1f})",
                f"<= {TARGET_S:g} s on a quiet machine", min(secs) <= TARGET_S,
                load=[min(loads), max(loads)],
            ))  # fmt: skip
        else:
            rows.append(row(f"`reproduce fig7`: {name}", min(secs), f"{min(secs):.1f} s", "",
                            None))  # fmt: skip
    if same is not None:
        print(f"CSVs equal to {args.compare}: {same}")
        rows.append(row("fig7 CSVs equal to the reference's, byte for byte", None,
                        "yes" if same else "NO", "yes", same))  # fmt: skip
    print("\nPhases of one more run (time stamps from the start of the process):")
    lines = phase_table(tl)
    print("\n".join(lines))
    write_json(args.json, "bench_fig7", rows, phases=lines)
    if args.in_process:
        in_process(args.seeds)


if __name__ == "__main__":
    main()
