"""The checks of arguments that every layer shares, each written once (layer 0).

A positive finite period, a finite number, a count, "an integer multiple" (with ONE
tolerance, :data:`MULTIPLE_RTOL`), the samples of a time window, a finite array of a
shape; the bounds of work and memory (:func:`check_memory` and the limits below it). A
value of the wrong type raises ``TypeError``; a value out of range raises
:class:`~sampledyn.exceptions.ArgumentError` (a ``ValueError``) whose ``argument`` is
the name given, so that the command line names its own option for it (one mapping,
``sampledyn/cli/_status.py``). Messages name the argument, the value that came and,
where there is one, the fix; ``where`` (e.g. ``" in sweep.toml"``) follows the name.
"""

from __future__ import annotations

import math
import numbers
import os
import re
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

from .exceptions import ArgumentError, WorkLimitError

if TYPE_CHECKING:  # numpy loads where an array is checked: the command line imports this
    import numpy as np

__all__ = [
    "DEFAULT_MEMORY",
    "MAX_AB_ORDER",
    "MAX_SEED",
    "MAX_NEWTON_ITER",
    "MAX_SEEDS",
    "MEMORY_ENV",
    "MIN_STEP",
    "MULTIPLE_RTOL",
    "WORKERS_PER_CORE",
    "check_ab_order",
    "check_memory",
    "check_step",
    "format_bytes",
    "memory_limit",
    "parse_bytes",
    "samples_of",
    "trajectory_bytes",
    "worker_count",
    "at_or_after",
    "ceil_ratio",
    "count",
    "finite_array",
    "floor_ratio",
    "integer_ratio",
    "number",
    "period",
    "positive",
    "same_period",
    "time_window",
]

#: Relative tolerance of "an integer multiple" (T = n h, h = k h0, h_u = k h, a step of
#: whole clock ticks) and of "the same period": 1e-9 of the ratio. Decimal periods
#: carry a few rounding units (1e-16) of error (0.1 * 3 != 0.3), far inside it; a
#: period 1e-9 off would move an Euler step by 1e-9 h |f|, far below any error the
#: rules measure (their local errors are >= 1e-12 of |x| in every study).
MULTIPLE_RTOL = 1e-9

_ErrorType = type[ArgumentError]


def _named(name: str, what: str) -> str:
    return f"{what} `{name}`" if what else f"`{name}`"


def _wrong_type(types: type[Exception], name: str, message: str) -> Exception:
    """The error of a value of the wrong type: ``TypeError`` by default; a reader of
    files passes its own :class:`ArgumentError` kind (a file entry is a bad value)."""
    if issubclass(types, ArgumentError):
        return types(name, message)
    return types(message)


def number(
    value: Any, name: str, *, what: str = "", unit: str = "", where: str = "",
    error: _ErrorType = ArgumentError, types: type[Exception] = TypeError,
) -> float:  # fmt: skip
    """``value`` as a float, checked finite (bool and non-numbers: ``types``)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise _wrong_type(
            types,
            name,
            f"{_named(name, what)}{where} must be a finite number"
            f"{f' ({unit})' if unit else ''}, got {type(value).__name__} {value!r}.",
        )
    if not math.isfinite(value):
        raise error(name, f"{_named(name, what)}{where} must be a finite number, got {value!r}.")
    return float(value)


def positive(
    value: Any, name: str, *, what: str = "", unit: str = "", where: str = "",
    error: _ErrorType = ArgumentError, types: type[Exception] = TypeError,
) -> float:  # fmt: skip
    """``value`` as a float, checked finite and > 0 (the one spelling of "> 0")."""
    v = number(value, name, what=what, unit=unit, where=where, error=error, types=types)
    if not v > 0:
        raise error(
            name,
            f"{_named(name, what)}{where} must be a finite number > 0{f' {unit}' if unit else ''}"
            f", got {value!r}.",
        )
    return v


def period(
    value: Any, name: str = "h", *, where: str = "", error: _ErrorType = ArgumentError
) -> float:
    """A sampling period (s): a finite number > 0."""
    return positive(value, name, what="sampling period", unit="s", where=where, error=error)


def count(
    value: Any, name: str, *, least: int = 1, what: str = "", where: str = "",
    error: _ErrorType = ArgumentError, types: type[Exception] = TypeError,
) -> int:  # fmt: skip
    """``value`` as an int >= ``least`` (bool and non-integers: ``types``)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise _wrong_type(
            types,
            name,
            f"{_named(name, what)}{where} must be an int >= {least}, got "
            f"{type(value).__name__} {value!r}.",
        )
    if value < least:
        raise error(name, f"{_named(name, what)}{where} must be an int >= {least}, got {value!r}.")
    return int(value)


