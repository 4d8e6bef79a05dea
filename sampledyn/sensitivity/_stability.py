"""Stability before prediction: the largest step at which each rule is stable along
sampled data.

Linearised at a sample, the model's local modes are the eigenvalues lambda of its
Jacobian df/dx there; a rule applied with step h multiplies the mode by its
amplification at z = h lambda (:class:`sampledyn.methods.Stability`: |R(z)| for E,
RK_s and T, the largest root of the characteristic polynomial for AB_s and its
variants). The rule is stable at h along the data when that is <= 1 for every mode
at every sample (Hairer & Wanner, *Solving Ordinary Differential Equations II*,
Sec. IV.2 and V.1). Modes that grow in the model itself (Re lambda > 0) are left
out: no rule is to blame for them; undamped ones (Re lambda = 0 to rounding) count,
and make Euler, AB2 and RK2 unstable at every step (their regions touch the imaginary
axis only at 0; AB3, AB4, RK3, RK4 cover a segment of it, Tustin all of it).

Beyond its limit a rule amplifies the mode at every step: a one-step prediction
carries one factor of it (and the noise gain grows with it), a rollout or a
controller designed on the rule's discrete-time model one per step.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..methods import Stability, get_method, largest_stable_steps

__all__ = ["StabilityLimit", "jacobian_eigenvalues", "stability_limits"]

_BLOCK = 4096  # samples per batch of Jacobians (a (4096, 12, 12) batch is 4.7 MB)

# Re lambda > _GROWING |lambda|: a mode that grows in the model (left out);
# |lambda| < _ZERO max|lambda|: a zero eigenvalue (positions, heading) to rounding.
_GROWING = 1e-9
_ZERO = 1e-12
# Eigenvalues binned by magnitude (decades) and angle (rad) to this resolution; the
# few bins that limit a rule are then solved for every eigenvalue in them.
_BIN_LOG10, _BIN_ANGLE, _REFINE_BINS = 1e-2, 1e-3, 8


def jacobian_eigenvalues(model: Any, traj: Any) -> np.ndarray:
    """Eigenvalues of df/dx at every sample of ``traj``, shape (N, nx), complex (1/s).

    Raises
    ------
    JacobianUnavailableError
        for a model without a Jacobian.
    """
    n = traj.t.shape[0]
    out = np.empty((n, traj.x.shape[1]), dtype=complex)
    for lo in range(0, n, _BLOCK):
        blk = slice(lo, lo + _BLOCK)
        out[blk] = np.linalg.eigvals(model.jacobian(traj.t[blk], traj.x[blk], traj.u[blk]))
    return out


@dataclass(frozen=True)
class StabilityLimit:
    """One rule's stability along sampled data.

    Attributes
    ----------
    method : str
    h : float
        The step examined (s): the data's largest step.
    h_stable : float
        Largest h (s) at which the rule is stable for every mode at every sample; inf
        when no mode limits it, 0 when some mode makes it unstable at every step.
    eigenvalue : complex
        The eigenvalue (1/s) that sets ``h_stable`` (NaN if none does).
    sample : int
        Where it occurs (-1 if none).
    amplification : float
        The rule's growth per step of that mode at ``h`` (> 1: unstable).
    modes : int
        Eigenvalues examined (growing and zero ones left out).
    growing : int
        Eigenvalues with Re lambda > 0 (the model's own growing modes), left out.
    """

    method: str
    h: float
    h_stable: float
    eigenvalue: complex
    sample: int
    amplification: float
    modes: int
    growing: int

    @property
    def stable(self) -> bool:
        """True if the rule is stable at ``h`` along the data."""
        return self.h <= self.h_stable

    def message(self, t: Any = None) -> str:
        """What the limit means, for a warning (``t``: the data's sample times)."""
        lam = self.eigenvalue
        when = "" if t is None or self.sample < 0 else f", t = {float(t[self.sample]):.6g} s"
        mode = f"lambda = {lam.real:.4g}{lam.imag:+.4g}j 1/s (sample {self.sample}{when})"
        if self.h_stable == 0.0:
            # a real negative lambda is damped: what limits the step is the rule's region
            kind = "undamped" if abs(lam.real) <= _GROWING * abs(lam) else "damped"
            where = (
                f"{self.method} is unstable at every step on the {kind} mode {mode}: its "
                "stability region leaves the ray h lambda before h |lambda| = 1e-6 (the "
                "scan's first point), so no practical step is short enough; "
                f"|R(h lambda)| = {self.amplification:.6g} at h = {self.h:.4g} s"
            )
        else:
            where = (
                f"{self.method} at h = {self.h:.4g} s is beyond its stability limit along "
                f"the data: |R(h lambda)| = {self.amplification:.6g} > 1 for {mode}; its "
                f"largest stable step is {self.h_stable:.4g} s"
            )
        return (
            f"{where}. One prediction carries that factor once (its noise gain grows "
            "with it); a rollout or a controller designed on the rule's discrete-time "
            "model grows by it at every step. A rule stable at this h (T is stable on "
            f"every damped mode){'' if self.h_stable == 0.0 else ' or a shorter step'} "
            "avoids it."
        )


def _modes(eig: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """The eigenvalues a rule must be stable on, one of each conjugate pair, with their
    samples: (lambda (M,), sample (M,), number of growing ones left out)."""
    n, nx = eig.shape
    lam = eig.reshape(-1)
    sample = np.repeat(np.arange(n), nx)
    mag = np.abs(lam)
    top = float(mag.max()) if mag.size else 0.0
    growing = lam.real > _GROWING * mag
    keep = (mag > _ZERO * top) & ~growing & (lam.imag >= 0)
    return lam[keep], sample[keep], int((growing & (lam.imag >= 0)).sum())


def _bins(lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(index of each eigenvalue's bin, one representative per bin)."""
    key = np.column_stack(
        [np.round(np.log10(np.abs(lam)) / _BIN_LOG10), np.round(np.angle(lam) / _BIN_ANGLE)]
    )
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    return inverse.reshape(-1), first


def _limit(
    m: Any, lam: np.ndarray, sample: np.ndarray, bins: tuple[np.ndarray, np.ndarray], h: float
) -> tuple[float, int]:
    """(largest stable h, index into lam of the eigenvalue that sets it; -1 if none)."""
    if lam.size == 0:
        return math.inf, -1
    inverse, reps = bins
    rep_h = largest_stable_steps(m, lam[reps])
    worst = np.argsort(rep_h)[:_REFINE_BINS]
    worst = worst[np.isfinite(rep_h[worst])]
    if worst.size == 0:
        return math.inf, -1
    members = np.flatnonzero(np.isin(inverse, worst))
    exact = largest_stable_steps(m, lam[members])
    k = int(np.argmin(exact))
    return float(exact[k]), int(members[k])


def stability_limits(
    model: Any,
    methods: Sequence[Any],
    traj: Any,
    *,
    h: float | None = None,
    eigenvalues: np.ndarray | None = None,
) -> tuple[StabilityLimit, ...]:
    """The largest stable step of each rule along ``traj`` (see the module docstring).

    Parameters
    ----------
    model : Model
        With an exact Jacobian df/dx.
    methods : sequence of str or method objects
        Rules that answer ``amplification`` (:class:`sampledyn.methods.Stability`);
        others are skipped.
    traj : Trajectory
        The samples the Jacobians are taken at.
    h : float, optional
        The step to judge (s); default the data's largest step.
    eigenvalues : ndarray, shape (N, nx), optional
        The eigenvalues of df/dx at the samples of ``traj`` (1/s), when the caller
        has them.

    Returns
    -------
    tuple of StabilityLimit, in the order of ``methods`` (those that answer).

    Raises
    ------
    JacobianUnavailableError
        for a model without a Jacobian.
    """
    eig = jacobian_eigenvalues(model, traj) if eigenvalues is None else eigenvalues
    if h is None:
        steps = np.diff(traj.t)
        h = float(steps.max()) if steps.size else float(traj.h)
    lam, sample, growing = _modes(np.asarray(eig))
    bins = _bins(lam) if lam.size else (np.zeros(0, dtype=int), np.zeros(0, dtype=int))
    out = []
    for name in methods:
        m = get_method(name)
        if not isinstance(m, Stability):
            continue
        h_stable, k = _limit(m, lam, sample, bins, h)
        z = lam[k] if k >= 0 else complex("nan")
        amp = float(m.amplification(np.array([h * z]))[0]) if k >= 0 else 1.0
        out.append(
            StabilityLimit(
                method=str(m.name),
                h=float(h),
                h_stable=h_stable,
                eigenvalue=complex(z),
                sample=int(sample[k]) if k >= 0 else -1,
                amplification=amp,
                modes=int(lam.size),
                growing=growing,
            )
        )
    return tuple(out)
