"""From a sweep grid to cells (one stored row each) and tasks (what a worker runs).

A cell is one (h, noise pair, seed, method, norm). Its key is the SHA-256 of its
configuration as canonical JSON, which holds the library version and fingerprints of
the model and the input, so a changed vehicle file, input mapping, norm or library
version gives new keys instead of mixing with old rows.

Cells that share exact samples (same vehicle, input, T, h) form one trajectory; cells
that share measured data (same noise pair and seed) form one group, whose f values
are computed once for every Adams-Bashforth order. A task is a chunk of groups of
one trajectory.

Planning is lazy: :func:`plan_study` builds the model and the input and checks them,
but lists no cell. :attr:`Study.n_cells` counts the grid by arithmetic, and
:meth:`Study.iter_groups` yields its groups one at a time, so a grid of any size is
counted at once and streamed in the memory of one group.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from ...methods import get_method
from ._config import SweepConfig
from ._inputs import build_model, make_input

__all__ = [
    "Cell",
    "Chunk",
    "Group",
    "PlannedGroup",
    "Setup",
    "Study",
    "cell_order",
    "plan_study",
]

SCHEMA = 1  # bump when the meaning of a stored number changes


def _canonical(obj: Any) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)


def digest(obj: Any) -> str:
    """SHA-256 (hex) of ``obj`` as canonical JSON."""
    return hashlib.sha256(_canonical(obj).encode()).hexdigest()


def _hash_numbers(values: np.ndarray) -> str:
    # 10 significant digits: insensitive to last-bit differences of libm across
    # machines, sensitive to any real change of a parameter or of the input.
    text = ",".join(f"{v:.9e}" for v in np.asarray(values, dtype=float).ravel())
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def model_fingerprint(model: Any) -> str:
    """Hash of ``model.f`` at 16 fixed pseudo-random points, with its names and units."""
    rng = np.random.default_rng(20240607)
    x0 = np.asarray(getattr(model, "default_x0", np.zeros(model.nx)), dtype=float)
    x = x0 + rng.uniform(-0.3, 0.3, (16, model.nx))
    u_scale = 0.5 * float(getattr(model, "n_max", 2.0))
    u = rng.uniform(-u_scale, u_scale, (16, model.nu))
    t = rng.uniform(0.0, 10.0, 16)
    f = np.asarray(model.f(t, x, u), dtype=float)
    names = "|".join((*model.state_names, *model.state_units, *model.input_names))
    return hashlib.sha256((names + _hash_numbers(f)).encode()).hexdigest()[:16]


def input_fingerprint(signal: Any, T: float) -> str:
    """Hash of the input at 512 fixed times in [0, T]."""
    t = np.linspace(0.0, T, 512)
    return _hash_numbers(np.asarray(signal(t), dtype=float))


def vehicle_label(vehicle: str) -> str:
    """A vehicle as recorded with its cells: a built-in name, or a file's name (its
    content is in the model fingerprint, so moving the file keeps the keys)."""
    return Path(vehicle).name if vehicle.endswith(".toml") else vehicle


@lru_cache(maxsize=256)
def cell_order(method: str) -> int:
    """Order s of the registered method ``method`` (AB<s>, RK<s>: s; E: 1; T: 2; ...)."""
    return int(get_method(method).order)


@dataclass(frozen=True)
class Cell:
    """One stored result: a method's error norm on one measured trajectory."""

    key: str
    traj_key: str
    h: float
    eta_pct: float
    v_pct: float
    seed: int
    method: str
    norm: str
    config: str  # canonical JSON


@dataclass(frozen=True)
class Group:
    """Cells on the same measured data: one noise pair and seed of one trajectory."""

    eta_pct: float
    v_pct: float
    seed: int
    cells: tuple[tuple[str, str, str], ...]  # (key, method, norm)


@dataclass(frozen=True)
class PlannedGroup:
    """The cells of one (trajectory, noise pair, seed), as planned (client side)."""

    traj_key: str
    h: float
    eta_pct: float
    v_pct: float
    seed: int
    cells: tuple[Cell, ...]

    def task_group(self, keys: set[str] | None = None) -> Group:
        """The :class:`Group` a worker computes: every cell, or those of ``keys``."""
        cells = tuple(
            (c.key, c.method, c.norm) for c in self.cells if keys is None or c.key in keys
        )
        return Group(self.eta_pct, self.v_pct, self.seed, cells)


@dataclass(frozen=True)
class Chunk:
    """One task: some groups of one trajectory."""

    traj_key: str
    h: float
    groups: tuple[Group, ...]

    @property
    def n_cells(self) -> int:
        return sum(len(g.cells) for g in self.groups)


@dataclass(frozen=True)
class Setup:
    """What every task needs besides its chunk (pickled to the workers)."""

    model: Any
    signal: Any
    T: float
    after: float
    base_seed: int
    distribution: str
    x0: tuple[float, ...] | None = None


def _seeds_of(config: SweepConfig, eta: float, v: float) -> Sequence[int]:
    # The noise-free pair does not depend on the seed: it runs once.
    return config.seeds[:1] if eta == 0 and v == 0 else config.seeds


