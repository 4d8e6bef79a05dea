"""Message streams at different rates to one table: the sampling rule shared by the
ROS bag and ArduSub DataFlash readers.

* States are taken at the stamps of the state message (odometry, EKF state); a state
  quantity logged by another message (a gyro) is taken from its message nearest in
  time, and the largest time offset is reported.
* Inputs are a zero-order hold: at each state stamp, the last command stamped at or
  before it. State samples before the first command are dropped (and reported).
* Thruster commands are converted to the model's rpm: from rpm, rps, rev/s or rad/s by
  a factor, from ESC PWM (us) by the T200 table (:mod:`._t200`), then signed by each
  thruster's ``direction`` (+1 or -1).
"""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..exceptions import LogFormatError, MissingArgumentError
from ..models import Model
from ._mapping import check_keys, load_toml
from ._t200 import T200_VOLTAGES, t200_deadband, t200_rpm
from ._units import CONVERSIONS

__all__ = [
    "SAMPLING_RULE",
    "SURFACE_DEPTH",
    "THRUSTER_KEYS",
    "VEHICLE_STATES",
    "MAPPING_EXAMPLES",
    "check_vehicle",
    "default_mapping_note",
    "drop_before_first_command",
    "hold_last",
    "longest_stretch",
    "mapping_section",
    "nearest",
    "surface_warning",
    "thruster_options",
    "thruster_rpm",
    "vehicle_frame",
]

VEHICLE_STATES = ("x", "y", "z", "phi", "theta", "psi", "u", "v", "w", "p", "q", "r")
_STATE_UNITS = ("m",) * 3 + ("rad",) * 3 + ("m/s",) * 3 + ("rad/s",) * 3
THRUSTER_KEYS = ("unit", "direction", "voltage")
SAMPLING_RULE = (
    "states at the stamps of the state message; inputs a zero-order hold of the last "
    "command at or before each state stamp"
)


def check_vehicle(model: Model, src: str) -> None:
    """Bags and DataFlash logs hold 6-DoF vehicle motion: the model must have the
    states (x, y, z, phi, theta, psi, u, v, w, p, q, r) in m, rad, m/s, rad/s."""
    if tuple(model.state_names) != VEHICLE_STATES or tuple(model.state_units) != _STATE_UNITS:
        raise LogFormatError(
            "vehicle",
            f"{src}: a bag or DataFlash log gives 6-DoF vehicle motion; the model's states "
            f"{tuple(model.state_names)} are not {VEHICLE_STATES}. Use a vehicle model "
            "(sampledyn.models.load_vehicle).",
        )


#: Section of a mapping file -> (the logs it is for, the example mapping files).
MAPPING_EXAMPLES: dict[str, tuple[str, str]] = {
    "ardusub": ("an ArduSub DataFlash log (.bin)", "examples/ardusub_dataflash.toml"),
    "mavlink": ("a MAVLink .tlog or a BlueOS MCAP log", "examples/ardusub_mavlink.toml"),
    "ros": (
        "a ROS bag",
        "examples/ros2_bluerov2_heavy.toml, examples/ros1_mavros_bluerov2_heavy.toml",
    ),
    "columns": ("a CSV/Parquet table", "docs/logs.md"),
}

#: The sections whose every key has a default (the autopilot logs: their message names
#: and PWM servo outputs are fixed by ArduSub), read as such without a mapping file.
_DEFAULTS: dict[str, dict[str, Any]] = {
    "ardusub": {"thrusters": {"unit": "pwm"}},
    "mavlink": {"thrusters": {"unit": "pwm"}},
}


def _mapping_name(mapping: Any) -> str:
    return "the mapping" if isinstance(mapping, Mapping) else f"mapping file {str(mapping)!r}"


