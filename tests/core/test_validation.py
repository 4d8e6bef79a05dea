"""Bad input gets a clear error naming the argument."""

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


@pytest.mark.parametrize("s", [0, -1])
def test_order_below_one(s):
    with pytest.raises(ValueError, match="order `s` must be an int >= 1"):
        sd.AdamsBashforth(s)


def test_unknown_method_lists_valid(model):
    traj = sd.simulate(model, sd.signals.Multilevel(hold=0.1), T=1.0, h=0.1)
    with pytest.raises(ValueError, match="valid names: E"):
        sd.predict("Heun", model, traj)


def test_trajectory_shapes():
    t = np.arange(5.0)
    with pytest.raises(ValueError, match="`x` must have shape"):
        sd.Trajectory(
            t=t,
            x=np.zeros((4, 2)),
            u=np.zeros((5, 1)),
            h=1.0,
            state_names=("a", "b"),
            state_units=("", ""),
        )
    with pytest.raises(ValueError, match="`u` must have shape"):
        sd.Trajectory(
            t=t,
            x=np.zeros((5, 2)),
            u=np.zeros((3, 1)),
            h=1.0,
            state_names=("a", "b"),
            state_units=("", ""),
        )
    with pytest.raises(ValueError, match="`state_names`"):
        sd.Trajectory(
            t=t,
            x=np.zeros((5, 2)),
            u=np.zeros((5, 1)),
            h=1.0,
            state_names=("a",),
            state_units=("",),
        )


def test_model_f_shape_errors(model):
    with pytest.raises(ValueError, match=r"`x` must have shape \(N, 2\)"):
        model.f(0.0, np.zeros((4, 3)), np.zeros((4, 1)))
    with pytest.raises(ValueError, match="`u` must have shape"):
        model.f(0.0, np.zeros((4, 2)), np.zeros((5, 1)))


def test_error_norm_errors():
    t = np.arange(4.0)
    e = np.ones((4, 2))
    with pytest.raises(ValueError, match="unknown norm kind"):
        sd.error_norm(e, t, kind="l3")
    with pytest.raises(ValueError, match="no samples"):
        sd.error_norm(e, t, after=10.0)
    with pytest.raises(ValueError, match="`errors` must have shape"):
        sd.error_norm(np.ones((3, 2)), t)


def test_multilevel_arguments():
    with pytest.raises(ValueError, match="`low` < `high`"):
        sd.signals.Multilevel(low=1.0, high=-1.0)
    with pytest.raises(ValueError, match="`hold`"):
        sd.signals.Multilevel(hold=0.0)
    with pytest.raises(TypeError, match="`seed`"):
        sd.signals.Multilevel(seed=1.5)  # type: ignore[arg-type]


def test_model_parameters_validated():
    with pytest.raises(ValueError, match="`alpha`"):
        sd.models.AUVLike(alpha=float("nan"))
    with pytest.raises(TypeError, match="unknown parameter"):
        sd.models.AUVLike().with_params(zeta=1.0)
