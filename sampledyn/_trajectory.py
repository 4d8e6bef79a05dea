"""Sampled data: the value every layer passes along."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any, NamedTuple

import numpy as np

from . import _checks as checks
from .exceptions import ArgumentError

__all__ = ["Certificate", "SlidingInterval", "Trajectory", "steps_on_grid", "uniform_grid"]


def _frozen(a: np.ndarray, dtype: type = np.float64) -> np.ndarray:
    """A read-only copy of ``a`` as ``dtype``; an array that already has that dtype, is
    C-ordered, read-only and owns its memory (nothing else can write to it) is taken as
    it is, so that large results (5 M samples) are not copied on the way out."""
    if (
        isinstance(a, np.ndarray)
        and a.dtype == dtype
        and a.base is None
        and not a.flags.writeable
        and a.flags.c_contiguous
    ):
        return a
    a = np.array(a, dtype=dtype, copy=True)
    a.setflags(write=False)
    return a


# Steps that differ from h by no more than this many rounding units of the largest
# |t| are rounding of t = n h (t_n = n h, or t_0 + n h, carries up to half a unit of
# t_n): such a grid is uniform, and the fixed-step code runs on it.
_ROUNDING_UNITS = 64.0


def steps_on_grid(t: np.ndarray, h: float) -> np.ndarray:
    """Per step of ``t``, shape (N - 1,): True where it equals ``h`` up to the rounding
    of ``t`` (see :func:`uniform_grid`)."""
    tol = _ROUNDING_UNITS * np.finfo(float).eps * max(abs(t[0]), abs(t[-1]), h)
    return np.asarray(np.abs(np.diff(t) - h) <= tol)


def uniform_grid(t: np.ndarray, h: float) -> bool:
    """True if every step of ``t`` equals ``h`` up to the rounding of ``t``:
    ``|t_{n+1} - t_n - h| <= 64 eps max(|t_0|, |t_{N-1}|, h)``.

    This is the one test of "uniform" that selects the fixed-step code of every rule
    (fixed coefficients and one h: results bit-identical to a rule that knows only
    uniform grids) and the unweighted error norms; any other grid is predicted on its
    actual steps. It is much tighter than a tolerance on h: a grid that is 1e-6 h off
    would move an Euler step by 1e-6 h |f|.
    """
    t = np.asarray(t, dtype=float)
    return bool(t.size < 2 or steps_on_grid(t, h).all())


class SlidingInterval(NamedTuple):
    """A time interval in which the state slid on a switching surface (Filippov's
    sliding motion, where f jumps across the surface and both sides push the state
    onto it): the surface ``surface = 0`` (its switching function as text), from
    ``start`` to ``end`` (s)."""

    surface: str
    start: float
    end: float


@dataclass(frozen=True)
class Certificate:
    """Accuracy certificate of exact samples.

    Each interval ``[t_n, t_{n+1}]`` is integrated twice from the same sample
    ``x_n``: once with the accepted adaptive steps, once with every one of those
    steps halved. Their difference estimates the per-interval flow error of the
    samples (the half-step run is ``2**8`` times more accurate for an 8th-order
    scheme on smooth stretches).

    Attributes
    ----------
    per_interval : ndarray, shape (N - 1,)
        Estimated flow error of each interval, component ``i`` divided by
        ``scale[i]``, maximum over components (dimensionless).
    scale : ndarray, shape (nx,)
        ``max(1, max_n |x_i(t_n)|)`` per state component, in the state's units.
    steps : ndarray of int, shape (N - 1,)
        Accepted internal steps per sampling interval.
    rtol : float
        Tolerance the integrator was run with.
    """

    per_interval: np.ndarray
    scale: np.ndarray
    steps: np.ndarray
    rtol: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "per_interval", _frozen(self.per_interval))
        object.__setattr__(self, "scale", _frozen(self.scale))
        object.__setattr__(self, "steps", _frozen(self.steps, np.int64))

    @property
    def max_error(self) -> float:
        """Largest scaled per-interval flow error (dimensionless)."""
        return float(self.per_interval.max()) if self.per_interval.size else 0.0

    @property
    def worst_interval(self) -> int:
        """Index ``n`` of the interval ``[t_n, t_{n+1}]`` with the largest error."""
        return int(self.per_interval.argmax()) if self.per_interval.size else 0

    def __str__(self) -> str:
        return (
            f"per-interval flow error <= {self.max_error:.2e} (scaled; worst interval "
            f"{self.worst_interval}), {int(self.steps.sum())} internal steps, "
            f"rtol={self.rtol:g}"
        )


def _check_spacing(t: np.ndarray, h: float) -> None:
    """``h`` must be the period of ``t``, nominally: within 25 % of the step of a
    uniform grid (a nominal h that differs a little makes the rules take the actual
    steps), within [0.5, 2.5] h of the median step of a non-uniform one (a jittered
    log, or one with many one-record gaps). A grossly different h (h = 0.1 s on data
    sampled every 0.01 s) would be taken for the period where one is needed (noise
    gains, windows, discrete-time models) and be wrong without a sign."""
    if t.shape[0] < 2:
        return
    d = np.diff(t)
    if not (d > 0).all():
        return  # not increasing: the rules refuse it, naming the sample (check_times)
    rounding = 64 * np.finfo(float).eps * max(abs(float(t[0])), abs(float(t[-1])), h)
    if float(d.max() - d.min()) <= 1e-6 * h + rounding:  # a uniform grid
        step = float(t[-1] - t[0]) / (t.shape[0] - 1)
        if abs(step - h) <= 0.25 * h:
            return
        raise ValueError(
            f"`h` = {h:g} s disagrees with the spacing of `t`, {step:.9g} s (more than 25 % "
            "off): give h = the step of t; a rule would take h for the period."
        )
    median = float(np.median(d))
    if not 0.5 * h <= median <= 2.5 * h:
        raise ValueError(
            f"`h` = {h:g} s disagrees with the spacing of `t` (median step {median:.6g} s, "
            "outside [0.5, 2.5] h): give the nominal period of t; a rule would take h for "
            "the period."
        )


@dataclass(frozen=True)
class Trajectory:
    """Sampled states and inputs (immutable).

    Attributes
    ----------
    t : ndarray, shape (N,)
        Sample times (s). Simulated data: t_n = n h. Logs: seconds from the first
        sample, as logged (a log may be non-uniform: jitter, bridged gaps).
    x : ndarray, shape (N, nx)
        States at the sample times; for vehicles eta then v.
    u : ndarray, shape (N, nu)
        Inputs at the sample times (the value held over ``[t_n, t_{n+1})``).
    h : float
        Sampling period (s); for a non-uniform log the nominal period (median step).
    state_names, state_units : tuple of str, length nx
    input_names, input_units : tuple of str, length nu
    clean : Trajectory or None
        For measured (noisy) data, the noise-free samples they were made from.
    certificate : Certificate or None
        Accuracy certificate when the samples come from :func:`sampledyn.simulate`.
    origin : str or None
        Absolute time of the first sample (t = 0) as logged, e.g.
        ``"2024-05-02T10:00:00.000000000+00:00"`` or ``"TimeUS = 51234000 us"``;
        None for simulated data.
    sliding : tuple of SlidingInterval
        For simulated data of a model whose f jumps, the intervals in which the state
        slid on a switching surface (in time order); empty otherwise. One-step
        predictors evaluate f on one branch at each of their points, so their errors
        on intervals that overlap these are those of a rule that does not know the
        sliding (of order h times the jump of f), not of order h^(s+1).
    signal : Signal or None
        The input in continuous time that made the samples (set by
        :func:`sampledyn.simulate`; kept by noise, subsampling and slicing in time);
        the rules that evaluate f between samples (RK_s, T) take their stage inputs
        from it when no ``signal`` is given. None for a log, whose input between
        samples is unknown (the rules then hold the sampled input), and after
        :meth:`replace` changes ``u`` without giving a ``signal``.
    """

    t: np.ndarray
    x: np.ndarray
    u: np.ndarray
    h: float
    state_names: tuple[str, ...]
    state_units: tuple[str, ...]
    input_names: tuple[str, ...] = ()
    input_units: tuple[str, ...] = ()
    clean: Trajectory | None = field(default=None, repr=False)
    certificate: Certificate | None = field(default=None, repr=False)
    origin: str | None = field(default=None, repr=False)
    sliding: tuple[SlidingInterval, ...] = field(default=(), repr=False)
    signal: Any = field(default=None, repr=False, compare=False)

    def __post_init__(self) -> None:
        t = _frozen(self.t)
        x = _frozen(self.x)
        u = _frozen(self.u)
        if t.ndim != 1:
            raise ValueError(f"`t` must be 1-dimensional, got shape {t.shape}.")
        if x.ndim != 2 or x.shape[0] != t.shape[0]:
            raise ValueError(
                f"`x` must have shape (len(t), nx) = ({t.shape[0]}, nx), got {x.shape}."
            )
        if u.ndim == 1:
            u = _frozen(u[:, None])
        if u.ndim != 2 or u.shape[0] != t.shape[0]:
            raise ValueError(
                f"`u` must have shape (len(t), nu) = ({t.shape[0]}, nu), got {u.shape}."
            )
        checks.period(self.h)
        _check_spacing(t, float(self.h))
        nx = x.shape[1]
        if len(self.state_names) != nx or len(self.state_units) != nx:
            raise ValueError(
                f"`state_names` and `state_units` need {nx} entries each, got "
                f"{len(self.state_names)} and {len(self.state_units)}."
            )
        names = tuple(self.input_names) or tuple(f"u{i + 1}" for i in range(u.shape[1]))
        units = tuple(self.input_units) or ("",) * u.shape[1]
        if len(names) != u.shape[1] or len(units) != u.shape[1]:
            raise ValueError(f"`input_names` and `input_units` need {u.shape[1]} entries each.")
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "x", x)
        object.__setattr__(self, "u", u)
        object.__setattr__(self, "h", float(self.h))
        object.__setattr__(self, "state_names", tuple(self.state_names))
        object.__setattr__(self, "state_units", tuple(self.state_units))
        object.__setattr__(self, "input_names", names)
        object.__setattr__(self, "input_units", units)
        object.__setattr__(self, "sliding", tuple(SlidingInterval(*s) for s in self.sliding))

    @property
    def n_samples(self) -> int:
        return int(self.t.shape[0])

    @property
    def nx(self) -> int:
        return int(self.x.shape[1])

    @property
    def nu(self) -> int:
        return int(self.u.shape[1])

    @cached_property
    def on_uniform_grid(self) -> bool:
        """True if ``t`` is uniform with step ``h`` up to the rounding of t
        (:func:`uniform_grid`): the test that selects the rules' fixed-step code.
        Computed once per Trajectory (its arrays are read-only)."""
        return uniform_grid(self.t, self.h)

    def is_uniform(self, rtol: float = 1e-6) -> bool:
        """True if every step ``t[n+1] - t[n]`` is within ``rtol * h`` of ``h``.

        A check of the sampling, looser than :func:`uniform_grid` (steps equal to h up
        to the rounding of t), which is what selects the rules' fixed-step code."""
        steps = np.diff(self.t)
        return bool(steps.size == 0 or np.abs(steps - self.h).max() <= rtol * self.h)

    def replace(self, **changes: object) -> Trajectory:
        """A copy with some fields changed (``dataclasses.replace``). A new ``u``
        without a ``signal`` drops the signal (it made the old inputs, not these)."""
        if "u" in changes and "signal" not in changes:
            changes["signal"] = None
        return replace(self, **changes)  # type: ignore[arg-type]

    def subsample(self, k: int) -> Trajectory:
        """Every k-th sample: the same data at the period k h.

        Exact samples stay exact (they are values of the same continuous path). The
        certificate of an interval of the new grid is the sum of the certificates of
        the k intervals it spans (a first-order bound). A tail shorter than k
        intervals is dropped.
        """
        if isinstance(k, bool) or not isinstance(k, int | np.integer) or k < 1:
            raise ArgumentError("k", f"`k` must be an int >= 1, got {k!r}.")
        n_int = (self.n_samples - 1) // k
        if n_int < 1:
            raise ValueError(f"k={k} leaves no interval of {self.n_samples - 1}.")
        sl = slice(0, n_int * k + 1, k)
        cert = None
        if self.certificate is not None:
            c = self.certificate
            cert = Certificate(
                per_interval=c.per_interval[: n_int * k].reshape(n_int, k).sum(axis=1),
                scale=c.scale,
                steps=c.steps[: n_int * k].reshape(n_int, k).sum(axis=1),
                rtol=c.rtol,
            )
        return replace(
            self,
            t=self.t[sl],
            x=self.x[sl],
            u=self.u[sl],
            h=self.h * k,
            clean=self.clean.subsample(k) if self.clean is not None else None,
            certificate=cert,
        )

    def check_finite(self, argument: str = "measured") -> None:
        """Raise ``ValueError`` naming the first sample that holds NaN or inf (looked
        for once per Trajectory: its arrays are read-only)."""
        if self._first_non_finite is not None:
            name, n = self._first_non_finite
            raise ValueError(
                f"`{argument}.{name}` holds NaN or inf; first bad sample n={n} "
                f"(t={self.t[n]:g} s). Remove or fill it before predicting."
            )

    @cached_property
    def _first_non_finite(self) -> tuple[str, int] | None:
        """(array name, sample) of the first NaN or inf in x, u, t (in that order)."""
        for name, a in (("x", self.x), ("u", self.u), ("t", self.t)):
            if np.isfinite(a).all():
                continue
            bad = ~np.isfinite(a if a.ndim == 2 else a[:, None]).all(axis=1)
            if bad.any():
                return name, int(np.argmax(bad))
        return None
