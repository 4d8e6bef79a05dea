"""The disturbed local-error bound of eqs. (24)-(25), part by part.

For a rule with noise gain G (see :mod:`._gains`) and uniform noise of amplitude
vector ``a`` (``|delta_i| <= a_i``), the disturbed local error of block b (eta or v)
at every sample n obeys

    ||eps~_b,n+1|| <= ||eps_b||_max                       truncation
                    + 2 ||a_b||                           noise difference
                    + (G(L_D) (||a_eta||, ||a_v||))_b     Jacobian (a_s) term
                    + (G(L_D+) - G(L_D)) (...)_b          second order

Norms are Euclidean over the six components of the block (m and rad mixed for eta,
m/s and rad/s for v) at one sample, the norm of the measured errors' per-sample
values; the bound is on their maximum over the samples.

* Truncation: ``||eps_b||_max``, the largest undisturbed local error of the rule on
  exact samples of a reference run of the model at the same h (the eps of (11)-(12),
  computed rather than estimated; it includes the effect of the kinks of |v| v and
  n |n|, which the asymptotic ``gamma_s h^{s+1} max ||x^{(s+1)}||`` misses). For AB_s
  the classical estimate ``gamma_s h max ||nabla^s f_n||`` (= gamma_s h^{s+1}
  x^{(s+1)} to leading order, the derivative taken by s-th differences of f along the
  reference) is reported beside it.
* Noise difference: ``||delta_{n+1} - delta_n|| <= 2 ||a_b||``; the largest Euclidean
  norm of a vector uniform in the box [-a, a] is ``||a||``.
* Jacobian term: the gain with the Jacobian maxima ``L_D`` over the domain D of the
  clean states (eqs. (19)-(23)).
* Second order: by the mean-value theorem ``f(x + delta) - f(x)`` is bounded exactly
  by the Jacobian maxima over the domain D+ widened by the noise amplitudes; the
  excess over the first-order term, ``G(L_D+) - G(L_D)``, is O(||delta||^2) and
  replaces the paper's ``s o_v + s o_eta``. (Runge-Kutta and Tustin stages are assumed
  to stay inside D+.)

The Jacobian and second-order terms need f Lipschitz on D+: true of the vehicles,
whose f is continuous (|v| v and n |n| are kinks). A model whose f jumps (``sign``,
``Heaviside`` or ``Piecewise`` of a state: Coulomb friction, a relay) has no Jacobian
across its switching surfaces and no such bound; its Jacobian there is that of one
branch (:meth:`sampledyn.models.SymbolicModel.jacobian`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

from .. import _checks as checks
from .._local_errors import sum_of_squares
from .._noise import NOISE_REFERENCE, noise_amplitudes
from .._trajectory import Trajectory
from ..exceptions import ArgumentError
from ..methods import Method, stencil_steps
from ..methods._base import fixed_step
from ..models import Model, Vehicle
from ._domain import Domain, check_vehicle, pitch_guard
from ._gains import error_constant, first_order_gain, noise_gain, supported_method
from ._jacobians import JacobianReport, _jacobian_bounds

__all__ = [
    "BoundParts",
    "ErrorBound",
    "block_error_norms",
    "disturbed_error_bound",
    "domain_maxima",
    "exact_reference",
    "period_ratio",
    "reference_at",
    "state_blocks",
    "subsample",
    "truncation_errors",
]

# The blocks of the 6-DoF vehicle of eqs. (5)-(7): eta then v.
ETA = slice(0, 6)
V = slice(6, 12)


def state_blocks(state_units: Any, argument: str = "model") -> tuple[Any, Any]:
    """The position/angle (eta: units m, rad) and rate (v: m/s, rad/s) components of a
    state, as slices when contiguous (index arrays otherwise).

    Raises
    ------
    ValueError
        naming the first state whose unit is none of these, or a missing block.
    """
    units = tuple(state_units)
    bad = [(i, u) for i, u in enumerate(units) if u not in NOISE_REFERENCE]
    if bad:
        i, u = bad[0]
        raise ValueError(
            f"`{argument}`: the sensitivity analysis splits the state into positions/angles "
            f"(units m, rad) and rates (m/s, rad/s); state {i} has unit {u!r} (units: "
            f"{', '.join(units)}). Give every state one of these units."
        )
    kind = np.array([NOISE_REFERENCE[u][0] for u in units])
    out = []
    for name, label in (("eta", "positions/angles (m, rad)"), ("v", "rates (m/s, rad/s)")):
        idx = np.flatnonzero(kind == name)
        if idx.size == 0:
            raise ValueError(
                f"`{argument}` has no {label} among its states (units: {', '.join(units)}); "
                "the analysis needs both blocks."
            )
        contiguous = idx.size == 1 or bool((np.diff(idx) == 1).all())
        out.append(slice(int(idx[0]), int(idx[-1]) + 1) if contiguous else idx)
    return out[0], out[1]


@dataclass(frozen=True)
class BoundParts:
    """The four parts of the bound on one block (state units, Euclidean over 6 components).

    Attributes
    ----------
    truncation : float
        Largest undisturbed local error ``||eps||`` on the reference.
    noise_difference : float
        ``2 ||a||``, the bound on ``||delta_{n+1} - delta_n||``.
    jacobian_term : float
        The noise passed through the rule, first order: ``a_s h (L ||a||)`` for AB_s.
    second_order : float
        The rest of the noise term, from the Jacobian maxima over the widened domain.
    """

    truncation: float
    noise_difference: float
    jacobian_term: float
    second_order: float

    @property
    def noise(self) -> float:
        """Everything the noise contributes: noise difference + Jacobian + second order."""
        return self.noise_difference + self.jacobian_term + self.second_order

    @property
    def total(self) -> float:
        """The bound: truncation + noise."""
        return self.truncation + self.noise


@dataclass(frozen=True)
class ErrorBound:
    """Bound (24)-(25) on the disturbed local errors of one rule at one h and noise level.

    Attributes
    ----------
    method : str
    h : float
        Sampling period (s).
    eta_pct, v_pct : float
        Noise levels (% of 1 m, 30 deg; 1 m/s, 30 deg/s).
    eta, v : BoundParts
        Position (m, rad) and velocity (m/s, rad/s) blocks.
    gain : ndarray, shape (2, 2)
        Noise gain with the clean-domain Jacobian maxima (see :func:`noise_gain`).
    first_order_gain : float
        a_s for AB_s, 1 for RK_s and T.
    noise_norms : tuple of float
        ``(||a_eta||, ||a_v||)``, the largest noise vector norms.
    truncation_estimate : tuple of float or None
        ``C h max ||nabla^s f||`` per block (eta, v) for the rules that extrapolate
        sampled f (AB_s: C = gamma_s); None for the others.
    jacobians, jacobians_widened : JacobianReport
        Maxima over the domain of the clean states and over it widened by the noise.
    """

    method: str
    h: float
    eta_pct: float
    v_pct: float
    eta: BoundParts
    v: BoundParts
    gain: np.ndarray
    first_order_gain: float
    noise_norms: tuple[float, float]
    truncation_estimate: tuple[float, float] | None
    jacobians: JacobianReport
    jacobians_widened: JacobianReport

    @property
    def total(self) -> tuple[float, float]:
        """``(bound on ||eps~_eta||, bound on ||eps~_v||)``."""
        return (self.eta.total, self.v.total)


def subsample(traj: Trajectory, k: int) -> Trajectory:
    """Every k-th sample of ``traj`` (sampling period ``k h``), without noise or certificate."""
    if k == 1:
        return traj.replace(clean=None, certificate=None)
    return traj.replace(
        t=traj.t[::k], x=traj.x[::k], u=traj.u[::k], h=traj.h * k, clean=None, certificate=None
    )


def period_ratio(h: float, base: float, argument: str = "h") -> int:
    """The integer k with h = k base (s), or a ValueError naming ``argument``."""
    k = checks.integer_ratio(h, base)
    if k is None:
        raise ArgumentError(
            argument,
            f"`{argument}` h = {h} s must be an integer multiple of the reference sampling "
            f"period {base} s; simulate the reference with a divisor of h.",
        )
    return k


def exact_reference(reference: Any) -> Trajectory:
    """The exact samples of ``reference`` (its ``clean`` samples if it is measured).

    Raises
    ------
    TypeError
        if it is not a Trajectory.
    """
    if not isinstance(reference, Trajectory):
        raise TypeError(
            f"`reference` must be a Trajectory of exact samples (sampledyn.simulate), got "
            f"{type(reference).__name__}."
        )
    return reference.clean if reference.clean is not None else reference


def reference_at(reference: Any, h: float) -> Trajectory:
    """The exact samples of ``reference`` at period ``h`` (a multiple of its period)."""
    clean = exact_reference(reference)
    return subsample(clean, period_ratio(h, clean.h))


def domain_maxima(
    model: Vehicle,
    clean: Trajectory,
    signal: Any,
    domain: Domain | None,
    amplitudes: np.ndarray,
    samples: int,
    *,
    stacklevel: int = 4,
) -> tuple[Domain, JacobianReport, JacobianReport]:
    """The domain of the bound (default: the box of ``clean`` and its input), checked
    against the pitch singularity, and the Jacobian maxima over it and over it widened
    by the noise. ``stacklevel`` of the pitch warning as seen from here."""
    if domain is None:
        domain = Domain.from_trajectory(clean, model.n_max, signal)
    elif not isinstance(domain, Domain):
        raise TypeError(f"`domain` must be a sensitivity.Domain, got {type(domain).__name__}.")
    pitch_guard(model, domain.theta_max_deg, "domain.theta_max_deg", stacklevel=stacklevel)
    jac, jac_plus = jacobian_pair(model, domain, amplitudes, samples)
    return domain, jac, jac_plus


def block_error_norms(errors: np.ndarray, state_units: Any = None) -> tuple[np.ndarray, np.ndarray]:
    """Per-sample Euclidean norms over the eta and the v components, shapes (N,) each
    (the blocks from ``state_units``, :func:`state_blocks`; default the vehicle's 6 + 6).

    NaN rows (no prediction) stay NaN.
    """
    e = np.asarray(errors, dtype=float)
    eta, v = (ETA, V) if state_units is None else state_blocks(state_units)
    # The sum of squares as sampledyn.error_norm forms it, so a bound built from
    # these norms and an error measured by the engine compare to the last bit.
    return np.sqrt(sum_of_squares(e, eta)), np.sqrt(sum_of_squares(e, v))


def _nanmax(a: np.ndarray) -> float:
    a = a[~np.isnan(a)]
    if a.size == 0:
        raise ValueError("no prediction: the run is shorter than the method's history.")
    return float(a.max())


def truncation_errors(
    model: Model, method: str | Method, clean: Trajectory, signal: Any = None
) -> tuple[float, float]:
    """Largest undisturbed local errors ``(max ||eps_eta||, max ||eps_v||)`` of ``method``
    on exact samples ``clean`` (state units)."""
    m = supported_method(method)
    x_hat = m.predict(model, clean, signal)
    e_eta, e_v = block_error_norms(clean.x - x_hat, clean.state_units)
    return _nanmax(e_eta), _nanmax(e_v)


def truncation_estimate(model: Model, m: Any, clean: Trajectory) -> tuple[float, float] | None:
    """``C h max ||nabla^s f||`` per block, for the rules that extrapolate sampled f."""
    d = m.truncation_differences(model, clean)
    if d is None or d.shape[0] == 0 or m.error_constant is None:
        return None
    gamma = float(error_constant(m) or 0)
    e_eta, e_v = block_error_norms(d, clean.state_units)
    return gamma * clean.h * float(e_eta.max()), gamma * clean.h * float(e_v.max())


@lru_cache(maxsize=64)
def _cached_jacobians(vehicle: Any, domain: Domain, samples: int) -> JacobianReport:
    return _jacobian_bounds(vehicle, domain, samples=samples)


def jacobian_pair(
    vehicle: Any, domain: Domain, amplitudes: np.ndarray, samples: int = 5000
) -> tuple[JacobianReport, JacobianReport]:
    """Jacobian maxima over the domain and over it widened by the noise (cached)."""
    widened = domain.enlarged(amplitudes)
    return (
        _cached_jacobians(vehicle, domain, samples),
        _cached_jacobians(vehicle, widened, samples),
    )


def block_noise(amplitudes: np.ndarray, state_units: Any = None) -> np.ndarray:
    """``(||a_eta||, ||a_v||)``: the largest noise vector norms of the two blocks."""
    eta, v = (ETA, V) if state_units is None else state_blocks(state_units)
    a = np.asarray(amplitudes, dtype=float)
    return np.array([np.linalg.norm(a[eta]), np.linalg.norm(a[v])])


def _apply(g: np.ndarray, a: np.ndarray) -> np.ndarray:
    """``g @ a`` where a zero noise contributes nothing even through an infinite gain."""
    terms = np.where(a[None, :] > 0, g * np.where(a > 0, a, 1.0)[None, :], 0.0)
    return terms.sum(axis=1)


def assemble_bound(
    method: str | Method,
    h: float,
    eta_pct: float,
    v_pct: float,
    amplitudes: np.ndarray,
    jacobians: JacobianReport,
    widened: JacobianReport,
    truncation: tuple[float, float],
    truncation_estimate: tuple[float, float] | None = None,
    samples: Trajectory | None = None,
) -> ErrorBound:
    """Put the parts of (24)-(25) together (no simulation).

    ``samples``, the data the bound is for, matters only when their time is not
    uniform: the gains are then taken at the largest step and the largest step
    ratio of a stencil (:func:`sampledyn.methods.stencil_steps`), which the rule's
    noise gain accounts for (or refuses with a message naming them)."""
    m = supported_method(method)
    a = block_noise(amplitudes)
    h_gain, ratio = (h, 1.0)
    if samples is not None and fixed_step(samples) is None:
        h_gain, ratio = stencil_steps(samples, m.history)
    g = noise_gain(m, h_gain, jacobians.lipschitz, ratio)
    g_plus = noise_gain(m, h_gain, widened.lipschitz, ratio)
    first = _apply(g, a)
    with np.errstate(invalid="ignore"):
        second = _apply(g_plus, a) - first
    parts = [
        BoundParts(
            truncation=float(truncation[b]),
            noise_difference=float(2.0 * a[b]),
            jacobian_term=float(first[b]),
            second_order=float(second[b]) if np.isfinite(second[b]) else math.inf,
        )
        for b in (0, 1)
    ]
    return ErrorBound(
        method=m.name,
        h=float(h),
        eta_pct=float(eta_pct),
        v_pct=float(v_pct),
        eta=parts[0],
        v=parts[1],
        gain=g,
        first_order_gain=float(first_order_gain(m)),
        noise_norms=(float(a[0]), float(a[1])),
        truncation_estimate=truncation_estimate,
        jacobians=jacobians,
        jacobians_widened=widened,
    )


def disturbed_error_bound(
    model: Vehicle,
    method: str | Method,
    h: float,
    eta_pct: float,
    v_pct: float,
    domain: Domain | None = None,
    *,
    reference: Trajectory,
    signal: Any = None,
    samples: int = 5000,
) -> ErrorBound:
    """Bound (24)-(25) on the disturbed local errors of ``method`` on noisy samples.

    Parameters
    ----------
    model : Vehicle
        The 6-DoF vehicle (no thruster lag).
    method : str or method object
        "E", "AB<s>", "RK<s>" or "T".
    h : float
        Sampling period (s).
    eta_pct, v_pct : float
        Uniform noise levels, % of 1 m / 30 deg and of 1 m/s / 30 deg/s
        (:func:`sampledyn._noise.noise_amplitudes`).
    domain : Domain, optional
        Box of the clean states for the Jacobian maxima; default: the smallest box
        holding the reference run (and its input).
    reference : Trajectory
        Exact samples at h or at a divisor of h (the truncation term comes from them),
        e.g. from :func:`sampledyn.simulate` (this function simulates nothing).
    signal : Signal, optional
        The input (for Runge-Kutta stages between samples, and the domain's rpm).
    samples : int
        Random samples for the Jacobian check (:func:`jacobian_bounds`).

    Returns
    -------
    ErrorBound
        Bounds on ``max_n ||eps~_eta,n||`` and ``max_n ||eps~_v,n||`` with their parts.

    Raises
    ------
    ValueError
        If the domain (or its widening by the pitch noise) reaches theta = 90 deg, or
        h is not a multiple of the reference's period.

    Warns
    -----
    UserWarning
        If the domain's pitch exceeds the vehicle's ``pitch_limit_deg``.
    """
    check_vehicle(model, "model")
    m = supported_method(method)
    h = checks.period(h)
    amplitudes = noise_amplitudes(model.state_units, eta_pct, v_pct)
    clean = reference_at(reference, h)
    _, jac, jac_plus = domain_maxima(model, clean, signal, domain, amplitudes, samples)
    trunc = truncation_errors(model, m, clean, signal)
    return assemble_bound(
        m,
        h,
        eta_pct,
        v_pct,
        amplitudes,
        jac,
        jac_plus,
        trunc,
        truncation_estimate(model, m, clean),
        samples=clean,
    )
