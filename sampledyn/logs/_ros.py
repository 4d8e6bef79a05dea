"""ROS 2 and ROS 1 bags (through ``rosbags``; ``pip install 'sampledyn[ros]'``).

A mapping file (TOML) names the topics and frames::

    [ros]
    odometry = "/bluerov2/odom"  # nav_msgs/Odometry: pose (world) and twist (child frame)
    # or: pose = "/pose" (PoseStamped / PoseWithCovarianceStamped)
    #     twist = "/twist" (TwistStamped / TwistWithCovarianceStamped)
    world_frame = "enu"          # "enu" (REP 103, default) or "ned"
    body_frame = "flu"           # "flu" (REP 103, default) or "frd"
    twist_frame = "body"         # "body" (default; Odometry's child frame) or "world"

    [ros.thrusters]
    topic = "/bluerov2/thrusters"  # one message holds every thruster (an array field)
    field = "data"                 # dotted path to the array (or scalar) in the message
    index = [0, 1, 2, 3, 4, 5, 6, 7]  # optional: element per model input
    # or: topics = ["/t1", ..., "/t8"] with a scalar `field` in each
    unit = "rpm"                   # rpm, rps, rev/s, rad/s, or "pwm" (us, T200 table)
    direction = [1, 1, 1, 1, 1, 1, 1, 1]  # optional sign per model input
    voltage = 16                   # T200 table supply (V), for unit = "pwm"

Frames and units (:mod:`._frames`): positions ENU -> NED, orientation quaternion
(body FLU to world ENU) -> R_NED,FRD -> ZYX Euler angles, twist FLU -> FRD; ROS
uses SI units (m, m/s, rad/s). Time: a message's ``header.stamp`` (the time the data
refer to); the bag's record time only for a message without a header. Sampling rule:
:mod:`._streams` (states at the state message's stamps, inputs a zero-order hold).
"""

from __future__ import annotations

import difflib
from pathlib import Path
from typing import Any

import numpy as np

from ._frames import BODY_FRAMES, WORLD_FRAMES, quaternion_matrix, to_ned_frd
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

__all__ = ["read_bag"]

_ROS_KEYS = ("odometry", "pose", "twist", "world_frame", "body_frame", "twist_frame", "thrusters")


def _field(msg: Any, path: str, topic: str) -> Any:
    obj = msg
    for part in path.split("."):
        if not hasattr(obj, part):
            have = [f for f in getattr(type(obj), "__dataclass_fields__", {}) if f != "__msgtype__"]
            raise LogFormatError(
                "mapping",
                f"mapping file: messages on {topic!r} ({getattr(msg, '__msgtype__', '?')}) have no "
                f"field {path!r}: {part!r} is not among {', '.join(have)}.",
            )
        obj = getattr(obj, part)
    return obj


def _stamp(msg: Any, record_ns: int) -> tuple[int, bool]:
    """The message's header stamp (ns), or the record time if it has no header."""
    header = getattr(msg, "header", None)
    if header is None:
        return record_ns, False
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec), True


def _unwrap(obj: Any, inner: str) -> Any:
    """PoseWithCovariance.pose / TwistWithCovariance.twist -> the Pose / Twist."""
    return getattr(obj, inner) if hasattr(obj, inner) else obj


def _open(path: Path) -> tuple[Any, str]:
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise ImportError(
            "reading ROS bags needs the `rosbags` package: pip install 'sampledyn[ros]'."
        ) from exc
    if path.is_file() and path.suffix.lower() in (".db3", ".mcap"):
        path = path.parent
    if not path.exists():
        raise FileNotFoundError(f"no bag {str(path)!r}.")
    ros1 = path.is_file()
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    return AnyReader([path], default_typestore=store), ("ROS 1" if ros1 else "ROS 2")


def _collect(
    reader: Any, topics: list[str], src: str
) -> dict[str, tuple[str, np.ndarray, list[Any], bool]]:
    """topic -> (message type, stamps (ns), messages, stamped by header)."""
    have = sorted({c.topic for c in reader.connections})
    for topic in topics:
        if topic not in have:
            close = difflib.get_close_matches(topic, have, n=1)
            raise LogFormatError(
                "mapping",
                f"{src}: the mapping file names topic {topic!r}"
                + (f" (did you mean {close[0]!r}?)" if close else "")
                + f", which the bag does not have; it has {', '.join(have)}.",
            )
    conns = [c for c in reader.connections if c.topic in topics]
    out: dict[str, tuple[str, list[int], list[Any], list[bool]]] = {
        t: ("", [], [], []) for t in topics
    }
    for conn, record_ns, raw in reader.messages(connections=conns):
        msg = reader.deserialize(raw, conn.msgtype)
        stamp, header = _stamp(msg, int(record_ns))
        _, stamps, msgs, headers = out[conn.topic]
        out[conn.topic] = (conn.msgtype, stamps, msgs, headers)
        stamps.append(stamp)
        msgs.append(msg)
        headers.append(header)
    result = {}
    for topic, (msgtype, stamps, msgs, headers) in out.items():
        if not msgs:
            raise LogFormatError("mapping", f"{src}: topic {topic!r} holds no message.")
        result[topic] = (msgtype, np.array(stamps, dtype=np.int64), msgs, all(headers))
    return result


def _stamp_rule(topic: str, msgtype: str, header: bool) -> str:
    return f"{topic} ({msgtype}, {'header stamps' if header else 'no header: record time'})"


