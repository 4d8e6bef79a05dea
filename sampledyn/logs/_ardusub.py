"""ArduSub DataFlash logs (``.bin``, through ``pymavlink``; ``pip install
'sampledyn[ardusub]'``).

A mapping file (TOML) names the messages and the thruster outputs::

    [ardusub]
    states = "XKF1"   # EKF3 state (NKF1 for EKF2): attitude, NED velocity and position
    core = 0          # EKF core (field C)
    rates = "IMU"     # body rates GyrX, GyrY, GyrZ
    imu = 0           # IMU instance (field I)
    outputs = "RCOU"  # servo outputs C1..C14 (PWM, us)

    [ardusub.thrusters]
    channels = [1, 2, 3, 4, 5, 6, 7, 8]  # RCOU channel of each model input (n1..n8)
    unit = "pwm"                          # through the T200 table (or rpm, rps, rad/s)
    direction = [-1, -1, -1, -1, -1, -1, -1, -1]  # sign per model input
    voltage = 16                          # T200 table supply (V)

Frames and units as ArduPilot logs them (ArduPilot log message documentation,
``LogStructure.h`` of AP_NavEKF3 and AP_InertialSensor): XKF1 Roll, Pitch, Yaw in deg
(ZYX Euler angles, yaw 0..360 deg; unwrapped on reading), VN, VE, VD in m/s in the NED
frame, PN, PE, PD in m NED from the EKF origin; IMU GyrX/Y/Z in rad/s in the body FRD
frame (raw gyro, the EKF's bias estimate not removed). Converted: eta = (PN, PE, PD,
Roll, Pitch, Yaw) in m and rad; the body velocity (u, v, w) = R(phi, theta, psi)^T
(VN, VE, VD) (Fossen 2011, eq. (2.19)); (p, q, r) = the IMU sample nearest each state
stamp. Time: each message's TimeUS (us since boot, an integer counter). Sampling rule:
:mod:`._streams`.
"""

from __future__ import annotations

import difflib
import struct
from pathlib import Path
from typing import Any

import numpy as np

from ._frames import rotation_zyx
from ._read import LogData, log_from_frame
from ._streams import (
    SAMPLING_RULE,
    drop_before_first_command,
    hold_last,
    mapping_section,
    nearest,
    thruster_options,
    thruster_rpm,
    vehicle_frame,
)
from ._units import LogFormatError

__all__ = ["read_dataflash"]

_KEYS = ("states", "core", "rates", "imu", "outputs", "thrusters")
_STATE_FIELDS = ("Roll", "Pitch", "Yaw", "VN", "VE", "VD", "PN", "PE", "PD")
_RATE_FIELDS = ("GyrX", "GyrY", "GyrZ")


def _read_messages(path: Path, types: dict[str, tuple[str, ...]], src: str) -> dict[str, Any]:
    """type -> (TimeUS array, instance array or None, fields (N, k)) for each type."""
    try:
        from pymavlink import DFReader
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise ImportError(
            "reading DataFlash logs needs the `pymavlink` package: "
            "pip install 'sampledyn[ardusub]'."
        ) from exc
    try:
        log = DFReader.DFReader_binary(str(path), zero_time_base=False)
    except (struct.error, ValueError, IndexError, KeyError) as exc:
        raise LogFormatError("data", f"{src}: not a readable DataFlash log: {exc}") from exc
    rows: dict[str, list[tuple[Any, ...]]] = {t: [] for t in types}
    instance = {"XKF1": "C", "NKF1": "C", "IMU": "I"}
    try:
        while True:
            m = log.recv_match(type=list(types))
            if m is None:
                break
            kind = m.get_type()
            inst = getattr(m, instance[kind]) if kind in instance else -1
            rows[kind].append(
                (int(m.TimeUS), int(inst), *(float(getattr(m, f)) for f in types[kind]))
            )
    except AttributeError as exc:
        raise LogFormatError(
            "mapping", f"{src}: a message lacks a field the mapping needs: {exc}"
        ) from exc
    except (struct.error, ValueError, IndexError, KeyError) as exc:
        raise LogFormatError("data", f"{src}: not a readable DataFlash log: {exc}") from exc
    finally:
        log.close()
    out = {}
    have = sorted(log.name_to_id) if hasattr(log, "name_to_id") else []
    for kind, got in rows.items():
        if not got:
            close = difflib.get_close_matches(kind, have, n=1)
            raise LogFormatError(
                "mapping",
                f"{src}: the log has no {kind!r} message"
                + (f" (did you mean {close[0]!r}?)" if close else "")
                + (f"; it has {', '.join(have)}." if have else "."),
            )
        a = np.array(got)
        out[kind] = (a[:, 0].astype(np.int64), a[:, 1].astype(np.int64), a[:, 2:])
    return out


