"""Real log formats (issue 11, item 4): ROS 2 and ROS 1 bags written with rosbags'
writers, an ArduSub DataFlash log packed with struct after ArduPilot's published
message formats and read back by pymavlink; frames, units, the sampling rule and the
documented `sampledyn evaluate` command of each, with the shipped mapping files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import sampledyn as sd
from sampledyn.cli import main
from sampledyn.exceptions import LogFormatError, MissingArgumentError
from sampledyn.logs import read_log
from sampledyn.logs._t200 import t200_rpm

rosbags = pytest.importorskip("rosbags")
pytest.importorskip("pymavlink")

from _faults import error_lines  # noqa: E402
from _log_fixtures import (  # noqa: E402  (after the optional extras are known)
    FORMATS,
    SIGN,
    T0_NS,
    fmt_record,
    held,
    odometry,
    record,
    ros_states,
    simulate_run,
    write_dataflash,
    write_ros1_bag,
    write_ros2_bag,
)

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture(scope="module")
def run():
    """A BlueROV2 Heavy driven by ESC commands at 20 Hz, 13 ms off the 10 Hz state
    grid (so the commands change between state samples), simulated exactly."""
    return simulate_run()


def test_ros2_bag_through_the_documented_command(run, tmp_path, capsys):
    vehicle, traj, c, _, rpm = run
    bag = write_ros2_bag(tmp_path / "bluerov2_bag", run)
    data = read_log(bag, vehicle, mapping=EXAMPLES / "ros2_bluerov2_heavy.toml")
    tr = data.traj
    assert tr.n_samples == traj.n_samples - 1 and tr.h == pytest.approx(0.1, abs=1e-15)
    np.testing.assert_allclose(tr.t, traj.t[1:] - traj.t[1], rtol=0, atol=1e-12)
    np.testing.assert_allclose(tr.x, traj.x[1:], rtol=0, atol=1e-12)  # frames undone
    np.testing.assert_array_equal(tr.u, held(c, rpm, traj.t[1:]))  # zero-order hold
    assert tr.origin.startswith(f"{T0_NS + 100_000_000} ns (as Unix time: 2023-11-14T22:13:20.1")
    notes = "\n".join(data.notes)
    assert "ROS 2 bag; states from /bluerov2/odom (nav_msgs/msg/Odometry, header stamps)" in notes
    assert "/bluerov2/thrusters (std_msgs/msg/Float64MultiArray, no header: record time)" in notes
    assert "world ENU -> NED, body FLU -> FRD, quaternion -> ZYX Euler angles" in notes
    assert "1 state sample before the first command dropped" in notes
    code = main(
        ["evaluate", "--data", str(bag), "--vehicle", "bluerov2_heavy", "--mapping"]
        + [str(EXAMPLES / "ros2_bluerov2_heavy.toml"), "--methods", "E,AB2,RK4"]
    )
    out = capsys.readouterr().out
    assert code == 0 and "sampling rule: states at the stamps of the state message" in out
    assert "RK4" in out and "uniform, h = 0.1 s" in out


def test_a_bag_without_a_mapping_is_a_missing_option(run, tmp_path, capsys):
    """A bag names no states by itself: without ``mapping`` the library says which
    argument is missing, and the command ends as for a missing option (status 2)."""
    vehicle = run[0]
    bag = write_ros2_bag(tmp_path / "bluerov2_bag", run)
    with pytest.raises(MissingArgumentError, match="needs a mapping file") as exc:
        read_log(bag, vehicle)
    assert exc.value.argument == "mapping"
    with pytest.raises(SystemExit) as stop:
        main(["evaluate", "--data", str(bag), "--vehicle", "bluerov2_heavy"])
    err = capsys.readouterr().err
    assert stop.value.code == 2 and err.startswith("sampledyn: error: --mapping: ")
    assert "examples/ros2_bluerov2_heavy.toml" in err and len(error_lines(err)) == 1


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
    vehicle, traj, c, pwm, rpm = run
    bag = write_ros1_bag(tmp_path / "run.bag", run)
    mapping = EXAMPLES / "ros1_mavros_bluerov2_heavy.toml"
    data = read_log(bag, vehicle, mapping=mapping)
    np.testing.assert_allclose(data.traj.x, traj.x, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(data.traj.u, SIGN * t200_rpm(held(c, pwm, traj.t), 16))
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
    pos, quat, lin, ang = ros_states(traj)
    bag = tmp_path / "b"
    with Writer(bag, version=9) as w:
        odom = w.add_connection("/bluerov2/odom", "nav_msgs/msg/Odometry", typestore=ts)
        thr = w.add_connection(
            "/bluerov2/thrusters", "std_msgs/msg/Float64MultiArray", typestore=ts
        )
        for n in range(3):
            msg = odometry(ts, T0_NS + n * 10**8, pos[n], quat[n], lin[n], ang[n], ros1=False)
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


def test_ardusub_dataflash_through_the_documented_command(run, tmp_path, capsys):
    vehicle, traj, c, pwm, rpm = run
    log, cdeg, v_ned = write_dataflash(tmp_path / "00000042.BIN", run)
    # a log without parameters: the motor channels and signs given in the mapping
    mapping = tmp_path / "heavy.toml"
    mapping.write_text(
        '[ardusub]\n[ardusub.thrusters]\nchannels = [1, 2, 3, 4, 5, 6, 7, 8]\nunit = "pwm"\n'
        "voltage = 16\ndirection = [-1, -1, -1, -1, -1, -1, -1, -1]\n"
    )
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
    np.testing.assert_array_equal(tr.u, SIGN * t200_rpm(held(c, pwm, traj.t), 16))
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
    log.write_bytes(b"".join(fmt_record(n) for n in FORMATS) + record("RCOU", 1, *([1500] * 14)))
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
