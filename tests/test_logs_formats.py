"""Real log formats (issue 11, item 4): ROS 2 and ROS 1 bags written with rosbags'
writers, an ArduSub DataFlash log packed with struct after ArduPilot's published
message formats and read back by pymavlink; frames, units, the sampling rule and the
documented `sampledyn evaluate` command of each, with the shipped mapping files."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import sampledyn as sd
from sampledyn.cli import main
from sampledyn.logs import LogFormatError, read_log, t200_rpm

rosbags = pytest.importorskip("rosbags")
pytest.importorskip("pymavlink")

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
T, H = 20.0, 0.1
E = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])  # NED <-> ENU
F = np.diag([1.0, -1.0, -1.0])  # FRD <-> FLU
SIGN = -1.0  # ArduSub vectored_6dof motor i against the vehicle file's T_i (examples)


@pytest.fixture(scope="module")
def run():
    """A BlueROV2 Heavy driven by ESC commands at 20 Hz, 13 ms off the 10 Hz state
    grid (so the commands change between state samples), simulated exactly."""
    vehicle = sd.models.load_vehicle("bluerov2_heavy")
    c = -0.037 + 0.05 * np.arange(int(T / 0.05) + 2)
    # the survey motion of the example log, as whole-microsecond ESC commands
    target = SIGN * sd.logs.survey_input(vehicle)(c)
    pwm = np.rint(_pwm_for(target)).astype(int)
    rpm = SIGN * t200_rpm(pwm, 16)
    traj = sd.simulate(vehicle, sd.signals.ZeroOrderHold(c, rpm), T=T, h=H)
    return vehicle, traj, c, pwm, rpm


def _pwm_for(rpm):
    """Inverse of the T200 table on its monotone parts (test helper)."""
    pwm = np.arange(1100.0, 1901.0, 4.0)  # the table's points
    table = t200_rpm(pwm)
    fwd, rev = pwm >= 1532, pwm <= 1468
    return np.where(
        rpm >= 0,
        np.interp(rpm, table[fwd], pwm[fwd]),
        np.interp(-rpm, -table[rev][::-1], pwm[rev][::-1]),
    )


def _held(c, values, t):
    """The command at or before each time t (zero-order hold)."""
    return values[np.searchsorted(c, t + 1e-12, side="right") - 1]


def _ros_states(traj):
    """Odometry in ROS conventions (REP 103/105) from NED/FRD states, built with
    scipy's rotations (independent of the reader's own formulas)."""
    phi, theta, psi = traj.x[:, 3], traj.x[:, 4], traj.x[:, 5]
    R_nb = Rotation.from_euler("ZYX", np.column_stack([psi, theta, phi])).as_matrix()
    R_enu_flu = E @ R_nb @ F
    quat = Rotation.from_matrix(R_enu_flu).as_quat()  # x, y, z, w
    return traj.x[:, :3] @ E.T, quat, traj.x[:, 6:9] @ F.T, traj.x[:, 9:12] @ F.T


def _odometry(ts, stamp_ns, pos, quat, lin, ang, ros1):
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


def test_ros2_bag_through_the_documented_command(run, tmp_path, capsys):
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    vehicle, traj, c, _, rpm = run
    ts = get_typestore(Stores.ROS2_HUMBLE)
    Odom, Arr = "nav_msgs/msg/Odometry", "std_msgs/msg/Float64MultiArray"
    pos, quat, lin, ang = _ros_states(traj)
    bag = tmp_path / "bluerov2_bag"
    with Writer(bag, version=9) as w:
        odom = w.add_connection("/bluerov2/odom", Odom, typestore=ts)
        thr = w.add_connection("/bluerov2/thrusters", Arr, typestore=ts)
        for n, t in enumerate(traj.t):
            stamp = T0_NS + int(round(t * 1e9))
            msg = _odometry(ts, stamp, pos[n], quat[n], lin[n], ang[n], ros1=False)
            # recorded 3 ms after its stamp: the header stamp must win
            w.write(odom, stamp + 3_000_000, ts.serialize_cdr(msg, Odom))
        layout = ts.types["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0)
        for k in range(1, c.size):  # no command before t = 0.013 s: the first state drops
            cmd = ts.types[Arr](layout=layout, data=rpm[k])
            w.write(thr, T0_NS + int(round(c[k] * 1e9)), ts.serialize_cdr(cmd, Arr))
    data = read_log(bag, vehicle, mapping=EXAMPLES / "ros2_bluerov2_heavy.toml")
    tr = data.traj
    assert tr.n_samples == traj.n_samples - 1 and tr.h == pytest.approx(0.1, abs=1e-15)
    np.testing.assert_allclose(tr.t, traj.t[1:] - traj.t[1], rtol=0, atol=1e-12)
    np.testing.assert_allclose(tr.x, traj.x[1:], rtol=0, atol=1e-12)  # frames undone
    np.testing.assert_array_equal(tr.u, _held(c, rpm, traj.t[1:]))  # zero-order hold
    assert tr.origin.startswith(f"{T0_NS + 100_000_000} ns (as Unix time: 2023-11-14T22:13:20.1")
    notes = "\n".join(data.notes)
    assert "ROS 2 bag; states from /bluerov2/odom (nav_msgs/msg/Odometry, header stamps)" in notes
    assert "/bluerov2/thrusters (std_msgs/msg/Float64MultiArray, no header: record time)" in notes
    assert "world ENU -> NED, body FLU -> FRD, quaternion -> ZYX Euler angles" in notes
    assert "1 state samples before the first command dropped" in notes
    code = main(
        ["evaluate", "--data", str(bag), "--vehicle", "bluerov2_heavy", "--mapping"]
        + [str(EXAMPLES / "ros2_bluerov2_heavy.toml"), "--methods", "E,AB2,RK4"]
    )
    out = capsys.readouterr().out
    assert code == 0 and "sampling rule: states at the stamps of the state message" in out
    assert "RK4" in out and "uniform, h = 0.1 s" in out


def test_a_ros_yaw_of_zero_faces_east(tmp_path):
    """A hand-checked case of the frame conversion: ENU yaw 0 (facing east) is NED
    psi = +90 deg; a forward FLU twist is a forward FRD surge; up is -z."""
    from sampledyn.logs._frames import quaternion_matrix, to_ned_frd

    eta, v = to_ned_frd(
        np.array([[1.0, 2.0, 3.0]]),
        quaternion_matrix(np.array([[0.0, 0.0, 0.0, 1.0]])),
        np.array([[0.5, 0.2, 0.1]]),
        np.array([[0.01, 0.02, 0.03]]),
        world="enu",
        body="flu",
    )
    np.testing.assert_allclose(eta[0], [2.0, 1.0, -3.0, 0.0, 0.0, np.pi / 2], atol=1e-15)
    np.testing.assert_allclose(v[0], [0.5, -0.2, -0.1, 0.01, -0.02, -0.03], atol=1e-15)


def test_ros1_mavros_bag_with_pwm_commands(run, tmp_path, capsys):
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    vehicle, traj, c, pwm, rpm = run
    ts = get_typestore(Stores.ROS1_NOETIC)
    ts.register(
        get_types_from_msg("std_msgs/Header header\nuint16[] channels", "mavros_msgs/msg/RCOut")
    )
    Odom, RC = "nav_msgs/msg/Odometry", "mavros_msgs/msg/RCOut"
    pos, quat, lin, ang = _ros_states(traj)
    bag = tmp_path / "run.bag"
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
                        _odometry(ts, stamp, pos[n], quat[n], lin[n], ang[n], True), Odom
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
    mapping = EXAMPLES / "ros1_mavros_bluerov2_heavy.toml"
    data = read_log(bag, vehicle, mapping=mapping)
    np.testing.assert_allclose(data.traj.x, traj.x, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(data.traj.u, SIGN * t200_rpm(_held(c, pwm, traj.t), 16))
    notes = "\n".join(data.notes)
    assert "ROS 1 bag" in notes and "/mavros/rc/out (mavros_msgs/msg/RCOut, header stamps)" in notes
    assert "thruster PWM (us) -> rpm by the Blue Robotics T200 table at 16 V" in notes
    code = main(
        ["evaluate", "--data", str(bag), "--vehicle", "bluerov2_heavy", "--mapping", str(mapping)]
    )
    assert code == 0 and "AB4" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (
            {"odometry": "/bluerov2/odm"},
            r"names topic '/bluerov2/odm' \(did you mean '/bluerov2/odom'\?\)",
        ),
        (
            {"body_frame": "flu", "bodyframe": "frd"},
            r"unknown key\(s\) in \[ros\]: 'bodyframe' \(did you mean 'body_frame'\?\)",
        ),
        ({"world_frame": "nwu"}, r"world_frame must be one of ned, enu, got 'nwu'"),
    ],
)
def test_bag_mapping_mistakes_are_named(run, tmp_path, edit, message):
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    vehicle, traj, *_ = run
    ts = get_typestore(Stores.ROS2_HUMBLE)
    pos, quat, lin, ang = _ros_states(traj)
    bag = tmp_path / "b"
    with Writer(bag, version=9) as w:
        odom = w.add_connection("/bluerov2/odom", "nav_msgs/msg/Odometry", typestore=ts)
        thr = w.add_connection(
            "/bluerov2/thrusters", "std_msgs/msg/Float64MultiArray", typestore=ts
        )
        for n in range(3):
            msg = _odometry(ts, T0_NS + n * 10**8, pos[n], quat[n], lin[n], ang[n], ros1=False)
            w.write(odom, T0_NS + n * 10**8, ts.serialize_cdr(msg, "nav_msgs/msg/Odometry"))
    del thr
    mapping = {
        "ros": {
            "odometry": "/bluerov2/odom",
            "thrusters": {"topic": "/bluerov2/thrusters", "unit": "rpm"},
        }
    }
    mapping["ros"].update(edit)
    with pytest.raises(LogFormatError, match=message):
        read_log(bag, vehicle, mapping=mapping)


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


def _record(name, *values):
    type_id, fmt, _ = FORMATS[name]
    return (
        b"\xa3\x95"
        + bytes([type_id])
        + struct.pack("<" + "".join(_STRUCT[ch] for ch in fmt), *values)
    )


def _fmt_record(name):
    type_id, fmt, cols = FORMATS[name]
    length = 3 + struct.calcsize("<" + "".join(_STRUCT[ch] for ch in fmt))
    return _record("FMT", type_id, length, name.encode(), fmt.encode(), cols.encode())


def test_ardusub_dataflash_through_the_documented_command(run, tmp_path, capsys):
    vehicle, traj, c, pwm, rpm = run
    t_us = 30_000_000 + np.rint(traj.t * 1e6).astype(np.int64)
    att = np.degrees(traj.x[:, 3:6])
    cdeg = np.rint(att * 100).astype(int)
    cdeg[:, 2] %= 36000  # yaw logged in 0..360 deg
    R_nb = Rotation.from_euler(
        "ZYX", np.column_stack([psi := traj.x[:, 5], traj.x[:, 4], traj.x[:, 3]])
    ).as_matrix()
    del psi
    v_ned = np.einsum("nij,nj->ni", R_nb, traj.x[:, 6:9])
    blob = b"".join(_fmt_record(n) for n in FORMATS)
    records = []
    for n in range(traj.n_samples):
        records.append(
            (
                int(t_us[n]),
                _record(
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
            (int(t_us[n]), _record("XKF1", int(t_us[n]), 1, 0, 0, 0, *([9.0] * 7), 0, 0, 0, 0))
        )  # core 1: ignored
        for k in range(5):  # IMU at 50 Hz; only the samples at the state stamps are right
            gyro = traj.x[n, 9:12] + (0.0 if k == 0 else 1.0)
            stamp = int(t_us[n]) + 20_000 * k
            records.append(
                (stamp, _record("IMU", stamp, 0, *gyro, 0, 0, -9.8, 0, 0, 25.0, 1, 1, 400, 400))
            )
    for k in range(c.size):
        stamp = 30_000_000 + int(round(c[k] * 1e6))
        records.append((stamp, _record("RCOU", stamp, *pwm[k], *([1500] * 6))))
    blob += b"".join(r for _, r in sorted(records, key=lambda r: r[0]))
    log = tmp_path / "00000042.BIN"
    log.write_bytes(blob)

    mapping = EXAMPLES / "ardusub_bluerov2_heavy.toml"
    data = read_log(log, vehicle, mapping=mapping)
    tr = data.traj
    # what the log holds, decoded independently: centidegrees, float32 NED, R^T v
    att_log = np.radians(np.where(np.arange(3) == 2, cdeg % 36000, cdeg) * 0.01)
    att_log[:, 2] = np.unwrap(att_log[:, 2])
    R_log = Rotation.from_euler("ZYX", att_log[:, ::-1]).as_matrix()
    v_log = np.einsum("nji,nj->ni", R_log, v_ned.astype(np.float32).astype(float))
    np.testing.assert_allclose(tr.x[:, :3], traj.x[:, :3].astype(np.float32), rtol=0, atol=0)
    np.testing.assert_allclose(tr.x[:, 3:6], att_log, rtol=0, atol=1e-14)
    np.testing.assert_allclose(tr.x[:, 6:9], v_log, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(tr.x[:, 9:12], traj.x[:, 9:12].astype(np.float32))
    np.testing.assert_array_equal(tr.u, SIGN * t200_rpm(_held(c, pwm, traj.t), 16))
    # and close to the exact motion (within the logging quantisation)
    assert np.abs(tr.x[:, 3:5] - traj.x[:, 3:5]).max() < 1e-4
    assert tr.origin == "30000000 us" and tr.h == pytest.approx(0.1, abs=1e-15)
    notes = "\n".join(data.notes)
    assert "states from XKF1 (EKF core 0) at its TimeUS" in notes
    assert "the sample nearest each state stamp (at most 0 s away)" in notes
    code = main(
        ["evaluate", "--data", str(log), "--vehicle", "bluerov2_heavy", "--mapping", str(mapping)]
    )
    out = capsys.readouterr().out
    assert code == 0 and "integer counter in us; t = 0 at 30000000 us" in out


def test_ardusub_mapping_mistakes_are_named(tmp_path):
    vehicle = sd.models.load_vehicle("bluerov2_heavy")
    log = tmp_path / "x.bin"
    log.write_bytes(b"".join(_fmt_record(n) for n in FORMATS) + _record("RCOU", 1, *([1500] * 14)))
    bad = {
        "ardusub": {"states": "XFK1", "thrusters": {"channels": list(range(1, 9)), "unit": "pwm"}}
    }
    with pytest.raises(LogFormatError, match=r"no 'XFK1' message \(did you mean 'XKF1'\?\)"):
        read_log(log, vehicle, mapping=bad)
    bad = {"ardusub": {"thrusters": {"channels": [1, 2], "unit": "pwm"}}}
    with pytest.raises(LogFormatError, match=r"channels must list 8 output channels"):
        read_log(log, vehicle, mapping=bad)
    bad = {"ardusub": {"thrusters": {"chanels": list(range(1, 9)), "unit": "pwm"}}}
    with pytest.raises(LogFormatError, match=r"'chanels' \(did you mean 'channels'\?\)"):
        read_log(log, vehicle, mapping=bad)


def test_t200_table_matches_the_vehicle_file():
    """The published 16 V table ends at the vehicle file's n_max (3533 rpm forward) and
    gives its partial-command point (2129 rpm at 1700 us); deadband 1472..1528 us."""
    vehicle = sd.models.load_vehicle("bluerov2_heavy")
    np.testing.assert_array_equal(t200_rpm([1100, 1500, 1700, 1900]), [-3465, 0, 2129, 3533])
    assert vehicle.n_max == 3533
    assert (t200_rpm(np.arange(1472, 1529, 4)) == 0).all()
    with pytest.raises(ValueError, match="outside the published range"):
        t200_rpm([1000])
