"""ArduSub DataFlash logs (``.bin``, through ``pymavlink``; ``pip install
'sampledyn[ardusub]'``).

A mapping file (TOML) names the messages; every key has a default, and a log
given without a mapping file is read with these (a note says so)::

    [ardusub]
    states = "XKF1"   # EKF3 state (NKF1 for EKF2): attitude, NED velocity and position
    core = 0          # EKF core (field C; logs without it: one core, read as 0)
    rates = "IMU"     # body rates GyrX, GyrY, GyrZ
    imu = 0           # IMU instance (field I; logs without it: read as 0)
    outputs = "RCOU"  # servo outputs C1..C14 (PWM, us)
    battery = "BAT"   # battery voltage Volt (V), instance 0
    status = "XKF4"   # estimator status SS (NKF4 for EKF2), same core
    armed_only = true # use the armed samples only (ARM / EV records)
    estimator = "check"  # leave states without a valid estimate out of the errors

    [ardusub.thrusters]
    unit = "pwm"          # through the T200 table
    voltage = "logged"    # the BAT voltage at each sample (or a supply in V)
    # frame, channels and direction come from the log's FRAME_CONFIG, SERVOn_FUNCTION
    # and MOT_n_DIRECTION parameters; `frame = "vectored"`, `channels = [...]` and
    # `direction = [...]` override them.

Frames and units as ArduPilot logs them (ArduPilot log message documentation,
``LogStructure.h`` of AP_NavEKF3 and AP_InertialSensor): XKF1 Roll, Pitch, Yaw in deg
(ZYX Euler angles, yaw 0..360 deg; unwrapped on reading), VN, VE, VD in m/s in the NED
frame, PN, PE, PD in m NED from the EKF origin; IMU GyrX/Y/Z in rad/s in the body FRD
frame (raw gyro, the EKF's bias estimate not removed). Converted: eta = (PN, PE, PD,
Roll, Pitch, Yaw) in m and rad; the body velocity (u, v, w) = R(phi, theta, psi)^T
(VN, VE, VD) (Fossen 2011, eq. (2.19)); (p, q, r) = the IMU sample nearest each state
stamp. Time: each message's TimeUS (us since boot, an integer counter). Sampling rule:
:mod:`._streams`; arming, estimator, depth and thrusters: :mod:`._autopilot`. Events
(EV) 10 and 11 are ARMED and DISARMED; ARM records ArmState.
"""

from __future__ import annotations

import difflib
import re
import struct
from pathlib import Path
from typing import Any

import numpy as np

from ..exceptions import LogFormatError
from ..models import Model
from ._autopilot import AUTOPILOT_KEYS, AutopilotStreams, autopilot_log, check_thrusters
from ._frames import rotation_zyx
from ._read import LogData
from ._streams import default_mapping_note, mapping_section, nearest

__all__ = ["read_dataflash"]

_KEYS = ("states", "core", "rates", "imu", "outputs", "battery", "status", *AUTOPILOT_KEYS)
_STATE_FIELDS = ("Roll", "Pitch", "Yaw", "VN", "VE", "VD", "PN", "PE", "PD")
_RATE_FIELDS = ("GyrX", "GyrY", "GyrZ")
# instance field of each message type that has one (older logs lack it: instance 0)
_INSTANCE = {"XKF1": "C", "NKF1": "C", "XKF4": "C", "NKF4": "C", "IMU": "I", "BAT": "Instance"}
_ARMED_EVENTS = {10: 1, 11: 0}  # LogEvent ARMED, DISARMED


# DataFlash field type -> bytes (pymavlink's DFReader.FORMAT_TO_STRUCT).
_FIELD_BYTES = {"a": 64, "b": 1, "B": 1, "g": 2, "h": 2, "H": 2, "i": 4, "I": 4, "f": 4,
                "n": 4, "N": 16, "Z": 64, "c": 2, "C": 2, "e": 4, "E": 4, "L": 4, "d": 8,
                "M": 1, "q": 8, "Q": 8}  # fmt: skip
_FMT_HEAD = b"\xa3\x95\x80"  # a record's two header bytes and the FMT type (128)
_FMT_LENGTH = 89  # 3 header bytes + Type, Length (uint8), Name[4], Format[16], Columns[64]
_NAME = re.compile(rb"[A-Z0-9_]{1,4}\x00*")


