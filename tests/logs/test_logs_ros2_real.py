"""ROS 2 bags as they are recorded (issue 20, item 4): sqlite3 and MCAP storage, with
or without metadata.yaml; a mavros type the bag does not embed; RC override refused as
thruster commands unless ArduSub's MANUAL mixer is declared; a type from a .msg file;
a world-frame twist found by the kinematics check; the commanded wrench as input."""

from __future__ import annotations

import numpy as np
import pytest

import sampledyn as sd
from sampledyn.cli import main
from sampledyn.exceptions import LogFormatError
from sampledyn.logs import read_log
from sampledyn.logs._t200 import t200_rpm

pytest.importorskip("rosbags")

from _log_fixtures import T0_NS, odometry, ros_states, simulate_run  # noqa: E402, I001

from _ros_fixtures import (  # noqa: E402
    ODOM,
    OVERRIDE_MSG,
    _store,
    strip_definitions,
    write_tank_bag,
)

MAPPING = {
    "ros": {
        "odometry": "/mocap/bluerov_saab/odom",
        "thrusters": {"topic": "/mavros/rc/override", "field": "channels", "unit": "pwm"},
    }
}
MIXER = {"mode": "MANUAL", "frame": "vectored_6dof"}


@pytest.fixture(scope="module")
def heavy():
    return sd.models.load_vehicle("bluerov2_heavy")


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_rc_override_is_refused_as_thruster_commands(heavy, tmp_path, storage):
    bag = write_tank_bag(tmp_path / "tank", storage)
    with pytest.raises(
        LogFormatError,
        match=r"topic '/mavros/rc/override' \(mavros_msgs/msg/OverrideRCIn\) holds pilot inputs.*"
        r"\[ros.mixer\] mode = \"MANUAL\"",
    ):
        read_log(bag, heavy, mapping=MAPPING)


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_rc_override_through_the_declared_manual_mixer(heavy, tmp_path, storage):
    """Roll 1700 us (norm 0.5) on the Heavy: vertical motors 5-8 have roll factors
    +1, -1, +1, -1 (AP_Motors6DOF), so 1700, 1300, 1700, 1300 us; horizontals 1500."""
    bag = write_tank_bag(tmp_path / "tank", storage)
    mapping = {"ros": {**MAPPING["ros"], "mixer": MIXER}}
    data = read_log(bag, heavy, mapping=mapping)
    t = data.traj.t + 0.1 * (data.traj.n_samples and 0)  # states from t = 0 s
    rolled = np.array([1500] * 4 + [1700, 1300, 1700, 1300])
    neutral = np.full(8, 1500)
    # message k (at -0.05 + 0.2 k s) rolls from k = 5, i.e. from t = 0.95 s on
    want = np.where((t >= 0.95 - 1e-9)[:, None], rolled, neutral)
    np.testing.assert_array_equal(data.traj.u, -1.0 * t200_rpm(want, 16))  # signs -1 (docs)
    notes = "\n".join(data.notes)
    assert "RC 65535 (CHAN_NOCHANGE) holds the channel's last value" in notes
    assert "MANUAL-mode mixer (AP_Motors6DOF, frame vectored_6dof, FRAME_CONFIG 2)" in notes


def test_a_standalone_mcap_file_without_metadata(heavy, tmp_path):
    bag = write_tank_bag(tmp_path / "tank", "mcap")
    (bag / "metadata.yaml").unlink()
    alone = next(bag.glob("*.mcap"))
    mapping = {"ros": {**MAPPING["ros"], "mixer": MIXER}}
    for path in (alone, bag):  # the file itself, or its folder holding it alone
        data = read_log(path, heavy, mapping=mapping)
        assert data.traj.n_samples == 30


def test_a_type_neither_embedded_nor_known_names_the_option(heavy, tmp_path):
    bag = write_tank_bag(tmp_path / "tank", rc_type="brov_msgs/msg/StampedRcOverride")
    mapping = {"ros": {**MAPPING["ros"], "mixer": MIXER}}
    with pytest.raises(
        LogFormatError,
        match=r"topic '/mavros/rc/override' has type 'brov_msgs/msg/StampedRcOverride'.*"
        r"\[ros.types\] \"brov_msgs/msg/StampedRcOverride\" = \"path/to/StampedRcOverride.msg\"",
    ):
        read_log(bag, heavy, mapping=mapping)
    msg = tmp_path / "StampedRcOverride.msg"
    msg.write_text(OVERRIDE_MSG)
    mapping["ros"]["types"] = {"brov_msgs/msg/StampedRcOverride": str(msg)}
    data = read_log(bag, heavy, mapping=mapping)  # not a mavros type: read as thruster PWM
    assert data.traj.n_samples == 30


