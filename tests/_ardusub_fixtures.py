"""ArduSub logs as they come off real vehicles, written by the tests with the features
of the public logs sampledyn is tried on (a bench DataFlash log of a 6-thruster
BlueROV2, a QGroundControl .tlog of a BlueROV2 Heavy, a BlueOS MCAP log):

* DataFlash: packed with struct after the published format (AP_Logger: a record is
  0xA3 0x95, the type, the fields little-endian; FMT records define the types), with
  PARM (FRAME_CONFIG, SERVOn_FUNCTION, MOT_n_DIRECTION), ARM/EV (a disarm), MODE,
  BAT, XKF4 (SS) records; an "old" variant without instance fields (NKF1 without C,
  IMU without I);
* .tlog: pymavlink's MAVLink 2 encoder, each packet after an 8-byte big-endian receive
  time (us) of the ground station (here deliberately off the vehicle's clock);
* BlueOS MCAP: mcap's writer, the same messages as JSON on ``mavlink/out`` in the
  mavlink crate's serde form (bitmasks as {"bits": n}, enums as {"type": NAME}).
"""

from __future__ import annotations

import json
import struct
from pathlib import Path
from typing import Any

import numpy as np

_STRUCT = {
    "Q": "Q",
    "B": "B",
    "b": "b",
    "c": "h",
    "C": "H",
    "e": "i",
    "f": "f",
    "H": "H",
    "I": "I",
    "n": "4s",
    "N": "16s",
    "Z": "64s",
}

XKF1 = ("QBccCfffffffccce", "TimeUS,C,Roll,Pitch,Yaw,VN,VE,VD,dPD,PN,PE,PD,GX,GY,GZ,OH")
NKF1_OLD = ("QccCfffffffccc", "TimeUS,Roll,Pitch,Yaw,VN,VE,VD,dPD,PN,PE,PD,GX,GY,GZ")
IMU = ("QBffffff", "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ")
IMU_OLD = ("Qffffff", "TimeUS,GyrX,GyrY,GyrZ,AccX,AccY,AccZ")
RCOU = ("Q" + "H" * 14, "TimeUS," + ",".join(f"C{i}" for i in range(1, 15)))
FORMATS_41 = {
    "PARM": ("QNf", "TimeUS,Name,Value"),
    "XKF1": XKF1,
    "XKF4": ("QBI", "TimeUS,C,SS"),
    "IMU": IMU,
    "RCOU": RCOU,
    "BAT": ("QBf", "TimeUS,Instance,Volt"),
    "ARM": ("QB", "TimeUS,ArmState"),
    "EV": ("QB", "TimeUS,Id"),
    "MODE": ("QBB", "TimeUS,Mode,ModeNum"),
}
FORMATS_OLD = {
    "PARM": FORMATS_41["PARM"],
    "NKF1": NKF1_OLD,
    "NKF4": ("QI", "TimeUS,SS"),
    "IMU": IMU_OLD,
    "RCOU": RCOU,
}

SS_NO_POSITION = 65703  # the bench log's XKF4.SS: attitude, velocities, vert. pos., const-pos mode
SS_GOOD = 0b111111  # attitude, both velocities, relative and absolute horizontal, vertical
PARAMS_VECTORED = {
    "FRAME_CONFIG": 1.0,
    **{f"SERVO{k}_FUNCTION": float(32 + k) for k in range(1, 7)},
    **{f"SERVO{k}_FUNCTION": 0.0 for k in range(7, 15)},
    **{f"MOT_{k}_DIRECTION": 1.0 for k in range(1, 7)},
    "MOT_1_DIRECTION": -1.0,
}


