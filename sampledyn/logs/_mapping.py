"""Mapping files (TOML): read, and refuse every key that is not known (a misspelt
section, column or field is an error naming it, never ignored)."""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .._files import parse_toml, read_text
from ..exceptions import FileContentError, LogFormatError

if TYPE_CHECKING:  # the command line imports this module before the kernels
    from ..models import Model

__all__ = ["check_keys", "load_toml", "model_for_mapping", "table_mapping"]


def load_toml(mapping: Any) -> dict[str, Any]:
    """A mapping given as a dict, or the TOML file at a path; {} for None.

    Raises
    ------
    FileNotFoundError, IsADirectoryError
        for a path with no file, or a folder (:func:`sampledyn._files.regular_file`).
    LogFormatError
        for a file that is not UTF-8 TOML.
    """
    if mapping is None:
        return {}
    if isinstance(mapping, Mapping):
        return dict(mapping)
    path = Path(mapping)  # missing or a folder: FileNotFoundError, IsADirectoryError
    try:  # a regular file, bounded, UTF-8, TOML nested a few levels
        return parse_toml(read_text(path, "mapping file"), f"`mapping` {str(path)!r}")
    except FileContentError as exc:
        raise LogFormatError("mapping", str(exc).replace("not valid TOML", "not TOML")) from None


def _hint(key: str, allowed: Iterable[str]) -> str:
    close = difflib.get_close_matches(key, list(allowed), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def check_keys(
    table: Mapping[str, Any],
    allowed: Iterable[str],
    where: str,
    required: Iterable[str] = (),
) -> None:
    """Raise LogFormatError("mapping") naming every key of ``table`` not in
    ``allowed`` (with the closest allowed one), or a missing required key."""
    allowed = list(allowed)
    unknown = [k for k in table if k not in allowed]
    if unknown:
        names = ", ".join(f"{k!r}{_hint(k, allowed)}" for k in unknown)
        raise LogFormatError(
            "mapping",
            f"mapping file: unknown key(s) in {where}: {names}; allowed: {', '.join(allowed)}.",
        )
    missing = [k for k in required if k not in table]
    if missing:
        raise LogFormatError(
            "mapping", f"mapping file: {where} needs {', '.join(repr(k) for k in missing)}."
        )


def table_mapping(
    raw: Mapping[str, Any], columns: Iterable[str], quantities: Iterable[str], src: str
) -> dict[str, dict[str, str]]:
    """The ``[columns]`` section of a mapping file for a CSV/Parquet log, checked.

    Accepted forms: a ``[columns]`` table (nothing else at the top), or the column
    entries at the top level. Each entry is ``{ name = "...", unit = "..." }`` (either
    key may be left out).

    Raises
    ------
    LogFormatError
        for an unknown section or key, an entry for a column the log does not have, or
        a ``name`` that is not a quantity of the model; each named, with the closest
        valid spelling.
    """
    if "columns" in raw:
        check_keys(
            raw, ["columns", "inputs"], "the top level (a CSV/Parquet mapping has [columns])"
        )
        if raw.get("inputs", "wrench") != "wrench":
            raise LogFormatError(
                "mapping",
                f'mapping file: `inputs` may only be "wrench" (the commanded body force and '
                f"moment X, Y, Z, K, M, N), got {raw['inputs']!r}.",
            )
        cols = raw["columns"]
        if not isinstance(cols, Mapping):
            raise LogFormatError("mapping", "mapping file: [columns] must be a table.")
    else:
        cols = raw
        for key, entry in cols.items():
            if isinstance(entry, Mapping) and any(isinstance(v, Mapping) for v in entry.values()):
                raise LogFormatError(
                    "mapping",
                    f"mapping file: unknown section [{key}]{_hint(key, ['columns'])}; a "
                    "CSV/Parquet mapping has [columns] only.",
                )
    have = [str(c) for c in columns]
    names = list(quantities)
    out: dict[str, dict[str, str]] = {}
    for col, entry in cols.items():
        if not isinstance(entry, Mapping):
            raise LogFormatError(
                "mapping", f"mapping file: entry {col!r} must be a table with `name` and/or `unit`."
            )
        check_keys(entry, ["name", "unit"], f"the entry for column {col!r}")
        if str(col) not in have:
            raise LogFormatError(
                "mapping",
                f"{src}: the mapping file names column {col!r}{_hint(str(col), have)}, which "
                f"the log does not have; the log has {', '.join(repr(c) for c in have)}.",
            )
        if "name" in entry and str(entry["name"]) not in names:
            name = str(entry["name"])
            raise LogFormatError(
                "mapping",
                f"mapping file: column {col!r} is given the name {name!r}{_hint(name, names)}, "
                f"which is not a quantity of the model ({', '.join(names)}).",
            )
        out[str(col)] = {k: str(v) for k, v in entry.items()}
    return out


def model_for_mapping(model: Model, mapping: Any) -> Any:
    """``model`` with the commanded wrench as its input (``wrench_input=True``) when
    the mapping file gives wrench inputs (``[ros.wrench]``, or ``inputs = "wrench"``
    beside a table's ``[columns]``), else ``model`` itself.

    Raises
    ------
    LogFormatError
        if the mapping gives wrench inputs and the model is no vehicle that can take
        them.
    """
    raw = load_toml(mapping)
    ros = raw.get("ros")
    wrench = raw.get("inputs") == "wrench" or (isinstance(ros, Mapping) and "wrench" in ros)
    if not wrench or getattr(model, "wrench_input", False):
        return model
    from ..models import Vehicle

    if not isinstance(model, Vehicle):
        raise LogFormatError(
            "mapping",
            "mapping file: gives the commanded wrench as the input, but the model is no "
            "vehicle (only a Vehicle takes wrench_input=True).",
        )
    return model.with_params(wrench_input=True)
