"""Real ``sampledyn`` processes, mounts and process trees, for the fault-injection
tests and ``tests/fault_injection.py``."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

CLI = [sys.executable, "-m", "sampledyn.cli"]


def error_lines(err: str) -> list[str]:
    """The lines of a command's stderr without the compile notice that a run which
    compiled prints first (``cli._main.compile_notice``; docs/cli.md: "one line, besides
    the compile notice"). Whether a test's command compiles depends on what ran before
    it in the same process and on the kernel cache, not on the test."""
    return [ln for ln in err.strip().splitlines() if ": compiling the numerical kernels" not in ln]


# An AUV-like grid of 460 cells that runs a few seconds: long enough to be killed
# mid-run, short enough for a test.
SLOW_GRID = """\
vehicle = "auv_like"
input = {{ name = "multilevel", hold = 0.1, seed = 3 }}
x0 = [1.0, 0.0]
T = {T}
after = 20.0
h = [0.005, 0.01]
methods = ["AB1", "AB2", "AB3", "AB4", "RK4"]
eta_pct = [0, 1, 2, 5]
v_pct = [0, 1, 2, 5]
seeds = 3
norm = "rms"
"""
SLOW_GRID_CELLS = 2 * (1 + 15 * 3) * 5


class Unavailable(Exception):
    """The machine does not allow this fault (e.g. no permission to mount)."""


def write_grid(path: Path, T: float = 600.0) -> Path:
    path.write_text(SLOW_GRID.format(T=T))
    return path


def _default_sigint() -> None:
    # A shell may start us with SIGINT ignored; Python then never raises
    # KeyboardInterrupt. Give the command the default, as a terminal would.
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def start(*args: str, **kwargs: Any) -> subprocess.Popen[str]:
    """``sampledyn ARGS`` as a real process in its own session (stdout/stderr piped)."""
    return subprocess.Popen(
        [*CLI, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=_default_sigint,
        **kwargs,
    )


def run(*args: str, timeout: float = 300.0, **kwargs: Any) -> subprocess.CompletedProcess[str]:
    """``sampledyn ARGS`` to the end."""
    return subprocess.run(
        [*CLI, *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        preexec_fn=_default_sigint,
        **kwargs,
    )


def _state(pid: int) -> str | None:
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except (FileNotFoundError, ProcessLookupError):
        return None
    return text.rsplit(")", 1)[1].split()[0]


def alive(pid: int) -> bool:
    """A process that runs (a zombie is dead)."""
    state = _state(pid)
    return state is not None and state not in ("Z", "X")


def children(pid: int) -> list[int]:
    """Direct children of ``pid`` (Linux /proc)."""
    out = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                text = (entry / "stat").read_text()
            except (FileNotFoundError, ProcessLookupError):
                continue
            if int(text.rsplit(")", 1)[1].split()[1]) == pid:
                out.append(int(entry.name))
    return out


def wait_for_children(pid: int, n: int, timeout: float) -> list[int]:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        kids = [k for k in children(pid) if alive(k)]
        if len(kids) >= n:
            return kids
        time.sleep(0.05)
    raise TimeoutError(f"process {pid} did not start {n} workers within {timeout} s")


def still_alive(pids: list[int], timeout: float) -> list[int]:
    """The ``pids`` still running after waiting up to ``timeout`` s for them to end."""
    deadline = time.monotonic() + timeout
    left = [p for p in pids if alive(p)]
    while left and time.monotonic() < deadline:
        time.sleep(0.05)
        left = [p for p in left if alive(p)]
    return left


def kill_all(pids: list[int]) -> None:
    for p in pids:
        try:
            os.kill(p, signal.SIGKILL)
        except ProcessLookupError:
            pass


def count_cells(db: Path) -> int:
    """Stored cells, read without touching the store (0 if not there yet)."""
    if not db.exists():
        return 0
    try:
        with sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=5) as conn:
            return int(conn.execute("SELECT COUNT(*) FROM cells").fetchone()[0])
    except sqlite3.OperationalError:
        return 0


def wait_for_cells(db: Path, n: int, proc: subprocess.Popen[str], timeout: float) -> int:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            out, err = proc.communicate()
            raise RuntimeError(f"the run ended before it was interrupted:\n{out}\n{err}")
        got = count_cells(db)
        if got >= n:
            return got
        time.sleep(0.02)
    raise TimeoutError(f"fewer than {n} cells in {db} after {timeout} s")


def query(db: Path, sql: str) -> list[tuple[Any, ...]]:
    """``sql`` on the store ``db``, read-only (immutable on read-only media)."""
    try:
        with sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=30) as conn:
            return conn.execute(sql).fetchall()
    except sqlite3.OperationalError:
        with sqlite3.connect(f"file:{db}?immutable=1", uri=True) as conn:
            return conn.execute(sql).fetchall()


def _mount(*args: str) -> None:
    res = subprocess.run(["mount", *args], capture_output=True, text=True)
    if res.returncode != 0:
        raise Unavailable(f"mount {' '.join(args)}: {res.stderr.strip()}")


def _umount(path: Path) -> None:
    subprocess.run(["umount", "-l", str(path)], capture_output=True)


@contextmanager
def tmpfs(path: Path, size: str = "1m") -> Iterator[Path]:
    """A small tmpfs mounted at ``path`` (root only; raises :class:`Unavailable`)."""
    if os.geteuid() != 0 or not sys.platform.startswith("linux"):
        raise Unavailable("mounting a tmpfs needs root on Linux")
    path.mkdir(parents=True, exist_ok=True)
    _mount("-t", "tmpfs", "-o", f"size={size},mode=0755", "tmpfs", str(path))
    try:
        yield path
    finally:
        _umount(path)


def remount_readonly(path: Path) -> None:
    """Make the tmpfs at ``path`` read-only (for root too)."""
    _mount("-o", "remount,ro", str(path))
