"""``sampledyn reproduce fig7`` end to end: wall and CPU time in fresh processes, its f
floor, the first run after a fresh install, and where the time goes.

Run:  python benchmarks/bench_fig7.py [--runs 3] [--no-first-run] [--compare DIR]
      [--baseline DIR] [--also-bluerov2] [--in-process] [--json PATH]

The command is run as a user runs it, with its defaults (the RexROV open loop,
T = 5000 s, 10 seeds, 6,660 cells, 2 local worker processes). Rows (issues 14 and 23):

* **wall** and **CPU**: ``--runs`` timed runs of ``python -m sampledyn.cli -q reproduce
  fig7`` in fresh processes after one untimed run that fills the caches ("warm cache":
  numba's kernel cache and Python's bytecode cache; this benchmark lets Python write its
  bytecode even where ``PYTHONDONTWRITEBYTECODE`` is set), with the load average before
  each. CPU is that of every process of the run (the command and its workers, from
  ``getrusage(RUSAGE_CHILDREN)``). The wall row is judged only on a quiet machine (load
  average below 1); the ratios hold better under load.
* **f floor**: the study's f evaluations times the cost of one f of a straight-line
  reference kernel written and timed in this run (``bench_kernels.py``). The count is
  from the study file: every trajectory (the noise-free one and 11 noisy pairs x 10
  seeds, at each h) needs f at its N samples (shared by AB1-AB4 and RK4's first stage)
  and RK4's three other stages on its N - 1 intervals: 26.6 M. (Issue 23 counted RK4's
  first stage again, 33.3 M; that ratio is printed too.)
* **cores used**: wall / (CPU / 2).
* **first run**: the same command with empty kernel caches (``SAMPLEDYN_CACHE_DIR`` and
  ``NUMBA_CACHE_DIR`` in fresh folders: every kernel compiled), stderr a pipe; when the
  compile notice came and the whole run.
* **phases**: one more run with time stamps (the same command, inside this script):
  start-up (interpreter, imports, options, plan), pool start (kernels loaded, workers
  forked), the exact samples on a worker, the cells on the two workers (CPU seconds
  per worker), collecting the results, and the output (summary, CSVs, figure, tables).
* ``--compare DIR``: the CSVs written must equal those in DIR byte for byte (e.g. the
  output of the main branch): a speed-up must not change a number.
* ``--baseline DIR``: the same command from another checkout (e.g. ``git archive`` of
  main), timed interleaved with this one (same load).
* ``--in-process``: the engine in this process, chunks as two workers get them: CPU
  seconds in f, simulate, predict (f excluded), norms, noise, the rest.
"""

from __future__ import annotations

import argparse
import filecmp
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path
from typing import Any

from _rows import row, write_json

REPO = Path(__file__).resolve().parents[1]
STUDY_FILE = REPO / "sampledyn" / "experiments" / "studies" / "fig7.toml"
WALL_TARGET_S = 4.5  # issue 23, quiet machine
FLOOR_TARGET = 3.0
CORES_TARGET = 1.15
FIRST_TARGET_S = 10.0
QUIET_LOAD = 1.0


def _env(checkout: Path = REPO) -> dict[str, str]:
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # warm cache: keep the bytecode
    env["PYTHONPATH"] = str(checkout)
    return env


def _command(out: Path, extra: list[str]) -> list[str]:
    return [sys.executable, "-m", "sampledyn.cli", "-q", "reproduce", "fig7", "--out", str(out),
            *extra]  # fmt: skip


