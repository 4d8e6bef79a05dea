"""Fault injection against real ``sampledyn sweep`` processes on a small grid.

    python tests/fault_injection.py [--T 300] [--keep DIR] [--only CASE,...]

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
import resource
import shutil
import signal
import sqlite3
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

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


def worker_killed(work: Path, T: float) -> Outcome:
    """One worker process killed (-9) mid-run: one line, exit 6, the run marked, the
    other worker stopped, and a rerun computes the rest."""
    cfg, db = write_grid(work / "grid.toml", T), work / "worker.db"
    proc = start("sweep", str(cfg), "--store", str(db), "--workers", "2", "--no-progress")
    workers = wait_for_children(proc.pid, 2, 120)
    kept = wait_for_cells(db, 10, proc, 120)
    os.kill(workers[0], signal.SIGKILL)
    _, err = proc.communicate(timeout=120)
    left = still_alive(workers, 10)
    kill_all(left)
    [(status,)] = query(db, "SELECT status FROM runs")
    one_line = len(err.strip().splitlines()) == 1 and "worker process died" in err
    rerun = _rerun(cfg, db)
    out = _finish(
        "one worker of `sweep --workers 2` killed (-9)",
        f"after {kept} cells; run marked {status!r}, "
        f"{'one line saying so' if one_line else 'BAD message'}; rerun",
        [proc.returncode, rerun],
        db,
        left,
    )
    if proc.returncode != 6 or not one_line:
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


def _quick(*args: str, env: dict[str, str] | None = None, memory: int | None = None) -> Any:
    """``sampledyn ARGS`` with an address-space limit (``memory`` bytes): a command that
    tried to allocate beyond it would die with MemoryError (exit 1), not refuse."""

    def limit() -> None:
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        if memory is not None:
            resource.setrlimit(resource.RLIMIT_AS, (memory, memory))

    return subprocess.run(
        [*CLI, *args], capture_output=True, text=True, timeout=300, preexec_fn=limit, env=env
    )


def _one_line(res: Any) -> bool:
    errors = [x for x in res.stderr.strip().splitlines() if x.startswith("sampledyn: error:")]
    return len(errors) == 1 and "Traceback" not in res.stderr


def _row(fault: str, how: str, statuses: str, ok: bool) -> Outcome:
    """A row of a case without a grid to count (stored / twice: not applicable)."""
    return Outcome(fault, how, statuses, "-", "-", "none", "ok" if ok else "FAILED")


def cache(work: Path, T: float) -> list[Outcome]:
    """Cached kernels edited to plant code, then a cache folder another user could
    write (mode 777): rewritten, or refused, and the planted code never runs."""
    cfg = write_grid(work / "grid.toml", min(T, 30.0))
    marker = work / "PLANTED_CODE_RAN"
    root = work / "cache"
    env = dict(os.environ, SAMPLEDYN_CACHE_DIR=str(root))

    def sweep(name: str) -> Any:
        return _quick("sweep", str(cfg), "--store", str(work / name), "--no-progress", env=env)

    first = sweep("a.db")
    sources = sorted((root / "kernels").glob("*.py"))
    for src in sources:
        src.write_text(src.read_text() + f"\nopen({str(marker)!r}, 'w').close()\n")
    edited = sweep("b.db")
    rewritten = sum(not src.read_text().endswith("close()\n") for src in sources)
    ran = marker.exists()
    warned = "rewritten" in edited.stderr
    out = [
        _row(
            "kernel cache: cached sources edited to plant code",
            f"{len(sources)} cached kernels edited; the next run rewrote {rewritten} "
            f"({'with' if warned else 'WITHOUT'} a warning); planted code "
            f"{'RAN' if ran else 'not run'}",
            f"{first.returncode} / {edited.returncode}",
            edited.returncode == 0 and not ran and bool(sources) and rewritten == len(sources),
        )
    ]
    os.chmod(root / "kernels", 0o777)
    opened = sweep("c.db")
    said = "may be written by others" in opened.stderr and "SAMPLEDYN_CACHE_DIR" in opened.stderr
    made = (work / "c.db").exists()
    out.append(
        _row(
            "kernel cache: folder mode 777 (another user could plant code)",
            f"refused, {'one line with the reason and the variable' if said else 'BAD message'}"
            f"; store {'CREATED' if made else 'not created'}",
            str(opened.returncode),
            opened.returncode == 4 and said and _one_line(opened) and not made,
        )
    )
    return out


def output_over_input(work: Path, T: float) -> list[Outcome]:
    """Outputs naming an input: refused before work, the store byte for byte intact."""
    cfg = write_grid(work / "grid.toml", min(T, 30.0))
    db = work / "s.db"
    first = _rerun(cfg, db)
    before = db.read_bytes()
    rep = work / "rep"
    rep.mkdir()
    (rep / "figures").symlink_to(work, target_is_directory=True)
    tries = {
        "results --format csv --out STORE": ["--format", "csv", "--out", str(db)],
        "results --format parquet --out STORE": ["--format", "parquet", "--out", str(db)],
        "results --out STORE-wal (no such file now)": ["--out", str(db) + "-wal"],
    }
    out = []
    for what, extra in [*tries.items(), ("report (figures/ a link to the store's folder)", None)]:
        args = ["report", str(db), "--out", str(rep)] if extra is None else ["results", str(db)]
        res = _quick(*args, *(extra or []))
        intact = db.read_bytes() == before and not Path(str(db) + "-wal").exists()
        out.append(
            _row(
                f"output over input: {what}",
                f"{'refused in one line' if _one_line(res) else 'BAD message'}; store "
                f"{'intact' if intact else 'CHANGED'}",
                f"{first} / {res.returncode}",
                res.returncode in (2, 4) and intact and _one_line(res),
            )
        )
    return out


# Grid keys changed for each oversized case (the rest of SLOW_GRID as it is).
_OVERSIZED = {
    "h = [1e-9]": {"h": "[1e-9]"},
    "T = 1e12 s": {"h": "[0.01]", "T": "1e12"},
    "a seed beyond int64": {"h": "[0.01]", "seeds": "[9223372036854775808]"},
    "AB100000": {"h": "[0.01]", "methods": '["AB100000"]'},
    "rms@smooth(-5)": {"h": "[0.01]", "norm": '"rms@smooth(-5)"'},
}


def _grid(path: Path, **keys: str) -> Path:
    """SLOW_GRID (T = 30 s) with some keys replaced."""
    lines = dict(
        (line.split("=", 1)[0].strip(), line)
        for line in write_grid(path, 30.0).read_text().splitlines()
        if "=" in line
    )
    lines |= {k: f"{k} = {v}" for k, v in keys.items()}
    path.write_text("\n".join(lines.values()) + "\n")
    return path


def oversized(work: Path, T: float) -> list[Outcome]:
    """Work and memory bounded before they start: under a 3 GB address-space limit
    each case refuses in one line, in seconds, creating nothing."""
    big = work / "big_vehicle.toml"
    with big.open("wb") as fh:
        fh.truncate(17 << 20)  # sparse
    fifo = work / "fifo.db"
    os.mkfifo(fifo)
    runs = {
        f"a sweep with {name}": ["sweep", str(_grid(work / f"g{i}.toml", **keys)), "--store",
                                 str(work / f"g{i}.db"), "--no-progress"]
        for i, (name, keys) in enumerate(_OVERSIZED.items())
    }  # fmt: skip
    runs["a 17 MB vehicle file (sparse)"] = ["advise", "--vehicle", str(big)]
    runs["a FIFO as the store"] = ["sweep", str(_grid(work / "f.toml")), "--store", str(fifo)]
    out = []
    for name, args in runs.items():
        t0 = time.perf_counter()
        res = _quick(*args, memory=3 << 30)
        took = time.perf_counter() - t0
        made = any(p.suffix == ".db" and p.name != "fifo.db" for p in work.iterdir())
        out.append(
            _row(
                f"oversized: {name}",
                f"refused in {took:.1f} s under a 3 GB address-space limit"
                + ("" if _one_line(res) else ", BAD message")
                + ("; a store CREATED" if made else "; no store"),
                str(res.returncode),
                res.returncode in (3, 4) and _one_line(res) and not made,
            )
        )
    small = _grid(work / "small.toml", h="[0.01]", methods='["AB1", "AB2"]', eta_pct="[0]",
                  v_pct="[0, 1]", seeds="1")  # fmt: skip
    db = work / "w.db"
    res = _quick("sweep", str(small), "--store", str(db), "--workers", "200", "--no-progress")
    stored = query(db, "SELECT COUNT(*) FROM cells")[0][0] if db.exists() else 0
    capped = "capped at" in res.stderr
    out.append(
        Outcome(
            "oversized: --workers 200 on a 4-cell grid",
            f"ran {'with a note: capped' if capped else 'NOT capped'}",
            str(res.returncode),
            f"{stored} / 4",
            "0",
            "none",
            "ok" if res.returncode == 0 and capped and stored == 4 else "FAILED",
        )
    )
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--T", type=float, default=300.0, help="run length of the grid (s)")
    parser.add_argument("--keep", help="folder to work in and keep (default: a temporary one)")
    parser.add_argument("--only", help="run only these cases (comma-separated names)")
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
        ("sighup", lambda d: interrupt(d, args.T, signal.SIGHUP)),
        ("worker_killed", lambda d: worker_killed(d, args.T)),
        ("cache", lambda d: cache(d, args.T)),
        ("output_over_input", lambda d: output_over_input(d, args.T)),
        ("oversized", lambda d: oversized(d, args.T)),
    ]
    if args.only:
        chosen = set(args.only.split(","))
        cases = [(n, c) for n, c in cases if n in chosen]
    for name, case in cases:
        folder = work / name
        folder.mkdir(exist_ok=True)
        print(f"running {name} ...", file=sys.stderr, flush=True)
        found = case(folder)
        outcomes.extend(found if isinstance(found, list) else [found])
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
