"""Every row of the performance tables of issues 14 and 23, measured now: one command,
one table.

Run:  python benchmarks/run_all.py [--quick] [--only NAME ...] [--baseline DIR] [--out FILE]

Runs each benchmark of this folder in its own process (one after the other, never two
at a time), collects the rows they write with ``--json``, and prints one Markdown table:
measure, now, target, met / not met, with the load average (1 min) before and after
each benchmark, the date and the commands. Every ratio in it is of two timings taken in
the same run of one benchmark (interleaved repeats, minima), so a uniformly slow
machine changes few of them; a loaded one (load average above the number of cores)
still does: run it on a quiet machine, and read the load column.

* ``--quick`` shortens the slow benchmarks (peer table at T = 500 s, memory at
  T = 5,000 s, sweep T = 120 s, one fig7 run and no fresh-install run): a smoke run,
  not the table's settings (each row says its own size).
* ``--only NAME ...``: only these benchmarks (names as in ``BENCHES``).
* ``--baseline DIR``: also time the fixed costs of another checkout (e.g. a
  ``git archive`` of main) for a before/after line.
* ``--out FILE``: write the Markdown there too.

Benchmarks (the issue's rows they measure):

``fixed_costs``   ``python -c "import sampledyn"`` and the first real call,
                  ``python -c "import sampledyn as sd; sd.simulate"`` (fresh processes,
                  warm caches, best of 7 interleaved)
``kernels``       ``bench_kernels.py``: the vehicle's f against a straight-line reference
                  kernel written in the same run (model.f, inside the integrator, the
                  RK stages)
``fig7``          ``bench_fig7.py``: ``reproduce fig7`` wall and CPU time, its f floor,
                  cores used, the first run after a fresh install, the phases
``methods``       ``bench_methods.py --fig7-only``: T / AB4, RK4 / 4 f, AB4 M/s, AB4 / E
``models``        ``bench_models.py``: f from Python (single state, batch of one), the
                  closed-loop Jacobian
``rov``           ``bench_rov.py``: simulate with certificate / without
``discretize``    ``bench_discretize.py``: AB4 rollout, one f per sample
``memory``        ``bench_memory.py``: peak RSS / returned arrays, T = 50,000 s, h = 0.01 s
``log_memory``    ``bench_log_memory.py``: peak RSS / arrays kept, a 10-million-row CSV log
``sweep``         ``bench_sweep.py --dask``: Dask LocalCluster / ``--workers 2``
``peers``         ``bench_peers.py``: exact samples against the best peer at equal accuracy
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent

BENCHES: dict[str, tuple[list[str], list[str]]] = {
    # name: (arguments, arguments with --quick)
    "kernels": (["bench_kernels.py"], ["bench_kernels.py", "--rounds", "5"]),
    "fig7": (["bench_fig7.py", "--runs", "3"], ["bench_fig7.py", "--runs", "1", "--no-first-run"]),
    "methods": (["bench_methods.py", "--fig7-only"], ["bench_methods.py", "--fig7-only"]),
    "models": (["bench_models.py"], ["bench_models.py"]),
    "rov": (["bench_rov.py"], ["bench_rov.py", "--rounds", "2"]),
    "discretize": (["bench_discretize.py"], ["bench_discretize.py"]),
    "memory": (["bench_memory.py"], ["bench_memory.py", "--T", "5000"]),
    "log_memory": (["bench_log_memory.py"], ["bench_log_memory.py", "--rows", "1000000"]),
    "sweep": (
        ["bench_sweep.py", "--dask"],
        ["bench_sweep.py", "--dask", "--T", "120", "--repeat", "1"],
    ),  # fmt: skip
    "peers": (
        ["bench_peers.py"],
        ["bench_peers.py", "--T", "500", "--T-calibrate", "100", "--repeat", "2"],
    ),  # fmt: skip
}
IMPORT_TARGET_S = 0.6


def _env(path: Path) -> dict[str, str]:
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # warm cache: Python keeps the bytecode
    env["PYTHONPATH"] = str(path)
    return env


def fixed_costs(checkouts: dict[str, Path], repeat: int = 7) -> dict[str, dict[str, float]]:
    """Best wall time (s) of the two one-liners in fresh processes, per checkout."""
    lines = {
        "import": "import sampledyn",
        "first simulate": "import sampledyn as sd; sd.simulate",
    }
    best = {name: dict.fromkeys(lines, float("inf")) for name in checkouts}
    for r in range(repeat + 1):  # the first round fills the caches
        for name, path in checkouts.items():
            for what, code in lines.items():
                t0 = time.perf_counter()
                subprocess.run([sys.executable, "-c", code], env=_env(path), check=True,
                               cwd=tempfile.gettempdir())  # fmt: skip
                if r:
                    best[name][what] = min(best[name][what], time.perf_counter() - t0)
    return best


def fixed_cost_rows(times: dict[str, dict[str, float]]) -> list[dict]:
    now = times["now"]
    base = times.get("baseline")

    def shown(what: str) -> str:
        before = "" if base is None else f" (baseline {base[what]:.2f} s)"
        return f"{now[what]:.2f} s{before}"

    return [
        {
            "measure": '`python -c "import sampledyn"` (cache warm)',
            "value": now["import"],
            "shown": shown("import"),
            "target": f"<= {IMPORT_TARGET_S:g} s",
            "met": now["import"] <= IMPORT_TARGET_S,
        },
        {
            "measure": '`python -c "import sampledyn as sd; sd.simulate"` (first real call)',
            "value": now["first simulate"],
            "shown": shown("first simulate"),
            "target": "",
            "met": None,
        },
    ]


def run_bench(args: list[str], json_path: Path) -> tuple[list[dict], str, float, float]:
    """Run one benchmark; (its rows, its output, load before, load after)."""
    load0 = os.getloadavg()[0]
    env = dict(os.environ)
    env["PYTHONPATH"] = str(REPO) + (os.pathsep + env["PYTHONPATH"] if "PYTHONPATH" in env else "")
    done = subprocess.run([sys.executable, *args, "--json", str(json_path)], cwd=HERE, env=env,
                          capture_output=True, text=True)  # fmt: skip
    load1 = os.getloadavg()[0]
    out = done.stdout + (f"\n[exit {done.returncode}]\n{done.stderr[-3000:]}" if done.returncode
                         else "")  # fmt: skip
    if not json_path.exists():  # a benchmark that missed a target still wrote its rows
        return [{"measure": f"`{' '.join(args)}`", "value": None, "shown": "failed",
                 "target": "", "met": False}], out, load0, load1  # fmt: skip
    data = json.loads(json_path.read_text())
    extra = data.get("phases")
    if extra:
        out += "\n" + "\n".join(extra)
    return data["rows"], out, load0, load1


def _met(m: bool | None) -> str:
    return "-" if m is None else ("met" if m else "**not met**")


def table(results: list[tuple[str, list[dict], float, float]]) -> list[str]:
    lines = ["| measure | now | target | met | load (before-after) |", "|---|---|---|---|---|"]
    for name, rows, l0, l1 in results:
        for r in rows:
            lines.append(
                f"| {r['measure']} | {r['shown']} | {r['target']} | {_met(r['met'])} | "
                f"{l0:.2f}-{l1:.2f} ({name}) |"
            )
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="short runs (a smoke test)")
    ap.add_argument("--only", nargs="+", choices=["fixed_costs", *BENCHES], help="these only")
    ap.add_argument("--baseline", type=Path, help="another checkout, for the fixed costs")
    ap.add_argument("--out", type=Path, help="also write the Markdown here")
    args = ap.parse_args()
    chosen = args.only or ["fixed_costs", *BENCHES]
    started = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    results: list[tuple[str, list[dict], float, float]] = []
    outputs: list[str] = []
    commands: list[str] = []
    loads: list[float] = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in chosen:
            print(f"== {name} (load average {os.getloadavg()[0]:.2f})", flush=True)
            if name == "fixed_costs":
                l0 = os.getloadavg()[0]
                checkouts = {"now": REPO}
                if args.baseline is not None:
                    checkouts["baseline"] = args.baseline.resolve()
                rows = fixed_cost_rows(fixed_costs(checkouts))
                l1 = os.getloadavg()[0]
                commands.append('python -c "import sampledyn" / "...; sd.simulate" (best of 7)')
                results.append((name, rows, l0, l1))
            else:
                bench_args = BENCHES[name][1 if args.quick else 0]
                commands.append("python benchmarks/" + " ".join(bench_args))
                rows, out, l0, l1 = run_bench(bench_args, Path(tmp) / f"{name}.json")
                outputs.append(f"### {name}\n\n```\n{out.strip()}\n```")
                results.append((name, rows, l0, l1))
            loads += [results[-1][2], results[-1][3]]
            print("\n".join(table(results[-1:])[2:]), flush=True)
    md = [
        f"Measured {started} on {os.cpu_count()} CPUs, load average (1 min) "
        f"{min(loads):.2f}-{max(loads):.2f} (median {statistics.median(loads):.2f})"
        + (" -- QUICK settings, not the table's" if args.quick else ""),
        "",
        *table(results),
        "",
        "Commands:",
        "",
        *(f"    {c}" for c in commands),
        "",
        *outputs,
    ]
    text = "\n".join(md)
    print("\n" + text)
    if args.out is not None:
        args.out.write_text(text + "\n")


if __name__ == "__main__":
    main()
