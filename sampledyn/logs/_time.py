"""Time as logged: any clock to seconds from the first sample, and the sampling rule.

Clocks read (the column's unit in the header or mapping file):

========================  ===========================  ==============================
column holds              unit                         resolution taken as
========================  ===========================  ==============================
numbers (float)           s, ms, us (or µs), ns, min   one rounding unit of the
                                                       largest stamp (float64)
integers (a counter)      s, ms, us, ns, min           one count
decimal text (CSV)        s, ms, us, ns, min           the last printed decimal
                                                       (read exactly, not as float)
date-times (datetime64)   none, or "datetime"          the dtype's unit (ns)
ISO-8601 text             none, or "datetime"          the last printed decimal
========================  ===========================  ==============================

Every clock becomes an exact integer count where the source is exact (counters,
decimal text, date-times, ISO-8601 text), and the offsets from the first sample are
taken on those integers: a Unix time of 1.7e9 s loses nothing, and t0 + n h is never
formed at 1.7e9. A date-time column never passes as a number: a unit such as "s" on
it is an error. ISO-8601 text with a time-zone offset is converted to UTC; text
without one is taken as it is (offsets do not depend on the zone); a mix is an error.

Sampling (on the offsets): h0 is the median step; every step must be within
``tolerance`` h0 of a whole number m >= 1 of periods (else the log is irregular and
refused). Steps with m > 1 are dropped records (m - 1 missing), handled by the gap
policy. The log is *uniform* if every stamp lies within the clock's resolution of the
grid n h (h = span / number of periods): its times are then n h exactly. Otherwise it
is *jittered*: the stamps are kept as logged (never snapped to a grid) and h is the
median of the one-period steps.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

import numpy as np

from .. import _checks as checks
from ..exceptions import LogFormatError

__all__ = [
    "CLOCK_UNITS",
    "GAP_POLICIES",
    "TIME_UNITS",
    "Clock",
    "ClockReader",
    "Sampling",
    "read_clock",
]

# unit -> (multiplier, divisor) taking the unit to seconds exactly in integer steps
TIME_UNITS: dict[str, tuple[int, int]] = {
    "s": (1, 1),
    "ms": (1, 1_000),
    "us": (1, 1_000_000),
    "µs": (1, 1_000_000),
    "ns": (1, 1_000_000_000),
    "min": (60, 1),
}
CLOCK_UNITS = ("datetime", "iso8601")
GAP_POLICIES = ("refuse", "bridge", "split")

_DECIMAL = re.compile(r"^\s*([+-]?)(\d*)(?:\.(\d*))?\s*$")
_ZONE = re.compile(r"(?:Z|[+-]\d\d(?::?\d\d)?)$")
_UNIX_RANGE = (631_152_000, 4_102_444_800)  # 1990-01-01 .. 2100-01-01 (s)


@dataclass(frozen=True)
class Clock:
    """A time column read as offsets from its first stamp.

    Attributes
    ----------
    offsets : ndarray, shape (N,)
        Seconds from the first stamp (float64), from exact integer differences where
        the source is exact.
    origin : str
        The first stamp as logged (and its UTC date where it reads as one).
    resolution : float
        Finest step the stamps can express (s).
    kind : str
        How the column was read, for the notes.
    """

    offsets: np.ndarray
    origin: str
    resolution: float
    kind: str


def _unix(seconds: float) -> str:
    if _UNIX_RANGE[0] <= seconds <= _UNIX_RANGE[1]:
        iso = datetime.fromtimestamp(seconds, UTC).isoformat(timespec="microseconds")
        return f" (as Unix time: {iso})"
    return ""


def _from_ticks(ticks: np.ndarray, per_second: float, mult: int) -> np.ndarray:
    """Offsets (s) from integer ticks of 1/per_second unit; exact integer difference."""
    diff = ticks - ticks[0]
    return diff.astype(np.float64) / per_second * mult


def _check_increasing(t: np.ndarray, column: str, src: str, row: Callable[[int], str]) -> None:
    d = np.diff(t)
    if (d <= 0).any():
        i = int(np.argmax(d <= 0))
        raise LogFormatError(
            "t",
            f"{src}: t is not strictly increasing at {row(i + 1)}: the stamp in column "
            f"{column!r} is {t[i + 1] - t[0]:.9g} s after the first, the one before "
            f"{t[i] - t[0]:.9g} s.",
        )


def _datetime_ns(
    values: Any, column: str, src: str, row: Callable[[int], str], at: int
) -> tuple[np.ndarray, bool, str]:
    """(int64 ns since the epoch (UTC if zoned), zoned, the dtype's unit) of date-times."""
    import pandas as pd

    s = pd.Series(values)
    if s.isna().any():
        i = at + int(np.argmax(s.isna().to_numpy()))
        raise LogFormatError("t", f"{src}: t is missing (NaT) at {row(i)}.")
    aware = getattr(s.dtype, "tz", None) is not None
    naive = s.dt.tz_convert("UTC").dt.tz_localize(None) if aware else s
    ns = np.asarray(naive, dtype="datetime64[ns]").view(np.int64)
    unit = np.datetime_data(np.asarray(naive).dtype)[0] if not aware else "ns"
    return ns, aware, str(unit)


def _iso_ns(
    text: Any, column: str, src: str, row: Callable[[int], str], at: int
) -> tuple[np.ndarray, bool, int]:
    """(int64 ns, zoned, digits of the fraction) of one chunk of ISO-8601 text."""
    import pandas as pd

    s = pd.Series(np.asarray(text, dtype=object)).astype(str).str.strip()
    zoned = s.str.contains(_ZONE)
    if zoned.any() and not zoned.all():
        i = int(np.argmax(~zoned if zoned.iloc[0] else zoned))
        raise LogFormatError(
            "t",
            f"{src}: column {column!r} mixes ISO-8601 times with and without a time zone "
            f"(first change at {row(at + i)}: {s.iloc[i]!r}); give every stamp a zone.",
        )
    try:
        stamps = pd.to_datetime(s, format="ISO8601", utc=bool(zoned.all()))
    except (ValueError, TypeError) as exc:
        bad = pd.to_datetime(s, format="ISO8601", errors="coerce").isna()
        i = int(np.argmax(bad.to_numpy()))
        raise LogFormatError(
            "t",
            f"{src}: column {column!r} is neither numbers nor ISO-8601 date-times "
            f"({row(at + i)}: {s.iloc[i]!r}): {exc}",
        ) from None
    fraction = s.str.extract(r"T?\d\d:\d\d:\d\d\.(\d+)", expand=False).str.len()
    digits = int(min(9, fraction.max())) if fraction.notna().any() else 0
    ns, _aware, _unit = _datetime_ns(stamps, column, src, row, at)
    return ns, bool(zoned.all()), digits


def _decimal_ticks(text: Any) -> tuple[np.ndarray, int] | None:
    """(integer ticks of 10^-digits, digits) of decimal numbers written as text
    (``[+-]digits[.digits]``, blanks around allowed); None if some are not plain
    decimals (e.g. '1.7e9') or too long to be exact in 64-bit integers (2^62).
    Vectorised: one chunk of a log of any length at numpy's speed."""
    s = np.char.strip(np.asarray(text, dtype=str))
    if s.size == 0:
        return np.zeros(0, dtype=np.int64), 0
    lead = np.char.lstrip(s, "+-")
    negative = np.char.startswith(s, "-")
    if (np.char.str_len(s) - np.char.str_len(lead) > 1).any():
        return None
    split = np.char.partition(lead, ".")
    whole, frac = split[:, 0], split[:, 2]
    plain = (np.char.isdecimal(whole) | (whole == "")) & (np.char.isdecimal(frac) | (frac == ""))
    plain &= (whole != "") | (frac != "")
    if not plain.all():
        return None
    digits = int(np.char.str_len(frac).max())
    joined = np.char.add(whole, np.char.ljust(frac, digits, "0"))
    if (np.char.str_len(joined) > 19).any():
        return None
    try:
        values = np.char.add("0", joined).astype(np.int64)  # "0" for an empty whole part
    except (OverflowError, ValueError):
        return None
    if int(values.max()) >= 2**62:
        return None
    return np.where(negative, -values, values), digits


def _is_text(dtype: Any) -> bool:
    return dtype.kind == "O" or str(dtype).startswith(("string", "str"))


class ClockReader:
    """Reads a time column (see the module docstring) chunk by chunk: a log of any
    length in the memory of its offsets (8 bytes a row) and one chunk.

    Parameters
    ----------
    unit : str or None
        The column's unit from the header or mapping file.
    column, src : str
        Column and file names for messages.
    row : callable
        Row index (0-based, over all chunks) -> how the user sees that row.

    Chunks given to :meth:`add` must be of one kind (all text, all numbers, all
    date-times); :meth:`clock` reads them as one column.
    """

    def __init__(self, unit: str | None, column: str, src: str, row: Callable[[int], str]):
        if unit is not None and unit not in TIME_UNITS and unit not in CLOCK_UNITS:
            raise LogFormatError(
                column,
                f"{src}: column {column!r}: unknown time unit {unit!r}; accepted: "
                f"{', '.join(TIME_UNITS)} for numbers, 'datetime' for date-times.",
            )
        self.unit, self.column, self.src, self.row = unit, column, src, row
        self.mode: str | None = None
        self.count = 0
        self.first = ""
        self.parts: list[Any] = []
        self.floats: list[np.ndarray] | None = []  # text read as numbers, or None
        self.float_error: Exception | None = None
        self.exact = True  # every text chunk a plain decimal
        self.flags: dict[str, Any] = {}

    def _mode_of(self, dtype: Any) -> str:
        import pandas as pd

        column, src, unit = self.column, self.src, self.unit
        if pd.api.types.is_datetime64_any_dtype(dtype):
            if unit in TIME_UNITS:
                raise LogFormatError(
                    column,
                    f"{src}: column {column!r} holds date-times ({dtype}), not numbers in "
                    f"{unit!r}: drop the unit or give unit = 'datetime'.",
                )
            return "datetime"
        if unit in CLOCK_UNITS or (unit is None and _is_text(dtype)):
            if _is_text(dtype):
                return "iso"
            raise LogFormatError(
                column,
                f"{src}: column {column!r} holds numbers ({dtype}), not date-times: give its "
                f"unit ({', '.join(TIME_UNITS)}).",
            )
        if unit is None:
            raise LogFormatError(
                column,
                f"{src}: column {column!r} (t) has no unit; write it as 't[s]' (or ms, us, "
                "ns) in the header or give it in a mapping file.",
            )
        if _is_text(dtype):
            return "text"
        return "int" if dtype.kind in "iu" else "float"

    def add(self, values: Any) -> None:
        """Read one chunk (array-like or pandas Series, shape (n,))."""
        dtype = getattr(values, "dtype", None)
        if dtype is None:
            values = np.asarray(values)
            dtype = values.dtype
        mode = self._mode_of(dtype)
        if self.mode is None:
            self.mode = mode
        elif mode != self.mode:
            raise LogFormatError(
                self.column,
                f"{self.src}: column {self.column!r} changes what it holds at "
                f"{self.row(self.count)} ({self.mode} before, {mode} there).",
            )
        n = len(values)
        if n == 0:
            return
        if not self.first:
            first = values.iloc[0] if hasattr(values, "iloc") else values[0]
            self.first = str(first).strip()
        getattr(self, f"_add_{mode}")(values)
        self.count += n

    def _add_datetime(self, values: Any) -> None:
        import pandas as pd

        ns, aware, unit = _datetime_ns(values, self.column, self.src, self.row, self.count)
        if not self.parts:
            self.flags.update(aware=aware, unit=unit,
                              first=pd.Timestamp(pd.Series(values).iloc[0]))  # fmt: skip
        self.parts.append(ns)

    def _add_iso(self, values: Any) -> None:
        ns, zoned, digits = _iso_ns(values, self.column, self.src, self.row, self.count)
        if self.parts and zoned != self.flags["zoned"]:
            raise LogFormatError(
                "t",
                f"{self.src}: column {self.column!r} mixes ISO-8601 times with and without a "
                f"time zone (first change at or after {self.row(self.count)}); give every "
                "stamp a zone.",
            )
        self.flags["zoned"] = zoned
        self.flags["digits"] = max(digits, self.flags.get("digits", 0))
        self.parts.append(ns)

    def _add_text(self, values: Any) -> None:
        ticks = _decimal_ticks(values) if self.exact else None
        if ticks is None:
            self.exact = False
        else:
            self.parts.append(ticks)
        if self.floats is not None:
            try:
                self.floats.append(np.asarray(values, dtype=float))
            except (TypeError, ValueError) as exc:
                self.floats, self.float_error = None, exc
                self.flags["text"] = values  # for the hint (does it look like ISO?)
        if not self.exact and self.floats is None:
            self._not_numeric()

    def _not_numeric(self) -> None:
        values = self.flags.get("text")
        name = str(self.column).split("[", 1)[0]
        hint = (
            f"; it holds date-time text: drop the unit ('{name}' in the header, or "
            "unit = 'datetime' in a mapping file) to read it as ISO-8601"
            if values is not None and _looks_like_iso(values)
            else ""
        )
        raise LogFormatError(
            self.column,
            f"{self.src}: column {self.column!r} is not numeric: {self.float_error}{hint}",
        ) from self.float_error

    def _add_int(self, values: Any) -> None:
        self.parts.append(np.asarray(values, dtype=np.int64))

    def _add_float(self, values: Any) -> None:
        try:
            t = np.asarray(values, dtype=float)
        except (TypeError, ValueError) as exc:
            raise LogFormatError(
                self.column, f"{self.src}: column {self.column!r} is not numeric: {exc}"
            ) from exc
        bad = ~np.isfinite(t)
        if bad.any():
            raise LogFormatError(
                "t", f"{self.src}: t is NaN or inf at {self.row(self.count + int(np.argmax(bad)))}."
            )
        self.parts.append(t)

    def clock(self) -> Clock:
        """The column read so far as a :class:`Clock`.

        Raises
        ------
        LogFormatError
            for stamps that do not increase (and what :meth:`add` raises).
        """
        if self.mode is None or self.count == 0:
            raise LogFormatError("t", f"{self.src}: column {self.column!r} holds no time stamp.")
        clock = getattr(self, f"_clock_{self.mode}")()
        _check_increasing(clock.offsets, self.column, self.src, self.row)
        return clock

    def _joined(self, parts: list[np.ndarray] | None = None) -> np.ndarray:
        parts = self.parts if parts is None else parts
        out = parts[0] if len(parts) == 1 else np.concatenate(parts)
        self.parts = []
        return out

    def _clock_datetime(self) -> Clock:
        f = self.flags
        first = f["first"].tz_convert("UTC").tz_localize(None) if f["aware"] else f["first"]
        origin = (
            f"{first.isoformat()}+00:00" if f["aware"] else f"{first.isoformat()} (no time zone)"
        )
        resolution = {"s": 1.0, "ms": 1e-3, "us": 1e-6}.get(f["unit"], 1e-9)
        kind = "date-times" + (" (UTC)" if f["aware"] else "")
        return Clock(_from_ticks(self._joined(), 1e9, 1), origin, resolution, kind)

    def _clock_iso(self) -> Clock:
        import pandas as pd

        ns = self._joined()
        first = pd.Timestamp(int(ns[0]), unit="ns").isoformat()
        zoned = self.flags["zoned"]
        origin = f"{first}+00:00" if zoned else f"{first} (no time zone)"
        kind = "ISO-8601 text" + (", converted to UTC" if zoned else ", no time zone")
        return Clock(_from_ticks(ns, 1e9, 1), origin, 10.0 ** -self.flags["digits"], kind)

    def _clock_text(self) -> Clock:
        assert self.unit is not None
        mult, div = TIME_UNITS[self.unit]
        if self.exact:
            digits = max(d for _t, d in self.parts)
            # Chunks with fewer printed decimals, to the finest one (exact if it fits).
            fits = all(int(np.abs(t).max()) * 10 ** (digits - d) < 2**62 for t, d in self.parts)
            if fits:
                scaled = [t * 10 ** (digits - d) if d < digits else t for t, d in self.parts]
                self.floats = None
                ticks = self._joined(scaled)
                offsets = _from_ticks(ticks, 10.0**digits * div, mult)
                origin = f"{self.first} {self.unit}" + _unix(float(self.first) * mult / div)
                return Clock(offsets, origin, 10.0**-digits * mult / div,
                             f"decimal text in {self.unit} (read exactly)")  # fmt: skip
        if self.floats is None:
            self._not_numeric()
        self.parts = self.floats or []
        self.floats = None
        return self._clock_float()

    def _clock_int(self) -> Clock:
        assert self.unit is not None
        mult, div = TIME_UNITS[self.unit]
        ticks = self._joined()
        return Clock(
            _from_ticks(ticks, float(div), mult),
            f"{int(ticks[0])} {self.unit}" + _unix(int(ticks[0]) * mult / div),
            mult / div,
            f"integer counter in {self.unit}",
        )

    def _clock_float(self) -> Clock:
        assert self.unit is not None
        mult, div = TIME_UNITS[self.unit]
        t = self._joined()
        bad = ~np.isfinite(t)
        if bad.any():
            i = int(np.argmax(bad))
            raise LogFormatError("t", f"{self.src}: t is NaN or inf at {self.row(i)}.")
        offsets = (t - t[0]) / div * mult
        resolution = float(np.spacing(np.abs(t).max())) / div * mult
        first = float(t[0])
        return Clock(
            offsets,
            f"{first!r} {self.unit}" + _unix(first * mult / div),
            resolution,
            f"numbers in {self.unit}",
        )


def read_clock(
    values: Any, unit: str | None, column: str, src: str, row: Callable[[int], str]
) -> Clock:
    """Read a time column (see the module docstring); :class:`ClockReader` with one
    chunk.

    Parameters
    ----------
    values : array-like or pandas Series, shape (N,)
    unit : str or None
        The column's unit from the header or mapping file.
    column, src : str
        Column and file names for messages.
    row : callable
        Row index -> how the user sees that row ("data row 5 (line 6)").

    Raises
    ------
    LogFormatError
        naming the column: a unit that does not fit what the column holds (a
        date-time column with "s"), NaN or NaT stamps, text that is neither numbers
        nor ISO-8601, stamps that do not increase.
    """
    reader = ClockReader(unit, column, src, row)
    reader.add(values)
    return reader.clock()


@dataclass(frozen=True)
class Sampling:
    """How a log is sampled (see the module docstring).

    Attributes
    ----------
    t : ndarray, shape (N,)
        Sample times (s from the first sample): n h on a uniform log (with gaps where
        records are missing), the logged offsets on a jittered one.
    h : float
        Sampling period (uniform) or nominal period (median one-period step).
    uniform : bool
        Every stamp within the clock's resolution of the grid.
    jitter : float
        Largest |t_{n+1} - t_n - m h| / h over the steps (m periods each).
    gaps : tuple of (int, int)
        (row before the gap, records missing) for every dropped-record gap.
    segments : tuple of (int, int)
        Row ranges [start, stop) evaluated on their own (one unless split).
    notes : tuple of str
        The rule applied, for the output.
    """

    t: np.ndarray
    h: float
    uniform: bool
    jitter: float
    gaps: tuple[tuple[int, int], ...]
    segments: tuple[tuple[int, int], ...]
    notes: tuple[str, ...]


def sampling(
    clock: Clock,
    *,
    tolerance: float,
    gaps: str,
    max_missing: int,
    src: str,
    row: Callable[[int], str],
    irregular: bool = False,
) -> Sampling:
    """Classify the steps of ``clock`` and apply the gap policy (module docstring).

    With ``irregular`` a log whose steps are no whole numbers of one period is
    accepted as it is: the stamps are kept, h is the median step, and no step is
    taken as dropped records.

    Raises
    ------
    LogFormatError
        "t" for fewer than 3 samples or an irregular step; "gaps" for dropped records
        that the policy refuses (naming the first, its rows and times).
    """
    t = clock.offsets
    if t.size < 3:
        raise LogFormatError(
            "t",
            f"{src}: the log has {t.size} sample{'s' if t.size != 1 else ''} with data; "
            "at least 3 are needed to tell its sampling period (and each rule needs its "
            "history before the first sample it predicts).",
        )
    d = np.diff(t)
    h0 = float(np.median(d))
    m = np.rint(d / h0).astype(np.int64)
    off = np.abs(d - m * h0)
    bad = (m < 1) | (off > tolerance * h0)
    if bad.any() and irregular:
        return _irregular(t, d, h0, clock)
    if bad.any():
        i = int(np.argmax(bad))
        raise LogFormatError(
            "t",
            f"{src}: t is not uniformly sampled: between {row(i)} and {row(i + 1)} t jumps "
            f"from {t[i]:.9g} s to {t[i + 1]:.9g} s (step {d[i]:.6g} s; h = {h0:.6g} s, the "
            f"median step), not within {tolerance:.2%} of a whole number of periods. Split "
            "the log there, raise `time_tolerance`, or accept irregular steps (`irregular`="
            "True, --irregular: every rule predicts on the logged stamps).",
        )
    idx = np.concatenate([[0], np.cumsum(m)])
    h_grid = float(t[-1] / idx[-1])
    grid_dev = float(np.abs(t - idx * h_grid).max())
    rounding = 8 * np.finfo(float).eps * float(t[-1])
    uniform = grid_dev <= clock.resolution + rounding
    notes = [f"time: {clock.kind}; t = 0 at {clock.origin}"]
    if uniform:
        h = h_grid
        times = idx * h
        jitter = 0.0
        within = (
            f" (every stamp within {grid_dev:.2g} s of n h: the clock's resolution, "
            f"{clock.resolution:.2g} s)"
            if grid_dev > rounding
            else ""
        )
        notes.append(f"sampling: uniform, h = {h:.9g} s{within}")
    else:
        one = m == 1
        h = float(np.median(d[one])) if one.any() else h0
        times = t
        steps = d[one] if one.any() else d
        jitter = float((np.abs(d - m * h) / h).max())
        notes.append(
            f"sampling: jittered, one-period steps {steps.min():.6g}..{steps.max():.6g} s "
            f"(up to {jitter:.2%} of h = {h:.6g} s, the median step); the time stamps are "
            "kept as logged, not snapped to a grid"
        )
    gap_rows = np.flatnonzero(m > 1)
    gap_list = tuple((int(i), int(m[i] - 1)) for i in gap_rows)
    segments: tuple[tuple[int, int], ...] = ((0, int(t.size)),)
    if gap_list:
        missing = sum(k for _, k in gap_list)
        first, k = gap_list[0]
        where = (
            f"{k} record{'s' if k > 1 else ''} missing between {row(first)} and "
            f"{row(first + 1)} (t = {times[first]:.9g} s to {times[first + 1]:.9g} s)"
        )
        more = f" and {len(gap_list) - 1} more gap(s)" if len(gap_list) > 1 else ""
        if gaps == "refuse":
            raise LogFormatError(
                "gaps",
                f"{src}: dropped records: {where}"
                + (f"{more}, {missing} in all" if more else "")
                + ". Nothing is resampled; choose a gap policy: `gaps`='bridge' (with "
                "`max_missing`) or 'split' (--gaps).",
            )
        if gaps == "bridge":
            worst = max(gap_list, key=lambda g: g[1])
            if worst[1] > max_missing:
                i, k = worst
                raise LogFormatError(
                    "gaps",
                    f"{src}: {k} records missing between {row(i)} and {row(i + 1)} "
                    f"(t = {times[i]:.9g} s to {times[i + 1]:.9g} s), more than "
                    f"`max_missing` = {max_missing} bridges; raise it or split the log "
                    "(--gaps split).",
                )
            notes.append(
                f"gaps: bridged {len(gap_list)} gap(s) of dropped records ({missing} missing; "
                f"first: {where}); the samples keep their logged times across each gap, "
                "nothing is interpolated"
            )
        else:
            bounds = [0, *(int(i) + 1 for i, _ in gap_list), int(t.size)]
            segments = tuple(zip(bounds[:-1], bounds[1:], strict=True))
            notes.append(
                f"gaps: split at {len(gap_list)} gap(s) of dropped records ({missing} "
                f"missing; first: {where}) into {len(segments)} segments of "
                f"{', '.join(str(b - a) for a, b in segments)} samples, each evaluated on "
                "its own; nothing is interpolated"
            )
    return Sampling(times, h, bool(uniform), jitter, gap_list, segments, tuple(notes))


def _irregular(t: np.ndarray, d: np.ndarray, h: float, clock: Clock) -> Sampling:
    """An irregular log taken as it is (``irregular=True``)."""
    ratio = float(d.max() / d.min())
    jitter = float((np.abs(d - h) / h).max())
    notes = (
        f"time: {clock.kind}; t = 0 at {clock.origin}",
        f"sampling: irregular, accepted (irregular=True, --irregular): steps "
        f"{d.min():.6g}..{d.max():.6g} s (ratio {ratio:.3g}), h = {h:.6g} s the median "
        "step; the time stamps are kept as logged, no step is taken as dropped records",
    )
    return Sampling(t, h, False, jitter, (), ((0, int(t.size)),), notes)


def check_policy(gaps: str, max_missing: Any, tolerance: Any) -> None:
    """Validate the sampling options before any reading (errors name the argument)."""
    if gaps not in GAP_POLICIES:
        raise LogFormatError(
            "gaps", f"`gaps` must be one of {', '.join(GAP_POLICIES)}, got {gaps!r}."
        )
    checks.count(max_missing, "max_missing", error=LogFormatError, types=LogFormatError)
    if not (
        isinstance(tolerance, int | float) and math.isfinite(tolerance) and 0 < tolerance < 0.5
    ):
        raise LogFormatError(
            "time_tolerance",
            f"`time_tolerance` must be in (0, 0.5) (a fraction of h), got {tolerance!r}.",
        )


def _looks_like_iso(values: Any) -> bool:
    """Does the first stamp read as an ISO-8601 date-time?"""
    import datetime as dt

    try:
        dt.datetime.fromisoformat(str(np.asarray(values, dtype=object)[0]).strip())
    except (ValueError, IndexError):
        return False
    return True
