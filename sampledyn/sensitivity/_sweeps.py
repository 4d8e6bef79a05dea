"""Sensitivity of the bound to the pitch angle, and vehicles of scaled inertia
(section 5.2). The study that simulates the scaled vehicles and measures their errors
is :func:`sampledyn.experiments.inertia_sensitivity`."""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._noise import noise_amplitudes
from ._bound import ETA, V, _apply
from ._domain import Domain, check_vehicle, pitch_guard
from ._gains import noise_gain, supported_method
from ._jacobians import J_norm, _corners, _jac, _v_blocks, dJ_norm, spectral_norm

__all__ = ["PitchSensitivity", "pitch_sensitivity", "scaled_inertia"]

DEFAULT_PITCH_DOMAIN = Domain(
    v_max=(0.1, 0.05, 0.05, 0.3, 0.3, 0.3), phi_max_deg=10.0, theta_max_deg=0.0, rpm_frac=0.2
)


@dataclass(frozen=True)
class PitchSensitivity:
    """Jacobian norms and the position-error bound against the pitch limit.

    Every array has shape (K,), one entry per ``theta_deg``.

    Attributes
    ----------
    theta_deg : ndarray
        Pitch limits |theta| <= theta (deg).
    J_norm : ndarray
        ``||J(eta)||`` at theta, eq. (22) (= 1/sqrt(1 - |sin theta|)).
    dJ_norm : ndarray
        ``||dJ/deta||`` at theta (operator norm, see :func:`dJ_norm`), eq. (23).
    L_eta_eta, L_eta_v, L_v_eta : ndarray
        Maxima of the Jacobian blocks over the domain with |theta| <= theta.
    L_v_v : float
        Maximum of df_v/dv over the domain (independent of theta).
    noise_bound_eta, noise_bound_v : ndarray
        Noise part of the bound (24)-(25) on the position (m, rad) and velocity
        (m/s, rad/s) errors (noise difference + gain terms + second order; no
        truncation, which depends on the motion).
    method : str
    h, eta_pct, v_pct : float
    domain : Domain
        The other bounds (v, phi, rpm) of the domain.
    """

    theta_deg: np.ndarray
    J_norm: np.ndarray
    dJ_norm: np.ndarray
    L_eta_eta: np.ndarray
    L_eta_v: np.ndarray
    L_v_eta: np.ndarray
    L_v_v: float
    noise_bound_eta: np.ndarray
    noise_bound_v: np.ndarray
    method: str
    h: float
    eta_pct: float
    v_pct: float
    domain: Domain


