"""The engine's value types and its one extension point, the cell kind.

A study is planned and run the same way whatever it computes: a grid of
trajectories (model x input x T x h) crossed with noise pairs, seeds, methods and
measures, one keyed cell each, chunked, claimed in the store and computed on the same
backends. What is computed once per trajectory (its *shared* part) and what one
cell computes is the study's **cell kind** (:class:`CellKind`):

``prediction`` (the default; :mod:`._prediction`)
    Shared: the exact samples of the model under the input. A cell: one rule's
    one-step prediction on the noisy samples, measured by one norm (sweeps, Figs. 2,
    3 and 7, the Monte Carlo of ``advise``, the bound validation).
``closed_loop``, ``multistep`` (:mod:`sampledyn.experiments`, registered there)
    The controller studies: a discrete LQR designed on each rule and run against the
    exact plant; k-step-ahead predictions and free runs.

A kind is registered once (:func:`register_cell_kind`) and named by a sweep file
(``kind = "closed_loop"``). The backends call :func:`prepare_shared` and
:func:`compute_cells`, which ask the study's kind; nothing else in the engine
depends on what a cell computes.
"""

from __future__ import annotations

import os
import re
import socket
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

from ...methods import get_method, get_predictor
from ...models import ClosedLoop, Model
from ._norms import NormSpec

__all__ = [
    "Cell",
    "CellKind",
    "Chunk",
    "Group",
    "PlannedGroup",
    "Setup",
    "SimPlan",
    "available_cell_kinds",
    "cell_order",
    "compute_cells",
    "get_cell_kind",
    "prepare_shared",
    "register_cell_kind",
    "warning_text",
    "worker_name",
]


@lru_cache(maxsize=256)
def cell_order(method: str) -> int | None:
    """Order s of the registered method ``method`` (AB<s>, RK<s>: s; E: 1; T: 2; ...;
    None for an exact map, ZOH)."""
    return get_method(method).order


@dataclass(frozen=True)
class Cell:
    """One planned cell: its key, its kind's coordinates (trajectory, h, noise pair,
    seed, method, measure) and its configuration as canonical JSON. What it stores is
    its kind's values (:attr:`CellKind.columns`)."""

    key: str
    traj_key: str
    h: float
    eta_pct: float
    v_pct: float
    seed: int
    method: str
    measure: str
    config: str  # canonical JSON


@dataclass(frozen=True)
class Group:
    """Cells on the same measured data: one noise pair and seed of one trajectory."""

    eta_pct: float
    v_pct: float
    seed: int
    cells: tuple[tuple[str, str, str], ...]  # (key, method, measure)


@dataclass(frozen=True)
class PlannedGroup:
    """The cells of one (trajectory, noise pair, seed), as planned (client side)."""

    traj_key: str
    sim_key: str
    h: float
    eta_pct: float
    v_pct: float
    seed: int
    cells: tuple[Cell, ...]

    def task_group(self, keys: set[str] | None = None) -> Group:
        """The :class:`Group` a worker computes: every cell, or those of ``keys``."""
        cells = tuple(
            (c.key, c.method, c.measure) for c in self.cells if keys is None or c.key in keys
        )
        return Group(self.eta_pct, self.v_pct, self.seed, cells)


@dataclass(frozen=True)
class Chunk:
    """One task: some groups of one trajectory (``sim_key``: its simulation)."""

    traj_key: str
    h: float
    groups: tuple[Group, ...]
    sim_key: str = ""

    @property
    def n_cells(self) -> int:
        return sum(len(g.cells) for g in self.groups)


@dataclass(frozen=True)
class SimPlan:
    """One simulation: the exact samples of input ``input_index`` at period ``h``,
    and the trajectories taken from it, ``members`` = ((traj_key, h, k), ...): every
    k-th sample (k = 1 for the simulated period itself)."""

    key: str
    input_index: int
    h: float
    members: tuple[tuple[str, float, int], ...]


