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
    voltage = 16                   # T200 table supply (V, 10..20), for unit = "pwm"

    # RC channels (mavros_msgs/OverrideRCIn, RCIn) are pilot inputs, refused as thruster
    # commands unless the mapping declares ArduSub's MANUAL mode and its mixer:
    [ros.mixer]
    mode = "MANUAL"
    frame = "vectored_6dof"        # or "vectored" (FRAME_CONFIG 2 or 1)
    direction = [1, 1, 1, 1, 1, 1, 1, 1]  # MOT_n_DIRECTION (default +1)
    # channels = { pitch = 1, roll = 2, throttle = 3, yaw = 4, forward = 5, lateral = 6 }

    # or the commanded wrench instead of thrusters (the vehicle's wrench_input):
    [ros.wrench]
    topic = "/tau"                 # geometry_msgs/WrenchStamped (or Wrench, or 6 numbers)
    field = "wrench"
    frame = "flu"                  # body frame of the wrench: "flu" (REP 103) or "frd"

    [ros.types]                    # message types the bag neither embeds nor rosbags knows
    "my_msgs/msg/Thing" = "path/to/Thing.msg"

Message types: rosbags' ROS 2 Humble (ROS 1 Noetic) type store, the definitions a bag
embeds, mavros_msgs OverrideRCIn, RCIn, RCOut, State, ManualControl
(:mod:`._mavros_msgs`), and ``[ros.types]``; all registered after the bag is opened
(rosbags ignores its default type store once any connection embeds a definition).

Odometry frame check: the logged position increments are compared with the
kinematics (6) under the body-frame and the world-frame reading of the twist
(:func:`._frames.twist_frame_fit`); the notes say which fits, and a warning comes when
the mapping's ``twist_frame`` fits worse by more than :data:`FRAME_FIT_RATIO`.

