"""Read and validate a vehicle log (CSV or Parquet) into a Trajectory.

A log has one row per sample and the columns t, the states of the model (for a
vehicle x, y, z, phi, theta, psi, u, v, w, p, q, r) and its inputs (thruster rpm:
n_r1..n_r8, or n1..n8), each with its unit in the header, ``x[m]``, ``phi[deg]``,
``n1[rpm]``, or given by a mapping file (TOML)::

    [columns]
    "North (ft)" = { name = "x", unit = "ft" }
    "roll" = { unit = "deg" }          # name defaults to the column's
    "stamp" = { name = "t" }           # date-times / ISO-8601 text need no unit

An unknown section, key or column in the mapping file is an error naming it.

Checks, in order, before anything else happens (the first failure raises
:class:`LogFormatError` naming the column or row):

1. every needed column is present once, with a known unit of the right kind;
2. NaN in states or inputs, by the ``nan`` policy: "error" (default); "interpolate"
   (linear in time inside the log, rows at either end trimmed); "drop" (the rows are
   filled for computation but no error is counted on a sample whose prediction
   uses or targets them);
3. time as logged (see :mod:`sampledyn.logs._time`): any clock (s, ms, us, ns, min,
   integer counters, date-times, ISO-8601 text) becomes seconds from the first sample,
   exactly where the source is exact; the absolute start is kept
   (``Trajectory.origin``). Steps must be whole numbers of periods within
   ``time_tolerance``; dropped records follow the ``gaps`` policy ("refuse", "bridge"
   up to ``max_missing`` records in a row, "split" into segments). A uniform log gets
   t = n h; a jittered one keeps its stamps (never snapped to a grid);
4. units: converted to the model's; roll/pitch beyond pi rad or angle steps beyond
   3 pi are reported as a likely deg/rad mix-up;
5. angles are unwrapped (a heading that wraps from 180 deg to -180 deg would
   otherwise look like a 2 pi jump to every predictor).

Every choice made is written to ``LogData.notes`` (printed by ``sampledyn evaluate``).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .._trajectory import Trajectory
from ..exceptions import LogFormatError
from ._mapping import load_toml, table_mapping
from ._time import ClockReader, Sampling, check_policy, sampling
from ._units import conversion_factor, split_header

if TYPE_CHECKING:  # the command line imports this module before the kernels
    from ..models import Model

__all__ = [
    "NAN_POLICIES",
    "TIME_TOLERANCE",
    "LogData",
    "log_from_chunks",
    "log_from_frame",
    "read_table",
    "read_table_log",
]

NAN_POLICIES = ("error", "drop", "interpolate")

# Default largest deviation of a step from a whole number of periods (fraction of h).
TIME_TOLERANCE = 0.25


@dataclass(frozen=True)
class LogData:
    """A validated log in the model's units.

    Attributes
    ----------
    traj : Trajectory
        States and inputs in the model's units; ``t`` in s from the first sample (n h
        on a uniform log, the logged stamps on a jittered one), ``origin`` the
        absolute start as logged.
    valid : ndarray of bool, shape (N,)
        False for rows that held NaN under ``nan="drop"`` (filled by interpolation
        so that f can be evaluated; not to be counted).
    source : str
        File name.
    jitter : float
        Largest |t_{n+1} - t_n - m h| / h of the log (0 on a uniform log).
    notes : tuple of str
        What was done to the data (time rule, gaps, conversions, unwrapping, NaN).
    sampling : Sampling or None
        The sampling rule applied: uniform or jittered, h, gaps, segments.
    rows : ndarray of int, shape (N,), or None
        Data row of the source (0-based) of each sample.
    time_column : str
        The column the times were read from, as the source names it.
    time_unit : str or None
        Its unit as read (header or mapping file: "s", "ms", ..., "datetime"), None
        where the column had none (ISO-8601 text).
    unmeasured : tuple of str
        States the log holds but does not measure (an estimator without a position
        fix holds x, y): predicted, but left out of the error norms.
    warnings : tuple of str
        What makes the log's errors doubtful as a test of the model (a log in air);
        :func:`evaluate_log` passes them on.
    """

    traj: Trajectory
    valid: np.ndarray
    source: str
    jitter: float
    notes: tuple[str, ...]
    sampling: Sampling | None = None
    rows: np.ndarray | None = None
    time_column: str = "t"
    time_unit: str | None = "s"
    unmeasured: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()

    @property
    def segments(self) -> tuple[tuple[int, int], ...]:
        """Row ranges [start, stop) evaluated on their own (one unless the log was
        split at dropped records)."""
        if self.sampling is None:
            return ((0, self.traj.n_samples),)
        return self.sampling.segments


def _row(i: int, csv: bool) -> str:
    """Data row i (0-based) as the user sees it: 1-based, and its line in a CSV."""
    return f"data row {i + 1}" + (f" (line {i + 2})" if csv else "")


def _aliases(model: Model) -> tuple[list[tuple[str, ...]], list[tuple[str, ...]]]:
    states: list[tuple[str, ...]] = [(str(n),) for n in model.state_names]
    inputs: list[tuple[str, ...]] = []
    for i, (n, unit) in enumerate(zip(model.input_names, model.input_units, strict=True)):
        names = [n, f"u{i + 1}"] + ([f"n{i + 1}"] if unit == "rpm" else [])
        inputs.append(tuple(dict.fromkeys(names)))
    return states, inputs


def _columns(
    columns: list[Any], model: Model, mapping: Any, src: str
) -> tuple[dict[str, tuple[str, str | None]], list[str]]:
    """Model quantity -> (log column, unit) for t, every state and every input; and
    the log's columns named like a numbered input the model does not have (n7 on a
    vehicle of 6 thrusters: :func:`_stray_inputs`)."""
    states, inputs = _aliases(model)
    quantities = ["t", "time", *(n for a in states for n in a), *(n for a in inputs for n in a)]
    entries = table_mapping(load_toml(mapping), columns, quantities, src)
    found: dict[str, tuple[str, str | None]] = {}
    for col in columns:
        name, unit = split_header(str(col))
        entry = entries.get(str(col), {})
        name = entry.get("name", name)
        unit = entry.get("unit", unit)
        if name == "time":
            name = "t"
        if name in found:
            raise LogFormatError(
                str(col), f"{src}: two columns for {name!r}: {found[name][0]!r} and {str(col)!r}."
            )
        found[name] = (str(col), unit)
    out: dict[str, tuple[str, str | None]] = {}
    missing = []
    missing_inputs = 0
    for names in [("t",), *states, *inputs]:
        hit = [n for n in names if n in found]
        if not hit:
            missing.append(" or ".join(repr(n) for n in names))
            missing_inputs += names in inputs
            continue
        if len(hit) > 1:
            cols = [found[n][0] for n in hit]
            raise LogFormatError(hit[1], f"{src}: columns {cols} all give {names[0]!r}.")
        out[names[0]] = found[hit[0]]
    if missing and missing_inputs == len(missing):
        given = [out[a[0]][0] for a in inputs if a[0] in out]
        used = {col for col, _ in out.values()}
        other = [c for n, (c, _) in found.items() if c not in used and _NUMBERED.match(n)]
        shown = ", ".join(repr(c) for c in other[:8]) + (", ..." if len(other) > 8 else "")
        raise LogFormatError(
            "columns",
            f"{src}: missing input column {missing[0]}"
            + (f" (and {len(missing) - 1} more)" if len(missing) > 1 else "")
            + f": {_count_inputs(model)}, the log has "
            + (
                f"{len(given)} input column{'s' if len(given) != 1 else ''} "
                f"({', '.join(repr(c) for c in given)})"
                if given
                else "none of them"
            )
            + (
                f"; its {len(other)} numbered column{'s' if len(other) != 1 else ''} "
                f"({shown}) look like the inputs of another model"
                if other
                else ""
            )
            + ". Use a model whose inputs the log holds (a vehicle with as many thrusters "
            "as the log), add the missing columns, or name them in a mapping file.",
        )
    if missing:
        have = ", ".join(repr(str(c)) for c in columns)
        raise LogFormatError(
            "columns",
            f"{src}: missing column {missing[0]}"
            + (f" (and {len(missing) - 1} more)" if len(missing) > 1 else "")
            + f"; the log has {have}. Name columns like 'x[m]', or map them with a mapping file.",
        )
    for name, (col, unit) in out.items():
        if unit is None and name != "t":  # a date-time clock needs no unit (checked later)
            raise LogFormatError(
                col,
                f"{src}: column {col!r} ({name}) has no unit; write it as '{name}[unit]' in "
                "the header or give it in a mapping file.",
            )
    return out, _stray_inputs(found, inputs, {col for col, _ in out.values()})


_NUMBERED = re.compile(r"^(.*?)(\d+)$")


def _stray_inputs(
    found: dict[str, tuple[str, str | None]], inputs: list[tuple[str, ...]], used: set[str]
) -> list[str]:
    """Columns whose name (after the mapping file) is a numbered input name of the
    model's families (n<k>, u<k>, n_r<k> ...) that is not one of its inputs."""
    stems = {m.group(1) for names in inputs for n in names if (m := _NUMBERED.match(n))}
    return [
        col
        for name, (col, _) in found.items()
        if col not in used and (m := _NUMBERED.match(name)) and m.group(1) in stems
    ]


