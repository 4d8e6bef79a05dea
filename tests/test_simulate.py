import numpy as np
import pytest
from scipy.integrate import solve_ivp

import sampledyn as sd


def _scipy_samples(model, signal, T, h, x0):
    """Independent reference: solve_ivp interval by interval, input held."""
    n = int(round(T / h))
    t = h * np.arange(n + 1)
    x = np.empty((n + 1, model.nx))
    x[0] = x0
    u = signal(t)
    for k in range(n):
        sol = solve_ivp(
            lambda tt, xx, uk=u[k]: model.f(tt, xx, uk),
            (t[k], t[k + 1]),
            x[k],
            method="DOP853",
            rtol=1e-13,
            atol=1e-14,
        )
        x[k + 1] = sol.y[:, -1]
    return t, x


def test_simulate_matches_scipy_on_auv():
    model = sd.models.AUVLike()
    signal = sd.signals.Multilevel(hold=0.04, seed=5)
    x0 = np.array([1.0, 0.0])
    traj = sd.simulate(model, signal, T=4.0, h=0.02, x0=x0)
    t, ref = _scipy_samples(model, signal, 4.0, 0.02, x0)
    np.testing.assert_allclose(traj.t, t, rtol=0, atol=1e-12)
    assert np.abs(traj.x - ref).max() < 1e-11
    # The velocity crosses zero in this run: the kink is part of the test.
    assert (np.diff(np.sign(traj.x[:, 1])) != 0).any()


def test_certificate_is_small_and_honest():
    model = sd.models.AUVLike()
    signal = sd.signals.Multilevel(hold=0.02, seed=1)
    traj = sd.simulate(model, signal, T=3.0, h=0.01, x0=np.array([1.0, 0.0]))
    cert = traj.certificate
    assert cert is not None
    assert cert.per_interval.shape == (traj.n_samples - 1,)
    assert cert.max_error < 1e-12
    assert (cert.steps >= 1).all()
    assert "per-interval flow error" in str(cert)


def test_samples_are_frozen():
    traj = sd.simulate(sd.models.AUVLike(), sd.signals.Multilevel(hold=0.1), T=1.0, h=0.1)
    with pytest.raises(ValueError):
        traj.x[0, 0] = 1.0
    assert traj.x.shape == (11, 2) and traj.u.shape == (11, 1)
    assert traj.state_units == ("m", "m/s")


def test_simulate_is_reproducible_by_seed():
    model = sd.models.AUVLike()
    a = sd.simulate(model, sd.signals.Multilevel(hold=0.1, seed=9), T=2.0, h=0.1)
    b = sd.simulate(model, sd.signals.Multilevel(hold=0.1, seed=9), T=2.0, h=0.1)
    c = sd.simulate(model, sd.signals.Multilevel(hold=0.1, seed=10), T=2.0, h=0.1)
    np.testing.assert_array_equal(a.x, b.x)
    assert not np.array_equal(a.u, c.u)
