"""Numbers that describe a trajectory of exact samples (stored with it).

A study asks for them by name (``summaries = ["motion"]`` in a sweep file); the
engine computes them on the exact samples at each sampling period, where the
samples are (no data leaves the worker).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ...models import Model
from ...sensitivity import fastest_time_constant

__all__ = ["SUMMARIES", "fastest_time_constant", "motion_summary", "summarize_trajectory"]


def _state(traj: Any, name: str) -> np.ndarray:
    names = tuple(traj.state_names)
    if name not in names:
        raise ValueError(
            f"the motion summary needs a state named {name!r}; the states are "
            f"{', '.join(names) or 'unnamed'}."
        )
    return np.asarray(traj.x[:, names.index(name)])


def motion_summary(traj: Any) -> dict[str, float]:
    """Statistics of a vehicle's forced motion (states named as in Fossen: x, y, z,
    phi, theta, psi, u, ...): mean surge speed (m/s), depth change (m, NED z; negative
    = ascent), largest |pitch| and |roll| (deg), distance travelled (m)."""
    pos = np.column_stack([_state(traj, n) for n in ("x", "y", "z")])
    return {
        "mean_surge_m_s": float(_state(traj, "u").mean()),
        "depth_change_m": float(pos[-1, 2] - pos[0, 2]),
        "max_abs_pitch_deg": float(np.degrees(np.abs(_state(traj, "theta")).max())),
        "max_abs_roll_deg": float(np.degrees(np.abs(_state(traj, "phi")).max())),
        "distance_m": float(np.linalg.norm(np.diff(pos, axis=0), axis=1).sum()),
    }


def _tau(model: Model, traj: Any) -> dict[str, float]:
    return {"tau_min": fastest_time_constant(model, traj)}


def _motion(model: Model, traj: Any) -> dict[str, float]:
    return motion_summary(traj)


#: Summary name -> (function(model, exact samples) -> dict of floats, description).
SUMMARIES: dict[str, tuple[Callable[[Any, Any], dict[str, float]], str]] = {
    "motion": (_motion, "mean surge, depth change, largest |pitch| and |roll|, distance"),
    "tau_min": (_tau, "fastest local time constant 1/max|eig(df/dx)| along the run (s)"),
}


def summarize_trajectory(names: tuple[str, ...], model: Model, traj: Any) -> dict[str, float]:
    """The summaries ``names`` of the exact samples ``traj`` of ``model``, merged."""
    out: dict[str, float] = {}
    for name in names:
        out.update(SUMMARIES[name][0](model, traj))
    return out