def integer_ratio(value: float, base: float) -> int | None:
    """The integer k >= 1 with ``value`` = k ``base`` within :data:`MULTIPLE_RTOL`
    (relative to ``value``), or None."""
    ratio = value / base
    k = round(ratio)
    if k < 1 or abs(k * base - value) > MULTIPLE_RTOL * value:
        return None
    return int(k)


def same_period(a: float, b: float) -> bool:
    """``a`` and ``b`` are the same period (within :data:`MULTIPLE_RTOL`)."""
    return integer_ratio(a, b) == 1


def floor_ratio(value: float, base: float) -> int:
    """The largest integer k with k ``base`` <= ``value`` (a ratio within
    :data:`MULTIPLE_RTOL` of an integer counts as that integer)."""
    ratio = value / base
    return int(math.floor(ratio + MULTIPLE_RTOL * max(1.0, ratio)))


def ceil_ratio(value: float, base: float) -> int:
    """The smallest integer k with k ``base`` >= ``value`` (a ratio within
    :data:`MULTIPLE_RTOL` of an integer counts as that integer)."""
    ratio = value / base
    return int(math.ceil(ratio - MULTIPLE_RTOL * max(1.0, ratio)))


def time_window(
    T: Any, after: Any, *, where: str = "", error: _ErrorType = ArgumentError,
    types: type[Exception] = TypeError,
) -> tuple[float, float]:  # fmt: skip
    """``(T, after)`` of a run: ``T`` finite and > 0 (s), ``after`` in [0, T) (s)."""
    T = positive(T, "T", where=where, error=error, types=types)
    after = number(after, "after", where=where, error=error, types=types)
    if not 0 <= after < T:
        raise error("after", f"`after`{where} must be in [0, T={T:g}) s, got {after}.")
    return T, after


def at_or_after(t: np.ndarray, after: float) -> np.ndarray:
    """The samples of times ``t`` (s) at or after ``after`` (s), as a bool mask: a sample
    within :data:`MULTIPLE_RTOL` (of max(1 s, |after|)) before ``after`` counts, as the
    rounding of t = n h."""
    import numpy as np

    return np.asarray(t) >= after - MULTIPLE_RTOL * max(1.0, abs(after))


def finite_array(
    value: Any, name: str, shape: tuple[int, ...] | None = None, *, where: str = "",
    error: _ErrorType = ArgumentError,
) -> np.ndarray:  # fmt: skip
    """``value`` as a float array, checked finite and (if given) of ``shape``."""
    import numpy as np

    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise error(name, f"`{name}`{where} must be an array of numbers, got {value!r}.") from None
    if shape is not None and a.shape != shape:
        raise error(name, f"`{name}`{where} must have shape {shape}, got {a.shape}.")
    if not np.isfinite(a).all():
        bad = int(np.flatnonzero(~np.isfinite(a.ravel()))[0])
        raise error(name, f"`{name}`{where} must be finite; element {bad} is {a.ravel()[bad]}.")
    return a


# -- bounds of work and memory ---------------------------------------------------------
#
# Everything that allocates by T / h, a horizon, a mask window, a number of seeds or an
# order estimates its memory first (check_memory) and refuses beyond a stated limit,
# naming the argument, the estimate and the limit, instead of growing until the machine
# swaps or Python raises MemoryError.

GiB = 1 << 30
#: Memory one allocation plan (one trajectory, one cell's group, one input's levels, in
#: one process) may take without being asked for (bytes): 4 GiB, about half of a common
#: laptop's memory; the audit's blow-ups (6-7 GB) stop before they start, and the
#: built-in studies at their defaults plan far less. Raised with
#: ``$SAMPLEDYN_MAX_MEMORY`` (``16G``, ``500M``, bytes), ``sampledyn --max-memory`` or
#: :func:`memory_limit`.
DEFAULT_MEMORY = 4 * GiB
MEMORY_ENV = "SAMPLEDYN_MAX_MEMORY"