@pytest.fixture(scope="module")
def run():
    return simulate_run()


def test_a_world_frame_twist_is_found_by_the_kinematics(run, tmp_path):
    vehicle, traj = run[0], run[1]
    bag = write_tank_bag(tmp_path / "turning", twist_world=True, run=run)
    mapping = {"ros": {**MAPPING["ros"], "mixer": MIXER}}
    wrong = read_log(bag, vehicle, mapping=mapping)
    assert len(wrong.warnings) == 1
    assert (
        "reads the twist in the body frame, but the world-frame reading fits" in wrong.warnings[0]
    )
    mapping["ros"]["twist_frame"] = "world"
    right = read_log(bag, vehicle, mapping=mapping)
    assert right.warnings == ()
    assert "the world frame fits" in "\n".join(right.notes)
    np.testing.assert_allclose(right.traj.x[:, 6:9], traj.x[:, 6:9], rtol=0, atol=1e-12)


def test_the_commanded_wrench_as_input_from_a_mapping_file(tmp_path, capsys):
    """A vehicle driven by a logged body wrench (thrusters bypassed): the bag gives the
    WrenchStamped in FLU, the mapping's [ros.wrench] makes `evaluate` use the
    vehicle's wrench input; RK4's one-step errors are those of an exact log."""
    from rosbags.rosbag2 import Writer

    vehicle = sd.models.load_vehicle("bluerov2_heavy", wrench_input=True)
    c = np.arange(0.0, 6.01, 0.1)
    tau = np.column_stack(
        [8 * np.sin(0.5 * c), 2 * np.cos(c), -1 + 0 * c, 0 * c, 0.1 * np.sin(c), 0.4 + 0 * c]
    )
    traj = sd.simulate(vehicle, sd.signals.ZeroOrderHold(c, tau), T=6.0, h=0.1)
    ts = _store()
    pos, quat, lin, ang = ros_states(traj)
    F = np.diag([1.0, -1.0, -1.0])
    bag = tmp_path / "auv"
    with Writer(bag, version=8) as w:
        odom = w.add_connection("/odom", ODOM, typestore=ts)
        wr = w.add_connection("/tau", "geometry_msgs/msg/WrenchStamped", typestore=ts)
        T_ = ts.types
        for i in range(traj.n_samples):
            stamp = T0_NS + i * 100_000_000
            w.write(
                odom,
                stamp,
                ts.serialize_cdr(odometry(ts, stamp, pos[i], quat[i], lin[i], ang[i], False), ODOM),
            )
            f, m = F @ tau[i, :3], F @ tau[i, 3:]
            head = T_["std_msgs/msg/Header"](
                stamp=T_["builtin_interfaces/msg/Time"](sec=stamp // 10**9, nanosec=stamp % 10**9),
                frame_id="base_link",
            )
            V3 = T_["geometry_msgs/msg/Vector3"]
            msg = T_["geometry_msgs/msg/WrenchStamped"](
                header=head,
                wrench=T_["geometry_msgs/msg/Wrench"](
                    force=V3(x=f[0], y=f[1], z=f[2]), torque=V3(x=m[0], y=m[1], z=m[2])
                ),
            )
            w.write(wr, stamp, ts.serialize_cdr(msg, "geometry_msgs/msg/WrenchStamped"))
    strip_definitions(bag)
    mapping = tmp_path / "wrench.toml"
    mapping.write_text(
        '[ros]\nodometry = "/odom"\n[ros.wrench]\ntopic = "/tau"\nfield = "wrench"\n'
    )
    data = read_log(bag, vehicle, mapping=mapping)
    np.testing.assert_allclose(data.traj.u, tau[: traj.n_samples], rtol=0, atol=1e-12)
    thrusters = sd.models.load_vehicle("bluerov2_heavy")
    with pytest.raises(LogFormatError, match=r"mapping gives the wrench inputs.*wrench_input=True"):
        read_log(bag, thrusters, mapping=mapping)
    code = main(
        [
            "evaluate",
            "--data",
            str(bag),
            "--vehicle",
            "bluerov2_heavy",
            "--mapping",
            str(mapping),
            "--methods",
            "E,RK4",
            "--format",
            "json",
        ]
    )
    import json

    doc = json.loads(capsys.readouterr().out)
    assert code == 0
    rows = {r["method"]: r for r in doc["rows"]}
    # exact samples: RK4's local error is its truncation, O(h^5), far below Euler's O(h^2)
    assert rows["RK4"]["err_all"] < 1e-3 * rows["E"]["err_all"]
