"""A vehicle with a roll-pitch attitude hold on its vertical thrusters.

Not in the paper: its Fig. 6 input is open loop. On a vehicle with a small righting
arm (the BlueROV2 Heavy has BG = 1 cm, a maximum righting moment W BG = 1.3 N m) the
Fig. 6 forward thrust, applied 8.5 cm below the centre of gravity, pitches the vehicle
over, and the vertical thrusters' sinusoids drive roll near its natural frequency. A
PD hold on roll and pitch keeps the attitude small, as in the paper's run, while the
Fig. 6 rpm stay the reference of every thruster:

    n = n_ref + Delta n(x),   Delta n = P (-(k_p (phi, theta) + k_d (p, q))) / (2 K1 n_lin)

P (N_thr x 2) maps desired roll and pitch moments (N m) to vertical thrust increments
(minimum norm, no net heave); the division converts thrust to rpm about the operating
point n_lin. The applied rpm ``n`` is what the thrusters turn at and what a log would
record; the model's input is the reference ``n_ref``.

The hold is a :class:`~sampledyn.models.LinearFeedback` law closed around the vehicle
by :class:`~sampledyn.models.ClosedLoop`; the vehicle's kernel knows nothing of it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _checks as checks
from ._closed_loop import ClosedLoop, LinearFeedback

__all__ = ["AttitudeHold", "roll_pitch_hold"]

# State indices of (phi, theta, p, q) in (eta, v).
_ATTITUDE = (3, 4, 9, 10)


def _vertical_map(vehicle: Any) -> np.ndarray:
    """P (N_thr x 2): roll and pitch moments (N m) -> thrust increments (N) of the
    vertical thrusters, minimum norm, with no net heave force."""
    d = np.asarray(vehicle.thruster_directions, dtype=float)
    vertical = np.abs(d[:, 2]) > np.hypot(d[:, 0], d[:, 1])
    if vertical.sum() < 2:
        raise ValueError("`vehicle` needs at least 2 vertical thrusters for the attitude hold.")
    alloc = np.asarray(vehicle.allocation)  # rows: X, Y, Z, K, M, N
    rows = np.vstack([alloc[2][vertical], alloc[3:5][:, vertical]])  # heave kept out
    p_map = np.zeros((d.shape[0], 2))
    p_map[vertical] = np.linalg.pinv(rows)[:, 1:]
    return p_map


def roll_pitch_hold(
    vehicle: Any, kp: float = 40.0, kd: float = 6.0, n_lin_frac: float = 0.3
) -> LinearFeedback:
    """The roll-pitch PD hold as a linear feedback law ``n = n_ref + G x``.

    Parameters
    ----------
    vehicle : Vehicle
        The open-loop vehicle (thruster directions, allocation, K1, n_max).
    kp, kd : float
        Moment per radian (N m/rad) and per rad/s (N m s/rad) of roll and pitch.
    n_lin_frac : float
        Operating point n_lin of the thrust-to-rpm conversion, as a fraction of n_max.

    Returns
    -------
    LinearFeedback with gain G of shape (N_thr, nx) (rpm per state unit), non-zero in
    the columns of phi, theta, p and q.
    """
    for name, value in (("kp", kp), ("kd", kd), ("n_lin_frac", n_lin_frac)):
        checks.positive(value, name)
    p_map = _vertical_map(vehicle)
    scale = 1.0 / (2.0 * vehicle.K1 * n_lin_frac * vehicle.n_max)  # rpm per N
    gain = np.zeros((p_map.shape[0], int(vehicle.nx)))
    gain[:, _ATTITUDE[0:2]] = -kp * p_map * scale  # roll, pitch angle
    gain[:, _ATTITUDE[2:4]] = -kd * p_map * scale  # roll, pitch rate
    names = tuple(f"{n}_ref" for n in vehicle.input_names)
    return LinearFeedback(gain, reference_names=names, reference_units=vehicle.input_units)


class AttitudeHold(ClosedLoop):
    """``vehicle`` with a roll-pitch PD hold on its vertical thrusters.

    Parameters
    ----------
    vehicle : Vehicle
        The open-loop vehicle.
    kp : float
        Moment per radian of roll or pitch (N m/rad). Default 40: with the BlueROV2
        Heavy's roll inertia and added inertia (0.45 kg m^2) the loop's natural
        frequency is about 1.5 Hz, above the Fig. 6 sinusoids (0.15-0.3 Hz).
    kd : float
        Moment per rad/s of roll or pitch rate (N m s/rad). Default 6 (damping ratio
        about 0.7 on that inertia).
    n_lin_frac : float
        Operating point n_lin of the thrust-to-rpm conversion, as a fraction of n_max.

    Attributes
    ----------
    gains : ndarray, shape (N_thr, 4)
        rpm per unit of (phi, theta, p, q).
    """

    def __init__(
        self, vehicle: Any, kp: float = 40.0, kd: float = 6.0, n_lin_frac: float = 0.3
    ) -> None:
        law = roll_pitch_hold(vehicle, kp, kd, n_lin_frac)
        super().__init__(vehicle, law, name=f"{vehicle.name} + attitude hold")
        self.kp = float(kp)
        self.kd = float(kd)
        self.n_lin_frac = float(n_lin_frac)
        gains = np.ascontiguousarray(law.gain[:, list(_ATTITUDE)])
        gains.setflags(write=False)
        self.gains = gains

    @property
    def vehicle(self) -> Any:
        """The open-loop vehicle (the plant)."""
        return self.plant

    def applied_rpm(self, x: Any, u_ref: Any) -> np.ndarray:
        """Applied rpm n = n_ref + Delta n(x), shape (N, N_thr) (:meth:`applied_input`)."""
        x = np.atleast_2d(np.asarray(x, dtype=float))
        return self.applied_input(0.0, x, u_ref)

    def with_params(self, **values: Any) -> AttitudeHold:
        """The hold, recomputed, around the vehicle with some parameters changed."""
        return AttitudeHold(self.vehicle.with_params(**values), self.kp, self.kd, self.n_lin_frac)

    def __repr__(self) -> str:
        return f"AttitudeHold({self.vehicle.name!r}, kp={self.kp:g}, kd={self.kd:g})"