def _count_inputs(model: Model) -> str:
    """'vehicle bluerov2_heavy has 6 thrusters (inputs n_r1..n_r6)' or the like."""
    names = list(model.input_names)
    listed = f"{names[0]}..{names[-1]}" if len(names) > 2 else ", ".join(names)
    n_thr = getattr(model, "n_thrusters", None)
    who = f"vehicle {model.name!r}" if hasattr(model, "name") else "the model"
    if n_thr is not None and not getattr(model, "wrench_input", False):
        return f"{who} has {n_thr} thruster{'s' if n_thr != 1 else ''} (inputs {listed})"
    units = [f"{n} [{u}]" for n, u in zip(names, model.input_units, strict=True)]
    listed = f"{units[0]}..{units[-1]}" if len(units) > 2 else ", ".join(units)
    return f"{who} has {len(names)} input{'s' if len(names) != 1 else ''} ({listed})"


def _check_stray_inputs(stray: list[str], zero: list[bool], model: Model, src: str) -> list[str]:
    """Refuse input columns the model has no input for, unless they are 0 throughout
    (thrusters of a bigger vehicle that were off: leaving them out loses nothing);
    then say so in the notes. ``zero[i]``: column ``stray[i]`` holds numbers, all 0."""
    if not stray:
        return []
    names = ", ".join(repr(c) for c in stray)
    if all(zero):
        return [f"column(s) {names} are 0 throughout; {_count_inputs(model)}: left out"]
    live = ", ".join(repr(c) for c, z in zip(stray, zero, strict=True) if not z)
    raise LogFormatError(
        stray[zero.index(False)],
        f"{src}: column(s) {live} look like inputs (thrusters) the model does not have: "
        f"{_count_inputs(model)}, and the model would ignore them. Use a vehicle with "
        "those thrusters, or remove the columns from the log.",
    )


