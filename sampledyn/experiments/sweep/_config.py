"""The grid of a sweep, read from a TOML file and checked before anything runs.

A sweep file names one vehicle, its inputs, one duration and error window, and lists
the values to cross::

    vehicle = "rexrov"           # built-in name, vehicle file (relative to this file)
                                 # or "auv_like" (eqs. (9)-(10))
    buoyancy_pct = 1.0           # optional, vehicles only: B = (1 + pct/100) W
    feedback = { law = "roll_pitch_hold", kp = 40.0, kd = 6.0 }   # optional closed loop
    feedback_tuning = { roll_pitch_hold = { kp = 40.0, kd = 6.0 } }  # optional: a law's
                                 # parameters when `feedback` names it without them
    input = "fig6"               # or a table: { name = "multilevel", hold = 0.1 },
                                 # or a list of them (crossed with h)
    T = 5000.0                   # s
    after = 1000.0               # errors on t >= after (s)
    h = [0.1, 0.5]               # s
    methods = ["AB1", "AB4"]     # and/or orders = [1, 2, 3, 4]  (AB<s>)
    eta_pct = [0, 2, 10]         # crossed with v_pct ...
    v_pct = [0, 2]
    # noise = [[0, 0], [2, 0]]   # ... or explicit (eta %, v %) pairs instead
    seeds = 10                   # 0..9, or a list of seeds
    norm = "l2_over_n"           # or a list; see sampledyn.experiments.sweep._norms.parse_norm
    base_seed = 0                # optional
    distribution = "uniform"     # optional, or "gaussian"
    x0 = [1.0, 0.0]              # optional initial state (default: the model's)
    rtol = 1e-12                 # optional tolerance of the exact samples (atol the same)
    summaries = ["motion"]       # optional numbers stored per trajectory
    max_cells = 1000000          # optional: refuse a bigger grid (default 1,000,000)

    [per_vehicle.bluerov2_heavy] # optional: settings that apply when `vehicle` is this
    feedback = { law = "roll_pitch_hold" }
    feedback_tuning = { roll_pitch_hold = { kp = 40.0, kd = 6.0 } }

A norm is a string (:mod:`._norms`): ``rms``, ``max[rad]`` (Euler angles only),
``rms@away_from_jumps`` (only samples whose history holds no input jump), ...; every
cell stores it over the position/angle components, the rate components and all.

A ``per_vehicle`` entry gives the keys that hold for one vehicle (the Fig. 7 study
closes a roll-pitch loop on the BlueROV2 Heavy only); a key given at the top level
wins over it. A feedback law's gains depend on the vehicle, so ``feedback_tuning``
(usually per vehicle) gives each law's parameters for it: a ``feedback`` that names
the law takes them, its own parameters win, the law's defaults fill the rest (the
Fig. 7 study tunes the roll-pitch hold for each vehicle this way, and
``reproduce fig7 --attitude-hold`` switches it on with those gains).

Nothing is enumerated here: a count of seeds stays a ``range`` and crossed
``eta_pct``/``v_pct`` lists stay a :class:`NoiseGrid`, so a grid of any size is read
in constant memory and its cells are counted by arithmetic
(:attr:`sampledyn.experiments.sweep._plan.Study.n_cells`).
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from ... import _checks as checks
from ..._files import parse_toml, read_text
from ..._noise import MAX_NOISE_PCT
from ...exceptions import FileContentError, SweepConfigError
from ...methods import families
from ...models import FEEDBACK_LAWS, MODELS, Model
from ...models._names import is_model_file, model_names
from ...signals import INPUTS
from ._cells import CellKind, get_cell_kind
from ._norms import parse_norm
from ._summaries import SUMMARIES

__all__ = [
    "DEFAULT_MAX_CELLS",
    "NoiseGrid",
    "SweepConfig",
    "check_time_grid",
    "load_config",
]

#: Largest grid a sweep runs unless told otherwise (``max_cells``, ``--max-cells``).
DEFAULT_MAX_CELLS = 1_000_000

_DISTRIBUTIONS = ("uniform", "gaussian")
_DEFAULT_VEHICLE = "bluerov2_heavy"
_KEYS = (
    "vehicle",
    "buoyancy_pct",
    "input",
    "T",
    "after",
    "h",
    "methods",
    "orders",
    "eta_pct",
    "v_pct",
    "noise",
    "seeds",
    "norm",
    "base_seed",
    "distribution",
    "x0",
    "max_cells",
    "feedback",
    "feedback_tuning",
    "rtol",
    "summaries",
    "per_vehicle",
)
_PER_VEHICLE_KEYS = tuple(k for k in _KEYS if k not in ("vehicle", "per_vehicle"))
_ALWAYS = ("vehicle", "T", "after", "h", "max_cells", "per_vehicle")  # every kind's
#: The family whose members ``orders = [s, ...]`` names (AB<s>).
_ORDERS_FAMILY = "AB<s>"


@dataclass(frozen=True)
class NoiseGrid(Sequence[tuple[float, float]]):
    """The noise pairs ``eta_pct`` x ``v_pct`` (eta-major), without listing them.

    A sequence of (eta %, v %) pairs of length ``len(eta) * len(v)``.
    """

    eta: tuple[float, ...]
    v: tuple[float, ...]

    def __len__(self) -> int:
        return len(self.eta) * len(self.v)

    def __getitem__(self, index: Any) -> Any:
        if isinstance(index, slice):
            return tuple(self[i] for i in range(*index.indices(len(self))))
        i = index + len(self) if index < 0 else index
        if not 0 <= i < len(self):
            raise IndexError("noise pair index out of range")
        return (self.eta[i // len(self.v)], self.v[i % len(self.v)])

    def __iter__(self) -> Iterator[tuple[float, float]]:
        return ((e, w) for e in self.eta for w in self.v)

    def __contains__(self, pair: object) -> bool:
        return (
            isinstance(pair, tuple) and len(pair) == 2 and pair[0] in self.eta and pair[1] in self.v
        )

    def count(self, pair: Any) -> int:
        return int(pair in self)


@dataclass(frozen=True)
class SweepConfig:
    """A checked sweep grid (see the module docstring for the file format).

    The grid checks itself when it is made, whoever makes it: :func:`load_config`
    (a sweep file), a built-in study, or Python code (``SweepConfig(...)``,
    ``dataclasses.replace(config, h=(0.2,))``). Each value is checked once, here,
    and the messages name the sweep-file key.

    Attributes
    ----------
    vehicle : str
        Built-in model name (:func:`sampledyn.models._names.model_names`) or absolute path
        of a vehicle file; with ``model`` given, a label of that model.
    inputs : tuple of Mapping[str, Any]
        ``{"name": <input of sampledyn.signals.INPUTS>, **parameters}`` per input
        (crossed with h); required unless the kind needs none or ``signals`` are given.
    T, after : float
        Duration and start of the error window (s).
    h : tuple of float
        Sampling periods (s), each dividing T into whole steps.
    methods : tuple of str
        Registry names (:func:`sampledyn.get_method`), or what the kind accepts.
    noise : sequence of (eta %, v %)
        Noise pairs (a tuple, or a :class:`NoiseGrid` for crossed lists).
    seeds : sequence of int
        Noise seeds (a tuple, or a ``range`` for a count); the noise-free pair (0, 0)
        runs with the first seed only, since its result does not depend on the seed.
    norms : tuple of str
        Norms (canonical strings, :func:`parse_norm`), one cell each; default
        ("rms",) for a kind that measures norms, () for another.
    base_seed : int
        Seed k of a cell draws from ``SeedSequence([base_seed, k])``.
    distribution : str
        "uniform" (the paper's) or "gaussian".
    buoyancy_pct : float or None
        Net buoyancy of a vehicle in percent of its weight; None keeps the file's.
    x0 : tuple of float or None
        Initial state of the exact samples; None uses the model's default.
    max_cells : int or None
        Largest grid to run (None: :data:`DEFAULT_MAX_CELLS`).
    feedback : Mapping[str, Any] or None
        ``{"law": <law of sampledyn.models.FEEDBACK_LAWS>, **parameters}``: the model
        is the plant closed by this law (a closed-loop study); None: open loop.
    feedback_tuning : Mapping[str, Mapping[str, float]]
        Each law's parameters for this vehicle (used by ``feedback`` and by
        :meth:`with_feedback` for the parameters they do not give).
    rtol : float
        Relative (and absolute) tolerance of the exact samples.
    summaries : tuple of str
        Numbers stored with each trajectory (:data:`SUMMARIES`).
    kind : str
        What a cell computes (:func:`sampledyn.experiments.sweep._cells.available_cell_kinds`):
        "prediction" (the default: one-step predictions measured by ``norms``),
        "closed_loop" or "multistep" (the controller studies).
    options : Mapping[str, Any]
        The kind's own settings (checked and completed by it).
    model : object or None
        A model object instead of ``vehicle`` (from Python, not from a file).
    signals : tuple or None
        Signal objects instead of named ``inputs`` (from Python), one per input.
    reference : Trajectory or None
        Exact samples to use instead of simulating (from Python): every h must be a
        multiple of its period; with one input only.
    source : str
        Where the config came from (file path or "<dict>"), for messages.

    Raises
    ------
    SweepConfigError
        (a ``ValueError``) naming the key of the first bad value, the value and the fix.
    """

    vehicle: str
    inputs: tuple[Mapping[str, Any], ...] = ()
    T: float = 0.0
    after: float = 0.0
    h: tuple[float, ...] = ()
    methods: tuple[str, ...] = ()
    noise: Sequence[tuple[float, float]] = ((0.0, 0.0),)
    seeds: Sequence[int] = range(1)
    norms: tuple[str, ...] = ()
    base_seed: int = 0
    distribution: str = "uniform"
    buoyancy_pct: float | None = None
    x0: tuple[float, ...] | None = None
    max_cells: int | None = None
    feedback: Mapping[str, Any] | None = None
    feedback_tuning: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    rtol: float = 1e-12
    summaries: tuple[str, ...] = ()
    kind: str = "prediction"
    options: Mapping[str, Any] = field(default_factory=dict)
    model: Model | None = field(default=None, compare=False)
    signals: tuple[Any, ...] | None = field(default=None, compare=False)
    reference: Any = field(default=None, compare=False)
    source: str = field(default="<dict>", compare=False)

    def __post_init__(self) -> None:
        values = _checked(self)
        for name, value in values.items():
            object.__setattr__(self, name, value)

    @property
    def cell_kind(self) -> CellKind:
        """The registered :class:`CellKind` of :attr:`kind`."""
        return get_cell_kind(self.kind)

    def with_feedback(self, law: str | None, **parameters: float) -> SweepConfig:
        """The same grid closed by feedback law ``law`` (None: open loop), with its
        parameters from :attr:`feedback_tuning` for this vehicle where not given."""
        if law is None:
            return replace(self, feedback=None)
        tuned = dict(self.feedback_tuning.get(law, {}))
        return replace(self, feedback={"law": law, **tuned, **parameters})

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON-able description (recorded with each run)."""
        return {
            "vehicle": self.vehicle,
            "input": [dict(i) for i in self.inputs],
            "T": self.T,
            "after": self.after,
            "h": list(self.h),
            "methods": list(self.methods),
            "noise": (
                {"eta_pct": list(self.noise.eta), "v_pct": list(self.noise.v)}
                if isinstance(self.noise, NoiseGrid)
                else [list(p) for p in self.noise]
            ),
            "seeds": (
                len(self.seeds)
                if isinstance(self.seeds, range) and self.seeds.start == 0
                else list(self.seeds)
            ),
            "norms": list(self.norms),
            "base_seed": self.base_seed,
            "distribution": self.distribution,
            "buoyancy_pct": self.buoyancy_pct,
            "x0": None if self.x0 is None else list(self.x0),
            "max_cells": self.max_cells,
            "feedback": None if self.feedback is None else dict(self.feedback),
            "rtol": self.rtol,
            "summaries": list(self.summaries),
            **({} if self.kind == "prediction" else {"kind": self.kind, **self.options}),
        }

    @classmethod
    def from_mapping(
        cls, data: Mapping[str, Any], *, base_dir: str | os.PathLike[str] | None = None
    ) -> SweepConfig:
        """Check a parsed sweep file; relative vehicle paths resolve against ``base_dir``."""
        return _parse(data, Path(base_dir) if base_dir is not None else None, "<dict>")