def read_bag(path: Path, model: Any, *, mapping: Any = None, **options: Any) -> LogData:
    """Read a ROS 2 bag (directory, ``.db3`` or ``.mcap``) or a ROS 1 ``.bag`` of a
    vehicle through a mapping file (module docstring); ``options`` as
    :func:`read_log`. Returns :class:`LogData`; the notes say where each quantity came
    from, the frames and the sampling rule."""
    path = Path(path)
    src = path.name
    ros, thr = mapping_section(model, mapping, "ros", _ROS_KEYS, src, "a bag")
    world = str(ros.get("world_frame", "enu"))
    body = str(ros.get("body_frame", "flu"))
    twist_frame = str(ros.get("twist_frame", "body"))
    for key, value, allowed in (
        ("world_frame", world, WORLD_FRAMES),
        ("body_frame", body, BODY_FRAMES),
        ("twist_frame", twist_frame, ("body", "world")),
    ):
        if value not in allowed:
            raise LogFormatError(
                "mapping",
                f"mapping file: [ros] {key} must be one of {', '.join(allowed)}, got {value!r}.",
            )
    if ("odometry" in ros) == ("pose" in ros or "twist" in ros) or (
        "odometry" not in ros and not ("pose" in ros and "twist" in ros)
    ):
        raise LogFormatError(
            "mapping",
            "mapping file: [ros] needs either `odometry` or both `pose` and `twist` topics.",
        )
    unit, direction, voltage = thruster_options(
        thr, model.nu, "[ros.thrusters]", ("topic", "topics", "field", "index"), ()
    )
    if ("topic" in thr) == ("topics" in thr):
        raise LogFormatError(
            "mapping", "mapping file: [ros.thrusters] needs `topic` or `topics` (one of them)."
        )
    field = str(thr.get("field", "data"))
    cmd_topics = [str(thr["topic"])] if "topic" in thr else [str(t) for t in thr["topics"]]
    if "topics" in thr and len(cmd_topics) != model.nu:
        raise LogFormatError(
            "mapping",
            f"mapping file: [ros.thrusters] topics lists {len(cmd_topics)} topics; the model "
            f"has {model.nu} inputs.",
        )
    state_topics = (
        [str(ros["odometry"])] if "odometry" in ros else [str(ros["pose"]), str(ros["twist"])]
    )

    reader, kind = _open(path)
    from rosbags.highlevel import AnyReaderError

    try:
        with reader:
            streams = _collect(reader, list(dict.fromkeys(state_topics + cmd_topics)), src)
    except AnyReaderError as exc:
        raise LogFormatError("data", f"{src}: not a readable {kind} bag: {exc}") from exc

    # states at the stamps of the pose (or odometry) messages
    ptype, t_state, pmsgs, pheader = streams[state_topics[0]]
    poses = [_unwrap(m.pose, "pose") for m in pmsgs]
    position = np.array([[p.position.x, p.position.y, p.position.z] for p in poses])
    quat = np.array(
        [[p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w] for p in poses]
    )
    notes = [f"{kind} bag; states from {_stamp_rule(state_topics[0], ptype, pheader)}"]
    if "odometry" in ros:
        twists = [_unwrap(m.twist, "twist") for m in pmsgs]
    else:
        ttype, t_twist, tmsgs, theader = streams[state_topics[1]]
        idx, offset = nearest(t_state, t_twist, np.arange(t_twist.size))
        twists = [_unwrap(tmsgs[i].twist, "twist") for i in idx]
        notes.append(
            f"twist from {_stamp_rule(state_topics[1], ttype, theader)}, the message nearest "
            f"each pose stamp (at most {offset / 1e9:.3g} s away)"
        )
    linear = np.array([[w.linear.x, w.linear.y, w.linear.z] for w in twists])
    angular = np.array([[w.angular.x, w.angular.y, w.angular.z] for w in twists])
    eta, v = to_ned_frd(
        position,
        quaternion_matrix(quat),
        linear,
        angular,
        world=world,
        body=body,
        twist_in_world=twist_frame == "world",
    )
    notes.append(
        f"frames: world {world.upper()} -> NED, body {body.upper()} -> FRD, quaternion -> ZYX "
        f"Euler angles, twist in the {twist_frame} frame"
    )

    # inputs: zero-order hold of the last command at or before each state stamp
    cmds = np.empty((t_state.size, model.nu))
    have = np.ones(t_state.size, dtype=bool)
    sources = []
    for j, topic in enumerate(cmd_topics):
        ctype, t_cmd, cmsgs, cheader = streams[topic]
        sources.append(_stamp_rule(topic, ctype, cheader))
        values = np.array(
            [np.atleast_1d(np.asarray(_field(m, field, topic), dtype=float)) for m in cmsgs]
        )
        if "topic" in thr:
            index = list(thr.get("index", range(model.nu)))
            if len(index) != model.nu or max(index) >= values.shape[1] or min(index) < 0:
                raise LogFormatError(
                    "mapping",
                    f"mapping file: [ros.thrusters] index {index} does not pick {model.nu} "
                    f"elements of {topic!r} {field!r} (length {values.shape[1]}).",
                )
            held, ok = hold_last(t_state, t_cmd, values[:, index])
            cmds[:] = held
        else:
            held, ok = hold_last(t_state, t_cmd, values[:, 0])
            cmds[:, j] = held
        have &= ok
    rpm, how = thruster_rpm(cmds, unit, direction, voltage, src)
    notes.append(f"inputs from {', '.join(dict.fromkeys(sources))}; {how}")
    notes.append(f"sampling rule: {SAMPLING_RULE}")
    notes.extend(drop_before_first_command(have, src))
    frame = vehicle_frame(model, t_state[have], "ns", eta[have], v[have], rpm[have])
    return log_from_frame(frame, model, source=src, notes=tuple(notes), **options)
