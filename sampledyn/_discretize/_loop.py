"""A digital controller against the exact plant: the sampled loop.

At each sample t_n the controller gets the measured state y_n = x(t_n) + delta_n and
returns a command u_n; the plant integrates exactly (the simulator's compiled
Dormand-Prince 8 intervals with kink location, the thrusters saturating inside the
plant model) over [t_n, t_{n+1}) with the command held, or, with ``delay``, with the
command of the previous sample (a computation delay of one sample).

Why here and not in :func:`sampledyn.simulate`: ``simulate`` integrates a known input
signal and certifies the samples; in a loop the input of an interval depends on the
samples before it, so the integration goes interval by interval, and a controller
designed on a discrete-time model (:class:`~sampledyn.DiscreteModel`) builds
its state z from the measured history the way that model's rule does. Both are facts
of this layer. The loop calls the simulator's compiled interval integrator
(:data:`sampledyn._simulate.integrate_intervals`) from compiled code: a
:class:`LinearLaw` (gain matrix and references as data) runs without any Python call
per sample; any other controller is a Python callable, called once per sample.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit, types

from .. import _checks as checks
from .. import _integrator as _int
from .._noise import add_noise
from .._simulate import integrate_intervals, switching
from .._trajectory import Trajectory
from ..exceptions import ArgumentError, EnvelopeExceeded, IntegrationError
from ..models._base import RHS_TYPE, RO1, RO2, readonly
from ..models._jumps import refuse_jumps
from ._model import DiscreteModel

__all__ = ["LinearLaw", "LoopRun", "run_loop"]


_F = types.float64
_A2 = types.float64[:, ::1]
_B1 = types.Array(types.boolean, 1, "C", readonly=True)
_I1 = types.Array(types.int64, 1, "C", readonly=True)
_LOOP_SIG = types.Tuple((types.int64, _F, types.int64))(
    RHS_TYPE, RO1, RHS_TYPE, RO1, _B1,  # plant rhs, p, sw, sp, input_only
    RHS_TYPE, RO1,  # design model rhs, p (f-blocks of z)
    RO1, _A2, RO2, _A2, _A2, _A2,  # t, X, noise, Y (measured), command, applied
    RO2, RO2, RO2, _I1, _I1, RO1, RO1,  # K, z_ref, u_ref, kinds, lags, u_lo, u_hi
    types.boolean, types.boolean, types.int64, types.int64,  # law_on, delay, n_start, n_stop
    _F, _F, _F, types.int64[::1], _A2, _B1, RO1, RO2,  # rtol, atol, dt, steps, diff, restart, zeros
    RO1, RO1,  # envelope lo, hi
)  # fmt: skip


@njit(inline="always")
def _law(n, t, Y, U, cmd, drhs, dp, K, z_ref, u_ref, kinds, lags, u_lo, u_hi, delay, z, fb):
    """cmd[n] of the linear law: z from the measured history as the design model's
    layout says (a past state, or f of the design model there with the input applied),
    the previous command with ``delay``; ``u_ref`` until the history is complete."""
    nx = Y.shape[1]
    nu = cmd.shape[1]
    nb = kinds.shape[0]
    nz = K.shape[1]
    hist = 0
    for b in range(nb):
        hist = max(hist, lags[b] + 1)
    if n < hist - 1 or (delay and n < 1):
        for i in range(nu):
            cmd[n, i] = min(max(u_ref[n, i], u_lo[i]), u_hi[i])
        return
    for b in range(nb):
        k = n - lags[b]
        if kinds[b] == 0:
            for j in range(nx):
                z[b * nx + j] = Y[k, j]
        else:
            drhs(t[k], Y[k], U[k], dp, fb)
            for j in range(nx):
                z[b * nx + j] = fb[j]
    if delay:
        for j in range(nu):
            z[nb * nx + j] = cmd[n - 1, j]
    for i in range(nu):
        v = u_ref[n, i]
        for j in range(nz):
            v += K[i, j] * (z[j] - z_ref[n, j])
        cmd[n, i] = min(max(v, u_lo[i]), u_hi[i])


@njit(inline="always")
def _outside(X, n, x_lo, x_hi):
    """True if sample n left the envelope [x_lo, x_hi]."""
    for j in range(X.shape[1]):
        if not x_lo[j] <= X[n, j] <= x_hi[j]:
            return True
    return False


# The loop calls the integrator's smooth specialisation: compiled below (or loaded from
# numba's cache), after the process compiling it on a first run has saved it there.
_int.wait_aside(True)


@njit(_LOOP_SIG, cache=True)
def _loop(
    rhs, p, sw, sp, sw_io, drhs, dp, t, X, noise, Y, cmd, U,
    K, z_ref, u_ref, kinds, lags, u_lo, u_hi,
    law_on, delay, n_start, n_stop, rtol, atol, dt, steps, diff, restart, z1, z2, x_lo, x_hi,
):  # fmt: skip  # pragma: no cover - compiled
    """Samples n_start..n_stop-1: measure, command, hold, integrate one interval.

    Returns (status, next dt proposal, n reached); status as the integrator's, or 3
    when the state leaves the envelope [x_lo, x_hi].
    """
    nx = X.shape[1]
    nu = U.shape[1]
    z = np.empty(K.shape[1])
    fb = np.empty(nx)
    for n in range(n_start, n_stop):
        for j in range(nx):
            Y[n, j] = X[n, j] + noise[n, j]
        if law_on:
            _law(n, t, Y, U, cmd, drhs, dp, K, z_ref, u_ref, kinds, lags, u_lo, u_hi, delay, z, fb)
        if n + 1 >= X.shape[0]:
            break
        for i in range(nu):
            U[n, i] = cmd[n - 1, i] if delay and n >= 1 else cmd[n, i]
        status, dt = integrate_intervals(
            rhs, p, t, X[n], U, z1, z2, z2, z2, rtol, atol, False, n, n + 1, dt,
            sw, sp, sw_io, X, steps, diff, restart,
        )  # fmt: skip
        if status != 0:
            return status, dt, n
        if math.isnan(X[n + 1, 0]):
            return 2, dt, n
        if _outside(X, n + 1, x_lo, x_hi):
            return 3, dt, n + 1
    return 0, dt, n_stop


def _in_slices(
    args: Any, delay: bool, n: int, rtol: float, atol: float, dt: float, steps: Any,
    diff: Any, tail: Any,
) -> tuple[int, float, int]:  # fmt: skip
    """The compiled loop of a LinearLaw over samples 0..n-1, in slices of about 0.05 s
    each, so that Ctrl-C and SIGTERM (which act in Python) stop it within a second;
    every value the loop carries lives in the arrays, so the numbers are those of one
    call."""
    start, size = 0, 16
    status, reached = 0, 0
    while start < n and status == 0:
        stop = min(n, start + size)
        began = time.perf_counter()
        loop: Any = _loop
        status, dt, reached = loop(*args, True, delay, start, stop, rtol, atol, dt, steps, diff,
                                   *tail)  # fmt: skip
        rate = (stop - start) / max(time.perf_counter() - began, 1e-6)
        size = int(min(max(0.05 * rate, 1), 1 << 20))
        start = stop
    return status, dt, reached


@dataclass(frozen=True)
class LinearLaw:
    """``u_n = clip(u_ref + K (z_n - z_ref), lo, hi)``: state feedback on the discrete
    state of a :class:`DiscreteModel`, as data (evaluated in compiled code).

    z_n is built from the measured samples the way the design model's rule keeps its
    history (its ``layout``: past measured states, f of the design model at past
    measured states with the inputs that were applied, and with ``delay`` the previous
    command). Before the history is complete the law outputs ``u_ref``.

    Parameters
    ----------
    design : DiscreteModel
        The model the gain was designed on (its rule, h and delay option).
    gain : array_like, shape (nu, nz)
        K (e.g. minus the gain of ``control.dlqr``: u = u_ref - K_lqr (z - z_ref)).
    z_ref : array_like, shape (nz,)
        The discrete state of the operating point (``design.steady_state(x_ref, u_ref)``).
    u_ref : array_like, shape (nu,)
        The input there (feed-forward).
    limits : (lo, hi) of shape (nu,), optional
        Command limits; default the model's ``input_limits()`` (thruster n_max), else
        none. The plant saturates on its own in any case.
    reference : callable, optional
        ``reference(t) -> (z_ref (N, nz), u_ref (N, nu))`` on the sample times, for a
        time-varying set point; overrides ``z_ref`` and ``u_ref``.
    """

    design: DiscreteModel
    gain: Any
    z_ref: Any
    u_ref: Any
    limits: Any = None
    reference: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]] | None = None

    def __post_init__(self) -> None:
        d = self.design
        if not isinstance(d, DiscreteModel):
            raise TypeError(f"`design` must be a DiscreteModel, got {type(d).__name__}.")
        put = object.__setattr__
        k = np.ascontiguousarray(checks.finite_array(self.gain, "gain", (d.nu, d.nz)))
        put(self, "gain", k)
        zr = np.asarray(self.z_ref, dtype=float)
        ur = np.asarray(self.u_ref, dtype=float)
        if zr.shape != (d.nz,) or ur.shape != (d.nu,):
            raise ValueError(
                f"`z_ref` and `u_ref` must have shapes ({d.nz},) and ({d.nu},), got "
                f"{zr.shape} and {ur.shape}."
            )
        put(self, "z_ref", zr)
        put(self, "u_ref", ur)
        if self.limits is None:
            get = getattr(d.model, "input_limits", None)
            lim = get() if get is not None else (np.full(d.nu, -np.inf), np.full(d.nu, np.inf))
        else:
            lim = self.limits
        lo, hi = (np.ascontiguousarray(a, dtype=float) for a in lim)
        if lo.shape != (d.nu,) or hi.shape != (d.nu,) or (lo > hi).any():
            raise ValueError(f"`limits` must be (lo, hi) of shape ({d.nu},) with lo <= hi.")
        put(self, "limits", (lo, hi))

    def references(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(z_ref, u_ref) on the sample times, shapes (N, nz) and (N, nu)."""
        n = t.shape[0]
        if self.reference is None:
            return (
                np.ascontiguousarray(np.broadcast_to(self.z_ref, (n, self.design.nz))),
                np.ascontiguousarray(np.broadcast_to(self.u_ref, (n, self.design.nu))),
            )
        zr, ur = self.reference(t)
        zr = np.ascontiguousarray(zr, dtype=float)
        ur = np.ascontiguousarray(ur, dtype=float)
        if zr.shape != (n, self.design.nz) or ur.shape != (n, self.design.nu):
            raise ValueError(
                f"`reference(t)` must return arrays of shapes ({n}, {self.design.nz}) and "
                f"({n}, {self.design.nu}), got {zr.shape} and {ur.shape}."
            )
        return zr, ur