#: Smallest sampling period h (s). Sample times are t_n = n h in double precision;
#: below 1 ns a run of 10^7 samples spans only 10 ms, and at 5e-324 (the smallest
#: double) n h underflows or collapses (the crash the audit found). No vehicle is
#: sampled faster than 1 MHz (1e-6 s); the floor leaves three decades for convergence
#: studies.
MIN_STEP = 1e-9

#: Largest Adams-Bashforth order s (AB, ABu, ABj, ABe). The prediction sums s values of
#: f weighted by coefficients whose absolute sum a_s = sum |a_i| grows about 2x per
#: order: a_28 = 6.1e7 < 2^26 < a_29 = 1.2e8, so beyond s = 28 the rounding error of f
#: alone, amplified by a_s, costs more than half the digits of double precision
#: (a_s > 1/sqrt(eps)), and the real stability interval 2/a_s is below 3.3e-8 (a mode
#: must be sampled 3e7 times per time constant). The exact coefficients also cost
#: O(s^3) rational operations (AB2000 ran for minutes).
MAX_AB_ORDER = 28

#: Most noise seeds of one Monte Carlo (``advise --seeds``): 10,000 seeds give a mean to
#: 1 % of the spread; more is a typo. (A sweep's seeds are bounded by its max_cells.)
MAX_SEEDS = 10_000

#: Most Newton iterations of one implicit step (Tustin's ``max_iter``,
#: ``--newton-max-iter``): Newton converges quadratically near a root, so an iteration
#: that has not met its tolerance after 1,000 steps is not converging (the default is
#: 25); more would only make each failing sample of a log cost that many solves.
MAX_NEWTON_ITER = 1000

#: Largest seed (a noise seed, a base seed): seeds are stored as SQLite INTEGER (int64).
MAX_SEED = 2**63 - 1

#: Local worker processes per CPU core at most: a cell is CPU-bound, so more
#: processes than cores only add memory and switching (2x leaves room for I/O).
WORKERS_PER_CORE = 2

_LOCK = threading.Lock()
_UNITS = {"": 1, "b": 1, "k": 1 << 10, "m": 1 << 20, "g": GiB, "t": 1 << 40}


def parse_bytes(text: str | float, what: str = "memory limit") -> int:
    """``"16G"``, ``"500M"``, ``"4096"`` (bytes) -> bytes (binary units, KiB..TiB)."""
    if isinstance(text, int | float) and not isinstance(text, bool):
        value, unit = float(text), ""
    else:
        m = re.fullmatch(r"\s*([0-9.eE+]+)\s*([kKmMgGtT]?)(?:i?[bB])?\s*", str(text))
        if m is None:
            raise ArgumentError(what, f"{what} {text!r} is not a size such as 16G, 500M or 4096.")
        try:
            value = float(m[1])
        except ValueError:
            raise ArgumentError(what, f"{what} {text!r} is not a size such as 16G.") from None
        unit = m[2].lower()
    if not (math.isfinite(value) and value > 0):
        raise ArgumentError(what, f"{what} must be a positive size, got {text!r}.")
    return int(value * _UNITS[unit])


def format_bytes(n: float) -> str:
    """``1.5e9`` -> "1.4 GiB"."""
    if not math.isfinite(n) or n >= 1 << 70:
        return "more than any machine holds"
    for unit, size in (("TiB", 1 << 40), ("GiB", GiB), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n:.0f} B"


def _limit() -> int:
    env = os.environ.get(MEMORY_ENV)
    return parse_bytes(env, f"${MEMORY_ENV}") if env else DEFAULT_MEMORY


