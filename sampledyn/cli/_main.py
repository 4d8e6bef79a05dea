"""The ``sampledyn`` command: the parser, and ``main``, which turns every failure into
one line and an exit status (see :mod:`._status`)."""

from __future__ import annotations

import argparse
import errno
import gc
import os
import signal
import sys
import threading
import traceback
import warnings
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any, NoReturn

from . import _advise, _evaluate, _methods, _reproduce, _sweep
from ._common import Parser, common_options
from ._status import (
    EXIT_HANGUP,
    EXIT_INTERRUPTED,
    EXIT_PIPE,
    EXIT_TERMINATED,
    HangUp,
    Terminated,
    UsageError,
    classify,
    status_table,
)

__all__ = ["build_parser", "main"]

_DEBUG_ENV = "SAMPLEDYN_DEBUG"
# Commands quick enough to need no start-up line.
_QUICK = {"methods"}


def _version() -> str:
    from .._version import __version__

    return __version__


def build_parser() -> argparse.ArgumentParser:
    """The ``sampledyn`` argument parser (every command and option has a help text)."""
    common = common_options()
    parser = Parser(
        prog="sampledyn",
        parents=[common],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            "Sampled-data models of vehicle dynamics: build Euler, Tustin, Runge-Kutta and "
            "Adams-Bashforth one-step predictors from continuous-time models, run them on "
            "exact (and noisy) samples, and measure their local errors; reproduces the "
            "paper 'On the Adequacy of Adams-Bashforth Sampled-Data Models for "
            "Characterizing Complex Underwater-Vehicle Dynamics with Noisy Measurements'."
        ),
        epilog=(
            "exit status:\n"
            f"{status_table()}\n\n"
            "Every error ends with one line 'sampledyn: error: ...' naming the file or the "
            f"option; --debug or {_DEBUG_ENV}=1 also prints the traceback."
        ),
    )
    parser.add_argument(
        "--version", action="version", version=f"sampledyn {_version()}", help="print the version"
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    parents = [common]
    _reproduce.add_parser(sub, parents)
    _methods.add_parser(sub, parents)
    _advise.add_parser(sub, parents)
    _sweep.add_parsers(sub, parents)
    _evaluate.add_parser(sub, parents)
    return parser


def _raise_terminated(signum: int, frame: Any) -> None:
    raise HangUp() if signum == _SIGHUP else Terminated()


_SIGHUP = getattr(signal, "SIGHUP", None)


@contextmanager
def _sigterm_as_interrupt() -> Iterator[None]:
    """SIGTERM and SIGHUP unwind the command like Ctrl-C (finished work is kept, workers are
    stopped), in the main thread only (signals cannot be set elsewhere)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    signals = [signal.SIGTERM] + ([_SIGHUP] if _SIGHUP is not None else [])
    previous = {s: signal.signal(s, _raise_terminated) for s in signals}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


def _format_warning(
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    line: str | None = None,
) -> str:
    return f"sampledyn: warning: {' '.join(str(message).split())}\n"


@contextmanager
def _one_line_warnings() -> Iterator[None]:
    """Library warnings print as one line each (not file:line plus source), and each
    text once per command (the library may warn of the same rule wherever it builds
    it: checking a grid, then running it; Python's own once-per-place registry is
    reset by every ``catch_warnings``)."""
    previous: Callable[..., str] = warnings.formatwarning
    show: Callable[..., None] = warnings.showwarning
    shown: set[tuple[type[Warning], str]] = set()

    def show_once(message: Warning | str, category: type[Warning], *rest: Any,
                  **kw: Any) -> None:  # fmt: skip
        key = (category, " ".join(str(message).split()))
        if key not in shown:
            shown.add(key)
            show(message, category, *rest, **kw)

    warnings.formatwarning = _format_warning
    warnings.showwarning = show_once
    try:
        yield
    finally:
        warnings.formatwarning = previous
        warnings.showwarning = show


def _quiet_stdout() -> None:
    """After a broken pipe, point stdout at /dev/null so the interpreter's final
    flush does not complain (the Python docs' recipe for SIGPIPE)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):
        pass  # stdout is not a file (e.g. captured by a test)


def _is_terminal(stream: Any) -> bool:
    """A person watches ``stream`` (as git, the start-up line goes to terminals only)."""
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


# What a first run after an install compiles, measured: `reproduce fig7` on the
# 2-core development machine, about 13 CPU s of compiling, the integrator's 6-8 s in a
# process of its own beside the rest (benchmarks/bench_fig7.py, row "first run": the
# whole run 11.8-16.2 s wall on the quiet machine; docs/benchmarks.md). The figure
# given is of the whole first run, rounded up for a loaded machine.
COMPILE_ESTIMATE = "about 15 s"


def compile_notice(command: str, stream: Any) -> Callable[[], None]:
    """Say once on ``stream`` (any stream: a terminal, a pipe, a CI log) that numba has
    started compiling, the moment it starts: the first run after an install, or the
    first with a new model, compiles its kernels before any output. Returns the
    function that stops listening. Nothing is said when the kernels load from the
    cache."""
    from numba.core import event  # numba's compile events (documented in its event API)

    class _Notice(event.Listener):
        said = False

        def on_start(self, ev: Any) -> None:
            if not self.said:
                self.said = True
                try:
                    stream.write(
                        f"sampledyn {command}: compiling the numerical kernels, once for this "
                        f"installation and model ({COMPILE_ESTIMATE}; later runs load them "
                        "from the cache in under a second)...\n"
                    )
                    stream.flush()
                except (OSError, ValueError):
                    pass  # a closed stream: nothing to tell

        def on_end(self, ev: Any) -> None:
            return None

    listener = _Notice()
    event.register("numba:compile", listener)
    return lambda: event.unregister("numba:compile", listener)


@contextmanager
def _memory(args: argparse.Namespace) -> Iterator[None]:
    """``--max-memory`` for this command and its worker processes."""
    from .._checks import memory_limit, parse_bytes

    size = getattr(args, "max_memory", None)
    if size is not None:
        try:
            parse_bytes(size, "--max-memory")
        except ValueError as exc:
            raise UsageError(str(exc)) from None
    with memory_limit(size):
        yield


def _options(parser: argparse.ArgumentParser, command: str) -> dict[str, str]:
    """The options of ``command``: dest -> its long flag (for naming them in errors)."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction) and command in action.choices:
            sub = action.choices[command]
            return {a.dest: flags[0] for a in sub._actions
                    for flags in [[f for f in a.option_strings if f.startswith("--")]]
                    if flags and a.dest != "help"}  # fmt: skip
    return {}


def _fail(status: int, text: str, debug: bool) -> NoReturn:
    try:
        if debug:
            traceback.print_exc()
        sys.stderr.write(f"sampledyn: error: {text}\n")
        sys.stderr.flush()
    except (OSError, ValueError, AttributeError):
        pass  # stderr closed: the exit status still tells
    raise SystemExit(status)


def _closed_streams() -> None:
    """A closed stderr (``2>&-``) goes to /dev/null (warnings and errors would raise
    inside the error handling; the exit status still tells); a closed stdout stays
    closed, so the first write fails with one line saying so."""
    if sys.stderr is None or _bad_fd(sys.stderr):
        sys.stderr = open(os.devnull, "w")  # noqa: SIM115 - for the life of the process
    if sys.stdout is None:
        sys.stdout = _Closed()


def _bad_fd(stream: Any) -> bool:
    try:
        os.fstat(stream.fileno())
    except (OSError, ValueError, AttributeError):
        return not hasattr(stream, "getvalue")  # a StringIO (tests) has no descriptor
    return False


class _Closed:
    """Standard output when the command was started without one."""

    def write(self, text: str) -> int:
        raise OSError(errno.EBADF, "standard output is closed")

    def flush(self) -> None:
        return None


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``sampledyn`` command; returns 0 on success, raises ``SystemExit``
    with the status of the table in ``sampledyn --help`` otherwise."""
    argv = list(sys.argv[1:] if argv is None else argv)
    frozen_before = gc.get_freeze_count()  # (a caller's own frozen objects stay so)
    _closed_streams()
    debug = "--debug" in argv or os.environ.get(_DEBUG_ENV, "") not in ("", "0")
    parser = build_parser()
    args = parser.parse_args(argv)
    quiet = bool(getattr(args, "quiet", False))
    announce = not quiet and args.command not in _QUICK
    if announce and _is_terminal(sys.stderr):
        sys.stderr.write(
            f"sampledyn {args.command}: loading the numerical kernels (the first run after an "
            f"install compiles them, {COMPILE_ESTIMATE})...\n"
        )
        sys.stderr.flush()
    stop_notice = compile_notice(args.command, sys.stderr) if announce else None
    try:
        with _sigterm_as_interrupt(), _one_line_warnings(), _memory(args):
            result = args.func(args)
            sys.stdout.flush()  # a closed pipe shows here, not at exit
    except BrokenPipeError:
        _quiet_stdout()
        raise SystemExit(EXIT_PIPE) from None
    except KeyboardInterrupt as exc:
        kind, status = (
            ("hang-up (SIGHUP)", EXIT_HANGUP)
            if isinstance(exc, HangUp)
            else ("terminated (SIGTERM)", EXIT_TERMINATED)
            if isinstance(exc, Terminated)
            else ("interrupted (Ctrl-C)", EXIT_INTERRUPTED)
        )
        note = getattr(args, "on_interrupt", None)
        _fail(status, f"{kind}" + (f"; {note}" if note else ""), debug)
    except Exception as exc:
        status, text = classify(
            exc, _options(parser, args.command), kept=getattr(args, "on_interrupt", None)
        )
        _fail(status, text, debug)
    finally:
        if stop_notice is not None:
            stop_notice()
        if not frozen_before:  # a command may freeze what it loaded (``reproduce``)
            gc.unfreeze()
    return int(result or 0)


def console() -> None:
    """The ``sampledyn`` program (``python -m sampledyn.cli`` and the installed
    command): :func:`main`, then the process ends with its status. Before it ends, the
    objects left are moved out of the garbage collector's reach (``gc.freeze``):
    Python's last collection at exit would walk them all for nothing (0.3 s after a
    ``reproduce fig7``, some 200,000 objects of numba and matplotlib)."""
    status = main()
    gc.freeze()
    sys.exit(status)


if __name__ == "__main__":
    console()
