"""Fault injection against real ``sampledyn sweep`` processes on a small grid.

    python tests/fault_injection.py [--T 300] [--keep DIR]

Runs each fault, then (where the fault allows) reruns the same command, and prints a
Markdown table: what was tried, the exit statuses, whether every cell of the grid is
stored exactly once (nothing lost, nothing duplicated), and whether any process was
left running. Mounting a small tmpfs (full disk, read-only media) needs root; without
it the full disk is injected as the SQLite error instead and the read-only case is
skipped (the table says so).
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import sqlite3
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _faults import (  # noqa: E402
    CLI,
    SLOW_GRID_CELLS,
    Unavailable,
    alive,
    children,
    kill_all,
    query,
    remount_readonly,
    run,
    start,
    still_alive,
    tmpfs,
    wait_for_cells,
    wait_for_children,
    write_grid,
)


@dataclass
class Outcome:
    fault: str
    how: str
    statuses: str
    stored: str
    twice: str
    left: str
    verdict: str


def _store_facts(db: Path) -> tuple[int, int, int]:
    """(distinct cells, stored rows, cells a run reported computing twice)."""
    keys, rows = query(db, "SELECT COUNT(DISTINCT key), COUNT(*) FROM cells")[0]
    dup = query(db, "SELECT COALESCE(SUM(duplicates), 0) FROM runs")[0][0]
    return int(keys), int(rows), int(dup)


def _finish(fault: str, how: str, statuses: list[int], db: Path, left: list[int]) -> Outcome:
    keys, rows, dup = _store_facts(db)
    ok = keys == rows == SLOW_GRID_CELLS and dup == 0 and not left
    return Outcome(
        fault,
        how,
        " / ".join(str(s) for s in statuses),
        f"{keys} / {SLOW_GRID_CELLS}",
        str(rows - keys + dup),
        ", ".join(map(str, left)) or "none",
        "ok" if ok else "FAILED",
    )


def _rerun(cfg: Path, db: Path) -> int:
    res = run("sweep", str(cfg), "--store", str(db), "--no-progress")
    if res.returncode != 0:
        print(res.stderr, file=sys.stderr)
    return res.returncode


def kill9(work: Path, T: float) -> Outcome:
    cfg, db = write_grid(work / "grid.toml", T), work / "kill9.db"
    proc = start("sweep", str(cfg), "--store", str(db), "--workers", "2", "--no-progress")
    workers = wait_for_children(proc.pid, 2, 120)
    kept = wait_for_cells(db, 10, proc, 120)
    os.kill(proc.pid, signal.SIGKILL)
    proc.communicate(timeout=60)
    left = still_alive(workers, 10)
    kill_all(left)
    status = _rerun(cfg, db)
    return _finish(
        "kill -9 of `sweep --workers 2`",
        f"killed after {kept} cells; workers must die with it; rerun",
        [proc.returncode, status],
        db,
        left,
    )


def interrupt(work: Path, T: float, sig: signal.Signals) -> Outcome:
    cfg, db = write_grid(work / "grid.toml", T), work / f"{sig.name}.db"
    proc = start("sweep", str(cfg), "--store", str(db), "--workers", "2", "--no-progress")
    workers = wait_for_children(proc.pid, 2, 120)
    kept = wait_for_cells(db, 10, proc, 120)
    if sig == signal.SIGINT:
        os.killpg(proc.pid, sig)  # a terminal's Ctrl-C
    else:
        os.kill(proc.pid, sig)
    _, err = proc.communicate(timeout=60)
    left = still_alive(workers, 10)
    kill_all(left)
    [(status,)] = query(db, "SELECT status FROM runs")
    one_line = len(err.strip().splitlines()) == 1 and "Traceback" not in err
    rerun = _rerun(cfg, db)
    out = _finish(
        f"{sig.name} to `sweep --workers 2`"
        + (" (Ctrl-C: to its process group)" if sig == signal.SIGINT else ""),
        f"after {kept} cells; run marked {status!r}, "
        f"{'one-line message' if one_line else 'NOT one line'}; rerun",
        [proc.returncode, rerun],
        db,
        left,
    )
    if status != "interrupted" or not one_line:
        out.verdict = "FAILED"
    return out


def concurrent(work: Path, T: float, kill_one: bool) -> Outcome:
    cfg, db = write_grid(work / "grid.toml", T), work / f"shared{int(kill_one)}.db"
    procs = [start("sweep", str(cfg), "--store", str(db), "--no-progress") for _ in range(2)]
    how = "two sweeps started together on one store"
    statuses = []
    if kill_one:
        wait_for_cells(db, 40, procs[0], 120)
        os.kill(procs[0].pid, signal.SIGKILL)
        how += ", the first killed (-9) mid-run; then a rerun"
    for p in procs:
        p.communicate(timeout=600)
        statuses.append(p.returncode)
    computed = [c for (c,) in query(db, "SELECT computed FROM runs WHERE status = 'complete'")]
    if kill_one:
        statuses.append(_rerun(cfg, db))
    else:
        how += f"; they computed {' + '.join(map(str, computed))} cells"
    left = [c for p in procs for c in children(p.pid) if alive(c)]
    out = _finish("concurrent sweeps" + (" + kill -9" if kill_one else ""), how, statuses, db, left)
    if not kill_one and (len(computed) != 2 or min(computed) == 0):
        out.verdict = "FAILED (not split)"
    return out


def full_disk(work: Path, T: float) -> Outcome:
    cfg = write_grid(work / "grid.toml", T)
    media = work / "small"
    try:
        with tmpfs(media, "160k"):
            db = media / "r.db"
            res = run("sweep", str(cfg), "--store", str(db), "--no-progress")
            lines = res.stderr.strip().splitlines()
            one_line = len(lines) == 1 and str(db) in lines[0] and "no space left" in lines[0]
            with sqlite3.connect(f"file:{db}?mode=ro", uri=True) as conn:
                intact = conn.execute("PRAGMA integrity_check").fetchone()[0]
                kept = conn.execute("SELECT COUNT(*) FROM cells").fetchone()[0]
            subprocess.run(["mount", "-o", "remount,size=64m", str(media)], check=True)
            status = _rerun(cfg, db)
            out = _finish(
                "full disk (160 KB tmpfs)",
                f"{kept} cells kept, integrity {intact}, "
                f"{'one line naming the store, no space left' if one_line else 'BAD message'}"
                "; tmpfs grown, rerun",
                [res.returncode, status],
                db,
                [],
            )
            if res.returncode != 5 or intact != "ok" or not one_line:
                out.verdict = "FAILED"
            return out
    except Unavailable as exc:
        return Outcome("full disk", f"skipped: {exc}", "-", "-", "-", "-", "skipped")


def read_only(work: Path, T: float) -> Outcome:
    cfg = write_grid(work / "grid.toml", T)
    media = work / "ro"
    try:
        with tmpfs(media, "64m"):
            db = media / "r.db"
            first = _rerun(cfg, db)
            remount_readonly(media)
            before = (db.read_bytes(), db.stat().st_mtime_ns)
            results = run("results", str(db), "--format", "csv")
            report = run("report", str(db), "--out", str(work / "report"))
            sweep = run("sweep", str(cfg), "--store", str(db), "--no-progress")
            same = before == (db.read_bytes(), db.stat().st_mtime_ns)
            lines = results.stdout.count("\n") - 1
            out = _finish(
                "read-only media (tmpfs remounted ro)",
                f"results ({lines} rows), report, then a sweep on it (refused); store "
                f"{'unchanged' if same else 'CHANGED'}",
                [first, results.returncode, report.returncode, sweep.returncode],
                db,
                [],
            )
            if (results.returncode, report.returncode, sweep.returncode) != (0, 0, 4) or not same:
                out.verdict = "FAILED"
            return out
    except Unavailable as exc:
        return Outcome("read-only media", f"skipped: {exc}", "-", "-", "-", "-", "skipped")


def foreign(work: Path, T: float) -> Outcome:
    cfg = write_grid(work / "grid.toml", T)
    other = work / "other_app.db"
    with sqlite3.connect(other) as conn:
        conn.execute("CREATE TABLE users (id INTEGER PRIMARY KEY, name TEXT)")
    before = sorted((p.name, p.read_bytes(), p.stat().st_mtime_ns) for p in work.glob("other*"))
    statuses = [
        run("sweep", str(cfg), "--store", str(other), *extra).returncode
        for extra in (["--dry-run"], ["--no-progress"])
    ]
    after = sorted((p.name, p.read_bytes(), p.stat().st_mtime_ns) for p in work.glob("other*"))
    same = before == after
    return Outcome(
        "another application's SQLite file as --store",
        "--dry-run and a run; file "
        + ("untouched (bytes, mtime, no side files)" if same else "CHANGED"),
        " / ".join(map(str, statuses)),
        "-",
        "-",
        "none",
        "ok" if same and statuses == [3, 3] else "FAILED",
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--T", type=float, default=300.0, help="run length of the grid (s)")
    parser.add_argument("--keep", help="folder to work in and keep (default: a temporary one)")
    args = parser.parse_args()
    work = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="sampledyn-faults-"))
    work.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    outcomes = []
    cases = [
        ("kill9", lambda d: kill9(d, args.T)),
        ("sigterm", lambda d: interrupt(d, args.T, signal.SIGTERM)),
        ("sigint", lambda d: interrupt(d, args.T, signal.SIGINT)),
        ("concurrent", lambda d: concurrent(d, args.T, kill_one=False)),
        ("concurrent_kill", lambda d: concurrent(d, args.T, kill_one=True)),
        ("full_disk", lambda d: full_disk(d, args.T)),
        ("read_only", lambda d: read_only(d, args.T)),
        ("foreign", lambda d: foreign(d, args.T)),
    ]
    for name, case in cases:
        folder = work / name
        folder.mkdir(exist_ok=True)
        print(f"running {name} ...", file=sys.stderr, flush=True)
        outcomes.append(case(folder))
    print(f"Fault injection, grid of {SLOW_GRID_CELLS} cells (AUV-like, T = {args.T:g} s), ")
    print(f"`{' '.join(Path(c).name for c in CLI)} sweep`; {time.perf_counter() - t0:.0f} s.\n")
    print("| fault | what was done | exit statuses | cells stored / grid | stored or "
          "computed twice | processes left | verdict |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    for o in outcomes:
        print(f"| {o.fault} | {o.how} | {o.statuses} | {o.stored} | {o.twice} | {o.left} | "
              f"{o.verdict} |")  # fmt: skip
    if not args.keep:
        shutil.rmtree(work, ignore_errors=True)
    return 0 if all(o.verdict in ("ok", "skipped") for o in outcomes) else 1


if __name__ == "__main__":
    sys.exit(main())