def _timed(cmd: list[str], env: dict[str, str], cwd: Path) -> tuple[float, float]:
    """(wall s, CPU s of the command and every process it waited for) of one run."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, env=env, check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL, cwd=cwd)  # fmt: skip
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def wall_runs(
    runs: int, variants: dict[str, tuple[Path, list[str]]], tmp: Path
) -> dict[str, list[tuple]]:
    """(wall s, CPU s, load before) of each timed run, variants (checkout, extra
    options) interleaved."""
    for name, (checkout, extra) in variants.items():  # fill the caches, untimed
        subprocess.run(_command(tmp / f"warm_{name}", extra), env=_env(checkout), check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=tmp)  # fmt: skip
    times: dict[str, list[tuple]] = {name: [] for name in variants}
    for i in range(runs):
        for name, (checkout, extra) in variants.items():
            load = os.getloadavg()[0]
            wall, cpu = _timed(_command(tmp / f"{name}_{i}", extra), _env(checkout), tmp)
            times[name].append((wall, cpu, load))
            print(f"  run {i + 1} {name}: {wall:.2f} s wall, {cpu:.2f} s CPU (load {load:.2f})",
                  flush=True)  # fmt: skip
    return times


def first_run(tmp: Path) -> tuple[float, float | None, float, float]:
    """The command with empty kernel caches, stderr a pipe: (wall s, seconds to the
    compile notice or None, CPU s, load before)."""
    env = _env() | {"SAMPLEDYN_CACHE_DIR": str(tmp / "fresh_kernels"),
                    "NUMBA_CACHE_DIR": str(tmp / "fresh_numba")}  # fmt: skip
    cmd = [sys.executable, "-m", "sampledyn.cli", "reproduce", "fig7", "--out",
           str(tmp / "fresh_out"), "--no-progress"]  # fmt: skip
    load = os.getloadavg()[0]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True, cwd=tmp)  # fmt: skip
    said = None
    assert proc.stderr is not None
    for line in proc.stderr:
        if said is None and "compiling the numerical kernels" in line:
            said = time.perf_counter() - t0
    proc.wait()
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if proc.returncode != 0:
        raise RuntimeError(f"the first run failed (exit {proc.returncode})")
    return wall, said, cpu, load


def f_evaluations(path: Path = STUDY_FILE) -> tuple[int, int]:
    """(f evaluations of the study as the engine makes them, as issue 23 counted them):
    per trajectory f at its N samples (the AB rules' and RK4's first stage, shared) and
    RK4's other three stages on the N - 1 intervals; the issue counted 5 per sample."""
    cfg = tomllib.loads(path.read_text())
    noisy = sum(1 for pair in cfg["noise"] if any(pair))
    trajectories = 1 + noisy * int(cfg["seeds"])
    engine = issue = 0
    for h in cfg["h"]:
        n = round(float(cfg["T"]) / float(h)) + 1
        engine += trajectories * (n + 3 * (n - 1))
        issue += trajectories * 5 * n
    return engine, issue


# ------------------------------------------------------------------ the timed phases


