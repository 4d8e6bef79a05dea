"""The one registry of method names, iterated by tests, the CLI, the figures and the docs.

Every built-in family is one row of :data:`BUILT_IN` below, in listing order: a name
pattern, the factory that builds its rules, as ``"module:attribute"``, and a
description. A family is a single rule ("E", "T", "Ee", "ZOH": ``factory()``) or a
family of orders ("AB<s>": ``factory(s)``) with the largest order listed by default
and, where the family ends, the largest order that exists.

The table is static, so :func:`available_methods` is complete in a fresh process;
each factory is imported on first use (a lazy entry), so naming the estimated rules
(Ee, ABe<s>, defined in :mod:`sampledyn._estimate`) costs nothing until one is built,
and no layer writes into this registry on import. :func:`register_family` adds a
family of the user's at run time (after the built-in ones). Every other layer gets
names and method objects from here and asks the objects what they are (the
protocols of :mod:`sampledyn.methods._base`); nobody parses names.
"""

from __future__ import annotations

import importlib
import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, cast

from .._checks import did_you_mean
from ..exceptions import ArgumentError
from ._base import Method, Predictor

__all__ = [
    "BUILT_IN",
    "Family",
    "available_methods",
    "describe_methods",
    "families",
    "get_method",
    "get_predictor",
    "register_family",
]


@dataclass(frozen=True)
class Family:
    """A registered family of methods.

    Attributes
    ----------
    key : str
        Its name pattern for people: "E", "AB<s>", ...; "<s>" stands for the order.
    pattern : re.Pattern
        Matches the names of its members; the group (if any) is the order.
    factory : callable or str
        ``factory(s)`` for a family of orders, ``factory()`` for a single rule; or
        ``"module:attribute"`` naming it, imported on first use (:attr:`build`).
    description : str
    default_max_order : int or None
        Orders 1..default_max_order are listed by :func:`available_methods`; None for
        a single rule.
    max_order : int or None
        Largest order that exists (None: unbounded, or a single rule).
    """

    key: str
    pattern: re.Pattern[str]
    factory: Callable[..., Any] | str
    description: str
    default_max_order: int | None = None
    max_order: int | None = None

    @property
    def ordered(self) -> bool:
        """True for a family of orders ("AB<s>"), False for a single rule ("T")."""
        return self.pattern.groups > 0

    def name(self, s: int | None = None) -> str:
        """Member name of order s ("AB<s>" -> "AB3"), or the single rule's name."""
        return self.key.replace("<s>", str(s)) if self.ordered else self.key

    def names(self) -> tuple[str, ...]:
        """Names listed by default: orders 1..default_max_order, or the single rule."""
        if not self.ordered:
            return (self.key,)
        return tuple(self.name(s) for s in range(1, (self.default_max_order or 1) + 1))

    def build(self, s: int | None = None) -> Method:
        """The method object of order s (ignored for a single rule).

        Raises
        ------
        sampledyn.exceptions.ArgumentError
            (argument ``method``) for an order outside 1..max_order.
        """
        make = self.resolve()
        if not self.ordered:
            return make()
        assert s is not None
        if s < 1 or (self.max_order is not None and s > self.max_order):
            allowed = ">= 1" if self.max_order is None else f"in 1..{self.max_order}"
            raise ArgumentError(
                "method",
                f"order `s` of {self.key} must be {allowed}, got {s} ({self.name(s)!r}).",
            )
        return make(s)

    def resolve(self) -> Callable[..., Any]:
        """The factory itself, importing its module first for a lazy entry."""
        if callable(self.factory):
            return self.factory
        module, _, attr = self.factory.partition(":")
        factory: Callable[..., Any] = getattr(importlib.import_module(module), attr)
        return factory


_FAMILIES: dict[str, Family] = {}


