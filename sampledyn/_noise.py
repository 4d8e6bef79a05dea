"""Measurement noise delta_eta, delta_v (section 6.2 of the paper): added to exact
samples (:func:`add_noise`), and estimated from measured ones (:func:`estimate_noise`).

Noise levels are percentages of reference magnitudes chosen by the unit of each state
component: 1 m for positions, 30 deg for angles, 1 m/s for linear rates and 30 deg/s
for angular rates (the paper's "1(m)-30(deg)" and "1(m/s)-30(deg/s)"). Components in
other units (e.g. thruster rpm states) get no noise.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import _checks as checks
from ._trajectory import Trajectory

__all__ = [
    "MAX_NOISE_PCT",
    "NOISE_ORDER",
    "RESOLVED",
    "NOISE_REFERENCE",
    "NoiseEstimate",
    "add_noise",
    "difference_weights",
    "estimate_noise",
    "noise_amplitudes",
]

# unit -> (group, reference magnitude in that unit)
NOISE_REFERENCE: dict[str, tuple[str, float]] = {
    "m": ("eta", 1.0),
    "rad": ("eta", math.radians(30.0)),
    "m/s": ("v", 1.0),
    "rad/s": ("v", math.radians(30.0)),
}

_DISTRIBUTIONS = ("uniform", "gaussian")


#: Largest noise level (% of the reference magnitude of NOISE_REFERENCE): at 1000 %
#: the noise is ten times the motion, the samples hold nothing of it, and the errors
#: measure the noise alone (the paper goes to 20 %; 1e308 % made every error inf).
MAX_NOISE_PCT = 1000.0


def noise_amplitudes(state_units: tuple[str, ...], eta_pct: float, v_pct: float) -> np.ndarray:
    """Amplitude a_i of the noise on each state component (in its unit), shape (nx,).

    Uniform noise is drawn from [-a_i, a_i].
    """
    for name, pct in (("eta_pct", eta_pct), ("v_pct", v_pct)):
        if not (isinstance(pct, int | float) and math.isfinite(pct) and pct >= 0):
            raise ValueError(f"`{name}` must be a finite percentage >= 0, got {pct!r}.")
        if pct > MAX_NOISE_PCT:
            raise ValueError(
                f"`{name}` = {pct:g} % is above {MAX_NOISE_PCT:g} %: the noise would be more "
                "than ten times the motion, and the errors would measure the noise alone."
            )
    amp = np.zeros(len(state_units))
    for i, unit in enumerate(state_units):
        if unit in NOISE_REFERENCE:
            group, ref = NOISE_REFERENCE[unit]
            amp[i] = (eta_pct if group == "eta" else v_pct) / 100.0 * ref
    return amp


_SCRATCH = threading.local()


def _scratch(slot: int, shape: tuple[int, int]) -> np.ndarray:
    """A float64 buffer of ``shape`` for the draws of stream ``slot``, kept per thread
    and reused by the next call of that shape: the draws are read only inside
    :func:`add_noise`, and a new buffer of some MB per call costs its page faults."""
    kept = getattr(_SCRATCH, "buffers", None)
    if kept is None:
        kept = _SCRATCH.buffers = {}
    buf = kept.get(slot)
    if buf is None or buf.shape != shape:
        buf = kept[slot] = np.empty(shape)
    return buf


def add_noise(
    traj: Trajectory,
    eta_pct: float = 0.0,
    v_pct: float = 0.0,
    seed: Any = 0,
    *,
    distribution: str = "uniform",
) -> Trajectory:
    """Measured data: the samples plus white measurement noise.

    Parameters
    ----------
    traj : Trajectory
        Exact samples (if it is itself measured, noise is added to its clean samples).
    eta_pct, v_pct : float
        Noise level on positions/angles and on rates, in percent of the reference
        magnitudes (1 m, 30 deg; 1 m/s, 30 deg/s).
    seed : int or numpy SeedSequence
        Seed. Positions and rates draw from independent streams spawned from it, so the
        position noise of a seed does not change when ``v_pct`` does; a zero level
        draws nothing (those components are the samples).
    distribution : {"uniform", "gaussian"}
        "uniform": white noise uniform in [-a, a] (the paper's). "gaussian": white
        normal noise with the same standard deviation a / sqrt(3).

    Returns
    -------
    Trajectory whose ``x`` is noisy and whose ``clean`` holds the exact samples.
    """
    if not isinstance(traj, Trajectory):
        raise TypeError(f"`traj` must be a Trajectory, got {type(traj).__name__}.")
    if distribution not in _DISTRIBUTIONS:
        raise ValueError(
            f"unknown `distribution` {distribution!r}; valid: {', '.join(_DISTRIBUTIONS)}."
        )
    clean = traj.clean if traj.clean is not None else traj
    amp = noise_amplitudes(clean.state_units, eta_pct, v_pct)
    groups = np.array([NOISE_REFERENCE.get(u, ("", 0.0))[0] for u in clean.state_units])
    seq = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    streams = dict(zip(("eta", "v"), seq.spawn(2), strict=True))
    from ._sums import add_scaled_draws  # numba, loaded on first use

    x = np.ascontiguousarray(clean.x, dtype=float)
    n = x.shape[0]
    # Per component: its stream (1 eta, 2 v; 0 none: no noise, or a zero level, which
    # draws nothing) and its column among that stream's draws.
    stream = np.zeros(x.shape[1], dtype=np.int64)
    pos = np.zeros(x.shape[1], dtype=np.int64)
    draws = []
    low, span = (-1.0, 2.0) if distribution == "uniform" else (0.0, 1.0)
    for g, (group, ss) in enumerate(streams.items(), start=1):
        cols = np.flatnonzero(groups == group)
        if cols.size == 0 or not amp[cols].any():
            draws.append(np.zeros((1, 1)))
            continue
        stream[cols], pos[cols] = g, np.arange(cols.size)
        rng = np.random.default_rng(ss)
        d = _scratch(g, (n, cols.size))
        # The draws of uniform(-1, 1) (-1 + 2 r, r in [0, 1)) and of standard_normal()
        # / sqrt(3), scaled and added to the samples in one pass, without temporaries.
        if distribution == "uniform":
            rng.random(out=d)
        else:
            rng.standard_normal(out=d)
            np.divide(d, math.sqrt(3.0), out=d)
        draws.append(d)
    noisy = np.empty_like(x)
    add_scaled_draws(x, draws[0], draws[1], stream, pos, amp, low, span, noisy)
    noisy.setflags(write=False)
    return clean.replace(x=noisy, clean=clean)


# ---------------------------------------------------------------------------------
# estimated from the data

#: Order k of the differences :func:`estimate_noise` takes by default.
NOISE_ORDER = 4

#: Least ratio of the order k + 1 to the order k estimate for a state's estimate to
#: count as the noise's (:attr:`NoiseEstimate.resolved`): noise alone gives 1 to the
#: sampling spread (0.97..1.01 on a 113-sample log, 0.98..1.00 on 800 samples).
RESOLVED = 0.9


def difference_weights(t: np.ndarray) -> np.ndarray:
    """Weights c, shape (M, k + 1), of the k-th divided difference on each window of
    k + 1 sample times (``t`` shape (M, k + 1)), scaled to unit Euclidean norm.

    ``sum_j c_j p(t_j) = 0`` for every polynomial p of degree < k, and for white noise
    of variance sigma^2 ``E[(sum_j c_j delta_j)^2] = sigma^2``. On a uniform grid c is
    ``(-1)^j binom(k, j) / sqrt(binom(2k, k))``; on jittered stamps the divided
    difference of the actual nodes (``c_j ~ 1 / prod_{m != j} (t_j - t_m)``)."""
    t = np.asarray(t, dtype=float)
    scale = np.ptp(t, axis=1, keepdims=True)
    tau = (t - t[:, :1]) / np.where(scale > 0, scale, 1.0)
    diff = tau[:, :, None] - tau[:, None, :]
    k1 = t.shape[1]
    diff[:, np.arange(k1), np.arange(k1)] = 1.0
    w = 1.0 / np.prod(diff, axis=2)
    return w / np.linalg.norm(w, axis=1, keepdims=True)


@dataclass(frozen=True)
class NoiseEstimate:
    """Per-state measurement-noise levels estimated from sampled data.

    Attributes
    ----------
    sigma : ndarray, shape (nx,)
        Standard deviation of the noise on each state (state units); NaN where not
        estimated (a state left out, or fewer than two windows).
    check : ndarray, shape (nx,)
        The same estimate from differences of order ``order + 1``: where the smooth
        signal still contributes, the two differ (the higher order is then lower);
        for noise alone they agree to the sampling spread.
    order : int
        k, the order of the differences.
    windows : int
        Windows of k + 1 samples the estimate averages over.
    state_names, state_units : tuple of str
    across_jumps : int
        Windows left out because the sampled input changes inside them (the rates'
        derivatives jump there, so the signal is not smooth); 0 when none were left
        out (none changes, or it changes in most windows: a continuous input).
    """

    sigma: np.ndarray
    check: np.ndarray
    order: int
    windows: int
    state_names: tuple[str, ...]
    state_units: tuple[str, ...]
    across_jumps: int = 0

    @property
    def resolved(self) -> np.ndarray:
        """Per state, shape (nx,): True where the estimate is the noise's, not the
        motion's: the order k + 1 estimate is within ``RESOLVED`` (10 %) of it. A
        signal that is not smooth over k steps (a motion near the Nyquist frequency,
        h too long for the dynamics) falls with the order, and cannot be told from
        noise by its differences at all near the Nyquist frequency; there the estimate
        is an upper bound."""
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = self.check / self.sigma
        return np.asarray(np.isfinite(ratio) & (ratio >= RESOLVED))

    def describe(self) -> str:
        """``x 9.2e-06 m, y 2.5e-05 m, ...`` (the estimated states only)."""
        return ", ".join(
            f"{n} {s:.2g} {u}"
            for n, s, u in zip(self.state_names, self.sigma, self.state_units, strict=True)
            if np.isfinite(s)
        )


def _windows(rows: np.ndarray, width: int) -> np.ndarray:
    """Every run of ``width`` consecutive row indices inside ``rows`` (sorted), shape
    (M, width): the windows that stay within one segment of valid samples."""
    if rows.size < width:
        return np.zeros((0, width), dtype=int)
    win = np.lib.stride_tricks.sliding_window_view(rows, width)
    return np.asarray(win[(win[:, -1] - win[:, 0]) == width - 1])


def _smooth_windows(traj: Trajectory, win: np.ndarray) -> tuple[np.ndarray, int]:
    """The windows over which the sampled input does not change, and how many were
    left out; all of them when fewer than half would remain (an input that changes
    at most samples varies continuously: nothing to leave out)."""
    if win.shape[0] == 0 or traj.nu == 0:
        return win, 0
    u = traj.u[win]  # (M, k + 1, nu)
    same = (u == u[:, :1]).all(axis=(1, 2))
    if same.sum() < 0.5 * win.shape[0]:
        return win, 0
    return win[same], int((~same).sum())


def estimate_noise(
    traj: Trajectory,
    order: int = NOISE_ORDER,
    *,
    rows: Any = None,
    states: Any = None,
    segments: Any = None,
) -> NoiseEstimate:
    """Measurement-noise level of every state, from high-order differences of the data.

    Over a window of k + 1 consecutive samples the k-th divided difference, scaled to
    unit norm (:func:`difference_weights`), annihilates every polynomial of degree < k,
    so a signal that is smooth on the scale of k steps all but vanishes from it, while
    white noise of standard deviation sigma keeps its variance sigma^2. The estimate is
    the root mean square of these combinations over all windows, per state.

    Parameters
    ----------
    traj : Trajectory
        Sampled data, uniform or not (the divided differences use the actual stamps).
    order : int
        k >= 1 (default :data:`NOISE_ORDER` = 4).
    rows : array of int or bool, optional
        The samples to use (e.g. the valid ones of a log); windows never span a
        missing sample, so each segment counts on its own.
    states : sequence of int, optional
        The states to estimate (default all); the others get NaN.
    segments : sequence of (start, stop), optional
        Row ranges evaluated on their own (a log split at dropped records): no window
        spans two of them.

    Windows over which the sampled input changes are left out when the input is
    piecewise constant (it changes in fewer than half of the windows): the rates'
    derivatives jump with the input, and a difference across the jump measures the
    jump, not the noise (``NoiseEstimate.across_jumps`` counts them).

    Returns
    -------
    NoiseEstimate

    Raises
    ------
    ArgumentError
        (a ``ValueError``) for an order < 1.
    TypeError
        for an order that is no int, or ``traj`` that is no Trajectory.

    Notes
    -----
    **Bias.** For white noise the estimate of sigma^2 is unbiased; the smooth signal
    adds its own normalised k-th difference, ``E[sigma_hat^2] = sigma^2 +
    mean((c . s)^2)`` with ``c . s ~ h^k s^(k) / sqrt(binom(2k, k))`` on a uniform
    grid, so the estimate errs high where the signal moves fast on the scale of k
    steps (``check``, from order k + 1, shows it: it is lower then). Noise that is
    correlated between samples biases it too: a low-pass filtered measurement (an
    estimator's output) reads low, a differentiated one (rates from differenced
    positions) high. The relative sampling spread of the estimate is about
    sqrt(2 / windows) times a factor of the overlap of neighbouring windows (about 2
    for k = 4).
    """
    order = checks.count(order, "order")
    if not isinstance(traj, Trajectory):
        raise TypeError(f"`traj` must be a Trajectory, got {type(traj).__name__}.")
    n, nx = traj.x.shape
    if rows is None:
        idx = np.arange(n)
    else:
        r = np.asarray(rows)
        idx = np.flatnonzero(r) if r.dtype == bool else np.sort(r.astype(int))
    cols = np.arange(nx) if states is None else np.asarray(list(states), dtype=int)
    seg = np.zeros(n, dtype=int)
    for i, (a, b) in enumerate(segments or ()):
        seg[a:b] = i

    def level(k: int) -> tuple[np.ndarray, int, int]:
        win = _windows(idx, k + 1)
        win = win[seg[win[:, 0]] == seg[win[:, -1]]]
        win, skipped = _smooth_windows(traj, win)
        out = np.full(nx, np.nan)
        if win.shape[0] < 2:
            return out, int(win.shape[0]), skipped
        c = difference_weights(traj.t[win])
        comb = np.einsum("wj,wjn->wn", c, traj.x[win][:, :, cols])
        out[cols] = np.sqrt(np.mean(comb * comb, axis=0))
        return out, int(win.shape[0]), skipped

    sigma, windows, skipped = level(int(order))
    check, _, _ = level(int(order) + 1)
    return NoiseEstimate(
        sigma=sigma,
        check=check,
        order=int(order),
        windows=windows,
        state_names=tuple(traj.state_names),
        state_units=tuple(traj.state_units),
        across_jumps=skipped,
    )
