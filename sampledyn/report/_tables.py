"""Plain-text tables and CSV files from lists of row dicts."""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .._files import csv_safe

__all__ = ["format_grid", "write_csv"]


def write_csv(rows: Sequence[dict[str, Any]], path: str | Path) -> Path:
    """Write rows (dicts) to a CSV file; returns the path.

    The columns are every key of any row, in order of appearance (a failed row's
    ``error`` too); a row without a key leaves its cell empty. Text a spreadsheet
    would run as a formula is written as text (:func:`sampledyn._files.csv_safe`).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if not rows:
        raise ValueError("no rows to write.")
    fields = list(dict.fromkeys(k for r in rows for k in r))
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields, restval="")
        writer.writeheader()
        writer.writerows({k: csv_safe(v) for k, v in r.items()} for r in rows)
    return path


def format_grid(
    rows: Sequence[dict[str, Any]],
    row_key: str,
    col_key: str,
    value_key: str,
    fmt: str = "{:.2e}",
    row_title: str | None = None,
    col_title: str | None = None,
    missing: str = "n/a",
) -> str:
    """A text table with one row per ``row_key`` value and one column per ``col_key``.

    A NaN value prints as ``missing`` (the caller says why below the table); a
    combination without a row as "-".
    """
    row_vals = list(dict.fromkeys(r[row_key] for r in rows))
    col_vals = list(dict.fromkeys(r[col_key] for r in rows))
    cell = {(r[row_key], r[col_key]): r[value_key] for r in rows}
    head = [row_title or row_key] + [f"{col_title or col_key}={c}" for c in col_vals]

    def text(key: tuple[Any, Any]) -> str:
        if key not in cell:
            return "-"
        value = cell[key]
        if isinstance(value, float) and math.isnan(value):
            return missing
        return fmt.format(value)

    body = [[str(rv)] + [text((rv, cv)) for cv in col_vals] for rv in row_vals]
    widths = [max(len(line[i]) for line in [head, *body]) for i in range(len(head))]
    lines = [
        "  ".join(s.rjust(w) for s, w in zip(line, widths, strict=True)) for line in [head, *body]
    ]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)
