"""First-order prediction of the disturbed local errors along a reference path.

The domain bound (24)-(25) takes every Jacobian at its worst over a box and splits
the noise as ``2||delta|| + gain ||delta||``; it cannot see that damping makes a
one-step rule forget its starting noise, and for Runge-Kutta and Tustin at h L >~ 1
it is loose by orders of magnitude. Linearising the rule's prediction in the noise,
sample by sample, gives

    eps~_{n+1} = eps_{n+1} + delta_{n+1} - sum_i Phi_{n,i} delta_{n-i} + O(||delta||^2),

with ``Phi_{n,i} = d x^_{n+1} / d x_{n-i}`` evaluated on the exact samples, which the
rule computes itself (:meth:`sampledyn.methods.Method.prediction_jacobians`; e.g. for
AB_s ``Phi_{n,0} = I + h a_0 F(x_n)``, ``Phi_{n,i} = h a_i F(x_{n-i})``, F = df/dx).

The predicted error of block b at sample n is then

    ||eps_b,n+1|| + ||a_b|| + sum_i sum_c ||Phi_{n,i}[b, c]|| ||a_c||     (c = eta, v),

an upper bound to first order in the noise (exact Jacobians, the triangle inequality
only), and the prediction is its maximum over the samples.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .._trajectory import Trajectory
from ..methods import Method
from ..models import Model
from ._bound import block_error_norms, block_noise, state_blocks
from ._gains import supported_method
from ._jacobians import spectral_norm

__all__ = ["PathPrediction", "path_prediction"]


@dataclass(frozen=True)
class PathPrediction:
    """Predicted largest disturbed local errors (first order in the noise).

    Attributes
    ----------
    method : str
    h, eta_pct, v_pct : float
    eta, v : float
        Predicted ``max_n ||eps~_eta,n||`` (m, rad) and ``max_n ||eps~_v,n||`` (m/s, rad/s).
    truncation : tuple of float
        Largest undisturbed local errors (eta, v).
    noise : tuple of float
        Largest noise parts (eta, v).
    """

    method: str
    h: float
    eta_pct: float
    v_pct: float
    eta: float
    v: float
    truncation: tuple[float, float]
    noise: tuple[float, float]


def _block_norms(phi: np.ndarray, eta: Any, v: Any) -> np.ndarray:
    """Spectral norms of the 2 x 2 blocks, shape (N, 2, 2) from (N, nx, nx)."""
    out = np.empty(phi.shape[:-2] + (2, 2))
    for i, r in enumerate((eta, v)):
        for j, c in enumerate((eta, v)):
            out[..., i, j] = spectral_norm(phi[..., r, :][..., c])
    return out


def path_prediction(
    model: Model,
    method: str | Method,
    clean: Trajectory,
    amplitudes: np.ndarray,
    signal: Any = None,
    eta_pct: float = float("nan"),
    v_pct: float = float("nan"),
    *,
    cache: dict[Any, Any] | None = None,
) -> PathPrediction:
    """First-order prediction of the largest disturbed local errors of ``method`` on
    noisy copies of the exact samples ``clean`` (see the module docstring).

    Parameters
    ----------
    model : Model
        A vehicle, or any model whose states are positions/angles (units m, rad) and
        rates (m/s, rad/s) (:func:`state_blocks`), with an exact Jacobian.
    method : str or method object
        A fixed rule, or any object with ``predict`` and ``prediction_jacobians`` (a
        baseline, :mod:`sampledyn._baselines`).
    clean : Trajectory
        Exact samples at the sampling period of interest, ``x`` shape (N, nx).
    amplitudes : ndarray, shape (nx,)
        Uniform noise amplitudes per state component (state units).
    signal : Signal, optional
        Input between samples, for Runge-Kutta stages.
    eta_pct, v_pct : float
        Noise levels, for the record.
    cache : dict, optional
        Kept by the caller for several rules on the same ``clean``: f and df/dx at the
        samples are then computed once (see :meth:`sampledyn.methods.Method.predict`).
    """
    # a rule with a noise bound by name or object, or any object that predicts and
    # gives its prediction Jacobians (the baselines of sampledyn._baselines)
    is_object = not isinstance(method, str) and hasattr(method, "prediction_jacobians")
    m: Any = method if is_object else supported_method(method)
    eta, v = state_blocks(clean.state_units)
    a = block_noise(amplitudes, clean.state_units)
    x_hat = m.predict(model, clean, signal, cache=cache)
    t_eta, t_v = block_error_norms(clean.x - x_hat, clean.state_units)
    phi = m.prediction_jacobians(model, clean, signal, cache=cache)
    noise = np.full((clean.n_samples, 2), np.nan)
    rows = ~np.isnan(phi).any(axis=(1, 2, 3))
    acc = np.zeros((int(rows.sum()), 2))
    for i in range(phi.shape[1]):
        acc += _block_norms(phi[rows, i], eta, v) @ a
    noise[rows] = a[None, :] + acc
    tot_eta = t_eta + noise[:, 0]
    tot_v = t_v + noise[:, 1]
    keep = ~np.isnan(tot_eta) & ~np.isnan(tot_v)
    if not keep.any():
        raise ValueError("no prediction: the run is shorter than the method's history.")
    return PathPrediction(
        method=m.name,
        h=float(clean.h),
        eta_pct=float(eta_pct),
        v_pct=float(v_pct),
        eta=float(tot_eta[keep].max()),
        v=float(tot_v[keep].max()),
        truncation=(float(t_eta[keep].max()), float(t_v[keep].max())),
        noise=(float(noise[keep, 0].max()), float(noise[keep, 1].max())),
    )
