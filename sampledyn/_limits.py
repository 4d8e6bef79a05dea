"""Work and memory bounded before they start.

Everything that allocates by T / h, a horizon, a mask window, a number of seeds or an
order estimates its memory first (:func:`check_memory`) and refuses beyond a stated
limit, naming the argument, the estimate and the limit, instead of growing until the
machine swaps or Python raises ``MemoryError``. The limit is :data:`DEFAULT_MEMORY`
bytes per allocation plan (one trajectory, one cell, one study's arrays in one
process), raised with ``$SAMPLEDYN_MAX_MEMORY`` (bytes, or with a unit: ``16G``,
``500M``), ``sampledyn --max-memory``, or :func:`memory_limit` in code.

Other bounds, with their reasons:

* :data:`MIN_STEP`: the smallest sampling period;
* :data:`MAX_AB_ORDER`: the largest Adams-Bashforth order;
* :data:`MAX_SEEDS`: the most noise seeds of one grid point;
* :func:`worker_count`: local workers at most :data:`WORKERS_PER_CORE` per core.
"""

from __future__ import annotations

import math
import os
import re
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

__all__ = [
    "DEFAULT_MEMORY",
    "MAX_AB_ORDER",
    "MAX_SEED",
    "MAX_SEEDS",
    "MEMORY_ENV",
    "MIN_STEP",
    "WORKERS_PER_CORE",
    "WorkLimitError",
    "check_ab_order",
    "check_memory",
    "check_step",
    "format_bytes",
    "memory_limit",
    "parse_bytes",
    "samples_of",
    "trajectory_bytes",
    "worker_count",
]

GiB = 1 << 30
#: Memory one allocation plan may take without being asked for (bytes): 4 GiB, about
#: half of a common laptop's memory; the audit's blow-ups (6-7 GB) stop before they
#: start. The largest built-in study (fig7 at its defaults) plans well below 1 GiB.
DEFAULT_MEMORY = 4 * GiB
MEMORY_ENV = "SAMPLEDYN_MAX_MEMORY"

#: Smallest sampling period h (s). Sample times are t_n = n h in double precision;
#: below 1 ns a run of 10^7 samples already spans only 10 ms, and at 5e-324 (the
#: smallest double) h * n underflows or collapses (the crash the audit found). No
#: vehicle is sampled faster than 1 MHz (1e-6 s); the floor leaves three decades for
#: convergence studies.
MIN_STEP = 1e-9

#: Largest Adams-Bashforth order s (AB, ABu, ABj, ABe). The one-step prediction sums
#: s values of f weighted by coefficients whose absolute sum a_s = sum |a_i| grows
#: about 2x per order: a_28 = 6.1e7 < 2^26 < a_29 = 1.2e8, so beyond s = 28 the
#: rounding error of f alone, amplified by a_s, costs more than half the digits of
#: double precision (a_s > 1/sqrt(eps)), and the real stability interval 2/a_s is
#: below 3.3e-8 (a mode must be sampled 3e7 times per time constant). The exact
#: coefficients also cost O(s^3) rational operations (AB2000 runs for minutes).
MAX_AB_ORDER = 28

#: Most noise seeds of one grid point (a Monte Carlo of 10,000 seeds gives the mean
#: to 1 % of the spread; more is a typo).
MAX_SEEDS = 10_000

#: Largest seed (a noise seed, a base seed): seeds are stored as SQLite INTEGER (int64).
MAX_SEED = 2**63 - 1

#: Local worker processes per CPU core at most: a cell is CPU-bound, so more
#: processes than cores only add memory and switching (2x leaves room for I/O).
WORKERS_PER_CORE = 2

_LOCK = threading.Lock()


class WorkLimitError(ValueError):
    """A computation refused before it started: its estimated memory (or work) is
    beyond the stated limit; the message names the argument, the estimate, the limit
    and how to raise it."""


_UNITS = {"": 1, "b": 1, "k": 1 << 10, "m": 1 << 20, "g": GiB, "t": 1 << 40}


def parse_bytes(text: str | float, what: str = "memory limit") -> int:
    """``"16G"``, ``"500M"``, ``"4096"`` (bytes) -> bytes (binary units, KiB..TiB)."""
    if isinstance(text, int | float) and not isinstance(text, bool):
        value, unit = float(text), ""
    else:
        m = re.fullmatch(r"\s*([0-9.eE+]+)\s*([kKmMgGtT]?)(?:i?[bB])?\s*", str(text))
        if m is None:
            raise ValueError(f"{what} {text!r} is not a size such as 16G, 500M or 4096.")
        value, unit = float(m[1]), m[2].lower()
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{what} must be a positive size, got {text!r}.")
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


def check_memory(
    estimate: float, argument: str, what: str, fix: str = "use a larger h or a shorter run"
) -> None:
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

    Raises
    ------
    WorkLimitError
        naming ``argument``, the estimate, the limit and how to raise it.
    """
    limit = _limit()
    if not estimate > limit and math.isfinite(estimate):
        return
    raise WorkLimitError(
        f"{argument}: {what} would need {_about(estimate)} of memory, above "
        f"the limit of {format_bytes(limit)}; {fix}, or raise the limit (sampledyn "
        f"--max-memory SIZE, ${MEMORY_ENV}=SIZE, or sampledyn.memory_limit(SIZE) in code)."
    )


def _about(n: float) -> str:
    text = format_bytes(n)
    return text if text.startswith("more") else f"about {text}"


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


def check_step(h: Any, argument: str = "h") -> None:
    """Refuse a sampling period below :data:`MIN_STEP` (``h`` positive and finite
    checked by the caller)."""
    if float(h) < MIN_STEP:
        raise WorkLimitError(
            f"`{argument}` = {float(h):g} s is below the smallest sampling period "
            f"{MIN_STEP:g} s (sample times t = n h lose their meaning in double precision "
            "below it; no vehicle is sampled faster than 1 MHz)."
        )


def check_ab_order(s: int, name: str = "AB") -> None:
    """Refuse an Adams-Bashforth order above :data:`MAX_AB_ORDER` (with the reason)."""
    if s > MAX_AB_ORDER:
        raise WorkLimitError(
            f"order `s` of {name}<s> must be in 1..{MAX_AB_ORDER}, got {s}: above "
            f"{MAX_AB_ORDER} the absolute sum of the coefficients a_s exceeds 2^26, so the "
            "rounding of f alone costs more than half of double precision's digits, and "
            "the real stability interval 2/a_s is below 3.3e-8 (s <= 6 is stable at "
            "usual sampling rates)."
        )


def worker_count(workers: int, argument: str = "--workers") -> tuple[int, str | None]:
    """``workers`` capped at :data:`WORKERS_PER_CORE` per CPU core: (count, a note
    when capped, else None).

    Raises
    ------
    ValueError
        for fewer than one worker.
    """
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"`{argument}` must be an integer >= 1, got {workers!r}.")
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    cap = WORKERS_PER_CORE * max(1, cores or 1)
    if workers <= cap:
        return workers, None
    return cap, (
        f"{argument} {workers} capped at {cap} ({WORKERS_PER_CORE} per CPU core, {cores} "
        "cores): cells are CPU-bound, more processes only add memory"
    )