def _check_formats(path: Path, src: str) -> None:
    """Refuse a DataFlash log whose FMT records declare a message shorter than its
    header and fields, before pymavlink reads it: pymavlink advances by the declared
    length, so a length of 0 never ends. Every FMT record is found by its header
    bytes (a C-speed search of the mapped file); one counts if its name and format
    read as a FMT's (upper-case name, known field types), so payload bytes that
    happen to look like a header do not."""
    import mmap

    with path.open("rb") as fh:
        if fh.seek(0, 2) < len(_FMT_HEAD):
            return
        with mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as data:
            at = data.find(_FMT_HEAD)
            while 0 <= at and at + _FMT_LENGTH <= len(data):
                rec = data[at : at + _FMT_LENGTH]
                kind, length, name = rec[3], rec[4], rec[5:9]
                fields = rec[9:25].rstrip(b"\x00")
                if _NAME.fullmatch(name) and fields and all(chr(c) in _FIELD_BYTES for c in fields):
                    need = 3 + sum(_FIELD_BYTES[chr(c)] for c in fields)
                    if length < need or (kind == 0x80 and length != _FMT_LENGTH):
                        label = name.rstrip(b"\x00").decode()
                        raise LogFormatError(
                            "data",
                            f"{src}: the FMT record at byte {at} declares message {label} "
                            f"(type {kind}) {length} bytes long, but its header and fields "
                            f"({fields.decode()}) take {need}: a damaged or forged DataFlash "
                            "log (a reader would loop on it); not read.",
                        )
                at = data.find(_FMT_HEAD, at + 1)


def _open(path: Path, src: str) -> Any:
    _check_formats(path, src)
    try:
        from pymavlink import DFReader
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise ImportError(
            "reading DataFlash logs needs the `pymavlink` package: "
            "pip install 'sampledyn[ardusub]'."
        ) from exc
    try:
        return DFReader.DFReader_binary(str(path), zero_time_base=False)
    except (struct.error, ValueError, IndexError, KeyError) as exc:
        raise LogFormatError("data", f"{src}: not a readable DataFlash log: {exc}") from exc


class _Messages:
    """The records of the wanted types: per type (TimeUS, instance, fields (n, k))."""

    def __init__(self, path: Path, wanted: dict[str, tuple[str, ...]], src: str) -> None:
        self.src = src
        self.wanted = wanted
        self.rows: dict[str, list[tuple[Any, ...]]] = {t: [] for t in wanted}
        self.params: dict[str, float] = {}
        self.no_instance: set[str] = set()
        log = _open(path, src)
        try:
            self._read(log)
        except (struct.error, ValueError, IndexError, KeyError) as exc:
            raise LogFormatError("data", f"{src}: not a readable DataFlash log: {exc}") from exc
        finally:
            log.close()
        self.have = sorted(log.name_to_id) if hasattr(log, "name_to_id") else []

    def _read(self, log: Any) -> None:
        types = [*self.wanted, "PARM"]
        while (m := log.recv_match(type=types)) is not None:
            kind = m.get_type()
            if kind == "PARM":
                self.params[str(m.Name)] = float(m.Value)
                continue
            self.rows[kind].append(self._record(m, kind))

    def _record(self, m: Any, kind: str) -> tuple[Any, ...]:
        fields = self.wanted[kind]
        names = m.get_fieldnames()
        missing = [f for f in ("TimeUS", *fields) if f not in names]
        if missing:
            row = len(self.rows[kind])
            when = f" (TimeUS {int(m.TimeUS)} us)" if "TimeUS" in names else ""
            raise LogFormatError(
                "mapping",
                f"{self.src}: {kind} record {row + 1}{when} has no field {missing[0]!r}, which "
                f"the mapping's message needs; its fields are {', '.join(names)}. Name another "
                "message in the mapping file ([ardusub] states, rates, outputs, battery, status).",
            )
        inst_field = _INSTANCE.get(kind)
        if inst_field is not None and inst_field not in names:
            self.no_instance.add(f"{kind}.{inst_field}")
            inst = 0
        else:
            inst = int(getattr(m, inst_field)) if inst_field else 0
        return (int(m.TimeUS), inst, *(float(getattr(m, f)) for f in fields))

    def get(self, kind: str, instance: int | None = None, required: bool = True) -> Any:
        """(TimeUS, fields) of ``kind`` (of ``instance``), or None where optional and absent."""
        got = self.rows.get(kind, [])
        if not got:
            if not required:
                return None
            if kind in self.have:
                raise LogFormatError(
                    "data", f"{self.src}: the log defines {kind!r} but holds no record of it."
                )
            close = difflib.get_close_matches(kind, self.have, n=1)
            raise LogFormatError(
                "mapping",
                f"{self.src}: the log has no {kind!r} message"
                + (f" (did you mean {close[0]!r}?)" if close else "")
                + (f"; it has {', '.join(self.have)}." if self.have else "."),
            )
        a = np.array(got, dtype=float)
        t, inst = a[:, 0].astype(np.int64), a[:, 1].astype(np.int64)
        if instance is not None and kind in _INSTANCE:
            keep = inst == instance
            if not keep.any():
                raise LogFormatError(
                    "mapping",
                    f"{self.src}: no {kind} record of instance {instance} (field "
                    f"{_INSTANCE[kind]}); the log has instances {sorted(set(inst.tolist()))}.",
                )
            t, a = t[keep], a[keep]
        return t, a[:, 2:]


