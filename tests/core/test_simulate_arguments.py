"""sd.simulate: bad arguments get a clear error naming the argument."""

import numpy as np
import pytest

import sampledyn as sd


@pytest.fixture
def model():
    return sd.models.AUVLike()


@pytest.fixture
def signal():
    return sd.signals.Multilevel(hold=0.1, seed=0)


@pytest.mark.parametrize("h", [0.0, -0.1, float("nan"), float("inf")])
def test_bad_h(model, signal, h):
    with pytest.raises(ValueError, match="`h`"):
        sd.simulate(model, signal, T=1.0, h=h)


def test_t_shorter_than_h(model, signal):
    with pytest.raises(ValueError, match="`T`"):
        sd.simulate(model, signal, T=0.05, h=0.1)


def test_t_not_multiple_of_h(model, signal):
    with pytest.raises(ValueError, match="integer multiple of `h`"):
        sd.simulate(model, signal, T=1.05, h=0.1)


def test_hold_not_multiple_of_h(model):
    with pytest.raises(ValueError, match="h_u = 0.15 s must be an integer multiple"):
        sd.simulate(model, sd.signals.Multilevel(hold=0.15), T=1.0, h=0.1)


def test_bad_x0_shape(model, signal):
    with pytest.raises(ValueError, match=r"`x0` must have shape \(2,\)"):
        sd.simulate(model, signal, T=1.0, h=0.1, x0=np.zeros(3))


def test_signal_channel_mismatch(model):
    with pytest.raises(ValueError, match="nu=2"):
        sd.simulate(model, sd.signals.Multilevel(hold=0.1, nu=2), T=1.0, h=0.1)
