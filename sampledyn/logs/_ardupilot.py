"""What an ArduSub log means: frames, motor map, directions, modes, estimator status,
and the MANUAL-mode mixer from pilot inputs to motor outputs.

Sources (ArduPilot, the ArduSub vehicle and its libraries):

* ``libraries/AP_Motors/AP_Motors6DOF.cpp``, ``setup_motors()``: the factors of each
  frame (FRAME_CONFIG 0..6) per motor: roll, pitch, yaw, throttle, forward, lateral;
  ``output_armed_stabilizing_vectored()`` (FRAME_CONFIG 1) and
  ``output_armed_stabilizing_vectored_6dof()`` (FRAME_CONFIG 2): the mix, each motor
  ``MOT_n_DIRECTION * (...)`` clipped to [-1, 1]; ``calc_thrust_to_pwm()``: PWM =
  1500 + thrust (MOT_PWM_MAX - 1500) forward, (1500 - MOT_PWM_MIN) in reverse.
* ``ArduSub/mode_manual.cpp``: in MANUAL the six pilot inputs go straight to the
  mixer, each ``RC_Channel::norm_input()`` = (pwm - trim) / (max - trim) above the
  trim, (pwm - trim) / (trim - min) below, clipped to [-1, 1]; the throttle enters
  as (norm + 1) / 2 and the mixer takes ``2 (throttle - 0.5)``, i.e. norm again.
  Default channel map (RCMAP_*): 1 pitch, 2 roll, 3 throttle, 4 yaw, 5 forward,
  6 lateral; RCn_MIN/TRIM/MAX 1100/1500/1900 us.
* ``libraries/SRV_Channel``: SERVOn_FUNCTION 33..40 are Motor1..Motor8, 82..85
  Motor9..Motor12; 0 is disabled.
* ``libraries/AP_NavEKF/AP_Nav_Common.h`` (``nav_filter_status``, logged as XKF4/NKF4
  ``SS``) and MAVLink's ``EKF_STATUS_FLAGS`` (EKF_STATUS_REPORT ``flags``) share their
  first ten bits: attitude, horizontal velocity, vertical velocity, relative and
  absolute horizontal position, vertical position, terrain height, constant-position
  mode, predicted relative / absolute horizontal position.
* ArduSub's flight modes (``ArduSub/mode.h``, ``Mode::Number``): 0 STABILIZE,
  1 ACRO, 2 ALT_HOLD, 3 AUTO, 4 GUIDED, 7 CIRCLE, 9 SURFACE, 16 POSHOLD, 19 MANUAL,
  20 MOTOR_DETECT. Log events (``AP_Logger``, LogEvent): 10 ARMED, 11 DISARMED.

Not modelled: the later releases' thrust linearisation (MOT_THST_EXPO applied in
``output_to_motors``), the motors' slew limits and the battery current limit (off by
default, MOT_BAT_CURR_MAX = 0), the throttle input filter.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ..exceptions import LogFormatError
from ..models import Vehicle

__all__ = [
    "FRAMES",
    "MODES",
    "RC_AXES",
    "estimator_note",
    "frame_of",
    "manual_mixer",
    "motor_channels",
    "motor_signs",
]

# AXES of the factors, in the order of add_motor_raw_6dof()
_AXES = ("roll", "pitch", "yaw", "throttle", "forward", "lateral")

# FRAME_CONFIG -> (name, factors (motors, 6) in _AXES order), from setup_motors()
FRAMES: dict[int, tuple[str, np.ndarray]] = {
    1: (
        "vectored",
        np.array(
            [
                [0, 0, 1, 0, -1, 1],
                [0, 0, -1, 0, -1, -1],
                [0, 0, -1, 0, 1, 1],
                [0, 0, 1, 0, 1, -1],
                [1, 0, 0, -1, 0, 0],
                [-1, 0, 0, -1, 0, 0],
            ],
            dtype=float,
        ),
    ),
    2: (
        "vectored_6dof",
        np.array(
            [
                [0, 0, 1, 0, -1, 1],
                [0, 0, -1, 0, -1, -1],
                [0, 0, -1, 0, 1, 1],
                [0, 0, 1, 0, 1, -1],
                [1, -1, 0, -1, 0, 0],
                [-1, -1, 0, -1, 0, 0],
                [1, 1, 0, -1, 0, 0],
                [-1, 1, 0, -1, 0, 0],
            ],
            dtype=float,
        ),
    ),
}
_FRAME_NAMES = {name: k for k, (name, _) in FRAMES.items()}

MODES = {
    0: "STABILIZE",
    1: "ACRO",
    2: "ALT_HOLD",
    3: "AUTO",
    4: "GUIDED",
    7: "CIRCLE",
    9: "SURFACE",
    16: "POSHOLD",
    19: "MANUAL",
    20: "MOTOR_DETECT",
}

#: The mixer's axes and their default RC channels (RCMAP_*, 1-based).
RC_AXES = {"pitch": 1, "roll": 2, "throttle": 3, "yaw": 4, "forward": 5, "lateral": 6}

_MOTOR_FUNCTIONS = {**{33 + k: k + 1 for k in range(8)}, **{82 + k: k + 9 for k in range(4)}}

# nav_filter_status / EKF_STATUS_FLAGS bits (the first ten agree)
_ATTITUDE, _VEL_H, _VEL_V, _POS_REL, _POS_ABS, _POS_V = 1, 2, 4, 8, 16, 32
_CONST_POS = 128


def frame_of(
    params: Mapping[str, float], nu: int, src: str, declared: Any = None
) -> tuple[int, str]:
    """The ArduSub frame (FRAME_CONFIG and its name) the log's parameters (or the
    mapping's ``frame``) name, checked against the vehicle's thruster count."""
    if declared is not None:
        if str(declared) not in _FRAME_NAMES:
            raise LogFormatError(
                "mapping",
                f"mapping file: frame {declared!r} is not an ArduSub frame sampledyn knows; "
                f"known: {', '.join(_FRAME_NAMES)}.",
            )
        code, where = _FRAME_NAMES[str(declared)], "the mapping file"
    elif "FRAME_CONFIG" in params:
        code, where = int(params["FRAME_CONFIG"]), "the log's FRAME_CONFIG"
    else:
        raise LogFormatError(
            "mapping",
            f"{src}: the log holds no FRAME_CONFIG parameter; give the frame in the mapping "
            f"file (frame = {' or '.join(repr(n) for n in _FRAME_NAMES)}).",
        )
    if code not in FRAMES:
        raise LogFormatError(
            "vehicle",
            f"{src}: {where} is {code}, a frame sampledyn has no motor factors for; known: "
            + ", ".join(f"{k} ({n})" for k, (n, _) in FRAMES.items())
            + ".",
        )
    name, factors = FRAMES[code]
    if factors.shape[0] != nu:
        fits = {6: "bluerov2", 8: "bluerov2_heavy"}.get(factors.shape[0], "a vehicle with them")
        raise LogFormatError(
            "vehicle",
            f"{src}: {where} is {code} ({name}, {factors.shape[0]} motors) but the vehicle "
            f"has {nu} thrusters; use --vehicle {fits}.",
        )
    return code, name


def motor_channels(params: Mapping[str, float], n_motors: int, src: str) -> list[int]:
    """Servo output (1-based) of motors 1..n_motors from SERVOn_FUNCTION."""
    found: dict[int, int] = {}
    for name, value in params.items():
        if name.startswith("SERVO") and name.endswith("_FUNCTION"):
            motor = _MOTOR_FUNCTIONS.get(int(value))
            if motor is not None:
                found.setdefault(motor, int(name[5:-9]))
    missing = [k for k in range(1, n_motors + 1) if k not in found]
    if missing:
        raise LogFormatError(
            "mapping",
            f"{src}: no SERVOn_FUNCTION parameter assigns Motor{missing[0]} to an output "
            "(33..40 are Motor1..Motor8); give `channels` in the mapping file.",
        )
    return [found[k] for k in range(1, n_motors + 1)]


def motor_signs(model: Vehicle, factors: np.ndarray, src: str) -> np.ndarray:
    """+1 or -1 per motor: whether a positive output of ArduSub motor k pushes along
    the vehicle file's thruster k (a positive rpm). A positive output pushes along
    (forward, lateral, -throttle, roll, pitch, yaw) of its factors (throttle is up,
    body z is down); its sign against the allocation column B[:, k] must be the
    same on every axis the motor acts on, else the vehicle file's thrusters are not
    ArduSub's motors in ArduSub's order."""
    alloc = np.asarray(model.allocation)
    push = factors[:, [4, 5, 3, 0, 1, 2]] * np.array([1, 1, -1, 1, 1, 1])
    signs = np.empty(factors.shape[0])
    for k, w in enumerate(push):
        on = np.flatnonzero(w)
        rel = np.sign(w[on] * alloc[on, k])
        if not rel.size or (rel != rel[0]).any() or rel[0] == 0:
            raise LogFormatError(
                "vehicle",
                f"{src}: thruster T{k + 1} of vehicle {getattr(model, 'name', '?')!r} does not "
                f"act like ArduSub's motor {k + 1} (factors roll, pitch, yaw, throttle, "
                f"forward, lateral = {factors[k].tolist()}); number the vehicle file's "
                "thrusters as ArduSub's motors, or give `channels` and `direction`.",
            )
        signs[k] = rel[0]
    return signs


def estimator_note(flags: np.ndarray, what: str) -> tuple[list[str], list[str]]:
    """(states the estimator had no valid estimate of, notes) from status flags per
    sample (nav_filter_status / EKF_STATUS_FLAGS bits)."""
    flags = np.asarray(flags, dtype=np.int64)
    n = flags.size
    left: list[str] = []
    notes: list[str] = []

    def count(bit: int) -> int:
        return int(((flags & bit) != 0).sum())

    pos = int((((flags & _POS_REL) != 0) | ((flags & _POS_ABS) != 0)).sum())
    const = count(_CONST_POS)
    if pos < n:
        left += ["x", "y"]
        notes.append(
            f"estimator status ({what}): a valid horizontal position in {pos} of {n} "
            f"samples{f', constant-position mode in {const}' if const else ''}: x and y "
            "are the filter's own, not measurements, so they are left out of the errors"
        )
    vel = count(_VEL_H)
    if vel < n:
        left += ["u", "v"]
        notes.append(
            f"estimator status ({what}): a valid horizontal velocity in {vel} of {n} "
            "samples: u and v are left out of the errors"
        )
    if not left:
        notes.append(
            f"estimator status ({what}): attitude, velocity and horizontal position valid "
            f"in all {n} samples"
        )
    return left, notes


def _norm_input(pwm: np.ndarray, lo: float, trim: float, hi: float) -> np.ndarray:
    up = (pwm - trim) / (hi - trim)
    down = (pwm - trim) / (trim - lo)
    return np.clip(np.where(pwm < trim, down, up), -1.0, 1.0)


def manual_mixer(
    rc: np.ndarray,
    frame: int,
    reverse: np.ndarray,
    *,
    axes: Mapping[str, int] = RC_AXES,
    rc_range: tuple[float, float, float] = (1100.0, 1500.0, 1900.0),
    pwm_range: tuple[float, float] = (1100.0, 1900.0),
    coupling: float = 1.0,
) -> np.ndarray:
    """Motor PWM (N, motors) that ArduSub's MANUAL mode outputs for the RC channels
    ``rc`` (N, channels, us; 1-based channel k in column k - 1) on ``frame``
    (FRAME_CONFIG 1 or 2); ``reverse`` is MOT_n_DIRECTION per motor, ``coupling``
    MOT_FV_CPLNG_K (vectored frame). See the module docstring for the source."""
    factors = FRAMES[frame][1]
    lo, trim, hi = rc_range
    a = {name: _norm_input(rc[:, ch - 1], lo, trim, hi) for name, ch in axes.items()}
    roll, pitch, yaw = a["roll"], a["pitch"], a["yaw"]
    thr, fwd, lat = a["throttle"], a["forward"], a["lateral"]
    f = factors.T  # (6, motors)
    if frame == 2:  # output_armed_stabilizing_vectored_6dof: normalise each group
        rpt = roll[:, None] * f[0] + pitch[:, None] * f[1] + thr[:, None] * f[3]
        yfl = yaw[:, None] * f[2] + fwd[:, None] * f[4] + lat[:, None] * f[5]
        rpt_max = np.maximum(1.0, np.abs(rpt).max(axis=1, keepdims=True))
        yfl_max = np.maximum(1.0, np.abs(yfl).max(axis=1, keepdims=True))
        mix = rpt / rpt_max + yfl / yfl_max
    else:  # output_armed_stabilizing_vectored: forward/vertical decoupling
        rpy = roll[:, None] * f[0] + pitch[:, None] * f[1] + yaw[:, None] * f[2]
        limit = np.maximum(0.0, 1.0 - coupling * np.abs(thr))[:, None]
        direction = np.zeros(factors.shape[0])
        direction[:4] = (-1, -1, 1, 1)
        rear = (direction != 0) & ((fwd[:, None] < 0) == (direction < 0)) & (fwd[:, None] != 0)
        fwd_m = np.where(rear, np.clip(fwd[:, None], -limit, limit), fwd[:, None])
        mix = rpy + thr[:, None] * f[3] + fwd_m * f[4] + lat[:, None] * f[5]
    thrust = np.clip(np.asarray(reverse, dtype=float) * mix, -1.0, 1.0)
    pmin, pmax = pwm_range
    return 1500.0 + thrust * np.where(thrust > 0, pmax - 1500.0, 1500.0 - pmin)
