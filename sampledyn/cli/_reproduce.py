"""``sampledyn reproduce STUDY``: the paper's figures and tables, and the controller
studies, generated from the study registry (:data:`sampledyn.experiments.STUDIES`).

The choices, the options and the help come from the registry; nothing here names a
study. Every option is checked before any work: one a study does not take is
refused by name, as are several values where it takes one and a value outside its
choices; the values themselves are checked once, by the study's settings and the
engine's grid (``SweepConfig``), when the grids are made, before anything runs.
"""

from __future__ import annotations

import argparse
import gc
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .. import _checks as checks
from ._common import (
    Parser,
    floats,
    ints,
    names,
    option,
    progress,
    refuse,
    writable_dir,
    writable_file,
)

__all__ = ["add_parser"]

_ENGINE_FLAGS = {"store": "--store", "workers": "--workers", "scheduler": "--scheduler"}


def _studies() -> dict[str, Any]:
    from ..experiments import STUDIES

    return STUDIES


def _options() -> dict[str, list[tuple[str, Any]]]:
    """Option name -> [(study, how it takes it)], in the order the studies list them."""
    out: dict[str, list[tuple[str, Any]]] = {}
    for name, entry in _studies().items():
        for take in entry.takes:
            out.setdefault(take.option.name, []).append((name, take))
    return out


def _given(args: argparse.Namespace, name: str) -> Any:
    return getattr(args, name, None)


def _refuse_unused(args: argparse.Namespace, entry: Any, options: dict[str, Any]) -> None:
    unused = [n for n in options if entry.take(n) is None and _given(args, n) is not None]
    if unused:
        flags = [options[n][0][1].option.flag for n in unused]
        users = sorted({study for n in unused for study, _t in options[n]})
        negated = [f"{f}/--no-{f[2:]}" if options[n][0][1].option.type is bool else f
                   for f, n in zip(flags, unused, strict=True)]  # fmt: skip
        refuse(
            f"reproduce {entry.name} does not use {', '.join(negated)} "
            f"(options of {', '.join(users)})."
        )


def _value(entry: Any, take: Any, raw: Any) -> Any:
    """The typed value of one option for the study: a tuple, or one value."""
    opt = take.option
    values = names(raw) if opt.type is str and isinstance(raw, str) else raw
    if isinstance(values, tuple) and not take.many:
        if len(values) != 1:
            shown = ",".join(f"{v:g}" if isinstance(v, float) else str(v) for v in values)
            refuse(
                f"reproduce {entry.name} takes one {opt.flag}; got {len(values)} values "
                f"({shown}): run the command once per value."
            )
        values = values[0]
    if take.choices is not None and values not in take.choices:
        refuse(
            f"reproduce {entry.name} reports the {opt.name}s {', '.join(take.choices)}, not "
            f"`{opt.flag} {values}`."
        )
    return values


def _values(args: argparse.Namespace, entry: Any) -> dict[str, Any]:
    """The options given for the study, as its settings take them."""
    out = {}
    for take in entry.takes:
        raw = _given(args, take.option.name)
        if raw is not None:
            out[take.option.name] = _value(entry, take, raw)
    return out


def _engine(args: argparse.Namespace, default_workers: int | None) -> dict[str, Any]:
    """The engine options of a reproduce run (store, workers, Dask), checked now."""
    if args.workers is not None and args.scheduler is not None:
        refuse("give --workers or --scheduler, not both.")
    if args.workers is not None:
        checks.count(args.workers, "workers")
    out: dict[str, Any] = {"store": args.store}
    if args.scheduler is not None:
        out["scheduler"] = args.scheduler
    else:
        out["workers"] = default_workers if args.workers is None else args.workers
    if args.store is not None:
        from ..experiments.sweep._store import inspect_store

        with option("--store"):
            writable_file(args.store, "--store")
            inspect_store(Path(args.store))  # refuses a foreign file, untouched
        args.on_interrupt = (
            f"the finished cells are in {args.store}; rerun the same command to compute the rest"
        )
    else:
        args.on_interrupt = (
            "without --store the finished cells were not kept and no table or figure was "
            "written; give --store FILE to keep them (a rerun then computes only the rest)"
        )
    return out


class _Ahead:
    """A study's report preparation (:attr:`StudyEntry.prepare`) in a daemon thread,
    started when the engine has started (local workers forked: a fork must not copy a
    thread in flight), so that it overlaps the cells; the report waits for it, so the
    two never import the same modules at once. A failure is left to the report, which
    meets it again where it is reported."""

    def __init__(self, prepare: Callable[[], object] | None) -> None:
        self._prepare = prepare
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        if self._prepare is None or self._thread is not None:
            return
        self._thread = threading.Thread(
            target=self._run, name="sampledyn-report-prepare", daemon=True
        )
        self._thread.start()

    def _run(self) -> None:
        assert self._prepare is not None
        try:
            self._prepare()
        except Exception:  # the report does the same work, and reports it
            return

    def wait(self) -> None:
        if self._thread is not None:
            self._thread.join()


