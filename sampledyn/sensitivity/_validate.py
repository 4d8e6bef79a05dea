"""Monte Carlo check of the bound (24)-(25): measured disturbed local errors vs bound."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._trajectory import Trajectory
from ..noise import add_noise, noise_amplitudes
from ._bound import (
    ErrorBound,
    _truncation_estimate,
    assemble_bound,
    block_error_norms,
    jacobian_pair,
    reference_run,
)
from ._domain import Domain, check_vehicle, pitch_guard
from ._gains import supported_method

__all__ = ["MonteCarloRow", "measured_errors", "monte_carlo_check", "raw_errors"]


@dataclass(frozen=True)
class MonteCarloRow:
    """Bound and measured disturbed local errors of one rule at one noise level.

    Errors are per-sample Euclidean norms over the 6 eta (m, rad) or 6 v (m/s, rad/s)
    components of ``measured - prediction``; ``measured_*`` is their maximum over all
    samples and seeds, ``rms_*`` the root mean square over them.

    Attributes
    ----------
    method : str
    h, eta_pct, v_pct : float
    seeds, samples : int
        Monte Carlo repetitions, and samples with a prediction per repetition.
    bound : ErrorBound
    measured_eta, measured_v, rms_eta, rms_v : float
    noise_eta, noise_v : float
        Largest noise contribution ``||eps~_n - eps_n||`` (disturbed minus undisturbed
        local error at the same sample), over samples and seeds.
    violations : int
        Samples (over all seeds) whose error exceeds the bound in either block.
    """

    method: str
    h: float
    eta_pct: float
    v_pct: float
    seeds: int
    samples: int
    bound: ErrorBound
    measured_eta: float
    measured_v: float
    rms_eta: float
    rms_v: float
    noise_eta: float
    noise_v: float
    violations: int

    @property
    def tightness_eta(self) -> float:
        """Bound / measured maximum for the positions (>= 1 when the bound holds)."""
        return self.bound.eta.total / self.measured_eta if self.measured_eta > 0 else np.inf

    @property
    def tightness_v(self) -> float:
        """Bound / measured maximum for the velocities (>= 1 when the bound holds)."""
        return self.bound.v.total / self.measured_v if self.measured_v > 0 else np.inf


def raw_errors(
    model: Any, methods: Sequence[Any], data: Trajectory, signal: Any = None
) -> dict[str, np.ndarray]:
    """Local errors ``data.x - prediction`` of every method, shape (N, 12) each (NaN
    without prediction). f is evaluated once and shared by every AB order."""
    out: dict[str, np.ndarray] = {}
    cache: dict[Any, Any] = {}
    for name in methods:
        m = supported_method(name)
        out[m.name] = data.x - m.predict(model, data, signal, cache=cache)
    return out


def measured_errors(
    model: Any, methods: Sequence[Any], measured: Trajectory, signal: Any = None
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per-sample disturbed local-error norms of every method on measured data.

    Returns
    -------
    dict method name -> (eta norms, v norms), each shape (N,), NaN without prediction.
    """
    return {
        name: block_error_norms(err)
        for name, err in raw_errors(model, methods, measured, signal).items()
    }


def monte_carlo_check(
    model: Any,
    methods: Sequence[Any],
    h: float,
    noise_levels: Sequence[tuple[float, float]],
    *,
    reference: Trajectory | None = None,
    signal: Any = None,
    domain: Domain | None = None,
    seeds: int = 5,
    base_seed: int = 0,
    T: float = 60.0,
    x0: Any = None,
    samples: int = 5000,
) -> tuple[MonteCarloRow, ...]:
    """Measure the disturbed local errors on noisy copies of exact samples and compare
    them, sample by sample, with the bound.

    Parameters
    ----------
    model : Vehicle
    methods : sequence of str
        Rules ("E", "AB<s>", "RK<s>", "T").
    h : float
        Sampling period (s).
    noise_levels : sequence of (eta %, v %)
    reference, signal, T, x0
        The exact samples (see :func:`disturbed_error_bound`).
    domain : Domain, optional
        Default: the box of the reference run.
    seeds : int
        Noise realisations per level; seed k draws from ``SeedSequence([base_seed, k])``.
    samples : int
        Random samples of the Jacobian check.

    Returns
    -------
    tuple of MonteCarloRow, one per (noise level, method).
    """
    check_vehicle(model, "model")
    if isinstance(seeds, bool) or not isinstance(seeds, int) or seeds < 1:
        raise ValueError(f"`seeds` must be an int >= 1, got {seeds!r}.")
    clean, signal = reference_run(model, h, signal, reference, T, x0)
    if domain is None:
        domain = Domain.from_trajectory(clean, model.n_max, signal)
    pitch_guard(model, domain.theta_max_deg, "domain.theta_max_deg", stacklevel=3)
    ms = [supported_method(m, "methods") for m in methods]
    clean_err = raw_errors(model, ms, clean, signal)
    trunc = {}
    for name, err in clean_err.items():
        t_eta, t_v = block_error_norms(err)
        trunc[name] = (float(np.nanmax(t_eta)), float(np.nanmax(t_v)))
    rows = []
    for eta_pct, v_pct in noise_levels:
        amp = noise_amplitudes(model.state_units, eta_pct, v_pct)
        jac, jac_plus = jacobian_pair(model, domain, amp, samples)
        bounds = {
            m.name: assemble_bound(
                m,
                h,
                eta_pct,
                v_pct,
                amp,
                jac,
                jac_plus,
                trunc[m.name],
                _truncation_estimate(model, m, clean),
            )
            for m in ms
        }
        runs: dict[str, list[tuple[np.ndarray, ...]]] = {m.name: [] for m in ms}
        for k in range(seeds):
            noisy = add_noise(clean, eta_pct, v_pct, np.random.SeedSequence([base_seed, k]))
            for name, err in raw_errors(model, ms, noisy, signal).items():
                runs[name].append(block_error_norms(err) + block_error_norms(err - clean_err[name]))
        for m in ms:
            e_eta, e_v, n_eta, n_v = (
                np.concatenate([r[j] for r in runs[m.name]]) for j in range(4)
            )
            keep = ~(np.isnan(e_eta) | np.isnan(e_v))
            e_eta, e_v, n_eta, n_v = e_eta[keep], e_v[keep], n_eta[keep], n_v[keep]
            b = bounds[m.name]
            rows.append(
                MonteCarloRow(
                    method=m.name,
                    h=float(h),
                    eta_pct=float(eta_pct),
                    v_pct=float(v_pct),
                    seeds=seeds,
                    samples=int(keep.sum()) // seeds,
                    bound=b,
                    measured_eta=float(e_eta.max()),
                    measured_v=float(e_v.max()),
                    rms_eta=float(np.sqrt(np.mean(e_eta**2))),
                    rms_v=float(np.sqrt(np.mean(e_v**2))),
                    noise_eta=float(n_eta.max()),
                    noise_v=float(n_v.max()),
                    violations=int(((e_eta > b.eta.total) | (e_v > b.v.total)).sum()),
                )
            )
    return tuple(rows)
