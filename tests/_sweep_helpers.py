"""Small sweep files shared by the sweep tests."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import time
from pathlib import Path
from typing import Any

import pytest

AUV_SWEEP = """\
vehicle = "auv_like"
input = {{ name = "multilevel", hold = 0.1, seed = 3 }}
x0 = [1.0, 0.0]
T = {T}
after = {after}
h = {h}
methods = {methods}
eta_pct = {eta}
v_pct = {v}
seeds = {seeds}
norm = {norm}
"""

DEFAULTS: dict[str, Any] = {
    "T": 20.0,
    "after": 2.0,
    "h": "[0.01, 0.02]",
    "methods": '["AB1", "AB2", "AB4", "RK4"]',
    "eta": "[0, 2]",
    "v": "[0, 5]",
    "seeds": 2,
    "norm": '"rms"',
}


def write_sweep(path: Path, **changes: Any) -> Path:
    """A sweep file of the AUV-like model (fast), with some entries changed."""
    path.write_text(AUV_SWEEP.format(**{**DEFAULTS, **changes}))
    return path


def rows(db: Path, columns: str = "key, err_eta, err_v, err_all, status") -> dict[str, tuple]:
    """Cells of a store by key (read with plain sqlite3)."""
    with sqlite3.connect(db) as conn:
        return {r[0]: r[1:] for r in conn.execute(f"SELECT {columns} FROM cells")}


def count_cells(db: Path) -> int:
    """Cells in a store (0 before it exists), read while a run writes it."""
    try:
        with sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=5) as conn:
            return int(conn.execute("SELECT COUNT(*) FROM cells").fetchone()[0])
    except sqlite3.OperationalError:  # not created yet
        return 0


def kill_when_stored(proc: subprocess.Popen, db: Path, cells: int, timeout: float = 300) -> None:
    """SIGKILL ``proc`` once ``db`` holds at least ``cells`` cells; fail the test if it
    ends before (the run is too short to be killed mid-way)."""
    deadline = time.monotonic() + timeout
    try:
        while proc.poll() is None and time.monotonic() < deadline:
            if db.exists() and count_cells(db) >= cells:
                break
            time.sleep(0.01)
        if proc.poll() is not None:
            out, err = proc.communicate()
            pytest.fail(f"the run ended before it was killed (make it longer):\n{out}{err}")
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == -signal.SIGKILL
