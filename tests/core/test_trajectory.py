"""Trajectory: shapes checked on construction; checks remembered and unchanged."""

from __future__ import annotations

import numpy as np
import pytest

import sampledyn as sd


@pytest.mark.parametrize(
    "change, message",
    [
        ({"x": np.zeros((4, 2))}, "`x` must have shape"),
        ({"u": np.zeros((3, 1))}, "`u` must have shape"),
        ({"state_names": ("a",), "state_units": ("",)}, "`state_names`"),
    ],
)
def test_trajectory_shapes(change, message):
    good = dict(t=np.arange(5.0), x=np.zeros((5, 2)), u=np.zeros((5, 1)), h=1.0,
                state_names=("a", "b"), state_units=("", ""))  # fmt: skip
    sd.Trajectory(**good)
    with pytest.raises(ValueError, match=message):
        sd.Trajectory(**{**good, **change})


def test_trajectory_checks_are_remembered_and_unchanged():
    from sampledyn._trajectory import uniform_grid

    t = np.arange(100) * 0.01
    x = np.zeros((100, 2))
    traj = sd.Trajectory(t=t, x=x, u=np.zeros((100, 1)), h=0.01, state_names=("a", "b"),
                         state_units=("m", "m/s"))  # fmt: skip
    assert traj.on_uniform_grid is uniform_grid(traj.t, traj.h) is True
    bad_x = x.copy()
    bad_x[37, 1] = np.inf
    bad = traj.replace(x=bad_x)
    assert bad.on_uniform_grid
    for _ in range(2):  # the remembered answer raises the same message
        with pytest.raises(ValueError, match=r"`data.x` holds NaN or inf; first bad sample n=37"):
            bad.check_finite("data")
    jittered = traj.replace(t=t + 1e-4 * (np.arange(100) % 3))  # 0, 0.1, 0.2 ms off the grid
    assert jittered.on_uniform_grid is uniform_grid(jittered.t, jittered.h) is False