@dataclass(frozen=True)
class Study:
    """A planned sweep: the model and input built once; cells listed on demand."""

    config: SweepConfig
    setup: Setup
    trajectories: dict[str, dict[str, Any]]  # traj_key -> its configuration
    model_fingerprint: str
    input_fingerprint: str
    version: str

    @property
    def groups_per_trajectory(self) -> int:
        """(noise pair, seed) groups of one trajectory, counted without listing them."""
        cfg = self.config
        zero = cfg.noise.count((0.0, 0.0))
        return zero * min(1, len(cfg.seeds)) + (len(cfg.noise) - zero) * len(cfg.seeds)

    @property
    def n_groups(self) -> int:
        return len(self.trajectories) * self.groups_per_trajectory

    @property
    def n_cells(self) -> int:
        """Cells in the grid, by arithmetic (instant for any size)."""
        return self.n_groups * len(self.config.methods) * len(self.config.norms)

    def size_text(self) -> str:
        """The factors of :attr:`n_cells`, for messages."""
        cfg = self.config
        return (
            f"{len(cfg.h)} h x {len(cfg.noise)} noise pairs x {len(cfg.seeds)} seeds (1 for "
            f"the noise-free pair) x {len(cfg.methods)} methods x {len(cfg.norms)} norms"
        )

    def iter_groups(self) -> Iterator[PlannedGroup]:
        """Every group with its cells and their keys, trajectory by trajectory; one
        group in memory at a time."""
        cfg = self.config
        for traj_key, tconf in self.trajectories.items():
            h = float(tconf["h"])
            for eta, v in cfg.noise:
                for seed in _seeds_of(cfg, eta, v):
                    cells = []
                    for method in cfg.methods:
                        for norm in cfg.norms:
                            cconf = {
                                **tconf,
                                "after": cfg.after,
                                "eta_pct": eta,
                                "v_pct": v,
                                "seed": seed,
                                "base_seed": cfg.base_seed,
                                "distribution": cfg.distribution,
                                "method": method,
                                "norm": norm,
                            }
                            text = _canonical(cconf)
                            key = hashlib.sha256(text.encode()).hexdigest()
                            cells.append(Cell(key, traj_key, h, eta, v, seed, method, norm, text))
                    yield PlannedGroup(traj_key, h, eta, v, seed, tuple(cells))

    def iter_cells(self) -> Iterator[Cell]:
        """Every cell, lazily (see :meth:`iter_groups`)."""
        for group in self.iter_groups():
            yield from group.cells

    @property
    def cells(self) -> tuple[Cell, ...]:
        """Every cell as a tuple. Lists the whole grid: for small grids and tests; use
        :meth:`iter_groups` or :attr:`n_cells` otherwise."""
        return tuple(self.iter_cells())

    def chunks(self, cells: Sequence[Cell], groups_per_chunk: int) -> list[Chunk]:
        """Tasks for ``cells``: grouped by trajectory, then by (noise pair, seed)."""
        if groups_per_chunk < 1:
            raise ValueError(f"`groups_per_chunk` must be >= 1, got {groups_per_chunk}.")
        by_traj: dict[str, dict[tuple[float, float, int], list[Cell]]] = {}
        for c in cells:
            by_traj.setdefault(c.traj_key, {}).setdefault((c.eta_pct, c.v_pct, c.seed), []).append(
                c
            )
        out: list[Chunk] = []
        for traj_key, groups in by_traj.items():
            h = self.trajectories[traj_key]["h"]
            glist = [
                Group(e, v, s, tuple((c.key, c.method, c.norm) for c in cs))
                for (e, v, s), cs in groups.items()
            ]
            for i in range(0, len(glist), groups_per_chunk):
                out.append(Chunk(traj_key, h, tuple(glist[i : i + groups_per_chunk])))
        return out


def plan_study(config: SweepConfig) -> Study:
    """Build the model and input, check them against the grid, and key the
    trajectories; the cells are listed lazily (:meth:`Study.iter_groups`).

    Raises
    ------
    ValueError
        if the vehicle or the input cannot be built (the message names them).
    """
    from ..._version import __version__

    try:
        model = build_model(config.vehicle, config.buoyancy_pct)
    except (ValueError, FileNotFoundError) as exc:
        raise ValueError(f"`vehicle` {config.vehicle!r}: {exc}") from exc
    try:
        signal = make_input(config.input, model)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"`input` {dict(config.input)!r}: {exc}") from exc
    if config.x0 is not None and len(config.x0) != model.nx:
        raise ValueError(
            f"`x0` needs {model.nx} numbers for {config.vehicle!r}, got {len(config.x0)}."
        )
    for h in config.h:
        try:
            signal.check_sampling(h)
        except ValueError as exc:
            raise ValueError(f"`input` with `h` = {h:g} s: {exc}") from exc
    mfp = model_fingerprint(model)
    ifp = input_fingerprint(signal, config.T)
    common = {
        "schema": SCHEMA,
        "version": __version__,
        "vehicle": vehicle_label(config.vehicle),
        "buoyancy_pct": config.buoyancy_pct,
        "model_fingerprint": mfp,
        "input": dict(config.input),
        "input_fingerprint": ifp,
        "T": config.T,
        "x0": None if config.x0 is None else list(config.x0),
    }
    trajectories = {digest(t): t for t in ({**common, "h": h} for h in config.h)}
    setup = Setup(
        model, signal, config.T, config.after, config.base_seed, config.distribution, config.x0
    )
    return Study(config, setup, trajectories, mfp, ifp, __version__)