def _child_timeline(argv: list[str]) -> None:
    """Inside the timeline run: install the time stamps, run the CLI, write them."""
    t_zero = float(os.environ["BENCH_T0"])
    log = Path(os.environ["BENCH_LOG"])
    marks: dict[str, float] = {}
    cpu: dict[str, float] = {}

    def mark(name: str) -> None:
        marks.setdefault(name, time.time() - t_zero)
        cpu.setdefault(name, time.process_time())

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
    import sampledyn.report._fig7 as fig7_report

    # (looked up by name when the thread starts; its CPU is the thread's own; a
    # checkout from before it, --baseline, has none)
    real_prepare = getattr(fig7_report, "prepare_fig7_report", None)

    def prepare() -> None:
        assert real_prepare is not None
        w0, c0 = time.time() - t_zero, time.thread_time()
        real_prepare()
        with log.open("a") as fh:
            fh.write(json.dumps(["main", "prepare", w0, time.time() - t_zero,
                                 time.thread_time() - c0]) + "\n")  # fmt: skip

    if real_prepare is not None:
        fig7_report.prepare_fig7_report = prepare
    real_start = run_mod.start_pool

    def start_pool(*a: Any, **k: Any) -> Any:
        mark("plan done")
        pool = real_start(*a, **k)
        mark("pool started")
        return pool

    run_mod.start_pool = start_pool
    real_study = run_mod.run_study  # the studies import it from there when they run

    def run_rov_study(*a: Any, **k: Any) -> Any:
        out = real_study(*a, **k)
        mark("engine done")
        return out

    run_mod.run_study = run_rov_study
    mark("imports done")
    from sampledyn.cli import main

    c0 = time.process_time()
    main(argv)
    mark("done")
    marks["main process CPU"] = time.process_time() - c0
    with log.open("a") as fh:
        fh.write(json.dumps(["marks", marks]) + "\n")
        fh.write(json.dumps(["cpu", cpu]) + "\n")
        fh.write(json.dumps(["main_pid", os.getpid()]) + "\n")


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
    cpu: dict[str, float] = {}
    tasks = []
    main_pid = None
    for line in log.read_text().splitlines():
        item = json.loads(line)
        if item[0] == "marks":
            marks = item[1]
        elif item[0] == "cpu":
            cpu = item[1]
        elif item[0] == "main_pid":
            main_pid = item[1]
        else:
            tasks.append(item)
    prepared = [t for t in tasks if t[1] == "prepare"]
    # (a first run compiles the cells' kernels in the main process, on stand-in samples,
    # while the integrator compiles aside: a phase of its own, not the workers' tasks)
    in_main = [t for t in tasks if t[0] == main_pid and t[1] == "cells"]
    tasks = [t for t in tasks if t[0] != main_pid]
    sims = [t for t in tasks if t[1] == "simulate"]
    cells = [t for t in tasks if t[1] == "cells"]
    workers = sorted({t[0] for t in cells})
    return {
        "marks": marks,
        "simulate": (min(t[2] for t in sims), max(t[3] for t in sims), sum(t[4] for t in sims)),
        "cells": (min(t[2] for t in cells), max(t[3] for t in cells)),
        "cells_cpu": {w: sum(t[4] for t in cells if t[0] == w) for w in workers},
        "chunks": len(cells),
        "main_cpu": cpu,
        "prepare": tuple(prepared[0][2:]) if prepared else None,
        "cells_in_main": tuple(in_main[0][2:]) if in_main else None,
    }


def phase_table(tl: dict[str, Any]) -> list[str]:
    """The phases of the timeline run; the main process's CPU seconds from one time
    stamp to the next where they are known (its threads included)."""
    m = tl["marks"]
    sim0, sim1, sim_cpu = tl["simulate"]
    c0, c1 = tl["cells"]
    cpu = tl["cells_cpu"]
    mc = tl.get("main_cpu") or {}

    def main_cpu(a: str, b: str) -> str:
        return f"main {mc[b] - mc[a]:.2f} s CPU" if a in mc and b in mc else ""

    rows = [
        ("start-up: interpreter, imports, options, plan", 0.0, m["plan done"],
         f"main {mc['plan done']:.2f} s CPU" if "plan done" in mc else ""),
        ("pool: kernels loaded, 2 workers forked", m["plan done"], m["pool started"],
         main_cpu("plan done", "pool started")),
        ("exact samples (one worker; certified)", sim0, sim1, f"{sim_cpu:.2f} s CPU"),
        (f"cells ({tl['chunks']} tasks on {len(cpu)} workers)", c0, c1,
         " + ".join(f"{v:.2f}" for v in cpu.values()) + " s CPU"),
        ("results collected", c1, m["engine done"],
         main_cpu("pool started", "engine done") + " (since the pool started)"
         if mc else ""),
        ("output: summary, CSVs, figure, tables", m["engine done"], m["done"],
         main_cpu("engine done", "done")),
    ]  # fmt: skip
    if tl.get("prepare") is not None:
        p0, p1, p_cpu = tl["prepare"]
        rows.insert(4, ("report prepared ahead (a thread of the main process)", p0, p1,
                        f"{p_cpu:.2f} s CPU"))  # fmt: skip
    if tl.get("cells_in_main") is not None:
        w0, w1, w_cpu = tl["cells_in_main"]
        name = "cells' kernels compiled in the main process (stand-in samples; integrator aside)"
        rows.insert(2, (name, w0, w1, f"{w_cpu:.2f} s CPU"))
    lines = ["| phase | from (s) | to (s) | wall (s) | CPU |", "|---|---|---|---|---|"]
    for name, a, b, note in rows:
        lines.append(f"| {name} | {a:.2f} | {b:.2f} | {b - a:.2f} | {note} |")
    lines.append(
        f"| total (main process {m['main process CPU']:.2f} s CPU) | 0.00 | {m['done']:.2f} | "
        f"{m['done']:.2f} | |"
    )
    return lines


