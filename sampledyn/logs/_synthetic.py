"""A synthetic vehicle log made by the library: the example of ``sampledyn evaluate``.

The vehicle is driven by a gentle survey-like thruster command (forward, turning,
with sinusoidal excitation on every thruster) so that it travels, yaws through more
than a full turn (the heading wraps at +-180 deg in the log) and stays upright. The
samples are exact (:func:`sampledyn.simulate`) plus uniform measurement noise, and
written the way a logger would: angles in deg, angular rates in deg/s, heading
wrapped, thrusters in rpm, units in the header.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from .. import _checks as checks
from ..exceptions import ArgumentError

__all__ = ["survey_input", "synthetic_log", "write_synthetic_log"]

# Mean generalized force of the survey (N, N, N, N m, N m, N m): forward, slightly up,
# turning to starboard.
_SURVEY_TAU = np.array([8.0, 0.0, -1.0, 0.0, 0.0, 0.25])


def survey_input(vehicle: Any) -> Any:
    """Thruster rpm: mean rpm for a forward, turning motion (least-squares allocation
    of a constant force) plus two sinusoids per thruster (6 % and 3 % of n_max on
    horizontal thrusters, 2 % and 1 % on vertical ones)."""
    from ..models._rigid_body import thruster_allocation
    from ..signals import Sinusoidal

    dirs = np.asarray(vehicle.thruster_directions, dtype=float)
    alloc = thruster_allocation(vehicle.thruster_positions, dirs)
    thrust = np.linalg.pinv(alloc) @ _SURVEY_TAU
    n0 = np.sign(thrust) * np.sqrt(np.abs(thrust) / vehicle.K1)
    nu = dirs.shape[0]
    vertical = np.abs(dirs[:, 2]) > np.hypot(dirs[:, 0], dirs[:, 1])
    level = np.where(vertical, 0.02, 0.06) * vehicle.n_max
    amp = np.column_stack([level, 0.5 * level])
    k = np.arange(nu)
    freq = np.column_stack([0.05 + 0.02 * k, 0.31 + 0.03 * k])
    names = tuple(f"n{i + 1}" for i in range(nu))
    return Sinusoidal(n0, amp, freq, names=names, units=("rpm",) * nu)


_LOG_UNITS = {
    "m": ("m", 1.0),
    "rad": ("deg", 180.0 / np.pi),
    "m/s": ("m/s", 1.0),
    "rad/s": ("deg/s", 180.0 / np.pi),
}


def synthetic_log(
    vehicle: str = "bluerov2_heavy",
    *,
    T: float = 40.0,
    h: float = 0.1,
    eta_pct: float = 0.5,
    v_pct: float = 0.5,
    seed: int = 0,
    jitter: float = 0.0,
    clock: float = 1e-4,
) -> Any:
    """A log of ``vehicle`` under :func:`survey_input` as a pandas DataFrame.

    Columns: ``t[s]``, the 12 states (``x[m]``, ..., ``phi[deg]``, ..., ``p[deg/s]``,
    ...; psi wrapped to [-180, 180) deg), ``n1[rpm]`` ... One row per sample,
    ``T / h + 1`` rows.

    With ``jitter`` > 0 (s) the stamps are those of a logger whose clock ticks every
    ``clock`` seconds: ``n h`` plus a whole number of ticks within +-jitter, drawn
    uniformly (seeded; the first and last stamps stay inside [0, T]); states and
    inputs are exact at those stamps (simulated at the clock's period).
    """
    import pandas as pd

    from .._noise import add_noise
    from .._simulate import simulate
    from ..models import load_vehicle

    model = load_vehicle(vehicle)
    if jitter > 0:
        ticks = checks.integer_ratio(h, clock)
        if ticks is None:
            raise ArgumentError(
                "h", f"`h` = {h} s must be a whole number of `clock` = {clock} s ticks."
            )
        fine = simulate(model, survey_input(model), T=T, h=clock, certify=False)
        n = int(round(T / h)) + 1
        reach = checks.floor_ratio(jitter, clock)
        shift = np.random.default_rng([seed, 1]).integers(-reach, reach + 1, n)
        shift[0], shift[-1] = abs(shift[0]), -abs(shift[-1])
        at = ticks * np.arange(n) + shift
        traj = fine.replace(t=fine.t[at], x=fine.x[at], u=fine.u[at], h=h, certificate=None)
    else:
        traj = simulate(model, survey_input(model), T=T, h=h)
    measured = add_noise(traj, eta_pct, v_pct, seed)
    columns: dict[str, Any] = {"t[s]": np.round(measured.t, 9)}
    for k, (name, unit) in enumerate(zip(model.state_names, model.state_units, strict=True)):
        log_unit, factor = _LOG_UNITS[unit]
        values = measured.x[:, k] * factor
        if name == "psi":
            values = (values + 180.0) % 360.0 - 180.0
        columns[f"{name}[{log_unit}]"] = values
    for i in range(model.nu):
        columns[f"n{i + 1}[rpm]"] = measured.u[:, i]
    return pd.DataFrame(columns)


def write_synthetic_log(path: str | os.PathLike[str], **kwargs: Any) -> Path:
    """Write :func:`synthetic_log` to ``path`` (``.parquet`` or CSV); returns the path."""
    path = Path(path)
    frame = synthetic_log(**kwargs)
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix.lower() in (".parquet", ".pq"):
        frame.to_parquet(path, index=False)
    else:
        frame.to_csv(path, index=False, float_format="%.9g")
    return path
