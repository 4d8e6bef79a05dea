"""Random multilevel input and zero-order hold of sampled data."""

from __future__ import annotations

import math

import numpy as np

from .. import _checks as checks
from ..exceptions import ArgumentError
from ._base import Signal

__all__ = ["Multilevel", "ZeroOrderHold"]

# Relative slack when locating a time on a grid, so that t = n*h computed in floating
# point lands in interval n and not n - 1.
_GRID_SLACK = 1e-9


class Multilevel(Signal):
    """Random multilevel signal: levels uniform in ``[low, high]``, each held for
    ``hold`` seconds, starting at t = 0 (section 4.1 of the paper).

    Parameters
    ----------
    low, high : float
        Level range (input units). Paper: -10, 10.
    hold : float
        Duration of each level h_u (s); must be an integer multiple of the sampling
        period h used with it (checked by :func:`sampledyn.simulate`).
    seed : int
        Seed of the level sequence; the same seed gives the same levels.
    nu : int
        Number of independent channels.

    Examples
    --------
    >>> sig = Multilevel(low=-10.0, high=10.0, hold=0.05, seed=0)
    >>> sig(np.array([0.0, 0.01, 0.05])).shape
    (3, 1)
    """

    def __init__(
        self, low: float = -10.0, high: float = 10.0, hold: float = 0.1, seed: int = 0, nu: int = 1
    ) -> None:
        if not (math.isfinite(low) and math.isfinite(high)) or not low < high:
            raise ValueError(f"need finite `low` < `high`, got low={low}, high={high}.")
        hold = checks.positive(hold, "hold", what="level duration", unit="s")
        if not isinstance(seed, int | np.integer):
            raise TypeError(f"`seed` must be an int, got {type(seed).__name__}.")
        nu = checks.count(nu, "nu")
        self.low = float(low)
        self.high = float(high)
        self.hold = float(hold)
        self.seed = int(seed)
        self.nu = nu
        self.names = tuple(f"u{i + 1}" for i in range(nu))
        self.units = ("",) * nu
        self._levels = np.empty((0, nu))

    def __repr__(self) -> str:
        return (
            f"Multilevel(low={self.low}, high={self.high}, hold={self.hold}, "
            f"seed={self.seed}, nu={self.nu})"
        )

    def levels(self, count: int) -> np.ndarray:
        """The first ``count`` levels, shape (count, nu); a prefix never changes."""
        if count > self._levels.shape[0]:
            checks.check_memory(
                8.0 * count * self.nu,
                f"`hold` = {self.hold:g} s up to t = {count * self.hold:g} s ({count:.4g} levels)",
                "the input's levels",
                "use a longer hold or a shorter run",
            )
            # random() draws are sequential, so a longer draw extends a shorter one.
            rng = np.random.default_rng(self.seed)
            size = max(count, 2 * self._levels.shape[0])
            raw = rng.random((size, self.nu))
            self._levels = self.low + (self.high - self.low) * raw
        return self._levels[:count]

    def hold_values(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        if t.size and t.min() < 0:
            raise ValueError(f"Multilevel is defined for t >= 0, got t = {t.min()}.")
        last = float(t.max()) / self.hold + 1.0 if t.size else 0.0
        if last > 2**53:  # more levels than any memory (and than int64 time indices)
            self.levels(int(2**53))
        k = np.floor(t / self.hold + _GRID_SLACK).astype(np.int64)
        top = int(k.max()) + 1 if k.size else 0
        return self.levels(top)[k]

    def check_sampling(self, h: float) -> None:
        ratio = self.hold / h
        if checks.integer_ratio(self.hold, h) is None:
            raise ArgumentError(
                "hold",
                f"`hold` h_u = {self.hold} s must be an integer multiple of the sampling "
                f"period h = {h} s (h_u/h = {ratio:.6g}). Choose h_u = k*h.",
            )


class ZeroOrderHold(Signal):
    """Zero-order hold of sampled inputs: u(t) = u_k on ``[t_k, t_{k+1})``.

    The stamps ``t`` need not be sample times of the grid the signal is simulated on:
    :func:`sampledyn.simulate` stops its integration at every stamp that falls inside
    a sampling interval and changes the value (see :meth:`breakpoints`), so a 40 ms
    pulse inside a 0.1 s interval is integrated exactly.

    Parameters
    ----------
    t : ndarray, shape (N,)
        Strictly increasing stamps (s).
    u : ndarray, shape (N, nu) or (N,)
        Input values from each stamp on.

    Notes
    -----
    A time within ``slack`` (s) of a stamp counts as that stamp (a grid time n h
    computed in floating point lands on the stamp it means): ``slack`` is
    1e-9 of the smallest step, at least 64 rounding units of the largest |t|.
    """

    def __init__(self, t: np.ndarray, u: np.ndarray) -> None:
        t = np.asarray(t, dtype=float)
        u = np.asarray(u, dtype=float)
        if u.ndim == 1:
            u = u[:, None]
        if t.ndim != 1 or u.ndim != 2 or u.shape[0] != t.shape[0]:
            raise ValueError(
                f"`t` must have shape (N,) and `u` shape (N, nu); got {t.shape} and {u.shape}."
            )
        if t.size < 1 or np.any(np.diff(t) <= 0):
            raise ValueError("`t` must be non-empty and strictly increasing.")
        if not np.isfinite(t).all():
            raise ValueError(f"`t` holds NaN or inf at stamp {int(np.argmax(~np.isfinite(t)))}.")
        if not np.isfinite(u).all():
            raise ValueError(
                f"`u` holds NaN or inf at sample {int(np.argmax(~np.isfinite(u).all(1)))}."
            )
        self.t = t
        self.u = u
        self.nu = u.shape[1]
        self.names = tuple(f"u{i + 1}" for i in range(self.nu))
        self.units = ("",) * self.nu
        rounding = 64 * np.finfo(float).eps * float(np.abs(t).max())
        step = float(np.diff(t).min()) if t.size > 1 else 0.0
        self.slack = max(_GRID_SLACK * step, rounding)

    def hold_values(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        idx = np.searchsorted(self.t, t + self.slack, side="right") - 1
        if np.any(idx < 0):
            raise ValueError(f"ZeroOrderHold starts at t = {self.t[0]}; asked for {t.min()}.")
        return self.u[idx]

    def breakpoints(self, t: np.ndarray) -> np.ndarray:
        """Stamps where the value changes that lie strictly inside an interval of the
        grid ``t`` (more than ``slack`` from every grid time), shape (M,)."""
        grid = np.asarray(t, dtype=float)
        change = np.flatnonzero((self.u[1:] != self.u[:-1]).any(axis=1)) + 1
        s = self.t[change]
        if s.size == 0 or grid.size < 2:
            return np.empty(0)
        # The first grid time whose hold sees the jump at s: s <= t_j + slack.
        j = np.searchsorted(grid + self.slack, s, side="left")
        inside = (j > 0) & (j < grid.size)
        jj = np.minimum(j, grid.size - 1)
        off_grid = inside & (s < grid[jj] - self.slack)
        return s[off_grid]
