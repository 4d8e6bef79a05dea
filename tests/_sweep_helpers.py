"""Small sweep files shared by the sweep tests."""

from __future__ import annotations

import sqlite3
from pathlib import Path
from typing import Any

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
