"""One-step-ahead prediction of any method on any sampled data."""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

from ._trajectory import Trajectory
from .exceptions import NumericalError, SingularPitchError
from .methods import Method, get_predictor
from .models import Model

__all__ = ["HELD_INPUT_TEXT", "predict", "warn_held_input"]

#: What a rule that evaluates f between samples does without the input there (the
#: warning of :func:`warn_held_input`, after the rule's name).
HELD_INPUT_TEXT = (
    "the input between samples is not known (no `signal`, and the data carry none: a "
    "log or data built by hand), so the sampled input is held over each interval "
    "(zero-order hold) for the stages inside it; give signal=... if the input moved "
    "between samples."
)


def warn_held_input(names: str, stacklevel: int = 3) -> None:
    """Say that ``names`` (rules that evaluate f between samples) hold the sampled
    input (a UserWarning, shown once per place by Python's default filter)."""
    warnings.warn(f"{names}: {HELD_INPUT_TEXT}", UserWarning, stacklevel=stacklevel)


def predict(
    method: str | Method,
    model: Model,
    measured: Trajectory,
    signal: Any = None,
    *,
    cache: dict[Any, Any] | None = None,
) -> np.ndarray:
    """One-step-ahead predictions x_hat[n + 1] for every n, fed with sampled data.

    Parameters
    ----------
    method : str or method object
        "E", "T", "AB<s>", "RK<s>", ... (see :func:`sampledyn.get_method`).
    model : Model
        The continuous-time model the rule discretises.
    measured : Trajectory
        Sampled (possibly noisy) data; NaN or inf is an error.
    signal : Signal, optional
        The input in continuous time, for the rules that evaluate f between samples
        (Runge-Kutta stages, Tustin's end point). Default: the signal ``measured``
        remembers (``measured.signal``: data made by :func:`sampledyn.simulate`);
        without either (a log) the sampled input is held over each interval, which
        such a rule says once (a warning).
    cache : dict, optional
        Kept by the caller across calls on the same model and data: f at the samples
        is then computed once for every rule that uses it (all AB orders).

    Returns
    -------
    ndarray, shape (N, nx): row k predicts ``measured.x[k]`` from samples before k;
    NaN in the rows for which the method lacks history (row 0 always).

    Raises
    ------
    ValueError
        for NaN or inf in ``measured`` (naming the first bad sample), sizes that do
        not fit the model, sample times the method cannot handle (the fixed-step
        rules need a uniform grid; the message names the largest step deviation), or
        a rule that predicts nothing on sampled data (ZOH, a discrete-time system only).
    SingularPitchError
        (a ValueError) where the model refuses a state near its singularity (a
        vehicle's pitch near +-90 deg): the message says whether the measured data
        hold it, or the rule formed it between samples, and then names the rule and
        the sample whose prediction did.

    Notes
    -----
    A model whose f jumps (``sign``, ``Heaviside``, ``Piecewise`` of a state, see
    ``measured.sliding``): a rule evaluates the model's f at each of its points, the
    branch of the side that point is on (on a surface, the side the motion takes or
    Filippov's sliding vector). Over an interval that crosses a surface, or enters or
    leaves a sliding interval, the one-step error is then of order h times the jump of
    f (the rule does not know where the jump is), not of the rule's order h^(s+1);
    inside a sliding interval whose samples lie on the surface, rules that use f at
    the samples only follow it exactly.
    """
    m = get_predictor(method)
    check_measured(model, measured)
    if signal is None and measured.signal is None and m.intersample:
        warn_held_input(m.name)
    try:
        return np.asarray(m.predict(model, measured, signal, cache=cache))
    except SingularPitchError as exc:
        raise _singular_where(m, model, measured, signal, exc) from None


def _singular_where(
    m: Any, model: Model, measured: Trajectory, signal: Any, exc: SingularPitchError
) -> SingularPitchError:
    """Tell a singular state in ``measured`` from one that the rule formed between
    samples (a Runge-Kutta stage, a Tustin iterate) and find the first sample whose
    prediction formed it: one-step predictions use only the samples before the one
    they predict, so the shortest prefix of the data on which the rule meets the
    singularity ends at that sample (bisection, about log2 N predictions on the error
    path only)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the warnings of the first attempt stand
        try:
            model.f(measured.t, measured.x, measured.u)
        except SingularPitchError as on_data:
            return SingularPitchError(
                f"`measured` (the data, not a prediction): {on_data}",
                on_data.theta,
                on_data.sample,
                on_data.tolerance_deg,
            )

        def fails(n: int) -> SingularPitchError | None:
            part = measured.replace(t=measured.t[:n], x=measured.x[:n], u=measured.u[:n])
            try:
                m.predict(model, part, signal)
            except SingularPitchError as err:
                return err
            except NumericalError:  # e.g. Newton on the other intervals: not this check
                return None
            return None

        lo, hi = 1, measured.n_samples  # fails(lo) is None (no prediction), fails(hi) not
        while hi - lo > 1:
            mid = (lo + hi) // 2
            lo, hi = (lo, mid) if fails(mid) is not None else (mid, hi)
        err = fails(hi)
    if err is None:  # not reproduced on the data alone (cannot happen for a one-step rule)
        return SingularPitchError(
            f"{m.name}'s prediction: {exc}", exc.theta, exc.sample, exc.tolerance_deg
        )
    k = hi - 1
    step = measured.t[k] - measured.t[k - 1]
    return SingularPitchError(
        f"{m.name}'s prediction of sample {k} (t = {measured.t[k]:g} s, over a step of "
        f"{step:g} s from sample {k - 1}) passes through a state with pitch angle theta = "
        f"{math.degrees(err.theta):.4g} deg, within {err.tolerance_deg:g} deg of +-90 deg "
        "(modulo 180 deg), where the Euler-angle kinematics J(eta) of eq. (6) is singular. "
        "The measured states are clear of it: the rule formed that state between samples "
        "(a stage or an iterate), so the step is too large for the model's motion there; use a "
        "smaller h (and check the time unit of logged data).",
        err.theta,
        k,
        err.tolerance_deg,
    )


def check_measured(model: Model, measured: Any) -> None:
    """Raise if ``measured`` is not a finite Trajectory of the model's sizes (errors
    name the argument and the first bad sample). Whether the sample times suit a
    rule (uniform grid or not) is the rule's own check."""
    if not isinstance(measured, Trajectory):
        raise TypeError(f"`measured` must be a Trajectory, got {type(measured).__name__}.")
    if measured.nx != model.nx or measured.nu != model.nu:
        raise ValueError(
            f"`measured` has nx={measured.nx}, nu={measured.nu}; the model needs "
            f"nx={model.nx}, nu={model.nu}."
        )
    measured.check_finite("measured")
