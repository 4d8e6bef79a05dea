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
    norm = "l2_over_n"           # or a list; see sampledyn.experiments.sweep.parse_norm
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
(:attr:`sampledyn.experiments.sweep.Study.n_cells`).
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ._cells import CellKind, get_cell_kind
from ._norms import parse_norm
from ._summaries import SUMMARIES

__all__ = [
    "DEFAULT_MAX_CELLS",
    "NoiseGrid",
    "SweepConfig",
    "SweepConfigError",
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


class SweepConfigError(ValueError):
    """A bad sweep file; ``key`` names the offending entry."""

    def __init__(self, key: str, message: str) -> None:
        super().__init__(message)
        self.key = key


@dataclass(frozen=True)
class SweepConfig:
    """A checked sweep grid (see the module docstring for the file format).

    Attributes
    ----------
    vehicle : str
        Built-in vehicle name, absolute path of a vehicle file, or "auv_like"; with
        ``model`` given, a label of that model.
    inputs : tuple of Mapping[str, Any]
        ``{"name": <registered input>, **parameters}`` per input (crossed with h).
    T, after : float
        Duration and start of the error window (s).
    h : tuple of float
        Sampling periods (s).
    methods : tuple of str
        Registry names (:func:`sampledyn.get_method`).
    noise : sequence of (eta %, v %)
        Noise pairs (a tuple, or a :class:`NoiseGrid` for crossed lists).
    seeds : sequence of int
        Noise seeds (a tuple, or a ``range`` for a count); the noise-free pair (0, 0)
        runs with the first seed only, since its result does not depend on the seed.
    norms : tuple of str
        Norms (canonical strings, :func:`parse_norm`), one cell each.
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
        ``{"law": <registered law>, **parameters}``: the model is the plant closed by
        this law (a closed-loop study); None: open loop.
    rtol : float
        Relative (and absolute) tolerance of the exact samples.
    summaries : tuple of str
        Numbers stored with each trajectory (:data:`SUMMARIES`).
    kind : str
        What a cell computes (:func:`sampledyn.experiments.sweep.available_cell_kinds`):
        "prediction" (the default: one-step predictions measured by ``norms``),
        "closed_loop" or "multistep" (the controller studies).
    options : Mapping[str, Any]
        The kind's own settings (checked by it; empty for a prediction study).
    model : object or None
        A model object instead of ``vehicle`` (from Python, not from a file).
    signals : tuple or None
        Signal objects instead of named ``inputs`` (from Python), one per input.
    reference : Trajectory or None
        Exact samples to use instead of simulating (from Python): every h must be a
        multiple of its period; with one input only.
    source : str
        Where the config came from (file path or "<dict>").
    """

    vehicle: str
    inputs: tuple[Mapping[str, Any], ...]
    T: float
    after: float
    h: tuple[float, ...]
    methods: tuple[str, ...]
    noise: Sequence[tuple[float, float]]
    seeds: Sequence[int]
    norms: tuple[str, ...]
    base_seed: int = 0
    distribution: str = "uniform"
    buoyancy_pct: float | None = None
    x0: tuple[float, ...] | None = None
    max_cells: int | None = None
    feedback: Mapping[str, Any] | None = None
    rtol: float = 1e-12
    summaries: tuple[str, ...] = ()
    kind: str = "prediction"
    options: Mapping[str, Any] = field(default_factory=dict)
    model: Any = field(default=None, compare=False)
    signals: tuple[Any, ...] | None = field(default=None, compare=False)
    reference: Any = field(default=None, compare=False)
    source: str = field(default="<dict>", compare=False)

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


def load_config(path: str | os.PathLike[str]) -> SweepConfig:
    """Read and check a sweep TOML file.

    Raises
    ------
    SweepConfigError
        naming the bad key (unknown keys too), or the TOML syntax error.
    FileNotFoundError
        if ``path`` does not exist.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"sweep file {str(path)!r} does not exist.")
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise SweepConfigError("<file>", f"{path}: not valid TOML: {exc}") from exc
    return _parse(data, path.resolve().parent, str(path))


def _where(src: str) -> str:
    return "" if src in ("", "<dict>") else f" in {src}"


def _nearby_divisor(T: float, h: float) -> float | None:
    """A round period near ``h`` (1, 2, 2.5, 4, 5 x 10^k) dividing ``T``, or None."""
    exp = math.floor(math.log10(h))
    candidates = [m * 10.0 ** (exp + e) for e in (-1, 0, 1) for m in (1, 2, 2.5, 4, 5)]
    fits = [c for c in candidates if abs(T / c - round(T / c)) <= 1e-9 * (T / c)]
    return min(fits, key=lambda c: abs(math.log(c / h)), default=None)


def _number(key: str, value: Any, src: str, *, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise SweepConfigError(key, f"`{key}`{_where(src)} must be a finite number, got {value!r}.")
    if positive and value <= 0:
        raise SweepConfigError(key, f"`{key}`{_where(src)} must be > 0, got {value!r}.")
    return float(value)


def _number_list(key: str, value: Any, src: str, *, positive: bool = False) -> tuple[float, ...]:
    values = value if isinstance(value, list) else [value]
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
    [0, T) (s), every period of ``h`` (a number or a list, s) > 0 and dividing ``T``
    into whole steps. The one rule for sweep files and the built-in studies.

    Raises
    ------
    SweepConfigError
        naming the key (``T``, ``after`` or ``h``), its value and the fix.
    """
    T = _number("T", T, src, positive=True)
    after = _number("after", after, src)
    if not 0 <= after < T:
        raise SweepConfigError(
            "after", f"`after`{_where(src)} must be in [0, T={T:g}) s, got {after}."
        )
    hs = _number_list("h", h, src, positive=True)
    for period in hs:
        ratio = T / period
        if abs(ratio - round(ratio)) > 1e-9 * ratio:
            near = _nearby_divisor(T, period)
            hint = "" if near is None else f" (e.g. {near:g} s)"
            raise SweepConfigError(
                "h",
                f"`h` = {period:g} s{_where(src)} does not divide T = {T:g} s into whole "
                f"steps; choose h = T/n for an integer n{hint} or another T.",
            )
    return T, after, hs


def _percentages(key: str, value: Any, src: str) -> tuple[float, ...]:
    out = _number_list(key, value, src)
    if min(out) < 0:
        raise SweepConfigError(key, f"`{key}`{_where(src)} must be percentages >= 0, got {value}.")
    return out


def _vehicle(data: Mapping[str, Any], base: Path | None, src: str) -> str:
    vehicle = data.get("vehicle", _DEFAULT_VEHICLE)
    if not isinstance(vehicle, str) or not vehicle.strip():
        raise SweepConfigError(
            "vehicle", f"`vehicle`{_where(src)} must be a string, got {vehicle!r}."
        )
    if vehicle.endswith(".toml") or "/" in vehicle or os.sep in vehicle:
        p = Path(vehicle)
        if not p.is_absolute() and base is not None:
            p = base / p
        if not p.is_file():
            raise SweepConfigError("vehicle", f"`vehicle`{_where(src)}: no file {str(p)!r}.")
        return str(p.resolve())
    return vehicle.strip()


def _inputs(data: Mapping[str, Any], src: str) -> tuple[dict[str, Any], ...]:
    from ._inputs import check_input

    raw = data.get("input")
    if raw is None:
        raise SweepConfigError("input", f'`input`{_where(src)} is required, e.g. input = "fig6".')
    out = []
    for item in raw if isinstance(raw, list) and raw else [raw]:
        spec = (
            {"name": item}
            if isinstance(item, str)
            else dict(item)
            if isinstance(item, dict)
            else None
        )
        if spec is None:
            raise SweepConfigError(
                "input", f"`input`{_where(src)} must be a name, a table or a list, got {raw!r}."
            )
        try:
            out.append(check_input(spec))
        except ValueError as exc:
            raise SweepConfigError("input", f"`input`{_where(src)}: {exc}") from exc
    if len({repr(sorted(i.items())) for i in out}) != len(out):
        raise SweepConfigError("input", f"`input`{_where(src)} lists an input twice.")
    return tuple(out)


def _tuning(data: Mapping[str, Any], src: str) -> dict[str, dict[str, Any]]:
    """``feedback_tuning``: law -> its parameters (names checked, finite numbers)."""
    from ._inputs import check_feedback

    raw = data.get("feedback_tuning", {})
    if not isinstance(raw, dict) or not all(isinstance(v, dict) for v in raw.values()):
        raise SweepConfigError(
            "feedback_tuning",
            f"`feedback_tuning`{_where(src)} must be a table of tables, one per feedback law, "
            f"e.g. {{ roll_pitch_hold = {{ kp = 40.0, kd = 6.0 }} }}, got {raw!r}.",
        )
    for law, params in raw.items():
        try:
            check_feedback({"law": law, **params})
        except ValueError as exc:
            raise SweepConfigError(
                "feedback_tuning", f"`feedback_tuning.{law}`{_where(src)}: {exc}"
            ) from exc
        for name, value in params.items():
            _number(f"feedback_tuning.{law}.{name}", value, src)
    return {law: dict(params) for law, params in raw.items()}


def _feedback(data: Mapping[str, Any], src: str) -> dict[str, Any] | None:
    from ._inputs import check_feedback

    tuning = _tuning(data, src)
    raw = data.get("feedback")
    if raw is None or raw == "none":
        return None
    if not isinstance(raw, dict):
        raise SweepConfigError(
            "feedback",
            f"`feedback`{_where(src)} must be a table such as "
            f'{{ law = "roll_pitch_hold", kp = 40.0 }} or "none", got {raw!r}.',
        )
    try:
        # The law's tuning for this vehicle, then the parameters given with it.
        return check_feedback({**tuning.get(str(raw.get("law")), {}), **raw})
    except ValueError as exc:
        raise SweepConfigError("feedback", f"`feedback`{_where(src)}: {exc}") from exc


def _norms(data: Mapping[str, Any], src: str) -> tuple[str, ...]:
    raw = data.get("norm", "rms")
    values = raw if isinstance(raw, list) else [raw]
    if not values:
        raise SweepConfigError("norm", f"`norm`{_where(src)} must not be empty.")
    out = []
    for n in values:
        try:
            out.append(parse_norm(n).text)
        except ValueError as exc:
            raise SweepConfigError("norm", f"`norm`{_where(src)}: {exc}") from exc
    return tuple(dict.fromkeys(out))


def _summaries(data: Mapping[str, Any], src: str) -> tuple[str, ...]:
    raw = data.get("summaries", [])
    raw = [raw] if isinstance(raw, str) else raw
    if not isinstance(raw, list) or any(n not in SUMMARIES for n in raw):
        raise SweepConfigError(
            "summaries",
            f"`summaries`{_where(src)} must be a list of {', '.join(SUMMARIES)}, got {raw!r}.",
        )
    return tuple(dict.fromkeys(raw))


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
    """Warn about a ``per_vehicle`` entry that names no built-in vehicle and not this
    file's vehicle: most likely a misspelling, which would be ignored without a word
    (an entry for a vehicle file used with this study elsewhere is legitimate, so it is
    a warning, not an error)."""
    import difflib
    import warnings

    from ...models import builtin_vehicles

    known = {*builtin_vehicles(), "auv_like", vehicle, Path(vehicle).stem}
    for name in table:
        if name not in known:
            close = difflib.get_close_matches(name, sorted(known), n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            warnings.warn(
                f"`per_vehicle.{name}`{_where(src)} names no built-in vehicle and not this "
                f"sweep's vehicle {vehicle!r}: it applies only when `vehicle` is {name!r} "
                f"or a file {name}.toml{hint}",
                UserWarning,
                stacklevel=4,
            )


def _methods(data: Mapping[str, Any], src: str, kind: CellKind) -> tuple[str, ...]:
    names: list[str] = []
    raw = data.get("methods", [])
    if isinstance(raw, str):
        raw = [raw]
    if not isinstance(raw, list) or not all(isinstance(m, str) for m in raw):
        raise SweepConfigError("methods", f"`methods`{_where(src)} must be a list of names.")
    orders = data.get("orders", [])
    if not isinstance(orders, list) or not all(
        isinstance(s, int) and not isinstance(s, bool) and s >= 1 for s in orders
    ):
        raise SweepConfigError(
            "orders", f"`orders`{_where(src)} must be a list of integers >= 1, got {orders!r}."
        )
    names = [*(f"AB{s}" for s in orders), *(m.strip() for m in raw)]
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


def _noise(data: Mapping[str, Any], src: str) -> Sequence[tuple[float, float]]:
    if "noise" in data:
        if "eta_pct" in data or "v_pct" in data:
            raise SweepConfigError(
                "noise", f"give either `noise` pairs or `eta_pct`/`v_pct`{_where(src)}, not both."
            )
        raw = data["noise"]
        ok = isinstance(raw, list) and raw and all(isinstance(p, list) and len(p) == 2 for p in raw)
        if not ok:
            raise SweepConfigError(
                "noise", f"`noise`{_where(src)} must be a list of [eta %, v %] pairs, got {raw!r}."
            )
        pairs = [
            (_percentages("noise", [p[0]], src)[0], _percentages("noise", [p[1]], src)[0])
            for p in raw
        ]
        if len(set(pairs)) != len(pairs):
            raise SweepConfigError("noise", f"`noise`{_where(src)} lists a pair twice.")
        return tuple(pairs)
    # Distinct lists (checked) give distinct pairs; the product is never listed.
    eta = _percentages("eta_pct", data.get("eta_pct", [0.0]), src)
    v = _percentages("v_pct", data.get("v_pct", [0.0]), src)
    return NoiseGrid(eta, v)


def _seeds(data: Mapping[str, Any], src: str) -> Sequence[int]:
    raw = data.get("seeds", 1)
    if isinstance(raw, int) and not isinstance(raw, bool):
        if raw < 1:
            raise SweepConfigError("seeds", f"`seeds`{_where(src)} must be >= 1, got {raw}.")
        return range(raw)
    if (
        isinstance(raw, list)
        and raw
        and all(isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in raw)
        and len(set(raw)) == len(raw)
    ):
        return tuple(raw)
    raise SweepConfigError(
        "seeds",
        f"`seeds`{_where(src)} must be a count or a list of distinct ints >= 0, got {raw!r}.",
    )


def _kind(data: Mapping[str, Any], src: str) -> CellKind:
    name = data.get("kind", "prediction")
    try:
        return get_cell_kind(name)
    except ValueError as exc:
        raise SweepConfigError("kind", f"`kind`{_where(src)}: {exc}") from exc


def _kind_keys(data: Mapping[str, Any], src: str, kind: CellKind) -> dict[str, Any]:
    """Refuse the common keys the kind does not read; its own settings, checked."""
    uses = set(_KEYS) if kind.uses is None else {*kind.uses, *_ALWAYS}
    for key in (k for k in _KEYS if k in data and k not in uses):
        raise SweepConfigError(
            key,
            f"`{key}`{_where(src)} does not apply to a {kind.name} study ({kind.description}); "
            "remove it.",
        )
    own = {k: data[k] for k in kind.option_keys if k in data}
    try:
        return kind.check_options(own)
    except (ValueError, TypeError) as exc:
        key = exc.key if isinstance(exc, SweepConfigError) else "kind"
        raise SweepConfigError(key, f"{str(exc).rstrip('.')}{_where(src)}.") from exc


def _parse(data: Mapping[str, Any], base: Path | None, src: str) -> SweepConfig:
    kind = _kind(data, src)
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
    T, after, hs = check_time_grid(data["T"], data["after"], data["h"], src)
    base_seed = data.get("base_seed", 0)
    if not isinstance(base_seed, int) or isinstance(base_seed, bool) or base_seed < 0:
        raise SweepConfigError("base_seed", f"`base_seed`{_where(src)} must be an int >= 0.")
    distribution = data.get("distribution", "uniform")
    if distribution not in _DISTRIBUTIONS:
        raise SweepConfigError(
            "distribution",
            f"`distribution`{_where(src)} must be one of {', '.join(_DISTRIBUTIONS)}, "
            f"got {distribution!r}.",
        )
    max_cells = data.get("max_cells")
    if max_cells is not None and (
        not isinstance(max_cells, int) or isinstance(max_cells, bool) or max_cells < 1
    ):
        raise SweepConfigError(
            "max_cells", f"`max_cells`{_where(src)} must be an int >= 1, got {max_cells!r}."
        )
    buoy = data.get("buoyancy_pct")
    x0 = data.get("x0")
    if x0 is not None and not isinstance(x0, list):
        raise SweepConfigError("x0", f"`x0`{_where(src)} must be a list of numbers, got {x0!r}.")
    rtol = _number("rtol", data.get("rtol", 1e-12), src, positive=True)
    return SweepConfig(
        vehicle=_vehicle(data, base, src),
        inputs=_inputs(data, src) if kind.needs_input else (),
        T=T,
        after=after,
        h=hs,
        methods=_methods(data, src, kind),
        noise=_noise(data, src),
        seeds=_seeds(data, src),
        norms=_norms(data, src) if kind.uses is None or "norm" in kind.uses else (),
        base_seed=base_seed,
        distribution=distribution,
        buoyancy_pct=None if buoy is None else _number("buoyancy_pct", buoy, src),
        x0=None if x0 is None else tuple(_number("x0", v, src) for v in x0),
        max_cells=max_cells,
        feedback=_feedback(data, src),
        rtol=rtol,
        summaries=_summaries(data, src),
        kind=kind.name,
        options=options,
        source=src,
    )