def dataflash(
    formats: dict[str, tuple[str, str]], records: list[tuple[str, tuple[Any, ...]]]
) -> bytes:
    """FMT records for ``formats`` (types 129, 130, ...) then ``records``."""
    ids = {name: 129 + k for k, name in enumerate(formats)}

    def pack(type_id: int, fmt: str, values: tuple[Any, ...]) -> bytes:
        return (
            b"\xa3\x95"
            + bytes([type_id])
            + struct.pack("<" + "".join(_STRUCT[c] for c in fmt), *values)
        )

    out = b""
    for name, (fmt, cols) in formats.items():
        length = 3 + struct.calcsize("<" + "".join(_STRUCT[c] for c in fmt))
        out += pack(128, "BBnNZ", (ids[name], length, name.encode(), fmt.encode(), cols.encode()))
    for name, values in records:
        out += pack(ids[name], formats[name][0], values)
    return out


class BenchRun:
    """A 6-thruster BlueROV2 log in the way of the public bench log: 60 state samples at
    10 Hz from TimeUS 30 s, armed for the first 40 (a disarm then), outputs at 20 Hz 13 ms
    off the state grid on SERVO1..6 (the others 0 us), a 17.4 V battery, no horizontal
    position fix, depth ``depth`` (m)."""

    N, ARMED = 60, 40
    T0 = 30_000_000

    def __init__(self, depth: float = 0.005, volts: float = 17.4) -> None:
        n = np.arange(self.N)
        self.t_us = self.T0 + 100_000 * n
        self.depth, self.volts = depth, volts
        self.att_cdeg = np.column_stack(
            [np.rint(300 * np.sin(0.3 * n)), np.rint(-200 * np.cos(0.2 * n)), 9000 + 50 * n]
        ).astype(int)
        self.v_ned = np.column_stack([0.1 * np.sin(0.1 * n), 0.05 + 0 * n, 0.01 * np.cos(0.2 * n)])
        self.gyro = np.column_stack([0.01 * np.sin(0.3 * n), -0.02 + 0 * n, 0.087 + 0 * n])
        self.t_cmd = self.T0 + 13_000 + 50_000 * np.arange(2 * self.N)
        k = np.arange(self.t_cmd.size)
        self.pwm = np.column_stack(
            [np.rint(1500 + (200 + 20 * j) * np.sin(0.05 * k + j)) for j in range(6)]
        ).astype(int)
        self.pwm[:5, 0] = 1508  # inside the T200 deadband, off neutral

    def records(self, old: bool = False) -> list[tuple[str, tuple[Any, ...]]]:
        recs: list[tuple[int, str, tuple[Any, ...]]] = [
            (0, "PARM", (1, name.encode(), value)) for name, value in PARAMS_VECTORED.items()
        ]
        if not old:
            recs.append((2, "MODE", (2, 19, 19)))
        for i, t in enumerate(self.t_us):
            t = int(t)
            r, p, y = (int(c) for c in self.att_cdeg[i])
            pos = (0.0, 0.0, self.depth)
            state = (r, p, y % 36000, *self.v_ned[i], 0.0, *pos, 0, 0, 0)
            if old:
                recs.append((t, "NKF1", (t, *state)))
                recs.append((t, "NKF4", (t, SS_NO_POSITION)))
                recs.append((t, "IMU", (t, *self.gyro[i], 0.0, 0.0, -9.8)))
            else:
                recs.append((t, "XKF1", (t, 0, *state, 0)))
                recs.append((t, "XKF4", (t, 0, SS_NO_POSITION)))
                recs.append((t, "IMU", (t, 0, *self.gyro[i], 0.0, 0.0, -9.8)))
                recs.append((t + 1, "BAT", (t + 1, 0, self.volts)))
        for k, t in enumerate(self.t_cmd):
            recs.append((int(t), "RCOU", (int(t), *self.pwm[k], *([0] * 8))))
        if not old:
            t_off = int(self.t_us[self.ARMED] - 50_000)
            recs += [(t_off, "ARM", (t_off, 0)), (t_off + 3, "EV", (t_off + 3, 11))]
        return [(name, values) for _, name, values in sorted(recs, key=lambda r: r[0])]

    def write(self, path: Path, old: bool = False) -> Path:
        path.write_bytes(dataflash(FORMATS_OLD if old else FORMATS_41, self.records(old)))
        return path

    def held_pwm(self, t_us: np.ndarray) -> np.ndarray:
        return self.pwm[np.searchsorted(self.t_cmd, t_us, side="right") - 1]


