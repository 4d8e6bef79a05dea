"""An ArduSub log (DataFlash, MAVLink telemetry, BlueOS) to one validated table.

The format readers (:mod:`._ardusub`, :mod:`._mavlink`) hand over the streams they
found as an :class:`AutopilotStreams`: the states at the state message's stamps, the
servo outputs, the parameters, the battery voltage, the arming and mode changes and
the estimator's status flags, all on the vehicle's own clock (us since boot). Then,
in this order:

1. **armed**: only state samples while the vehicle was armed are used (the longest
   armed stretch; ``armed_only = false`` keeps everything); what was left out is said;
2. **estimator**: states the EKF had no valid estimate of (no horizontal position fix,
   constant-position mode) are left out of the errors (``estimator = "ignore"`` keeps
   them), with the flags' counts;
3. **depth**: a log whose depth stays about 0 (in air, at the surface) is warned about;
4. **thrusters**: the frame (FRAME_CONFIG), the motor-to-output map (SERVOn_FUNCTION)
   and the motor directions (MOT_n_DIRECTION) are read from the log's parameters
   (the mapping may give ``frame``, ``channels``, ``direction`` instead); the sign
   between ArduSub's motor k and the vehicle file's thruster k follows from the
   motor factors and the vehicle's geometry (:func:`._ardupilot.motor_signs`); the
   outputs at each state stamp (zero-order hold) go through the T200 table at the
   logged battery voltage.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

from ..exceptions import LogFormatError
from ..models import Model, Vehicle
from ._ardupilot import FRAMES, MODES, estimator_note, frame_of, motor_channels, motor_signs
from ._read import LogData, log_from_frame
from ._streams import (
    SAMPLING_RULE,
    drop_before_first_command,
    hold_last,
    longest_stretch,
    surface_warning,
    thruster_options,
    thruster_rpm,
    vehicle_frame,
)

__all__ = ["AUTOPILOT_KEYS", "AutopilotStreams", "autopilot_log", "check_thrusters"]

#: Keys of the thruster table of an ArduSub mapping (DataFlash or MAVLink).
THRUSTER_EXTRA = ("channels", "frame")
#: Keys every ArduSub mapping section accepts besides its own messages.
AUTOPILOT_KEYS = ("armed_only", "estimator", "thrusters")

Stream = tuple[np.ndarray, np.ndarray]


@dataclass
class AutopilotStreams:
    """What a format reader found in an ArduSub log (times: int64 us since boot)."""

    src: str
    kind: str
    t_state: np.ndarray
    eta: np.ndarray
    v: np.ndarray
    outputs: Stream  # (t, pwm (M, channels)): output k (1-based) in column k - 1
    outputs_name: str
    params: dict[str, float] = field(default_factory=dict)
    battery: Stream | None = None
    battery_name: str = ""
    armed: Stream | None = None  # (t, 1/0) at arming events or heartbeats
    armed_before: bool | None = None  # the state before the first entry of `armed`
    armed_name: str = ""
    modes: Stream | None = None  # (t, ArduSub mode number)
    status: Stream | None = None  # (t, nav_filter_status / EKF_STATUS_FLAGS)
    status_name: str = ""
    notes: list[str] = field(default_factory=list)

    def take(self, keep: slice) -> None:
        self.t_state, self.eta, self.v = self.t_state[keep], self.eta[keep], self.v[keep]


def _held(t: np.ndarray, stream: Stream, before: Any) -> np.ndarray:
    """The stream's value at each t (zero-order hold), ``before`` ahead of its first."""
    values, ok = hold_last(t, stream[0], stream[1])
    return np.where(ok, values, before)


def _armed(s: AutopilotStreams, cfg: Mapping[str, Any]) -> list[str]:
    """Keep the longest armed stretch (notes say what was left out)."""
    if not cfg.get("armed_only", True):
        return ["armed_only = false: disarmed samples kept"]
    if s.armed is None or not s.armed[0].size:
        return [f"arming: the log holds no arming record ({s.armed_name}); every sample kept"]
    before = s.armed_before if s.armed_before is not None else bool(s.armed[1][0])
    armed = _held(s.t_state, s.armed, before).astype(bool)
    n = armed.size
    start, stop, stretches = longest_stretch(armed)
    if stop == start:
        raise LogFormatError(
            "armed",
            f"{s.src}: the vehicle is disarmed at every state sample ({s.armed_name}): its "
            "thrusters were off. Give a log of a dive, or keep disarmed samples "
            "(armed_only = false in the mapping file).",
        )
    t0 = s.t_state[0]
    span = f"t = {(s.t_state[start] - t0) / 1e6:.3f}..{(s.t_state[stop - 1] - t0) / 1e6:.3f} s"
    note = (
        f"arming ({s.armed_name}): armed in {int(armed.sum())} of {n} state samples; "
        + (f"the longest of {stretches} armed stretches, " if stretches > 1 else "")
        + f"{span} of the log ({stop - start} samples), is used"
    )
    if stop - start < n:
        why = "disarmed, other stretches" if stretches > 1 else "disarmed"
        note += f"; {n - (stop - start)} samples left out ({why})"
    s.take(slice(start, stop))
    return [note]


def _modes(s: AutopilotStreams) -> list[str]:
    if s.modes is None or not s.modes[0].size:
        return []
    held = _held(s.t_state, s.modes, s.modes[1][0]).astype(int)
    names = [f"{MODES.get(int(m), 'mode ' + str(int(m)))}" for m in dict.fromkeys(held.tolist())]
    return [f"flight mode(s) while used: {', '.join(names)}"]


