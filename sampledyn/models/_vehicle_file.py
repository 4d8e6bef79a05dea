"""Vehicle files: TOML with a unit and a source for every number.

The format is described in the header of the built-in file
``sampledyn/models/vehicles/bluerov2_heavy.toml``. In short::

    name = "my_rov"
    [rigid_body]
    mass = { value = 13.5, unit = "kg", source = "datasheet" }
    ...
    [[thruster]]
    name = "T1"
    position = { value = [0.156, 0.111, 0.085], unit = "m", source = "CAD" }
    direction = { value = [0.7071, -0.7071, 0.0], unit = "1", source = "CAD" }

Matrices are lists of rows: ``inertia`` a 3 x 3 tensor, ``added_mass`` and
``linear_damping`` 6 x 6 matrices with the units of their four 3 x 3 blocks
(see ``_SCHEMA``). No unit conversion is done: each number must carry the unit
listed in ``_SCHEMA``. Every problem raises ValueError naming the field
(``rigid_body.mass``, ``thruster[3].direction``, ``hydrodynamics.added_mass[2][5]``).

A published inertia tensor or added-mass matrix that is symmetric only to its
printed digits is averaged pair by pair ((A + A^T)/2, pairs within
:data:`~sampledyn.models.SYMMETRY_RTOL` relative; larger differences are refused),
with a warning, unless the file states it with a fourth key::

    added_mass = { value = [...], unit = [...], source = "...",
                   symmetrised = { rule = "mean", rtol = 1e-3,
                                   pairs = [[2, 5, 10.774, 10.775]] } }

``pairs`` lists every asymmetric pair of the printed matrix as [i, j, A_ij, A_ji]
(0-based, i < j, the printed values), ``rule`` is "mean" (the only rule), ``rtol``
(optional, at most 1e-3) the tolerance the file asks for. Loading is then silent; a
declaration that no longer matches the matrix is refused, naming the pair.
"""

from __future__ import annotations

import math
import os
import warnings
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from .._files import parse_toml, read_text
from ..exceptions import VehicleParameterError
from ._vehicle import QUADRATIC_IS_DIAGONAL, SYMMETRY_RTOL, AsymmetricPair, Vehicle, symmetrized

__all__ = ["builtin_vehicles", "load_vehicle"]

_L6 = ("kg", "kg", "kg", "kg m^2", "kg m^2", "kg m^2")
_D6 = ("N s/m",) * 3 + ("N m s/rad",) * 3
_Q6 = ("N s^2/m^2",) * 3 + ("N m s^2/rad^2",) * 3
# Units of the 3 x 3 blocks [[11, 12], [21, 22]] of a 6 x 6 matrix, in this order
# (force / moment rows, linear / angular velocity or acceleration columns).
_MA_BLOCKS = ("kg", "kg m", "kg m", "kg m^2")
_DL_BLOCKS = ("N s/m", "N s/rad", "N s", "N m s/rad")

_Units = str | tuple[str, ...]
# table -> key -> (Vehicle argument, {accepted shape: unit(s)}, required)
_SCHEMA: dict[str, dict[str, tuple[str, dict[tuple[int, ...], _Units], bool]]] = {
    "environment": {
        "rho": ("rho", {(): "kg/m^3"}, True),
        "g": ("g", {(): "m/s^2"}, True),
    },
    "rigid_body": {
        "mass": ("mass", {(): "kg"}, True),
        "inertia": ("inertia", {(3,): "kg m^2", (3, 3): "kg m^2"}, True),
        "r_G": ("r_G", {(3,): "m"}, True),
        "r_B": ("r_B", {(3,): "m"}, True),
        "volume": ("volume", {(): "m^3"}, True),
    },
    "hydrodynamics": {
        "added_mass": ("added_mass", {(6,): _L6, (6, 6): _MA_BLOCKS}, True),
        "linear_damping": ("linear_damping", {(6,): _D6, (6, 6): _DL_BLOCKS}, True),
        "quadratic_damping": ("quadratic_damping", {(6,): _Q6}, True),
    },
    "thruster_model": {
        "K1": ("K1", {(): "N/rpm^2"}, True),
        "K2": ("K2", {(): "N s/(m rpm)"}, True),
        "n_max": ("n_max", {(): "rpm"}, True),
        "lag_time_constant": ("lag_time_constant", {(): "s"}, False),
    },
}
_THRUSTER: dict[str, dict[tuple[int, ...], _Units]] = {
    "position": {(3,): "m"},
    "direction": {(3,): "1"},
}
_TOP = {"name", "description", "thruster", *_SCHEMA}
_DAMPING = {"linear_damping", "quadratic_damping"}
_SYMMETRIC = {"inertia", "added_mass"}  # matrices a `symmetrised` declaration applies to
_RULES = ("mean",)