class TelemetryRun:
    """A BlueROV2 Heavy (FRAME_CONFIG 2, MOT_1_DIRECTION -1) as a ground station logs
    it: LOCAL_POSITION_NED 5 Hz, ATTITUDE 20 Hz, SERVO_OUTPUT_RAW 2 Hz, HEARTBEAT 1 Hz
    (armed from 2 s to 8 s), SYS_STATUS 16.0 V, EKF_STATUS_REPORT all valid, PARAM_VALUE;
    a GPS_INPUT source (1/220) and the ground station (255/190) as well. The boot
    clock starts at ``boot_ms`` (near 2^32 to make it wrap)."""

    SECONDS = 10.0

    def __init__(self, boot_ms: int = 600_000) -> None:
        self.boot_ms = boot_ms
        self.params = {
            "FRAME_CONFIG": 2.0,
            **{f"SERVO{k}_FUNCTION": float(32 + k) for k in range(1, 9)},
            **{f"MOT_{k}_DIRECTION": 1.0 for k in range(2, 9)},
            "MOT_1_DIRECTION": -1.0,
        }

    def pwm(self, t: float) -> list[int]:
        return [int(round(1500 + (150 + 10 * j) * np.sin(0.7 * t + j))) for j in range(8)]

    def messages(self) -> list[tuple[float, int, int, str, dict[str, Any]]]:
        """(t s since start, sysid, compid, type, fields), in send order."""
        out: list[tuple[float, int, int, str, dict[str, Any]]] = []
        for name, value in self.params.items():
            out.append(
                (
                    0.0,
                    1,
                    1,
                    "PARAM_VALUE",
                    {
                        "param_id": name,
                        "param_value": value,
                        "param_type": 9,
                        "param_count": len(self.params),
                        "param_index": 0,
                    },
                )
            )
        for k in range(int(self.SECONDS * 20)):
            t = k / 20
            ms = (self.boot_ms + 50 * k) % 2**32
            out.append(
                (
                    t,
                    1,
                    1,
                    "ATTITUDE",
                    {
                        "time_boot_ms": ms,
                        "roll": 0.01 * np.sin(t),
                        "pitch": 0.02,
                        "yaw": 0.3 + 0.05 * t,
                        "rollspeed": 0.01 * np.cos(t),
                        "pitchspeed": 0.0,
                        "yawspeed": 0.05,
                    },
                )
            )
            if k % 4 == 1:
                out.append(
                    (
                        t,
                        1,
                        1,
                        "LOCAL_POSITION_NED",
                        {
                            "time_boot_ms": (ms + 3) % 2**32,
                            "x": 0.1 * t,
                            "y": 0.0,
                            "z": 1.5,
                            "vx": 0.1,
                            "vy": 0.0,
                            "vz": 0.0,
                        },
                    )
                )
            if k % 10 == 7:
                us = ((ms + 2) * 1000) % 2**32
                out.append(
                    (
                        t,
                        1,
                        1,
                        "SERVO_OUTPUT_RAW",
                        {
                            "time_usec": us,
                            "port": 0,
                            **{f"servo{j + 1}_raw": p for j, p in enumerate(self.pwm(t))},
                        },
                    )
                )
            if k % 20 == 0:
                armed = 2.0 <= t < 8.0
                out.append(
                    (
                        t,
                        1,
                        1,
                        "HEARTBEAT",
                        {
                            "type": 12,
                            "autopilot": 3,
                            "base_mode": 81 | (128 if armed else 0),
                            "custom_mode": 19,
                            "system_status": 4,
                        },
                    )
                )
                out.append(
                    (
                        t,
                        255,
                        190,
                        "HEARTBEAT",
                        {
                            "type": 6,
                            "autopilot": 8,
                            "base_mode": 192,
                            "custom_mode": 0,
                            "system_status": 4,
                        },
                    )
                )
                out.append((t, 1, 1, "SYS_STATUS", {"voltage_battery": 16000}))
                out.append((t, 1, 1, "EKF_STATUS_REPORT", {"flags": 831}))
            if k % 5 == 0:
                out.append((t, 1, 220, "GPS_INPUT", {"time_usec": 0}))
        return out

    def write_tlog(self, path: Path) -> Path:
        from pymavlink.dialects.v20 import ardupilotmega as mav

        class Sink:
            def write(self, data: bytes) -> None:  # pragma: no cover - unused
                pass

        links: dict[tuple[int, int], Any] = {}
        blob = b""
        for t, sysid, compid, kind, f in self.messages():
            link = links.setdefault(
                (sysid, compid), mav.MAVLink(Sink(), srcSystem=sysid, srcComponent=compid)
            )
            msg = _encode(mav, link, kind, f)
            # the ground station's receive time: its own clock, late by a varying delay
            recv_us = 1_700_000_000_000_000 + int(t * 1e6) + 40_000 + (int(t * 997) % 7) * 9_000
            blob += struct.pack(">Q", recv_us) + msg.pack(link)
        path.write_bytes(blob)
        return path

    def write_blueos(self, path: Path) -> Path:
        from mcap.writer import Writer

        with path.open("wb") as fh:
            w = Writer(fh)
            w.start()
            ch = w.register_channel(topic="mavlink/out", message_encoding="json", schema_id=0)
            for seq, (t, sysid, compid, kind, f) in enumerate(self.messages()):
                data = {
                    "header": {"system_id": sysid, "component_id": compid, "sequence": seq % 256},
                    "message": {"type": kind, **_serde(kind, f)},
                }
                ns = 1_700_000_000 * 10**9 + int(t * 1e9)
                w.add_message(ch, log_time=ns, data=json.dumps(data).encode(), publish_time=ns)
            w.finish()
        return path


