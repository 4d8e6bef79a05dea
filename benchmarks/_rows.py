"""Rows of the performance table (issue 14): what each benchmark measured against its
target, written as JSON with ``--json PATH`` and collected by ``run_all.py``."""

from __future__ import annotations

import datetime
import json
import os
import platform
from pathlib import Path
from typing import Any


def row(
    measure: str,
    value: float | None,
    shown: str,
    target: str = "",
    met: bool | None = None,
    **notes: Any,
) -> dict[str, Any]:
    """One line of the table: ``measure`` (the issue's wording), the number ``value``
    and how it is ``shown``, the ``target`` text and whether it is ``met`` (None: no
    target, for information)."""
    return {
        "measure": measure,
        "value": value,
        "shown": shown,
        "target": target,
        "met": met,
        **notes,
    }


def machine() -> dict[str, Any]:
    """Where and when: CPUs, load average (1, 5, 15 min), UTC time, Python."""
    return {
        "cpus": os.cpu_count(),
        "load": [round(x, 2) for x in os.getloadavg()],
        "utc": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M:%S"),
        "python": platform.python_version(),
    }


def write_json(path: str | os.PathLike[str] | None, bench: str, rows: list[dict], **info: Any):
    """Write the rows of ``bench`` (with the machine and load at the end of the run)."""
    if path is None:
        return
    Path(path).write_text(
        json.dumps({"bench": bench, "rows": rows, "machine": machine(), **info}, indent=1)
    )
