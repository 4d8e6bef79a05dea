"""Pieces every command shares: option types, the options every command takes,
checks of output paths before any work, machine-readable output."""

from __future__ import annotations

import argparse
import errno
import json
import math
import os
import sys
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from ..exceptions import UsageError

__all__ = [
    "add_format",
    "common_options",
    "floats",
    "ints",
    "names",
    "newton_options",
    "option",
    "pair",
    "print_json",
    "progress",
    "refuse",
    "refuse_overwriting_inputs",
    "writable_dir",
    "writable_file",
]


def floats(text: str) -> tuple[float, ...]:
    """``"0.1,0.5"`` -> (0.1, 0.5)."""
    try:
        return tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from exc


def ints(text: str) -> tuple[int, ...]:
    """``"1,10"`` -> (1, 10)."""
    try:
        return tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError as exc:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated integers, got {text!r}"
        ) from exc


def pair(text: str) -> tuple[float, float]:
    """``"2,5"`` -> (2.0, 5.0); ``"2"`` -> (2.0, 2.0)."""
    try:
        vals = tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected numbers like 2,2, got {text!r}") from exc
    if len(vals) == 1:
        vals = vals * 2
    if len(vals) != 2:
        raise argparse.ArgumentTypeError(f"expected one or two numbers (eta,v), got {text!r}")
    return vals[0], vals[1]


def names(text: str | None) -> tuple[str, ...]:
    """``"E, AB2"`` -> ("E", "AB2")."""
    return tuple(m.strip() for m in (text or "").split(",") if m.strip())


def common_options() -> argparse.ArgumentParser:
    """A parent parser of the options every command takes (also accepted before the
    command). Defaults are SUPPRESSed so a subcommand does not reset the global ones."""
    p = argparse.ArgumentParser(add_help=False)
    p.add_argument(
        "-q",
        "--quiet",
        action="store_true",
        default=argparse.SUPPRESS,
        help="no progress bars and no start-up line on stderr (errors and warnings still)",
    )
    p.add_argument(
        "--max-memory",
        metavar="SIZE",
        default=argparse.SUPPRESS,
        help="largest memory one computation may plan, e.g. 16G (default 4G, or "
        "$SAMPLEDYN_MAX_MEMORY); larger plans are refused before they start",
    )
    p.add_argument(
        "--debug",
        action="store_true",
        default=argparse.SUPPRESS,
        help="print the traceback of an error (also: environment SAMPLEDYN_DEBUG=1)",
    )
    return p


def add_format(parser: argparse.ArgumentParser, what: str) -> None:
    """``--format {text,json}`` for a command that prints ``what``."""
    parser.add_argument(
        "--format",
        choices=("text", "json"),
        default="text",
        help=f"print {what} as a text table (default) or as one JSON document on stdout "
        "(keys in docs/cli.md)",
    )


def progress(args: argparse.Namespace) -> bool:
    """Show progress bars? Not with --quiet or --no-progress."""
    return not (getattr(args, "quiet", False) or getattr(args, "no_progress", False))


@contextmanager
def option(name: str) -> Iterator[None]:
    """Name option ``name`` in the message of a file error (``OSError``) raised inside."""
    try:
        yield
    except OSError as exc:
        if getattr(exc, "sampledyn_option", None) is None:
            exc.sampledyn_option = name  # type: ignore[attr-defined]
        raise


def _existing_ancestor(path: Path) -> Path:
    parent = path
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    return parent


def _named(exc: OSError, name: str) -> OSError:
    exc.sampledyn_option = name  # type: ignore[attr-defined]
    return exc


def _check_creatable(path: Path, name: str) -> None:
    anc = _existing_ancestor(path.parent if not path.exists() else path)
    if not anc.is_dir():
        raise _named(
            NotADirectoryError(errno.ENOTDIR, f"{anc} is a file, not a folder", str(path)), name
        )
    if not os.access(anc, os.W_OK | os.X_OK):
        raise _named(PermissionError(errno.EACCES, f"cannot write in {anc}", str(path)), name)


