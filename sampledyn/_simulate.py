"""Exact sampled data: compiled adaptive high-order integration between samples.

Each sampling interval ``[t_n, t_{n+1}]`` is integrated on its own with the
Dormand-Prince 8(5,3) pair (Hairer, Norsett & Wanner, *Solving ODEs I*, 2nd ed.,
sec. II.10; the coefficients of Hairer's ``dop853.f``, in :mod:`sampledyn._dop853`), with
error-controlled steps that never cross a sample time, so an input that jumps at a sample
time is never integrated across. Where f is not smooth inside an interval (``|v| v`` or
``n |n|`` crossing zero) a step ends exactly there; where f jumps (``sign``,
``Heaviside``, ``Piecewise`` of a state) the state crosses the switching surface or
slides on it (Filippov). The compiled integrator is :mod:`sampledyn._integrator`; this
module checks the arguments, runs it in chunks and pauses (Ctrl-C and SIGTERM act
between them), and turns its stops into errors.

The samples come with a :class:`~sampledyn.Certificate`: every interval is integrated a
second time, in lockstep, with each accepted step halved, and the difference is the
per-interval flow-error estimate. For a model without jumps on a long run the second
integration runs in a thread beside the first (:class:`_Certifier`), from the end times
of its accepted steps: the same operations, the same numbers, on another core.
"""

from __future__ import annotations

import math
import os
import queue
import threading
import time
import warnings
from typing import Any

import numpy as np

from . import _checks as checks
from . import _integrator as _int
from ._integrator import DEFAULT_MAX_STEPS, integrate_intervals
from ._trajectory import Certificate, SlidingInterval, Trajectory
from .exceptions import ArgumentError, IntegrationError, JumpRefused
from .models import Model
from .models._base import index_switch as _index_switch
from .models._base import readonly
from .signals import Signal

__all__ = [
    "DEFAULT_MAX_STEPS",
    "integrate_intervals",
    "simulate",
    "switching",
]

# Sampling intervals per call of the compiled integrator.
_CHUNK = 1 << 15
# Wall time one call of the compiled integrator may take before it returns to Python
# (where Ctrl-C and SIGTERM take effect), and its first step budget.
_CALL_SECONDS = 0.05
_FIRST_BUDGET = 256
# Sampling intervals from which a certified run of a model without jumps certifies in a
# second thread (:class:`_Certifier`) when this process may use more than one core.
_THREAD_MIN = 2048
# Step ends the main run keeps for that thread between two hand-overs (grown if one
# interval takes more).
_ENDS = 1 << 14


def switching(model: Model) -> tuple[Any, np.ndarray, np.ndarray]:
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

    def __init__(self, model: Model) -> None:
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


# More samples than any machine holds (8 PB of times alone): refused before T / h is
# rounded (which would overflow).
_MAX_SAMPLES = 1e15


def check_period(h: Any, T: Any) -> int:
    """The number of sampling intervals n = T / h of a run, after checking ``h`` (a
    sampling period, at least :data:`sampledyn._checks.MIN_STEP`) and ``T`` (at least h,
    an integer multiple of it, not more samples than any memory holds)."""
    h = checks.period(h)
    checks.check_step(h)
    T = checks.number(T, "T", unit="s")
    if T < h:
        raise ArgumentError(
            "T", f"duration `T` = {T} s must be at least one sampling period h = {h} s."
        )
    if T / h > _MAX_SAMPLES:
        checks.check_memory(math.inf, f"T / h = {T:g} / {h:g} = {T / h:.3g} samples", "the run")
    n = checks.integer_ratio(T, h)
    if n is None:
        raise ArgumentError("T", f"`T` = {T} s must be an integer multiple of `h` = {h} s.")
    return n


