"""Logs of a BlueROV2 Heavy in real formats, written by the tests: a ROS 2 bag and a
ROS 1 (MAVROS) bag with rosbags' writers, and an ArduSub DataFlash log packed with
struct after ArduPilot's published message formats. The tests of the formats and of
the documented ``sampledyn evaluate`` commands write them with these functions."""

from __future__ import annotations

import struct
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

import sampledyn as sd
from sampledyn.logs._synthetic import survey_input
from sampledyn.logs._t200 import t200_rpm

T, H = 20.0, 0.1
E = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])  # NED <-> ENU
F = np.diag([1.0, -1.0, -1.0])  # FRD <-> FLU
SIGN = -1.0  # ArduSub vectored_6dof motor i against the vehicle file's T_i (examples)


def simulate_run() -> tuple[Any, Any, np.ndarray, np.ndarray, np.ndarray]:
    """A BlueROV2 Heavy driven by ESC commands at 20 Hz, 13 ms off the 10 Hz state
    grid (so the commands change between state samples), simulated exactly."""
    vehicle = sd.models.load_vehicle("bluerov2_heavy")
    c = -0.037 + 0.05 * np.arange(int(T / 0.05) + 2)
    # the survey motion of the example log, as whole-microsecond ESC commands
    target = SIGN * survey_input(vehicle)(c)
    pwm = np.rint(pwm_for(target)).astype(int)
    rpm = SIGN * t200_rpm(pwm, 16)
    traj = sd.simulate(vehicle, sd.signals.ZeroOrderHold(c, rpm), T=T, h=H)
    return vehicle, traj, c, pwm, rpm


def pwm_for(rpm):
    """Inverse of the T200 table on its monotone parts (test helper)."""
    pwm = np.arange(1100.0, 1901.0, 4.0)  # the table's points
    table = t200_rpm(pwm)
    fwd, rev = pwm >= 1532, pwm <= 1468
    return np.where(
        rpm >= 0,
        np.interp(rpm, table[fwd], pwm[fwd]),
        np.interp(-rpm, -table[rev][::-1], pwm[rev][::-1]),
    )


def held(c, values, t):
    """The command at or before each time t (zero-order hold)."""
    return values[np.searchsorted(c, t + 1e-12, side="right") - 1]


def ros_states(traj):
    """Odometry in ROS conventions (REP 103/105) from NED/FRD states, built with
    scipy's rotations (independent of the reader's own formulas)."""
    phi, theta, psi = traj.x[:, 3], traj.x[:, 4], traj.x[:, 5]
    R_nb = Rotation.from_euler("ZYX", np.column_stack([psi, theta, phi])).as_matrix()
    R_enu_flu = E @ R_nb @ F
    quat = Rotation.from_matrix(R_enu_flu).as_quat()  # x, y, z, w
    return traj.x[:, :3] @ E.T, quat, traj.x[:, 6:9] @ F.T, traj.x[:, 9:12] @ F.T


def odometry(ts, stamp_ns, pos, quat, lin, ang, ros1):
    T_ = ts.types
    header = {
        "stamp": T_["builtin_interfaces/msg/Time"](sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)
    }
    if ros1:
        header["seq"] = 0
    V3, P = T_["geometry_msgs/msg/Vector3"], T_["geometry_msgs/msg/Point"]
    return T_["nav_msgs/msg/Odometry"](
        header=T_["std_msgs/msg/Header"](frame_id="odom", **header),
        child_frame_id="base_link",
        pose=T_["geometry_msgs/msg/PoseWithCovariance"](
            pose=T_["geometry_msgs/msg/Pose"](
                position=P(x=pos[0], y=pos[1], z=pos[2]),
                orientation=T_["geometry_msgs/msg/Quaternion"](
                    x=quat[0], y=quat[1], z=quat[2], w=quat[3]
                ),
            ),
            covariance=np.zeros(36),
        ),
        twist=T_["geometry_msgs/msg/TwistWithCovariance"](
            twist=T_["geometry_msgs/msg/Twist"](
                linear=V3(x=lin[0], y=lin[1], z=lin[2]), angular=V3(x=ang[0], y=ang[1], z=ang[2])
            ),
            covariance=np.zeros(36),
        ),
    )


T0_NS = 1_700_000_000 * 10**9