def default_mapping_note(mapping: Any, section: str) -> tuple[str, ...]:
    """The note of a log read with the defaults of ``[section]`` (no mapping given)."""
    if load_toml(mapping):
        return ()
    return (
        f"no mapping file: every key of [{section}] at its default (docs/logs.md; "
        f"{MAPPING_EXAMPLES[section][1]} lists them, to copy and change)",
    )


def mapping_section(
    model: Model, mapping: Any, section: str, keys: Sequence[str], src: str, what: str
) -> tuple[dict[str, Any], Mapping[str, Any]]:
    """The ``[section]`` of a bag or DataFlash mapping file and its input table
    (``thrusters``, or ``wrench`` where ``keys`` allows it), every key checked (the
    model must be a 6-DoF vehicle whose input is the one the table gives). Without a
    mapping, the sections of :data:`_DEFAULTS` take every key's default; the others
    need a file."""
    check_vehicle(model, src)
    raw = load_toml(mapping)
    if not raw and section in _DEFAULTS:
        raw = {section: copy.deepcopy(_DEFAULTS[section])}
    if not raw:
        raise MissingArgumentError(
            "mapping",
            f"{src}: {what} needs a mapping file naming its topics and thrusters; copy and "
            f"change {MAPPING_EXAMPLES[section][1]} (docs/logs.md).",
        )
    if section not in raw:
        other = [k for k in raw if k in MAPPING_EXAMPLES]
        if other:
            raise LogFormatError(
                "mapping",
                f"{src}: {_mapping_name(mapping)} has [{other[0]}], which is for "
                f"{MAPPING_EXAMPLES[other[0]][0]}; {what} needs [{section}] (see "
                f"{MAPPING_EXAMPLES[section][1]}).",
            )
    check_keys(
        raw, [section], f"the top level of {_mapping_name(mapping)} ({what} needs [{section}])",
        [section],
    )  # fmt: skip
    cfg = raw[section]
    if not isinstance(cfg, Mapping):
        raise LogFormatError("mapping", f"mapping file: [{section}] must be a table.")
    inputs = [k for k in ("thrusters", "wrench") if k in keys]
    check_keys(cfg, keys, f"[{section}]")
    given = [k for k in inputs if k in cfg]
    if len(given) != 1:
        raise LogFormatError(
            "mapping",
            f"mapping file: [{section}] needs "
            + " or ".join(f"[{section}.{k}]" for k in inputs)
            + (" (one of them)." if len(inputs) > 1 else "."),
        )
    table = cfg[given[0]]
    if not isinstance(table, Mapping):
        raise LogFormatError("mapping", f"mapping file: [{section}.{given[0]}] must be a table.")
    wrench = bool(getattr(model, "wrench_input", False))
    if wrench != (given[0] == "wrench"):
        fix = (
            "load the vehicle with wrench_input=True (sampledyn evaluate does so for a "
            "mapping with [{s}.wrench])"
            if given[0] == "wrench"
            else "give the commanded wrench in [{s}.wrench], or a vehicle with thruster inputs"
        ).format(s=section)
        raise LogFormatError(
            "mapping",
            f"{src}: the mapping gives the {'wrench' if given[0] == 'wrench' else 'thruster'} "
            f"inputs but the model's inputs are {', '.join(model.input_names)}; {fix}.",
        )
    return dict(cfg), table


