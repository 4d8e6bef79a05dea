"""Empirical local-error order against independent references."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import sampledyn as sd


def _traj(model, t, x):
    return sd.Trajectory(
        t=t,
        x=x,
        u=np.zeros((t.size, 1)),
        h=float(t[1] - t[0]),
        state_names=model.state_names,
        state_units=model.state_units,
    )


def _slope(hs, errs):
    return np.polyfit(np.log(hs), np.log(errs), 1)[0]


EXPECTED = (
    [(f"AB{s}", s + 1) for s in range(1, 7)]
    + [(f"RK{s}", s + 1) for s in range(1, 5)]
    + [
        ("T", 3),
        ("E", 2),
    ]
)


@pytest.mark.parametrize("name, expected", EXPECTED)
def test_local_error_order_closed_form(name, expected, damped_oscillator):
    model = damped_oscillator
    x0 = np.array([1.0, 0.0])
    hs = np.array([0.08, 0.04, 0.02, 0.01]) if expected < 6 else np.array([0.16, 0.08, 0.04, 0.02])
    errs = []
    for h in hs:
        t = h * np.arange(int(round(2.0 / h)) + 1)
        traj = _traj(model, t, model.flow(t, x0))
        x_hat = sd.predict(name, model, traj)
        e = sd.local_errors(x_hat, traj)
        errs.append(sd.error_norm(e, t, kind="max", after=1.0))
    slope = _slope(hs, np.array(errs))
    assert abs(slope - expected) <= 0.3, (name, slope, errs)


@pytest.mark.parametrize("name, expected", [("AB2", 3), ("AB4", 5), ("RK4", 5), ("T", 3), ("E", 2)])
def test_local_error_order_auv_against_scipy(name, expected):
    # Smooth stretch of the AUV-like system: constant input, velocity kept positive.
    model = sd.models.AUVLike()
    u = 3.0

    def rhs(t, x):
        return model.f(t, x, np.array([u]))

    hs = np.array([0.04, 0.02, 0.01])
    errs = []
    for h in hs:
        t = h * np.arange(int(round(1.0 / h)) + 1)
        sol = solve_ivp(
            rhs, (0, t[-1]), [0.8, 1.0], method="DOP853", t_eval=t, rtol=1e-13, atol=1e-14
        )
        traj = sd.Trajectory(
            t=t,
            x=sol.y.T,
            u=np.full((t.size, 1), u),
            h=h,
            state_names=model.state_names,
            state_units=model.state_units,
        )
        assert (traj.x[:, 1] > 0).all()
        e = sd.local_errors(sd.predict(name, model, traj), traj)
        errs.append(sd.error_norm(e, t, kind="max", after=0.3))
    slope = _slope(hs, np.array(errs))
    assert abs(slope - expected) <= 0.3, (name, slope, errs)
