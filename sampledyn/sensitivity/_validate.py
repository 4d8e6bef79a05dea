"""Disturbed local errors of several rules on given (measured) data, per sample and
block (the Monte Carlo check of the bound that feeds noisy copies through them is
:func:`sampledyn.experiments.monte_carlo_check`)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from .._trajectory import Trajectory
from ..models import Model
from ._bound import block_error_norms
from ._gains import supported_method

__all__ = ["measured_errors", "raw_errors"]


def raw_errors(
    model: Model, methods: Sequence[Any], data: Trajectory, signal: Any = None
) -> dict[str, np.ndarray]:
    """Local errors ``data.x - prediction`` of every method, shape (N, nx) each (NaN
    without prediction). f is evaluated once and shared by every AB order."""
    out: dict[str, np.ndarray] = {}
    cache: dict[Any, Any] = {}
    for name in methods:
        m = supported_method(name)
        out[m.name] = data.x - m.predict(model, data, signal, cache=cache)
    return out


def measured_errors(
    model: Model, methods: Sequence[Any], measured: Trajectory, signal: Any = None
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per-sample disturbed local-error norms of every method on measured data.

    Returns
    -------
    dict method name -> (eta norms, v norms), each shape (N,), NaN without prediction.
    """
    return {
        name: block_error_norms(err, measured.state_units)
        for name, err in raw_errors(model, methods, measured, signal).items()
    }
