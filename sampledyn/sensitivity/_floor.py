"""The noise floor: the one-step error that measurement noise alone gives through a rule.

With white noise delta_k of covariance Sigma = diag(sigma^2) on every sample, a rule's
one-step error on noisy data carries, to first order in the noise,

    delta_{n+1} - sum_i Phi_{n,i} delta_{n-i},    Phi_{n,i} = d x^_{n+1} / d x_{n-i}

(the rule's own prediction Jacobians, :meth:`sampledyn.methods.NoiseAnalysis.
prediction_jacobians`, as in :mod:`sampledyn.sensitivity._path`). Its expected square
in state component j is

    sigma_j^2 + sum_i (Phi_{n,i} Sigma Phi_{n,i}^T)_jj,

which is what this module computes per sample. The root mean square of a block of it
is the rule's noise floor: an rms error that does not exceed it by a margin measures
the sensor, not the model. For the hold baseline (Phi = I) the floor is sqrt(2) sigma
per component; for every consistent rule at h -> 0 it tends to the same, and it
grows with the rule's noise gain (about a_s h ||F|| above it for AB_s, a_s = sum
|a_i|: 1 for Euler, 6.67 for AB4).
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["FLOOR_FACTOR", "noise_floor_squares"]

#: An rms error within this factor of the noise floor counts as "at the floor": if the
#: model's own error e_m adds to the noise part in quadrature (independent), e <=
#: 1.25 floor means e_m <= sqrt(1.25^2 - 1) floor = 0.75 floor, below the noise.
FLOOR_FACTOR = 1.25


def noise_floor_squares(
    method: Any,
    model: Any,
    data: Any,
    sigma: Any,
    signal: Any = None,
    *,
    cache: dict[Any, Any] | None = None,
) -> np.ndarray:
    """Expected squared one-step error from the noise alone, per sample and state
    component, shape (N, nx) (state units squared); NaN where the rule predicts
    nothing (its first ``history`` rows).

    Parameters
    ----------
    method : method object
        With ``prediction_jacobians(model, data, signal)`` (the fixed rules and the
        baselines of :mod:`sampledyn._baselines`).
    model : Model
    data : Trajectory
        The (measured) samples; the Jacobians are taken there, which is right to
        first order in the noise.
    sigma : array_like, shape (nx,)
        Noise standard deviation of each state (state units); NaN counts as 0 (a state
        whose noise is unknown adds nothing).
    signal : Signal, optional
        As for the rule's predictions.
    cache : dict, optional
        f and df/dx at the samples, shared with the predictions.
    """
    s2 = np.nan_to_num(np.asarray(sigma, dtype=float), nan=0.0) ** 2
    phi = np.asarray(method.prediction_jacobians(model, data, signal, cache=cache))
    # (Phi Sigma Phi^T)_jj = sum_c Phi_jc^2 sigma_c^2, for every lag i, summed over i
    spread = np.einsum("nijc,c->nj", phi * phi, s2)
    return np.asarray(s2[None, :] + spread)