def load_config(path: str | os.PathLike[str], *, vehicle: str | None = None) -> SweepConfig:
    """Read and check a sweep TOML file.

    Parameters
    ----------
    path : path
        The sweep file.
    vehicle : str, optional
        Run the file's grid on this model instead of its ``vehicle`` (a built-in
        name, or a vehicle file relative to the working directory); the file's
        ``per_vehicle`` entry for it applies.

    Raises
    ------
    SweepConfigError
        naming the bad key (unknown keys too), or the TOML syntax error.
    FileNotFoundError
        if ``path`` does not exist.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"sweep file {str(path)!r} does not exist.")
    try:  # a regular file, bounded, UTF-8, TOML nested a few levels
        data = parse_toml(read_text(path, "sweep file"), str(path))
    except FileContentError as exc:
        raise SweepConfigError("<file>", str(exc)) from None
    if vehicle is not None:
        data["vehicle"] = str(Path(vehicle).resolve()) if is_model_file(vehicle) else vehicle
    return _parse(data, path.resolve().parent, str(path))


# A grid's bad entry, of a wrong type or out of range, is a SweepConfigError.
_GRID_ERRORS: dict[str, Any] = {"error": SweepConfigError, "types": SweepConfigError}


def _where(src: str) -> str:
    return "" if src in ("", "<dict>") else f" in {src}"


def _nearby_divisor(T: float, h: float) -> float | None:
    """A round period near ``h`` (1, 2, 2.5, 4, 5 x 10^k) dividing ``T``, or None."""
    exp = math.floor(math.log10(h))
    candidates = [m * 10.0 ** (exp + e) for e in (-1, 0, 1) for m in (1, 2, 2.5, 4, 5)]
    fits = [c for c in candidates if checks.integer_ratio(T, c) is not None]
    return min(fits, key=lambda c: abs(math.log(c / h)), default=None)


def _number(key: str, value: Any, src: str, *, positive: bool = False) -> float:
    check = checks.positive if positive else checks.number
    return check(value, key, where=_where(src), **_GRID_ERRORS)


def _number_list(key: str, value: Any, src: str, *, positive: bool = False) -> tuple[float, ...]:
    values = list(value) if isinstance(value, list | tuple) else [value]
    if not values:
        raise SweepConfigError(key, f"`{key}`{_where(src)} must not be empty.")
    out = tuple(_number(key, v, src, positive=positive) for v in values)
    if len(set(out)) != len(out):
        raise SweepConfigError(key, f"`{key}`{_where(src)} lists a value twice: {values!r}.")
    return out


def check_time_grid(
    T: Any, after: Any, h: Any, src: str = "<dict>"
) -> tuple[float, float, tuple[float, ...]]:
    """``(T, after, hs)`` of a study, checked: ``T`` finite and > 0 (s), ``after`` in
    [0, T) (s), every period of ``h`` (a number or a sequence, s) > 0 and dividing
    ``T`` into whole steps. The one rule for every grid (:class:`SweepConfig` runs
    it when made).

    Raises
    ------
    SweepConfigError
        naming the key (``T``, ``after`` or ``h``), its value and the fix.
    """
    T, after = checks.time_window(T, after, where=_where(src), **_GRID_ERRORS)
    hs = _number_list("h", h, src, positive=True)
    for period in hs:
        if period < checks.MIN_STEP:
            raise SweepConfigError(
                "h",
                f"`h` = {period:g} s{_where(src)} is below the smallest sampling period "
                f"{checks.MIN_STEP:g} s (sample times t = n h lose their meaning below it).",
            )
        if checks.integer_ratio(T, period) is None:
            near = _nearby_divisor(T, period)
            hint = "" if near is None else f" (e.g. {near:g} s)"
            raise SweepConfigError(
                "h",
                f"`h` = {period:g} s{_where(src)} does not divide T = {T:g} s into whole "
                f"steps; choose h = T/n for an integer n{hint} or another T.",
            )
    return T, after, hs


# -- the checks of a typed grid (SweepConfig.__post_init__) ---------------------------


def _checked(c: SweepConfig) -> dict[str, Any]:
    """Every field of ``c``, checked and in canonical form (what __post_init__ sets)."""
    src = c.source
    kind = _kind(c.kind, src)
    T, after, hs = check_time_grid(c.T, c.after, c.h, src)
    return {
        "vehicle": _vehicle_name(c.vehicle, c.model, src),
        "T": T,
        "after": after,
        "h": hs,
        "inputs": _input_specs(c.inputs, c.signals, kind, src),
        "methods": _method_names(c.methods, kind, src),
        "noise": _noise_pairs(c.noise, src),
        "seeds": _seed_list(c.seeds, src),
        "norms": _norm_texts(c.norms, kind, src),
        "base_seed": _count("base_seed", c.base_seed, src, least=0),
        "distribution": _distribution(c.distribution, src),
        "buoyancy_pct": _optional(_number, "buoyancy_pct", c.buoyancy_pct, src),
        "x0": _optional(_numbers, "x0", c.x0, src),
        "max_cells": _optional(_count, "max_cells", c.max_cells, src, least=1),
        "feedback_tuning": _tuning(c.feedback_tuning, src),
        "feedback": _feedback_spec(c.feedback, src),
        "rtol": _number("rtol", c.rtol, src, positive=True),
        "summaries": _summary_names(c.summaries, src),
        "options": _kind_options(kind, c.options, src),
    }  # fmt: skip


def _optional(check: Any, key: str, value: Any, src: str, **kw: Any) -> Any:
    return None if value is None else check(key, value, src, **kw)


def _numbers(key: str, value: Any, src: str) -> tuple[float, ...]:
    return tuple(_number(key, v, src) for v in _listed(key, value, src))


def _kind(name: Any, src: str) -> CellKind:
    try:
        return get_cell_kind(name)
    except ValueError as exc:
        raise SweepConfigError("kind", f"`kind`{_where(src)}: {exc}") from exc


def _vehicle_name(vehicle: Any, model: Model | None, src: str) -> str:
    if not isinstance(vehicle, str) or not vehicle.strip():
        raise SweepConfigError(
            "vehicle", f"`vehicle`{_where(src)} must be a string, got {vehicle!r}."
        )
    vehicle = vehicle.strip()
    if model is not None:
        return vehicle  # a label of the model object
    if is_model_file(vehicle):
        if not Path(vehicle).is_file():
            raise SweepConfigError("vehicle", f"`vehicle`{_where(src)}: no file {vehicle!r}.")
        return str(Path(vehicle).resolve())
    if MODELS.canonical(vehicle) is None and vehicle not in model_names():
        raise SweepConfigError(
            "vehicle",
            f"`vehicle`{_where(src)}: unknown model {vehicle!r}; built-in: "
            f"{', '.join(model_names())}, or the path of a .toml vehicle file.",
        )
    return vehicle


def _listed(key: str, value: Any, src: str) -> tuple[Any, ...]:
    if isinstance(value, str) or not isinstance(value, Sequence):
        raise SweepConfigError(key, f"`{key}`{_where(src)} must be a list, got {value!r}.")
    return tuple(value)


def _input_specs(
    inputs: Any, signals: Any, kind: CellKind, src: str
) -> tuple[Mapping[str, Any], ...]:
    specs = tuple(dict(i) for i in inputs)
    if not kind.needs_input:
        if specs:
            raise SweepConfigError(
                "input",
                f"`input`{_where(src)} does not apply to a {kind.name} study "
                f"({kind.description}); remove it.",
            )
        return ()
    if signals is not None:
        return specs  # labels of the signal objects
    if not specs:
        raise SweepConfigError("input", f'`input`{_where(src)} is required, e.g. input = "fig6".')
    out = []
    for spec in specs:
        try:
            out.append(INPUTS.check(spec))
        except ValueError as exc:
            raise SweepConfigError("input", f"`input`{_where(src)}: {exc}") from exc
    if len({repr(sorted(i.items())) for i in out}) != len(out):
        raise SweepConfigError("input", f"`input`{_where(src)} lists an input twice.")
    return tuple(out)


def _method_names(methods: Any, kind: CellKind, src: str) -> tuple[str, ...]:
    if isinstance(methods, str) or not all(isinstance(m, str) for m in methods):
        raise SweepConfigError("methods", f"`methods`{_where(src)} must be a list of names.")
    names = [m.strip() for m in methods]
    if not names:
        raise SweepConfigError(
            "methods", f'give `methods` or `orders`{_where(src)}, e.g. methods = ["AB1", "AB4"].'
        )
    for name in names:
        try:
            kind.check_method(name)
        except (ValueError, TypeError) as exc:
            raise SweepConfigError("methods", f"`methods`{_where(src)}: {exc}") from exc
    return tuple(dict.fromkeys(names))


def _percent(key: str, value: Any, src: str) -> float:
    out = _number(key, value, src)
    if out < 0:
        raise SweepConfigError(key, f"`{key}`{_where(src)} must be percentages >= 0, got {value}.")
    if out > MAX_NOISE_PCT:
        raise SweepConfigError(
            key,
            f"`{key}`{_where(src)}: {out:g} % is above {MAX_NOISE_PCT:g} % (noise ten times the "
            "motion: the errors would measure the noise alone).",
        )
    return out


def _noise_pairs(noise: Any, src: str) -> Sequence[tuple[float, float]]:
    if isinstance(noise, NoiseGrid):
        for key, values in (("eta_pct", noise.eta), ("v_pct", noise.v)):
            _number_list(key, list(values), src)
            for v in values:
                _percent(key, v, src)
        return NoiseGrid(tuple(map(float, noise.eta)), tuple(map(float, noise.v)))
    ok = isinstance(noise, Sequence) and len(noise) > 0
    ok = ok and all(isinstance(p, Sequence) and len(p) == 2 for p in noise)
    if not ok:
        raise SweepConfigError(
            "noise", f"`noise`{_where(src)} must be a list of [eta %, v %] pairs, got {noise!r}."
        )
    pairs = tuple((_percent("noise", e, src), _percent("noise", v, src)) for e, v in noise)
    if len(set(pairs)) != len(pairs):
        raise SweepConfigError("noise", f"`noise`{_where(src)} lists a pair twice.")
    return pairs


def _seed_list(seeds: Any, src: str) -> Sequence[int]:
    if isinstance(seeds, range) and seeds.step == 1 and 0 <= seeds.start < seeds.stop:
        top = seeds.stop - 1  # (a count of seeds is bounded by max_cells)
    else:
        ok = isinstance(seeds, Sequence) and len(seeds) > 0
        ok = ok and all(isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in seeds)
        if not ok or len(set(seeds)) != len(seeds):
            raise SweepConfigError(
                "seeds",
                f"`seeds`{_where(src)} must be a count or a list of distinct ints >= 0, got "
                f"{list(seeds) if isinstance(seeds, range) else seeds!r}.",
            )
        top = max(seeds)
    if top > checks.MAX_SEED:
        raise SweepConfigError(
            "seeds",
            f"`seeds`{_where(src)}: seed {top:.4g} is beyond {checks.MAX_SEED} (2^63 - 1, what the "
            "store keeps); give smaller seeds.",
        )
    return seeds if isinstance(seeds, range) else tuple(seeds)


def _norm_texts(norms: Any, kind: CellKind, src: str) -> tuple[str, ...]:
    values = [norms] if isinstance(norms, str) else list(norms)
    if kind.uses is not None and "norm" not in kind.uses:
        if values:
            raise SweepConfigError(
                "norm",
                f"`norm`{_where(src)} does not apply to a {kind.name} study "
                f"({kind.description}); remove it.",
            )
        return ()
    out = []
    for n in values or ["rms"]:
        try:
            out.append(parse_norm(n).text)
        except ValueError as exc:
            raise SweepConfigError("norm", f"`norm`{_where(src)}: {exc}") from exc
    return tuple(dict.fromkeys(out))


def _count(key: str, value: Any, src: str, *, least: int, most: int = checks.MAX_SEED) -> int:
    out = checks.count(value, key, least=least, where=_where(src), **_GRID_ERRORS)
    if out > most:
        raise SweepConfigError(
            key, f"`{key}`{_where(src)} must be an int <= {most}, got {out:.4g}."
        )
    return out


def _distribution(value: Any, src: str) -> str:
    if value not in _DISTRIBUTIONS:
        raise SweepConfigError(
            "distribution",
            f"`distribution`{_where(src)} must be one of {', '.join(_DISTRIBUTIONS)}, "
            f"got {value!r}.",
        )
    return str(value)


def _tuning(raw: Any, src: str) -> dict[str, dict[str, float]]:
    """``feedback_tuning``: law -> its parameters (names checked, finite numbers)."""
    if not isinstance(raw, Mapping) or not all(isinstance(v, Mapping) for v in raw.values()):
        raise SweepConfigError(
            "feedback_tuning",
            f"`feedback_tuning`{_where(src)} must be a table of tables, one per feedback law, "
            f"e.g. {{ roll_pitch_hold = {{ kp = 40.0, kd = 6.0 }} }}, got {raw!r}.",
        )
    for law, params in raw.items():
        try:
            FEEDBACK_LAWS.check({"law": law, **params})
        except ValueError as exc:
            raise SweepConfigError(
                "feedback_tuning", f"`feedback_tuning.{law}`{_where(src)}: {exc}"
            ) from exc
        for name, value in params.items():
            _number(f"feedback_tuning.{law}.{name}", value, src)
    return {law: dict(params) for law, params in raw.items()}


def _feedback_spec(raw: Any, src: str) -> dict[str, Any] | None:
    if raw is None:
        return None
    if not isinstance(raw, Mapping):
        raise SweepConfigError(
            "feedback",
            f"`feedback`{_where(src)} must be a table such as "
            f'{{ law = "roll_pitch_hold", kp = 40.0 }} or "none", got {raw!r}.',
        )
    try:
        return FEEDBACK_LAWS.check(raw)
    except ValueError as exc:
        raise SweepConfigError("feedback", f"`feedback`{_where(src)}: {exc}") from exc


def _summary_names(raw: Any, src: str) -> tuple[str, ...]:
    names = [raw] if isinstance(raw, str) else raw
    if not isinstance(names, Sequence) or any(n not in SUMMARIES for n in names):
        raise SweepConfigError(
            "summaries",
            f"`summaries`{_where(src)} must be a list of {', '.join(SUMMARIES)}, got {raw!r}.",
        )
    return tuple(dict.fromkeys(names))


def _kind_options(kind: CellKind, options: Mapping[str, Any], src: str) -> dict[str, Any]:
    bad = sorted(set(options) - set(kind.option_keys))
    if bad:
        raise SweepConfigError(
            bad[0], f"`{bad[0]}`{_where(src)} is no setting of a {kind.name} study."
        )
    try:
        return kind.check_options(options)
    except (ValueError, TypeError) as exc:
        key = exc.key if isinstance(exc, SweepConfigError) else "kind"
        raise SweepConfigError(key, f"{str(exc).rstrip('.')}{_where(src)}.") from exc


# -- a sweep file: one producer of a SweepConfig ---------------------------------------


def _apply_per_vehicle(
    data: Mapping[str, Any], src: str, own: tuple[str, ...] = ()
) -> Mapping[str, Any]:
    """``data`` with the ``per_vehicle`` entry of its vehicle merged in (top-level
    keys win); ``own`` are the cell kind's keys (also allowed per vehicle)."""
    table = data.get("per_vehicle")
    if table is None:
        return data
    if not isinstance(table, dict) or not all(isinstance(v, dict) for v in table.values()):
        raise SweepConfigError(
            "per_vehicle",
            f"`per_vehicle`{_where(src)} must be a table of tables, one per vehicle name.",
        )
    valid = (*_PER_VEHICLE_KEYS, *own)
    for name, entry in table.items():
        bad = sorted(set(entry) - set(valid))
        if bad:
            raise SweepConfigError(
                "per_vehicle",
                f"`per_vehicle.{name}`{_where(src)}: unknown key `{bad[0]}`; valid keys: "
                f"{', '.join(valid)}.",
            )
    vehicle = str(data.get("vehicle", _DEFAULT_VEHICLE))
    _warn_unknown_vehicle_names(table, vehicle, src)
    entry = table.get(vehicle) or table.get(Path(vehicle).stem) or {}
    return {**entry, **{k: v for k, v in data.items() if k != "per_vehicle"}}