def _angle_maxima(vehicle: Any, dom: Domain, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per pitch angle: max over |phi| <= phi_max and the v-box corners of
    ||d(J v)/deta||, and max over phi of ||M^-1 dg/deta||. Shapes (len(theta),)."""
    phis = np.linspace(-dom.phi_max, dom.phi_max, 9) if dom.phi_max > 0 else np.zeros(1)
    corners = _corners(dom.v_array)
    nt, npf, nc = theta.size, phis.size, corners.shape[0]
    th = np.repeat(theta, npf * nc)
    ph = np.tile(np.repeat(phis, nc), nt)
    v = np.tile(corners, (nt * npf, 1))
    jac = _jac(vehicle, ph, th, v, np.zeros(vehicle.nu))
    ee = spectral_norm(jac[:, ETA, ETA]).reshape(nt, npf * nc).max(axis=1)
    ve = spectral_norm(jac[:, V, ETA]).reshape(nt, npf * nc).max(axis=1)
    return ee, ve


def pitch_sensitivity(
    vehicle: Any,
    theta_deg: Any = None,
    *,
    method: str = "AB4",
    h: float = 0.1,
    eta_pct: float = 0.0,
    v_pct: float = 2.0,
    domain: Domain | None = None,
) -> PitchSensitivity:
    """How the Jacobian norms and the bound grow as the pitch limit nears 90 deg.

    Parameters
    ----------
    vehicle : Vehicle
    theta_deg : array_like, shape (K,), optional
        Pitch limits (deg); default 0, 1, ..., 89.
    method : str
        Rule whose noise gain is used.
    h : float
        Sampling period (s).
    eta_pct, v_pct : float
        Noise levels (%).
    domain : Domain, optional
        Bounds on v, |phi| and rpm (its own theta is replaced by each entry of
        ``theta_deg``). Default: |u| <= 0.1 m/s, |v|, |w| <= 0.05 m/s, rates <= 0.3
        rad/s, |phi| <= 10 deg, |n| <= 0.2 n_max.

    Returns
    -------
    PitchSensitivity

    Raises
    ------
    ValueError
        If some theta is within the vehicle's ``pitch_tolerance_deg`` of 90 deg.

    Warns
    -----
    UserWarning
        If some theta exceeds the vehicle's ``pitch_limit_deg``.
    """
    check_vehicle(vehicle)
    m = supported_method(method)
    th_deg = (
        np.arange(0.0, 90.0)
        if theta_deg is None
        else np.atleast_1d(np.asarray(theta_deg, dtype=float))
    )
    if th_deg.ndim != 1 or not np.isfinite(th_deg).all() or (th_deg < 0).any():
        raise ValueError(f"`theta_deg` must be angles >= 0 (deg), got {theta_deg!r}.")
    pitch_guard(vehicle, th_deg, "theta_deg", stacklevel=3)
    dom = DEFAULT_PITCH_DOMAIN if domain is None else domain
    amp = noise_amplitudes(vehicle.state_units, eta_pct, v_pct)
    a = np.array([np.linalg.norm(amp[ETA]), np.linalg.norm(amp[V])])
    a_theta = math.degrees(amp[4])
    top = float(th_deg.max()) + a_theta
    if top >= 90.0 - vehicle.pitch_tolerance_deg:
        raise ValueError(
            f"the pitch noise ({a_theta:.3g} deg) takes `theta_deg` up to {top:.4g} deg, "
            "within the pitch tolerance of 90 deg; lower `eta_pct` or the angles."
        )
    # A fine grid of |theta| for the running maxima over 0 <= |theta| <= limit.
    fine = np.union1d(np.linspace(0.0, top, int(4 * top) + 2), np.append(th_deg, th_deg + a_theta))
    fine = fine[fine <= top + 1e-12]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ee, ve = _angle_maxima(vehicle, dom, np.radians(fine))
        ee_neg, ve_neg = _angle_maxima(vehicle, dom, -np.radians(fine))
        dj = dJ_norm(vehicle, np.radians(th_deg))
    run_ee = np.maximum.accumulate(np.maximum(ee, ee_neg))
    run_ve = np.maximum.accumulate(np.maximum(ve, ve_neg))
    vv = float(_v_blocks(vehicle, dom)["combined"])
    vv_plus = float(
        _v_blocks(vehicle, Domain(tuple(dom.v_array + amp[V]), 0.0, 0.0, dom.rpm_frac))["combined"]
    )

    def at(limit: np.ndarray, run: np.ndarray) -> np.ndarray:
        idx = np.searchsorted(fine, limit - 1e-9)
        return run[np.minimum(idx, fine.size - 1)]

    l_ee, l_ve = at(th_deg, run_ee), at(th_deg, run_ve)
    l_ee_p, l_ve_p = at(th_deg + a_theta, run_ee), at(th_deg + a_theta, run_ve)
    jn = J_norm(np.radians(th_deg))
    jn_p = J_norm(np.radians(th_deg + a_theta))
    # Noise part of (24)-(25): 2||a|| + G(L over the noise-widened domain) a, i.e. the
    # first-order term plus the second-order excess, as in disturbed_error_bound.
    nb = np.empty((th_deg.size, 2))
    for i in range(th_deg.size):
        gp = noise_gain(m, h, np.array([[l_ee_p[i], jn_p[i]], [l_ve_p[i], vv_plus]]))
        nb[i] = 2.0 * a + _apply(gp, a)
    return PitchSensitivity(
        theta_deg=th_deg,
        J_norm=jn,
        dJ_norm=dj,
        L_eta_eta=l_ee,
        L_eta_v=jn,
        L_v_eta=l_ve,
        L_v_v=vv,
        noise_bound_eta=nb[:, 0],
        noise_bound_v=nb[:, 1],
        method=m.name,
        h=float(h),
        eta_pct=float(eta_pct),
        v_pct=float(v_pct),
        domain=dom,
    )


def scaled_inertia(vehicle: Any, scale: float) -> Any:
    """The vehicle with M scaled: mass, rigid-body inertia, added mass and displaced
    volume all times ``scale`` (the volume keeps the buoyancy-to-weight ratio, so the
    restoring terms scale too and M^-1 g(eta) is unchanged)."""
    if not (isinstance(scale, int | float) and math.isfinite(scale) and scale > 0):
        raise ValueError(f"`scale` must be a positive number, got {scale!r}.")
    return vehicle.with_params(
        mass=vehicle.mass * scale,
        inertia=tuple(np.asarray(vehicle.inertia) * scale),
        added_mass=tuple(np.asarray(vehicle.added_mass) * scale),
        volume=vehicle.volume * scale,
        name=f"{vehicle.name} x{scale:g} inertia",
    )