Frames and units (:mod:`._frames`): positions ENU -> NED, orientation quaternion
(body FLU to world ENU) -> R_NED,FRD -> ZYX Euler angles, twist FLU -> FRD; ROS
uses SI units (m, m/s, rad/s). Time: a message's ``header.stamp`` (the time the data
refer to); the bag's record time only for a message without a header. Sampling rule:
:mod:`._streams` (states at the state message's stamps, inputs a zero-order hold).
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import numpy as np

from .._files import read_text, regular_file
from ..exceptions import LogFormatError
from ..models import Model, Vehicle
from ._ardupilot import FRAMES, RC_AXES, manual_mixer, motor_signs
from ._frames import BODY_FRAMES, WORLD_FRAMES, quaternion_matrix, to_ned_frd, twist_frame_fit
from ._mapping import check_keys
from ._mavros_msgs import MAVROS_MSGS, PILOT_INPUTS
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

__all__ = ["FRAME_FIT_RATIO", "read_bag"]

_ROS_KEYS = (
    "odometry", "pose", "twist", "world_frame", "body_frame", "twist_frame",
    "thrusters", "wrench", "mixer", "types",
)  # fmt: skip
_MIXER_KEYS = ("mode", "frame", "direction", "channels", "rc_min", "rc_trim", "rc_max")
_WRENCH_KEYS = ("topic", "field", "frame")
_NO_CHANGE, _RELEASE = 65535, 0  # OverrideRCIn CHAN_NOCHANGE, CHAN_RELEASE

#: The mapping's twist frame is warned about when its residual in the kinematics (6)
#: is this many times the other reading's: below it the two are too alike to tell
#: (a vehicle that hardly turns: R nearly constant).
FRAME_FIT_RATIO = 1.5


@dataclass
class _Config:
    world: str
    body: str
    twist_frame: str
    state_topics: list[str]
    inputs: Mapping[str, Any]
    wrench: bool
    mixer: Mapping[str, Any] | None
    types: Mapping[str, Any]
    odometry: bool
    notes: list[str] = field(default_factory=list)

    @property
    def input_topics(self) -> list[str]:
        if "topics" in self.inputs:
            return [str(t) for t in self.inputs["topics"]]
        return [str(self.inputs["topic"])]


def _field(msg: Any, path: str, topic: str) -> Any:
    """The field ``path`` ("twist.linear.x") of a message: message fields only (the
    dataclass fields rosbags declares), never other Python attributes (a mapping that
    names ``__class__.__mro__`` is refused like any unknown field)."""
    obj = msg
    for part in path.split("."):
        fields = getattr(type(obj), "__dataclass_fields__", {})
        if part not in fields or part.startswith("__"):
            have = [f for f in fields if not f.startswith("__")]
            raise LogFormatError(
                "mapping",
                f"mapping file: messages on {topic!r} ({getattr(msg, '__msgtype__', '?')}) have no "
                f"field {path!r}: {part!r} is not among {', '.join(have) or 'no fields'}.",
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


def _choice(ros: Mapping[str, Any], key: str, default: str, allowed: Any) -> str:
    value = str(ros.get(key, default))
    if value not in allowed:
        raise LogFormatError(
            "mapping",
            f"mapping file: [ros] {key} must be one of {', '.join(allowed)}, got {value!r}.",
        )
    return value


def _config(model: Model, mapping: Any, src: str) -> _Config:
    ros, inputs = mapping_section(model, mapping, "ros", _ROS_KEYS, src, "a bag")
    world = _choice(ros, "world_frame", "enu", WORLD_FRAMES)
    body = _choice(ros, "body_frame", "flu", BODY_FRAMES)
    twist_frame = _choice(ros, "twist_frame", "body", ("body", "world"))
    if ("odometry" in ros) == ("pose" in ros or "twist" in ros) or (
        "odometry" not in ros and not ("pose" in ros and "twist" in ros)
    ):
        raise LogFormatError(
            "mapping",
            "mapping file: [ros] needs either `odometry` or both `pose` and `twist` topics.",
        )
    wrench = "wrench" in ros
    if wrench:
        check_keys(inputs, _WRENCH_KEYS, "[ros.wrench]", required=["topic"])
    elif ("topic" in inputs) == ("topics" in inputs):
        raise LogFormatError(
            "mapping", "mapping file: [ros.thrusters] needs `topic` or `topics` (one of them)."
        )
    if "topics" in inputs and len(inputs["topics"]) != model.nu:
        raise LogFormatError(
            "mapping",
            f"mapping file: [ros.thrusters] topics lists {len(inputs['topics'])} topics; the "
            f"model has {model.nu} inputs.",
        )
    mixer = ros.get("mixer")
    if mixer is not None:
        check_keys(mixer, _MIXER_KEYS, "[ros.mixer]", required=["mode", "frame"])
    types = ros.get("types", {})
    if not isinstance(types, Mapping):
        raise LogFormatError("mapping", "mapping file: [ros.types] must be a table.")
    states = [str(ros["odometry"])] if "odometry" in ros else [str(ros["pose"]), str(ros["twist"])]
    return _Config(
        world, body, twist_frame, states, inputs, wrench, mixer, types, "odometry" in ros
    )


def _regular_bag(path: Path) -> None:
    """A bag's files must be regular files (a FIFO or /dev/zero as metadata.yaml would
    block or fill the memory in the YAML reader); metadata.yaml is bounded in size."""
    if path.is_dir():
        regular_file(path / "metadata.yaml", "bag metadata")
        for part in path.iterdir():
            if part.suffix.lower() in (".db3", ".mcap"):
                regular_file(part, "bag file", limit=None)
    else:
        regular_file(path, "bag file", limit=None)


def _open(path: Path) -> tuple[Any, str]:
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise ImportError(
            "reading ROS bags needs the `rosbags` package: pip install 'sampledyn[ros]'."
        ) from exc
    if not path.exists():
        raise FileNotFoundError(f"no bag {str(path)!r}.")
    if path.is_file() and path.suffix.lower() in (".db3", ".mcap"):
        if (path.parent / "metadata.yaml").is_file():
            path = path.parent  # the bag's directory: its metadata (and every split file)
    elif path.is_dir() and not (path / "metadata.yaml").is_file():
        files = sorted(p for p in path.iterdir() if p.suffix in (".db3", ".mcap"))
        if len(files) != 1:
            raise LogFormatError(
                "data",
                f"{path.name}: a bag directory without metadata.yaml must hold one .db3 or "
                f".mcap file, it holds {len(files)}; name the file.",
            )
        path = files[0]
    _regular_bag(path)
    ros1 = path.suffix.lower() == ".bag"
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    return AnyReader([path], default_typestore=store), ("ROS 1" if ros1 else "ROS 2")


def _register_types(reader: Any, extra: Mapping[str, Any], src: str) -> None:
    """Add the default store's, mavros_msgs' and the mapping's types the reader lacks."""
    from rosbags.typesys import get_types_from_msg

    have = reader.typestore.fielddefs
    add: dict[str, Any] = {
        k: v for k, v in reader.default_typestore.fielddefs.items() if k not in have
    }
    for name, text in MAVROS_MSGS.items():
        if name not in have:
            add.update(get_types_from_msg(text, name))
    for name, file in extra.items():
        msg = Path(str(file))
        if not msg.is_file():
            raise LogFormatError(
                "mapping", f"mapping file: [ros.types] {name!r}: no .msg file {str(msg)!r}."
            )
        add.update(get_types_from_msg(read_text(msg, "message definition"), str(name)))
    reader.typestore.register({k: v for k, v in add.items() if k not in have})


def _deserialize(reader: Any, raw: bytes, conn: Any, src: str) -> Any:
    try:
        return reader.deserialize(raw, conn.msgtype)
    except KeyError as exc:
        raise LogFormatError(
            "mapping",
            f"{src}: topic {conn.topic!r} has type {conn.msgtype!r}, which the bag does not "
            f"embed and sampledyn does not know (missing definition {exc.args[0]!r}); give "
            'its .msg file in the mapping file: [ros.types] "'
            + conn.msgtype
            + '" = "path/to/'
            + conn.msgtype.rsplit("/", 1)[-1]
            + '.msg".',
        ) from None


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
        c.topic: (c.msgtype, [], [], []) for c in conns
    }
    for conn, record_ns, raw in reader.messages(connections=conns):
        msg = _deserialize(reader, raw, conn, src)
        stamp, header = _stamp(msg, int(record_ns))
        _, stamps, msgs, headers = out[conn.topic]
        stamps.append(stamp)
        msgs.append(msg)
        headers.append(header)
    result = {}
    for topic, (msgtype, stamps, msgs, headers) in out.items():
        if not msgs:
            raise LogFormatError(
                "mapping",
                f"{src}: topic {topic!r} ({msgtype}) holds no message"
                + (" (nothing was recorded on it)." if topic in topics else "."),
            )
        result[topic] = (msgtype, np.array(stamps, dtype=np.int64), msgs, all(headers))
    return result


def _stamp_rule(topic: str, msgtype: str, header: bool) -> str:
    return f"{topic} ({msgtype}, {'header stamps' if header else 'no header: record time'})"


def _frame_check(
    cfg: _Config,
    t_ns: np.ndarray,
    position: np.ndarray,
    R: np.ndarray,
    linear: np.ndarray,
    src: str,
) -> tuple[list[str], list[str]]:
    """Notes (and a warning) on which reading of the twist fits the kinematics (6)."""
    if t_ns.size < 3:
        return [], []
    body, world, moved = twist_frame_fit(
        (t_ns - t_ns[0]) / 1e9, position, R, linear, world=cfg.world, body=cfg.body
    )
    fits = {"body": body, "world": world}
    better = min(fits, key=fits.__getitem__)
    other = "world" if better == "body" else "body"
    ratio = fits[other] / fits[better] if fits[better] > 0 else np.inf
    note = (
        f"odometry frame check, kinematics (6): position increments (rms {moved:.3g} m) "
        f"against the integrated twist read in the body frame: residual {body:.3g} m, in "
        f"the world frame: {world:.3g} m"
    )
    if ratio < FRAME_FIT_RATIO:
        return [note + f"; the two readings fit alike (ratio {ratio:.3g}), not told apart"], []
    note += f"; the {better} frame fits ({ratio:.3g} times better)"
    warn = []
    if better != cfg.twist_frame:
        warn.append(
            f"{src}: the mapping reads the twist in the {cfg.twist_frame} frame, but the "
            f"{better}-frame reading fits the logged positions {ratio:.3g} times better "
            f"(kinematics (6)); set twist_frame = {better!r} in [ros] if the source logs it so"
        )
    return [note], warn


def _states(
    cfg: _Config, streams: Any, src: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str], list[str]]:
    """States at the stamps of the pose (or odometry) messages, and their notes."""
    ptype, t_state, pmsgs, pheader = streams[cfg.state_topics[0]]
    poses = [_unwrap(m.pose, "pose") for m in pmsgs]
    position = np.array([[p.position.x, p.position.y, p.position.z] for p in poses])
    quat = np.array(
        [[p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w] for p in poses]
    )
    notes = [f"states from {_stamp_rule(cfg.state_topics[0], ptype, pheader)}"]
    if cfg.odometry:
        twists = [_unwrap(m.twist, "twist") for m in pmsgs]
    else:
        ttype, t_twist, tmsgs, theader = streams[cfg.state_topics[1]]
        idx, offset = nearest(t_state, t_twist, np.arange(t_twist.size))
        twists = [_unwrap(tmsgs[i].twist, "twist") for i in idx]
        notes.append(
            f"twist from {_stamp_rule(cfg.state_topics[1], ttype, theader)}, the message nearest "
            f"each pose stamp (at most {offset / 1e9:.3g} s away)"
        )
    linear = np.array([[w.linear.x, w.linear.y, w.linear.z] for w in twists])
    angular = np.array([[w.angular.x, w.angular.y, w.angular.z] for w in twists])
    R = quaternion_matrix(quat)
    eta, v = to_ned_frd(
        position, R, linear, angular,
        world=cfg.world, body=cfg.body, twist_in_world=cfg.twist_frame == "world",
    )  # fmt: skip
    notes.append(
        f"frames: world {cfg.world.upper()} -> NED, body {cfg.body.upper()} -> FRD, "
        f"quaternion -> ZYX Euler angles, twist in the {cfg.twist_frame} frame"
    )
    check, warn = _frame_check(cfg, t_state, position, R, linear, src)
    return t_state, eta, v, notes + check, warn