# ------------------------------------------------------------- one process, by function


def in_process() -> None:
    """CPU seconds by function with the engine in this process, chunks as two workers
    get them (f inside predict counted as f)."""
    import sampledyn.experiments.sweep._compute as compute
    import sampledyn.experiments.sweep._run as run_mod
    import sampledyn.models._vehicle as vehicle
    from sampledyn.experiments._studies import get_study
    from sampledyn.experiments.sweep._plan import plan_study
    from sampledyn.experiments.sweep._run import run_study

    phases = dict.fromkeys(("f", "simulate", "predict (f excluded)", "norms", "noise"), 0.0)

    inside: set[str] = set()  # phases being timed (a nested call counts once)

    def timed(owner: Any, name: str, phase: str) -> None:
        real = getattr(owner, name)

        def wrapper(*args: Any, **kwargs: Any) -> Any:
            if phase in inside:
                return real(*args, **kwargs)
            inside.add(phase)
            t0 = time.process_time()
            try:
                return real(*args, **kwargs)
            finally:
                phases[phase] += time.process_time() - t0
                inside.discard(phase)

        setattr(owner, name, wrapper)

    timed(vehicle.Vehicle, "f", "f")
    timed(compute, "exact_samples", "simulate")
    timed(compute, "predict", "predict (f excluded)")
    timed(compute, "_errors", "predict (f excluded)")  # an Adams rule's f and weights
    timed(compute, "measure", "norms")
    timed(compute, "add_noise", "noise")
    definition = get_study("fig7").load()
    config = definition.configs(definition.settings())[0]
    study = plan_study(config)
    chunk = run_mod._groups_per_chunk(study.groups_per_trajectory, 2)
    run_study(config, groups_per_chunk=chunk)  # kernels loaded, caches warm
    for k in phases:
        phases[k] = 0.0
    c0 = time.process_time()
    run_study(config, groups_per_chunk=chunk)
    total = time.process_time() - c0
    phases["predict (f excluded)"] -= phases["f"]
    print(f"\nOne process, {study.n_cells} cells, {chunk} groups per chunk: CPU seconds")
    print("| phase | CPU (s) | share |\n|---|---|---|")
    rest = total - sum(phases.values())
    for name, sec in [*phases.items(), ("local errors, bookkeeping", rest), ("total", total)]:
        print(f"| {name} | {sec:.2f} | {100 * sec / total:.0f} % |")


def _variants(args: argparse.Namespace) -> dict[str, tuple[Path, list[str]]]:
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
    return variants


