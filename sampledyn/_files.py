"""Reading the user's files safely: regular files only, sizes and nesting bounded,
text decoded with the file named; writing outputs without following links or
overwriting an input.

Every file sampledyn reads by name (vehicle, sweep and mapping files, logs, stores,
a bag's ``metadata.yaml``) goes through :func:`regular_file` first: a FIFO, a device
(``/dev/zero``), a socket or a folder where a file is expected would block or fill
the memory, so it is refused naming the file. Text files that are parsed whole have
a size limit per kind (:data:`SIZE_LIMITS`), far above any real one; a log has none,
since logs are read in chunks. Parsed TOML and JSON may nest at most
:data:`MAX_NESTING` levels (a 5000-deep array would otherwise end in a
``RecursionError`` of the parser or of the code that walks the result).
"""

from __future__ import annotations

import errno
import json
import os
import re
import stat
import threading
import tomllib
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from .exceptions import FileContentError

__all__ = [
    "MAX_NESTING",
    "SIZE_LIMITS",
    "check_nesting",
    "csv_safe",
    "csv_safe_frame",
    "inside",
    "parse_json",
    "parse_toml",
    "read_text",
    "regular_file",
    "same_file",
    "write_text_atomic",
]

MiB = 1 << 20
#: Largest file read whole, per kind (bytes). The built-in vehicle files are about
#: 6 KB, the longest sweep file 2 KB, a ROS 2 bag's metadata.yaml a few KB per topic;
#: the limits are a thousand times that, and stop a mistaken multi-GB file before it
#: is read into memory.
SIZE_LIMITS: dict[str, int] = {
    "vehicle file": 16 * MiB,
    "sweep file": 16 * MiB,
    "mapping file": 16 * MiB,
    "message definition": 16 * MiB,
    "bag metadata": 64 * MiB,
    "parameter file": 64 * MiB,
}
#: Deepest nesting of arrays/tables (TOML) or arrays/objects (JSON) accepted: the
#: deepest real file (a vehicle's 6x6 matrices in a table) nests 3 levels.
MAX_NESTING = 64


def regular_file(
    path: str | os.PathLike[str], kind: str, *, limit: int | None = None, folder_ok: bool = False
) -> Path:
    """``path`` checked to be a regular file (or a folder, with ``folder_ok``) no
    larger than ``limit`` bytes (default: :data:`SIZE_LIMITS` of ``kind``, none if
    the kind has none), before it is opened.

    Raises
    ------
    FileNotFoundError
        if nothing is at ``path``.
    IsADirectoryError
        for a folder (without ``folder_ok``).
    OSError
        (errno ``EINVAL``) for a FIFO, a device or a socket: reading it would block or
        never end.
    FileContentError
        for a file above the limit.
    """
    p = Path(path)
    try:
        st = os.stat(p)  # a symbolic link to a regular file is a regular file
    except FileNotFoundError:
        raise FileNotFoundError(errno.ENOENT, f"no {kind} there", str(p)) from None
    if stat.S_ISDIR(st.st_mode):
        if folder_ok:
            return p
        raise IsADirectoryError(errno.EISDIR, f"the {kind} is a folder, not a file", str(p))
    if not stat.S_ISREG(st.st_mode):
        what = (
            "a FIFO (named pipe)"
            if stat.S_ISFIFO(st.st_mode)
            else "a device"
            if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode)
            else "a socket"
            if stat.S_ISSOCK(st.st_mode)
            else "not a regular file"
        )
        raise OSError(
            errno.EINVAL,
            f"the {kind} is {what}, not a regular file; only regular files are read "
            "(copy the data into a file)",
            str(p),
        )
    limit = SIZE_LIMITS.get(kind) if limit is None else limit
    if limit is not None and st.st_size > limit:
        raise FileContentError(
            str(p),
            f"{kind} {str(p)!r} is {st.st_size / MiB:.1f} MiB, above the {limit / MiB:g} MiB "
            f"a {kind} may have; is it the right file?",
        )
    return p


def read_text(path: str | os.PathLike[str], kind: str, *, limit: int | None = None) -> str:
    """The text of the regular file ``path`` (UTF-8; see :func:`regular_file`).

    Raises
    ------
    FileContentError
        for bytes that are not UTF-8, naming the file and the offset (a binary file,
        or text saved in another encoding), or a file above the limit.
    """
    p = regular_file(path, kind, limit=limit)
    data = p.read_bytes()
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise FileContentError(
            str(p),
            f"{kind} {str(p)!r} is not UTF-8 text (byte {exc.start}: "
            f"{data[exc.start : exc.start + 1]!r}); save it as UTF-8",
        ) from None


