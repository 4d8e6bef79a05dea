"""Inputs: multilevel signals and the zero-order hold."""

import numpy as np
import pytest

import sampledyn as sd


def test_multilevel_levels_held_and_in_range():
    sig = sd.signals.Multilevel(low=-10.0, high=10.0, hold=0.05, seed=0)
    t = 0.01 * np.arange(1000)
    u = sig(t)[:, 0]
    assert u.shape == (1000,)
    assert (u >= -10).all() and (u <= 10).all()
    # Constant within each hold of 5 samples, and changes at hold boundaries.
    blocks = u.reshape(-1, 5)
    assert (blocks == blocks[:, :1]).all()
    assert (np.diff(blocks[:, 0]) != 0).all()
    # Uniform levels: mean and spread of a uniform on [-10, 10].
    assert abs(blocks[:, 0].mean()) < 1.5
    assert blocks[:, 0].std() == pytest.approx(20 / np.sqrt(12), rel=0.15)


def test_multilevel_prefix_is_stable():
    a = sd.signals.Multilevel(hold=1.0, seed=4)
    first = a(np.arange(10.0)).copy()
    a(np.arange(1000.0))  # extends the cached level sequence
    np.testing.assert_array_equal(a(np.arange(10.0)), first)
    np.testing.assert_array_equal(sd.signals.Multilevel(hold=1.0, seed=4)(np.arange(10.0)), first)


def test_zero_order_hold():
    zoh = sd.signals.ZeroOrderHold(np.array([0.0, 1.0, 2.0]), np.array([5.0, 6.0, 7.0]))
    np.testing.assert_array_equal(zoh(np.array([0.0, 0.5, 1.0, 1.999, 2.5]))[:, 0], [5, 5, 6, 6, 7])
    with pytest.raises(ValueError, match="strictly increasing"):
        sd.signals.ZeroOrderHold(np.array([0.0, 0.0]), np.array([1.0, 2.0]))


def test_multilevel_arguments():
    with pytest.raises(ValueError, match="`low` < `high`"):
        sd.signals.Multilevel(low=1.0, high=-1.0)
    with pytest.raises(ValueError, match="`hold`"):
        sd.signals.Multilevel(hold=0.0)
    with pytest.raises(TypeError, match="`seed`"):
        sd.signals.Multilevel(seed=1.5)  # type: ignore[arg-type]