def _fill(values: np.ndarray, t: np.ndarray) -> None:
    """Interpolate the non-finite entries of ``values`` (N, k) linearly in ``t``, in
    place (no copy of a large log)."""
    for j in range(values.shape[1]):
        ok = np.isfinite(values[:, j])
        if not ok.all():
            values[:, j] = np.interp(t, t[ok], values[ok, j])


def _nan_policy(blocks: _Blocks, nan: str, src: str, csv: bool) -> tuple[np.ndarray, list[str]]:
    """Validity per kept row (rows ``blocks.start`` .. ``blocks.stop``), notes; raises
    under ``nan="error"`` at the first NaN, and for a column without any number."""
    if blocks.first_bad is None:
        return np.ones(blocks.stop - blocks.start, bool), []
    i, col = blocks.first_bad
    if nan == "error":
        raise LogFormatError(
            col,
            f"{src}: column {col!r} is NaN at {_row(i, csv)} ({blocks.n_bad} rows "
            "with NaN). Choose a policy: `nan`='drop' or 'interpolate' (--nan).",
        )
    for col, some in blocks.any_finite.items():
        if not some:
            raise LogFormatError(col, f"{src}: column {col!r} holds no number.")
    notes = []
    trimmed = blocks.rows - (blocks.stop - blocks.start)
    if trimmed:
        notes.append(f"{trimmed} rows with NaN at the ends of the log trimmed")
    inner = blocks.bad[: blocks.stop - blocks.start]
    if nan == "interpolate":
        notes.append(f"{int(inner.sum())} rows with NaN interpolated linearly in time")
        return np.ones(inner.size, bool), notes
    notes.append(f"{int(inner.sum())} rows with NaN dropped from the error norms")
    return ~inner, notes