def write_ros2_bag(bag: Path, run: Any) -> Path:
    """A ROS 2 bag (directory ``bag``) of ``run``: nav_msgs/Odometry on /bluerov2/odom
    at 10 Hz (recorded 3 ms after its header stamp) and the thruster rpm as a
    std_msgs/Float64MultiArray on /bluerov2/thrusters at 20 Hz (no header), as the
    shipped mapping ``examples/ros2_bluerov2_heavy.toml`` expects."""
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    _vehicle, traj, c, _, rpm = run
    ts = get_typestore(Stores.ROS2_HUMBLE)
    Odom, Arr = "nav_msgs/msg/Odometry", "std_msgs/msg/Float64MultiArray"
    pos, quat, lin, ang = ros_states(traj)
    with Writer(bag, version=9) as w:
        odom = w.add_connection("/bluerov2/odom", Odom, typestore=ts)
        thr = w.add_connection("/bluerov2/thrusters", Arr, typestore=ts)
        for n, t in enumerate(traj.t):
            stamp = T0_NS + int(round(t * 1e9))
            msg = odometry(ts, stamp, pos[n], quat[n], lin[n], ang[n], ros1=False)
            # recorded 3 ms after its stamp: the header stamp must win
            w.write(odom, stamp + 3_000_000, ts.serialize_cdr(msg, Odom))
        layout = ts.types["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0)
        for k in range(1, c.size):  # no command before t = 0.013 s: the first state drops
            cmd = ts.types[Arr](layout=layout, data=rpm[k])
            w.write(thr, T0_NS + int(round(c[k] * 1e9)), ts.serialize_cdr(cmd, Arr))
    return bag


def write_ros1_bag(bag: Path, run: Any) -> Path:
    """A ROS 1 bag (file ``bag``) of ``run`` as recorded through MAVROS: odometry on
    /mavros/local_position/odom and the servo PWM on /mavros/rc/out (mavros_msgs/RCOut,
    received 5 ms after its header stamp), as ``examples/ros1_mavros_bluerov2_heavy.toml``
    expects."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    _vehicle, traj, c, pwm, _rpm = run
    ts = get_typestore(Stores.ROS1_NOETIC)
    ts.register(
        get_types_from_msg("std_msgs/Header header\nuint16[] channels", "mavros_msgs/msg/RCOut")
    )
    Odom, RC = "nav_msgs/msg/Odometry", "mavros_msgs/msg/RCOut"
    pos, quat, lin, ang = ros_states(traj)
    with Writer(bag) as w:
        odom = w.add_connection("/mavros/local_position/odom", Odom, typestore=ts)
        rc = w.add_connection("/mavros/rc/out", RC, typestore=ts)
        msgs = []
        for n, t in enumerate(traj.t):
            stamp = T0_NS + int(round(t * 1e9))
            msgs.append(
                (
                    stamp,
                    odom,
                    ts.serialize_ros1(
                        odometry(ts, stamp, pos[n], quat[n], lin[n], ang[n], True), Odom
                    ),
                )
            )
        Time = ts.types["builtin_interfaces/msg/Time"]
        for k in range(c.size):
            stamp = T0_NS + int(round(c[k] * 1e9))
            head = ts.types["std_msgs/msg/Header"](
                seq=k, stamp=Time(sec=stamp // 10**9, nanosec=stamp % 10**9), frame_id=""
            )
            out = ts.types[RC](header=head, channels=np.array([*pwm[k], 0, 0], dtype=np.uint16))
            # received late (5 ms): the header stamp must win
            msgs.append((stamp + 5_000_000, rc, ts.serialize_ros1(out, RC)))
        for stamp, conn, raw in sorted(msgs, key=lambda m: m[0]):
            w.write(conn, stamp, raw)
    return bag


# ArduPilot DataFlash, packed after the published format (AP_Logger/LogStructure.h):
# a record is 0xA3 0x95, the message type, then the fields little-endian; FMT (type
# 128, "BBnNZ") defines each message type.
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
FORMATS = {
    "FMT": (128, "BBnNZ", "Type,Length,Name,Format,Columns"),
    "XKF1": (150, "QBccCfffffffccce", "TimeUS,C,Roll,Pitch,Yaw,VN,VE,VD,dPD,PN,PE,PD,GX,GY,GZ,OH"),
    "IMU": (151, "QBffffffIIfBBHH", "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,EG,EA,T,GH,AH,GHz,AHz"),
    "RCOU": (152, "QHHHHHHHHHHHHHH", "TimeUS," + ",".join(f"C{i}" for i in range(1, 15))),
}


def record(name, *values):
    type_id, fmt, _ = FORMATS[name]
    return (
        b"\xa3\x95"
        + bytes([type_id])
        + struct.pack("<" + "".join(_STRUCT[ch] for ch in fmt), *values)
    )


def fmt_record(name):
    type_id, fmt, cols = FORMATS[name]
    length = 3 + struct.calcsize("<" + "".join(_STRUCT[ch] for ch in fmt))
    return record("FMT", type_id, length, name.encode(), fmt.encode(), cols.encode())


def write_dataflash(log: Path, run: Any) -> tuple[Path, np.ndarray, np.ndarray]:
    """An ArduSub DataFlash log (file ``log``) of ``run``: XKF1 of EKF cores 0 and 1
    (core 1 wrong, to be ignored) at 10 Hz, IMU at 50 Hz, RCOU at 20 Hz, as a mapping
    with `channels` 1..8 and `direction` -1 expects (it holds no parameters). Returns
    (log, the attitude in centidegrees as logged, the NED velocity logged)."""
    _vehicle, traj, c, pwm, _rpm = run
    t_us = 30_000_000 + np.rint(traj.t * 1e6).astype(np.int64)
    att = np.degrees(traj.x[:, 3:6])
    cdeg = np.rint(att * 100).astype(int)
    cdeg[:, 2] %= 36000  # yaw logged in 0..360 deg
    R_nb = Rotation.from_euler(
        "ZYX", np.column_stack([psi := traj.x[:, 5], traj.x[:, 4], traj.x[:, 3]])
    ).as_matrix()
    del psi
    v_ned = np.einsum("nij,nj->ni", R_nb, traj.x[:, 6:9])
    blob = b"".join(fmt_record(n) for n in FORMATS)
    records = []
    for n in range(traj.n_samples):
        records.append(
            (
                int(t_us[n]),
                record(
                    "XKF1",
                    int(t_us[n]),
                    0,
                    *cdeg[n, :2],
                    cdeg[n, 2],
                    *v_ned[n],
                    0.0,
                    *traj.x[n, :3],
                    0,
                    0,
                    0,
                    0,
                ),
            )
        )
        records.append(
            (int(t_us[n]), record("XKF1", int(t_us[n]), 1, 0, 0, 0, *([9.0] * 7), 0, 0, 0, 0))
        )  # core 1: ignored
        for k in range(5):  # IMU at 50 Hz; only the samples at the state stamps are right
            gyro = traj.x[n, 9:12] + (0.0 if k == 0 else 1.0)
            stamp = int(t_us[n]) + 20_000 * k
            records.append(
                (stamp, record("IMU", stamp, 0, *gyro, 0, 0, -9.8, 0, 0, 25.0, 1, 1, 400, 400))
            )
    for k in range(c.size):
        stamp = 30_000_000 + int(round(c[k] * 1e6))
        records.append((stamp, record("RCOU", stamp, *pwm[k], *([1500] * 6))))
    blob += b"".join(r for _, r in sorted(records, key=lambda r: r[0]))
    log.write_bytes(blob)

    return log, cdeg, v_ned


def vehicle_without(tmp_path: Path, drop: tuple[str, ...] = ("T7", "T8")) -> Path:
    """The BlueROV2 Heavy vehicle file without the thrusters named in ``drop`` (each
    ``[[thruster]]`` table removed from the published file as it is), written to
    ``tmp_path``."""
    text = (Path(sd.models.__file__).parent / "vehicles" / "bluerov2_heavy.toml").read_text()
    head, *blocks = text.split("[[thruster]]")
    kept = [b for b in blocks if not any(f'name = "{n}"' in b for n in drop)]
    assert len(kept) == len(blocks) - len(drop)  # every dropped thruster was there
    path = tmp_path / f"bluerov2_without_{'_'.join(drop)}.toml"
    path.write_text(head + "".join("[[thruster]]" + b for b in kept))
    return path
