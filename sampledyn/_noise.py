"""Measurement noise delta_eta, delta_v (section 6.2 of the paper).

Noise levels are percentages of reference magnitudes chosen by the unit of each state
component: 1 m for positions, 30 deg for angles, 1 m/s for linear rates and 30 deg/s
for angular rates (the paper's "1(m)-30(deg)" and "1(m/s)-30(deg/s)"). Components in
other units (e.g. thruster rpm states) get no noise.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ._trajectory import Trajectory

__all__ = ["NOISE_REFERENCE", "add_noise", "noise_amplitudes"]

# unit -> (group, reference magnitude in that unit)
NOISE_REFERENCE: dict[str, tuple[str, float]] = {
    "m": ("eta", 1.0),
    "rad": ("eta", math.radians(30.0)),
    "m/s": ("v", 1.0),
    "rad/s": ("v", math.radians(30.0)),
}

_DISTRIBUTIONS = ("uniform", "gaussian")


def noise_amplitudes(state_units: tuple[str, ...], eta_pct: float, v_pct: float) -> np.ndarray:
    """Amplitude a_i of the noise on each state component (in its unit), shape (nx,).

    Uniform noise is drawn from [-a_i, a_i].
    """
    for name, pct in (("eta_pct", eta_pct), ("v_pct", v_pct)):
        if not (isinstance(pct, int | float) and math.isfinite(pct) and pct >= 0):
            raise ValueError(f"`{name}` must be a finite percentage >= 0, got {pct!r}.")
    amp = np.zeros(len(state_units))
    for i, unit in enumerate(state_units):
        if unit in NOISE_REFERENCE:
            group, ref = NOISE_REFERENCE[unit]
            amp[i] = (eta_pct if group == "eta" else v_pct) / 100.0 * ref
    return amp


def add_noise(
    traj: Trajectory,
    eta_pct: float = 0.0,
    v_pct: float = 0.0,
    seed: Any = 0,
    *,
    distribution: str = "uniform",
) -> Trajectory:
    """Measured data: the samples plus white measurement noise.

    Parameters
    ----------
    traj : Trajectory
        Exact samples (if it is itself measured, noise is added to its clean samples).
    eta_pct, v_pct : float
        Noise level on positions/angles and on rates, in percent of the reference
        magnitudes (1 m, 30 deg; 1 m/s, 30 deg/s).
    seed : int or numpy SeedSequence
        Seed. Positions and rates draw from independent streams spawned from it, so the
        position noise of a seed does not change when ``v_pct`` does.
    distribution : {"uniform", "gaussian"}
        "uniform": white noise uniform in [-a, a] (the paper's). "gaussian": white
        normal noise with the same standard deviation a / sqrt(3).

    Returns
    -------
    Trajectory whose ``x`` is noisy and whose ``clean`` holds the exact samples.
    """
    if not isinstance(traj, Trajectory):
        raise TypeError(f"`traj` must be a Trajectory, got {type(traj).__name__}.")
    if distribution not in _DISTRIBUTIONS:
        raise ValueError(
            f"unknown `distribution` {distribution!r}; valid: {', '.join(_DISTRIBUTIONS)}."
        )
    clean = traj.clean if traj.clean is not None else traj
    amp = noise_amplitudes(clean.state_units, eta_pct, v_pct)
    groups = np.array([NOISE_REFERENCE.get(u, ("", 0.0))[0] for u in clean.state_units])
    seq = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    streams = dict(zip(("eta", "v"), seq.spawn(2), strict=True))
    from ._sums import add_scaled_draws  # numba, loaded on first use

    x = np.ascontiguousarray(clean.x, dtype=float)
    noisy = x.copy()  # the components without noise stay the samples
    for group, ss in streams.items():
        cols = np.flatnonzero(groups == group)
        if cols.size == 0:
            continue
        rng = np.random.default_rng(ss)
        draws = np.empty((x.shape[0], cols.size))
        # The draws of uniform(-1, 1) (-1 + 2 r, r in [0, 1)) and of standard_normal()
        # / sqrt(3), scaled and added to the samples in one pass, without temporaries.
        if distribution == "uniform":
            rng.random(out=draws)
            add_scaled_draws(x, draws, cols, amp, -1.0, 2.0, noisy)
        else:
            rng.standard_normal(out=draws)
            np.divide(draws, math.sqrt(3.0), out=draws)
            add_scaled_draws(x, draws, cols, amp, 0.0, 1.0, noisy)
    noisy.setflags(write=False)
    return clean.replace(x=noisy, clean=clean)