def _depth(value: Any) -> int:
    """Deepest nesting of lists/dicts in ``value`` (iteratively: no recursion)."""
    deepest = 0
    stack: list[tuple[Any, int]] = [(value, 0)]
    while stack:
        item, level = stack.pop()
        if isinstance(item, Mapping):
            children: Iterable[Any] = item.values()
        elif isinstance(item, list | tuple):
            children = item
        else:
            continue
        level += 1
        deepest = max(deepest, level)
        if level > MAX_NESTING:
            return level
        stack.extend((c, level) for c in children)
    return deepest


def check_nesting(value: Any, where: str) -> Any:
    """``value`` if it nests at most :data:`MAX_NESTING` levels; else
    :class:`FileContentError` naming ``where``."""
    if _depth(value) > MAX_NESTING:
        raise FileContentError(
            where,
            f"{where}: arrays or tables nested deeper than {MAX_NESTING} levels; no "
            "sampledyn file nests more than a few",
        )
    return value


def _too_deep(where: str) -> FileContentError:
    return FileContentError(
        where,
        f"{where}: nested too deep to parse (more than {MAX_NESTING} levels are refused); "
        "no sampledyn file nests more than a few",
    )


def parse_toml(text: str, where: str) -> dict[str, Any]:
    """``tomllib.loads(text)`` with the nesting bounded; the errors name ``where``.

    Raises
    ------
    FileContentError
        for text that is not TOML (the parser's message, with ``where``) or nests too
        deep.
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise FileContentError(where, f"{where}: not valid TOML: {exc}") from None
    except RecursionError:
        raise _too_deep(where) from None
    except ValueError as exc:  # int() of a number too long to be one (4300 digits)
        raise _too_long(where, exc) from None
    return check_nesting(data, where)


def _too_long(where: str, exc: Exception) -> FileContentError:
    digits = re.search(r"value has (\d+) digits", str(exc))
    said = f" ({digits[1]} digits)" if digits else ""
    return FileContentError(
        where,
        f"{where}: holds an integer too long to read{said}; no sampledyn value has more than "
        "a few dozen digits",
    )


def parse_json(text: str | bytes, where: str) -> Any:
    """``json.loads(text)`` with the nesting bounded; errors name ``where``."""
    try:
        data = json.loads(text)
    except RecursionError:
        raise _too_deep(where) from None
    except json.JSONDecodeError as exc:
        raise FileContentError(where, f"{where}: not valid JSON: {exc}") from None
    except ValueError as exc:
        raise _too_long(where, exc) from None
    return check_nesting(data, where)


def same_file(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """``a`` and ``b`` name one file: the same resolved path, or (both existing) the
    same inode (a hard link, another mount of it)."""
    pa, pb = Path(a), Path(b)
    if pa.resolve() == pb.resolve():
        return True
    try:
        return os.path.samefile(pa, pb)
    except OSError:
        return False


def inside(path: str | os.PathLike[str], folder: str | os.PathLike[str]) -> bool:
    """``path`` is ``folder`` or lies below it (resolved)."""
    p, f = Path(path).resolve(), Path(folder).resolve()
    return p == f or f in p.parents


def write_text_atomic(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file and a rename: a symbolic
    link at ``path`` is replaced, never written through, and a reader never sees
    half a file."""
    p = Path(path)
    tmp = p.with_name(f".{p.name}.{os.getpid()}.{threading.get_ident()}.tmp")
    try:
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, p)
    finally:
        if tmp.exists():
            tmp.unlink()


# A spreadsheet runs a cell that starts with one of these as a formula (OWASP, "CSV
# injection"); tab and carriage return are what some spreadsheets strip before.
_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def csv_safe(value: Any) -> Any:
    """``value`` for a CSV cell: text that a spreadsheet would run as a formula
    (starting with ``= + - @``, tab or carriage return, and not a number) gets a
    leading apostrophe, which spreadsheets show as text; anything else unchanged."""
    if not isinstance(value, str) or not value.startswith(_FORMULA_START):
        return value
    try:
        float(value)
    except ValueError:
        return "'" + value
    return value


def csv_safe_frame(df: Any) -> Any:
    """A pandas DataFrame with :func:`csv_safe` applied to its text columns (a copy
    if anything changes)."""
    text = [c for c in df.columns if df[c].dtype.kind == "O"]  # object or string dtype
    if not text:
        return df
    df = df.copy()
    for c in text:
        df[c] = df[c].map(csv_safe)
    return df
