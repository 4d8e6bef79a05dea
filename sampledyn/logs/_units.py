"""Units of log columns: parse ``name[unit]`` headers and convert to the model's units."""

from __future__ import annotations

import math
import re

from ..exceptions import LogFormatError

__all__ = ["CONVERSIONS", "conversion_factor", "split_header"]


_DEG = math.pi / 180.0

# The model's unit -> {unit a log may use: factor to the model's unit}.
CONVERSIONS: dict[str, dict[str, float]] = {
    "s": {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "ns": 1e-9, "min": 60.0},
    "m": {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "km": 1e3, "ft": 0.3048},
    "rad": {"rad": 1.0, "deg": _DEG, "°": _DEG},
    "m/s": {
        "m/s": 1.0,
        "cm/s": 1e-2,
        "mm/s": 1e-3,
        "km/h": 1.0 / 3.6,
        "kn": 1852.0 / 3600.0,
        "ft/s": 0.3048,
    },
    "rad/s": {"rad/s": 1.0, "deg/s": _DEG, "°/s": _DEG},
    "rpm": {"rpm": 1.0, "rev/min": 1.0, "rps": 60.0, "rev/s": 60.0, "rad/s": 60.0 / (2 * math.pi)},
    "m/s^2": {"m/s^2": 1.0},
    "N": {"N": 1.0, "kN": 1e3},
    "N m": {"N m": 1.0, "Nm": 1.0, "N*m": 1.0},
    "": {"": 1.0, "1": 1.0, "-": 1.0},
}

_KIND = {
    "s": "a time",
    "m": "a length",
    "rad": "an angle",
    "m/s": "a speed",
    "rad/s": "an angular rate",
    "rpm": "a rotational speed",
    "m/s^2": "an acceleration",
    "N": "a force",
    "N m": "a moment",
    "": "dimensionless",
}

_HEADER = re.compile(r"^\s*(?P<name>[^\[\]]*?)\s*\[\s*(?P<unit>[^\[\]]*?)\s*\]\s*$")


def split_header(column: str) -> tuple[str, str | None]:
    """``"x[m]"`` -> ``("x", "m")``; ``"x"`` -> ``("x", None)``."""
    m = _HEADER.match(str(column))
    if m:
        return m.group("name"), m.group("unit")
    return str(column).strip(), None


def conversion_factor(column: str, name: str, unit: str, target: str) -> float:
    """Factor taking values of ``column`` (quantity ``name`` in ``unit``) to ``target``.

    Raises
    ------
    LogFormatError
        naming the column, for a unit of another quantity (e.g. "deg" for a length) or
        an unknown unit; the message lists the accepted units.
    """
    accepted = CONVERSIONS.get(target)
    if accepted is None:
        if unit == target:
            return 1.0
        raise LogFormatError(
            column, f"column {column!r}: {name} must be in {target!r} (no conversion known)."
        )
    if unit in accepted:
        return accepted[unit]
    kind = _KIND.get(target, target)
    choices = ", ".join(repr(u) for u in accepted)
    for other, table in CONVERSIONS.items():
        if unit in table:
            raise LogFormatError(
                column,
                f"column {column!r}: unit {unit!r} is {_KIND[other]}, but {name} is {kind} "
                f"({target!r}); accepted units: {choices}.",
            )
    raise LogFormatError(
        column,
        f"column {column!r}: unknown unit {unit!r} for {name} ({kind}); accepted units: {choices}.",
    )
