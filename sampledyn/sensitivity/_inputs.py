"""Reference inputs for the sensitivity analysis of a vehicle (thruster rpm).

The paper's Fig. 6 input makes a vehicle with a small righting arm tumble (the
BlueROV2 Heavy, 1 cm between the centres of gravity and buoyancy, reaches 88 deg of
pitch), which the Euler-angle bounds of eqs. (22)-(23) cannot cover. The bounds and
the advice therefore run on inputs that keep the attitude in range:

* :func:`gentle_input`: the Fig. 6 pattern with every mean and amplitude scaled down
  (default 20 %: |theta| stays near 13 deg on the BlueROV2 Heavy);
* :func:`pitch_input`: a slow nose-up / nose-down sweep by the vertical thrusters,
  with small excitation on the others, that takes the pitch to 30-75 deg on purpose.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .. import _checks as checks
from ..signals import Sinusoidal, fig6_thrusters
from ..signals._fig6 import thruster_roles

__all__ = ["gentle_input", "pitch_input"]


def gentle_input(vehicle: Any, scale: float = 0.2) -> Sinusoidal:
    """The Fig. 6 thruster rpm with every mean and sinusoid multiplied by ``scale``.

    Parameters
    ----------
    vehicle : Vehicle
        With 4 vertical and 4 horizontal thrusters (as :func:`~sampledyn.signals.fig6_thrusters`).
    scale : float
        Factor in (0, 1]. Default 0.2 (the largest mean is then 10 % of n_max).

    Returns
    -------
    Sinusoidal, rpm.
    """
    if not (isinstance(scale, int | float) and math.isfinite(scale) and 0 < scale <= 1):
        raise ValueError(f"`scale` must be in (0, 1], got {scale!r}.")
    sig = fig6_thrusters(vehicle)
    return Sinusoidal(
        sig.offset * scale,
        sig.amp * scale,
        sig.freq_hz,
        sig.phase_rad,
        names=sig.names,
        units=sig.units,
    )


def pitch_input(
    vehicle: Any,
    pitch_frac: float = 0.2,
    period_s: float = 50.0,
    excitation_frac: float = 0.1,
) -> Sinusoidal:
    """A slow pitch sweep: the vertical thrusters push nose up, then nose down.

    Vertical thruster j runs ``sign_j pitch_frac n_max sin(2 pi t / period_s)`` with
    the sign that makes its pitch moment positive, so their moments add and their
    heave forces cancel on a symmetric layout. The horizontal thrusters add a small
    forward mean (``excitation_frac / 2``) and sinusoids (``excitation_frac``) at
    0.15-0.3 Hz, the vertical ones 3 % sinusoids, to excite the other modes.

    On the BlueROV2 Heavy, ``pitch_frac`` = 0.18, 0.2, 0.22 give max |theta| near
    47, 59 and 75 deg.

    Returns
    -------
    Sinusoidal, rpm, two sinusoids per thruster.
    """
    for name, val, hi in (
        ("pitch_frac", pitch_frac, 1.0),
        ("excitation_frac", excitation_frac, 1.0),
        ("period_s", period_s, math.inf),
    ):
        if not (isinstance(val, int | float) and math.isfinite(val) and 0 <= val <= hi):
            raise ValueError(f"`{name}` must be in [0, {hi}], got {val!r}.")
    checks.positive(period_s, "period_s", unit="s")
    d = np.asarray(vehicle.thruster_directions, dtype=float)
    vertical, horizontal = thruster_roles(d)
    alloc = vehicle.allocation
    nmax = float(vehicle.n_max)
    nu = d.shape[0]
    offset = np.zeros(nu)
    amp = np.zeros((nu, 2))
    freq = np.zeros((nu, 2))
    freqs = (0.3, 0.25, 0.2, 0.15)
    for k, i in enumerate(vertical):
        sign = math.copysign(1.0, alloc[4, i]) if alloc[4, i] != 0 else 0.0
        amp[i, 0] = sign * pitch_frac * nmax
        freq[i, 0] = 1.0 / period_s
        amp[i, 1] = 0.03 * nmax
        freq[i, 1] = freqs[k % 4]
    for k, i in enumerate(horizontal):
        forward = math.copysign(1.0, d[i, 0]) if d[i, 0] != 0 else 0.0
        offset[i] = forward * 0.5 * excitation_frac * nmax
        amp[i, 1] = forward * excitation_frac * nmax
        freq[i, 1] = freqs[k % 4]
    names = tuple(f"n{i + 1}" for i in range(nu))
    return Sinusoidal(offset, amp, freq, names=names, units=("rpm",) * nu)