def hold_last(
    state_stamps: np.ndarray, stamps: np.ndarray, values: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Zero-order hold: ``values`` of the last command stamped at or before each state
    stamp, and a mask of the states that have one. Stamps are integers (ns or us)."""
    order = np.argsort(stamps, kind="stable")
    stamps, values = stamps[order], values[order]
    idx = np.searchsorted(stamps, state_stamps, side="right") - 1
    ok = idx >= 0
    return values[np.maximum(idx, 0)], ok


def drop_before_first_command(have: np.ndarray, src: str) -> list[str]:
    """Notes on the state samples dropped because no command precedes them; an error
    if none is left."""
    if not have.any():
        raise LogFormatError(
            "thrusters", f"{src}: no thruster command is stamped at or before any state sample."
        )
    dropped = int((~have).sum())
    samples = "sample" if dropped == 1 else "samples"
    return [f"{dropped} state {samples} before the first command dropped"] if dropped else []


def nearest(
    state_stamps: np.ndarray, stamps: np.ndarray, values: np.ndarray
) -> tuple[np.ndarray, int]:
    """``values`` of the message nearest in time to each state stamp, and the largest
    offset (same integer unit as the stamps)."""
    order = np.argsort(stamps, kind="stable")
    stamps, values = stamps[order], values[order]
    right = np.clip(np.searchsorted(stamps, state_stamps), 0, stamps.size - 1)
    left = np.clip(right - 1, 0, stamps.size - 1)
    pick = np.where(
        np.abs(stamps[left] - state_stamps) <= np.abs(stamps[right] - state_stamps), left, right
    )
    return values[pick], int(np.abs(stamps[pick] - state_stamps).max())


def thruster_options(
    table: Mapping[str, Any], nu: int, where: str, extra: Sequence[str], required: Sequence[str]
) -> tuple[str, np.ndarray | None, float | str]:
    """Check the thruster table of a mapping file; returns (unit, direction or None
    where the table gives none, voltage: a number in 10..20 V or "logged")."""
    check_keys(table, [*extra, *THRUSTER_KEYS], where, required=[*required, "unit"])
    unit = str(table["unit"])
    accepted = [*CONVERSIONS["rpm"], "pwm"]
    if unit not in accepted:
        raise LogFormatError(
            "mapping",
            f"mapping file: {where}: unit {unit!r} is not a thruster command unit; accepted: "
            f"{', '.join(accepted)} ('pwm': ESC pulse width in us, through the T200 table).",
        )
    direction = None
    if "direction" in table:
        direction = np.asarray(table["direction"], dtype=float)
        if direction.shape != (nu,) or not np.isin(direction, (-1.0, 1.0)).all():
            raise LogFormatError(
                "mapping",
                f"mapping file: {where}: `direction` must list {nu} signs (+1 or -1), got "
                f"{table.get('direction')!r}.",
            )
    voltage: float | str = table.get("voltage", 16)
    lo, hi = T200_VOLTAGES[0], T200_VOLTAGES[-1]
    if voltage != "logged" and not (
        isinstance(voltage, int | float) and not isinstance(voltage, bool) and lo <= voltage <= hi
    ):
        raise LogFormatError(
            "mapping",
            f"mapping file: {where}: `voltage` must be the T200 supply in {lo}..{hi} V "
            f'(interpolated between the measured {T200_VOLTAGES} V) or "logged" (the '
            f"log's battery voltage), got {voltage!r}.",
        )
    return unit, direction, voltage if voltage == "logged" else float(voltage)


def _volts_text(voltage: float | np.ndarray) -> str:
    v = np.asarray(voltage, dtype=float)
    if v.ndim == 0 or v.min() == v.max():
        return f"{float(v.ravel()[0]):.4g} V"
    return f"{v.min():.4g}..{v.max():.4g} V"


def _deadband_note(values: np.ndarray, voltage: float | np.ndarray) -> str | None:
    """How many commands (on, i.e. not 0 us) sit in the T200 deadband."""
    lo, hi = t200_deadband(float(np.mean(voltage)))
    on = values != 0
    inside = on & (values >= lo) & (values <= hi)
    if not inside.any():
        return None
    off = inside & (values != 1500)
    seen = values[off] if off.any() else values[inside]
    return (
        f"{int(inside.sum())} of {int(on.sum())} thruster commands lie in the T200 deadband "
        f"{lo:g}..{hi:g} us (0 rpm by the table), {int(off.sum())} of them off the 1500 us "
        f"neutral ({seen.min():g}..{seen.max():g} us)"
    )


def thruster_rpm(
    values: np.ndarray,
    unit: str,
    direction: np.ndarray,
    voltage: float | np.ndarray,
    src: str,
    voltage_source: str = "",
) -> tuple[np.ndarray, list[str]]:
    """Commands (N, nu) in ``unit`` -> signed rpm (N, nu), and notes saying how.

    ``voltage`` is one supply (V) or one per sample (shape (N,)); PWM of 0 us (no
    pulse: output off) is 0 rpm."""
    notes: list[str] = []
    if unit == "pwm":
        volts = np.asarray(voltage, dtype=float)
        off = values == 0
        try:
            rpm = t200_rpm(
                np.where(off, 1500.0, values), volts[:, None] if volts.ndim == 1 else volts
            )
        except ValueError as exc:
            raise LogFormatError("thrusters", f"{src}: {exc}") from None
        how = (
            f"thruster PWM (us) -> rpm by the Blue Robotics T200 table at {_volts_text(volts)}"
            f"{voltage_source} (bollard data, linear between its 4 us points"
            + (", and between its 2 V tables)" if _between_tables(volts) else ")")
        )
        if off.any():
            notes.append(
                f"{int(off.sum())} thruster commands of 0 us (no pulse: off) taken as 0 rpm"
            )
        dead = _deadband_note(values, volts)
        if dead:
            notes.append(dead)
    else:
        rpm = values * CONVERSIONS["rpm"][unit]
        how = f"thruster commands in {unit} -> rpm"
    if (direction < 0).any():
        how += f", signs {', '.join(f'{d:+.0f}' for d in direction)}"
    return rpm * direction, [how, *notes]


def _between_tables(volts: np.ndarray) -> bool:
    return not np.isin(np.ravel(volts), T200_VOLTAGES).all()


def longest_stretch(keep: np.ndarray) -> tuple[int, int, int]:
    """(start, stop, number of stretches) of the longest run of True in ``keep``."""
    edges = np.diff(np.concatenate([[0], keep.astype(np.int8), [0]]))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    if not starts.size:
        return 0, 0, 0
    k = int(np.argmax(stops - starts))
    return int(starts[k]), int(stops[k]), int(starts.size)


#: Depth (m) below which an ArduSub log is taken as in air or at the surface: the
#: BlueROV2's frame is 254 mm high, so with its origin less than 0.1 m under the
#: surface part of it is out of the water (and a bench log reads about 0).
SURFACE_DEPTH = 0.1


def surface_warning(z: np.ndarray, src: str) -> list[str]:
    """A warning when the depth z (m, NED, from the autopilot's pressure sensor) stays
    below :data:`SURFACE_DEPTH` throughout."""
    if z.size and float(np.max(z)) < SURFACE_DEPTH:
        return [
            f"{src}: the depth stays below {SURFACE_DEPTH:g} m throughout (z = "
            f"{float(np.min(z)):.3g}..{float(np.max(z)):.3g} m): the log was recorded in air or "
            "at the surface, outside the hydrodynamic model (added mass, damping and "
            "buoyancy of a submerged vehicle); its errors do not measure the model"
        ]
    return []


def vehicle_frame(
    model: Model,
    stamps: np.ndarray,
    stamp_unit: str,
    eta: np.ndarray,
    v: np.ndarray,
    rpm: np.ndarray,
) -> Any:
    """A table with the model's column names and units, for :func:`log_from_frame`."""
    import pandas as pd

    columns: dict[str, Any] = {f"t[{stamp_unit}]": np.asarray(stamps, dtype=np.int64)}
    for k, (name, unit) in enumerate(zip(VEHICLE_STATES, _STATE_UNITS, strict=True)):
        columns[f"{name}[{unit}]"] = (eta if k < 6 else v)[:, k % 6]
    for j, (name, unit) in enumerate(zip(model.input_names, model.input_units, strict=True)):
        columns[f"{name}[{unit}]"] = rpm[:, j]
    return pd.DataFrame(columns)
