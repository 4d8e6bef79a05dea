"""One-step-ahead prediction of any method on any sampled data."""

from __future__ import annotations

from typing import Any

import numpy as np

from ._trajectory import Trajectory
from .methods import get_method

__all__ = ["predict"]


def predict(method: Any, model: Any, measured: Trajectory, signal: Any = None) -> np.ndarray:
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
        The input in continuous time, for Runge-Kutta stages between samples; without
        it the sampled input is held.

    Returns
    -------
    ndarray, shape (N, nx): row k predicts ``measured.x[k]`` from samples before k;
    NaN in the rows for which the method lacks history (row 0 always).
    """
    m = get_method(method)
    check_measured(model, measured)
    return np.asarray(m.predict(model, measured, signal))


def check_measured(model: Any, measured: Any) -> None:
    """Raise if ``measured`` is not a finite, uniformly sampled Trajectory of the
    model's sizes (errors name the argument and the first bad sample)."""
    if not isinstance(measured, Trajectory):
        raise TypeError(f"`measured` must be a Trajectory, got {type(measured).__name__}.")
    if measured.nx != model.nx or measured.nu != model.nu:
        raise ValueError(
            f"`measured` has nx={measured.nx}, nu={measured.nu}; the model needs "
            f"nx={model.nx}, nu={model.nu}."
        )
    measured.check_finite("measured")
    steps = np.diff(measured.t)
    if steps.size and np.abs(steps - measured.h).max() > 1e-6 * measured.h:
        n = int(np.argmax(np.abs(steps - measured.h)))
        raise ValueError(
            f"`measured.t` is not uniformly sampled with h={measured.h} s: "
            f"t[{n + 1}] - t[{n}] = {steps[n]:g} s."
        )
