"""Bad rule names and orders get a clear error naming the argument."""

from __future__ import annotations

import pytest

import sampledyn as sd


@pytest.fixture
def model():
    return sd.models.AUVLike()


@pytest.mark.parametrize("s", [0, -1])
def test_order_below_one(s):
    with pytest.raises(ValueError, match="order `s` must be an int >= 1"):
        sd.AdamsBashforth(s)


def test_unknown_method_lists_valid(model):
    traj = sd.simulate(model, sd.signals.Multilevel(hold=0.1), T=1.0, h=0.1)
    with pytest.raises(ValueError, match="valid names: E"):
        sd.predict("Heun", model, traj)