def writable_dir(path: str | os.PathLike[str], name: str) -> Path:
    """``path`` as an output folder, checked before any work: a file there, a folder
    that cannot be created or written, fail now (naming option ``name``)."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise _named(
            FileExistsError(errno.EEXIST, "must be a folder, but a file is there", str(p)), name
        )
    _check_creatable(p, name)
    return p


def writable_file(path: str | os.PathLike[str], name: str) -> Path:
    """``path`` as an output file (overwritten), checked before any work."""
    p = Path(path)
    if p.is_dir():
        raise _named(
            IsADirectoryError(errno.EISDIR, "must be a file, but a folder is there", str(p)), name
        )
    if p.exists():
        if not os.access(p, os.W_OK):
            raise _named(PermissionError(errno.EACCES, "the file is not writable", str(p)), name)
        return p
    _check_creatable(p, name)
    return p


def _overwrites(target: Path, many: bool, source: Path) -> bool:
    """Would writing ``target`` (a file; with ``many``, a folder whose files are
    written) destroy ``source`` (a file or a folder)?"""
    from .._files import inside, same_file

    if source.is_dir():
        return inside(target, source)
    return inside(source, target) if many else same_file(target, source)


def refuse_overwriting_inputs(
    out: Path, name: str, inputs: Mapping[str, Any], *, writes: Sequence[str] = ()
) -> None:
    """Refuse, before any work, an output that is (or resolves to) an input.

    Parameters
    ----------
    out : Path
        The output file, or with ``writes`` the output folder.
    name : str
        Its option (``--out``), for the message.
    inputs : mapping
        What the command reads: a label (``STORE``, ``--data``) -> a path, or None /
        a name that is not a path (a built-in vehicle), skipped. A folder input (a
        ROS 2 bag) holds every file below it.
    writes : sequence of str
        The names the command writes into the folder ``out``; a name ending in "/" is
        a folder whose files it writes.

    Raises
    ------
    UsageError
        (exit 2) naming the option, the output and the input it would destroy.
    """
    targets = [(out / w.rstrip("/"), w.endswith("/")) for w in writes] if writes else [(out, False)]
    for label, value in inputs.items():
        if value is None:
            continue
        if not os.path.lexists(str(value)):
            # (a store's side file comes and goes with its connections: its name is kept)
            if "STORE's" in label and any(Path(value).resolve() == t.resolve()
                                          for t, _ in targets):  # fmt: skip
                refuse(
                    f"`{name} {out}` is the name of the {label} {str(value)!r}; nothing was "
                    f"written: give {name} another {'folder' if writes else 'file'}."
                )
            continue
        source = Path(value)
        for target, many in targets:
            if _overwrites(target, many, source):
                where = "" if target == out else f" (it writes {target})"
                refuse(
                    f"`{name} {out}`{where} would overwrite the input {label} {str(source)!r}; "
                    f"nothing was written: give {name} another "
                    f"{'folder' if writes else 'file'}."
                )


def _plain(value: Any) -> Any:
    """JSON-able ``value``: NaN and infinities become null, tuples lists."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, Sequence) and not isinstance(value, str):
        return [_plain(v) for v in value]
    if hasattr(value, "item") and callable(value.item):  # numpy scalar
        return _plain(value.item())
    if hasattr(value, "tolist"):  # numpy array
        return _plain(value.tolist())
    return value


def print_json(document: Mapping[str, Any]) -> None:
    """Print ``document`` as indented JSON on stdout (NaN as null)."""
    sys.stdout.write(json.dumps(_plain(document), indent=2, allow_nan=False) + "\n")


def refuse(message: str) -> None:
    """Raise a :class:`UsageError` (exit status 2)."""
    raise UsageError(message)


def newton_options(args: argparse.Namespace) -> dict[str, Any] | None:
    """``--newton-tol`` and ``--newton-max-iter`` as the ``newton`` mapping of
    ``evaluate_log`` and ``advise`` (None when neither is given), checked now, before
    any work, by the rule that takes them (:class:`sampledyn.methods.Tustin`; its
    ``tol`` and ``max_iter`` map to these options in ``_status.ARGUMENT_OPTIONS``)."""
    newton = {"tol": args.newton_tol, "max_iter": args.newton_max_iter}
    newton = {k: v for k, v in newton.items() if v is not None}
    if not newton:
        return None
    registry().Tustin().with_newton(**newton)
    return newton


def registry() -> Any:
    """The method registry (:mod:`sampledyn.methods`), imported when a command first
    names or lists rules (it is complete on import: the estimated rules are lazy
    entries)."""
    from .. import methods

    return methods
