"""ROS 2 bags as a tank test records them through MAVROS: motion-capture odometry and
/mavros/rc/override (mavros_msgs/OverrideRCIn), written with rosbags' writer in
sqlite3 (made as ROS 2 Humble writes it: no message definitions) or MCAP storage."""

from __future__ import annotations

import numpy as np
from _log_fixtures import T0_NS, odometry, ros_states

OVERRIDE = "mavros_msgs/msg/OverrideRCIn"
OVERRIDE_MSG = "uint16 CHAN_RELEASE=0\nuint16 CHAN_NOCHANGE=65535\nuint16[18] channels\n"
ODOM = "nav_msgs/msg/Odometry"


def _store(extra=None):
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    ts.register(get_types_from_msg(OVERRIDE_MSG, OVERRIDE))
    for name, text in (extra or {}).items():
        ts.register(get_types_from_msg(text, name))
    return ts


def _rc(k):
    """RC override k: neutral, then roll (channel 2) at 1700 us from message 5 on;
    channel 7.. 65535 (no change), and channel 2 'no change' at message 8 (held)."""
    ch = np.full(18, 65535, dtype=np.uint16)
    ch[:6] = 1500
    if k >= 5:
        ch[1] = 1700
    if k == 8:
        ch[1] = 65535
    return ch


def write_tank_bag(path, storage="sqlite3", n=30, rc_type=OVERRIDE, twist_world=False, run=None):
    """Odometry at 10 Hz (from ``run`` if given, else at rest) and RC override at 5 Hz."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    ts = _store({rc_type: OVERRIDE_MSG} if rc_type != OVERRIDE else None)
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    if run is not None:
        traj = run[1]
        pos, quat, lin, ang = ros_states(traj)
        if twist_world:  # the world-frame (ENU) twist: E R_nb v_body
            from _log_fixtures import E
            from scipy.spatial.transform import Rotation

            R_nb = Rotation.from_euler("ZYX", traj.x[:, [5, 4, 3]]).as_matrix()
            lin = np.einsum("nij,nj->ni", R_nb, traj.x[:, 6:9]) @ E.T
        n = traj.n_samples
    else:
        pos, quat = np.zeros((n, 3)), np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
        lin, ang = np.zeros((n, 3)), np.zeros((n, 3))
    with Writer(path, version=8, storage_plugin=plugin) as w:
        odom = w.add_connection("/mocap/bluerov_saab/odom", ODOM, typestore=ts)
        rc = w.add_connection("/mavros/rc/override", rc_type, typestore=ts)
        for i in range(n):
            stamp = T0_NS + i * 100_000_000
            msg = odometry(ts, stamp, pos[i], quat[i], lin[i], ang[i], ros1=False)
            w.write(odom, stamp, ts.serialize_cdr(msg, ODOM))
        for k in range(n // 2 + 1):
            stamp = T0_NS - 50_000_000 + k * 200_000_000
            w.write(rc, stamp, ts.serialize_cdr(ts.types[rc_type](channels=_rc(k)), rc_type))
    if storage == "sqlite3":
        strip_definitions(path)
    return path


def strip_definitions(bag):
    """Make a sqlite3 bag as ROS 2 Humble writes it: schema 3, no message definitions
    (rosbags' writer stores them, as rosbag2 does since Iron)."""
    import sqlite3

    for db in bag.glob("*.db3"):
        con = sqlite3.connect(db)
        con.execute("DROP TABLE message_definitions")
        con.execute("UPDATE schema SET schema_version = 3")
        con.commit()
        con.close()
