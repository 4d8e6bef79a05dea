"""What every sampled-data rule shares: the Method protocol and input handling."""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np

from .._trajectory import Trajectory

__all__ = ["Method", "stage_inputs"]


@runtime_checkable
class Method(Protocol):
    """A one-step-ahead sampled-data rule."""

    name: str
    order: int

    def predict(self, model: Any, data: Trajectory, signal: Any = None) -> np.ndarray:
        """x_hat[n + 1] for every n, shape (N, nx); NaN where history is missing."""
        ...


def stage_inputs(data: Trajectory, signal: Any, c: float) -> np.ndarray:
    """Input at ``t_n + c h`` for every interval n = 0..N-2, shape (N - 1, nu).

    From ``signal`` (its held part taken at ``t_n``) when given, else the sampled
    input held over the interval (zero-order hold).
    """
    if signal is None or c == 0.0:
        return data.u[:-1]
    u = np.asarray(signal.intersample(data.t[:-1], c * data.h), dtype=float)
    if u.shape != (data.n_samples - 1, data.nu):
        raise ValueError(
            f"`signal` gives inputs of shape {u.shape[1:]}, the data have nu = {data.nu}."
        )
    return u
