"""Tables of named things with parameters: built-in models, feedback laws, inputs.

A sweep file, a study or the command line names a built-in model (``"auv_like"``),
a feedback law (``{ law = "roll_pitch_hold", kp = 40.0 }``) or an input
(``{ name = "multilevel", hold = 0.1 }``) by a string. Each layer that defines such
things keeps ONE table of them (:class:`NamedTable`): the names and aliases, a
description, every parameter with its default, and the factory. The engine asks the
table; it never tests a name itself.

An entry's factory may be given as ``"module:attribute"``: it is imported on first
use, so a table lists what a higher layer provides (the inputs of
:mod:`sampledyn.sensitivity`) without importing it (and without that layer writing
into the table).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

__all__ = ["NamedEntry", "NamedTable"]


@dataclass(frozen=True)
class NamedEntry:
    """One entry of a :class:`NamedTable`.

    Attributes
    ----------
    name : str
        Its canonical name.
    factory : callable or str
        What builds it (``"module:attribute"``: imported on first use).
    description : str
        One line for messages and help texts.
    defaults : Mapping[str, Any]
        Every parameter it accepts, with its default value.
    aliases : tuple of str
        Other names accepted for it (case-insensitive).
    """

    name: str
    factory: Callable[..., Any] | str
    description: str
    defaults: Mapping[str, Any] = field(default_factory=dict)
    aliases: tuple[str, ...] = ()

    def resolve(self) -> Callable[..., Any]:
        """The factory, imported now if it was given as ``"module:attribute"``."""
        if callable(self.factory):
            return self.factory
        module, _, attribute = self.factory.partition(":")
        return getattr(importlib.import_module(module), attribute)


class NamedTable:
    """Names -> :class:`NamedEntry`, with the checks every caller shares.

    Parameters
    ----------
    what : str
        What an entry is, for messages ("input", "feedback law", "model").
    key : str
        The key of a spec that holds the name ("name", "law").
    """

    def __init__(self, what: str, key: str = "name") -> None:
        self.what = what
        self.key = key
        self._entries: dict[str, NamedEntry] = {}
        self._aliases: dict[str, str] = {}

    def register(
        self,
        name: str,
        factory: Callable[..., Any] | str,
        description: str,
        defaults: Mapping[str, Any] | None = None,
        aliases: tuple[str, ...] = (),
    ) -> None:
        """Add (or replace) the entry ``name``.

        Raises
        ------
        ValueError
            if ``name`` or an alias is already an alias of another entry.
        """
        for alias in (name, *aliases):
            owner = self._aliases.get(alias.lower())
            if owner is not None and owner != name:
                raise ValueError(f"{self.what} name {alias!r} is taken by {owner!r}.")
        self._entries[name] = NamedEntry(name, factory, description, dict(defaults or {}), aliases)
        for alias in (name, *aliases):
            self._aliases[alias.lower()] = name

    def names(self) -> tuple[str, ...]:
        """The canonical names, in registration order."""
        return tuple(self._entries)

    def describe(self) -> dict[str, str]:
        """Canonical name -> description."""
        return {name: e.description for name, e in self._entries.items()}

    def canonical(self, name: Any) -> str | None:
        """The canonical name of ``name`` or of one of its aliases; None if unknown."""
        return self._aliases.get(name.lower()) if isinstance(name, str) else None

    def entry(self, name: Any) -> NamedEntry:
        """The entry of ``name`` (or an alias).

        Raises
        ------
        ValueError
            for an unknown name, listing the registered ones.
        """
        canonical = self.canonical(name)
        if canonical is None:
            raise ValueError(
                f"unknown {self.what} {name!r}; registered: {', '.join(self._entries)}."
            )
        return self._entries[canonical]

    def check(self, spec: Mapping[str, Any]) -> dict[str, Any]:
        """``spec`` (``{key: name, **parameters}``) with the canonical name and every
        default filled in.

        Raises
        ------
        ValueError
            for a missing or unknown name, or a parameter the entry does not take
            (listing the valid ones).
        """
        name = spec.get(self.key)
        if name is None:
            first = next(iter(self._entries), "...")
            raise ValueError(
                f"the {self.what} table {dict(spec)!r} has no `{self.key}`; give one of "
                f"{', '.join(sorted(self._entries))}, e.g. {{ {self.key} = {first!r}, ... }}."
            )
        entry = self.entry(name)
        params = {k: v for k, v in spec.items() if k != self.key}
        bad = sorted(set(params) - set(entry.defaults))
        if bad:
            valid = ", ".join(entry.defaults) or "none"
            raise ValueError(
                f"{self.what} {entry.name!r} has no parameter {bad[0]!r}; its parameters: {valid}."
            )
        return {self.key: entry.name, **entry.defaults, **params}

    def build(self, spec: Mapping[str, Any], *args: Any) -> Any:
        """Build the entry of ``spec`` (checked): ``factory(*args, **parameters)``."""
        full = self.check(spec)
        params = {k: v for k, v in full.items() if k != self.key}
        return self._entries[full[self.key]].resolve()(*args, **params)
