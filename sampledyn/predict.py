"""One-step-ahead prediction of any method on any sampled data."""

from __future__ import annotations

from typing import Any

import numpy as np

from ._trajectory import Trajectory
from .methods import get_method

__all__ = ["predict"]


def predict(
    method: Any,
    model: Any,
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
        The input in continuous time, for Runge-Kutta stages between samples; without
        it the sampled input is held.
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
        not fit the model, or sample times the method cannot handle (the fixed-step
        rules need a uniform grid; the message names the largest step deviation).
    """
    m = get_method(method)
    check_measured(model, measured)
    return np.asarray(m.predict(model, measured, signal, cache=cache))


def check_measured(model: Any, measured: Any) -> None:
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