def _warn_unknown_vehicle_names(table: Mapping[str, Any], vehicle: str, src: str) -> None:
    """Warn about a ``per_vehicle`` entry that names no built-in model and not this
    file's vehicle: most likely a misspelling, which would be ignored without a word
    (an entry for a vehicle file used with this study elsewhere is legitimate, so it is
    a warning, not an error)."""
    import difflib
    import warnings

    known = {*model_names(), vehicle, Path(vehicle).stem}
    for name in table:
        if name not in known:
            close = difflib.get_close_matches(name, sorted(known), n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            warnings.warn(
                f"`per_vehicle.{name}`{_where(src)} names no built-in vehicle and not this "
                f"sweep's vehicle {vehicle!r}: it applies only when `vehicle` is {name!r} "
                f"or a file {name}.toml{hint}",
                UserWarning,
                stacklevel=5,
            )


def _file_vehicle(data: Mapping[str, Any], base: Path | None, src: str) -> Any:
    """The file's ``vehicle``, a relative vehicle path resolved against ``base``."""
    vehicle = data.get("vehicle", _DEFAULT_VEHICLE)
    if isinstance(vehicle, str) and is_model_file(vehicle) and base is not None:
        p = Path(vehicle)
        return str(p if p.is_absolute() else base / p)
    return vehicle


def _file_inputs(data: Mapping[str, Any], src: str) -> tuple[dict[str, Any], ...]:
    raw = data.get("input")
    if raw is None:
        return ()
    out = []
    for item in raw if isinstance(raw, list) and raw else [raw]:
        if isinstance(item, str):
            out.append({"name": item})
        elif isinstance(item, dict):
            out.append(dict(item))
        else:
            raise SweepConfigError(
                "input", f"`input`{_where(src)} must be a name, a table or a list, got {raw!r}."
            )
    return tuple(out)


def _file_methods(data: Mapping[str, Any], src: str) -> tuple[Any, ...]:
    """``methods``, after the members of the AB family of the ``orders`` listed."""
    raw = data.get("methods", [])
    raw = [raw] if isinstance(raw, str) else raw
    if not isinstance(raw, list):
        raise SweepConfigError("methods", f"`methods`{_where(src)} must be a list of names.")
    orders = data.get("orders", [])
    if not isinstance(orders, list) or not all(
        isinstance(s, int) and not isinstance(s, bool) and s >= 1 for s in orders
    ):
        raise SweepConfigError(
            "orders", f"`orders`{_where(src)} must be a list of integers >= 1, got {orders!r}."
        )
    family = next(f for f in families() if f.key == _ORDERS_FAMILY) if orders else None
    return (*(family.name(s) for s in orders if family is not None), *raw)


def _file_noise(data: Mapping[str, Any], src: str) -> Sequence[Any]:
    if "noise" in data:
        if "eta_pct" in data or "v_pct" in data:
            raise SweepConfigError(
                "noise", f"give either `noise` pairs or `eta_pct`/`v_pct`{_where(src)}, not both."
            )
        return data["noise"]
    # Distinct lists (checked) give distinct pairs; the product is never listed.
    eta, v = (data.get(k, [0.0]) for k in ("eta_pct", "v_pct"))
    return NoiseGrid(tuple(eta if isinstance(eta, list) else [eta]),
                     tuple(v if isinstance(v, list) else [v]))  # fmt: skip


def _file_seeds(raw: Any) -> Any:
    return range(raw) if isinstance(raw, int) and not isinstance(raw, bool) and raw >= 1 else raw


def _file_feedback(data: Mapping[str, Any]) -> Any:
    """``feedback`` with the law's ``feedback_tuning`` under its own parameters."""
    raw = data.get("feedback")
    if raw is None or raw == "none":
        return None
    if not isinstance(raw, dict):
        return raw  # refused by the check
    tuning = data.get("feedback_tuning", {})
    tuned = tuning.get(str(raw.get("law")), {}) if isinstance(tuning, dict) else {}
    return {**tuned, **raw} if isinstance(tuned, dict) else raw


def _kind_keys(data: Mapping[str, Any], src: str, kind: CellKind) -> dict[str, Any]:
    """Refuse the common keys the kind does not read; its own keys."""
    uses = set(_KEYS) if kind.uses is None else {*kind.uses, *_ALWAYS}
    for key in (k for k in _KEYS if k in data and k not in uses):
        raise SweepConfigError(
            key,
            f"`{key}`{_where(src)} does not apply to a {kind.name} study ({kind.description}); "
            "remove it.",
        )
    return {k: data[k] for k in kind.option_keys if k in data}


def _parse(data: Mapping[str, Any], base: Path | None, src: str) -> SweepConfig:
    kind = _kind(data.get("kind", "prediction"), src)
    valid = (*_KEYS, "kind", *kind.option_keys)
    unknown = sorted(set(data) - set(valid))
    if unknown:
        raise SweepConfigError(
            unknown[0], f"unknown key `{unknown[0]}`{_where(src)}; valid keys: {', '.join(valid)}."
        )
    data = _apply_per_vehicle(data, src, kind.option_keys)
    options = _kind_keys(data, src, kind)
    for key in ("T", "after", "h"):
        if key not in data:
            raise SweepConfigError(key, f"`{key}`{_where(src)} is required.")
    x0 = data.get("x0")
    if x0 is not None and not isinstance(x0, list):
        raise SweepConfigError("x0", f"`x0`{_where(src)} must be a list of numbers, got {x0!r}.")
    norms = data.get("norm", "rms" if kind.uses is None or "norm" in kind.uses else ())
    if norms == []:
        raise SweepConfigError("norm", f"`norm`{_where(src)} must not be empty.")
    return SweepConfig(
        vehicle=_file_vehicle(data, base, src),
        inputs=_file_inputs(data, src),
        T=data["T"],
        after=data["after"],
        h=data["h"],
        methods=_file_methods(data, src),
        noise=_file_noise(data, src),
        seeds=_file_seeds(data.get("seeds", 1)),
        norms=norms,
        base_seed=data.get("base_seed", 0),
        distribution=data.get("distribution", "uniform"),
        buoyancy_pct=data.get("buoyancy_pct"),
        x0=None if x0 is None else tuple(x0),
        max_cells=data.get("max_cells"),
        feedback=_file_feedback(data),
        feedback_tuning=data.get("feedback_tuning", {}),
        rtol=data.get("rtol", 1e-12),
        summaries=data.get("summaries", []),
        kind=kind.name,
        options=options,
        source=src,
    )
