"""Multi-step error: k-step-ahead predictions and free runs of each rule on sampled,
noisy data (what an MPC horizon sees, not only one step).

Data: the RexROV, open loop, under the paper's Fig. 6 thruster rpm (+1 % buoyancy),
exact samples (:func:`sampledyn.simulate`) with the paper's uniform measurement noise.
For each rule, h and noise level: the k-step-ahead predictions of
:meth:`~sampledyn.discretize.DiscreteModel.rollout` (z from the noisy data at n - k,
stepped k times with the applied inputs) against the exact samples, k = 1..K; and a
free run of the discrete model from the noisy data at the start of the window over the
whole window. Errors: rms over the window of the Euclidean norm of the position/angle
(eta) and velocity (v) parts of the error.

The BlueROV2 Heavy is left out: it pitches over open loop under the Fig. 6 input, and
with its roll-pitch hold (a ClosedLoop) the implicit Tustin step has no compiled
Jacobian kernel.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..discretize import discretize
from ..methods import get_method
from ..noise import add_noise
from ..signals import fig6_thrusters
from ..simulate import simulate

__all__ = ["MultistepStudy", "run_multistep_study", "summarize_multistep"]


@dataclass(frozen=True)
class MultistepStudy:
    """Settings (defaults: RexROV, T = 300 s, window from 50 s, K = 20 steps)."""

    vehicle: str = "rexrov"
    methods: tuple[str, ...] = ("E", "AB2", "AB4", "ABu4", "RK4", "T")
    h_values: tuple[float, ...] = (0.1, 0.5)
    noise_pairs: tuple[tuple[float, float], ...] = ((0, 0), (2, 2), (10, 10), (20, 20))
    seeds: int = 3
    T: float = 300.0
    after: float = 50.0
    K: int = 20
    buoyancy_pct: float = 1.0
    base_seed: int = 0

    def __post_init__(self) -> None:
        if not 0 <= self.after < self.T:
            raise ValueError(f"`after` = {self.after} s must be in [0, T = {self.T} s).")
        if self.K < 1 or self.seeds < 1:
            raise ValueError(f"`K` and `seeds` must be >= 1, got {self.K} and {self.seeds}.")
        for name in self.methods:
            get_method(name)


def _rms_norm(err: np.ndarray) -> float:
    if not np.isfinite(err).all() or np.abs(err).max(initial=0.0) > 1e100:
        return float("inf")
    return float(np.sqrt(np.mean(np.sum(err * err, axis=1))))


def run_multistep_study(
    study: MultistepStudy, progress: Callable[[str], None] | None = None
) -> list[dict[str, Any]]:
    """Rows (method, h, eta_pct, v_pct, seed, k, pos_rms, vel_rms, diverged); k = 0 is the
    free run; ``diverged``: a non-finite or > 1e3 rms error."""
    import warnings

    from ..models import load_vehicle

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the RexROV's published M_A asymmetry, known
        vehicle = load_vehicle(study.vehicle).with_buoyancy(study.buoyancy_pct)
    rows: list[dict[str, Any]] = []
    for h in study.h_values:
        exact = simulate(vehicle, fig6_thrusters(vehicle), study.T, h, certify=False)
        start = int(round(study.after / h))
        for method in study.methods:
            dm = discretize(vehicle, method, h)
            if progress is not None:
                progress(f"{method} h={h:g}")
            for pair in study.noise_pairs:
                for seed in range(study.seeds if any(pair) else 1):
                    meas = add_noise(
                        exact, pair[0], pair[1], np.random.SeedSequence([study.base_seed, seed])
                    )
                    base = {
                        "method": method, "h": float(h), "eta_pct": float(pair[0]),
                        "v_pct": float(pair[1]), "seed": seed,
                    }  # fmt: skip
                    for k in range(1, study.K + 1):
                        with np.errstate(all="ignore"):
                            err = dm.rollout(meas, k)[start:] - exact.x[start:]
                        pos, vel = _rms_norm(err[:, :6]), _rms_norm(err[:, 6:])
                        rows.append(
                            base
                            | {
                                "k": k,
                                "pos_rms": pos,
                                "vel_rms": vel,
                                "diverged": not max(pos, vel) < 1e3,
                            }  # fmt: skip
                        )
                    z0 = dm.state_from_data(meas, start)
                    with np.errstate(all="ignore"):
                        run = dm.simulate(z0, meas.u[start:-1], float(meas.t[start]))[:, : dm.nx]
                        err = run - exact.x[start:]
                    pos, vel = _rms_norm(err[:, :6]), _rms_norm(err[:, 6:])
                    diverged = not max(pos, vel) < 1e3
                    rows.append(
                        base | {"k": 0, "pos_rms": pos, "vel_rms": vel, "diverged": diverged}
                    )
    return rows


def summarize_multistep(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Mean over seeds per (method, h, eta_pct, v_pct, k)."""
    groups: dict[tuple[Any, ...], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["method"], r["h"], r["eta_pct"], r["v_pct"], r["k"]), []).append(r)
    out = []
    for key, rs in groups.items():
        cell = dict(zip(("method", "h", "eta_pct", "v_pct", "k"), key, strict=True))
        for m in ("pos_rms", "vel_rms"):
            cell[m] = float(np.mean([r[m] for r in rs]))
        cell["diverged"] = int(sum(bool(r["diverged"]) for r in rs))
        out.append(cell)
    return out