def _study_rows(got: list[tuple], ref_ns: float) -> list[dict]:
    """The rows of the warm runs of the default study: CPU / floor, cores used, wall."""
    walls, cpus, loads = zip(*got, strict=True)
    best = min(range(len(walls)), key=lambda i: walls[i])
    wall, cpu, load = walls[best], cpus[best], loads[best]
    engine, issue = f_evaluations()
    floor = engine * ref_ns * 1e-9
    ratio = min(cpus) / floor
    cores = wall / (cpu / 2.0)
    quiet = max(loads) < QUIET_LOAD
    print(f"f floor: {engine / 1e6:.1f} M f x {ref_ns:.1f} ns = {floor:.2f} s CPU (as the issue "
          f"counts, {issue / 1e6:.1f} M: {issue * ref_ns * 1e-9:.2f} s)")  # fmt: skip
    return [
        row("`reproduce fig7` CPU seconds (all processes) / its f floor "
            f"({engine / 1e6:.1f} M f x the reference)", ratio,
            f"{ratio:.1f}x ({min(cpus):.1f} s / {floor:.2f} s; issue's count "
            f"{min(cpus) / (issue * ref_ns * 1e-9):.1f}x)", f"<= {FLOOR_TARGET:g}x",
            ratio <= FLOOR_TARGET, load=[min(loads), max(loads)]),
        row("`reproduce fig7`, 2 workers, warm cache: wall / (CPU / 2)", cores,
            f"{cores:.2f} ({wall:.1f} s wall, {cpu:.1f} s CPU)", f"<= {CORES_TARGET:g}",
            cores <= CORES_TARGET, load=[min(loads), max(loads)]),
        row("`reproduce fig7`, 10 seeds, 2 workers, warm cache, fresh process: wall", wall,
            f"{wall:.1f} s (median {statistics.median(walls):.1f}; load {load:.2f})",
            f"<= {WALL_TARGET_S:g} s on a quiet machine (load < {QUIET_LOAD:g})",
            (wall <= WALL_TARGET_S) if quiet else None, load=[min(loads), max(loads)]),
    ]  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--runs", type=int, default=3, help="timed fresh-process runs")
    ap.add_argument("--no-first-run", action="store_true", help="skip the fresh-install run")
    ap.add_argument("--also-bluerov2", action="store_true",
                    help="also time the BlueROV2 Heavy + hold, interleaved")  # fmt: skip
    ap.add_argument("--compare", type=Path, help="folder whose fig7*.csv must be equal")
    ap.add_argument("--baseline", type=Path,
                    help="another checkout (e.g. main), timed interleaved")  # fmt: skip
    ap.add_argument("--in-process", action="store_true", help="also the one-process table")
    ap.add_argument("--json", help="write the table row here")
    ap.add_argument("--child-timeline", action="store_true", help=argparse.SUPPRESS)
    args, rest = ap.parse_known_args()
    if args.child_timeline:
        _child_timeline([a for a in rest if a != "--"])
        return
    from bench_kernels import fig7_model, reference_cost

    variants = _variants(args)
    with tempfile.TemporaryDirectory() as tmpname:
        tmp = Path(tmpname)
        print("reproduce fig7 (defaults: RexROV open loop, 10 seeds, 2 workers), fresh processes")
        times = wall_runs(args.runs, variants, tmp)
        ref_ns = reference_cost(fig7_model()) * 1e9
        print(f"reference kernel: {ref_ns:.1f} ns per f (load {os.getloadavg()[0]:.2f})")
        same = None
        if args.compare is not None:
            same = all(
                filecmp.cmp(tmp / f"rexrov_{i}" / f, args.compare / f, shallow=False)
                for i in range(args.runs)
                for f in ("fig7.csv", "fig7_runs.csv")
            )
        tl = timeline(tmp, [])
        first = None if args.no_first_run else first_run(tmp)
    rows = []
    for name, got in times.items():
        walls = [w for w, _, _ in got]
        loads = [ld for _, _, ld in got]
        print(f"{name}: min {min(walls):.2f} s, median {statistics.median(walls):.2f} s over "
              f"{len(walls)} runs (load average {min(loads):.2f}-{max(loads):.2f})")  # fmt: skip
        if name == "rexrov":
            rows += _study_rows(got, ref_ns)
        else:
            rows.append(row(f"`reproduce fig7`: {name}", min(walls), f"{min(walls):.1f} s", "",
                            None))  # fmt: skip
    if first is not None:
        wall, said, cpu, load = first
        told = "no notice" if said is None else f"compile notice after {said:.1f} s"
        print(f"first run, empty kernel caches: {wall:.1f} s wall, {cpu:.1f} s CPU, {told} "
              f"(load {load:.2f})")  # fmt: skip
        rows.append(row(
            "first `reproduce fig7` after a fresh install (every kernel compiled), wall",
            wall, f"{wall:.1f} s ({told}; load {load:.2f})",
            f"<= {FIRST_TARGET_S:g} s on a quiet machine", (wall <= FIRST_TARGET_S)
            if load < QUIET_LOAD else None, load=[load, load], notice_s=said,
        ))  # fmt: skip
    if same is not None:
        print(f"CSVs equal to {args.compare}: {same}")
        rows.append(row("fig7 CSVs equal to the reference's, byte for byte", None,
                        "yes" if same else "NO", "yes", same))  # fmt: skip
    print("\nPhases of one more run (time stamps from the start of the process):")
    lines = phase_table(tl)
    print("\n".join(lines))
    write_json(args.json, "bench_fig7", rows, phases=lines)
    if args.in_process:
        in_process()


if __name__ == "__main__":
    main()
