"""Read and validate a vehicle log (CSV or Parquet) into a Trajectory.

A log has one row per sample and the columns t, the states of the model (for a
vehicle x, y, z, phi, theta, psi, u, v, w, p, q, r) and its inputs (thruster rpm:
n_r1..n_r8, or n1..n8), each with its unit in the header, ``x[m]``, ``phi[deg]``,
``n1[rpm]``, or given by a mapping file (TOML)::

    [columns]
    "North (ft)" = { name = "x", unit = "ft" }
    "roll" = { unit = "deg" }          # name defaults to the column's

Checks, in order, before anything else happens (the first failure raises
:class:`LogFormatError` naming the column or row):

1. every needed column is present once, with a known unit of the right kind;
2. t is finite and strictly increasing, and uniformly sampled: every step within
   ``time_tolerance`` (relative) of the median step h;
3. NaN in states or inputs, by the ``nan`` policy: "error" (default); "interpolate"
   (linear in time inside the log, rows at either end trimmed); "drop" (the rows are
   filled for computation but no error is counted on a sample whose prediction
   uses or targets them);
4. units: converted to the model's; roll/pitch beyond pi rad or angle steps beyond
   3 pi are reported as a likely deg/rad mix-up;
5. angles are unwrapped (a heading that wraps from 180 deg to -180 deg would
   otherwise look like a 2 pi jump to every predictor).

Accepted sampling jitter is absorbed: the samples are placed on the uniform grid
``t_0 + n h`` with h the mean step.
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._trajectory import Trajectory
from ._units import LogFormatError, conversion_factor, split_header

__all__ = ["NAN_POLICIES", "LogData", "log_from_frame", "read_log"]

NAN_POLICIES = ("error", "drop", "interpolate")


@dataclass(frozen=True)
class LogData:
    """A validated log in the model's units.

    Attributes
    ----------
    traj : Trajectory
        Samples on the uniform grid, states and inputs in the model's units.
    valid : ndarray of bool, shape (N,)
        False for rows that held NaN under ``nan="drop"`` (filled by interpolation
        so that f can be evaluated; not to be counted).
    source : str
        File name.
    jitter : float
        Largest |t_{n+1} - t_n - h| / h of the log.
    notes : tuple of str
        What was done to the data (conversions, unwrapping, NaN handling).
    """

    traj: Trajectory
    valid: np.ndarray
    source: str
    jitter: float
    notes: tuple[str, ...]


def _row(i: int, csv: bool) -> str:
    """Data row i (0-based) as the user sees it: 1-based, and its line in a CSV."""
    return f"data row {i + 1}" + (f" (line {i + 2})" if csv else "")


def _load_mapping(mapping: Any) -> dict[str, dict[str, str]]:
    if mapping is None:
        return {}
    if isinstance(mapping, Mapping):
        raw = dict(mapping)
    else:
        path = Path(mapping)
        if not path.is_file():
            raise LogFormatError("mapping", f"`mapping`: no file {str(path)!r}.")
        try:
            raw = tomllib.loads(path.read_text())
        except tomllib.TOMLDecodeError as exc:
            raise LogFormatError("mapping", f"`mapping` {str(path)!r}: not TOML: {exc}") from exc
    cols = raw.get("columns", raw)
    out: dict[str, dict[str, str]] = {}
    for col, entry in cols.items():
        if not isinstance(entry, Mapping) or not set(entry) <= {"name", "unit"}:
            raise LogFormatError(
                "mapping", f"`mapping`: entry {col!r} must be a table with `name` and/or `unit`."
            )
        out[str(col)] = {k: str(v) for k, v in entry.items()}
    return out


def _aliases(model: Any) -> tuple[list[tuple[str, ...]], list[tuple[str, ...]]]:
    states: list[tuple[str, ...]] = [(str(n),) for n in model.state_names]
    inputs: list[tuple[str, ...]] = []
    for i, (n, unit) in enumerate(zip(model.input_names, model.input_units, strict=True)):
        names = [n, f"u{i + 1}"] + ([f"n{i + 1}"] if unit == "rpm" else [])
        inputs.append(tuple(dict.fromkeys(names)))
    return states, inputs


def _columns(
    frame: Any, model: Any, mapping: dict[str, dict[str, str]], src: str
) -> dict[str, tuple[str, str | None]]:
    """Model quantity -> (log column, unit) for t, every state and every input."""
    found: dict[str, tuple[str, str | None]] = {}
    for col in frame.columns:
        name, unit = split_header(str(col))
        entry = mapping.get(str(col), {})
        name = entry.get("name", name)
        unit = entry.get("unit", unit)
        if name == "time":
            name = "t"
        if name in found:
            raise LogFormatError(
                str(col), f"{src}: two columns for {name!r}: {found[name][0]!r} and {str(col)!r}."
            )
        found[name] = (str(col), unit)
    states, inputs = _aliases(model)
    out: dict[str, tuple[str, str | None]] = {}
    missing = []
    for names in [("t",), *states, *inputs]:
        hit = [n for n in names if n in found]
        if not hit:
            missing.append(" or ".join(repr(n) for n in names))
            continue
        if len(hit) > 1:
            cols = [found[n][0] for n in hit]
            raise LogFormatError(hit[1], f"{src}: columns {cols} all give {names[0]!r}.")
        out[names[0]] = found[hit[0]]
    if missing:
        have = ", ".join(repr(str(c)) for c in frame.columns)
        raise LogFormatError(
            "columns",
            f"{src}: missing column {missing[0]}"
            + (f" (and {len(missing) - 1} more)" if len(missing) > 1 else "")
            + f"; the log has {have}. Name columns like 'x[m]', or map them with a mapping file.",
        )
    for name, (col, unit) in out.items():
        if unit is None:
            raise LogFormatError(
                col,
                f"{src}: column {col!r} ({name}) has no unit; write it as '{name}[unit]' in "
                "the header or give it in a mapping file.",
            )
    return out


def _check_time(t: np.ndarray, tol: float, src: str, csv: bool) -> tuple[float, float]:
    if t.size < 3:
        raise LogFormatError("t", f"{src}: need at least 3 samples, got {t.size}.")
    bad = ~np.isfinite(t)
    if bad.any():
        i = int(np.argmax(bad))
        raise LogFormatError("t", f"{src}: t is NaN or inf at {_row(i, csv)}.")
    d = np.diff(t)
    if (d <= 0).any():
        i = int(np.argmax(d <= 0))
        raise LogFormatError(
            "t",
            f"{src}: t is not strictly increasing at {_row(i + 1, csv)}: t = {t[i + 1]:.9g} s "
            f"after {t[i]:.9g} s.",
        )
    h = float(np.median(d))
    dev = np.abs(d - h) / h
    if (dev > tol).any():
        i = int(np.argmax(dev > tol))
        raise LogFormatError(
            "t",
            f"{src}: t is not uniformly sampled: between {_row(i, csv)} and {_row(i + 1, csv)} "
            f"t jumps from {t[i]:.9g} s to {t[i + 1]:.9g} s (gap {d[i]:.6g} s; h = {h:.6g} s, "
            f"tolerance {tol:.2%} of h). Split the log there, resample it, or raise "
            "`time_tolerance`.",
        )
    return h, float(dev.max())


def _fill(values: np.ndarray, t: np.ndarray) -> np.ndarray:
    out = values.copy()
    for j in range(out.shape[1]):
        ok = np.isfinite(out[:, j])
        if not ok.all():
            out[:, j] = np.interp(t, t[ok], out[ok, j])
    return out


def _nan_policy(
    data: np.ndarray, t: np.ndarray, cols: list[str], nan: str, src: str, csv: bool
) -> tuple[slice, np.ndarray, list[str]]:
    """Rows to keep (a slice), validity per kept row, notes."""
    finite = np.isfinite(data)
    if finite.all():
        return slice(0, data.shape[0]), np.ones(data.shape[0], bool), []
    rows_bad = ~finite.all(axis=1)
    i = int(np.argmax(rows_bad))
    j = int(np.argmax(~finite[i]))
    if nan == "error":
        raise LogFormatError(
            cols[j],
            f"{src}: column {cols[j]!r} is NaN at {_row(i, csv)} ({int(rows_bad.sum())} rows "
            "with NaN). Choose a policy: `nan`='drop' or 'interpolate' (--nan).",
        )
    for jj in range(data.shape[1]):
        if not finite[:, jj].any():
            raise LogFormatError(cols[jj], f"{src}: column {cols[jj]!r} holds no number.")
    good = np.flatnonzero(~rows_bad)
    keep = slice(int(good[0]), int(good[-1]) + 1)
    notes = []
    trimmed = data.shape[0] - (keep.stop - keep.start)
    if trimmed:
        notes.append(f"{trimmed} rows with NaN at the ends of the log trimmed")
    inner = rows_bad[keep]
    if nan == "interpolate":
        notes.append(f"{int(inner.sum())} rows with NaN interpolated linearly in time")
        return keep, np.ones(keep.stop - keep.start, bool), notes
    notes.append(f"{int(inner.sum())} rows with NaN dropped from the error norms")
    return keep, ~inner, notes


def _check_angles(
    x: np.ndarray, model: Any, cols: dict[str, tuple[str, str | None]], src: str
) -> None:
    for k, (name, unit) in enumerate(zip(model.state_names, model.state_units, strict=True)):
        if unit != "rad":
            continue
        col = cols[name][0]
        v = x[:, k]
        if name in ("phi", "theta") and np.nanmax(np.abs(v)) > math.pi + 1e-9:
            raise LogFormatError(
                col,
                f"{src}: column {col!r}: |{name}| reaches {np.nanmax(np.abs(v)):.4g} rad, "
                "impossible for a roll/pitch angle; is the column in deg, not rad?",
            )
        steps = np.abs(np.diff(v))
        if steps.size and np.nanmax(steps) > 3 * math.pi:
            raise LogFormatError(
                col,
                f"{src}: column {col!r}: {name} steps by {np.nanmax(steps):.4g} rad between two "
                "samples, more than a wrap-around (2 pi); is the column in deg, not rad?",
            )


def log_from_frame(
    frame: Any,
    model: Any,
    *,
    source: str = "<frame>",
    mapping: Any = None,
    nan: str = "error",
    time_tolerance: float = 0.01,
    unwrap: bool = True,
    csv: bool = False,
) -> LogData:
    """Validate a pandas DataFrame as a log of ``model`` (see the module docstring)."""
    if nan not in NAN_POLICIES:
        raise LogFormatError("nan", f"`nan` must be one of {', '.join(NAN_POLICIES)}, got {nan!r}.")
    if not (time_tolerance > 0 and math.isfinite(time_tolerance)):
        raise LogFormatError(
            "time_tolerance", f"`time_tolerance` must be > 0, got {time_tolerance}."
        )
    cols = _columns(frame, model, _load_mapping(mapping), source)
    states, inputs = _aliases(model)
    targets = {"t": "s"}
    targets |= dict(zip(model.state_names, model.state_units, strict=True))
    targets |= {a[0]: u for a, u in zip(inputs, model.input_units, strict=True)}
    factors = {}
    for n, target in targets.items():
        try:
            factors[n] = conversion_factor(cols[n][0], n, str(cols[n][1]), target)
        except LogFormatError as exc:
            raise LogFormatError(exc.argument, f"{source}: {exc}") from None

    def numbers(name: str) -> np.ndarray:
        col = cols[name][0]
        try:
            return np.asarray(frame[col], dtype=float)
        except (TypeError, ValueError) as exc:
            raise LogFormatError(col, f"{source}: column {col!r} is not numeric: {exc}") from exc

    t = numbers("t") * factors["t"]
    h, jitter = _check_time(t, time_tolerance, source, csv)
    names = [*model.state_names, *(a[0] for a in inputs)]
    data = np.column_stack([numbers(n) * factors[n] for n in names])
    keep, valid, notes = _nan_policy(data, t, [cols[n][0] for n in names], nan, source, csv)
    t, data = t[keep], data[keep]
    nx = model.nx
    _check_angles(data[:, :nx], model, cols, source)
    converted = [
        f"{cols[n][0]} ({cols[n][1]} -> {targets[n]})" for n in targets if factors[n] != 1.0
    ]
    if converted:
        notes.append("converted " + ", ".join(converted))
    if unwrap:  # before any filling, so that no interpolation spans a wrap-around
        for k, unit in enumerate(model.state_units):
            if unit == "rad":
                ok = np.isfinite(data[:, k])
                w = np.unwrap(data[ok, k])
                if not np.array_equal(w, data[ok, k]):
                    notes.append(f"{model.state_names[k]} unwrapped")
                    data[ok, k] = w
    if not np.isfinite(data).all():
        data = _fill(data, t)
    x, u = data[:, :nx], data[:, nx:]
    n_rows = t.size
    h_mean = (t[-1] - t[0]) / (n_rows - 1)
    traj = Trajectory(
        t=t[0] + h_mean * np.arange(n_rows),
        x=x,
        u=u,
        h=h_mean,
        state_names=tuple(model.state_names),
        state_units=tuple(model.state_units),
        input_names=tuple(model.input_names),
        input_units=tuple(model.input_units),
    )
    return LogData(traj, valid, source, jitter, tuple(notes))


def read_log(
    path: str | os.PathLike[str],
    model: Any,
    *,
    mapping: Any = None,
    nan: str = "error",
    time_tolerance: float = 0.01,
    unwrap: bool = True,
) -> LogData:
    """Read a CSV or Parquet log of ``model`` and validate it (module docstring).

    Parameters
    ----------
    path : str or path
        ``.csv`` (any other suffix is read as CSV too) or ``.parquet``/``.pq``.
    model : Model
        The vehicle the log is of; its state and input names and units are expected.
    mapping : path or mapping, optional
        Column names and units for logs whose header does not follow ``name[unit]``.
    nan : {"error", "drop", "interpolate"}
    time_tolerance : float
        Largest accepted relative deviation of a time step from the median step.
    unwrap : bool
        Unwrap angles (default True).

    Raises
    ------
    LogFormatError (a ValueError)
        naming the column or the first bad row.
    FileNotFoundError
        if there is no file at ``path``.
    """
    import pandas as pd

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no log file {str(path)!r}.")
    parquet = path.suffix.lower() in (".parquet", ".pq")
    try:
        frame = pd.read_parquet(path) if parquet else pd.read_csv(path, skipinitialspace=True)
    except (ValueError, OSError, pd.errors.ParserError) as exc:
        raise LogFormatError("data", f"cannot read {str(path)!r}: {exc}") from exc
    return log_from_frame(
        frame,
        model,
        source=path.name,
        mapping=mapping,
        nan=nan,
        time_tolerance=time_tolerance,
        unwrap=unwrap,
        csv=not parquet,
    )
