"""MAVLink logs of an ArduSub vehicle: ground-station telemetry (``.tlog``, through
``pymavlink``; ``pip install 'sampledyn[ardusub]'``) and BlueOS MCAP logs (the
MAVLink messages as JSON on the ``mavlink/out`` channel, through ``mcap``;
``pip install 'sampledyn[blueos]'``).

A mapping file (TOML) names the messages; every key has a default::

    [mavlink]
    states = "LOCAL_POSITION_NED"  # x, y, z (m, NED), vx, vy, vz (m/s, NED)
    attitude = "ATTITUDE"          # roll, pitch, yaw (rad), rollspeed.. (rad/s, body)
    outputs = "SERVO_OUTPUT_RAW"   # servo1_raw..servo16_raw (us)
    battery = "SYS_STATUS"         # voltage_battery (mV); or BATTERY_STATUS voltages[0]
    status = "EKF_STATUS_REPORT"   # flags (EKF_STATUS_FLAGS)
    autopilot = [1, 1]             # system and component id (default: the autopilot's)
    armed_only = true              # HEARTBEAT base_mode bit 128 (MAV_MODE_FLAG_SAFETY_ARMED)
    estimator = "check"

    [mavlink.thrusters]
    unit = "pwm"
    voltage = "logged"

**Time**: the vehicle's own clock, never the ground station's receive stamp:
``time_boot_ms`` (ms since boot, uint32; a wrap past 2^32 ms is unwrapped) and
``time_usec`` of SERVO_OUTPUT_RAW (us since boot, uint32: it wraps every 71.6 min; its
wrap count is the one that puts it nearest the last ``time_boot_ms`` received). A
message without a time field (SYS_STATUS, EKF_STATUS_REPORT, HEARTBEAT, PARAM_VALUE)
takes the ``time_boot_ms`` of the last autopilot message received before it.
**Components**: only the autopilot's messages are used (the component whose
HEARTBEAT names an autopilot, MAV_AUTOPILOT != 8 INVALID, unless the mapping gives
``autopilot``); the others are named in a note. States are taken at the state
message's stamps, the attitude from the ATTITUDE message nearest in time, the outputs
held (:mod:`._streams`); then :mod:`._autopilot`.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from .._files import parse_json
from ..exceptions import LogFormatError
from ..models import Model
from ._autopilot import AUTOPILOT_KEYS, AutopilotStreams, autopilot_log, check_thrusters
from ._frames import rotation_zyx
from ._read import LogData
from ._streams import default_mapping_note, mapping_section, nearest

__all__ = ["read_blueos", "read_tlog"]

_KEYS = ("states", "attitude", "outputs", "battery", "status", "autopilot", *AUTOPILOT_KEYS)
_WRAP = 2**32
_ARMED_FLAG = 128  # MAV_MODE_FLAG_SAFETY_ARMED
_INVALID_AUTOPILOT = (8, "MAV_AUTOPILOT_INVALID")
_UNKNOWN_MV = 65535  # UINT16_MAX: voltage not known
_EXTENSIONS = {f"servo{k}_raw" for k in range(9, 17)}

Record = tuple[str, int, int, dict[str, Any]]


def _tlog_records(path: Path, src: str) -> Iterator[Record]:
    try:
        from pymavlink import mavutil
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise ImportError(
            "reading .tlog files needs the `pymavlink` package: pip install 'sampledyn[ardusub]'."
        ) from exc
    conn = mavutil.mavlink_connection(str(path), dialect="ardupilotmega", robust_parsing=True)
    try:
        while (m := conn.recv_match()) is not None:
            kind = m.get_type()
            if kind == "BAD_DATA":
                continue
            yield kind, int(m.get_srcSystem()), int(m.get_srcComponent()), m.to_dict()
    finally:
        conn.close()


def _json_value(value: Any) -> Any:
    """MAVLink JSON (the mavlink crate's serde form) to plain values: bitmasks are
    {"bits": n}, enums {"type": "NAME"}, char arrays lists of characters."""
    if isinstance(value, dict):
        if "bits" in value:
            return int(value["bits"])
        if "type" in value:
            return value["type"]
    if isinstance(value, list) and value and all(isinstance(c, str) for c in value):
        return "".join(value)
    return value


def _blueos_records(path: Path, src: str) -> Iterator[Record]:
    try:
        from mcap.reader import make_reader
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise ImportError(
            "reading BlueOS MCAP logs needs the `mcap` package: pip install 'sampledyn[blueos]'."
        ) from exc
    with path.open("rb") as fh:
        for _schema, _channel, message in make_reader(fh).iter_messages(topics=["mavlink/out"]):
            try:
                data = parse_json(message.data, f"{src}: mavlink/out")  # nesting bounded
                header, msg = data["header"], data["message"]
                kind = str(msg["type"])
                sysid, compid = int(header["system_id"]), int(header["component_id"])
            except (ValueError, KeyError, TypeError) as exc:
                raise LogFormatError(
                    "data",
                    f"{src}: a mavlink/out message (log time {message.log_time} ns) is not "
                    f"MAVLink JSON with header and message: {exc!r}",
                ) from None
            yield kind, sysid, compid, {k: _json_value(v) for k, v in msg.items() if k != "type"}


def _autopilot_id(records: list[Record], cfg: dict[str, Any], src: str) -> tuple[int, int]:
    if "autopilot" in cfg:
        given = cfg["autopilot"]
        if not (isinstance(given, list) and len(given) == 2):
            raise LogFormatError(
                "mapping",
                "mapping file: [mavlink] autopilot must be [system id, component id], got "
                f"{given!r}.",
            )
        return int(given[0]), int(given[1])
    for kind, sysid, compid, f in records:
        if kind == "HEARTBEAT" and f.get("autopilot") not in _INVALID_AUTOPILOT:
            return sysid, compid
    raise LogFormatError(
        "mapping",
        f"{src}: no HEARTBEAT of an autopilot; name its component in the mapping file "
        "(autopilot = [1, 1]).",
    )


class _Clock:
    """The autopilot's boot clock in us from time_boot_ms / time_usec, in receive order."""

    def __init__(self) -> None:
        self.raw_ms: int | None = None
        self.wraps = 0
        self.now_us: int | None = None
        self.wrapped = False

    def ms(self, value: Any) -> int:
        raw = int(value)
        if self.raw_ms is not None and raw < self.raw_ms - _WRAP // 2:
            self.wraps += 1
            self.wrapped = True
        self.raw_ms = raw
        self.now_us = (raw + self.wraps * _WRAP) * 1000
        return self.now_us

    def us(self, value: Any) -> int:
        raw = int(value)
        ref = self.now_us if self.now_us is not None else raw
        k = round((ref - raw) / _WRAP)
        return raw + k * _WRAP


def _collect(records: Iterable[Record], names: dict[str, str], who: tuple[int, int]) -> Any:
    """Per wanted message: list of (t us, fields); parameters; other components."""
    clock = _Clock()
    got: dict[str, list[tuple[int, dict[str, Any]]]] = {
        k: [] for k in (*names.values(), "HEARTBEAT")
    }
    params: dict[str, float] = {}
    others: Counter[tuple[int, int, str]] = Counter()
    for kind, sysid, compid, f in records:
        if (sysid, compid) != who:
            others[(sysid, compid, kind)] += 1
            continue
        t: int | None
        if "time_boot_ms" in f:
            t = clock.ms(f["time_boot_ms"])
        elif "time_usec" in f and kind == names["outputs"]:
            t = clock.us(f["time_usec"])
        else:
            t = clock.now_us
        if kind == "PARAM_VALUE":
            params[str(f["param_id"]).rstrip("\x00")] = float(f["param_value"])
        elif kind in got and t is not None:
            got[kind].append((t, f))
    return got, params, others, clock.wrapped


def _others_note(others: Counter[tuple[int, int, str]]) -> list[str]:
    if not others:
        return []
    by: dict[tuple[int, int], Counter[str]] = {}
    for (sysid, compid, kind), n in others.items():
        by.setdefault((sysid, compid), Counter())[kind] += n
    parts = [
        f"{s}/{c} ({', '.join(f'{k} {n}' for k, n in kinds.most_common(3))}"
        + (", ..." if len(kinds) > 3 else "")
        + ")"
        for (s, c), kinds in sorted(by.items())
    ]
    return [f"messages of other components left out: {'; '.join(parts)}"]


def _array(
    rows: list[tuple[int, dict[str, Any]]], fields: tuple[str, ...], kind: str, src: str
) -> tuple[np.ndarray, np.ndarray]:
    if not rows:
        raise LogFormatError("mapping", f"{src}: the log holds no {kind} message of the autopilot.")
    # MAVLink 2 extension fields (servo9_raw.. of SERVO_OUTPUT_RAW) may be absent: 0
    missing = [f for f in fields if f not in rows[0][1] and f not in _EXTENSIONS]
    if missing:
        raise LogFormatError(
            "mapping",
            f"{src}: {kind} messages have no field {missing[0]!r}; they have "
            f"{', '.join(rows[0][1])}.",
        )
    t = np.array([r[0] for r in rows], dtype=np.int64)
    return t, np.array([[float(r[1].get(k, 0)) for k in fields] for r in rows])


def _unique(t: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """Messages in time order, one per stamp (a stream requested twice repeats)."""
    order = np.argsort(t, kind="stable")
    t, values = t[order], values[order]
    keep = np.concatenate([[True], np.diff(t) > 0])
    return t[keep], values[keep], int((~keep).sum())


def _battery(
    rows: list[tuple[int, dict[str, Any]]], kind: str
) -> tuple[np.ndarray, np.ndarray] | None:
    got = []
    for t, f in rows:
        mv = f.get("voltage_battery") if kind == "SYS_STATUS" else (f.get("voltages") or [None])[0]
        if mv is not None and int(mv) != _UNKNOWN_MV and int(mv) > 0:
            got.append((t, int(mv) / 1000.0))
    if not got:
        return None
    a = np.array(got)
    return a[:, 0].astype(np.int64), a[:, 1]


def _streams(
    records: Iterable[Record], model: Model, cfg: dict[str, Any], src: str, kind: str
) -> AutopilotStreams:
    records = list(records)
    who = _autopilot_id(records, cfg, src)
    names = {
        "states": str(cfg.get("states", "LOCAL_POSITION_NED")),
        "attitude": str(cfg.get("attitude", "ATTITUDE")),
        "outputs": str(cfg.get("outputs", "SERVO_OUTPUT_RAW")),
        "battery": str(cfg.get("battery", "SYS_STATUS")),
        "status": str(cfg.get("status", "EKF_STATUS_REPORT")),
    }
    got, params, others, wrapped = _collect(records, names, who)
    t_s, pos = _array(got[names["states"]], ("x", "y", "z", "vx", "vy", "vz"), names["states"], src)
    t_s, pos, repeated = _unique(t_s, pos)
    t_a, att = _array(
        got[names["attitude"]],
        ("roll", "pitch", "yaw", "rollspeed", "pitchspeed", "yawspeed"),
        names["attitude"],
        src,
    )
    t_a, att, _ = _unique(t_a, att)
    a, offset = nearest(t_s, t_a, att)
    R = rotation_zyx(a[:, 0], a[:, 1], a[:, 2])
    v_body = np.einsum("nji,nj->ni", R, pos[:, 3:6])
    t_o, pwm = _array(
        got[names["outputs"]], tuple(f"servo{k}_raw" for k in range(1, 17)), names["outputs"], src
    )
    t_o, pwm, _ = _unique(t_o, pwm)
    beats = got["HEARTBEAT"]
    armed = modes = None
    if beats:
        t_h = np.array([b[0] for b in beats], dtype=np.int64)
        armed = (
            t_h,
            np.array([int(b[1]["base_mode"]) & _ARMED_FLAG != 0 for b in beats], dtype=np.int64),
        )
        modes = (t_h, np.array([int(b[1]["custom_mode"]) for b in beats], dtype=np.int64))
    status = None
    if got[names["status"]]:
        t_f = np.array([r[0] for r in got[names["status"]]], dtype=np.int64)
        status = (t_f, np.array([int(r[1]["flags"]) for r in got[names["status"]]], dtype=np.int64))
    notes = [
        f"autopilot: system {who[0]}, component {who[1]}; time: its time_boot_ms / time_usec "
        "(boot clock), not the ground station's receive stamps"
        + ("; a 32-bit clock wrap unwrapped" if wrapped else ""),
        *_others_note(others),
        f"states from {names['states']} at its time_boot_ms: NED position and velocity; "
        f"attitude and body rates from {names['attitude']}, the message nearest each state "
        f"stamp (at most {offset / 1e6:.3g} s away); body velocity = R^T v_NED",
    ]
    if repeated:
        notes.append(f"{repeated} {names['states']} messages repeating a stamp dropped")
    return AutopilotStreams(
        src=src,
        kind=kind,
        t_state=t_s,
        eta=np.column_stack([pos[:, :3], a[:, :3]]),
        v=np.column_stack([v_body, a[:, 3:6]]),
        outputs=(t_o, pwm),
        outputs_name=names["outputs"],
        params=params,
        battery=_battery(got[names["battery"]], names["battery"]),
        battery_name=f"{names['battery']} voltage",
        armed=armed,
        armed_name="HEARTBEAT base_mode",
        modes=modes,
        status=status,
        status_name=f"{names['status']} flags",
        notes=notes,
    )


def read_tlog(path: Path, model: Model, *, mapping: Any = None, **options: Any) -> LogData:
    """Read a MAVLink telemetry log (``.tlog``) of an ArduSub vehicle through a mapping
    file (module docstring); ``options`` as :func:`read_log`."""
    path = Path(path)
    cfg, thr = mapping_section(model, mapping, "mavlink", _KEYS, path.name, "a .tlog")
    check_thrusters(thr, model.nu)
    s = _streams(
        _tlog_records(path, path.name), model, cfg, path.name, "MAVLink telemetry log (.tlog)"
    )
    defaulted = default_mapping_note(mapping, "mavlink")
    return autopilot_log(s, model, cfg, thr, defaulted, **options)


def read_blueos(path: Path, model: Model, *, mapping: Any = None, **options: Any) -> LogData:
    """Read a BlueOS MCAP log (MAVLink JSON on ``mavlink/out``) of an ArduSub vehicle
    through a mapping file (module docstring); ``options`` as :func:`read_log`."""
    path = Path(path)
    cfg, thr = mapping_section(model, mapping, "mavlink", _KEYS, path.name, "a BlueOS log")
    check_thrusters(thr, model.nu)
    s = _streams(
        _blueos_records(path, path.name), model, cfg, path.name, "BlueOS MCAP log (mavlink/out)"
    )
    defaulted = default_mapping_note(mapping, "mavlink")
    return autopilot_log(s, model, cfg, thr, defaulted, **options)