def _run(args: argparse.Namespace) -> int:
    entry = _studies()[args.study]
    _refuse_unused(args, entry, _options())
    values = _values(args, entry)
    definition = entry.load()
    settings = definition.settings(**values)
    configs = definition.configs(settings)  # every grid value checked here, once
    out = writable_dir(args.out or definition.default_out(settings, configs), "--out")
    engine = _engine(args, entry.workers)

    def say(text: str) -> None:
        print(f"{entry.name}: {text}", flush=True)

    ahead = _Ahead(entry.prepare_function())

    def started() -> None:
        # What is loaded by now (modules, kernels, the plan) lives to the end: the
        # collections while the results come in need not walk it (4 full collections
        # of some 200,000 objects took 0.6 CPU s of a `reproduce fig7`). main() undoes
        # it when it returns.
        gc.freeze()
        ahead.start()

    output = definition.run(
        settings, configs=configs, progress=progress(args), say=say, on_start=started, **engine
    )
    ahead.wait()
    gc.freeze()  # matplotlib's modules, imported meanwhile
    for line in entry.report_function()(output, out, store=args.store):
        print(line)
    return 0


def _arg_type(option: Any, many: bool) -> Any:
    if option.type is str:
        return str
    if many:
        return floats if option.type is float else ints
    return option.type


def _help(option: Any, uses: list[tuple[str, Any]], n_studies: int) -> str:
    one = [s for s, t in uses if not t.many]
    several = [s for s, t in uses if t.many]
    text = option.help
    if len(uses) < n_studies:
        text += f" ({', '.join(s for s, _t in uses)} only)"
    if one and several:
        text += f"; {', '.join(one)}: one value; {', '.join(several)}: comma-separated"
    elif several and option.type is not bool:
        text += "; comma-separated"
    return text


class _ReproduceParser(Parser):
    """The ``reproduce`` parser; its help ends with each study's defaults (which
    load the studies: only when help is asked for)."""

    def format_help(self) -> str:
        lines = ["", "defaults of each study:"]
        for name, entry in _studies().items():
            definition = entry.load()
            shown = ", ".join(f"{t.option.flag} {_shown(v)}"
                              for t in entry.takes
                              for v in [definition.defaults().get(t.option.name)]
                              if v is not None)  # fmt: skip
            workers = "this process" if entry.workers is None else f"{entry.workers} workers"
            lines.append(f"  {name}: {shown}; {workers}")
        return super().format_help() + "\n".join(lines) + "\n"


def _shown(value: Any) -> str:
    if isinstance(value, tuple | list):
        return ",".join(_shown(v) for v in value)
    return f"{value:g}" if isinstance(value, float) else str(value)


def add_parser(sub: Any, parents: list[argparse.ArgumentParser]) -> None:
    """Add ``reproduce`` to the subparsers ``sub``, from the study registry."""
    import textwrap

    studies = _studies()
    listing = "\n".join(
        textwrap.fill(f"{name}: {entry.summary}.", 88, initial_indent="  ",
                      subsequent_indent="    ")
        for name, entry in studies.items()
    )  # fmt: skip
    intro = (
        "Regenerate the results of the paper 'On the Adequacy of Adams-Bashforth "
        "Sampled-Data Models for Characterizing Complex Underwater-Vehicle Dynamics with "
        "Noisy Measurements' (equation numbers refer to it), and the controller studies."
    )
    engine = (
        "Every study runs on the experiment engine: --store keeps the cells in a results "
        "store, so a killed run resumes and `sampledyn results`/`report` read it (without "
        "--store an interrupted run keeps nothing); --workers "
        "and --scheduler choose where the cells are computed. Writes CSV and PNG into --out "
        "and prints the table. Options a study does not take are refused."
    )
    rep = sub.add_parser(
        "reproduce",
        parents=parents,
        help=f"regenerate a figure or table of the paper or a study ({', '.join(studies)})",
        description=f"{textwrap.fill(intro, 88)}\n\nstudies:\n{listing}\n\n"
        f"{textwrap.fill(engine, 88)}",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    rep.__class__ = _ReproduceParser
    rep.add_argument("study", choices=list(studies), help="which study to run")
    rep.add_argument(
        "--out",
        help="output folder (default: out/STUDY; fig7 with a vehicle other than the "
        "RexROV: out/fig7_VEHICLE)",
    )
    for name, uses in _options().items():
        opt = uses[0][1].option
        many = any(t.many for _s, t in uses)
        choices = [c for _s, t in uses for c in (t.choices or ())]
        kwargs: dict[str, Any] = {"default": None, "help": _help(opt, uses, len(studies))}
        if opt.type is bool:
            kwargs["action"] = argparse.BooleanOptionalAction
        else:
            kwargs["type"] = _arg_type(opt, many)
            kwargs["metavar"] = opt.metavar or name.upper()
        if choices and not many:
            kwargs["choices"] = list(dict.fromkeys(choices))
            kwargs.pop("metavar", None)
        rep.add_argument(opt.flag, dest=name, **kwargs)
    rep.add_argument(
        "--store",
        default=None,
        help="results store (SQLite file): keep the cells there; rerunning after a kill "
        "computes only the missing ones; `sampledyn report STORE` renders them",
    )
    rep.add_argument(
        "--workers",
        type=int,
        default=None,
        help="local worker processes (1: in this process; default: the study's, see below)",
    )
    rep.add_argument(
        "--scheduler", default=None, help="address of a Dask scheduler, e.g. tcp://host:8786"
    )
    rep.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    rep.set_defaults(func=_run)