def _events(msgs: _Messages) -> tuple[Any, bool | None]:
    """Arming records: ARM (ArmState) and EV (ARMED / DISARMED), in time order."""
    got = []
    arm = msgs.get("ARM", required=False)
    if arm is not None:
        got += [(int(t), int(v[0] != 0)) for t, v in zip(*arm, strict=True)]
    ev = msgs.get("EV", required=False)
    if ev is not None:
        got += [
            (int(t), _ARMED_EVENTS[int(v[0])])
            for t, v in zip(*ev, strict=True)
            if int(v[0]) in _ARMED_EVENTS
        ]
    if not got:
        return None, None
    got.sort()
    a = np.array(got, dtype=np.int64)
    # the log starts before its first arming record: then the vehicle was in the other state
    return (a[:, 0], a[:, 1]), not bool(a[0, 1])


def read_dataflash(path: Path, model: Model, *, mapping: Any = None, **options: Any) -> LogData:
    """Read an ArduSub DataFlash log of a vehicle through a mapping file (module
    docstring); ``options`` as :func:`read_log`. Returns :class:`LogData`; the notes
    say where each quantity came from, what was left out and why."""
    path = Path(path)
    src = path.name
    cfg, thr = mapping_section(model, mapping, "ardusub", _KEYS, src, "a DataFlash log")
    check_thrusters(thr, model.nu)
    states = str(cfg.get("states", "XKF1"))
    rates = str(cfg.get("rates", "IMU"))
    outputs = str(cfg.get("outputs", "RCOU"))
    battery = str(cfg.get("battery", "BAT"))
    status = str(cfg.get("status", "XKF4" if states == "XKF1" else "NKF4"))
    core, imu = int(cfg.get("core", 0)), int(cfg.get("imu", 0))
    msgs = _Messages(
        path,
        {
            states: _STATE_FIELDS,
            rates: _RATE_FIELDS,
            outputs: tuple(f"C{c}" for c in range(1, 15)),
            battery: ("Volt",),
            status: ("SS",),
            "ARM": ("ArmState",),
            "EV": ("Id",),
            "MODE": ("Mode",),
        },
        src,
    )
    t_s, x = msgs.get(states, core if states in _INSTANCE else None)
    att = np.radians(x[:, :3])
    R = rotation_zyx(att[:, 0], att[:, 1], att[:, 2])
    v_body = np.einsum("nji,nj->ni", R, x[:, 3:6])  # R^T v_NED
    t_r, g = msgs.get(rates, imu if rates in _INSTANCE else None)
    pqr, offset = nearest(t_s, t_r, g)
    armed, before = _events(msgs)
    bat = msgs.get(battery, 0, required=False)
    sts = msgs.get(status, core, required=False)
    mode = msgs.get("MODE", required=False)
    notes = [
        f"states from {states} (EKF core {core}) at its TimeUS: attitude (deg, ZYX Euler), "
        "NED position and velocity; body velocity = R^T v_NED",
        f"rates from {rates} (instance {imu}) GyrX/GyrY/GyrZ (rad/s, FRD), the sample "
        f"nearest each state stamp (at most {offset / 1e6:.3g} s away)",
    ]
    if msgs.no_instance:
        notes.append(
            f"no instance field {', '.join(sorted(msgs.no_instance))} (an older log): read as "
            "instance 0"
        )
    streams = AutopilotStreams(
        src=src,
        kind="ArduSub DataFlash log",
        t_state=t_s,
        eta=np.column_stack([x[:, 6:9], att]),
        v=np.column_stack([v_body, pqr]),
        outputs=msgs.get(outputs),
        outputs_name=outputs,
        params=msgs.params,
        battery=None if bat is None else (bat[0], bat[1][:, 0]),
        battery_name=f"{battery}.Volt",
        armed=armed,
        armed_before=before,
        armed_name="ARM / EV records",
        modes=None if mode is None else (mode[0], mode[1][:, 0]),
        status=None if sts is None else (sts[0], sts[1][:, 0]),
        status_name=f"{status}.SS",
        notes=notes,
    )
    defaulted = default_mapping_note(mapping, "ardusub")
    return autopilot_log(streams, model, cfg, thr, defaulted, **options)