def read_dataflash(path: Path, model: Any, *, mapping: Any = None, **options: Any) -> LogData:
    """Read an ArduSub DataFlash log of a vehicle through a mapping file (module
    docstring); ``options`` as :func:`read_log`. Returns :class:`LogData`; the notes
    say where each quantity came from and the sampling rule."""
    path = Path(path)
    src = path.name
    cfg, thr = mapping_section(model, mapping, "ardusub", _KEYS, src, "a DataFlash log")
    unit, direction, voltage = thruster_options(
        thr, model.nu, "[ardusub.thrusters]", ("channels",), ("channels",)
    )
    channels = [int(c) for c in thr["channels"]]
    if len(channels) != model.nu or not all(1 <= c <= 14 for c in channels):
        raise LogFormatError(
            "mapping",
            f"mapping file: [ardusub.thrusters] channels must list {model.nu} output channels "
            f"in 1..14, got {thr['channels']!r}.",
        )
    states = str(cfg.get("states", "XKF1"))
    rates = str(cfg.get("rates", "IMU"))
    outputs = str(cfg.get("outputs", "RCOU"))
    core, imu = int(cfg.get("core", 0)), int(cfg.get("imu", 0))
    msgs = _read_messages(
        path,
        {
            states: _STATE_FIELDS,
            rates: _RATE_FIELDS,
            outputs: tuple(f"C{c}" for c in channels),
        },
        src,
    )

    t_s, inst, x = msgs[states]
    if states in ("XKF1", "NKF1"):
        keep = inst == core
        if not keep.any():
            raise LogFormatError(
                "mapping", f"{src}: no {states} message of EKF core {core} (`core` in [ardusub])."
            )
        t_s, x = t_s[keep], x[keep]
    att = np.radians(x[:, :3])
    R = rotation_zyx(att[:, 0], att[:, 1], att[:, 2])
    v_body = np.einsum("nji,nj->ni", R, x[:, 3:6])  # R^T v_NED
    t_r, inst_r, g = msgs[rates]
    if rates == "IMU":
        t_r, g = t_r[inst_r == imu], g[inst_r == imu]
    pqr, offset = nearest(t_s, t_r, g)
    eta = np.column_stack([x[:, 6:9], att])
    v = np.column_stack([v_body, pqr])

    t_o, _, pwm = msgs[outputs]
    held, have = hold_last(t_s, t_o, pwm)
    rpm, how = thruster_rpm(held[have], unit, direction, voltage, src)
    notes = [
        f"ArduSub DataFlash log; states from {states} (EKF core {core}) at its TimeUS: "
        "attitude (deg, ZYX Euler), NED position and velocity; body velocity = R^T v_NED",
        f"rates from {rates} (instance {imu}) GyrX/GyrY/GyrZ (rad/s, FRD), the sample "
        f"nearest each state stamp (at most {offset / 1e6:.3g} s away)",
        f"inputs from {outputs} channels {', '.join(f'C{c}' for c in channels)}; {how}",
        f"sampling rule: {SAMPLING_RULE}",
        *drop_before_first_command(have, src),
    ]
    frame = vehicle_frame(model, t_s[have], "us", eta[have], v[have], rpm)
    return log_from_frame(frame, model, source=src, notes=tuple(notes), **options)