def _encode(mav: Any, link: Any, kind: str, f: dict[str, Any]) -> Any:
    if kind == "PARAM_VALUE":
        return link.param_value_encode(
            f["param_id"].encode(), f["param_value"], 9, f["param_count"], 0
        )
    if kind == "SYS_STATUS":
        return link.sys_status_encode(0, 0, 0, 0, f["voltage_battery"], -1, -1, 0, 0, 0, 0, 0, 0)
    if kind == "EKF_STATUS_REPORT":
        return link.ekf_status_report_encode(f["flags"], 0, 0, 0, 0, 0)
    if kind == "GPS_INPUT":
        return link.gps_input_encode(0, 0, 0, 0, 0, 3, 0, 0, 0, 1, 1, 0, 0, 0, 0, 0, 0, 8)
    return getattr(link, kind.lower() + "_encode")(**f)


def _serde(kind: str, f: dict[str, Any]) -> dict[str, Any]:
    """The mavlink crate's JSON of a message's fields."""
    out = dict(f)
    if kind == "HEARTBEAT":
        out = {
            "custom_mode": f["custom_mode"],
            "mavtype": {"type": "MAV_TYPE_SUBMARINE"},
            "autopilot": {
                "type": "MAV_AUTOPILOT_ARDUPILOTMEGA"
                if f["autopilot"] == 3
                else "MAV_AUTOPILOT_INVALID"
            },
            "base_mode": {"bits": f["base_mode"]},
            "system_status": {"type": "MAV_STATE_ACTIVE"},
            "mavlink_version": 3,
        }
    elif kind == "EKF_STATUS_REPORT":
        out = {"flags": {"bits": f["flags"]}}
    elif kind == "PARAM_VALUE":
        out = {**f, "param_id": list(f["param_id"].ljust(16, "\x00"))}
    return out
