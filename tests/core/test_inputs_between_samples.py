"""Inputs that jump between sample times are integrated exactly or refused (issue 11,
item 3): a 40 ms pulse inside a 0.1 s sampling interval against the closed form of a
linear system."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit
from scipy.linalg import expm

import sampledyn as sd
from sampledyn.models import CompiledModel
from sampledyn.models._base import RHS_SIG

# x' = A x + B u: a lightly damped oscillator driven by u (closed form by expm).
A = np.array([[0.0, 1.0], [-4.0, -0.4]])
B = np.array([0.0, 1.0])


@njit(RHS_SIG)
def _linear_rhs(t, x, u, p, out):  # pragma: no cover - compiled
    out[0] = p[0] * x[0] + p[1] * x[1] + p[4] * u[0]
    out[1] = p[2] * x[0] + p[3] * x[1] + p[5] * u[0]


class Linear(CompiledModel):
    nx = 2
    nu = 1
    state_names = ("q", "dq")
    state_units = ("m", "m/s")
    input_names = ("u1",)
    input_units = ("m/s^2",)

    def kernel(self):
        return _linear_rhs, np.array([*A.ravel(), *B])


def _closed_form(stamps, values, t_eval, x0):
    """x(t) of x' = A x + B u for u held piecewise constant from each stamp on."""
    out = np.empty((t_eval.size, 2))
    x = np.array(x0, dtype=float)
    edges = np.union1d(stamps, t_eval)
    k = 0
    for i, (a, b) in enumerate(zip(edges[:-1], edges[1:], strict=True)):
        if i == 0:
            out[0] = x
            k = 1
        level = values[np.searchsorted(stamps, a, side="right") - 1]
        M = np.zeros((3, 3))
        M[:2, :2] = A
        M[:2, 2] = B * level
        x = (expm(M * (b - a)) @ np.append(x, 1.0))[:2]
        if k < t_eval.size and np.isclose(b, t_eval[k], rtol=0, atol=1e-15):
            out[k] = x
            k += 1
    return out


# A 40 ms pulse inside [0, 0.1]; a change exactly at a sample time (0.2 s); a change
# inside [0.3, 0.4].
STAMPS = np.array([0.0, 0.03, 0.07, 0.2, 0.33])
VALUES = np.array([0.0, 5.0, 0.0, 2.0, -1.0])


def test_a_pulse_inside_an_interval_matches_the_closed_form():
    zoh = sd.signals.ZeroOrderHold(STAMPS, VALUES)
    h, T = 0.1, 0.6
    np.testing.assert_array_equal(zoh.breakpoints(h * np.arange(7)), [0.03, 0.07, 0.33])
    traj = sd.simulate(Linear(), zoh, T=T, h=h, x0=np.array([0.1, 0.0]))
    exact = _closed_form(STAMPS, VALUES, traj.t, [0.1, 0.0])
    assert np.abs(traj.x - exact).max() < 1e-13
    # the samples of the input are the held values at the sample times
    np.testing.assert_array_equal(traj.u[:, 0], [0.0, 0.0, 2.0, 2.0, -1.0, -1.0, -1.0])
    # certificate intact: one per sampling interval, tiny, and it saw the extra steps
    cert = traj.certificate
    assert cert is not None and cert.per_interval.shape == (6,)
    assert cert.max_error < 1e-13
    assert cert.steps[0] >= 3 and cert.steps[3] >= 2  # the intervals with inner jumps
    # The test has teeth: holding the sampled input over each interval (the old
    # behaviour) misses the pulse by far more than the tolerance.
    held = _closed_form(traj.t, traj.u[:, 0], traj.t, [0.1, 0.0])
    assert np.abs(held - exact).max() > 1e-3


def test_certify_false_gives_the_same_samples():
    zoh = sd.signals.ZeroOrderHold(STAMPS, VALUES)
    a = sd.simulate(Linear(), zoh, T=0.6, h=0.1, x0=np.array([0.1, 0.0]))
    b = sd.simulate(Linear(), zoh, T=0.6, h=0.1, x0=np.array([0.1, 0.0]), certify=False)
    np.testing.assert_array_equal(a.x, b.x)
    assert b.certificate is None


def test_stamps_on_the_grid_add_no_breakpoint_and_change_nothing():
    t = 0.1 * np.arange(8)
    values = np.array([0.0, 1.0, 1.0, -2.0, 0.5, 0.5, 3.0, 0.0])
    zoh = sd.signals.ZeroOrderHold(t, values)
    assert zoh.breakpoints(t[:7]).size == 0
    traj = sd.simulate(Linear(), zoh, T=0.6, h=0.1, x0=np.array([0.1, 0.0]))
    exact = _closed_form(t, values, traj.t, [0.1, 0.0])
    assert np.abs(traj.x - exact).max() < 1e-13


class _HiddenJump(sd.signals.Signal):
    """A held part that jumps at 0.05 s without declaring it."""

    nu = 1

    def hold_values(self, t):
        return (np.asarray(t) >= 0.05).astype(float)[:, None]


def test_an_undeclared_jump_inside_an_interval_is_refused():
    with pytest.raises(ValueError, match=r"changes inside the interval \[0, 0\.1\] s"):
        sd.simulate(Linear(), _HiddenJump(), T=0.3, h=0.1)


class _BadBreaks(_HiddenJump):
    def breakpoints(self, t):
        return np.array([0.05, 0.1])  # 0.1 is a sample time


def test_breakpoints_on_a_sample_time_are_a_signal_error():
    with pytest.raises(ValueError, match=r"returned 0\.1 s, which is a sample time"):
        sd.simulate(Linear(), _BadBreaks(), T=0.3, h=0.1)


def test_a_simulated_trajectory_remembers_its_input_for_rk_and_tustin():
    """issue 21 item 6: without `signal=`, RK4 and T on a run whose input moves between
    samples used to hold the sampled input (355x larger errors in the issue); the
    Trajectory made by simulate now carries its signal and the rules use it, the
    same numbers as with signal= given, kept by noise and subsampling."""
    import warnings

    import sampledyn as sd

    auv = sd.models.AUVLike()
    sig = sd.signals.Sinusoidal([0.0], [5.0], [0.7], None)
    traj = sd.simulate(auv, sig, 20.0, 0.05)
    assert traj.signal is sig and sd.add_noise(traj, 1, 1).signal is sig
    assert traj.subsample(2).signal is sig
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no held-input warning: the input is known
        for name in ("RK4", "T"):
            e = sd.local_errors(sd.predict(name, auv, traj), traj)
            given = sd.local_errors(sd.predict(name, auv, traj, signal=sig), traj)
            np.testing.assert_array_equal(e, given)
    log_like = traj.replace(u=traj.u)  # a new u: the signal is dropped
    assert log_like.signal is None
    with pytest.warns(UserWarning, match="RK4: the input between samples is not known"):
        held = sd.local_errors(sd.predict("RK4", auv, log_like), log_like)
    # the held input errs by O(h^2 u') per step against RK4's O(h^5): 24x here
    ratio = np.nanmax(np.abs(held)) / np.nanmax(np.abs(e))
    assert ratio > 10
