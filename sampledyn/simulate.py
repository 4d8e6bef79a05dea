"""Exact sampled data: compiled adaptive high-order integration between samples.

Each sampling interval ``[t_n, t_{n+1}]`` is integrated on its own with the
Dormand-Prince 8(5,3) pair (Hairer, Norsett & Wanner, *Solving ODEs I*, 2nd ed.,
sec. II.10; the coefficients of Hairer's ``dop853.f``, in :mod:`sampledyn._dop853`), with
error-controlled steps that never cross a sample time, so an input that jumps at a sample
time is never integrated across. Where f is not smooth inside an interval (``|v| v`` or
``n |n|`` crossing zero) the error control shrinks the step there instead of every step.

The samples come with a :class:`~sampledyn.Certificate`: every interval is integrated a
second time, in lockstep, with each accepted step halved, and the difference is the
per-interval flow-error estimate.
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np
from numba import njit, types

from . import _dop853 as _dop
from ._trajectory import Certificate, NumericalError, Trajectory
from .models import RHS_TYPE, RO1, RO2, readonly
from .models import index_switch as _index_switch
from .signals import Signal

__all__ = ["IntegrationError", "integrate_intervals", "simulate", "switching"]

_NS = _dop.N_STAGES
_A = np.ascontiguousarray(_dop.A)
_B = np.ascontiguousarray(_dop.B)
_C = np.ascontiguousarray(_dop.C)
_E3 = np.ascontiguousarray(_dop.E3)
_E5 = np.ascontiguousarray(_dop.E5)


# Sampling intervals per call of the compiled integrator.
_CHUNK = 1 << 15


class IntegrationError(NumericalError):
    """The exact-sample integrator could not meet its tolerance."""


@njit(cache=True)
def _input_at(hold_row, offset, amp, freq, phase, t, out):  # pragma: no cover - compiled
    for j in range(out.shape[0]):
        v = hold_row[j] + offset[j]
        for k in range(amp.shape[1]):
            v += amp[j, k] * math.sin(2.0 * math.pi * freq[j, k] * t + phase[j, k])
        out[j] = v


@njit(cache=True)
def _dop_stages(rhs, p, t, y, dt, k0, hold_row, offset, amp, freq, phase, K, ytmp, u, ynew):
    """Stages 1..11 given K[0] = k0 already; writes y_new. (pragma: compiled)"""
    nx = y.shape[0]
    for j in range(nx):
        K[0, j] = k0[j]
    for s in range(1, _NS):
        for j in range(nx):
            acc = 0.0
            for m in range(s):
                acc += _A[s, m] * K[m, j]
            ytmp[j] = y[j] + dt * acc
        ts = t + _C[s] * dt
        _input_at(hold_row, offset, amp, freq, phase, ts, u)
        rhs(ts, ytmp, u, p, K[s])
    for j in range(nx):
        acc = 0.0
        for m in range(_NS):
            acc += _B[m] * K[m, j]
        ynew[j] = y[j] + dt * acc


@njit(cache=True)
def _switch_inside(
    sw, sp, tc, y, ynew, k0, k1, dt, hold_row, offset, amp, freq, phase, u, ytry, g, c
):  # pragma: no cover - compiled
    """The switching values at tc + c, c in [0, dt], written to ``g``.

    The state inside the step is the cubic Hermite interpolant of (y, k0) and
    (ynew, k1), accurate to O(dt^4).
    """
    th = c / dt
    h00 = (1.0 + 2.0 * th) * (1.0 - th) ** 2
    h10 = th * (1.0 - th) ** 2
    h01 = th * th * (3.0 - 2.0 * th)
    h11 = th * th * (th - 1.0)
    for j in range(y.shape[0]):
        ytry[j] = h00 * y[j] + h10 * dt * k0[j] + h01 * ynew[j] + h11 * dt * k1[j]
    _input_at(hold_row, offset, amp, freq, phase, tc + c, u)
    sw(tc + c, ytry, u, sp, g)


@njit(cache=True)
def _crossing_root(
    sw, sp, tc, y, ynew, k0, k1, dt, hold_row, offset, amp, freq, phase, u, ytry, g, idx, a, fa, fb
):  # pragma: no cover - compiled
    """Time c in (a, dt) where switching value ``idx`` crosses zero, given its values
    ``fa`` at tc + a and ``fb`` at tc + dt (of opposite signs).

    The values inside the step are taken on the step's Hermite interpolant
    (:func:`_switch_inside`): the kink is then placed to about 1e-8 s, and the error
    of a misplaced kink grows like the cube of that offset. Illinois method.
    """
    b = dt
    c = dt
    side = 0
    for _ in range(60):
        c = (fa * b - fb * a) / (fa - fb)
        _switch_inside(
            sw, sp, tc, y, ynew, k0, k1, dt, hold_row, offset, amp, freq, phase, u, ytry, g, c
        )
        fc = g[idx]
        if fc * fb > 0.0:
            b, fb = c, fc
            if side == -1:
                fa *= 0.5
            side = -1
        elif fa * fc > 0.0:
            a, fa = c, fc
            if side == 1:
                fb *= 0.5
            side = 1
        else:
            break
        if b - a <= 1e-13 * dt:
            break
    return c


_F = types.float64
_A2 = types.float64[:, ::1]
_B1 = types.Array(types.boolean, 1, "C", readonly=True)
_INTEGRATE_SIG = types.Tuple((types.int64, _F))(
    RHS_TYPE, RO1, RO1, RO1, RO2, RO1, RO2, RO2, RO2, _F, _F, types.boolean, types.int64,
    types.int64, _F, RHS_TYPE, RO1, _B1, _A2, types.int64[::1], _A2, _B1,
)  # fmt: skip


@njit(_INTEGRATE_SIG, cache=True)
def _integrate(
    rhs,
    p,
    t,
    x0,
    hold,
    offset,
    amp,
    freq,
    phase,
    rtol,
    atol,
    certify,
    n_start,
    n_stop,
    dt_init,
    sw,
    sp,
    sw_input_only,
    X,
    steps,
    diff,
    restart,
):  # pragma: no cover - compiled
    """Integrate intervals n_start..n_stop-1; X[n_start] must hold the start state.

    The nodes ``t`` are the sample times plus any input breakpoint between them. The
    certifying half-step run restarts from X[n] only where ``restart[n]`` (a sample
    time): across a breakpoint it goes on, so ``diff`` at the last node of a sampling
    interval is the difference over the whole interval.

    Steps end exactly where a switching value ``sw(t, x, u, sp)`` crosses zero, so no
    step straddles a point where f is not smooth (|v| v, n |n|). A value that is zero
    (or negligible) at a step's start takes its sign from just inside the step, so a
    state starting at rest on a kink is tested like any other.

    Returns (status, suggested next dt). status 0 ok, 1 step underflow, 2 non-finite.
    """
    nx = x0.shape[0]
    nu = hold.shape[1]
    K = np.empty((_NS + 1, nx))
    Kf = np.empty((_NS + 1, nx))
    ytmp = np.empty(nx)
    u = np.empty(nu)
    y = np.empty(nx)
    ynew = np.empty(nx)
    ytry = np.empty(nx)
    yf = np.empty(nx)
    yfm = np.empty(nx)
    yfn = np.empty(nx)
    k0 = np.empty(nx)
    kf0 = np.empty(nx)
    n_sw = sw_input_only.shape[0]
    ga = np.empty(n_sw)
    gb = np.empty(n_sw)
    gr = np.empty(n_sw)
    gp = np.empty(n_sw)
    dt = dt_init
    for n in range(n_start, n_stop):
        ta = t[n]
        tb = t[n + 1]
        hold_row = hold[n]
        for j in range(nx):
            y[j] = X[n, j]
            if restart[n]:
                yf[j] = X[n, j]
        tc = ta
        _input_at(hold_row, offset, amp, freq, phase, tc, u)
        rhs(tc, y, u, p, k0)
        count = 0
        min_dt = 1e-12 * (tb - ta)
        rejected = False
        dt_free = dt
        while tc < tb:
            # dt_free is the step the error control proposes; a step cut short to land
            # on the sample time or on a kink says nothing about it and does not
            # change it.
            dt = dt_free
            if dt > tb - tc or tb - (tc + dt) < 1e-9 * (tb - ta):
                dt = tb - tc
            if n_sw > 0:
                _input_at(hold_row, offset, amp, freq, phase, tc, u)
                sw(tc, y, u, sp, ga)
            while True:
                _dop_stages(
                    rhs, p, tc, y, dt, k0, hold_row, offset, amp, freq, phase, K, ytmp, u, ynew
                )
                tn = tc + dt
                if tb - tn < 1e-9 * (tb - ta):
                    tn = tb
                _input_at(hold_row, offset, amp, freq, phase, tn, u)
                rhs(tn, ynew, u, p, K[_NS])
                # Does a switching value change sign inside the step? Then end the step
                # on the first such kink (located on the step's Hermite interpolant),
                # so that f is smooth on every step; the error test follows.
                tau = dt
                if n_sw > 0:
                    sw(tn, ynew, u, sp, gb)
                    probed = False
                    for k in range(n_sw):
                        a, fa = 0.0, ga[k]
                        if abs(fa) <= 1e-13 * abs(gb[k]):
                            # The step starts on this kink (a value at exactly 0, as
                            # from a state at rest, or one just located): its sign at
                            # the start says nothing, so take the one it has just
                            # after, at the shortest step a kink may cut (1e-6 dt),
                            # and look for a crossing after that.
                            a = 1e-6 * dt
                            if not probed:
                                _switch_inside(
                                    sw, sp, tc, y, ynew, k0, K[_NS], dt, hold_row, offset,
                                    amp, freq, phase, u, ytry, gp, a,
                                )  # fmt: skip
                                probed = True
                            fa = gp[k]
                        if fa * gb[k] < 0.0:
                            r = _crossing_root(
                                sw, sp, tc, y, ynew, k0, K[_NS], dt, hold_row, offset, amp,
                                freq, phase, u, ytry, gr, k, a, fa, gb[k],
                            )  # fmt: skip
                            # A crossing at the very start (the previous step ended
                            # on this kink) must not hide a later one.
                            if r > 1e-6 * dt:
                                tau = min(tau, r)
                if 1e-6 * dt < tau < dt * (1.0 - 1e-9):
                    dt = tau
                    continue
                break
            e5 = 0.0
            e3 = 0.0
            finite = True
            for j in range(nx):
                a5 = 0.0
                a3 = 0.0
                for m in range(_NS + 1):
                    a5 += _E5[m] * K[m, j]
                    a3 += _E3[m] * K[m, j]
                sc = atol + rtol * max(abs(y[j]), abs(ynew[j]))
                e5 += (a5 / sc) ** 2
                e3 += (a3 / sc) ** 2
                if not math.isfinite(ynew[j]):
                    finite = False
            if not finite:
                return 2, dt
            if e5 == 0.0 and e3 == 0.0:
                err = 0.0
            else:
                err = dt * e5 / math.sqrt((e5 + 0.01 * e3) * nx)
            if err > 1.0:
                rejected = True
                dt_free = dt * max(0.2, 0.9 * err ** (-1.0 / 8.0))
                if dt_free < min_dt:
                    return 1, dt_free
                continue
            step = tn - tc
            if certify:
                # The same step as two half steps from the fine state.
                half = 0.5 * step
                _input_at(hold_row, offset, amp, freq, phase, tc, u)
                rhs(tc, yf, u, p, kf0)
                _dop_stages(
                    rhs, p, tc, yf, half, kf0, hold_row, offset, amp, freq, phase, Kf, ytmp, u, yfm
                )
                _input_at(hold_row, offset, amp, freq, phase, tc + half, u)
                rhs(tc + half, yfm, u, p, kf0)
                _dop_stages(
                    rhs,
                    p,
                    tc + half,
                    yfm,
                    half,
                    kf0,
                    hold_row,
                    offset,
                    amp,
                    freq,
                    phase,
                    Kf,
                    ytmp,
                    u,
                    yfn,
                )
                for j in range(nx):
                    yf[j] = yfn[j]
            tc = tn
            for j in range(nx):
                y[j] = ynew[j]
                k0[j] = K[_NS, j]
            count += 1
            factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** (-1.0 / 8.0))
            if rejected:  # no growth right after a rejection (as in Hairer's DOP853)
                factor = min(1.0, factor)
                rejected = False
            if step >= dt_free * (1.0 - 1e-9):
                dt_free = step * factor
        dt = dt_free
        for j in range(nx):
            X[n + 1, j] = y[j]
            diff[n, j] = y[j] - yf[j]
        steps[n] = count
    return 0, dt


def _readonly_bool(a: Any) -> np.ndarray:
    a = np.array(a, dtype=np.bool_, copy=True)
    a.setflags(write=False)
    return a


def switching(model: Any) -> tuple[Any, np.ndarray, np.ndarray]:
    """The model's switching function: values whose zero crossings are points where f
    is not smooth (``|v| v``, ``n |n|``).

    A model may provide ``switch_kernel()`` returning ``(sw, sp, input_only)`` with a
    compiled ``sw(t, x, u, sp, out)``; otherwise its ``kink_states`` and
    ``kink_inputs`` index tuples are used.

    Returns
    -------
    (sw, sp, input_only) with ``input_only`` a bool array, one entry per value: True
    where the value depends on the input only (no integration needed to locate it).
    """
    if hasattr(model, "switch_kernel"):
        sw, sp, input_only = model.switch_kernel()
        return sw, np.asarray(sp, dtype=float), np.asarray(input_only, dtype=np.bool_)
    states = tuple(int(i) for i in getattr(model, "kink_states", ()))
    inputs = tuple(int(j) for j in getattr(model, "kink_inputs", ()))
    sp = np.array([len(states), *states, len(inputs), *inputs], dtype=float)
    input_only = np.array([False] * len(states) + [True] * len(inputs), dtype=np.bool_)
    return _index_switch, sp, input_only


class _InputLimits:
    """Warn when the input leaves the model's ``input_limits()`` (lower, upper arrays
    of shape (nu,); e.g. thruster rpm beyond n_max, where the vehicle saturates),
    saying for how long in total and from when.

    The input is evaluated inside every integration interval as the integrator sees
    it (the interval's held part plus the sinusoids) on a grid of at least 4 points
    per interval and 256 per period of the fastest sinusoid; the time beyond a limit
    is interpolated linearly between grid points. Fed chunk by chunk (:meth:`add`),
    so the full-length input is never built; :meth:`warn` once at the end.
    """

    def __init__(self, model: Any) -> None:
        limits: Any = getattr(model, "input_limits", None)
        self.model = model
        self.active = limits is not None
        if self.active:
            self.lo, self.hi = (np.asarray(a, dtype=float) for a in limits())
            self.total, self.first = 0.0, math.inf
            self.worst = np.zeros(self.lo.shape)

    def add(self, spec: Any, t: np.ndarray) -> None:
        """The intervals [t_k, t_k+1] of one chunk, with its InputSpec."""
        if not self.active:
            return
        lo, hi = self.lo, self.hi
        length = np.diff(t)
        waves = bool(np.any(spec.amp))
        m = (
            max(4, math.ceil(256.0 * float(length.max()) * float(spec.freq_hz.max())))
            if waves
            else 1
        )
        frac = np.arange(m + 1) / m
        chunk = max(1, 100_000 // ((m + 1) * lo.size * max(1, spec.amp.shape[1])))
        for a in range(0, t.size - 1, chunk):
            b = min(a + chunk, t.size - 1)
            tt = t[a:b, None] + length[a:b, None] * frac[None, :]  # (c, m + 1)
            u = spec.hold[a:b, None, :] + spec.offset
            if waves:
                arg = 2.0 * np.pi * spec.freq_hz * tt[:, :, None, None] + spec.phase_rad
                u = u + (spec.amp * np.sin(arg)).sum(axis=-1)
            over = np.maximum(u - hi, lo - u)  # (c, m + 1, nu), > 0 beyond a limit
            self.worst = np.maximum(self.worst, over.max(axis=(0, 1)))
            e = over.max(axis=2)
            ea, eb = e[:, :-1], e[:, 1:]
            cross = (ea > 0) != (eb > 0)
            part = np.where(ea > 0, ea, eb) / np.where(cross, np.abs(ea) + np.abs(eb), 1.0)
            inside = np.where(cross, part, (ea > 0) & (eb > 0))
            self.total += float((inside * length[a:b, None]).sum()) / m
            hit = np.flatnonzero(((ea > 0) | (eb > 0)).ravel())
            if hit.size and not math.isfinite(self.first):
                i, j = divmod(int(hit[0]), m)
                lag = 0.0 if ea[i, j] > 0 else length[a + i] / m * (1.0 - part[i, j])
                self.first = float(tt[i, j]) + lag

    def warn(self, t_end: float) -> None:
        if not self.active or not math.isfinite(self.first):
            return
        lo = self.lo
        model = self.model
        names = getattr(model, "input_names", ()) or tuple(f"u{j + 1}" for j in range(lo.size))
        units = getattr(model, "input_units", ()) or ("",) * lo.size
        beyond = "; ".join(
            f"{names[j]} beyond [{lo[j]:.6g}, {self.hi[j]:.6g}] {units[j]} by up to "
            f"{self.worst[j]:.4g}"
            for j in np.flatnonzero(self.worst > 0)
        )
        warnings.warn(
            f"the input leaves the model's limits (`input_limits()`) for {self.total:.4g} s "
            f"in total of {t_end:g} s, first at t = {self.first:.6g} s ({beyond}); the "
            "model saturates it there.",
            UserWarning,
            stacklevel=3,
        )


def _check_period(h: Any, T: Any) -> int:
    for name, v in (("h", h), ("T", T)):
        if isinstance(v, bool) or not isinstance(v, int | float | np.floating | np.integer):
            raise TypeError(f"`{name}` must be a number (s), got {type(v).__name__}.")
        if not math.isfinite(v):
            raise ValueError(f"`{name}` must be finite, got {v}.")
    if h <= 0:
        raise ValueError(f"sampling period `h` must be > 0 s, got {h}.")
    if T < h:
        raise ValueError(f"duration `T` = {T} s must be at least one sampling period h = {h} s.")
    n = round(T / h)
    if abs(n * h - T) > 1e-9 * T:
        raise ValueError(f"`T` = {T} s must be an integer multiple of `h` = {h} s.")
    return int(n)


def simulate(
    model: Any,
    signal: Any,
    T: float,
    h: float,
    x0: Any = None,
    *,
    rtol: float = 1e-12,
    atol: float = 1e-12,
    certify: bool = True,
    progress: bool = False,
) -> Trajectory:
    """Exact samples of ``x' = f(t, x, u(t))`` at t_n = n h, n = 0..T/h.

    Parameters
    ----------
    model : CompiledModel
        A model with a compiled kernel (e.g. :class:`sampledyn.models.AUVLike`).
    signal : Signal
        The input u(t) (e.g. :class:`sampledyn.signals.Multilevel`).
    T : float
        Duration (s); an integer multiple of h.
    h : float
        Sampling period (s).
    x0 : ndarray, shape (nx,), optional
        Initial state; the model's ``default_x0`` if omitted.
    rtol, atol : float
        Tolerances of the error-controlled internal steps.
    certify : bool
        Attach a :class:`~sampledyn.Certificate` (costs about twice the work).
    progress : bool
        Show a progress bar.

    Returns
    -------
    Trajectory with ``t`` shape (N,), ``x`` shape (N, nx), ``u`` shape (N, nu);
    ``u`` is the input at the sample times, ``signal`` the input itself (so that the
    rules that need the input between samples find it, :attr:`Trajectory.signal`).

    Raises
    ------
    ValueError
        for a signal whose held part changes inside a sampling interval at a time its
        ``breakpoints()`` does not list (found at interval midpoints), naming the
        interval.
    IntegrationError
        if the integrator cannot meet its tolerance.

    Notes
    -----
    Inputs between samples are integrated exactly: where the signal's held part jumps
    inside a sampling interval (:meth:`~sampledyn.signals.Signal.breakpoints`, e.g. a
    :class:`~sampledyn.signals.ZeroOrderHold` of commands stamped off the grid), the
    integration stops at the jump and goes on with the new value; the certificate then
    covers the whole sampling interval (its half-step run is not restarted at the
    jump). Memory: about the returned arrays plus one N x nx array of differences
    when certifying.
    """
    n_int = _check_period(h, T)
    if not hasattr(model, "kernel"):
        raise TypeError(
            "`model` must provide a compiled kernel (a sampledyn model), "
            f"got {type(model).__name__}."
        )
    if getattr(signal, "nu", None) != model.nu:
        raise ValueError(
            f"`signal` has nu={getattr(signal, 'nu', None)} channels, "
            f"the model needs nu={model.nu}."
        )
    signal.check_sampling(float(h))
    if x0 is None:
        x0 = model.default_x0
    x0 = np.asarray(x0, dtype=float)
    if x0.shape != (model.nx,):
        raise ValueError(f"`x0` must have shape ({model.nx},), got {x0.shape}.")
    if not np.isfinite(x0).all():
        raise ValueError("`x0` holds NaN or inf.")
    if not (0 < rtol < 1 and atol > 0):
        raise ValueError(f"need 0 < rtol < 1 and atol > 0, got rtol={rtol}, atol={atol}.")

    # t_n = n h (the same values as h * arange, without the integer temporary)
    t = np.arange(n_int + 1, dtype=float)
    t *= float(h)
    nodes, sample_node = _nodes(signal, t)
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=n_int, desc=f"simulate T={T:g} s h={h:g} s", unit="interval")
    limits = _InputLimits(model)
    try:
        X, steps, diff = _run(
            model, signal, nodes, sample_node, x0, rtol, atol, certify, bar, limits
        )
    finally:
        if bar is not None:
            bar.close()
    limits.warn(float(t[-1]))
    certificate = None
    if diff is not None:
        # max |x| as max(max x, -min x): the same numbers as np.abs(X).max(0), without
        # an N x nx temporary
        scale = np.maximum(1.0, np.maximum(X.max(axis=0), -X.min(axis=0)))
        certificate = Certificate(
            per_interval=_owned_readonly(_scaled_row_max(diff, scale)),
            scale=scale,
            steps=_owned_readonly(steps),
            rtol=rtol,
        )
    u = signal(t)
    return Trajectory(
        t=_owned_readonly(t),
        x=_owned_readonly(X),
        u=_owned_readonly(u),
        h=float(h),
        state_names=model.state_names,
        state_units=model.state_units,
        input_names=model.input_names,
        input_units=model.input_units,
        certificate=certificate,
        signal=signal,
    )


def _run(
    model: Any,
    signal: Any,
    nodes: np.ndarray,
    sample_node: np.ndarray | None,
    x0: np.ndarray,
    rtol: float,
    atol: float,
    certify: bool,
    bar: Any,
    limits: _InputLimits,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Integrate over ``nodes`` in chunks of sampling intervals.

    Returns the samples X (N, nx), the internal steps per sampling interval (N - 1,)
    and, when certifying, the per-interval differences of the half-step run (N - 1, nx).
    The held input is built per chunk, so memory stays near the size of the result;
    dt carries over from chunk to chunk, so the numbers do not depend on the chunking.
    """
    rhs, p = model.kernel()
    sw, sp, sw_input_only = switching(model)
    n_int = nodes.shape[0] - 1 if sample_node is None else sample_node.shape[0] - 1
    X = np.empty((nodes.shape[0], model.nx))
    X[0] = x0
    steps = np.zeros(nodes.shape[0] - 1, dtype=np.int64)
    restart = np.ones(nodes.shape[0], dtype=np.bool_)
    if sample_node is not None:
        restart[:] = False
        restart[sample_node] = True
    restart.setflags(write=False)
    # Differences of the certifying run: kept for every sampling interval only when
    # certifying (the certificate's scale needs all samples first); otherwise, and at
    # breakpoint nodes, a scratch block the kernel writes into.
    diff = np.empty((n_int, model.nx)) if certify else None
    scratch = np.empty((0, model.nx))
    # the first step proposal: h
    dt = float(nodes[1 if sample_node is None else sample_node[1]] - nodes[0])
    for k0 in range(0, n_int, _CHUNK):
        k1 = min(k0 + _CHUNK, n_int)
        a, b = (k0, k1) if sample_node is None else (int(sample_node[k0]), int(sample_node[k1]))
        spec = signal.spec(nodes[a : b + 1])
        _check_held(signal, nodes[a : b + 1], spec.hold)
        limits.add(spec, nodes[a : b + 1])
        if diff is not None and sample_node is None:
            d_out = diff[k0:k1]
        else:
            if scratch.shape[0] < b - a:
                scratch = np.empty((b - a, model.nx))
            d_out = scratch[: b - a]
        status, dt = _integrate(
            rhs,
            readonly(p),
            readonly(nodes[a : b + 1]),
            readonly(x0),
            readonly(spec.hold),
            readonly(spec.offset),
            readonly(spec.amp),
            readonly(spec.freq_hz),
            readonly(spec.phase_rad),
            float(rtol),
            float(atol),
            bool(certify),
            0,
            b - a,
            dt,
            sw,
            readonly(sp),
            _readonly_bool(sw_input_only),
            X[a : b + 1],
            steps[a:b],
            d_out,
            restart[a : b + 1],
        )
        if status != 0:
            bad = int(np.argmax(steps[a:b] == 0)) + a
            what = "step size underflow" if status == 1 else "NaN or inf in the state"
            raise IntegrationError(
                f"{what} in the interval starting at t={nodes[bad]:g} s; the model may "
                "diverge there or the tolerance may be too tight."
            )
        if diff is not None and sample_node is not None:
            # the difference over a sampling interval is the one at its last node
            diff[k0:k1] = d_out[sample_node[k0 + 1 : k1 + 1] - a - 1]
        if bar is not None:
            bar.update(k1 - k0)
    if sample_node is not None:
        X = X[sample_node]
        steps = np.add.reduceat(steps, sample_node[:-1])
    return X, steps, diff


def _scaled_row_max(diff: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """``(np.abs(diff) / scale).max(axis=1)``, the same numbers, computed inside
    ``diff``'s own memory, which is then shrunk to the result: the N x nx array is
    gone before the inputs are evaluated, and no second N-array is needed."""
    n, nx = diff.shape
    flat = diff.reshape(-1)  # a view
    block = max(1, _CHUNK // nx)
    for a in range(0, n, block):
        rows = diff[a : a + block]
        np.abs(rows, out=rows)
        rows /= scale
        # row r's result goes to flat[r], inside rows <= r already reduced
        flat[a : a + rows.shape[0]] = rows.max(axis=1)
    del flat, rows
    diff.resize((n,), refcheck=False)
    return diff


def _owned_readonly(a: np.ndarray) -> np.ndarray:
    """Hand a freshly made array to a Trajectory without a copy (it keeps read-only
    arrays that own their memory as they are)."""
    if a.base is not None or not a.flags.c_contiguous:
        a = np.ascontiguousarray(a).copy()
    a.setflags(write=False)
    return a


def _check_held(signal: Any, nodes: np.ndarray, hold: np.ndarray) -> None:
    """Raise if the held part of ``signal`` changes inside an integration interval
    without a declared breakpoint (checked at each interval's midpoint): such an
    input would be integrated wrongly, held at its value at the interval's start."""
    if getattr(type(signal), "hold_values", Signal.hold_values) is Signal.hold_values:
        return
    mid = 0.5 * (nodes[:-1] + nodes[1:])
    changed = np.flatnonzero((signal.hold_values(mid) != hold[:-1]).any(axis=1))
    if changed.size:
        n = int(changed[0])
        raise ValueError(
            f"the held part of `signal` ({type(signal).__name__}) changes inside the "
            f"interval [{nodes[n]:.9g}, {nodes[n + 1]:.9g}] s (its value at {mid[n]:.9g} s "
            "differs from the one at the interval's start) and breakpoints() does not "
            "list that time: the input would be integrated wrongly. Override "
            "breakpoints() to return the times of the jumps."
        )


def _nodes(signal: Any, t: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """Integration nodes: the sample times ``t`` plus every breakpoint of the signal's
    held part strictly inside a sampling interval; and the node index of each sample
    (None when the nodes are the sample times).

    Raises ValueError for a breakpoint outside the grid's span (a signal bug)."""
    get = getattr(signal, "breakpoints", None)
    breaks = np.unique(np.asarray(get(t), dtype=float)) if get is not None else np.empty(0)
    if breaks.size == 0:
        return t, None
    if not np.isfinite(breaks).all() or breaks[0] <= t[0] or breaks[-1] >= t[-1]:
        raise ValueError(
            f"{type(signal).__name__}.breakpoints() must lie strictly inside "
            f"({t[0]:g}, {t[-1]:g}) s, got {breaks[0]:g}..{breaks[-1]:g} s."
        )
    nodes = np.concatenate([t, breaks])
    order = np.argsort(nodes, kind="stable")
    nodes = nodes[order]
    if np.any(np.diff(nodes) <= 0):
        i = int(np.argmax(np.diff(nodes) <= 0))
        raise ValueError(
            f"{type(signal).__name__}.breakpoints() returned {float(nodes[i + 1]):.9g} s, "
            "which is a sample time; breakpoints must lie strictly between sample times."
        )
    sample_node = np.flatnonzero(order < t.shape[0])
    return nodes, sample_node


# The compiled interval integrator under a public name: a sampled loop integrates one
# sampling interval at a time, with the held input computed from the samples before it
# (sampledyn.discretize.run_loop calls it from compiled code).
integrate_intervals = _integrate