@dataclass(frozen=True)
class Setup:
    """What every task needs besides its chunk (pickled to the workers).

    ``model`` is what is simulated (a closed loop, if the study closes one); ``plant``
    is the model the rules that use samples only predict with (the plant of a closed
    loop, else ``model``); ``signals`` one per input (none for a study without an
    input); ``norms`` parsed; ``kind`` the study's :class:`CellKind`; ``data`` what
    the kind computed once for the whole study on the client (e.g. a trim).
    """

    model: Model
    signals: tuple[Any, ...]
    T: float
    after: float
    base_seed: int
    distribution: str
    x0: tuple[float, ...] | None = None
    rtol: float = 1e-12
    summaries: tuple[str, ...] = ()
    norms: tuple[NormSpec, ...] = ()
    reference: Any = None
    kind: Any = None
    data: Any = None

    @property
    def signal(self) -> Any:
        """The first input (most studies have one; None for a study without one)."""
        return self.signals[0] if self.signals else None

    @property
    def closed_loop(self) -> bool:
        """True if the model is a plant closed by a feedback law."""
        return isinstance(self.model, ClosedLoop)

    @property
    def plant(self) -> Any:
        return self.model.plant if isinstance(self.model, ClosedLoop) else self.model


class CellKind:
    """What the cells of a study compute (subclass it and register an instance).

    Class attributes
    ----------------
    name : str
        The name a sweep file gives (``kind = "..."``).
    description : str
        One line for messages and ``--help``.
    uses : frozenset of str or None
        The sweep-file keys of the common grid this kind reads (``T``, ``h``,
        ``methods``, ``norm``, ``input``, ...); a file giving another one is refused
        by name. None: all of them.
    option_keys : tuple of str
        Sweep-file keys of the kind's own (checked by :meth:`check_options`).
    needs_input : bool
        The study is driven by an input signal (``input`` is required).
    subsample : bool
        The trajectories of periods that are integer multiples of another share one
        simulation at the smallest period (every k-th sample). False: each h is
        prepared on its own.
    measure_label : str
        What one entry of :meth:`measures` is called in messages ("norms").
    measure_name : str
        The name of the measure coordinate in the kind's view of the store ("norm"
        of a prediction, "horizon" of a multistep study; the store's column is
        ``measure``).
    columns : tuple of (str, type)
        The values one cell stores: column name and type (float, int, bool or
        str). The store holds them in columns of these names (``cells`` table) and
        shows them, with the common coordinates, in the view ``cells_<name>``.

    Every method gets the planned :class:`Setup` (pickled to the workers); the
    functions must be pure (same arguments, same numbers, on any worker).
    """

    name: str = ""
    description: str = ""
    uses: frozenset[str] | None = None
    option_keys: tuple[str, ...] = ()
    needs_input: bool = True
    subsample: bool = True
    measure_label: str = "measures"
    measure_name: str = "measure"
    columns: tuple[tuple[str, type], ...] = ()

    def check_options(self, options: Mapping[str, Any]) -> dict[str, Any]:
        """The kind's own settings from a sweep file (keys of :attr:`option_keys`
        only), checked and completed with defaults. Raises ValueError naming the key."""
        return dict(options)

    def check_method(self, name: str) -> None:
        """Raise (ValueError, naming it) if ``name`` is no method of this kind (here:
        a rule that predicts on sampled data)."""
        get_predictor(name, None)  # the grid's check names `methods`

    def method_order(self, name: str) -> int | None:
        """The order stored with a cell of method ``name`` (None if it has none)."""
        return cell_order(name)

    def measures(self, config: Any) -> tuple[str, ...]:
        """The innermost dimension of the grid: the cells one method computes on
        one measured trajectory (the norms of a prediction study)."""
        raise NotImplementedError

    def setup_data(self, config: Any, model: Model) -> Any:
        """What the whole study shares, computed once on the client when it is
        planned (picklable); None by default."""
        return None

    def prepare(self, setup: Setup, sim: SimPlan) -> dict[str, Any]:
        """The shared part of the trajectories of ``sim``, once: traj_key ->
        :class:`~sampledyn.experiments.sweep._compute.SimResult` (``meta`` becomes the
        trajectory's stored row)."""
        raise NotImplementedError

    def compute(self, setup: Setup, shared: Any, chunk: Chunk) -> Any:
        """Every cell of ``chunk`` on the shared part ``shared`` of its trajectory:
        a :class:`~sampledyn.experiments.sweep._compute.ChunkResult` with one row per cell
        (``key``, ``status``, ``seconds``, ``error``, ``warnings`` and ``values``: a
        dict of the kind's :attr:`columns`, empty or partial for a failed cell)."""
        raise NotImplementedError

    def warm_up(self, setup: Setup, h: float) -> None:
        """Compile what the cells need, here, before local workers fork (they
        inherit the compiled code). Failures are left to the cells to report."""
        return None

    def warm_up_cells(self, setup: Setup, sim: SimPlan, chunk: Chunk) -> None:
        """Compile what the cells of ``chunk`` need, on a short case, in a local worker
        while another simulates the exact samples (or, on a first run, in the sweep
        process while the integrator compiles in another: it must not need the
        integrator): the compiled kernels go to numba's disk cache, from which the
        other workers load them instead of compiling them too. Nothing is returned or
        stored; failures are left to the cells to report."""
        return None

    def decode(self, row: dict[str, Any]) -> dict[str, Any]:
        """A stored row's values in their types: NULL (or missing) as NaN for a float,
        None otherwise; an int stored for a bool as the bool."""
        out = {}
        for name, typ in self.columns:
            v = row.get(name)
            if v is None:
                out[name] = float("nan") if typ is float else None
            else:
                out[name] = typ(v)
        return out

    def __repr__(self) -> str:
        return f"<cell kind {self.name!r}>"