@dataclass(frozen=True)
class LoopRun:
    """A sampled loop's record.

    Attributes
    ----------
    exact : Trajectory
        The plant's exact samples x(t_n) (``exact.u``: the input held over
        [t_n, t_{n+1}), before the plant's own saturation).
    measured : ndarray, shape (N, nx)
        What the controller saw: exact samples plus the measurement noise.
    command : ndarray, shape (N, nu)
        The controller's output at each sample (applied one sample later with
        ``delay``).
    """

    exact: Trajectory
    measured: np.ndarray
    command: np.ndarray


def _frozen(a: np.ndarray) -> np.ndarray:
    """A read-only contiguous copy keeping the dtype (bool, int64)."""
    a = np.array(a, copy=True, order="C")
    a.setflags(write=False)
    return a


def _noise_array(plant: Any, t: np.ndarray, noise: Any, seed: Any, distribution: str) -> np.ndarray:
    n, nx = t.shape[0], int(plant.nx)
    if noise is None:
        return np.zeros((n, nx))
    if isinstance(noise, tuple) and len(noise) == 2:
        zero = Trajectory(
            t=t,
            x=np.zeros((n, nx)),
            u=np.zeros((n, int(plant.nu))),
            h=float(t[1] - t[0]),
            state_names=tuple(plant.state_names),
            state_units=tuple(plant.state_units),
        )
        return np.array(add_noise(zero, noise[0], noise[1], seed, distribution=distribution).x)
    arr = np.ascontiguousarray(noise, dtype=float)
    if arr.shape != (n, nx) or not np.isfinite(arr).all():
        raise ValueError(
            f"`noise` must be (eta %, v %) or a finite array of shape ({n}, {nx}), got "
            f"{np.shape(noise)}."
        )
    return arr