def simulate(
    model: Model,
    signal: Any,
    T: float,
    h: float,
    x0: Any = None,
    *,
    rtol: float = 1e-12,
    atol: float = 1e-12,
    certify: bool = True,
    progress: bool = False,
    max_steps: int = DEFAULT_MAX_STEPS,
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
        Attach a :class:`~sampledyn.Certificate` (costs about twice the work; for a
        model without jumps and at least 2048 sampling intervals, on a machine with
        more than one core, the half steps run in a second thread beside the main
        run, with the same numbers: about the wall time of the main run alone).
    progress : bool
        Show a progress bar.
    max_steps : int
        Step attempts (and events) one integration interval may take before the
        integration stops as stalled (default 100,000; a smooth interval takes a few
        to a few hundred).

    Returns
    -------
    Trajectory with ``t`` shape (N,), ``x`` shape (N, nx), ``u`` shape (N, nu);
    ``u`` is the input at the sample times; ``sliding`` the intervals of sliding
    motion on a switching surface (empty without jumps); ``signal`` the input itself
    (so that the rules that need the input between samples find it,
    :attr:`Trajectory.signal`).

    Raises
    ------
    ValueError
        for a signal whose held part changes inside a sampling interval at a time its
        ``breakpoints()`` does not list (found at interval midpoints), naming the
        interval.
    IntegrationError
        if the integrator cannot meet its tolerance, or stalls (more than
        ``max_steps`` in one interval: Zeno behaviour, chattering, an f that jumps
        where the model declares no switching function); the message names the time,
        the state and the switching function last located.
    JumpRefused
        (an IntegrationError) where f jumps and the solution is not unique (both
        sides push the state away from the surface, as x' = sign(x) from x = 0) or
        would slide on the intersection of two surfaces; the message names the
        surface, the time and the state.
    KeyboardInterrupt
        on Ctrl-C (or the caller's SIGTERM handler's exception): the integrator returns
        to Python at least every 0.05 s of work, so either stops it within a second;
        the message says how far it came.

    Notes
    -----
    Inputs between samples are integrated exactly: where the signal's held part jumps
    inside a sampling interval (:meth:`~sampledyn.signals.Signal.breakpoints`, e.g. a
    :class:`~sampledyn.signals.ZeroOrderHold` of commands stamped off the grid), the
    integration stops at the jump and goes on with the new value; the certificate then
    covers the whole sampling interval (its half-step run is not restarted at the
    jump). Memory: about the returned arrays plus one N x nx array of differences
    when certifying.

    Where f jumps across a switching surface (``sign``, ``Heaviside``, ``Piecewise``
    of a state in a :class:`~sampledyn.models.SymbolicModel`, or declared by a
    :class:`~sampledyn.models.FunctionModel`), the integration lands on the surface and
    crosses it with the branch of f of the other side, or slides on it with
    Filippov's convex combination of the two branches until one side's field points
    away (Piiroinen and Kuznetsov's event-driven method, ACM Trans. Math. Softw.
    34(3), 2008; details in :mod:`sampledyn._integrator`). The value the formula gives
    on the surface itself is never integrated.
    """
    n_int = check_period(h, T)
    _check_model(model, signal, h)
    x0 = initial_state(model, x0)
    if not (0 < rtol < 1 and atol > 0):
        raise ValueError(f"need 0 < rtol < 1 and atol > 0, got rtol={rtol}, atol={atol}.")
    checks.count(max_steps, "max_steps")
    checks.check_memory(
        checks.trajectory_bytes(n_int + 1, model.nx, model.nu, certify=certify),
        f"T / h = {T:g} s / {h:g} s = {n_int + 1:.4g} samples",
        "the exact samples",
    )

    # t_n = n h (the same values as h * arange, without the integer temporary)
    t = np.arange(n_int + 1, dtype=float)
    t *= float(h)
    nodes, sample_node = _nodes(signal, t)
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=n_int, desc=f"simulate T={T:g} s h={h:g} s", unit="interval")
    limits = _InputLimits(model)
    run = _Integration(model, rtol, atol, certify, int(max_steps))
    try:
        X, steps, diff = _run(run, signal, nodes, sample_node, x0, bar, limits)
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
        sliding=run.sliding(float(t[-1])),
        signal=signal,
    )


def _check_model(model: Model, signal: Any, h: float) -> None:
    if not hasattr(model, "kernel"):
        raise TypeError(
            "`model` must provide a compiled kernel (a sampledyn model), "
            f"got {type(model).__name__}."
        )
    if not isinstance(signal, Signal) and not hasattr(signal, "nu"):
        raise TypeError(
            f"`signal` must be an input signal (a sampledyn.signals.Signal with "
            f"nu={model.nu} channels), got {type(signal).__name__}."
        )
    if signal.nu != model.nu:
        raise ArgumentError(
            "signal", f"`signal` has nu={signal.nu} channels, the model needs nu={model.nu}."
        )
    signal.check_sampling(float(h))


def initial_state(model: Model, x0: Any) -> np.ndarray:
    """The state a simulation starts from, shape (nx,): ``x0``, or the model's
    ``default_x0`` when None. Raises ArgumentError naming ``x0`` when it is not a
    finite array of that shape."""
    if x0 is None:
        x0 = model.default_x0
    return checks.finite_array(x0, "x0", (model.nx,))


def _jump_kernels(model: Model) -> Any:
    """The model's jump kernels (``model.jump_kernel()``), None for a model without
    jumps: it is simulated with the integrator's smooth specialisation."""
    get = getattr(model, "jump_kernel", None)
    return get() if get is not None else None


def compile_integrator_aside(model: Model) -> None:
    """Start compiling the integrator specialisation ``model`` is simulated with (the
    smooth one unless it has jumps, :func:`_jump_kernels`, as in :class:`_Integration`)
    in a forked process, on a first run after an install
    (:func:`sampledyn._integrator.compile_aside`: Linux, nothing compiled or cached yet;
    call it before this process starts a thread). Its simulations wait for that
    process, then load what it compiled."""
    try:
        smooth = _jump_kernels(model) is None
    except Exception:  # the simulations report it (as the cells' failure), not the plan
        return
    _int.compile_aside(smooth=smooth)


class _Integration:
    """One run of the compiled integrator (:func:`sampledyn._integrator.integrate`):
    the model's kernels and the integrator's state, which persists from call to call,
    so that the integrator can return to Python as often as needed (every
    ``_CALL_SECONDS`` of work, where Ctrl-C and SIGTERM take effect) and go on with the
    same numbers."""

    def __init__(self, model: Model, rtol: float, atol: float, certify: bool, max_steps: int):
        self.model = model
        rhs, p = model.kernel()
        self.sw, sp, input_only = switching(model)
        self.sp = readonly(np.asarray(sp, dtype=float))
        n_sw = int(np.asarray(input_only).shape[0])
        jumps = _jump_kernels(model)
        if jumps is None:
            self.rhs, self.grad = rhs, None  # the integrator's smooth specialisation
            self.q = np.array(p, dtype=float)
            info = np.full((n_sw, 2), -1, dtype=np.int64)
            info[:, 1] = 0
        else:
            self.rhs, self.grad, q, info = jumps
            self.q = np.array(q, dtype=float)
        self.info = np.ascontiguousarray(info, dtype=np.int64)
        self.info.setflags(write=False)
        self.rtol, self.atol, self.certify, self.max_steps = rtol, atol, certify, max_steps
        self.st = np.zeros(_int.STATE_SLOTS + n_sw)
        self.st[_int.S_SLIDE] = -1.0
        self.st[_int.S_ERR_K] = -1.0
        self.W = np.zeros((_int.N_VECTORS, int(model.nx)))
        self.log = np.zeros((64, 3))
        self.budget = _FIRST_BUDGET

    def chunk(
        self, t: np.ndarray, spec: Any, X: np.ndarray, steps: np.ndarray, diff: np.ndarray,
        restart: np.ndarray, beside: _Certifier | None = None,
    ) -> None:  # fmt: skip
        """Integrate the intervals of nodes ``t`` (X[0] the start state), pausing
        every ``_CALL_SECONDS``; raise on a failure. With ``beside``, the certifying
        run is that thread's (this run keeps its step ends and hands it the intervals
        done after every call); ``diff`` is then scratch."""
        st = self.st
        st[_int.S_N] = 0.0
        st[_int.S_PHASE] = 0.0
        st[_int.S_NEND] = 0.0
        args = (
            readonly(t), readonly(spec.hold), readonly(spec.offset), readonly(spec.amp),
            readonly(spec.freq_hz), readonly(spec.phase_rad),
        )  # fmt: skip
        certify = bool(self.certify) and beside is None
        handed = 0  # intervals of this chunk handed to `beside`
        while True:
            start = time.perf_counter()
            ends = beside.ends if beside is not None else _NO_ENDS
            status = _int.integrator(self.grad is None)(
                self.rhs, self.grad, self.q, *args, float(self.rtol), float(self.atol),
                certify, t.shape[0] - 1, self.sw, self.sp, self.info, X, steps, diff,
                restart, st, self.W, self.log, self.budget, self.max_steps, ends,
            )  # fmt: skip
            if beside is not None:
                handed = beside.hand_over(self, args, X, steps, handed)
            if status == _int.ENDS_FULL:
                if beside is not None and st[_int.S_NEND] >= beside.ends.shape[0]:
                    beside.grow()  # one interval took more steps than it holds
            elif status == _int.PAUSED:
                # as many attempts as fit in _CALL_SECONDS at the rate just measured
                rate = self.budget / max(time.perf_counter() - start, 1e-6)
                self.budget = int(min(max(rate * _CALL_SECONDS, 16), 1 << 24))
            elif status == _int.LOG_FULL:
                self.log = np.concatenate([self.log, np.zeros_like(self.log)])
            elif status == _int.OK:
                return
            else:
                raise self.failure(status, t, X)

    def sliding(self, t_end: float) -> tuple[SlidingInterval, ...]:
        """The sliding intervals of the log (one still open at the end ends there)."""
        names = _switch_names(self.model, self.info.shape[0])
        out = []
        open_at: dict[int, float] = {}
        for t, k, what in self.log[: int(self.st[_int.S_NLOG])]:
            if what > 0:
                open_at[int(k)] = float(t)
            else:
                out.append(SlidingInterval(names[int(k)], open_at.pop(int(k)), float(t)))
        out += [SlidingInterval(names[k], t0, t_end) for k, t0 in open_at.items()]
        return tuple(sorted(out, key=lambda s: s.start))

    def failure(self, status: int, t: np.ndarray, X: np.ndarray) -> IntegrationError:
        """The error of a failed call, naming the time, state and switching function."""
        st = self.st
        model = self.model
        n = int(st[_int.S_N])
        t_err = float(st[_int.S_TC] if status != _int.NONFINITE else t[n])
        at = f"at t = {t_err:.10g} s"
        k = int(st[_int.S_ERR_K])
        names = _switch_names(model, self.info.shape[0])
        where = f"g = {names[k]}" if 0 <= k < len(names) else "none located"
        state = _state_text(model, self.W[0] if status != _int.NONFINITE else X[n])
        interval = f"the interval [{t[n]:.10g}, {t[n + 1]:.10g}] s"
        if status == _int.REPELLING:
            return JumpRefused(
                f"{at}, {state} is on the switching surface {names[k]} = 0 and f points away "
                f"from it on both sides (rate of {names[k]}: {st[_int.S_ERR_A]:.6g} on its "
                f"negative side, {st[_int.S_ERR_B]:.6g} on its positive side): the solution "
                "is not unique there (x' = sign(x) from x = 0 is the smallest example). "
                "Start off the surface, or change the model so that it decides."
            )
        if status == _int.INTERSECTION:
            other = names[int(st[_int.S_ERR_A])]
            return JumpRefused(
                f"{at}, {state} slides on the switching surface {other} = 0 and reaches "
                f"{names[k]} = 0, which both sliding fields push it onto: sliding on the "
                "intersection of two surfaces is not supported (Filippov's combination of "
                "four branches is not unique there)."
            )
        if status == _int.STALL:
            return IntegrationError(
                f"the integration stalled in {interval}: {self.max_steps} steps "
                f"(`max_steps`) without reaching its end, {at}, {state}; switching function "
                f"last located: {where}. Zeno behaviour or chattering there, or an f that "
                "jumps where the model declares no switching function (a FunctionModel "
                "declares them with `switching=` and `jumps=`); raise `max_steps` if the "
                "interval needs more steps."
            )
        what = "step size underflow" if status == _int.UNDERFLOW else "NaN or inf in the state"
        return IntegrationError(
            f"{what} in {interval}, {at}, {state} (switching function last located: "
            f"{where}); the model may diverge there, jump where it declares no switching "
            "function, or the tolerance may be too tight."
        )


_NO_ENDS = np.empty(0)


class _Certifier:
    """The certifying run of a model without jumps in a thread beside the main run
    (:func:`sampledyn._integrator.certify_steps`, the same numbers as the lockstep run):
    the main run keeps the end time of every accepted step (``ends``) and, after each
    call, hands over the intervals it has finished; this thread runs their half steps
    meanwhile (both calls release the GIL), on the core the main run leaves idle.
    ``diff`` is the per-interval differences the thread writes, rows of the whole run."""

    def __init__(self, run: _Integration, diff: np.ndarray) -> None:
        self.kernel = _int.certifier()
        self.rhs, self.q = run.rhs, run.q
        self.diff = diff
        self.ends = np.empty(_ENDS)
        self.offset = 0  # first interval of the current chunk, in the whole run
        self._work: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self._error: BaseException | None = None
        self._stop = False
        self._thread = threading.Thread(target=self._run, name="sampledyn-certify", daemon=True)
        self._thread.start()

    def hand_over(
        self, run: _Integration, args: tuple, X: np.ndarray, steps: np.ndarray, handed: int
    ) -> int:
        """Queue the chunk's intervals finished since ``handed`` (their step ends are
        the first entries of ``ends``; those of an unfinished interval move to the
        front); returns the intervals handed over now in all."""
        st = run.st
        done = int(st[_int.S_N])
        if done > handed:
            n = int(steps[handed:done].sum())
            kept = int(st[_int.S_NEND])
            t, hold, offset, amp, freq, phase = args
            a, b = handed, done
            self._work.put((
                t[a : b + 1], hold[a : b + 1], offset, amp, freq, phase, readonly(X[a : b + 1]),
                _frozen(steps[a:b]), readonly(self.ends[:n].copy()),
                self.diff[self.offset + a : self.offset + b],
            ))  # fmt: skip
            self.ends[: kept - n] = self.ends[n:kept]
            st[_int.S_NEND] = float(kept - n)
        return max(done, handed)

    def grow(self) -> None:
        self.ends = np.concatenate([self.ends, np.empty_like(self.ends)])

    def _run(self) -> None:
        while True:
            item = self._work.get()
            if item is None:
                return
            if self._stop or self._error is not None:
                continue
            try:
                self.kernel(self.rhs, self.q, *item)
            except BaseException as exc:  # pragma: no cover - raised in the caller
                self._error = exc

    def finish(self) -> None:
        """Wait for the queued intervals; raise what the thread raised."""
        self._work.put(None)
        self._thread.join()
        if self._error is not None:
            raise self._error

    def abandon(self) -> None:
        """Stop after the interval in hand (the run failed or was interrupted)."""
        self._stop = True
        self._work.put(None)
        self._thread.join()


def _frozen(a: np.ndarray) -> np.ndarray:
    """A read-only view of ``a``, its dtype kept."""
    v = a.view()
    v.setflags(write=False)
    return v


def _cores() -> int:
    get = getattr(os, "sched_getaffinity", None)
    return len(get(0)) if get is not None else (os.cpu_count() or 1)


def _switch_names(model: Model, n_sw: int) -> tuple[str, ...]:
    """Names of the switching values, for messages."""
    get = getattr(model, "switching_names", None)
    if get is not None:
        names = tuple(get())
        if len(names) == n_sw:
            return names
    states = [model.state_names[int(i)] for i in getattr(model, "kink_states", ())]
    inputs = [model.input_names[int(j)] for j in getattr(model, "kink_inputs", ())]
    names = tuple(states + inputs)
    return names if len(names) == n_sw else tuple(f"g[{k}]" for k in range(n_sw))


def _state_text(model: Model, x: np.ndarray) -> str:
    pairs = ", ".join(f"{n} = {v:.10g}" for n, v in zip(model.state_names, x, strict=True))
    return f"the state ({pairs})"


def _run(
    run: _Integration,
    signal: Any,
    nodes: np.ndarray,
    sample_node: np.ndarray | None,
    x0: np.ndarray,
    bar: Any,
    limits: _InputLimits,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Integrate over ``nodes`` in chunks of sampling intervals.

    Returns the samples X (N, nx), the internal steps per sampling interval (N - 1,)
    and, when certifying, the per-interval differences of the half-step run (N - 1, nx).
    The held input is built per chunk, so memory stays near the size of the result;
    the integrator's state (step proposal, sides of the jumps) carries over from chunk
    to chunk, so the numbers do not depend on the chunking.
    """
    nx = int(run.model.nx)
    n_int = nodes.shape[0] - 1 if sample_node is None else sample_node.shape[0] - 1
    X = np.empty((nodes.shape[0], nx))
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
    diff = np.empty((n_int, nx)) if run.certify else None
    scratch = np.empty((0, nx))
    beside = None
    if diff is not None and run.grad is None and sample_node is None and n_int >= _THREAD_MIN:
        if _cores() > 1:
            beside = _Certifier(run, diff)
    # the first step proposal: h
    run.st[_int.S_DT] = float(nodes[1 if sample_node is None else sample_node[1]] - nodes[0])
    try:
        for k0 in range(0, n_int, _CHUNK):
            k1 = min(k0 + _CHUNK, n_int)
            a, b = (k0, k1) if sample_node is None else (int(sample_node[k0]), int(sample_node[k1]))
            spec = signal.spec(nodes[a : b + 1])
            _check_held(signal, nodes[a : b + 1], spec.hold)
            limits.add(spec, nodes[a : b + 1])
            if diff is not None and sample_node is None and beside is None:
                d_out = diff[k0:k1]
            else:
                if scratch.shape[0] < b - a:
                    scratch = np.empty((b - a, nx))
                d_out = scratch[: b - a]
            if beside is not None:
                beside.offset = k0
            try:
                run.chunk(
                    nodes[a : b + 1], spec, X[a : b + 1], steps[a:b], d_out, restart[a : b + 1],
                    beside,
                )  # fmt: skip
            except KeyboardInterrupt:
                st = run.st
                t_at = float(st[_int.S_TC] if st[_int.S_PHASE] else nodes[a + int(st[_int.S_N])])
                raise KeyboardInterrupt(
                    f"simulate interrupted at t = {t_at:.6g} s of {float(nodes[-1]):g} s"
                ) from None
            if diff is not None and sample_node is not None:
                # the difference over a sampling interval is the one at its last node
                diff[k0:k1] = d_out[sample_node[k0 + 1 : k1 + 1] - a - 1]
            if bar is not None:
                bar.update(k1 - k0)
    except BaseException:
        if beside is not None:
            beside.abandon()
        raise
    if beside is not None:
        beside.finish()
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