@contextmanager
def memory_limit(limit: str | float | None) -> Iterator[int]:
    """Within the block, allocation plans up to ``limit`` (bytes or ``"16G"``) run;
    None leaves the current limit. Yields the limit in bytes.

    The limit is process-wide and held in ``$SAMPLEDYN_MAX_MEMORY``, so worker
    processes started inside the block (a sweep's) apply it too.
    """
    with _LOCK:
        old = os.environ.get(MEMORY_ENV)
        if limit is not None:
            os.environ[MEMORY_ENV] = str(parse_bytes(limit))
    try:
        yield _limit()
    finally:
        with _LOCK:
            if old is None:
                os.environ.pop(MEMORY_ENV, None)
            else:
                os.environ[MEMORY_ENV] = old


def _about(n: float) -> str:
    text = format_bytes(n)
    return text if text.startswith("more") else f"about {text}"


def check_memory(
    estimate: float, argument: str, what: str, fix: str = "use a larger h or a shorter run",
    *, name: str = "h",
) -> None:  # fmt: skip
    """Refuse a plan of ``estimate`` bytes above the limit.

    Parameters
    ----------
    estimate : float
        Bytes the computation will hold at its peak.
    argument : str
        What sets its size (``T / h = 1e9 samples``), for the message.
    what : str
        What would be allocated (``the exact samples``).
    fix : str
        How to need less (the message adds how to raise the limit).
    name : str
        The argument to name (:attr:`ArgumentError.argument`).

    Raises
    ------
    WorkLimitError
        naming ``argument``, the estimate, the limit and how to raise it.
    """
    limit = _limit()
    if estimate <= limit and math.isfinite(estimate):
        return
    raise WorkLimitError(
        name,
        f"{argument}: {what} would need {_about(estimate)} of memory, above the limit of "
        f"{format_bytes(limit)}; {fix}, or raise the limit (sampledyn --max-memory SIZE, "
        f"${MEMORY_ENV}=SIZE, or sampledyn.memory_limit(SIZE) in code).",
    )


def samples_of(T: float, h: float) -> float:
    """Number of samples of a run of length T at period h (T / h + 1), as a float
    (so that 1e300 / 1e-9 is an estimate, not an overflow)."""
    return float(T) / float(h) + 1.0


def trajectory_bytes(n_samples: float, nx: int, nu: int, *, certify: bool = True) -> float:
    """Peak bytes of :func:`sampledyn.simulate` for ``n_samples`` samples: t, x, u,
    the integration nodes, the certificate's differences and per-interval arrays
    (float64), plus the input evaluated at the samples once more."""
    per_sample = 2 + nx + 2 * nu + (nx + 3 if certify else 1)
    return 8.0 * n_samples * per_sample


def check_step(h: float, name: str = "h", *, where: str = "") -> None:
    """Refuse a sampling period below :data:`MIN_STEP` (``h`` checked positive and
    finite by :func:`period`)."""
    if float(h) < MIN_STEP:
        raise WorkLimitError(
            name,
            f"`{name}` = {float(h):g} s{where} is below the smallest sampling period "
            f"{MIN_STEP:g} s (sample times t = n h lose their meaning in double precision "
            "below it; no vehicle is sampled faster than 1 MHz).",
        )


def check_ab_order(s: int, name: str = "Adams-Bashforth AB") -> None:
    """Refuse an Adams-Bashforth order above :data:`MAX_AB_ORDER` (with the reason)."""
    if s > MAX_AB_ORDER:
        raise WorkLimitError(
            "s",
            f"order `s` of {name}<s> must be in 1..{MAX_AB_ORDER}, got {s}: above "
            f"{MAX_AB_ORDER} the absolute sum of the coefficients a_s exceeds 2^26, so the "
            "rounding of f alone costs more than half of double precision's digits, and "
            "the real stability interval 2/a_s is below 3.3e-8 (s <= 6 is stable at "
            "usual sampling rates).",
        )


def worker_count(workers: Any, name: str = "--workers") -> tuple[int, str | None]:
    """``workers`` capped at :data:`WORKERS_PER_CORE` per CPU core: (count, a note
    when capped, else None).

    Raises
    ------
    ArgumentError
        for fewer than one worker.
    """
    n = count(workers, name.lstrip("-"))
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    cap = WORKERS_PER_CORE * max(1, cores or 1)
    if n <= cap:
        return n, None
    return cap, (
        f"{name} {n} capped at {cap} ({WORKERS_PER_CORE} per CPU core, {cores} cores): "
        "cells are CPU-bound, more processes only add memory"
    )
