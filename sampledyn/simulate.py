"""Exact sampled data: compiled adaptive high-order integration between samples.

Each sampling interval ``[t_n, t_{n+1}]`` is integrated on its own with the
Dormand-Prince 8(5,3) pair (Hairer, Norsett & Wanner, *Solving ODEs I*, 2nd ed.,
sec. II.10; the coefficients are read from SciPy's ``DOP853``), with error-controlled
steps that never cross a sample time, so an input that jumps at a sample time is never
integrated across. Where f is not smooth inside an interval (``|v| v`` or ``n |n|``
crossing zero) the error control shrinks the step there instead of every step.

The samples come with a :class:`~sampledyn.Certificate`: every interval is integrated a
second time, in lockstep, with each accepted step halved, and the difference is the
per-interval flow-error estimate.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit, types
from scipy.integrate._ivp import dop853_coefficients as _dop

from ._trajectory import Certificate, Trajectory
from .models import RHS_SIG, RHS_TYPE, RO1, RO2, readonly

__all__ = ["IntegrationError", "simulate"]

_NS = _dop.N_STAGES
_A = np.ascontiguousarray(_dop.A[:_NS, :_NS])
_B = np.ascontiguousarray(_dop.B)
_C = np.ascontiguousarray(_dop.C[:_NS])
_E3 = np.ascontiguousarray(_dop.E3)
_E5 = np.ascontiguousarray(_dop.E5)


class IntegrationError(RuntimeError):
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


@njit(RHS_SIG, cache=True)
def _index_switch(t, x, u, sp, out):  # pragma: no cover - compiled
    """Switching values picked from the state and input: sp = [ns, i..., nu, j...]."""
    ns = int(sp[0])
    for k in range(ns):
        out[k] = x[int(sp[1 + k])]
    nu = int(sp[1 + ns])
    for k in range(nu):
        out[ns + k] = u[int(sp[2 + ns + k])]


@njit(cache=True)
def _crossing_root(
    sw, sp, tc, y, ynew, k0, k1, dt, hold_row, offset, amp, freq, phase, u, ytry, g, idx, ga, gb
):  # pragma: no cover - compiled
    """Time c in (0, dt) where switching value ``idx`` crosses zero.

    The state inside the step is the cubic Hermite interpolant of (y, k0) and
    (ynew, k1), accurate to O(dt^4): the kink is then placed to about 1e-8 s, and the
    error of a misplaced kink grows like the cube of that offset. Illinois method.
    """
    nx = y.shape[0]
    a, fa, b, fb = 0.0, ga, dt, gb
    c = dt
    side = 0
    for _ in range(60):
        c = (fa * b - fb * a) / (fa - fb)
        th = c / dt
        h00 = (1.0 + 2.0 * th) * (1.0 - th) ** 2
        h10 = th * (1.0 - th) ** 2
        h01 = th * th * (3.0 - 2.0 * th)
        h11 = th * th * (th - 1.0)
        for j in range(nx):
            ytry[j] = h00 * y[j] + h10 * dt * k0[j] + h01 * ynew[j] + h11 * dt * k1[j]
        _input_at(hold_row, offset, amp, freq, phase, tc + c, u)
        sw(tc + c, ytry, u, sp, g)
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
    types.int64, _F, RHS_TYPE, RO1, _B1, _A2, types.int64[::1], _A2,
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
):  # pragma: no cover - compiled
    """Integrate intervals n_start..n_stop-1; X[n_start] must hold the start state.

    Steps end exactly where a switching value ``sw(t, x, u, sp)`` crosses zero
    crosses zero, so no step straddles a point where f is not smooth (|v| v, n |n|).

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
    dt = dt_init
    for n in range(n_start, n_stop):
        ta = t[n]
        tb = t[n + 1]
        hold_row = hold[n]
        for j in range(nx):
            y[j] = X[n, j]
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
                    for k in range(n_sw):
                        if ga[k] * gb[k] < 0.0 and abs(ga[k]) > 1e-13 * abs(gb[k]):
                            r = _crossing_root(
                                sw, sp, tc, y, ynew, k0, K[_NS], dt, hold_row, offset, amp,
                                freq, phase, u, ytry, gr, k, ga[k], gb[k],
                            )  # fmt: skip
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
        Show a progress bar (the integration runs in 50 chunks).

    Returns
    -------
    Trajectory with ``t`` shape (N,), ``x`` shape (N, nx), ``u`` shape (N, nu).
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

    t = float(h) * np.arange(n_int + 1)
    spec = signal.spec(t)
    rhs, p = model.kernel()
    sw, sp, sw_input_only = switching(model)
    X = np.empty((n_int + 1, model.nx))
    X[0] = x0
    steps = np.zeros(n_int, dtype=np.int64)
    diff = np.zeros((n_int, model.nx))
    chunks = np.linspace(0, n_int, 51 if progress else 2).round().astype(int)
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=n_int, desc=f"simulate T={T:g} s h={h:g} s", unit="interval")
    dt = float(h)
    try:
        for a, b in zip(chunks[:-1], chunks[1:], strict=True):
            status, dt = _integrate(
                rhs,
                readonly(p),
                readonly(t),
                readonly(x0),
                readonly(spec.hold),
                readonly(spec.offset),
                readonly(spec.amp),
                readonly(spec.freq_hz),
                readonly(spec.phase_rad),
                float(rtol),
                float(atol),
                bool(certify),
                int(a),
                int(b),
                dt,
                sw,
                readonly(sp),
                _readonly_bool(sw_input_only),
                X,
                steps,
                diff,
            )
            if status != 0:
                bad = int(np.argmax(steps[a:b] == 0)) + int(a)
                what = "step size underflow" if status == 1 else "NaN or inf in the state"
                raise IntegrationError(
                    f"{what} in the interval starting at t={t[bad]:g} s; the model may "
                    "diverge there or the tolerance may be too tight."
                )
            if bar is not None:
                bar.update(int(b - a))
    finally:
        if bar is not None:
            bar.close()

    certificate = None
    if certify:
        scale = np.maximum(1.0, np.abs(X).max(axis=0))
        certificate = Certificate(
            per_interval=(np.abs(diff) / scale).max(axis=1), scale=scale, steps=steps, rtol=rtol
        )
    return Trajectory(
        t=t,
        x=X,
        u=signal(t),
        h=float(h),
        state_names=model.state_names,
        state_units=model.state_units,
        input_names=model.input_names,
        input_units=model.input_units,
        certificate=certificate,
    )