def run_loop(
    plant: Any,
    controller: Any,
    T: float,
    h: float,
    x0: Any = None,
    *,
    noise: Any = None,
    seed: Any = 0,
    distribution: str = "uniform",
    delay: bool | None = None,
    envelope: Any = None,
    rtol: float = 1e-10,
    atol: float = 1e-10,
) -> LoopRun:
    """Run a digital controller against the exact plant, sampled with period h.

    Parameters
    ----------
    plant : CompiledModel
        The continuous-time plant (a vehicle: thrusters saturate at n_max inside it).
    controller : LinearLaw or callable
        A :class:`LinearLaw` runs in compiled code; a callable ``controller(t_n, y_n)
        -> u_n`` (y_n shape (nx,), u_n shape (nu,)) is called once per sample (an MPC,
        any Python law).
    T, h : float
        Duration and sampling period (s); T a multiple of h.
    x0 : array_like, shape (nx,), optional
        Initial plant state (default the plant's ``default_x0``).
    noise : (eta %, v %) or ndarray (N, nx), optional
        Measurement noise: the paper's levels (as :func:`sampledyn.add_noise`, same
        seeds and streams) or the noise itself.
    seed, distribution
        As :func:`sampledyn.add_noise`.
    delay : bool, optional
        Apply each command one sample late (computation delay); the command before
        the first is ``u_ref``/the first command. Default: the LinearLaw's design
        option, False for a callable.
    envelope : (lo, hi), optional
        State bounds, each shape (nx,) (inf where unbounded): the run stops with
        :class:`EnvelopeExceeded` at the first sample outside (a diverging loop, e.g.
        a vehicle tumbling, otherwise costs the integrator ever smaller steps).
    rtol, atol : float
        Tolerances of the exact integration between samples.

    Returns
    -------
    LoopRun

    Raises
    ------
    IntegrationError
        if the plant cannot be integrated (e.g. the loop diverges to NaN).
    EnvelopeExceeded
        if the state leaves ``envelope``.
    """
    from .._simulate import check_period  # the simulator's own check of (h, T)

    n_int = check_period(h, T)
    nx, nu = int(plant.nx), int(plant.nu)
    checks.check_memory(  # states, measurements, commands, inputs, noise, references
        8.0 * (n_int + 1) * (3 + 5 * nx + 4 * nu),
        f"T / h = {T:g} s / {h:g} s = {n_int + 1:.4g} samples",
        "the closed-loop run",
    )
    t = np.arange(n_int + 1, dtype=float) * float(h)
    x0 = plant.default_x0 if x0 is None else x0
    x0 = checks.finite_array(x0, "x0", (nx,))
    noise_arr = _noise_array(plant, t, noise, seed, distribution)
    refuse_jumps(
        plant, "plant", "the sampled loop integrates it without the branches of f (no "
        "crossing, no sliding); simulate it with sampledyn.simulate and a ZeroOrderHold of "
        "the commands.",
    )  # fmt: skip
    rhs, p = plant.kernel()
    sw, sp, sw_io = switching(plant)
    X = np.zeros((t.shape[0], nx))
    X[0] = x0
    Y = np.zeros_like(X)
    cmd = np.zeros((t.shape[0], nu))
    U = np.zeros((t.shape[0], nu))
    steps = np.zeros(n_int, dtype=np.int64)
    diff = np.empty((n_int, nx))
    restart = _frozen(np.ones(t.shape[0], dtype=np.bool_))
    zeros1 = readonly(np.zeros(nu))
    zeros2 = readonly(np.zeros((nu, 0)))
    if envelope is None:
        x_lo, x_hi = np.full(nx, -np.inf), np.full(nx, np.inf)
    else:
        x_lo, x_hi = (np.ascontiguousarray(a, dtype=float) for a in envelope)
        if x_lo.shape != (nx,) or x_hi.shape != (nx,):
            raise ValueError(f"`envelope` must be (lo, hi) of shape ({nx},) each.")
    law = controller if isinstance(controller, LinearLaw) else None
    if law is None and not callable(controller):
        raise TypeError(
            f"`controller` must be a LinearLaw or a callable (t, y) -> u, got "
            f"{type(controller).__name__}."
        )
    if law is not None:
        d = law.design
        if not checks.same_period(float(h), d.h):
            raise ArgumentError(
                "h", f"the law was designed for h={d.h:g} s, the loop runs h={h:g} s."
            )
        if d.nx != nx or d.nu != nu:
            raise ValueError(
                f"the law's design model has nx={d.nx}, nu={d.nu}; the plant nx={nx}, nu={nu}."
            )
        delay = d.delay if delay is None else bool(delay)
        drhs, dp = d.model.kernel()
        z_ref, u_ref = law.references(t)
        gain = law.gain
        kinds = np.array([0 if k == "x" else 1 for k, _ in d.layout], dtype=np.int64)
        lags = np.array([lag for _, lag in d.layout], dtype=np.int64)
        lo, hi = law.limits
    else:
        delay = bool(delay)
        drhs, dp = rhs, p
        z_ref = np.zeros((t.shape[0], 0))
        u_ref = np.zeros((t.shape[0], nu))
        gain = np.zeros((nu, 0))
        kinds = lags = np.zeros(0, dtype=np.int64)
        lo, hi = np.full(nu, -np.inf), np.full(nu, np.inf)
    args = (
        rhs, readonly(p), sw, readonly(np.asarray(sp, dtype=float)),
        _frozen(np.asarray(sw_io, dtype=np.bool_)), drhs, readonly(np.asarray(dp, dtype=float)),
        readonly(t), X, readonly(noise_arr), Y, cmd, U,
        readonly(gain), readonly(z_ref), readonly(u_ref), _frozen(kinds), _frozen(lags),
        readonly(lo), readonly(hi),
    )  # fmt: skip
    dt = float(h)
    if law is not None:
        tail = (restart, zeros1, zeros2, readonly(x_lo), readonly(x_hi))
        status, dt, reached = _in_slices(
            args, delay, t.shape[0], float(rtol), float(atol), dt, steps, diff, tail
        )
    else:
        status, reached = 0, 0
        for n in range(t.shape[0]):
            y = X[n] + noise_arr[n]
            u = np.asarray(controller(float(t[n]), y), dtype=float)
            if u.shape != (nu,) or not np.isfinite(u).all():
                raise ValueError(
                    f"`controller` returned {u!r} at t={t[n]:g} s; it must return a finite "
                    f"array of shape ({nu},)."
                )
            cmd[n] = u
            status, dt, reached = _loop(
                *args, False, delay, n, n + 1, float(rtol), float(atol), dt, steps, diff,
                restart, zeros1, zeros2, readonly(x_lo), readonly(x_hi),
            )  # fmt: skip
            if status != 0:
                break
    if status == 3:
        x = X[reached]
        out = [
            f"{plant.state_names[j]} = {x[j]:.4g}" for j in np.flatnonzero((x < x_lo) | (x > x_hi))
        ]
        raise EnvelopeExceeded(
            f"the sampled loop left the state envelope at t={t[reached]:g} s ({', '.join(out)})."
        )
    if status != 0:
        what = {1: "step size underflow", 4: "the integration stalled"}.get(
            status, "NaN or inf in the state"
        )
        raise IntegrationError(
            f"{what} in the sampled loop at t={t[reached]:g} s: the closed loop may "
            "diverge there (check the controller's gain and the sampling period)."
        )
    U[-1] = U[-2] if t.shape[0] > 1 else cmd[0]
    exact = Trajectory(
        t=t,
        x=X,
        u=U,
        h=float(h),
        state_names=tuple(plant.state_names),
        state_units=tuple(plant.state_units),
        input_names=tuple(plant.input_names),
        input_units=tuple(plant.input_units),
    )
    return LoopRun(exact=exact, measured=Y, command=cmd)
