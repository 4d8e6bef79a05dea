"""The fastest rate of a model along sampled states: how short a sampling period its
fastest local mode asks for."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..models import Model

__all__ = ["fastest_time_constant"]

_BLOCK = 4096  # samples per batch of Jacobians (a (4096, 12, 12) batch is 4.7 MB)


def fastest_time_constant(model: Model, traj: Any, eigenvalues: Any = None) -> float:
    """Smallest local time constant ``1 / max |lambda|`` (s) over the eigenvalues
    ``lambda`` of the Jacobian df/dx at the samples of ``traj``.

    Parameters
    ----------
    model : Model
        With ``jacobian(t, x, u)`` of shape (N, nx, nx).
    traj : Trajectory
        Samples ``t`` (N,), ``x`` (N, nx), ``u`` (N, nu) in the model's units.
    eigenvalues : ndarray, shape (N, nx), optional
        The Jacobian's eigenvalues at those samples, when the caller has them
        (``numpy.linalg.eigvals`` of ``model.jacobian`` there).

    Returns
    -------
    float
        In s; inf if every eigenvalue is 0 (a pure integrator chain).

    Raises
    ------
    JacobianUnavailableError
        for a model without a Jacobian (from ``model.jacobian``).

    Notes
    -----
    ``h max |lambda|`` is the scaled step the linear stability of the rules is
    stated in (Hairer & Wanner, *Solving Ordinary Differential Equations II*, sec.
    IV.2): explicit Euler's stability interval on the negative real axis is
    h |lambda| <= 2, RK4's about 2.79.
    """
    if eigenvalues is not None:
        top = float(np.abs(eigenvalues).max()) if np.size(eigenvalues) else 0.0
        return 1.0 / top if top > 0 else float("inf")
    lam = 0.0
    for lo in range(0, traj.t.shape[0], _BLOCK):
        blk = slice(lo, lo + _BLOCK)
        jac = model.jacobian(traj.t[blk], traj.x[blk], traj.u[blk])
        lam = max(lam, float(np.abs(np.linalg.eigvals(jac)).max()))
    return 1.0 / lam if lam > 0 else float("inf")
