"""Baselines: what a one-step prediction gives without a model of the dynamics.

An error table of sampled-data rules on real data reads only beside these two:

``hold``
    ``x^_{n+1} = x_n``: no model at all. Its error is the increment of the data over
    one step, motion plus noise; a rule that does not beat it predicts nothing.
``kinematics``
    positions and angles advanced with the logged rates through the kinematics (6),
    ``eta^_{n+1} = eta_n + h_n J(eta_n) nu_n``, the rates held, ``nu^_{n+1} = nu_n``:
    the part of every rule that needs no dynamics (Euler's position block is exactly
    this). A rule must beat it in the rate block to show that its model of forces
    predicts anything.

They are baselines, not rules of some order: they do not discretise the model's
dynamics, have no order of convergence (the hold's error does not vanish as h -> 0
relative to h), no noise bound (24)-(25), no discrete-time system to design on and
nothing to estimate. So they are not in the method registry, where every rule
enters the generic contract tests (convergence order s + 1, noise gains, the
discretised system); every error table adds them itself (``sampledyn evaluate``,
``advise``). They answer the prediction questions a table asks of a rule (``predict``,
``prediction_jacobians`` for the noise floor) with the same signatures.

For a model that is not a vehicle the blocks come from the state units (m, rad:
positions/angles; m/s, rad/s: rates, as the noise levels of :mod:`sampledyn._noise`):
``kinematics`` advances the position/angle states with the model's own derivative of
them (for a vehicle J(eta) nu, eq. (6)) and holds every other state.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ._noise import NOISE_REFERENCE
from ._trajectory import Trajectory
from .exceptions import ArgumentError

__all__ = ["BASELINES", "Hold", "Kinematics", "baseline_names", "get_baseline"]


def _steps(data: Trajectory) -> np.ndarray:
    """h_n = t_{n+1} - t_n, shape (N - 1,)."""
    return np.diff(data.t)


def _eta_rows(data: Trajectory) -> np.ndarray:
    """Indices of the position/angle states (units m, rad)."""
    return np.array(
        [i for i, u in enumerate(data.state_units) if NOISE_REFERENCE.get(u, ("",))[0] == "eta"],
        dtype=int,
    )


@dataclass(frozen=True)
class _Baseline:
    """What the baselines share: order 0, one sample of history, f (if at all) only at
    the samples, any time grid."""

    family: str = "baseline"
    order: int = 0
    history: int = 1
    intersample: bool = False
    variable_step: bool = True
    sample_weights: None = None


@dataclass(frozen=True)
class Hold(_Baseline):
    """The hold baseline, ``x^_{n+1} = x_n`` (see the module docstring)."""

    name: str = "hold"
    step_rule: str = "x_n+1 = x_n (no model)"

    @property
    def label(self) -> str:
        return "hold (x_n+1 = x_n)"

    def predict(
        self, model: Any, data: Trajectory, signal: Any = None, *, cache: Any = None
    ) -> np.ndarray:
        """x^ shape (N, nx): row k is x[k - 1]; row 0 NaN. ``model`` is not used."""
        out = np.full(data.x.shape, np.nan)
        out[1:] = data.x[:-1]
        return out

    def prediction_jacobians(
        self, model: Any, data: Trajectory, signal: Any = None, *, cache: Any = None
    ) -> np.ndarray:
        """d x^[k] / d x[k-1] = I, shape (N, 1, nx, nx); row 0 NaN."""
        phi = np.full((data.n_samples, 1, data.nx, data.nx), np.nan)
        phi[1:, 0] = np.eye(data.nx)
        return phi


@dataclass(frozen=True)
class Kinematics(_Baseline):
    """The kinematics baseline (see the module docstring): Euler on the positions and
    angles, the other states held."""

    name: str = "kinematics"
    step_rule: str = "eta_n+1 = eta_n + h_n J(eta_n) nu_n, nu_n+1 = nu_n"

    @property
    def label(self) -> str:
        return "kinematics (eq. (6), rates held)"

    def predict(
        self, model: Any, data: Trajectory, signal: Any = None, *, cache: Any = None
    ) -> np.ndarray:
        """x^ shape (N, nx); row 0 NaN. The position/angle rows of f are the
        kinematics: for a vehicle J(eta) nu (6), whatever its dynamics."""
        out = np.full(data.x.shape, np.nan)
        out[1:] = data.x[:-1]
        eta = _eta_rows(data)
        if data.n_samples < 2 or eta.size == 0:
            return out
        f = np.asarray(model.f(data.t[:-1], data.x[:-1], data.u[:-1]))
        out[1:, eta] += _steps(data)[:, None] * f[:, eta]
        return out

    def prediction_jacobians(
        self, model: Any, data: Trajectory, signal: Any = None, *, cache: Any = None
    ) -> np.ndarray:
        """I, plus h_n df_eta/dx in the position/angle rows; shape (N, 1, nx, nx)."""
        phi = np.full((data.n_samples, 1, data.nx, data.nx), np.nan)
        if data.n_samples < 2:
            return phi
        phi[1:, 0] = np.eye(data.nx)
        eta = _eta_rows(data)
        if eta.size:
            jac = np.asarray(model.jacobian(data.t[:-1], data.x[:-1], data.u[:-1]))
            phi[1:, 0, eta, :] += _steps(data)[:, None, None] * jac[:, eta, :]
        return phi


#: The baselines every error table shows, in this order.
BASELINES: dict[str, Any] = {"hold": Hold(), "kinematics": Kinematics()}


def baseline_names() -> tuple[str, ...]:
    """("hold", "kinematics")."""
    return tuple(BASELINES)


def get_baseline(name: str) -> Any:
    """The baseline called ``name``: ``"hold"`` (x^_{n+1} = x_n) or ``"kinematics"``
    (positions and angles advanced with the sampled rates through the kinematics (6),
    the rates held); see the module docstring for why they are no registered rules.

    A baseline predicts as a rule does, on any time grid::

        hold = sd.get_baseline("hold")
        x_hat = hold.predict(model, measured)        # shape (N, nx), row 0 NaN
        errors = sd.local_errors(x_hat, measured)

    and gives ``prediction_jacobians(model, data)`` (shape (N, 1, nx, nx)) for the noise
    floor (:func:`sampledyn.sensitivity.noise_floor_squares`). ``sampledyn evaluate``
    and :func:`sampledyn.advise` put both beside the rules' errors.

    Raises
    ------
    ArgumentError
        (a ``ValueError``) for an unknown name, listing the baselines.
    """
    try:
        return BASELINES[name]
    except (KeyError, TypeError):
        raise ArgumentError(
            "name", f"unknown baseline {name!r}; the baselines are {', '.join(BASELINES)}."
        ) from None