def _rc_channels(values: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """RC channel values with 65535 (no change) held and 0 (release) as neutral."""
    out = values.astype(float).copy()
    notes = []
    nochange = out == _NO_CHANGE
    if nochange.any():
        for j in range(out.shape[1]):
            col = out[:, j]
            good = ~nochange[:, j]
            idx = np.where(good, np.arange(col.size), 0)
            idx = np.maximum.accumulate(idx)
            held = np.where(good[idx], col[idx], 1500.0)
            out[:, j] = held
        notes.append("RC 65535 (CHAN_NOCHANGE) holds the channel's last value (1500 us before any)")
    release = values == _RELEASE
    if release.any():
        out[release] = 1500.0
        notes.append(
            "RC 0 (CHAN_RELEASE) hands the channel back to the RC input, taken as neutral 1500 us"
        )
    return out, notes


def _mixed(
    cfg: _Config, model: Model, channels: np.ndarray, src: str, topic: str
) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Motor PWM from RC channels by ArduSub's MANUAL mixer; signs per motor."""
    mixer = cfg.mixer
    assert mixer is not None
    if str(mixer["mode"]).upper() != "MANUAL":
        raise LogFormatError(
            "mapping",
            f"mapping file: [ros.mixer] mode {mixer['mode']!r}: only ArduSub's MANUAL mode "
            "passes the pilot inputs to the motors without a controller; the others close "
            "loops sampledyn does not model.",
        )
    names = {v: k for k, (v, _) in FRAMES.items()}
    frame = str(mixer["frame"])
    if frame not in names:
        raise LogFormatError(
            "mapping",
            f"mapping file: [ros.mixer] frame {frame!r}; known: {', '.join(names)}.",
        )
    code = names[frame]
    factors = FRAMES[code][1]
    if factors.shape[0] != model.nu:
        raise LogFormatError(
            "vehicle",
            f"{src}: [ros.mixer] frame {frame!r} has {factors.shape[0]} motors, the vehicle "
            f"{model.nu} thrusters.",
        )
    reverse = np.asarray(mixer.get("direction", [1] * model.nu), dtype=float)
    axes = {**RC_AXES, **dict(mixer.get("channels", {}))}
    need = max(axes.values())
    if channels.shape[1] < need:
        raise LogFormatError(
            "mapping",
            f"{src}: {topic!r} holds {channels.shape[1]} RC channels, the mixer reads "
            f"channel {need}.",
        )
    rc_range = (
        float(mixer.get("rc_min", 1100)),
        float(mixer.get("rc_trim", 1500)),
        float(mixer.get("rc_max", 1900)),
    )
    pwm = manual_mixer(channels, code, reverse, axes=axes, rc_range=rc_range)
    signs = motor_signs(cast(Vehicle, model), factors, src) * reverse  # 6-DoF: checked
    note = (
        f"RC channels are pilot inputs: motor outputs from ArduSub's MANUAL-mode mixer "
        f"(AP_Motors6DOF, frame {frame}, FRAME_CONFIG {code}), as the mapping declares; "
        + ", ".join(f"{k} {v}" for k, v in axes.items())
        + f"; RC {rc_range[0]:g}/{rc_range[1]:g}/{rc_range[2]:g} us; MOT_n_DIRECTION "
        + ", ".join(f"{r:+.0f}" for r in reverse)
    )
    return pwm, signs, [note]


def _command_values(
    cfg: _Config, streams: Any, t_state: np.ndarray, model: Model, src: str
) -> tuple[np.ndarray, np.ndarray, list[str], list[str]]:
    """Commands at each state stamp (zero-order hold), the mask of stamps with one,
    the sources, notes."""
    fld = str(cfg.inputs.get("field", "wrench" if cfg.wrench else "data"))
    width = 6 if cfg.wrench else model.nu
    cmds = np.empty((t_state.size, width))
    have = np.ones(t_state.size, dtype=bool)
    sources: list[str] = []
    for j, topic in enumerate(cfg.input_topics):
        ctype, t_cmd, cmsgs, cheader = streams[topic]
        sources.append(_stamp_rule(topic, ctype, cheader))
        if ctype in PILOT_INPUTS and cfg.mixer is None:
            raise LogFormatError(
                "thrusters",
                f"{src}: topic {topic!r} ({ctype}) holds pilot inputs (RC channels or sticks), "
                "not motor commands: read as thruster PWM they would give every thruster the "
                "stick of one axis. Give the motor outputs (e.g. /mavros/rc/out, "
                "mavros_msgs/msg/RCOut), or declare ArduSub's MANUAL-mode mixer in the "
                'mapping file ([ros.mixer] mode = "MANUAL", frame = ...).',
            )
        values = np.array([_values(_field(m, fld, topic), cfg.wrench) for m in cmsgs])
        if cfg.mixer is not None:
            if ctype == "mavros_msgs/msg/ManualControl":
                raise LogFormatError(
                    "thrusters",
                    f"{src}: {topic!r} ({ctype}) holds joystick axes, which the mixer does not "
                    "take; give the RC channels (OverrideRCIn, RCIn).",
                )
            held, ok = hold_last(t_state, t_cmd, values)
            cmds, have = held, ok
            break
        if "topics" in cfg.inputs:
            held, ok = hold_last(t_state, t_cmd, values[:, 0])
            cmds[:, j] = held
        else:
            index = list(cfg.inputs.get("index", range(width)))
            if len(index) != width or max(index) >= values.shape[1] or min(index) < 0:
                raise LogFormatError(
                    "mapping",
                    f"mapping file: [ros.thrusters] index {index} does not pick {width} "
                    f"elements of {topic!r} {fld!r} (length {values.shape[1]}).",
                )
            held, ok = hold_last(t_state, t_cmd, values[:, index])
            cmds = held
        have &= ok
    return cmds, have, sources, []


def _values(obj: Any, wrench: bool) -> np.ndarray:
    """A message field as numbers: an array, a scalar, or a Wrench (force, torque)."""
    if wrench and hasattr(obj, "force"):
        f, m = obj.force, obj.torque
        return np.array([f.x, f.y, f.z, m.x, m.y, m.z], dtype=float)
    return np.atleast_1d(np.asarray(obj, dtype=float))


def _inputs(
    cfg: _Config, streams: Any, t_state: np.ndarray, model: Model, src: str
) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """The model's inputs at each state stamp (rpm or wrench), the mask, notes."""
    cmds, have, sources, notes = _command_values(cfg, streams, t_state, model, src)
    where = ", ".join(dict.fromkeys(sources))
    if cfg.wrench:
        frame = str(cfg.inputs.get("frame", "flu"))
        if frame not in BODY_FRAMES:
            raise LogFormatError(
                "mapping", f"mapping file: [ros.wrench] frame must be flu or frd, got {frame!r}."
            )
        F = BODY_FRAMES[frame]
        tau = np.column_stack([cmds[:, :3] @ F.T, cmds[:, 3:6] @ F.T])
        return (
            tau,
            have,
            [
                f"inputs: the commanded wrench from {where} (N, N m), body {frame.upper()} "
                "-> FRD; thrusters bypassed"
            ],
        )
    unit, direction, voltage = thruster_options(
        cfg.inputs, model.nu, "[ros.thrusters]", ("topic", "topics", "field", "index"), ()
    )
    if voltage == "logged":
        raise LogFormatError(
            "mapping",
            'mapping file: [ros.thrusters] voltage = "logged" needs a battery topic; give '
            "the supply in V.",
        )
    signs = np.ones(model.nu) if direction is None else direction
    if cfg.mixer is not None:
        channels, rc_notes = _rc_channels(cmds)
        cmds, mixer_signs, mix_notes = _mixed(cfg, model, channels, src, cfg.input_topics[0])
        signs = mixer_signs if direction is None else direction
        notes += rc_notes + mix_notes
    rpm, how = thruster_rpm(cmds, unit, signs, float(voltage), src)
    return rpm, have, [f"inputs from {where}; {how[0]}", *notes, *how[1:]]


def read_bag(path: Path, model: Model, *, mapping: Any = None, **options: Any) -> LogData:
    """Read a ROS 2 bag (directory, ``.db3`` or ``.mcap``, with or without its
    ``metadata.yaml``) or a ROS 1 ``.bag`` of a vehicle through a mapping file (module
    docstring); ``options`` as :func:`read_log`. Returns :class:`LogData`; the notes
    say where each quantity came from, the frames and the sampling rule."""
    path = Path(path)
    src = path.name
    cfg = _config(model, mapping, src)
    reader, kind = _open(path)
    from rosbags.highlevel import AnyReaderError

    try:
        with reader:
            _register_types(reader, cfg.types, src)
            streams = _collect(
                reader, list(dict.fromkeys(cfg.state_topics + cfg.input_topics)), src
            )
    except AnyReaderError as exc:
        raise LogFormatError("data", f"{src}: not a readable {kind} bag: {exc}") from exc
    t_state, eta, v, notes, warns = _states(cfg, streams, src)
    u, have, input_notes = _inputs(cfg, streams, t_state, model, src)
    notes = [f"{kind} bag; {notes[0]}", *notes[1:], *input_notes, f"sampling rule: {SAMPLING_RULE}"]
    notes.extend(drop_before_first_command(have, src))
    frame = vehicle_frame(model, t_state[have], "ns", eta[have], v[have], u[have])
    return log_from_frame(
        frame, model, source=src, notes=tuple(notes), warnings=tuple(warns), **options
    )
