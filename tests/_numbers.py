"""Comparing numbers computed here with numbers stored from another run (a committed
CSV, a fixture written by older code): by a tolerance that the caller states and
justifies, never bit for bit. Least squares, LAPACK, libm and numba's code for the
host CPU (FMA contraction, vector width) round differently on other CPUs and library
versions, so the last digits of a stored number are not the code's to keep.

A column is compared as numbers when both cells parse as floats (``nan`` equals
``nan``), else as text (names, flags, statuses must match exactly). A column listed in
``bounds`` is not compared with the stored value at all: it is a certificate (the
difference of two runs, which varies by tens of percent between machines) and must
only stay below its documented bound.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Tol:
    """|actual - stored| <= atol + rtol |stored|, and why these digits are all a run on
    another machine reproduces (``reason``, printed with a mismatch)."""

    rtol: float
    atol: float = 0.0
    reason: str = ""


def read_rows(path: Path) -> list[dict[str, str]]:
    with Path(path).open(newline="") as fh:
        return list(csv.DictReader(fh))


def _number(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


def rows_mismatches(
    actual: Sequence[Mapping[str, str]],
    stored: Sequence[Mapping[str, str]],
    tol: Tol | Callable[[Mapping[str, str], str], Tol],
    *,
    bounds: Mapping[str, float] | None = None,
    label: Callable[[Mapping[str, str]], str] = lambda row: "",
) -> list[str]:
    """Every cell of ``actual`` that does not match ``stored`` (same rows in the same
    order, same columns), as readable lines; ``tol`` is one Tol or a function of the
    stored row and the column name."""
    bounds = dict(bounds or {})
    found: list[str] = []
    if len(actual) != len(stored):
        return [f"{len(actual)} rows, stored {len(stored)}"]
    for i, (new, old) in enumerate(zip(actual, stored, strict=True)):
        if set(new) != set(old):
            found.append(f"row {i}: columns {sorted(new)} against stored {sorted(old)}")
            continue
        where = f"row {i} {label(old)}".rstrip()
        for col, want in old.items():
            got = new[col]
            if col in bounds:
                value = _number(got)
                if value is None or not value <= bounds[col]:
                    found.append(f"{where} {col}: {got} is not below its bound {bounds[col]:g}")
                continue
            a, b = _number(got), _number(want)
            if a is None or b is None:
                if got != want:
                    found.append(f"{where} {col}: {got!r} against stored {want!r}")
                continue
            if a == b or (math.isnan(a) and math.isnan(b)):  # inf == inf too
                continue
            t = tol(old, col) if callable(tol) else tol
            if not abs(a - b) <= t.atol + t.rtol * abs(b):  # False for a NaN on one side
                rel = abs(a - b) / abs(b) if b else math.inf
                found.append(
                    f"{where} {col}: {got} against stored {want} (relative {rel:.2g}; "
                    f"allowed rtol {t.rtol:g}, atol {t.atol:g}: {t.reason})"
                )
    return found


def assert_rows_close(actual, stored, tol, *, bounds=None, label=lambda row: "") -> None:
    """Assert :func:`rows_mismatches` finds nothing; the message lists the first 10."""
    found = rows_mismatches(actual, stored, tol, bounds=bounds, label=label)
    assert not found, f"{len(found)} cells differ:\n" + "\n".join(found[:10])


def assert_csv_close(actual: Path, stored: Path, tol, *, bounds=None, label=None) -> None:
    """:func:`assert_rows_close` on two CSV files."""
    assert_rows_close(
        read_rows(actual), read_rows(stored), tol, bounds=bounds, label=label or (lambda r: "")
    )
