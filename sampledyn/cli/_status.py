"""Exit statuses of the ``sampledyn`` command and the one-line message of each failure.

Every failure ends the command with one line on stderr, ``sampledyn: error: ...``,
naming the path or the option, and an exit status that tells its kind (the table
below, also in ``sampledyn --help`` and ``docs/cli.md``). ``--debug`` or
``SAMPLEDYN_DEBUG=1`` prints the traceback before that line.
"""

from __future__ import annotations

import errno
import re
import signal
from typing import Any

from ..exceptions import ArgumentError, MissingArgumentError, NumericalError, UsageError

__all__ = [
    "EXIT_BAD_VALUE",
    "EXIT_DISK",
    "EXIT_FILE",
    "EXIT_HANGUP",
    "EXIT_INTERNAL",
    "EXIT_INTERRUPTED",
    "EXIT_NUMERICAL",
    "EXIT_OK",
    "EXIT_PIPE",
    "EXIT_STATUSES",
    "EXIT_TERMINATED",
    "EXIT_UNAVAILABLE",
    "ARGUMENT_OPTIONS",
    "EXIT_USAGE",
    "HangUp",
    "Terminated",
    "classify",
    "status_table",
]

EXIT_OK = 0
EXIT_INTERNAL = 1
EXIT_USAGE = 2
EXIT_BAD_VALUE = 3
EXIT_FILE = 4
EXIT_DISK = 5
EXIT_UNAVAILABLE = 6
EXIT_NUMERICAL = 7
EXIT_HANGUP = 128 + 1  # 129, SIGHUP
EXIT_INTERRUPTED = 128 + int(signal.SIGINT)  # 130
EXIT_PIPE = 128 + 13  # 141, as a Unix tool killed by SIGPIPE
EXIT_TERMINATED = 128 + int(signal.SIGTERM)  # 143

