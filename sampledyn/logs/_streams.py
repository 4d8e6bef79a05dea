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

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ._mapping import check_keys, load_toml
from ._t200 import T200_VOLTAGES, t200_rpm
from ._units import CONVERSIONS, LogFormatError

__all__ = [
    "SAMPLING_RULE",
    "THRUSTER_KEYS",
    "VEHICLE_STATES",
    "check_vehicle",
    "drop_before_first_command",
    "hold_last",
    "mapping_section",
    "nearest",
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


def check_vehicle(model: Any, src: str) -> None:
    """Bags and DataFlash logs hold 6-DoF vehicle motion: the model must have the
    states (x, y, z, phi, theta, psi, u, v, w, p, q, r) in m, rad, m/s, rad/s."""
    if tuple(model.state_names) != VEHICLE_STATES or tuple(model.state_units) != _STATE_UNITS:
        raise LogFormatError(
            "vehicle",
            f"{src}: a bag or DataFlash log gives 6-DoF vehicle motion; the model's states "
            f"{tuple(model.state_names)} are not {VEHICLE_STATES}. Use a vehicle model "
            "(sampledyn.models.load_vehicle).",
        )


def mapping_section(
    model: Any, mapping: Any, section: str, keys: Sequence[str], src: str, what: str
) -> tuple[dict[str, Any], Mapping[str, Any]]:
    """The ``[section]`` of a bag or DataFlash mapping file and its ``thrusters``
    table, every key checked (the model must be a 6-DoF vehicle)."""
    check_vehicle(model, src)
    raw = load_toml(mapping)
    if not raw:
        raise LogFormatError("mapping", f"{src}: {what} needs a mapping file (see docs/logs.md).")
    check_keys(raw, [section], f"the top level (this mapping has [{section}])", [section])
    cfg = raw[section]
    if not isinstance(cfg, Mapping):
        raise LogFormatError("mapping", f"mapping file: [{section}] must be a table.")
    check_keys(cfg, keys, f"[{section}]", required=["thrusters"])
    thr = cfg["thrusters"]
    if not isinstance(thr, Mapping):
        raise LogFormatError("mapping", f"mapping file: [{section}.thrusters] must be a table.")
    return dict(cfg), thr


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
) -> tuple[str, np.ndarray, float]:
    """Check the thruster table of a mapping file; returns (unit, direction, voltage)."""
    check_keys(table, [*extra, *THRUSTER_KEYS], where, required=[*required, "unit"])
    unit = str(table["unit"])
    accepted = [*CONVERSIONS["rpm"], "pwm"]
    if unit not in accepted:
        raise LogFormatError(
            "mapping",
            f"mapping file: {where}: unit {unit!r} is not a thruster command unit; accepted: "
            f"{', '.join(accepted)} ('pwm': ESC pulse width in us, through the T200 table).",
        )
    direction = np.asarray(table.get("direction", [1] * nu), dtype=float)
    if direction.shape != (nu,) or not np.isin(direction, (-1.0, 1.0)).all():
        raise LogFormatError(
            "mapping",
            f"mapping file: {where}: `direction` must list {nu} signs (+1 or -1), got "
            f"{table.get('direction')!r}.",
        )
    voltage = float(table.get("voltage", 16))
    if unit == "pwm" and voltage not in T200_VOLTAGES:
        raise LogFormatError(
            "mapping",
            f"mapping file: {where}: `voltage` must be one of the T200 table's supplies "
            f"{T200_VOLTAGES} V, got {voltage:g}.",
        )
    return unit, direction, voltage


def thruster_rpm(
    values: np.ndarray, unit: str, direction: np.ndarray, voltage: float, src: str
) -> tuple[np.ndarray, str]:
    """Commands (N, nu) in ``unit`` -> signed rpm (N, nu), and a note saying how."""
    if unit == "pwm":
        try:
            rpm = t200_rpm(values, voltage)
        except ValueError as exc:
            raise LogFormatError("thrusters", f"{src}: {exc}") from None
        how = (
            f"thruster PWM (us) -> rpm by the Blue Robotics T200 table at {voltage:g} V "
            "(bollard data, linear between its 4 us points)"
        )
    else:
        rpm = values * CONVERSIONS["rpm"][unit]
        how = f"thruster commands in {unit} -> rpm"
    if (direction < 0).any():
        how += f", signs {', '.join(f'{d:+.0f}' for d in direction)}"
    return rpm * direction, how


def vehicle_frame(
    model: Any,
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
    for j, name in enumerate(model.input_names):
        columns[f"{name}[rpm]"] = rpm[:, j]
    return pd.DataFrame(columns)
