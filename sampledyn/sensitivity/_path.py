"""First-order prediction of the disturbed local errors along a reference path.

The domain bound (24)-(25) takes every Jacobian at its worst over a box and splits
the noise as ``2||delta|| + gain ||delta||``; it cannot see that damping makes a
one-step rule forget its starting noise, and for Runge-Kutta and Tustin at h L >~ 1
it is loose by orders of magnitude. Linearising the rule's prediction in the noise,
sample by sample, gives

    eps~_{n+1} = eps_{n+1} + delta_{n+1} - sum_i Phi_{n,i} delta_{n-i} + O(||delta||^2),

with ``Phi_{n,i} = d x^_{n+1} / d x_{n-i}`` evaluated on the exact samples:

* AB_s: ``Phi_{n,0} = I + h a_0 F(x_n)``, ``Phi_{n,i} = h a_i F(x_{n-i})`` (F = df/dx);
* RK_s: ``Phi_{n,0}`` only, forward-mode through the stages of eq. (8);
* Tustin: ``Phi_{n,0} = (I - h/2 F(x^_{n+1}))^-1 (I + h/2 F(x_n))``.

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
from ..methods import AdamsBashforth, Tustin
from ..methods._base import stage_inputs
from ._bound import ETA, V, block_error_norms
from ._gains import supported_method
from ._jacobians import spectral_norm

__all__ = ["PathPrediction", "path_prediction"]

_BLOCKS = ((ETA, ETA), (ETA, V), (V, ETA), (V, V))


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


def _block_norms(phi: np.ndarray) -> np.ndarray:
    """Spectral norms of the 2 x 2 blocks, shape (N, 2, 2) from (N, 12, 12)."""
    out = np.empty(phi.shape[:-2] + (2, 2))
    for (r, c), idx in zip(_BLOCKS, ((0, 0), (0, 1), (1, 0), (1, 1)), strict=True):
        out[..., idx[0], idx[1]] = spectral_norm(phi[..., r, c])
    return out


def _tustin_phi(model: Any, x_hat: np.ndarray, clean: Trajectory, signal: Any) -> np.ndarray:
    """``d x^_{k} / d x_{k-1} = (I - h/2 F(x^_k))^-1 (I + h/2 F(x_{k-1}))``, (N, 12, 12)."""
    h = clean.h
    eye = np.eye(clean.nx)
    f0 = np.asarray(model.jacobian(clean.t[:-1], clean.x[:-1], clean.u[:-1]))
    u1 = stage_inputs(clean, signal, 1.0)
    f1 = np.asarray(model.jacobian(clean.t[1:], x_hat[1:], u1))
    phi = np.full((clean.n_samples, clean.nx, clean.nx), np.nan)
    phi[1:] = np.linalg.solve(eye - 0.5 * h * f1, eye + 0.5 * h * f0)
    return phi


def _runge_kutta_phi(model: Any, m: Any, clean: Trajectory, signal: Any) -> np.ndarray:
    """``d x^_{k} / d x_{k-1}`` of an explicit Runge-Kutta rule, shape (N, 12, 12).

    Forward-mode through the stages of eq. (8): ``dk_i = F(y_i) (I + h sum_j a_ij
    dk_j)`` and ``Phi = I + h sum_i b_i dk_i``, with the stage inputs the rule uses.
    """
    tab = m.tableau
    h = clean.h
    t0, x0 = clean.t[:-1], clean.x[:-1]
    eye = np.eye(clean.nx)
    ks: list[np.ndarray] = []
    dks: list[np.ndarray] = []
    for i in range(tab.stages):
        yi = x0.copy()
        dyi = np.broadcast_to(eye, (x0.shape[0], clean.nx, clean.nx)).copy()
        for j in range(i):
            if tab.a[i][j] != 0:
                yi += (h * float(tab.a[i][j])) * ks[j]
                dyi += (h * float(tab.a[i][j])) * dks[j]
        ci = float(tab.c[i])
        ui = stage_inputs(clean, signal, ci)
        ks.append(np.asarray(model.f(t0 + ci * h, yi, ui)))
        dks.append(np.asarray(model.jacobian(t0 + ci * h, yi, ui)) @ dyi)
    phi = np.full((clean.n_samples, clean.nx, clean.nx), np.nan)
    phi[1:] = eye + h * sum(float(b) * dk for b, dk in zip(tab.b, dks, strict=True))
    return phi


def _diag_shift_norms(jac: np.ndarray, c: float) -> np.ndarray:
    """``||I + c F_bb||`` for the two diagonal blocks, shape (N, 2)."""
    eye = np.eye(6)
    return np.stack([spectral_norm(eye + c * jac[:, r, r]) for r in (ETA, V)], axis=1)


def path_prediction(
    model: Any,
    method: Any,
    clean: Trajectory,
    amplitudes: np.ndarray,
    signal: Any = None,
    eta_pct: float = float("nan"),
    v_pct: float = float("nan"),
    *,
    jac: np.ndarray | None = None,
    jac_norms: np.ndarray | None = None,
) -> PathPrediction:
    """First-order prediction of the largest disturbed local errors of ``method`` on
    noisy copies of the exact samples ``clean`` (see the module docstring).

    Parameters
    ----------
    model : Vehicle
    method : str or method object
    clean : Trajectory
        Exact samples at the sampling period of interest, ``x`` shape (N, 12).
    amplitudes : ndarray, shape (12,)
        Uniform noise amplitudes per state component (state units).
    signal : Signal, optional
        Input between samples, for Runge-Kutta stages.
    eta_pct, v_pct : float
        Noise levels, for the record.
    jac, jac_norms : ndarray, optional
        ``df/dx`` at the samples, shape (N, 12, 12), and its block norms, shape
        (N, 2, 2), when already computed (AB rules only).
    """
    m = supported_method(method)
    a = np.array([np.linalg.norm(amplitudes[ETA]), np.linalg.norm(amplitudes[V])])
    x_hat = m.predict(model, clean, signal)
    t_eta, t_v = block_error_norms(clean.x - x_hat)
    n = clean.x.shape[0]
    noise = np.full((n, 2), np.nan)
    if isinstance(m, AdamsBashforth):
        s, h = m.order, clean.h
        if jac is None:
            jac = np.asarray(model.jacobian(clean.t, clean.x, clean.u))
        if jac_norms is None:
            jac_norms = _block_norms(jac)
        w = m.weights
        acc = np.zeros((n - s, 2))
        for i in range(s):
            src = slice(s - 1 - i, n - 1 - i)  # sample k-1-i for rows k = s..n-1
            norms = abs(h * w[i]) * jac_norms[src]
            if i == 0:  # Phi_{n,0} = I + h a_0 F: its diagonal blocks hold the identity
                diag = _diag_shift_norms(jac[src], h * w[0])
                norms[:, 0, 0] = diag[:, 0]
                norms[:, 1, 1] = diag[:, 1]
            acc += norms @ a
        noise[s:] = a[None, :] + acc
    else:
        if isinstance(m, Tustin):
            phi = _tustin_phi(model, x_hat, clean, signal)
        else:
            phi = _runge_kutta_phi(model, m, clean, signal)
        noise[1:] = a[None, :] + _block_norms(phi[1:]) @ a
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
