"""From a sweep grid to cells (one stored row each) and tasks (what a worker runs).

A cell is one (input, h, noise pair, seed, method, norm). Its key is the SHA-256 of
its configuration as canonical JSON, which holds the library version and
fingerprints of the model and the input, so a changed vehicle file, input mapping,
norm or library version gives new keys instead of mixing with old rows.

Cells that share exact samples (same model, input, T, h) form one trajectory; the
trajectories of one input whose periods are multiples of the smallest one share one
simulation, at that smallest period, and take every k-th sample of it (exact samples
are values of one continuous path; every input the plan accepts has its jumps on
the grid of every h, :meth:`Signal.check_sampling`). Cells that share measured data
(same noise pair and seed) form one group, whose f values are computed once for
every Adams-Bashforth order. A task is a chunk of groups of one trajectory.

Planning is lazy: :func:`plan_study` builds the model and the inputs and checks
them, but lists no cell. :attr:`Study.n_cells` counts the grid by arithmetic, and
:meth:`Study.iter_groups` yields its groups one at a time, so a grid of any size is
counted at once and streamed in the memory of one group.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ... import _checks as checks
from ...exceptions import ArgumentError
from ...models import ClosedLoop, Model
from ...signals._names import input_for
from ._cells import (
    Cell,
    Chunk,
    Group,
    PlannedGroup,
    Setup,
    SimPlan,
    cell_order,
    get_cell_kind,
)
from ._config import SweepConfig
from ._inputs import build_model
from ._norms import parse_norm

__all__ = [
    "Cell",
    "Chunk",
    "Group",
    "PlannedGroup",
    "Setup",
    "SimPlan",
    "Study",
    "cell_order",
    "plan_study",
]  # the value types live in ._cells (re-exported here)

SCHEMA = 2  # bump when the meaning of a stored number changes (2: subsampled h)


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


def model_fingerprint(model: Model) -> str:
    """Hash of ``model.f`` at 16 fixed pseudo-random points, with its names and units."""
    rng = np.random.default_rng(20240607)
    x0 = np.asarray(getattr(model, "default_x0", np.zeros(model.nx)), dtype=float)
    x = x0 + rng.uniform(-0.3, 0.3, (16, model.nx))
    plant = getattr(model, "plant", model)  # a closed loop's reference is in plant units
    u_scale = 0.5 * float(getattr(plant, "n_max", 2.0))
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


def model_label(config: SweepConfig) -> str:
    """The model of a study as recorded with its cells: the vehicle label, and the
    feedback law that closes the loop around it."""
    label = vehicle_label(config.vehicle)
    if config.feedback is not None:
        label += f" + {config.feedback['law']}"
    return label


def _seeds_of(config: SweepConfig, eta: float, v: float) -> Sequence[int]:
    # The noise-free pair does not depend on the seed: it runs once.
    return config.seeds[:1] if eta == 0 and v == 0 else config.seeds


@dataclass(frozen=True)
class Study:
    """A planned sweep: the model and inputs built once; cells listed on demand."""

    config: SweepConfig
    setup: Setup
    trajectories: dict[str, dict[str, Any]]  # traj_key -> its configuration
    sims: dict[str, SimPlan]  # sim_key -> the simulation and its trajectories
    model_fingerprint: str
    input_fingerprints: tuple[str, ...]
    version: str
    measures: tuple[str, ...] = ()  # the innermost dimension (norms of a prediction)

    @property
    def input_fingerprint(self) -> str:
        """Fingerprint of the first input ("" for a study without an input)."""
        return self.input_fingerprints[0] if self.input_fingerprints else ""

    def sim_of(self, traj_key: str) -> SimPlan:
        """The simulation a trajectory is taken from."""
        return self.sims[self.trajectories[traj_key]["sim_key"]]

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
        return self.n_groups * len(self.config.methods) * len(self.measures)

    def size_text(self) -> str:
        """The factors of :attr:`n_cells`, for messages."""
        cfg = self.config
        inputs = f"{len(cfg.inputs)} inputs x " if len(cfg.inputs) > 1 else ""
        return (
            f"{inputs}{len(cfg.h)} h x {len(cfg.noise)} noise pairs x {len(cfg.seeds)} seeds "
            f"(1 for the noise-free pair) x {len(cfg.methods)} methods x {len(self.measures)} "
            f"{self.setup.kind.measure_label}"
        )

    def iter_groups(self) -> Iterator[PlannedGroup]:
        """Every group with its cells and their keys, trajectory by trajectory (those
        of one simulation in a row); one group in memory at a time."""
        cfg = self.config
        for sim in self.sims.values():
            for traj_key, h, _k in sim.members:
                tconf = {k: v for k, v in self.trajectories[traj_key].items() if k != "sim_key"}
                for eta, v in cfg.noise:
                    for seed in _seeds_of(cfg, eta, v):
                        cells = []
                        for method in cfg.methods:
                            for norm in self.measures:
                                cconf = {
                                    **tconf,
                                    "after": cfg.after,
                                    "eta_pct": eta,
                                    "v_pct": v,
                                    "seed": seed,
                                    "base_seed": cfg.base_seed,
                                    "distribution": cfg.distribution,
                                    "method": method,
                                    "norm": norm,  # the measure (its key, kept)
                                }
                                text = _canonical(cconf)
                                key = hashlib.sha256(text.encode()).hexdigest()
                                cells.append(
                                    Cell(key, traj_key, h, eta, v, seed, method, norm, text)
                                )
                        yield PlannedGroup(traj_key, sim.key, h, eta, v, seed, tuple(cells))

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
        checks.count(groups_per_chunk, "groups_per_chunk")
        by_traj: dict[str, dict[tuple[float, float, int], list[Cell]]] = {}
        for c in cells:
            by_traj.setdefault(c.traj_key, {}).setdefault((c.eta_pct, c.v_pct, c.seed), []).append(
                c
            )
        out: list[Chunk] = []
        for traj_key, groups in by_traj.items():
            h = self.trajectories[traj_key]["h"]
            sim_key = self.trajectories[traj_key]["sim_key"]
            glist = [
                Group(e, v, s, tuple((c.key, c.method, c.measure) for c in cs))
                for (e, v, s), cs in groups.items()
            ]
            for i in range(0, len(glist), groups_per_chunk):
                out.append(Chunk(traj_key, h, tuple(glist[i : i + groups_per_chunk]), sim_key))
        return out


def _simulation_periods(hs: Sequence[float], base: float | None) -> list[tuple[float, list]]:
    """Group the periods: each group is simulated at its smallest period ``p`` and
    every other period of it is an integer multiple k p. Returns [(p, [(h, k), ...])]."""
    groups: list[tuple[float, list[tuple[float, int]]]] = []
    if base is not None:
        groups.append((base, []))
    for h in sorted(hs):
        for p, members in groups:
            k = checks.integer_ratio(h, p)
            if k is not None:
                members.append((h, k))
                break
        else:
            if base is not None:
                raise ArgumentError(
                    "h",
                    f"`h` = {h:g} s is not an integer multiple of the period {base:g} s of the "
                    "given exact samples (`reference`).",
                )
            groups.append((h, [(h, 1)]))
    return [(p, members) for p, members in groups if members]


def _trajectory_fingerprint(traj: Any) -> str:
    return _hash_numbers(np.asarray(traj.x[:: max(1, traj.n_samples // 512)], dtype=float))


def _model(config: SweepConfig) -> Any:
    """The model of the grid: the object given, or built from its names."""
    if config.model is not None:
        if config.feedback is not None:
            raise ValueError("give a `model` object or a `feedback` law, not both.")
        return config.model
    try:
        return build_model(config.vehicle, config.buoyancy_pct, config.feedback)
    except (ValueError, FileNotFoundError) as exc:
        raise ValueError(f"`vehicle` {config.vehicle!r}: {exc}") from exc


def _signals(config: SweepConfig, model: Model) -> tuple[Any, ...]:
    """The inputs of the grid (the objects given, or built for the plant), checked
    against the model and every h."""
    plant = model.plant if isinstance(model, ClosedLoop) else model
    if config.signals is not None:
        if len(config.signals) != len(config.inputs):
            raise ValueError(f"{len(config.signals)} `signals` for {len(config.inputs)} `inputs`.")
        signals = tuple(config.signals)
    else:
        built = []
        for spec in config.inputs:
            try:
                built.append(input_for(spec, plant))
            except (ValueError, TypeError) as exc:
                raise ValueError(f"`input` {dict(spec)!r}: {exc}") from exc
        signals = tuple(built)
    for signal, spec in zip(signals, config.inputs, strict=True):
        if int(signal.nu) != int(model.nu):
            raise ValueError(
                f"the input has {signal.nu} channels, the model {model.nu} "
                f"({', '.join(model.input_names)})."
            )
        for h in config.h:
            try:
                signal.check_sampling(h)
            except ValueError as exc:
                raise ValueError(f"`input` {dict(spec)!r} with `h` = {h:g} s: {exc}") from exc
    return signals


def _reference(config: SweepConfig, signals: tuple[Any, ...]) -> Any:
    reference = config.reference
    if reference is None:
        return None
    if len(signals) != 1:
        raise ValueError("exact samples (`reference`) go with one input only.")
    return reference.clean if reference.clean is not None else reference


def _check_memory(config: SweepConfig, model: Any, p: float) -> None:
    """Refuse, before anything runs, a trajectory at period ``p`` whose exact samples
    and the arrays of one group of cells (measured copy, f values, predictions,
    errors) would not fit the memory limit (:func:`sampledyn._checks.check_memory`)."""
    n = checks.samples_of(config.T, p)
    nx, nu = int(model.nx), int(model.nu)
    estimate = checks.trajectory_bytes(n, nx, nu) + 8.0 * n * nx * 6
    checks.check_memory(
        estimate,
        f"`h` = {p:g} s with `T` = {config.T:g} s ({n:.4g} samples per trajectory)",
        "the exact samples and one group of cells",
    )


def plan_study(config: SweepConfig, on_model: Callable[[Any], object] | None = None) -> Study:
    """Build the model and inputs, check them against the grid, and key the
    trajectories; the cells are listed lazily (:meth:`Study.iter_groups`).
    ``on_model`` is called with the model as soon as it is built (the run on local
    processes starts compiling the integrator there: :func:`run_sweep`).

    Raises
    ------
    ValueError
        if the vehicle or an input cannot be built (the message names them).
    WorkLimitError
        (a ValueError) if one simulation's arrays would exceed the memory limit.
    """
    from ..._version import __version__

    kind = get_cell_kind(config.kind)
    model = _model(config)
    if on_model is not None:
        on_model(model)
    if config.x0 is not None and len(config.x0) != model.nx:
        raise ValueError(
            f"`x0` needs {model.nx} numbers for {config.vehicle!r}, got {len(config.x0)}."
        )
    for h in config.h:  # before anything allocates by T / h (the inputs' levels too)
        _check_memory(config, model, h)
    signals = _signals(config, model)
    reference = _reference(config, signals)
    mfp = model_fingerprint(model)
    ifps = tuple(input_fingerprint(signal, config.T) for signal in signals)
    common = {
        "schema": SCHEMA,
        "version": __version__,
        "vehicle": model_label(config),
        "buoyancy_pct": config.buoyancy_pct,
        "model_fingerprint": mfp,
        "T": config.T,
        "x0": None if config.x0 is None else list(config.x0),
        "rtol": config.rtol,
    }
    if reference is not None:
        common["reference"] = _trajectory_fingerprint(reference)
    if kind.name != "prediction":  # (prediction keys stay as they were before kinds)
        common["kind"] = kind.name
        common["options"] = dict(config.options)
    trajectories: dict[str, dict[str, Any]] = {}
    sims: dict[str, SimPlan] = {}
    base = None if reference is None else float(reference.h)
    periods = (
        _simulation_periods(config.h, base) if kind.subsample else [(h, [(h, 1)]) for h in config.h]
    )
    # A study without an input (a controller makes it) has one trajectory per h.
    driven = [
        {"input": dict(spec), "input_fingerprint": ifp}
        for spec, ifp in zip(config.inputs, ifps, strict=True)
    ]
    for i, by_input in enumerate(driven or [{}]):
        for p, members in periods:
            sim_key = digest({**common, **by_input, "p": p})
            keyed = []
            for h, k in members:
                t = {**common, **by_input, "h": h, "simulated_h": p}
                traj_key = digest(t)
                trajectories[traj_key] = {**t, "sim_key": sim_key}
                keyed.append((traj_key, h, k))
            sims[sim_key] = SimPlan(sim_key, i, p, tuple(keyed))
    setup = Setup(
        model,
        signals,
        config.T,
        config.after,
        config.base_seed,
        config.distribution,
        config.x0,
        config.rtol,
        config.summaries,
        tuple(parse_norm(n) for n in config.norms),
        reference,
        kind,
        kind.setup_data(config, model),
    )
    measures = tuple(kind.measures(config))
    return Study(config, setup, trajectories, sims, mfp, ifps, __version__, measures)
