"""The paper's Fig. 6 thruster input: n_i(t) = n0_i + n1_i sin(2 pi f_i t).

The table gives each of 8 thrusters a mean and a sinusoid in percent of the maximum
rpm, with the direction the mean pushes ("up", "down", "forward"). The paper's vehicle
is not the one here, so the rows are mapped by role onto this vehicle's thrusters:

* rows 1-4 ("up", "up", "down", "down") go to the vehicle's vertical thrusters (those
  whose axis is mostly along body z), in file order;
* rows 5-8 ("forward") go to its horizontal thrusters, in file order.

A row's mean pushes in its labelled direction on this vehicle: the sign of each
thruster's rpm is chosen from its axis (positive rpm pushes along the axis), so "up"
means thrust towards -z (NED, body z down), "down" towards +z and "forward" towards
+x. The sinusoids get the same sign (a phase shift of pi where the sign flips).

On the built-in vehicles (thrusters numbered as in their files):

============  ======================================  ===================================
row (Fig. 6)  bluerov2_heavy                          rexrov
============  ======================================  ===================================
1, 2 (up)     T5, T6 (front verticals, z axis)        T1, T2 (rear verticals, 15.5 deg
                                                      tilt; uuv_simulator ids 0, 1)
3, 4 (down)   T7, T8 (rear verticals)                 T3, T4 (front verticals; ids 2, 3)
5, 6 (fwd)    T1, T2 (front, vectored 45 deg)         T5, T6 (rear, vectored 45 deg;
                                                      ids 4, 5)
7, 8 (fwd)    T3, T4 (rear, axis pointing aft: the    T7, T8 (front, axis pointing aft;
              rows' negative rpm push forward)        ids 6, 7; negative rpm push forward)
============  ======================================  ===================================

The paper does not give its thruster layout, so which end of the vehicle the "up"
rows act on is a convention (file order): on the BlueROV2 Heavy their mean thrust
raises the bow, on the RexROV the stern.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ._sinusoid import Sinusoidal

__all__ = ["FIG6_TABLE", "fig6_thrusters"]

# (row, mean % of max rpm (sign as printed), direction, sinus amplitude %, frequency Hz)
# Paper, Fig. 6.
FIG6_TABLE: tuple[tuple[int, float, str, float, float], ...] = (
    (1, -5.0, "up", 30.0, 0.30),
    (2, -5.0, "up", 30.0, 0.20),
    (3, 10.0, "down", 15.0, 0.15),
    (4, 10.0, "down", 15.0, 0.25),
    (5, 45.0, "forward", 25.0, 0.30),
    (6, 50.0, "forward", 25.0, 0.25),
    (7, -50.0, "forward", 25.0, 0.15),
    (8, -45.0, "forward", 25.0, 0.20),
)

_PUSH = {"up": (2, -1.0), "down": (2, 1.0), "forward": (0, 1.0)}


def thruster_roles(directions: Any) -> tuple[list[int], list[int]]:
    """Indices of the vertical and horizontal thrusters (by their axis), file order."""
    d = np.asarray(directions, dtype=float)
    vertical = [i for i in range(d.shape[0]) if abs(d[i, 2]) > np.hypot(d[i, 0], d[i, 1])]
    horizontal = [i for i in range(d.shape[0]) if i not in vertical]
    return vertical, horizontal


def fig6_thrusters(vehicle: Any) -> Sinusoidal:
    """Thruster rpm of the paper's Fig. 6 mapped onto ``vehicle`` (8 thrusters, 4
    vertical and 4 horizontal). Returns a continuous-time :class:`Sinusoidal` in rpm.

    Raises
    ------
    ValueError
        if the vehicle does not have 4 vertical and 4 horizontal thrusters.
    """
    d = np.asarray(vehicle.thruster_directions, dtype=float)
    vertical, horizontal = thruster_roles(d)
    if len(vertical) != 4 or len(horizontal) != 4:
        raise ValueError(
            "fig6_thrusters needs a vehicle with 4 vertical and 4 horizontal thrusters; "
            f"{vehicle.name!r} has {len(vertical)} vertical and {len(horizontal)} horizontal."
        )
    n_max = float(vehicle.n_max)
    nu = d.shape[0]
    offset = np.zeros(nu)
    amp = np.zeros(nu)
    freq = np.zeros(nu)
    for (_row, mean, direction, sin_pct, f_hz), i in zip(
        FIG6_TABLE, vertical + horizontal, strict=True
    ):
        axis, want = _PUSH[direction]
        # Positive rpm pushes along d_i; choose the sign that pushes the requested way.
        sign = np.sign(d[i, axis]) * want
        if sign == 0:
            raise ValueError(f"thruster {i + 1} has no component along the {direction!r} axis.")
        offset[i] = sign * abs(mean) / 100.0 * n_max
        amp[i] = sign * sin_pct / 100.0 * n_max
        freq[i] = f_hz
    names = tuple(f"n{i + 1}" for i in range(nu))
    return Sinusoidal(offset, amp, freq, names=names, units=("rpm",) * nu)
