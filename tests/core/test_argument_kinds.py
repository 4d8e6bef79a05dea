"""Wrong arguments of the core functions raise the library's kinds: an ArgumentError
naming the argument for a bad value, a TypeError saying what was swapped."""

from __future__ import annotations

import numpy as np
import pytest

import sampledyn as sd
from sampledyn.exceptions import ArgumentError


@pytest.fixture(scope="module")
def run():
    model = sd.models.AUVLike()
    return sd.simulate(model, sd.signals.Sinusoidal([0.0], [5.0], [0.7], None), T=1.0, h=0.1)


def test_local_errors_with_swapped_arguments_says_so(run):
    x_hat = np.zeros_like(run.x)
    with pytest.raises(TypeError, match=r"`x_hat` is a Trajectory: the prediction comes first"):
        sd.local_errors(run, x_hat)


def test_local_errors_shape_mismatch_is_an_argument_error(run):
    with pytest.raises(ArgumentError, match=r"`x_hat` has shape \(3, 2\)") as exc:
        sd.local_errors(np.zeros((3, 2)), run)
    assert exc.value.argument == "x_hat"


def test_unknown_norm_kind_suggests(run):
    from sampledyn._local_errors import error_norms

    with pytest.raises(ArgumentError, match=r"unknown norm kind 'rsm' \(did you mean 'rms'") as e:
        error_norms(np.zeros_like(run.x), run.t, kinds=("rsm",))
    assert e.value.argument == "kinds"


def test_simulate_without_a_signal_says_what_it_needs():
    model = sd.models.AUVLike()
    with pytest.raises(TypeError, match=r"`signal` must be an input signal .* got NoneType"):
        sd.simulate(model, None, T=1.0, h=0.1)
