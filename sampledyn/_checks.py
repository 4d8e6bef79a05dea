"""The checks of arguments that every layer shares, each written once (layer 0).

A positive finite period, a finite number, a count, "an integer multiple" (with ONE
tolerance, :data:`MULTIPLE_RTOL`), the samples of a time window, a finite array of a
shape. A value of the wrong type raises ``TypeError``; a value out of range raises
:class:`~sampledyn.exceptions.ArgumentError` (a ``ValueError``) whose ``argument`` is
the name given, so that the command line names its own option for it (one mapping,
``sampledyn/cli/_status.py``). Messages name the argument, the value that came and,
where there is one, the fix; ``where`` (e.g. ``" in sweep.toml"``) follows the name.
"""

from __future__ import annotations

import math
import numbers
from typing import TYPE_CHECKING, Any

from .exceptions import ArgumentError

if TYPE_CHECKING:  # numpy loads where an array is checked: the command line imports this
    import numpy as np

__all__ = [
    "MULTIPLE_RTOL",
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
