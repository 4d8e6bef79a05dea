"""The built-in studies as plug-ins: one protocol, one registry.

A *study* (``sampledyn reproduce STUDY``) is a typed settings object, the grids it
runs on the experiment engine (one :class:`~sampledyn.experiments.sweep.SweepConfig`
per engine run), the rows it makes of the cells, a summary of the rows, and a report
function (in :mod:`sampledyn.report`) that writes its files and says what it found.
:class:`StudyDefinition` is that protocol; :data:`STUDIES` lists the studies, each
with the options it takes. The command line builds ``reproduce``, its choices, its
options and its help from this table, checks which options apply to which study from
it, and runs any study the same way; nothing in it names a study.

Options have shared names (:data:`SHARED`): ``h``, ``T``, ``after``, ``seeds``,
``seed``, ``vehicle``, ``methods``, ``norm``. A study's settings dataclass has a field
of the same name for each option it takes, a tuple where the study takes several
values (``h`` of Fig. 7, ``vehicle`` of the closed-loop study) and one value where it
takes one (``h`` of Figs. 2-3). Every value is checked once, where it lands: the grid
values by :class:`~sampledyn.experiments.sweep.SweepConfig`, the study's own by its
settings.

Adding a study: its module (settings, a :class:`StudyDefinition`), its registration
line below, its report function, its test.

This module is light (the standard library and numpy), so that the command line can build
its parser without loading the numerical kernels; an entry's definition and report
function are imported on first use.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from .._local_errors import ERROR_NORMS

__all__ = [
    "SHARED",
    "STUDIES",
    "Option",
    "StudyDefinition",
    "StudyEntry",
    "StudyOutput",
    "Take",
    "available_studies",
    "get_study",
    "register_study",
]


@dataclass(frozen=True)
class Option:
    """A typed option of the studies (a settings field, the flag ``--name``).

    Attributes
    ----------
    name : str
        The settings field; the flag is ``--`` + name with ``_`` as ``-``.
    type : type
        float, int, str or bool (a switch with a ``--no-`` form).
    help : str
        What it is, with its unit.
    metavar : str, optional
        How the help shows its value.
    """

    name: str
    type: type
    help: str
    metavar: str | None = None

    @property
    def flag(self) -> str:
        return "--" + self.name.replace("_", "-")


@dataclass(frozen=True)
class Take:
    """How a study takes an option: one value or several (``many``: a tuple,
    comma-separated on the command line), and the values it accepts (``choices``,
    None: any the option's type allows)."""

    option: Option
    many: bool = False
    choices: tuple[str, ...] | None = None


#: The options every study that has the concept names the same way.
SHARED: dict[str, Option] = {
    o.name: o
    for o in (
        Option("h", float, "sampling period h (s)", "H[,H...]"),
        Option("T", float, "duration of each run (s)"),
        Option("after", float, "errors (residuals) are measured on t >= after (s)"),
        Option("seeds", int, "noise seeds per noisy cell (the noise-free cell runs once)"),
        Option("seed", int, "root seed (of the study's input, or of its noise seeds)"),
        Option("vehicle", str, "built-in vehicle name or vehicle TOML file", "NAME[,NAME...]"),
        Option("methods", str, "method names of the registry (`sampledyn methods`)", "M[,M...]"),
        Option("norm", str, "norm shown in the table and figure (the CSV has them all)"),
    )
}


def _takes(*spec: str | Take) -> tuple[Take, ...]:
    """``"h+"``: the shared option h, several values; ``"T"``: one value."""
    out = []
    for s in spec:
        if isinstance(s, Take):
            out.append(s)
        else:
            out.append(Take(SHARED[s.rstrip("+")], many=s.endswith("+")))
    return tuple(out)


@dataclass(frozen=True)
class StudyOutput:
    """What a study run gives its report.

    Attributes
    ----------
    study : str
        The study's name.
    settings : object
        Its settings.
    results : tuple of StudyResult
        One per engine run (:func:`sampledyn.experiments.run_study`), in order.
    rows : list of dict
        The study's rows (one per cell or per group of cells; the ``_runs.csv``).
    summary : list of dict
        The rows summarised (means over seeds; the table).
    """

    study: str
    settings: Any
    results: tuple[Any, ...]
    rows: list[dict[str, Any]]
    summary: list[dict[str, Any]]

    @property
    def configs(self) -> tuple[Any, ...]:
        """The grid of each engine run."""
        return tuple(r.study.config for r in self.results)

    def describe(self, store: Any = None) -> list[str]:
        """One line per engine run: what it computed and found stored."""
        return [f"{r.study.config.vehicle}: {r.summary.describe(store)}" for r in self.results]


class StudyDefinition:
    """A study on the experiment engine (subclass it, register an instance).

    Class attributes
    ----------------
    name : str
        The registry name (``reproduce NAME``).
    settings_type : type
        The frozen dataclass of its typed options (defaults: the study's).
    """

    name: str = ""
    settings_type: type = object

    def settings(self, **values: Any) -> Any:
        """Settings from option values (the study's defaults for the others)."""
        return self.settings_type(**values)

    def configs(self, settings: Any) -> tuple[Any, ...]:
        """The engine grids of ``settings``, one per engine run, checked now (so a
        bad value fails before any work)."""
        raise NotImplementedError

    def rows(self, settings: Any, results: Sequence[Any]) -> list[dict[str, Any]]:
        """The study's rows from the engine's results (one per config)."""
        raise NotImplementedError

    def summary(self, settings: Any, rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
        """The rows summarised (default: the rows)."""
        return rows

    def defaults(self) -> dict[str, Any]:
        """Option name -> the study's default value (for help texts)."""
        settings = self.settings()
        return {f: getattr(settings, f) for f in getattr(settings, "__dataclass_fields__", {})}

    def default_out(self, settings: Any, configs: Sequence[Any]) -> str:
        """The default output folder: ``out/<name>``."""
        return f"out/{self.name}"

    def run(
        self,
        settings: Any,
        *,
        configs: Sequence[Any] | None = None,
        store: Any = None,
        workers: int | None = None,
        scheduler: str | None = None,
        progress: bool = False,
        say: Callable[[str], None] | None = None,
        on_start: Callable[[], object] | None = None,
    ) -> StudyOutput:
        """Run the study on the engine.

        Parameters
        ----------
        settings : the study's settings
        configs : sequence of SweepConfig, optional
            The grids, if :meth:`configs` was called already.
        store : path, optional
            Results store: the cells are kept there, a rerun (after a kill) computes
            only the missing ones, and ``sampledyn results`` / ``report`` read them.
        workers : int, optional
            Local worker processes (None or 1: this process).
        scheduler : str, optional
            Address of a Dask scheduler instead.
        progress : bool
            Show the engine's progress bar.
        say : callable, optional
            Called with one line per engine run (what it computed, found stored).
        on_start : callable, optional
            Called once, when the first engine run that computes cells has started
            (:func:`~sampledyn.experiments.sweep.run_sweep`'s ``on_start``).
        """
        from .sweep._run import backend_options, run_study

        options = backend_options(workers, scheduler, progress)
        results = []
        started = [] if on_start is None else [on_start]

        def start() -> None:
            if started:
                started.pop()()

        for config in self.configs(settings) if configs is None else configs:
            result = run_study(config, store, on_start=start, **options)
            if say is not None:
                say(f"{config.vehicle}: {result.summary.describe(store)}")
            results.append(result)
        rows = self.rows(settings, results)
        return StudyOutput(self.name, settings, tuple(results), rows, self.summary(settings, rows))


def _load(ref: str) -> Any:
    module, _, attribute = ref.partition(":")
    return getattr(importlib.import_module(module), attribute)


@dataclass(frozen=True)
class StudyEntry:
    """A registered study.

    Attributes
    ----------
    name : str
        ``reproduce NAME``.
    summary : str
        One line for ``sampledyn reproduce --help``.
    takes : tuple of Take
        The options it takes (any other one given is refused by name).
    definition : str
        ``"module:attribute"`` of its :class:`StudyDefinition` (imported on first use).
    report : str
        ``"module:attribute"`` of its report function, ``report(output, out) ->
        (lines, files)``.
    workers : int or None
        Local worker processes by default (None: this process).
    prepare : str, optional
        ``"module:attribute"`` of a function without arguments that does ahead what
        the report would do first and that does not depend on the results (imports,
        matplotlib's fonts and text parser): ``reproduce`` runs it in a thread while
        the workers compute the cells, so it does not add to the run's time.
    """

    name: str
    summary: str
    takes: tuple[Take, ...]
    definition: str
    report: str
    workers: int | None = None
    prepare: str | None = None
    _cache: dict[str, Any] = field(default_factory=dict, compare=False, repr=False)

    def take(self, name: str) -> Take | None:
        """How the study takes option ``name`` (None: not at all)."""
        return next((t for t in self.takes if t.option.name == name), None)

    def load(self) -> StudyDefinition:
        """The study's definition (imported now)."""
        if "definition" not in self._cache:
            self._cache["definition"] = _load(self.definition)
        return self._cache["definition"]

    def report_function(self) -> Callable[..., Any]:
        """Its report function (imported now)."""
        return _load(self.report)

    def prepare_function(self) -> Callable[[], object] | None:
        """Its report's preparation (:attr:`prepare`; imported when called), or None."""
        if self.prepare is None:
            return None
        ref = self.prepare
        return lambda: _load(ref)()


STUDIES: dict[str, StudyEntry] = {}


def register_study(entry: StudyEntry) -> None:
    """Add ``entry`` to :data:`STUDIES`.

    Raises
    ------
    ValueError
        if the name is taken, or an option of the same name as another study's
        differs from it (type or help).
    """
    if entry.name in STUDIES:
        raise ValueError(f"study {entry.name!r} is already registered.")
    known = {t.option.name: t.option for e in STUDIES.values() for t in e.takes}
    for t in entry.takes:
        other = known.get(t.option.name)
        if other is not None and other != t.option:
            raise ValueError(
                f"study {entry.name!r}: option {t.option.flag} differs from the one of the "
                "same name that other studies take; give it another name."
            )
    STUDIES[entry.name] = entry


def available_studies() -> dict[str, str]:
    """Study name -> one line."""
    return {name: e.summary for name, e in STUDIES.items()}


def get_study(name: str) -> StudyEntry:
    """The registered study ``name``.

    Raises
    ------
    ValueError
        for an unknown name, listing the registered ones.
    """
    if name not in STUDIES:
        raise ValueError(f"unknown study {name!r}; registered: {', '.join(STUDIES)}.")
    return STUDIES[name]


_RATIOS = Option("ratios", int, "h_u/h values, one curve each", "R[,R...]")
_HOLD = Option(
    "attitude_hold",
    bool,
    "close a roll-pitch PD loop on the vertical thrusters, or not (--no-attitude-hold: the "
    "paper's open-loop input); default: the vehicle's entry in the study table "
    "(sampledyn/experiments/studies/fig7.toml)",
)
_GAINS = Option(
    "hold_gains",
    float,
    "gains of the roll-pitch hold, KP in N m/rad and KD in N m s/rad (> 0), instead of the "
    "study table's for the vehicle; the hold must be on",
    "KP,KD",
)
_AUV = ("h", "T", "after", "seed", "methods+", Take(SHARED["norm"], choices=ERROR_NORMS),
        Take(_RATIOS, many=True))  # fmt: skip

register_study(
    StudyEntry(
        "fig2",
        "local-error norms of the multistep rules of the registry (AB_s, ABu_s, ABj_s, ABe_s) "
        "against s, one curve per h_u/h, on the AUV-like system (9)-(10)",
        _takes(*_AUV),
        "sampledyn.experiments._auv:FIG2",
        "sampledyn.report._auv_figs:auv_report",
    )
)
register_study(
    StudyEntry(
        "fig3",
        "the same for the one-step rules (E, T, RK_s, Ee)",
        _takes(*_AUV),
        "sampledyn.experiments._auv:FIG3",
        "sampledyn.report._auv_figs:auv_report",
    )
)
register_study(
    StudyEntry(
        "fig7",
        "the ROV study of section 6 (Fig. 6 input, the 12 noise pairs, Monte Carlo over "
        "--seeds) on the RexROV open loop as in the paper (--vehicle to choose), next to "
        "the paper's numbers",
        _takes(
            "h+",
            "T",
            "after",
            "seeds",
            "seed",
            "vehicle",
            "methods+",
            Take(SHARED["norm"], choices=("l2_over_n", "rms")),
            Take(_HOLD),
            Take(_GAINS, many=True),
        ),  # fmt: skip
        "sampledyn.experiments._rov:FIG7",
        "sampledyn.report._fig7:fig7_report",
        workers=2,
        prepare="sampledyn.report._fig7:prepare_fig7_report",
    )
)
register_study(
    StudyEntry(
        "closed-loop",
        "the same discrete LQR (depth/heading/surge hold) designed on each rule's "
        "discrete-time model (and on the exact ZOH), run on the exact vehicles with "
        "thruster saturation and noise: residual sets and effort",
        _takes("h+", "T", "after", "seeds", "seed", "vehicle+", "methods+"),
        "sampledyn.experiments._closed_loop:CLOSED_LOOP_STUDY",
        "sampledyn.report._closed_loop:closed_loop_report",
        workers=2,
    )
)
register_study(
    StudyEntry(
        "multistep",
        "k-step-ahead errors and free runs of each rule's discrete-time model on the RexROV "
        "(Fig. 6 input)",
        _takes("h+", "T", "after", "seeds", "seed", "vehicle", "methods+"),
        "sampledyn.experiments._multistep:MULTISTEP_STUDY",
        "sampledyn.report._closed_loop:multistep_report",
        workers=2,
    )
)
