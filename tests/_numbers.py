"""Comparing numbers computed here with numbers stored from another run (a committed
CSV, a fixture written by older code): by a tolerance that the caller states and
justifies, never bit for bit. BLAS/LAPACK pick kernels for the CPU (OpenBLAS's Zen
kernels against its SkylakeX ones: OPENBLAS_CORETYPE=Zen on an Intel machine gives
an AMD EPYC's digits), and libm, numpy's SIMD loops and numba's code for the host CPU
may too; other library versions round otherwise again. The last digits of a stored
number are not the code's to keep.

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

import sampledyn as sd
from sampledyn.methods import Estimator


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


# ------------------------------------------------------- the AUV-like study (Figs. 2-3)
# The exact samples take one DOP853 step per sample (error control never shortens a
# step at h = 0.01 s: the same numbers at rtol 1e-12 and 0.9e-12), so another CPU
# changes them only by rounding: atol 1e-13 is 1000 ulps of states of size ~1, which a
# norm of the local errors inherits (an rms of RK4's 1e-8 errors keeps 5 digits).
AUV_FIXED_RULE = Tol(1e-12, 1e-13, "exact samples and predictions to rounding")
# Ee and ABe_s fit their parameters by least squares, condition number <= 13 on these
# runs (res.condition_number): forward error <= rows * kappa * eps (7e-12 relative for
# the 2500 rows of a 30 s run, 5e-11 for 200 s), which the error norms inherit.
AUV_FITTED_RULE = Tol(1e-10, 1e-13, "least squares: rows * condition number * eps")
# tau_min: eigenvalues of 2 x 2 Jacobians, rounding only.
AUV_TAU = Tol(1e-12, 0.0, "2 x 2 eigenvalues")
# The certificate is the difference of two integrations (it varies by tens of percent
# between machines): only its documented bound (README: "below 2e-13") is checked.
AUV_CERTIFICATE_BOUND = {"certificate": 2e-13}


def auv_tolerance(row: Mapping[str, str], column: str) -> Tol:
    """The tolerance of a cell of a fig2/fig3 CSV (row: the stored row)."""
    if column == "tau_min":
        return AUV_TAU
    fitted = isinstance(sd.get_method(row["method"]), Estimator)
    return AUV_FITTED_RULE if fitted else AUV_FIXED_RULE