def _estimator(s: AutopilotStreams, cfg: Mapping[str, Any]) -> tuple[list[str], list[str]]:
    how = str(cfg.get("estimator", "check"))
    if how not in ("check", "ignore"):
        raise LogFormatError(
            "mapping", f'mapping file: `estimator` must be "check" or "ignore", got {how!r}.'
        )
    if s.status is None or not s.status[0].size:
        return [], [f"estimator status: the log holds no {s.status_name}; not checked"]
    flags = _held(s.t_state, s.status, s.status[1][0]).astype(np.int64)
    left, notes = estimator_note(flags, s.status_name)
    if how == "ignore" and left:
        return [], [*notes, 'estimator = "ignore": those states are counted all the same']
    return left, notes


def _motors(
    s: AutopilotStreams, model: Model, thr: Mapping[str, Any], direction: np.ndarray | None
) -> tuple[list[int], np.ndarray, list[str]]:
    """Output channel and sign per model input, and the notes saying where from."""
    n_out = s.outputs[1].shape[1]
    if "channels" in thr:
        channels = [int(c) for c in thr["channels"]]
        if len(channels) != model.nu or not all(1 <= c <= n_out for c in channels):
            raise LogFormatError(
                "mapping",
                f"mapping file: [thrusters] channels must list {model.nu} output channels in "
                f"1..{n_out}, got {thr['channels']!r}.",
            )
        signs = np.ones(model.nu) if direction is None else direction
        return channels, signs, [f"outputs: channels {channels} as the mapping file gives them"]
    code, name = frame_of(s.params, model.nu, s.src, thr.get("frame"))
    channels = motor_channels(s.params, model.nu, s.src)
    reverse = np.array(
        [float(s.params.get(f"MOT_{k}_DIRECTION", 1.0)) for k in range(1, model.nu + 1)]
    )
    geometric = motor_signs(cast(Vehicle, model), FRAMES[code][1], s.src)  # 6-DoF: checked
    signs = geometric * reverse if direction is None else direction
    where = "the mapping file" if "frame" in thr else "the log's parameters"
    unused = [c for c in range(1, n_out + 1) if c not in channels]
    notes = [
        f"frame: {name} (FRAME_CONFIG {code}) from {where}; motors 1..{model.nu} on outputs "
        f"{', '.join(str(c) for c in channels)} (SERVOn_FUNCTION); MOT_n_DIRECTION "
        f"{', '.join(f'{r:+.0f}' for r in reverse)}; ArduSub motor k against the vehicle "
        f"file's thruster T_k (factors vs geometry): {', '.join(f'{g:+.0f}' for g in geometric)}",
    ]
    if unused:
        notes.append(
            f"outputs {', '.join(str(c) for c in unused)} drive no motor (SERVOn_FUNCTION): skipped"
        )
    return channels, signs, notes


def _voltage(s: AutopilotStreams, voltage: Any) -> tuple[Any, str, list[str]]:
    if voltage != "logged":
        return voltage, " (the mapping file's supply)", []
    if s.battery is None or not s.battery[0].size:
        return (
            16.0,
            "",
            [f"battery: no {s.battery_name or 'battery'} voltage in the log; T200 table at 16 V"],
        )
    volts = _held(s.t_state, s.battery, s.battery[1][0])
    return volts, f" (logged battery voltage, {s.battery_name})", []


def check_thrusters(thr: Mapping[str, Any], nu: int) -> None:
    """Check an ArduSub thruster table before the log is read (errors name the key)."""
    thruster_options({"voltage": "logged", **thr}, nu, "[thrusters]", THRUSTER_EXTRA, ())
    if "channels" in thr:
        channels = thr["channels"]
        if not (
            isinstance(channels, list)
            and len(channels) == nu
            and all(isinstance(c, int) and 1 <= c <= 16 for c in channels)
        ):
            raise LogFormatError(
                "mapping",
                f"mapping file: [thrusters] channels must list {nu} output channels in 1..16, "
                f"got {channels!r}.",
            )


def autopilot_log(
    s: AutopilotStreams,
    model: Model,
    cfg: Mapping[str, Any],
    thr: Mapping[str, Any],
    mapping_notes: tuple[str, ...] = (),
    **options: Any,
) -> LogData:
    """The validated log of ``model`` from an ArduSub log's streams (module docstring);
    ``cfg`` is the mapping's section, ``thr`` its thruster table; ``options`` as
    :func:`read_log`; ``mapping_notes`` go first among the notes."""
    unit, direction, voltage = thruster_options(
        {"voltage": "logged", **thr}, model.nu, "[thrusters]", THRUSTER_EXTRA, ()
    )
    notes = [f"{s.kind}", *mapping_notes, *s.notes]
    notes += _armed(s, cfg)
    notes += _modes(s)
    unmeasured, est = _estimator(s, cfg)
    notes += est
    warnings = surface_warning(s.eta[:, 2], s.src)
    channels, signs, motor_notes = _motors(s, model, thr, direction)
    notes += motor_notes
    volts, volts_from, volt_notes = _voltage(s, voltage)
    notes += volt_notes
    t_o, pwm = s.outputs
    held, have = hold_last(s.t_state, t_o, pwm[:, [c - 1 for c in channels]])
    if not isinstance(volts, float):
        volts = volts[have]
    rpm, how = thruster_rpm(held[have], unit, signs, volts, s.src, volts_from)
    notes.append(
        f"inputs from {s.outputs_name} outputs {', '.join(str(c) for c in channels)}; {how[0]}"
    )
    notes += how[1:]
    notes.append(f"sampling rule: {SAMPLING_RULE}")
    notes += drop_before_first_command(have, s.src)
    frame = vehicle_frame(model, s.t_state[have], "us", s.eta[have], s.v[have], rpm)
    return log_from_frame(
        frame,
        model,
        source=s.src,
        notes=tuple(notes),
        unmeasured=tuple(unmeasured),
        warnings=tuple(warnings),
        **options,
    )