def register_family(
    key: str,
    pattern: str,
    factory: Callable[..., Any] | str,
    description: str,
    *,
    default_max_order: int | None = None,
    max_order: int | None = None,
) -> Family:
    """Add a family of methods, e.g. ``register_family("AB<s>", r"AB(\\d+)", AdamsBashforth,
    "Adams-Bashforth", default_max_order=6)``.

    Parameters
    ----------
    key : str
        Name pattern shown to people; "<s>" marks the order. A single rule's key is
        its name.
    pattern : str
        Regular expression matching the member names (full match); one group, the
        order, for a family of orders, none for a single rule.
    factory : callable or str
        ``factory(s)`` or ``factory()``, returning a method object; or
        ``"module:attribute"`` naming it (imported on first use).
    description : str
        One line for ``sampledyn methods`` and error messages.
    default_max_order, max_order : int, optional
        See :class:`Family`. A family of orders needs ``default_max_order``.

    Raises
    ------
    ValueError
        if the key does not match the pattern, a family of orders has no default
        largest order, or its names collide with another family's.
    """
    rx = re.compile(pattern)
    if rx.groups > 1:
        raise ValueError(f"`pattern` {pattern!r} may have one group (the order), has {rx.groups}.")
    fam = Family(key, rx, factory, description, default_max_order, max_order)
    if fam.ordered and (default_max_order is None or default_max_order < 1):
        raise ValueError(f"family {key!r} of orders needs `default_max_order` >= 1.")
    unmatched = [n for n in fam.names() if not rx.fullmatch(n)]
    if unmatched:
        raise ValueError(
            f"`pattern` {pattern!r} does not match {unmatched[0]!r}, a name of {key!r}."
        )
    for other in _FAMILIES.values():
        if other.key != key:
            _check_disjoint(fam, other)
    _FAMILIES[key] = fam
    return fam


#: The built-in families, in listing order (available_methods, ``sampledyn methods``,
#: the figures): (key, pattern, factory, description, default_max_order, max_order).
#: Adding a family is one row here and its module.
BUILT_IN: tuple[tuple[str, str, str, str, int | None, int | None], ...] = (
    ("E", r"E", "sampledyn.methods._adams:Euler", "Euler (= AB1 = RK1)", None, None),
    (
        "AB<s>", r"AB(\d+)", "sampledyn.methods._adams:AdamsBashforth",
        "Adams-Bashforth, 1 <= s <= 28 (s > 6 warns: stability interval below 0.05)", 6, None,
    ),
    ("T", r"T", "sampledyn.methods._tustin:Tustin", "Tustin, implicit trapezoid", None, None),
    (
        "RK<s>", r"RK(\d+)", "sampledyn.methods._runge_kutta:RungeKutta",
        "Runge-Kutta, s in [1, 2, 3, 4]", 4, 4,
    ),
    (
        "ABu<s>", r"ABu(\d+)", "sampledyn.methods._held:HeldInputAdamsBashforth",
        "Adams-Bashforth with the input held over the predicted interval (f-history at "
        "u_n), 1 <= s <= 28", 6, None,
    ),
    (
        "ABj<s>", r"ABj(\d+)", "sampledyn.methods._jump:JumpAwareAdamsBashforth",
        "Adams-Bashforth with the input held and the f-history rebuilt after an input "
        "jump (order s across jumps), 1 <= s <= 28", 6, None,
    ),
    (
        "Ee", r"Ee", "sampledyn._estimate._estimated:estimated_euler",
        "estimated Euler (= ABe1)", None, None,
    ),
    (
        "ABe<s>", r"ABe(\d+)", "sampledyn._estimate._estimated:EstimatedAdamsBashforth",
        "Adams-Bashforth with parameters estimated on the data (l_2), 1 <= s <= 28", 6, None,
    ),
    (
        "ZOH", r"ZOH", "sampledyn.methods._exact:ExactHold",
        "exact zero-order hold: the flow over h with the input held (a discrete-time "
        "system only; its linearisation the flow's derivative, the matrix exponential at "
        "a trim)", None, None,
    ),
)  # fmt: skip


def _check_disjoint(a: Family, b: Family) -> None:
    """Raise if a name of one family is matched by the other's pattern."""
    for x, y in ((a, b), (b, a)):
        taken = [n for n in x.names() if y.pattern.fullmatch(n)]
        if taken:
            raise ValueError(
                f"name {taken[0]!r} of {x.key!r} is already taken by {y.key!r}: the families "
                f"{a.key!r} and {b.key!r} would share names."
            )