_KINDS: dict[str, CellKind] = {}
#: The built-in kinds of the studies above the engine, imported on first use (so the
#: table is complete in a fresh process, whatever was imported).
_BUILT_IN: dict[str, str] = {
    "prediction": "sampledyn.experiments.sweep._prediction:PREDICTION",
    "closed_loop": "sampledyn.experiments._closed_loop:CLOSED_LOOP",
    "multistep": "sampledyn.experiments._multistep:MULTISTEP",
}


_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def register_cell_kind(kind: CellKind) -> None:
    """Make ``kind`` available to sweep files and studies as ``kind.name``.

    Raises
    ------
    ValueError
        if the name is empty or taken by another kind, or a name that becomes a
        column or view of the store (the kind's, its measure's, its columns') is not a
        plain identifier (letters, digits, underscores).
    """
    if not kind.name:
        raise ValueError("a cell kind needs a `name`.")
    for what, text in [("name", kind.name), ("measure_name", kind.measure_name),
                       *(("columns", n) for n, _t in kind.columns)]:  # fmt: skip
        if not _IDENTIFIER.fullmatch(text):
            raise ValueError(
                f"cell kind {kind.name!r}: `{what}` {text!r} must be a plain identifier "
                "(letters, digits, underscores; it names a column or view of the store)."
            )
    old = _KINDS.get(kind.name)
    if old is not None and type(old) is not type(kind):
        raise ValueError(f"cell kind {kind.name!r} is already registered ({old!r}).")
    _KINDS[kind.name] = kind


def _names() -> list[str]:
    return list(dict.fromkeys([*_BUILT_IN, *_KINDS]))


def available_cell_kinds() -> dict[str, str]:
    """Registered cell kinds: name -> description (the built-in ones included)."""
    return {name: get_cell_kind(name).description for name in _names()}


def get_cell_kind(name: str) -> CellKind:
    """The registered cell kind ``name`` (a built-in one is imported on first use).

    Raises
    ------
    ValueError
        naming the registered kinds, for an unknown name.
    """
    if isinstance(name, str) and name not in _KINDS and name in _BUILT_IN:
        import importlib

        module, _, attribute = _BUILT_IN[name].partition(":")
        register_cell_kind(getattr(importlib.import_module(module), attribute))
    kind = _KINDS.get(name) if isinstance(name, str) else None
    if kind is None:
        raise ValueError(f"unknown cell kind {name!r}; registered: {', '.join(sorted(_names()))}.")
    return kind


def prepare_shared(setup: Setup, sim: SimPlan) -> dict[str, Any]:
    """The shared part of the trajectories of ``sim`` (the study's kind decides what:
    the exact samples, for a prediction study). What every backend runs once per
    simulation."""
    return setup.kind.prepare(setup, sim)


def warm_up_cells(setup: Setup, sim: SimPlan, chunk: Chunk) -> None:
    """The study's kind compiles the kernels of ``chunk``'s cells on a short case
    (:meth:`CellKind.warm_up_cells`). What a local pool runs beside the first
    simulation."""
    setup.kind.warm_up_cells(setup, sim, chunk)


def compute_cells(setup: Setup, shared: Any, chunk: Chunk) -> Any:
    """The cells of ``chunk`` (the study's kind computes them). What every backend
    runs per task."""
    return setup.kind.compute(setup, shared, chunk)


def worker_name() -> str:
    """``host:pid`` of this process (stored with the rows it computes)."""
    return f"{socket.gethostname()}:{os.getpid()}"


def warning_text(caught: list[warnings.WarningMessage], limit: int = 400) -> str:
    """The distinct messages of caught warnings, in one stored line."""
    return "; ".join(dict.fromkeys(str(w.message) for w in caught))[:limit]
