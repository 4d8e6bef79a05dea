"""One registry of method names, iterated by tests, the CLI and the docs."""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

from ._adams import AdamsBashforth, Euler
from ._runge_kutta import TABLEAUX, RungeKutta
from ._tustin import Tustin

__all__ = ["available_methods", "get_method", "register_family"]

# family name -> (regex, factory, description). The regex's optional group is the order.
_FAMILIES: dict[str, tuple[re.Pattern[str], Callable[..., Any], str]] = {}


def register_family(key: str, pattern: str, factory: Callable[..., Any], description: str) -> None:
    """Add a family of methods (e.g. ``"AB<s>"``); ``factory(order)`` or ``factory()``."""
    _FAMILIES[key] = (re.compile(pattern), factory, description)


register_family("E", r"E", lambda: Euler(), "Euler (= AB1 = RK1)")
register_family("T", r"T", lambda: Tustin(), "Tustin, implicit trapezoid")
register_family("AB<s>", r"AB(\d+)", lambda s: AdamsBashforth(s), "Adams-Bashforth, s >= 1")
register_family(
    "RK<s>", r"RK(\d+)", lambda s: RungeKutta(s), f"Runge-Kutta, s in {sorted(TABLEAUX)}"
)


def get_method(name: Any) -> Any:
    """The method registered under ``name``: "E", "T", "AB<s>", "RK<s>", ...

    A method object passes through unchanged.

    Raises
    ------
    ValueError
        for an unknown name (the message lists the valid ones) or a bad order.
    """
    if not isinstance(name, str):
        if hasattr(name, "predict") and hasattr(name, "name"):
            return name
        raise TypeError(f"`method` must be a name or a method object, got {type(name).__name__}.")
    key = name.strip()
    for pattern, factory, _ in _FAMILIES.values():
        m = pattern.fullmatch(key)
        if m:
            return factory(int(m.group(1))) if m.groups() else factory()
    valid = ", ".join(f"{k} ({d})" for k, (_, _, d) in _FAMILIES.items())
    raise ValueError(f"unknown method {name!r}; valid names: {valid}.")


def available_methods(max_ab_order: int = 6) -> tuple[str, ...]:
    """Concrete names of the built-in fixed rules, for iteration."""
    names = ["E", "T"]
    names += [f"AB{s}" for s in range(1, max_ab_order + 1)]
    names += [f"RK{s}" for s in sorted(TABLEAUX)]
    return tuple(names)


def describe_methods() -> dict[str, str]:
    """Family name -> one-line description."""
    return {k: d for k, (_, _, d) in _FAMILIES.items()}


# Estimated rules (section 4.2). Imported last: _estimated needs only _adams, and
# reaches sampledyn.estimate lazily at predict time, so there is no import cycle.
from ._estimated import EstimatedAdamsBashforth  # noqa: E402

register_family(
    "Ee", r"Ee", lambda: EstimatedAdamsBashforth(1, name="Ee"), "estimated Euler (= ABe1)"
)
register_family(
    "ABe<s>",
    r"ABe(\d+)",
    lambda s: EstimatedAdamsBashforth(s),
    "Adams-Bashforth with parameters estimated on the data (l_2), s >= 1",
)
