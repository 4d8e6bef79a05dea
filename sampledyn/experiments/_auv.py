"""The AUV-like case study of section 4 (Figs. 2 and 3).

For each input hold ratio h_u/h, exact samples of eqs. (9)-(10) are simulated under a
random multilevel input (levels uniform in [-10, 10]); every method's one-step-ahead
predictor is fed with those samples and its local errors are measured after the
transient.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ERROR_NORMS, error_norm, error_norms, local_errors
from ..methods import families, get_method
from ..models import AUVLike
from ..predict import predict
from ..signals import Multilevel
from ..simulate import simulate

__all__ = ["AUVStudy", "fig2_methods", "fig3_methods", "run_auv_study"]


def _multistep(fam: Any) -> bool:
    """A family of orders with a member that uses more than one past sample."""
    return fam.ordered and any(get_method(n).history > 1 for n in fam.names())


def fig2_methods() -> tuple[str, ...]:
    """Fig. 2's rules: every registered multistep family (AB_s, ABu_s, ABe_s, ...),
    orders 1 to the family's default largest one, in registration order."""
    return tuple(n for fam in families() if _multistep(fam) for n in fam.names())


def fig3_methods() -> tuple[str, ...]:
    """Fig. 3's rules: every registered single rule (E, T, Ee, ...) and every one-step
    family of orders (RK_s), in registration order."""
    return tuple(n for fam in families() if not _multistep(fam) for n in fam.names())


# Samples counted as "away from input jumps" have no jump in the last 7 samples, which
# covers the history of AB6 plus the interval being predicted.
SMOOTH_HISTORY = 7


@dataclass(frozen=True)
class AUVStudy:
    """Settings of the AUV-like study.

    Attributes
    ----------
    methods : tuple of str
        Registry names (default :func:`fig2_methods`).
    hold_ratios : tuple of int
        h_u / h values, one curve each.
    h : float
        Sampling period (s). The default 0.01 s is about 1/30 of the fastest local time
        constant of (9)-(10) under |u| <= 10 (reported by :func:`fastest_time_constant`).
    T : float
        Duration of each run (s).
    after : float
        Errors are measured on t >= after (s), past the transient from x0 = 0.
    seed : int
        Seed of the multilevel input.
    x0 : tuple of float
        Initial state (x, y).
    """

    methods: tuple[str, ...] = field(default_factory=fig2_methods)
    hold_ratios: tuple[int, ...] = (1, 2, 5, 10, 20, 50, 100)
    h: float = 0.01
    T: float = 200.0
    after: float = 20.0
    seed: int = 0
    low: float = -10.0
    high: float = 10.0
    x0: tuple[float, float] = (1.0, 0.0)
    model: Any = field(default_factory=AUVLike)

    def __post_init__(self) -> None:
        if not (np.isfinite(self.h) and self.h > 0):
            raise ValueError(f"sampling period `h` must be > 0 s, got {self.h}.")
        for r in self.hold_ratios:
            if not isinstance(r, int | np.integer) or r < 1:
                raise ValueError(f"`hold_ratios` must be positive integers, got {r!r}.")
        if not self.after < self.T:
            raise ValueError(f"`after` = {self.after} s must be below T = {self.T} s.")


def fastest_time_constant(model: Any, traj: Any) -> float:
    """Smallest 1/|lambda| (s) over the eigenvalues of df/dx along a trajectory."""
    jac = model.jacobian(traj.t, traj.x, traj.u)
    lam = np.abs(np.linalg.eigvals(jac)).max()
    return float(1.0 / lam) if lam > 0 else float("inf")


def away_from_jumps(u: np.ndarray, history: int) -> np.ndarray:
    """True at samples k whose prediction uses no input jump: u[k-history-1..k-1] constant.

    Parameters
    ----------
    u : ndarray, shape (N, nu)
    history : int
        The longest history among the methods compared (s of the highest AB_s).
    """
    n = u.shape[0]
    jump = np.zeros(n, dtype=bool)
    jump[1:] = (np.diff(u, axis=0) != 0).any(axis=1)  # u[k] differs from u[k-1]
    ok = np.zeros(n, dtype=bool)
    # k is fine when no jump happens at k-history..k-1.
    csum = np.concatenate([[0], np.cumsum(jump)])
    k = np.arange(n)
    lo = np.clip(k - history, 0, n)
    ok[:] = (csum[k] - csum[lo]) == 0
    ok[: history + 1] = False
    return ok


def away_from_kinks(x: np.ndarray, kink_states: tuple[int, ...], history: int) -> np.ndarray:
    """True at samples k with no zero crossing of a kink state in samples k-history..k.

    Where a state inside ``|.|`` (e.g. y in y|y|) crosses zero, f is not smooth and
    every method of order > 2 drops to about order 2 there.
    """
    n = x.shape[0]
    cross = np.zeros(n, dtype=bool)
    for k in kink_states:
        sign = np.sign(x[:, k])
        cross[1:] |= sign[1:] != sign[:-1]
    window = np.convolve(cross.astype(np.int64), np.ones(history + 1, dtype=np.int64))[:n]
    return window == 0


def run_auv_study(study: AUVStudy = AUVStudy(), *, progress: bool = False) -> list[dict[str, Any]]:
    """Local-error norms of every method for every h_u/h.

    Returns
    -------
    list of dict, one per (hold ratio, method), with keys ``hold_ratio``, ``method``,
    ``order``, the norms of :data:`sampledyn.errors.ERROR_NORMS` (over both states,
    t >= after), ``rms_away_from_jumps`` (rms over the samples whose prediction
    history holds no input jump; NaN when h_u/h is too short to have any),
    ``rms_smooth`` (same, also away from zero crossings of the model's kink states), ``h``,
    ``T``, ``after``, ``seed``, ``certificate`` (max scaled
    per-interval flow error of the samples) and ``tau_min`` (fastest local time
    constant, s).
    """
    rows: list[dict[str, Any]] = []
    cells = [(r, m) for r in study.hold_ratios for m in study.methods]
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(cells), desc="AUV study", unit="cell")
    try:
        for ratio in study.hold_ratios:
            signal = Multilevel(study.low, study.high, hold=ratio * study.h, seed=study.seed)
            traj = simulate(study.model, signal, T=study.T, h=study.h, x0=np.array(study.x0))
            tau = fastest_time_constant(study.model, traj)
            cert = traj.certificate.max_error if traj.certificate else float("nan")
            no_jump = away_from_jumps(traj.u, SMOOTH_HISTORY)
            smooth = no_jump & away_from_kinks(
                traj.x, getattr(study.model, "kink_states", ()), SMOOTH_HISTORY
            )
            late = traj.t >= study.after
            for name in study.methods:
                method = get_method(name)
                x_hat = predict(method, study.model, traj, signal=signal)
                err = local_errors(x_hat, traj)
                row: dict[str, Any] = {
                    "hold_ratio": int(ratio),
                    "method": method.name,
                    "order": int(method.order),
                }
                row.update(error_norms(err, traj.t, ERROR_NORMS, after=study.after))
                for key, mask in (("rms_away_from_jumps", no_jump), ("rms_smooth", smooth)):
                    row[key] = (
                        error_norm(err, traj.t, kind="rms", after=study.after, where=mask)
                        if mask[late].any()
                        else float("nan")
                    )
                row.update(
                    h=study.h,
                    T=study.T,
                    after=study.after,
                    seed=study.seed,
                    certificate=cert,
                    tau_min=tau,
                )
                rows.append(row)
                if bar is not None:
                    bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    return rows