def _fail(path: Any, fld: str, message: str) -> ValueError:
    return ValueError(f"vehicle file {path}: field `{fld}`: {message}")


def _number(path: Any, fld: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise _fail(path, fld, f"must be a number, got {value!r}.")
    if not math.isfinite(value):
        raise _fail(path, fld, f"must be finite, got {value!r}.")
    return float(value)


def _shape(value: Any) -> tuple[int, ...] | None:
    """Shape of a number, a list of numbers or a list of equal-length lists."""
    if not isinstance(value, list):
        return ()
    if value and all(isinstance(row, list) for row in value):
        if len({len(row) for row in value}) != 1:
            return None
        return (len(value), len(value[0]))
    if any(isinstance(c, list) for c in value):
        return None
    return (len(value),)


def _describe(shape: tuple[int, ...]) -> str:
    if shape == ():
        return "a number"
    if len(shape) == 1:
        return f"a list of {shape[0]} numbers"
    return f"a {shape[0]} x {shape[1]} matrix (a list of {shape[0]} rows of {shape[1]})"


def _quantity(
    path: Any, fld: str, entry: Any, units: dict[tuple[int, ...], _Units]
) -> tuple[Any, str]:
    """Check ``{ value, unit, source }``; return (value, source)."""
    if not isinstance(entry, dict):
        raise _fail(
            path,
            fld,
            f"must be a table {{ value = ..., unit = ..., source = ... }}, got {entry!r}.",
        )
    for key in ("value", "unit", "source"):
        if key not in entry:
            raise _fail(path, fld, f"missing `{key}`.")
    extra = set(entry) - {"value", "unit", "source"}
    if extra:
        raise _fail(path, fld, f"unknown key(s) {sorted(extra)}; allowed: value, unit, source.")
    source = entry["source"]
    if not isinstance(source, str) or not source.strip():
        raise _fail(path, fld, "`source` must be a non-empty string.")
    value = entry["value"]
    shape = _shape(value)
    if shape not in units:
        if fld.endswith("quadratic_damping") and shape == (6, 6):
            raise _fail(path, fld, f"quadratic damping {QUADRATIC_IS_DIAGONAL}")
        allowed = " or ".join(_describe(s) for s in units)
        raise _fail(path, fld, f"`value` must be {allowed}, got {value!r}.")
    want = units[shape]
    got = entry["unit"]
    if isinstance(want, tuple) and isinstance(got, str) and len(set(want)) == 1:
        got = (got,) * len(want)
    if isinstance(got, list):
        got = tuple(got)
    if got != want:
        shown = want if isinstance(want, str) else list(want)
        what = (
            " (units of the blocks [[11, 12], [21, 22]])"
            if len(shape) == 2 and len(want) == 4
            else ""
        )
        raise _fail(
            path, fld, f"unit must be {shown!r}{what}, got {entry['unit']!r} (no conversion)."
        )
    if shape == ():
        return _number(path, fld, value), source
    if len(shape) == 1:
        return tuple(_number(path, f"{fld}[{i}]", c) for i, c in enumerate(value)), source
    return (
        tuple(
            tuple(_number(path, f"{fld}[{i}][{j}]", c) for j, c in enumerate(row))
            for i, row in enumerate(value)
        ),
        source,
    )


def _check_damping(path: Any, fld: str, value: Any) -> None:
    """Damping must dissipate: v^T D v >= 0, i.e. (D + D^T)/2 positive semi-definite
    (for a diagonal D, entries >= 0)."""
    d = np.asarray(value, dtype=float)
    if d.ndim == 1:
        if d.min() < 0:
            raise _fail(path, fld, f"damping must be >= 0, got {value}.")
        return
    eig = np.linalg.eigvalsh(0.5 * (d + d.T))
    if eig.min() < -1e-12 * np.abs(d).max():
        raise _fail(
            path,
            fld,
            "damping must dissipate energy (v^T D_l v >= 0): the symmetric part of the "
            f"matrix has the eigenvalue {eig.min():.6g} < 0.",
        )


def _declaration(path: Any, fld: str, arg: str, spec: Any) -> tuple[list[AsymmetricPair], float]:
    """The pairs and tolerance of a ``symmetrised`` declaration (see the module
    docstring), checked."""
    if arg not in _SYMMETRIC:
        raise _fail(
            path, fld, "`symmetrised` applies to rigid_body.inertia and "
            "hydrodynamics.added_mass only (symmetric matrices).",
        )  # fmt: skip
    where = f"{fld}.symmetrised"
    if not isinstance(spec, dict) or set(spec) - {"rule", "rtol", "pairs"}:
        raise _fail(
            path, where, "must be a table { rule = \"mean\", rtol = 1e-3, pairs = "
            f"[[i, j, A_ij, A_ji], ...] }} (rtol optional), got {spec!r}.",
        )  # fmt: skip
    if spec.get("rule") not in _RULES:
        raise _fail(
            path, f"{where}.rule", f"must be one of {list(_RULES)} ((A + A^T)/2 pair by "
            f"pair), got {spec.get('rule')!r}.",
        )  # fmt: skip
    rtol = _number(path, f"{where}.rtol", spec.get("rtol", SYMMETRY_RTOL))
    if not 0 < rtol <= SYMMETRY_RTOL:
        raise _fail(
            path, f"{where}.rtol", f"must be in (0, {SYMMETRY_RTOL:g}] (the largest "
            f"relative difference a printed-digit rule may average), got {rtol!r}.",
        )  # fmt: skip
    raw = spec.get("pairs")
    if not isinstance(raw, list) or not raw:
        raise _fail(path, f"{where}.pairs", f"must be a non-empty list, got {raw!r}.")
    pairs = []
    for k, item in enumerate(raw):
        at = f"{where}.pairs[{k}]"
        ok = isinstance(item, list) and len(item) == 4
        if not ok or any(isinstance(c, bool) or not isinstance(c, int) for c in item[:2]):
            raise _fail(path, at, f"must be [i, j, A_ij, A_ji] (i, j integers), got {item!r}.")
        upper, lower = _number(path, at, item[2]), _number(path, at, item[3])
        if upper == lower:
            raise _fail(path, at, f"[{item[0]}, {item[1]}] is declared but not asymmetric.")
        pairs.append((int(item[0]), int(item[1]), upper, lower))
    return pairs, rtol


def _declared_symmetric(
    path: Any, fld: str, arg: str, value: Any, pairs: list[AsymmetricPair], rtol: float
) -> Any:
    """The matrix of ``fld`` made symmetric by its declaration (silently)."""
    a = np.asarray(value, dtype=float)
    if a.ndim != 2:
        raise _fail(path, fld, "`symmetrised` declares the asymmetry of a matrix; this is "
                    "a diagonal.")  # fmt: skip
    try:
        sym = symmetrized(arg, a, declared=pairs, rtol=rtol)
    except VehicleParameterError as exc:
        raise _fail(path, fld, str(exc)) from None
    return tuple(tuple(float(c) for c in row) for row in sym)


def _parse(path: Any, data: dict[str, Any]) -> dict[str, Any]:
    """The :class:`Vehicle` arguments of a vehicle file's ``data`` (every entry
    checked, its source kept in ``sources``)."""
    unknown = set(data) - _TOP
    if unknown:
        raise _fail(
            path, sorted(unknown)[0], f"unknown key; allowed top-level keys: {sorted(_TOP)}."
        )
    kwargs: dict[str, Any] = {}
    sources: dict[str, str] = {}
    name = data.get("name")
    if not isinstance(name, str) or not name:
        raise _fail(path, "name", "missing or not a non-empty string.")
    kwargs["name"] = name
    if "description" in data and not isinstance(data["description"], str):
        raise _fail(path, "description", "must be a string.")
    for table, spec in _SCHEMA.items():
        _parse_table(path, table, spec, data.get(table), kwargs, sources)
    positions, directions = _parse_thrusters(path, data.get("thruster"), sources)
    kwargs["thruster_positions"] = positions
    kwargs["thruster_directions"] = directions
    kwargs["sources"] = sources
    return kwargs


def _parse_table(
    path: Any, table: str, spec: dict[str, Any], content: Any, kwargs: dict[str, Any],
    sources: dict[str, str],
) -> None:  # fmt: skip
    """The quantities of one table of a vehicle file into ``kwargs`` and ``sources``."""
    if content is None:
        raise _fail(path, table, "missing table.")
    if not isinstance(content, dict):
        raise _fail(path, table, "must be a table.")
    unknown = set(content) - set(spec)
    if unknown:
        key = sorted(unknown)[0]
        raise _fail(path, f"{table}.{key}", f"unknown key; allowed: {sorted(spec)}.")
    for key, (arg, units, required) in spec.items():
        fld = f"{table}.{key}"
        if key not in content:
            if required:
                raise _fail(path, fld, "missing.")
            continue
        entry = content[key]
        declared = None
        if isinstance(entry, dict) and "symmetrised" in entry:
            entry = dict(entry)
            declared = _declaration(path, fld, arg, entry.pop("symmetrised"))
        value, source = _quantity(path, fld, entry, units)
        if declared is not None:
            value = _declared_symmetric(path, fld, arg, value, *declared)
        if arg in _DAMPING:
            _check_damping(path, fld, value)
        kwargs[arg] = value
        sources[arg] = source


def _parse_thrusters(
    path: Any, thrusters: Any, sources: dict[str, str]
) -> tuple[tuple[Any, ...], tuple[Any, ...]]:
    """Positions and directions of the ``[[thruster]]`` tables (sources kept)."""
    if not isinstance(thrusters, list) or not thrusters:
        raise _fail(path, "thruster", "missing: give at least one [[thruster]] table.")
    positions: list[Any] = []
    directions: list[Any] = []
    for i, th in enumerate(thrusters):
        base = f"thruster[{i}]"
        if not isinstance(th, dict):
            raise _fail(path, base, "must be a table.")
        unknown = set(th) - {"name", *_THRUSTER}
        if unknown:
            raise _fail(
                path,
                f"{base}.{sorted(unknown)[0]}",
                "unknown key; allowed: name, position, direction.",
            )
        if "name" in th and not isinstance(th["name"], str):
            raise _fail(path, f"{base}.name", "must be a string.")
        for key, units in _THRUSTER.items():
            if key not in th:
                raise _fail(path, f"{base}.{key}", "missing.")
            value, source = _quantity(path, f"{base}.{key}", th[key], units)
            (positions if key == "position" else directions).append(value)
            sources[f"{base}.{key}"] = source
    return tuple(positions), tuple(directions)


def _file_field(argument: str) -> str:
    for table, spec in _SCHEMA.items():
        for key, (arg, *_rest) in spec.items():
            if arg == argument:
                return f"{table}.{key}"
    if argument in ("thruster_positions", "thruster_directions"):
        return "thruster." + argument.removeprefix("thruster_")[:-1]
    return argument


def builtin_vehicles() -> tuple[str, ...]:
    """Names of the vehicle files shipped with sampledyn (for :func:`load_vehicle`)."""
    folder = resources.files("sampledyn.models") / "vehicles"
    return tuple(
        sorted(p.name.removesuffix(".toml") for p in folder.iterdir() if p.name.endswith(".toml"))
    )


def load_vehicle(name_or_path: str | os.PathLike[str], **overrides: Any) -> Vehicle:
    """Load a vehicle file and build the :class:`Vehicle`.

    Parameters
    ----------
    name_or_path : str or path
        A built-in name (see :func:`builtin_vehicles`, e.g. ``"bluerov2_heavy"``) or
        the path of a TOML vehicle file.
    **overrides
        Passed to :meth:`Vehicle.with_params`: parameters (``mass=14.0``,
        ``X_u=10.0``) or options (``thruster_lag=True``, ``current=(0.2, 0, 0, 0, 0, 0)``,
        ``cable_force=...``).

    Returns
    -------
    Vehicle

    Raises
    ------
    ValueError
        For an unknown built-in name or a bad file; the message names the field.
    FileNotFoundError
        If a path does not exist.
    """
    text: str
    where: Any
    is_path = isinstance(name_or_path, os.PathLike) or (
        isinstance(name_or_path, str)
        and (name_or_path.endswith(".toml") or os.sep in name_or_path or "/" in name_or_path)
    )
    if is_path:
        where = Path(name_or_path)
        text = read_text(where, "vehicle file")  # regular, bounded, UTF-8 (named)
    elif isinstance(name_or_path, str):
        names = builtin_vehicles()
        if name_or_path not in names:
            raise ValueError(
                f"unknown built-in vehicle {name_or_path!r}; available: {list(names)}, "
                "or give the path of a .toml vehicle file."
            )
        res = resources.files("sampledyn.models") / "vehicles" / f"{name_or_path}.toml"
        where = name_or_path
        text = res.read_text(encoding="utf-8")
    else:
        raise TypeError(
            f"`name_or_path` must be a str or a path, got {type(name_or_path).__name__}."
        )
    data = parse_toml(text, f"vehicle file {where}")  # nesting bounded
    kwargs = _parse(where, data)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            vehicle = Vehicle(**kwargs)
    except VehicleParameterError as exc:
        raise _fail(where, _file_field(exc.argument), str(exc)) from None
    for w in caught:  # name the file's field (a matrix symmetrised to printed digits)
        message = str(w.message)
        for arg in ("inertia", "added_mass"):
            message = message.replace(
                f"`{arg}`", f"vehicle file {where}: field `{_file_field(arg)}`"
            )
        warnings.warn(message, w.category, stacklevel=2)
    return vehicle.with_params(**overrides) if overrides else vehicle
