"""Pieces shared by the method tests (the contract on uniform grids, the variable-step
tests on non-uniform ones): small models and the checks both run."""

from __future__ import annotations

import numpy as np

import sampledyn as sd


def make_traj(t, x, u=None, names=None, h=None):
    """A Trajectory of unitless states x (N, nx) and inputs u (default zeros) at t; h
    defaults to t[1] - t[0]."""
    x = np.asarray(x, dtype=float).reshape(t.size, -1)
    u = np.zeros((t.size, 1)) if u is None else np.asarray(u, dtype=float).reshape(t.size, -1)
    names = names or tuple(f"x{i}" for i in range(x.shape[1]))
    h = float(t[1] - t[0]) if h is None else h
    return sd.Trajectory(t=t, x=x, u=u, h=h, state_names=names, state_units=("",) * len(names))


def slope(hs, errs):
    """Least-squares slope of log(errs) against log(hs)."""
    return float(np.polyfit(np.log(hs), np.log(errs), 1)[0])


class Quadrature:
    """x' = p(t): every rule becomes a quadrature rule for p."""

    nx, nu = 1, 1
    state_names, state_units = ("x",), ("",)
    input_names, input_units = ("u",), ("",)

    def __init__(self, coeffs):
        self.p = np.polynomial.Polynomial(coeffs)

    def f(self, t, x, u):
        return np.broadcast_to(self.p(np.asarray(t, dtype=float)), (np.shape(x)[0],))[
            :, None
        ].copy()

    def jacobian(self, t, x, u):
        return np.zeros((np.shape(x)[0], 1, 1))

    def exact(self, t):
        return self.p.integ()(t)


class PositiveLinear:
    """x' = a x + b u with a >= 0 elementwise, so L = a is its exact Lipschitz matrix."""

    nx, nu = 2, 1
    state_names, state_units = ("x1", "x2"), ("", "")
    a = np.array([[0.3, 0.5], [0.2, 0.4]])
    b = np.array([0.0, 1.0])

    def f(self, t, x, u):
        return np.asarray(x) @ self.a.T + np.asarray(u)[:, :1] * self.b

    def jacobian(self, t, x, u):
        return np.broadcast_to(self.a, (np.shape(x)[0], 2, 2)).copy()


def check_jacobians_against_predict(m, model, traj, signal=None, every=23):
    """``m.prediction_jacobians`` equal central differences of ``m.predict`` (rtol 1e-6)
    at samples away from y = 0 (the kink of the AUV-like y|y|)."""
    phi = m.prediction_jacobians(model, traj, signal)
    n, nx = traj.x.shape
    assert phi.shape == (n, m.history, nx, nx)
    assert np.isnan(phi[: m.history]).all() and np.isfinite(phi[m.history :]).all()
    picks = [
        k for k in range(10, n - m.history - 1, every) if np.abs(traj.x[k : k + 8, 1]).min() > 0.05
    ]
    assert len(picks) >= 5
    for k in picks:
        for j in range(nx):
            eps = 1e-6 * (1.0 + abs(traj.x[k, j]))
            xp, xm = traj.x.copy(), traj.x.copy()
            xp[k, j] += eps
            xm[k, j] -= eps
            dp = m.predict(model, traj.replace(x=xp), signal)
            dm = m.predict(model, traj.replace(x=xm), signal)
            for i in range(m.history):
                row = k + 1 + i  # x[k] is lag i of the prediction of x[k + 1 + i]
                fd = (dp[row] - dm[row]) / (2 * eps)
                np.testing.assert_allclose(phi[row, i, :, j], fd, rtol=1e-6, atol=1e-8)


def check_gain_bounds(m, traj, gain, perturbations=10):
    """On :class:`PositiveLinear` data ``traj``: ``gain`` bounds, on every row, the
    increment's response ``sum_i |Phi_i - [i = 0] I|`` and the effect of random
    perturbations of the samples; returns the responses, shape (rows, 2, 2)."""
    plant = PositiveLinear()
    phi = m.prediction_jacobians(plant, traj)
    eye = np.eye(2)
    rows = range(m.history, traj.n_samples)
    totals = np.array(
        [sum(np.abs(phi[k, i] - (eye if i == 0 else 0.0)) for i in range(m.history)) for k in rows]
    )
    assert (totals <= gain * (1 + 1e-12)).all()
    rng = np.random.default_rng(0)
    base = m.predict(plant, traj)
    for _ in range(perturbations):
        d = rng.uniform(-1e-3, 1e-3, traj.x.shape)
        moved = m.predict(plant, traj.replace(x=traj.x + d))
        for k in rows:
            incr = np.abs(moved[k] - d[k - 1] - base[k])  # P(x~) - P(x)
            box = np.abs(d[k - m.history : k]).max(axis=0)
            assert (incr <= gain @ box * (1 + 1e-9) + 1e-15).all()
    return totals


def auv_smooth_order(name, times, hs):
    """Slope of the largest local error (after t = 0.5 s) of rule ``name`` against h on
    the smooth stretch of the AUV-like system (constant input 3, velocity > 0), the
    reference by SciPy's DOP853 at rtol 1e-13 on the stamps ``times(h)``; returns
    (slope, errors)."""
    from scipy.integrate import solve_ivp

    model = sd.models.AUVLike()
    u = 3.0
    errs = []
    for h in hs:
        t = times(h)
        sol = solve_ivp(
            lambda tt, x: model.f(tt, x, np.array([u])),
            (0, t[-1]),
            [0.8, 1.0],
            method="DOP853",
            t_eval=t,
            rtol=1e-13,
            atol=1e-14,
        )
        traj = make_traj(t, sol.y.T, np.full(t.size, u), model.state_names, h=float(h))
        assert (traj.x[:, 1] > 0).all()
        e = sd.local_errors(sd.predict(name, model, traj), traj)
        errs.append(sd.error_norm(e, t, kind="max", after=0.5))
    return slope(hs, np.array(errs)), errs