def families() -> tuple[Family, ...]:
    """Every registered family, in registration order."""
    return tuple(_FAMILIES.values())


#: (protocol, class) pairs that passed ``isinstance``: a runtime Protocol check looks up
#: every member (some 10 us), and a study asks it of the same classes thousands of times.
_CONFORMING: set[tuple[type, type]] = set()


def _conforms(obj: Any, protocol: type) -> bool:
    """``isinstance(obj, protocol)``, remembered per class when it holds (the methods'
    members are the class's, not set per instance)."""
    key = (protocol, type(obj))
    if key in _CONFORMING:
        return True
    if isinstance(obj, protocol):
        _CONFORMING.add(key)
        return True
    return False


def get_method(name: Any) -> Method:
    """The method registered under ``name``: "E", "T", "AB<s>", "RK<s>", "ABu<s>", ...

    A method object passes through unchanged.

    Raises
    ------
    sampledyn.exceptions.ArgumentError
        (argument ``method``, a ``ValueError``) for an unknown name (the message
        suggests the closest names and lists the families, :func:`families`) or a bad
        order.
    TypeError
        for anything that is neither a name nor a method object.
    """
    if not isinstance(name, str):
        if _conforms(name, Method):
            return name
        raise TypeError(f"`method` must be a name or a method object, got {type(name).__name__}.")
    key = name.strip()
    for fam in _FAMILIES.values():
        m = fam.pattern.fullmatch(key)
        if m:
            if not fam.ordered:
                return fam.build()
            digits = m.group(1)
            if len(digits) > 9:  # refused as too large, not parsed (int() of 5000 digits)
                raise ArgumentError(
                    "method",
                    f"method {key[:12]}...: the order of {fam.key} has {len(digits)} digits; "
                    "orders are small integers (`sampledyn methods` lists them).",
                )
            return fam.build(int(digits))
    raise ArgumentError("method", unknown_method(name))


def _family_names(fam: Family) -> str:
    """A family in a short list: "E", "RK1-RK4", "AB<s>" (unbounded orders)."""
    if fam.ordered and fam.max_order is not None:
        return f"{fam.name(1)}-{fam.name(fam.max_order)}"
    return fam.key


def unknown_method(name: str) -> str:
    """The message for an unknown method ``name``: the closest names (case ignored; a
    single rule also by its description's first words, "Euler" -> E), then the
    families in one short line."""
    singles = {f.description.split(" (")[0].split(",")[0].split(":")[0]: f.key
               for f in _FAMILIES.values() if not f.ordered}  # fmt: skip
    hint = did_you_mean(name, available_methods(), singles)
    short = ", ".join(_family_names(f) for f in _FAMILIES.values())
    return (
        f"unknown method {name!r}{hint}; the methods are {short} (<s>: the order; "
        "describe_methods() describes each family)."
    )


def get_predictor(name: Any, argument: str | None = "method") -> Predictor:
    """:func:`get_method`, for a rule that predicts on sampled data.

    Raises
    ------
    ValueError
        for a rule that is a discrete-time system only (ZOH), naming ``argument``
        (``None``: the caller names it, as :func:`get_method`'s messages leave it to).
    """
    m = get_method(name)
    if not _conforms(m, Predictor):
        where = "" if argument is None else f"`{argument}` "
        raise ValueError(
            f"{where}{m.name!r} does not predict on sampled data (it is a discrete-time "
            "system only: use sampledyn.discretize); give a predictor such as 'AB4' "
            "(`sampledyn methods` lists them)."
        )
    return cast(Predictor, m)


def available_methods() -> tuple[str, ...]:
    """Every usable name of every registered family, orders up to each family's
    default largest one (E, AB1-AB6, T, RK1-RK4, ABu1-ABu6, ...)."""
    return tuple(n for fam in _FAMILIES.values() for n in fam.names())


def describe_methods() -> dict[str, str]:
    """Family key -> one-line description."""
    return {k: f.description for k, f in _FAMILIES.items()}


for _row in BUILT_IN:
    register_family(*_row[:4], default_max_order=_row[4], max_order=_row[5])
del _row