#: status -> what it means (the table of ``sampledyn --help``).
EXIT_STATUSES: dict[int, str] = {
    EXIT_OK: "success",
    EXIT_INTERNAL: "internal error (a bug: rerun with --debug and report the traceback)",
    EXIT_USAGE: "usage: unknown, missing or malformed option, or one that does not apply",
    EXIT_BAD_VALUE: "bad input value: out of range, unknown name, malformed sweep file, log, "
    "vehicle file, or a file that is not a results store (left untouched)",
    EXIT_FILE: "a file or folder cannot be read or written: missing, not permitted, "
    "read-only, a folder where a file is expected or the reverse",
    EXIT_DISK: "no space left (or an I/O error) while writing; "
    "finished cells in a store (--store) are kept",
    EXIT_UNAVAILABLE: "a worker or service died or does not answer (a killed worker process, "
    "the Dask scheduler); finished cells in a store (--store) are kept",
    EXIT_NUMERICAL: "a numerical method failed on these inputs (Newton did not converge, the "
    "exact integrator missed its tolerance); the message says what to change",
    EXIT_HANGUP: "hang-up (SIGHUP: the terminal closed); "
    "finished cells in a store (--store) are kept",
    EXIT_INTERRUPTED: "interrupted by Ctrl-C (SIGINT); "
    "finished cells in a store (--store) are kept",
    EXIT_PIPE: "the reader of the output went away (e.g. `| head`); quiet, as Unix tools",
    EXIT_TERMINATED: "terminated (SIGTERM); finished cells in a store (--store) are kept",
}


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread so that it unwinds like Ctrl-C."""


class HangUp(Terminated):
    """SIGHUP (the terminal closed), unwound like SIGTERM."""


_DISK_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EIO}


def status_table() -> str:
    """The exit statuses as lines ``  N  meaning`` (for help texts)."""
    return "\n".join(f"  {code:>3d}  {text}" for code, text in EXIT_STATUSES.items())


def _os_message(exc: OSError) -> str:
    text = exc.strerror or str(exc)
    if exc.filename is None:
        return text
    where = str(exc.filename)
    if exc.filename2 is not None:
        where += f" -> {exc.filename2}"
    return f"{where}: {text}"


def _sqlite_status(exc: Exception) -> int:
    text = str(exc).lower()
    if "full" in text or "disk i/o" in text:
        return EXIT_DISK
    if "readonly" in text or "unable to open" in text or "locked" in text:
        return EXIT_FILE
    return EXIT_BAD_VALUE


def _broken_pool(exc: BaseException) -> bool:
    from concurrent.futures.process import BrokenProcessPool

    return isinstance(exc, BrokenProcessPool)


#: Library argument -> the option (its ``dest``) that gives it, where the names differ.
ARGUMENT_OPTIONS: dict[str, str] = {
    "base_seed": "seed",
    "tol": "newton_tol",  # Tustin's Newton options (evaluate, advise)
    "max_iter": "newton_max_iter",
    "name_or_path": "vehicle",  # load_vehicle's
    "method": "methods",  # get_method's
}


def _mentions(text: str, flag: str) -> bool:
    """``text`` names option ``flag`` (``--h`` is not named by ``--hold-gains``)."""
    return re.search(rf"{re.escape(flag)}(?![\w-])", text) is not None


def _with_options(text: str, argument: str, options: dict[str, str]) -> str:
    """``text`` with the option that gave ``argument`` in front (``--h: ...``), and the
    option of any other argument it names in backticks after that name (unless the
    text names the option already)."""
    for dest, flag in options.items():
        named = f"`{dest}`"
        if dest != argument and named in text and not _mentions(text, flag):
            text = text.replace(named, f"{named} ({flag})", 1)
    own = options.get(ARGUMENT_OPTIONS.get(argument, argument))
    return text if own is None or _mentions(text, own) else f"{own}: {text}"


def classify(
    exc: BaseException, options: dict[str, str] | None = None, kept: str | None = None
) -> tuple[int, str]:
    """The exit status and the one-line message of ``exc``.

    ``kept`` is what the command says of its finished work when it stops early (its
    ``on_interrupt`` note: in a store, or not kept without ``--store``); a worker that
    died ends with it.

    The one place where library errors meet options: an
    :class:`~sampledyn.exceptions.ArgumentError` names its ``argument``, and when the
    command has an option for it (``options``: dest -> flag, with
    :data:`ARGUMENT_OPTIONS` for names that differ) the message starts with the option
    (``--h: sampling period `h` must be ...``).
    An option name attached to a file error as ``exc.sampledyn_option`` (see
    ``_common.option``) prefixes the message.
    """
    import sqlite3

    status: int
    if isinstance(exc, UsageError | MissingArgumentError):
        status, text = EXIT_USAGE, str(exc)
    elif _broken_pool(exc):
        status, text = (
            EXIT_UNAVAILABLE,
            "a worker process died (killed by a signal, or out of memory) while computing "
            "cells; "
            + (kept or "the finished cells are kept: rerun the same command to compute the rest"),
        )
    elif isinstance(exc, OSError) and exc.errno == errno.EBADF and exc.filename is None:
        status, text = EXIT_FILE, "standard output is closed: the output has nowhere to go"
    elif isinstance(exc, ConnectionError):
        status, text = EXIT_UNAVAILABLE, str(exc)
    elif isinstance(exc, OSError):
        # Anything else the system says about a path is about that file or folder.
        status = EXIT_DISK if exc.errno in _DISK_ERRNOS else EXIT_FILE
        text = _os_message(exc)
    elif isinstance(exc, sqlite3.Error):
        status, text = _sqlite_status(exc), f"SQLite: {exc}"
    elif isinstance(exc, ValueError | TypeError):
        status, text = EXIT_BAD_VALUE, str(exc)
    elif isinstance(exc, NumericalError):
        status, text = EXIT_NUMERICAL, str(exc)
    else:
        status = EXIT_INTERNAL
        text = (
            f"internal error {type(exc).__name__}: {exc} (rerun with --debug for the traceback "
            "and report it)"
        )
    option: Any = getattr(exc, "sampledyn_option", None)
    if option and not text.startswith(option):
        text = f"{option} {text}" if status == EXIT_FILE else f"{option}: {text}"
    elif isinstance(exc, ArgumentError) and options:
        text = _with_options(text, exc.argument, options)
    return status, " ".join(text.split())