def _check_angles(
    x: np.ndarray, model: Model, cols: dict[str, tuple[str, str | None]], src: str
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


def _unwrap_angles(data: np.ndarray, model: Model) -> list[str]:
    """Unwrap the angle columns of ``data`` in place (NaN rows skipped); notes."""
    notes = []
    for k, unit in enumerate(model.state_units):
        if unit == "rad":
            ok = np.isfinite(data[:, k])
            w = np.unwrap(data[ok, k])
            if not np.array_equal(w, data[ok, k]):
                notes.append(f"{model.state_names[k]} unwrapped")
                data[ok, k] = w
    return notes


# Rows per chunk of a table read from a file: a chunk's text and temporaries stay in the
# tens of MB whatever the length of the log.
CHUNK_ROWS = 1 << 16


@dataclass(frozen=True)
class _Layout:
    """Where the model's quantities are in a log's columns, and their conversions."""

    columns: tuple[str, ...]  # every column of the log, as named
    cols: dict[str, tuple[str, str | None]]  # quantity -> (column, unit)
    stray: tuple[str, ...]  # input-like columns the model has no input for
    names: tuple[str, ...]  # states, then inputs (canonical names)
    factors: dict[str, float]  # quantity -> factor to the model's unit
    targets: dict[str, str]  # quantity -> the model's unit

    @property
    def needed(self) -> list[str]:
        """The columns read: time, states, inputs, stray inputs (others skipped)."""
        return list(dict.fromkeys([self.cols["t"][0], *(self.cols[n][0] for n in self.names),
                                   *self.stray]))  # fmt: skip


def _layout(columns: list[Any], model: Any, mapping: Any, source: str) -> _Layout:
    cols, stray = _columns(columns, model, mapping, source)
    _states, inputs = _aliases(model)
    targets = dict(zip(model.state_names, model.state_units, strict=True))
    targets |= {a[0]: u for a, u in zip(inputs, model.input_units, strict=True)}
    factors = {}
    for n, target in targets.items():
        try:
            factors[n] = conversion_factor(cols[n][0], n, str(cols[n][1]), target)
        except LogFormatError as exc:
            raise LogFormatError(exc.argument, f"{source}: {exc}") from None
    names = (*model.state_names, *(a[0] for a in inputs))
    return _Layout(tuple(str(c) for c in columns), cols, tuple(stray), names, factors, targets)


@dataclass
class _Blocks:
    """A log's numbers gathered chunk by chunk (:class:`_Gatherer`): states and inputs in
    the model's units, rows ``start`` .. ``stop`` (the ends without NaN rows trimmed),
    the time column read, and what the NaN and stray-input checks need."""

    x: np.ndarray
    u: np.ndarray
    clock: Any
    rows: int
    start: int
    stop: int
    bad: np.ndarray  # per kept row: holds a NaN
    n_bad: int
    first_bad: tuple[int, str] | None
    any_finite: dict[str, bool]
    stray_zero: list[bool]


def _numbers(chunk: Any, col: str, source: str) -> np.ndarray:
    try:
        return np.asarray(chunk[col], dtype=float)
    except (TypeError, ValueError) as exc:
        raise LogFormatError(col, f"{source}: column {col!r} is not numeric: {exc}") from exc


class _Gatherer:
    """One pass over a log's chunks (DataFrames of its rows, in order) into a
    :class:`_Blocks`; memory: the arrays kept plus one chunk."""

    def __init__(self, layout: _Layout, model: Any, capacity: int, source: str):
        self.layout, self.source = layout, source
        self.reader: Any = None  # the ClockReader of the time column
        self.nx = int(model.nx)
        self.data_cols = [layout.cols[n][0] for n in layout.names]
        width = len(layout.names)
        self.x = np.empty((capacity, self.nx))
        self.u = np.empty((capacity, width - self.nx))
        self.bad = np.zeros(capacity, dtype=bool)
        self.rows = 0  # rows seen
        self.start: int | None = None  # first row without NaN
        self.stop = 0  # one past the last row without NaN
        self.filled = 0  # rows stored from `start` on
        self.n_bad = 0
        self.first_bad: tuple[int, str] | None = None
        self.any_finite = dict.fromkeys(self.data_cols, False)
        self.stray_zero = {c: [True, False] for c in layout.stray}  # (all 0, some finite)
        self.pending: list[Any] = []  # time stamps after the last good row (maybe trimmed)

    def add(self, chunk: Any) -> None:
        n = len(chunk)
        block = np.empty((n, len(self.data_cols)))
        for j, (name, col) in enumerate(zip(self.layout.names, self.data_cols, strict=True)):
            block[:, j] = _numbers(chunk, col, self.source)
            factor = self.layout.factors[name]
            if factor != 1.0:
                block[:, j] *= factor
        finite = np.isfinite(block)
        row_bad = np.asarray(~finite.all(axis=1))
        for j, col in enumerate(self.data_cols):
            self.any_finite[col] = self.any_finite[col] or bool(finite[:, j].any())
        for col in self.layout.stray:
            self._stray(chunk, col)
        if row_bad.any():
            if self.first_bad is None:
                i = int(np.argmax(row_bad))
                self.first_bad = (self.rows + i, self.data_cols[int(np.argmax(~finite[i]))])
            self.n_bad += int(row_bad.sum())
        good = np.flatnonzero(~row_bad)
        skip = 0
        if self.start is None:
            if not good.size:
                self.rows += n
                return
            skip = int(good[0])
            self.start = self.rows + skip
        k = n - skip
        self._grow(self.filled + k)
        self.x[self.filled : self.filled + k] = block[skip:, : self.nx]
        self.u[self.filled : self.filled + k] = block[skip:, self.nx :]
        self.bad[self.filled : self.filled + k] = row_bad[skip:]
        self.filled += k
        times = chunk[self.layout.cols["t"][0]]
        times = times.iloc[skip:] if hasattr(times, "iloc") else times[skip:]
        if good.size:
            last = int(good[-1]) - skip  # in `times`
            self.stop = self.rows + skip + last + 1
            for part in self.pending:
                self.reader.add(part)
            self.pending = []
            head = times.iloc[: last + 1] if hasattr(times, "iloc") else times[: last + 1]
            self.reader.add(head)
            times = times.iloc[last + 1 :] if hasattr(times, "iloc") else times[last + 1 :]
        if len(times):
            self.pending.append(times)
        self.rows += n

    def _stray(self, chunk: Any, col: str) -> None:
        flags = self.stray_zero[col]
        try:
            values = np.asarray(chunk[col], dtype=float)
        except (TypeError, ValueError):
            flags[0] = False  # text: not an input that was off
            return
        ok = np.isfinite(values)
        flags[0] = flags[0] and bool(np.all(values[ok] == 0.0))
        flags[1] = flags[1] or bool(ok.any())

    def _grow(self, need: int) -> None:
        """More rows than the file's line count promised (never for a CSV): double."""
        if need <= self.x.shape[0]:
            return
        size = max(need, 2 * self.x.shape[0])
        self.x = np.concatenate([self.x, np.empty((size - self.x.shape[0], self.x.shape[1]))])
        self.u = np.concatenate([self.u, np.empty((size - self.u.shape[0], self.u.shape[1]))])
        self.bad = np.concatenate([self.bad, np.zeros(size - self.bad.size, dtype=bool)])

    def blocks(self) -> _Blocks:
        start = self.rows if self.start is None else self.start
        kept = max(0, self.stop - start)
        x, u = _shrink(self.x, kept), _shrink(self.u, kept)
        stray_zero = [a and b for a, b in (self.stray_zero[c] for c in self.layout.stray)]
        return _Blocks(x, u, self.reader, self.rows, start, start + kept, self.bad[:kept],
                       self.n_bad, self.first_bad, self.any_finite, stray_zero)  # fmt: skip


def _shrink(a: np.ndarray, rows: int) -> np.ndarray:
    """The first ``rows`` rows of ``a``, resized in place where ``a`` owns its memory
    (no second copy of a large log)."""
    if rows == a.shape[0]:
        return a
    if a.base is None and a.flags.c_contiguous:
        a.resize((rows, *a.shape[1:]), refcheck=False)
        return a
    return np.ascontiguousarray(a[:rows])


def log_from_frame(
    frame: Any,
    model: Model,
    *,
    source: str = "<frame>",
    mapping: Any = None,
    nan: str = "error",
    time_tolerance: float = TIME_TOLERANCE,
    unwrap: bool = True,
    csv: bool = False,
    gaps: str = "refuse",
    max_missing: int = 1,
    notes: tuple[str, ...] = (),
    irregular: bool = False,
    unmeasured: tuple[str, ...] = (),
    warnings: tuple[str, ...] = (),
) -> LogData:
    """Validate a pandas DataFrame as a log of ``model`` (see the module docstring).

    ``notes`` are prepended to the log's notes (how a bag or DataFlash log was
    turned into this frame); ``unmeasured`` and ``warnings`` go to the LogData as
    they are. Other parameters: :func:`read_log`.
    """
    return log_from_chunks(
        [frame], len(frame), list(frame.columns), model, source=source, mapping=mapping,
        nan=nan, time_tolerance=time_tolerance, unwrap=unwrap, csv=csv, gaps=gaps,
        max_missing=max_missing, notes=notes, irregular=irregular, unmeasured=unmeasured,
        warnings=warnings,
    )  # fmt: skip


def log_from_chunks(
    chunks: Any,
    capacity: int,
    columns: list[Any],
    model: Any,
    *,
    source: str = "<frame>",
    mapping: Any = None,
    nan: str = "error",
    time_tolerance: float = TIME_TOLERANCE,
    unwrap: bool = True,
    csv: bool = False,
    gaps: str = "refuse",
    max_missing: int = 1,
    notes: tuple[str, ...] = (),
    irregular: bool = False,
    unmeasured: tuple[str, ...] = (),
    warnings: tuple[str, ...] = (),
) -> LogData:
    """:func:`log_from_frame` for a log given as consecutive DataFrames (``chunks``,
    each with the ``columns`` of the log, or only those the model uses), about
    ``capacity`` rows in all (an upper bound saves a copy). Memory: the arrays of the
    returned LogData and one chunk."""
    if nan not in NAN_POLICIES:
        raise LogFormatError("nan", f"`nan` must be one of {', '.join(NAN_POLICIES)}, got {nan!r}.")
    check_policy(gaps, max_missing, time_tolerance)
    layout = _layout(columns, model, mapping, source)
    tcol, tunit = layout.cols["t"]
    gatherer = _Gatherer(layout, model, capacity, source)
    # Stamps are read from the first row without NaN on (the rows before are trimmed).
    gatherer.reader = ClockReader(tunit, tcol, source,
                                  lambda i: _row((gatherer.start or 0) + i, csv))  # fmt: skip
    for chunk in chunks:
        gatherer.add(chunk)
    blocks = gatherer.blocks()
    reader = gatherer.reader
    if blocks.rows == 0:
        raise LogFormatError(
            "data",
            f"{source}: the log has no data rows (a header only); it needs at least 3 "
            "samples, one per row.",
        )
    stray_notes = _check_stray_inputs(list(layout.stray), blocks.stray_zero, model, source)
    valid, nan_notes = _nan_policy(blocks, nan, source, csv)

    def row(i: int) -> str:
        return _row(blocks.start + i, csv)

    clock = reader.clock()
    smp = sampling(
        clock,
        tolerance=time_tolerance,
        gaps=gaps,
        max_missing=max_missing,
        src=source,
        row=row,
        irregular=irregular,
    )
    t = smp.t
    x, u = blocks.x, blocks.u
    cols = layout.cols
    _check_angles(x, model, cols, source)
    out_notes = [*notes, *smp.notes, *nan_notes, *stray_notes]
    converted = [f"{cols[n][0]} ({cols[n][1]} -> {layout.targets[n]})"
                 for n in layout.targets if layout.factors[n] != 1.0]  # fmt: skip
    if converted:
        out_notes.append("converted " + ", ".join(converted))
    used = {str(cols[n][0]) for n in (*layout.names, "t")} | set(layout.stray)
    unused = [c for c in layout.columns if c not in used]
    if unused:
        more = f" and {len(unused) - 8} more" if len(unused) > 8 else ""
        out_notes.append(f"columns not used by the model: {', '.join(unused[:8])}{more}")
    if unwrap:  # before any filling, so that no interpolation spans a wrap-around
        out_notes += _unwrap_angles(x, model)
    if blocks.n_bad:
        _fill(x, t)
        _fill(u, t)
    for a in (x, u):
        a.setflags(write=False)  # owned, read-only: the Trajectory takes them as they are
    traj = Trajectory(
        t=t,
        x=x,
        u=u,
        h=smp.h,
        state_names=tuple(model.state_names),
        state_units=tuple(model.state_units),
        input_names=tuple(model.input_names),
        input_units=tuple(model.input_units),
        origin=clock.origin,
    )
    rows = np.arange(blocks.start, blocks.stop)
    return LogData(
        traj,
        valid,
        source,
        smp.jitter,
        tuple(out_notes),
        smp,
        rows,
        str(tcol),
        tunit,
        tuple(unmeasured),
        tuple(warnings),
    )


def _refuse_repeated_columns(path: Path) -> None:
    """A CSV header naming a column twice (pandas would rename the second 'x[m].1' and
    the first would be used without a word)."""
    import csv

    with path.open(newline="", encoding="utf-8-sig") as fh:
        names = [n.strip() for n in next(csv.reader(fh), [])]
    twice = sorted({n for n in names if n and names.count(n) > 1})
    if twice:
        where = ", ".join(
            f"{n!r} (columns {', '.join(str(i + 1) for i, m in enumerate(names) if m == n)})"
            for n in twice
        )
        raise LogFormatError(
            twice[0],
            f"{path.name}: the header names {where} more than once; which one holds the "
            "data is ambiguous. Rename or remove the extra column.",
        )


def _said(path: Path, exc: Exception) -> bool:
    """``exc`` says what is wrong as it is: a LogFormatError, or a file error about
    another file than the log (its mapping file)."""
    if isinstance(exc, LogFormatError):
        return True
    return isinstance(exc, OSError) and exc.filename is not None and str(exc.filename) != str(path)


def _unreadable(path: Path, exc: Exception) -> LogFormatError:
    """The error of a table that cannot be read: an empty file, or bytes that are no
    text, said as such; else what pandas or the system said."""
    import pandas as pd

    from ._formats import FORMATS_RECOGNISED

    if isinstance(exc, pd.errors.EmptyDataError):
        return LogFormatError(
            "data", f"{str(path)!r} is empty (no header, no rows): no log to read."
        )
    if isinstance(exc, UnicodeDecodeError):
        return LogFormatError(
            "data",
            f"{str(path)!r} is no log of a format read: it is not UTF-8 text (byte "
            f"{exc.start}: {exc.object[exc.start : exc.start + 1]!r}), so no CSV, and none "
            f"of the binary formats recognised; formats read: {FORMATS_RECOGNISED}.",
        )
    return LogFormatError("data", f"cannot read {str(path)!r}: {exc}")


def read_table(path: Path, model: Model, mapping: Any) -> tuple[Any, bool]:
    """A CSV or Parquet file as a DataFrame; a CSV's time column is read as text, so
    that decimal stamps (1700000000.123456789) are read exactly."""
    import pandas as pd

    parquet = path.suffix.lower() in (".parquet", ".pq")
    try:
        if parquet:
            return pd.read_parquet(path), False
        header = pd.read_csv(path, skipinitialspace=True, nrows=0)
        _refuse_repeated_columns(path)
        tcol = _columns(list(header.columns), model, mapping, path.name)[0]["t"][0]
        return pd.read_csv(path, skipinitialspace=True, dtype={tcol: str}), True
    except (ValueError, OSError, pd.errors.ParserError) as exc:
        if _said(path, exc):
            raise
        raise _unreadable(path, exc) from exc


def _count_rows(path: Path) -> int:
    """Lines of a text file (an upper bound of its data rows plus the header), in
    blocks of 16 MiB."""
    lines = 0
    with path.open("rb") as fh:
        while block := fh.read(16 << 20):
            lines += block.count(b"\n")
    return lines + 1


def _table_chunks(path: Path, model: Model, mapping: Any) -> tuple[Any, int, list[Any], bool]:
    """(chunks of the columns the model uses, a bound of the rows, every column, csv)
    of a CSV or Parquet file, read lazily: a CSV's time column as text, so that
    decimal stamps (1700000000.123456789) are read exactly."""
    import pandas as pd

    if path.suffix.lower() in (".parquet", ".pq"):
        import pyarrow.parquet as pq

        pf = pq.ParquetFile(path)
        columns = list(pf.schema_arrow.names)
        needed = _layout(columns, model, mapping, path.name).needed
        batches = pf.iter_batches(batch_size=CHUNK_ROWS, columns=needed)
        return (b.to_pandas() for b in batches), int(pf.metadata.num_rows), columns, False
    columns = list(pd.read_csv(path, skipinitialspace=True, nrows=0).columns)
    _refuse_repeated_columns(path)
    layout = _layout(columns, model, mapping, path.name)
    tcol = layout.cols["t"][0]
    chunks = pd.read_csv(path, skipinitialspace=True, usecols=layout.needed, dtype={tcol: str},
                         chunksize=CHUNK_ROWS)  # fmt: skip
    return chunks, _count_rows(path), columns, True


def read_table_log(path: Path, model: Model, *, mapping: Any = None, **options: Any) -> LogData:
    """A CSV or Parquet log (the reader of the "csv" and "parquet" formats), read in
    chunks of :data:`CHUNK_ROWS` rows: memory about the arrays returned (10 million
    rows of 21 columns: benchmarks/bench_log_memory.py)."""
    import pandas as pd

    try:
        chunks, capacity, columns, csv = _table_chunks(path, model, mapping)
        return log_from_chunks(chunks, capacity, columns, model, source=path.name,
                               mapping=mapping, csv=csv, **options)  # fmt: skip
    except (ValueError, OSError, pd.errors.ParserError) as exc:
        if _said(path, exc):
            raise
        raise _unreadable(path, exc) from exc
