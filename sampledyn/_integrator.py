"""The compiled integrator of exact samples: Dormand-Prince 8(5,3) steps between
switching surfaces, the branches of f on each side of a jump, Filippov sliding.

Each integration interval is integrated with the error-controlled steps of DOP853
(coefficients in :mod:`sampledyn._dop853`). A step never straddles a zero of a
switching value ``g(t, x, u)``: it is cut to end on the first one, located on the
step's cubic Hermite interpolant (Illinois method). Two kinds of switching value:

* a **kink** (``|v| v``, ``n |n|``, ``Max``/``Min``): f is continuous, only its
  derivatives jump; landing on the zero keeps every step smooth and nothing else
  happens there;
* a **jump** (``sign``, ``Heaviside``, ``Piecewise`` of a state): f itself jumps. The
  model gives one smooth branch of f per side (the *branch kernel*, which reads the
  side s_j = -1 or +1 of jump j from its parameter array ``q``, entry
  ``sw_info[k, 0]``) and the gradient of every switching value (``grad``, rows
  ``(dg/dx, dg/dt, dg/du)``). A step is integrated with the branches of the current
  sides only (their smooth extensions), so the formula's value on the surface itself
  is never used. At a zero the normal speeds of both sides,
  ``sigma_-+ = dg/dx f_-+ + dg/dt + dg/du u'``, decide, as in the event-driven method
  of Piiroinen and Kuznetsov (ACM Trans. Math. Softw. 34(3), article 13, 2008):

  - both > 0 (or both < 0): a **crossing**, the integration goes on with the branch
    of the side the state enters;
  - sigma_- > 0 > sigma_+ (both sides push the state onto the surface): **sliding**
    with Filippov's convex combination (Utkin's equivalent dynamics)
    ``f_s = (1 - a) f_- + a f_+``, ``a = sigma_- / (sigma_- - sigma_+)``, which keeps
    ``dg/dt = 0``; the sliding ends where sigma_- or sigma_+ reaches zero (two more
    event functions, located like the switching values), and the state leaves on
    that side. After each accepted sliding step the state is put back on the surface
    by one Newton step along dg/dx (exact for a surface linear in x);
  - sigma_- < 0 < sigma_+ (both sides push it away): the solution is not unique,
    the integrator stops (status :data:`REPELLING`);
  - a second surface reached while sliding: crossed if both sliding fields cross it,
    else the integrator stops (status :data:`INTERSECTION`: sliding on the
    intersection of two surfaces is not solved).

The certifying run (every accepted step again as two half steps, in lockstep) uses
the same field as the main run on each step (the same branch, or the same sliding
field), so the certificate covers the steps on both sides of a jump and the sliding
segments.

Every computation is bounded and can be stopped: the integrator returns
:data:`PAUSED` after ``budget`` step attempts with its whole state in the arrays it
was given (``st``, ``W``, ``q``), so that the caller returns to Python (where Ctrl-C
and SIGTERM take effect) and calls it again to go on, with the same numbers as
without the pause; and it stops with :data:`STALL` when one interval takes more than
``max_steps`` attempts and events (Zeno behaviour, chattering, an f that jumps where
no switching value says so).
"""

from __future__ import annotations

import math
import os
import sys
import threading
import warnings
from typing import Any

import numpy as np
from numba import njit, types
from numba.core import cgutils
from numba.core.errors import NumbaExperimentalFeatureWarning
from numba.extending import intrinsic

from . import _dop853 as _dop
from .models._base import JAC_TYPE, RHS_TYPE, RO1, RO2
from .models._jumps import decide, sliding_weight

__all__ = [
    "DEFAULT_MAX_STEPS",
    "INTERSECTION",
    "ENDS_FULL",
    "LOG_FULL",
    "NONFINITE",
    "N_VECTORS",
    "OK",
    "PAUSED",
    "REPELLING",
    "STALL",
    "STATE_SLOTS",
    "UNDERFLOW",
    "certify_steps",
    "certifier",
    "integrate",
    "integrate_intervals",
]

_NS = _dop.N_STAGES
_A = np.ascontiguousarray(_dop.A)
_B = np.ascontiguousarray(_dop.B)
_C = np.ascontiguousarray(_dop.C)
_E3 = np.ascontiguousarray(_dop.E3)
_E5 = np.ascontiguousarray(_dop.E5)

# Status of a call (3 is the sampled loop's "envelope left", sampledyn.discretize).
OK = 0
UNDERFLOW = 1
NONFINITE = 2
STALL = 4
REPELLING = 5
INTERSECTION = 6
PAUSED = 7
LOG_FULL = 8
ENDS_FULL = 9  # the step ends' array is full (a main run certified elsewhere)

# Slots of the state array ``st`` (from _S_G on: the switching values at the end of
# the last interval).
S_N = 0  # the interval being integrated (index into the call's nodes)
S_PHASE = 1  # 0: at its start, 1: inside it
S_TC = 2  # time reached
S_DT = 3  # the step the error control proposes
S_REJ = 4  # 1 after a rejected step
S_COUNT = 5  # accepted steps in the interval
S_WORK = 6  # step attempts and events in the interval (the stall budget)
S_SLIDE = 7  # switching value the state slides on, -1 if none
S_READY = 8  # 1 once the sides of the jumps are set
S_NLOG = 9  # entries written to the sliding log
S_ERR_T = 10  # time of a refusal or stall
S_ERR_K = 11  # switching value of a refusal, or the last event located (-1: none)
S_ERR_A = 12  # normal speeds of a refusal (sigma_-, sigma_+), or the surface slid on
S_ERR_B = 13
S_FRESH = 14  # switching value decided at time S_TC (its next step trusts the decision)
S_NEND = 15  # entries written to ``ends`` (the end times of the accepted steps)
_S_G = 16
STATE_SLOTS = _S_G

# Step attempts and events one interval may take before the integrator stops with
# STALL (a smooth interval takes a few to a few hundred).
DEFAULT_MAX_STEPS = 100_000

# Rows of the vector workspace V (nx columns); Y, YF and K0 persist between calls.
Y, YF, YTMP, YNEW, YTRY, YFM, YFN = range(7)
F0 = 7  # 4 rows: the two branches, the two sliding fields of a decision
K_ = 11  # 13 rows: the stages of the step (K[12]: f at its end)
K0 = K_  # the first stage, f at the step's start
KF = 24  # 13 rows: the stages of the certifying half steps
N_VECTORS = 37
# Rows of the event workspace E (n_sw + 2 columns): values at the step's start, its
# end, the rootfinder's and the probe's points.
GA, GB, GR, GP = range(4)
# Rows of the input workspace U (nu columns): the input, its rate, the held part of
# the interval, the offset. S: the sinusoids' amplitudes, frequencies, phases.
U_, DU, HOLD, OFFSET = range(4)


@intrinsic
def _borrow_intrinsic(typingctx, arr):  # pragma: no cover - compiled
    """The array ``arr`` without its reference count (no memory owner): numba takes
    and drops a reference to every array at each function entry and exit and at every
    view, atomic operations that cost more than a step of a small model; the
    integrator's arrays are owned by :func:`integrate` (or its caller) for the whole
    call, so the helpers it calls work on borrowed ones, whose counting is a test
    for null. numba frees a local array after its last use by name, which its
    borrowed copy is not: a function that borrows an array it made uses it again
    after the borrowed copy's last use (:func:`_keep`)."""
    if not isinstance(arr, types.Array):
        return None

    def codegen(context, builder, sig, args):
        src = context.make_array(arr)(context, builder, value=args[0])
        out = context.make_array(arr)(context, builder)
        for name in ("nitems", "itemsize", "data", "shape", "strides"):
            setattr(out, name, getattr(src, name))
        out.meminfo = cgutils.get_null_value(out.meminfo.type)
        out.parent = cgutils.get_null_value(out.parent.type)
        return out._getvalue()

    return arr(arr), codegen


_borrow: Any = _borrow_intrinsic  # called as _borrow(arr) in compiled code

# The integrator's helpers: compiled only into the integrator (their code is linked
# into its two dispatchers and cached with them), so without the Python and C entry
# points a dispatcher has, and none inlined by numba: numba's own inlining copies and
# types the callee's IR once per call site (it doubled the compile time of the smooth
# specialisation, for the same speed; LLVM inlines the calls anyway).
_njit: Any = njit  # (numba's type stubs do not list the entry-point options)
_helper = _njit(no_cpython_wrapper=True, no_cfunc_wrapper=True)


@_helper
def _input_at(U, S, t):  # pragma: no cover - compiled
    """u(t) into U[U_]: the interval's held part, the offset and the sinusoids."""
    for j in range(U.shape[1]):
        v = U[HOLD, j] + U[OFFSET, j]
        for k in range(S.shape[2]):
            v += S[0, j, k] * math.sin(2.0 * math.pi * S[1, j, k] * t + S[2, j, k])
        U[U_, j] = v


@_helper
def _input_rate(U, S, t):  # pragma: no cover - compiled
    """du/dt into U[DU] (the held part is constant inside an interval)."""
    for j in range(U.shape[1]):
        v = 0.0
        for k in range(S.shape[2]):
            w = 2.0 * math.pi * S[1, j, k]
            v += S[0, j, k] * w * math.cos(w * t + S[2, j, k])
        U[DU, j] = v


# ----------------------------------------------------------------- the two fields
@_helper
def _normal_speeds(rhs, grad, q, pos, k, t, y, U, V, G):  # pragma: no cover - compiled
    """Branches of f on both sides of jump surface k (V[F0]: side -1, V[F0 + 1]: +1)
    at (t, y), and their normal speeds dg_k/dt along each (U holds u and du/dt)."""
    u = U[U_]
    q[pos] = -1.0
    rhs(t, y, u, q, V[F0])
    q[pos] = 1.0
    rhs(t, y, u, q, V[F0 + 1])
    grad(t, y, u, q, G)
    return _speeds(G, k, U, V, F0)


@njit(inline="always")
def _speeds(G, k, U, V, row):  # pragma: no cover - compiled
    """dg_k/dt along the fields V[row] and V[row + 1] (G: the gradients at the point,
    U[DU]: du/dt)."""
    nx = V.shape[1]
    c = G[k, nx]
    for j in range(U.shape[1]):
        c += G[k, nx + 1 + j] * U[DU, j]
    s_lo = c
    s_hi = c
    for i in range(nx):
        s_lo += G[k, i] * V[row, i]
        s_hi += G[k, i] * V[row + 1, i]
    return s_lo, s_hi


@_helper
def _filippov(rhs, grad, q, pos, k, t, y, U, V, G, out):  # pragma: no cover - compiled
    """Filippov's sliding vector on surface k: the convex combination of the two
    branches whose normal speed is zero (Utkin's equivalent dynamics)."""
    s_lo, s_hi = _normal_speeds(rhs, grad, q, pos, k, t, y, U, V, G)
    a = sliding_weight(s_lo, s_hi)
    for i in range(y.shape[0]):
        out[i] = V[F0, i] + a * (V[F0 + 1, i] - V[F0, i])


@_helper
def _sliding_field(rhs, grad, q, mode, S, U, V, G, t, y, out):  # pragma: no cover - compiled
    """Filippov's sliding vector on surface ``mode[0]`` at (t, y), u in U[U_]."""
    _input_rate(U, S, t)
    _filippov(rhs, grad, q, mode[1], mode[0], t, y, U, V, G, out)


@_helper
def _field(rhs, grad, q, mode, S, U, V, G, t, y, out):  # pragma: no cover - compiled
    """f of the current mode at (t, y), u in U[U_]: the branch of the sides in ``q``,
    or, while sliding on surface ``mode[0]``, Filippov's sliding vector. (The steps
    test the mode themselves and call ``rhs`` directly: a call that passes this many
    arrays costs their reference counts, which would double the cost of a step.)"""
    if grad is None or mode[0] < 0:
        rhs(t, y, U[U_], q, out)
    else:
        _sliding_field(rhs, grad, q, mode, S, U, V, G, t, y, out)


@_helper
def _dop_stages(rhs, grad, q, mode, S, U, V, G, t, y, dt, K, ynew, ytmp, u):  # pragma: no cover
    """Stages 1..11 given K[0] already; writes y_new. (ytmp, u: the rows V[YTMP] and
    U[U_], made once by the caller: a view made here would cost its reference count
    on every step.)"""
    nx = y.shape[0]
    smooth = mode[0] < 0
    for s in range(1, _NS):
        for j in range(nx):
            acc = 0.0
            for m in range(s):
                acc += _A[s, m] * K[m, j]
            ytmp[j] = y[j] + dt * acc
        ts = t + _C[s] * dt
        _input_at(U, S, ts)
        if grad is None or smooth:
            rhs(ts, ytmp, u, q, K[s])
        else:
            _sliding_field(rhs, grad, q, mode, S, U, V, G, ts, ytmp, K[s])
    for j in range(nx):
        acc = 0.0
        for m in range(_NS):
            acc += _B[m] * K[m, j]
        ynew[j] = y[j] + dt * acc


# ------------------------------------------------------------------- event values
@_helper
def _events(sw, sp, rhs, grad, q, mode, U, V, G, S, t, y, g):  # pragma: no cover
    """The switching values at (t, y) (u in U[U_]) and, while sliding, the two normal
    speeds (g[n_sw], g[n_sw + 1]) whose zeros end the sliding."""
    sw(t, y, U[U_], sp, g)
    if grad is not None and mode[0] >= 0:
        _input_rate(U, S, t)
        s_lo, s_hi = _normal_speeds(rhs, grad, q, mode[1], mode[0], t, y, U, V, G)
        n = g.shape[0] - 2
        g[n] = s_lo
        g[n + 1] = s_hi


@_helper
def _switch_inside(sw, sp, rhs, grad, q, mode, S, U, V, G, tc, dt, c, g):  # pragma: no cover
    """The event values at tc + c, c in [0, dt], written to ``g``.

    The state inside the step is the cubic Hermite interpolant of (y, k0) and
    (ynew, k1) (V[Y], V[K0], V[YNEW], K[12]), accurate to O(dt^4).
    """
    th = c / dt
    h00 = (1.0 + 2.0 * th) * (1.0 - th) ** 2
    h10 = th * (1.0 - th) ** 2
    h01 = th * th * (3.0 - 2.0 * th)
    h11 = th * th * (th - 1.0)
    ytry = V[YTRY]
    for j in range(ytry.shape[0]):
        ytry[j] = h00 * V[Y, j] + h10 * dt * V[K0, j] + h01 * V[YNEW, j] + h11 * dt * V[K_ + _NS, j]
    _input_at(U, S, tc + c)
    _events(sw, sp, rhs, grad, q, mode, U, V, G, S, tc + c, ytry, g)


@njit(inline="always")
def _illinois(x, fx, low, a, fa, b, fb, last):  # pragma: no cover - compiled
    """One Illinois step (the secant method's modification of Dowell and Jarratt, BIT
    11, 1971): the bracket [a, b] of a sign change (values fa, fb) after the point x
    (value fx) replaces its end a (``low``) or b, the other end's value halved when
    the same end was replaced the step before (``last``: 1 a, -1 b, 0 none).
    Returns ``(a, fa, b, fb, last)``. Both root finders of the integrator step so:
    an event on the step's interpolant (:func:`_crossing_root`) and a jump on the
    step length (:func:`_secant`)."""
    if low:
        a, fa = x, fx
        if last == 1:
            fb *= 0.5
        last = 1
    else:
        b, fb = x, fx
        if last == -1:
            fa *= 0.5
        last = -1
    return a, fa, b, fb, last


@_helper
def _crossing_root(
    sw, sp, rhs, grad, q, mode, S, U, V, G, E, tc, dt, idx, a, fa, fb
):  # pragma: no cover - compiled
    """Time c in (a, dt) where event value ``idx`` crosses zero, given its values
    ``fa`` at tc + a and ``fb`` at tc + dt (of opposite signs).

    The values inside the step are taken on the step's Hermite interpolant
    (:func:`_switch_inside`): the zero is then placed to about 1e-8 s, and the error
    of a misplaced kink grows like the cube of that offset. Illinois method.
    """
    b = dt
    c = dt
    side = 0
    for _ in range(60):
        c = (fa * b - fb * a) / (fa - fb)
        _switch_inside(sw, sp, rhs, grad, q, mode, S, U, V, G, tc, dt, c, E[GR])
        fc = E[GR, idx]
        if fc * fb > 0.0:
            low = False
        elif fa * fc > 0.0:
            low = True
        else:
            break
        a, fa, b, fb, side = _illinois(c, fc, low, a, fa, b, fb, side)
        if b - a <= 1e-13 * dt:
            break
    return c


@_helper
def _side_event(
    sw, sp, rhs, grad, q, mode, S, U, V, G, E, tc, dt, k, s, fresh, probed, tau
):  # pragma: no cover - compiled
    """Event value k, which must keep the sign s over the step (the side of a jump
    surface, or a sliding speed): ``(tau, found, start, probed)`` with ``found`` = k
    if it leaves that sign before ``tau`` (then at the new ``tau``), ``start`` = k
    if it does so at the step's start (the state is on the surface already)."""
    if E[GB, k] * s >= 0.0:
        return tau, -1, -1, probed
    a, fa = 0.0, E[GA, k]
    if fa * s <= 0.0:
        if k == fresh:
            # Decided here a moment ago; the step leaves the surface on the side
            # chosen (within the rounding of the switching value).
            return tau, -1, -1, probed
        a = 1e-6 * dt
        if not probed:
            _switch_inside(sw, sp, rhs, grad, q, mode, S, U, V, G, tc, dt, a, E[GP])
            probed = True
        fa = E[GP, k]
        if fa * s <= 0.0:
            return tau, -1, k, probed
    r = _crossing_root(sw, sp, rhs, grad, q, mode, S, U, V, G, E, tc, dt, k, a, fa, E[GB, k])
    if r <= 1e-6 * dt:
        return tau, -1, k, probed
    if r < tau:
        return r, k, -1, probed
    return tau, -1, -1, probed


@_helper
def _first_event(
    sw, sp, rhs, grad, q, mode, sw_info, S, U, V, G, E, tc, dt, fresh
):  # pragma: no cover - compiled
    """The first event inside the step ``(tau, found, start)``: the step should end at
    ``tau`` on event value ``found`` (-1: none), or event value ``start`` happens at
    its start (-1: none).

    Kinks: a value that is zero (or negligible) at the step's start takes its sign
    from just inside the step (1e-6 dt), the shortest step a kink may cut, so a state
    starting at rest on a kink is tested like any other; a zero at the very start
    (the previous step ended on this kink) does not hide a later one. Jumps and
    sliding speeds: :func:`_side_event`.
    """
    n_sw = sw_info.shape[0]
    tau = dt
    found = -1
    probed = False
    # (without a gradient kernel there is no jump and no sliding speed: kinks only)
    for k in range(n_sw if grad is None else n_sw + 2):
        if grad is not None and (k >= n_sw or sw_info[k, 0] >= 0):
            if k == mode[0] or (k >= n_sw and mode[0] < 0):
                continue  # the surface slid on; no sliding speeds without sliding
            # sigma_- > 0 and sigma_+ < 0 while sliding; a zero of either ends it
            s = q[sw_info[k, 0]] if k < n_sw else 3.0 - 2.0 * (k - n_sw + 1)
            tau, hit, start, probed = _side_event(
                sw, sp, rhs, grad, q, mode, S, U, V, G, E, tc, dt, k, s, fresh, probed, tau
            )
            if start >= 0:
                return tau, found, start
            found = hit if hit >= 0 else found
            continue
        a, fa = 0.0, E[GA, k]
        if abs(fa) <= 1e-13 * abs(E[GB, k]):
            a = 1e-6 * dt
            if not probed:
                _switch_inside(sw, sp, rhs, grad, q, mode, S, U, V, G, tc, dt, a, E[GP])
                probed = True
            fa = E[GP, k]
        if fa * E[GB, k] < 0.0:
            r = _crossing_root(
                sw, sp, rhs, grad, q, mode, S, U, V, G, E, tc, dt, k, a, fa, E[GB, k]
            )
            if r > 1e-6 * dt and r < tau:
                tau = r
                found = k
    return tau, found, -1


# ------------------------------------------------------------ at a jump surface
@_helper
def _log(log, st, t, k, what):  # pragma: no cover - compiled
    i = int(st[S_NLOG])
    log[i, 0] = t
    log[i, 1] = k
    log[i, 2] = what
    st[S_NLOG] = i + 1


@_helper
def _refuse(st, status, t, k, a, b):  # pragma: no cover - compiled
    st[S_ERR_T] = t
    st[S_ERR_K] = k
    st[S_ERR_A] = a
    st[S_ERR_B] = b
    return status


@_helper
def _on_surface(rhs, grad, q, mode, sw_info, U, V, G, k, t, y, st, log):  # pragma: no cover
    """At a zero of jump k: cross, start sliding, or refuse (see the module notes).
    While sliding on another surface, the two sliding fields (k's side -1 and +1)
    decide. U holds the input and its rate at t. Returns a status."""
    pos = sw_info[k, 0]
    old = q[pos]
    if mode[0] < 0:
        s_lo, s_hi = _normal_speeds(rhs, grad, q, pos, k, t, y, U, V, G)
    else:
        q[pos] = -1.0
        _filippov(rhs, grad, q, mode[1], mode[0], t, y, U, V, G, V[F0 + 2])
        q[pos] = 1.0
        _filippov(rhs, grad, q, mode[1], mode[0], t, y, U, V, G, V[F0 + 3])
        s_lo, s_hi = _speeds(G, k, U, V, F0 + 2)
    d = decide(s_lo, s_hi)
    if d == 1 or d == -1:
        q[pos] = float(d)
        return OK
    q[pos] = old
    if d == 3:
        return OK
    if d == 2:
        return _refuse(st, REPELLING, t, k, s_lo, s_hi)
    if mode[0] >= 0:
        return _refuse(st, INTERSECTION, t, k, mode[0], 0.0)
    mode[0] = k
    mode[1] = pos
    _log(log, st, t, k, 1.0)
    return OK


@_helper
def _event(rhs, grad, q, mode, sw_info, S, U, V, G, k, tc, st, log):  # pragma: no cover
    """Event value k has reached zero at (tc, V[Y]): nothing for a kink; a jump
    surface is decided by :func:`_on_surface`; a sliding speed ends the sliding on
    that side. Then the first stage of the next step, in the new mode. Returns a
    status."""
    n_sw = sw_info.shape[0]
    y = V[Y]
    _input_at(U, S, tc)
    _input_rate(U, S, tc)
    status = OK
    if k >= n_sw:
        slid = mode[0]
        q[mode[1]] = -1.0 if k == n_sw else 1.0
        mode[0] = -1
        mode[1] = -1
        _log(log, st, tc, slid, -1.0)
        st[S_FRESH] = slid
        st[S_ERR_K] = slid
    elif sw_info[k, 0] >= 0:
        status = _on_surface(rhs, grad, q, mode, sw_info, U, V, G, k, tc, y, st, log)
        st[S_FRESH] = k
    st[S_WORK] += 1.0
    _field(rhs, grad, q, mode, S, U, V, G, tc, y, V[K0])
    return status


@_helper
def _project(sw, sp, grad, q, k, t, y, u, g, G):  # pragma: no cover - compiled
    """One Newton step back onto the surface g_k = 0 along dg_k/dx (exact for a
    surface linear in x): the projection of Hairer, Lubich and Wanner, *Geometric
    Numerical Integration*, 2nd ed., sec. IV.4."""
    nx = y.shape[0]
    sw(t, y, u, sp, g)
    grad(t, y, u, q, G)
    nrm = 0.0
    for i in range(nx):
        nrm += G[k, i] * G[k, i]
    if nrm > 0.0:
        c = g[k] / nrm
        for i in range(nx):
            y[i] -= c * G[k, i]


# ------------------------------------------------------------------ the steps
@_helper
def _error(K, y, ynew, dt, rtol, atol):  # pragma: no cover - compiled
    """DOP853's error estimate of the step (Hairer's dop853.f), and whether ynew is
    finite."""
    nx = y.shape[0]
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
    if e5 == 0.0 and e3 == 0.0:
        return 0.0, finite
    return dt * e5 / math.sqrt((e5 + 0.01 * e3) * nx), finite


@_helper
def _half_steps(
    rhs, grad, q, mode, S, U, V, G, tc, step, yf, yfm, yfn, Kf, ytmp, u
):  # pragma: no cover - compiled
    """The certifying run: the same step as two half steps from the fine state yf
    (V[YF]), with the same field (branch or sliding vector) as the main run."""
    half = 0.5 * step
    _input_at(U, S, tc)
    if grad is None or mode[0] < 0:
        rhs(tc, yf, u, q, Kf[0])
    else:
        _sliding_field(rhs, grad, q, mode, S, U, V, G, tc, yf, Kf[0])
    _dop_stages(rhs, grad, q, mode, S, U, V, G, tc, yf, half, Kf, yfm, ytmp, u)
    _input_at(U, S, tc + half)
    if grad is None or mode[0] < 0:
        rhs(tc + half, yfm, u, q, Kf[0])
    else:
        _sliding_field(rhs, grad, q, mode, S, U, V, G, tc + half, yfm, Kf[0])
    _dop_stages(rhs, grad, q, mode, S, U, V, G, tc + half, yfm, half, Kf, yfn, ytmp, u)
    for j in range(yf.shape[0]):
        yf[j] = yfn[j]


@_helper
def _attempt(
    rhs, grad, q, mode, sw, sp, sw_info, S, U, V, G, E, ta, tb, tc, dt, fresh, y, ynew, ytmp,
    u, K, ga, gb,
):  # fmt: skip  # pragma: no cover - compiled
    """One trial step of size dt from (tc, y), cut to end on the first event:
    ``(dt, tn, cut, start)``. ``cut``: the event value the step ends on (-1: none);
    ``start`` >= 0: that event happens at tc already (no step was taken). y, ynew,
    ytmp, u, K, ga, gb: the rows of V, U and E (:func:`_intervals`)."""
    n_sw = sw_info.shape[0]
    if n_sw > 0:
        _input_at(U, S, tc)
        if mode[0] < 0:
            sw(tc, y, u, sp, ga)
        else:
            _events(sw, sp, rhs, grad, q, mode, U, V, G, S, tc, y, ga)
    cut = -1
    lo_dt, lo_g, hi_dt, hi_g, kept, tries = 0.0, 0.0, 0.0, 0.0, 0, 0
    while True:
        _dop_stages(rhs, grad, q, mode, S, U, V, G, tc, y, dt, K, ynew, ytmp, u)
        tn = tc + dt
        if tb - tn < 1e-9 * (tb - ta):
            tn = tb
        _input_at(U, S, tn)
        if grad is None or mode[0] < 0:
            rhs(tn, ynew, u, q, K[_NS])
        else:
            _sliding_field(rhs, grad, q, mode, S, U, V, G, tn, ynew, K[_NS])
        # Does an event value change sign inside the step? Then end the step on the
        # first such zero (located on the step's Hermite interpolant), so that f is
        # smooth on every step; the error test follows.
        tau = dt
        found = -1
        if n_sw > 0:
            if mode[0] < 0:
                sw(tn, ynew, u, sp, gb)
            else:
                _events(sw, sp, rhs, grad, q, mode, U, V, G, S, tn, ynew, gb)
            tau, found, start = _first_event(
                sw, sp, rhs, grad, q, mode, sw_info, S, U, V, G, E, tc, dt, fresh
            )
            if start >= 0:
                return dt, tn, cut, start
        if found >= 0 and 1e-6 * dt < tau < dt * (1.0 - 1e-9):
            if found != cut:  # the crossing lies between the step's start and this end
                lo_dt, lo_g = 0.0, ga[found]
            hi_dt, hi_g, cut = dt, gb[found], found
            dt = tau
            continue
        cut = found if found >= 0 else cut
        if grad is None or cut < 0 or cut >= n_sw or sw_info[cut, 0] < 0 or tries >= 40:
            return dt, tn, cut, -1
        # A jump: its crossing to rounding, by the secant method on the step's own end
        # values. (The interpolant places it to about 1e-9 of a step, which is enough
        # for a kink, whose error grows with the cube of the offset, not for a jump,
        # which turns the offset into an error of its size times the jump of f.)
        lo_dt, lo_g, hi_dt, hi_g, kept, nxt = _secant(
            dt, gb[cut], q[sw_info[cut, 0]], lo_dt, lo_g, hi_dt, hi_g, kept
        )
        if nxt < 0.0:
            return dt, tn, cut, -1
        dt = nxt
        tries += 1


@njit(inline="always")
def _secant(dt, g, side, lo_dt, lo_g, hi_dt, hi_g, kept):  # pragma: no cover - compiled
    """One Illinois step on the step length: ``g`` is the switching value at the end
    of a step of length dt (``side``: its sign before the crossing); the bracket
    [lo_dt, hi_dt] holds the crossing. Returns the new bracket and the next length to
    try, -1 when the crossing is found (bracket or value at rounding level)."""
    lo_dt, lo_g, hi_dt, hi_g, kept = _illinois(
        dt, g, g * side > 0.0, lo_dt, lo_g, hi_dt, hi_g, kept
    )
    if hi_dt - lo_dt <= 1e-15 * hi_dt or abs(g) <= 1e-15 * max(abs(lo_g), abs(hi_g)):
        return lo_dt, lo_g, hi_dt, hi_g, kept, -1.0
    nxt = (lo_g * hi_dt - hi_g * lo_dt) / (lo_g - hi_g)  # the secant point, as _crossing_root
    if not lo_dt < nxt < hi_dt:
        nxt = 0.5 * (lo_dt + hi_dt)
    if nxt == dt:
        return lo_dt, lo_g, hi_dt, hi_g, kept, -1.0
    return lo_dt, lo_g, hi_dt, hi_g, kept, nxt


@_helper
def _new_step(err, step, dt_free, rejected):  # pragma: no cover - compiled
    """The step proposal after an accepted step (a step cut short to land on the
    sample time or on an event says nothing about it and does not change it)."""
    factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** (-1.0 / 8.0))
    if rejected:  # no growth right after a rejection (as in Hairer's DOP853)
        factor = min(1.0, factor)
    if step >= dt_free * (1.0 - 1e-9):
        return step * factor
    return dt_free


@_helper
def _accept(
    sw, sp, rhs, grad, q, mode, sw_info, S, U, V, G, E, cut, tc, st, log
):  # pragma: no cover - compiled
    """After an accepted step to tc (V[Y] the new state, K[0] its first stage): back
    onto the surface slid on, then the event the step ended on (if any), the last
    kink located noted for messages. Returns a status."""
    n_sw = sw_info.shape[0]
    if 0 <= cut < n_sw:
        st[S_ERR_K] = cut
    jump = cut >= n_sw or (cut >= 0 and sw_info[cut, 0] >= 0)
    if mode[0] < 0 and not jump:
        return OK
    if mode[0] >= 0:
        _input_at(U, S, tc)
        _project(sw, sp, grad, q, mode[0], tc, V[Y], U[U_], E[GR], G)
        _project(sw, sp, grad, q, mode[0], tc, V[YF], U[U_], E[GR], G)
    if not jump:
        cut = -1  # nothing to decide: the first stage again, at the projected state
    return _event(rhs, grad, q, mode, sw_info, S, U, V, G, cut, tc, st, log)


@_helper
def _advance(
    rhs, grad, q, mode, sw, sp, sw_info, S, U, V, G, E, ta, tb, ctl, st, log, ends, work, y,
    yf, ynew, ytmp, yfm, yfn, u, K, Kf, ga, gb,
):  # fmt: skip  # pragma: no cover - compiled
    """Steps of the interval [ta, tb] from the state in (st, V) until its end (OK), a
    pause after ``budget`` attempts in this call, or a stop; (status, work done).
    ``ctl``: rtol, atol, certify, budget, max_steps. ``ends`` (empty: none kept): the
    end time of every accepted step, for a certifying run elsewhere
    (:func:`certify_steps`); the call returns :data:`ENDS_FULL` when it is full.
    y ... gb: the rows of V, U and E the steps use, made once (:func:`_intervals`)."""
    rtol, atol, certify = ctl[0], ctl[1], ctl[2] != 0.0
    budget, max_steps = ctl[3], ctl[4]
    min_dt = 1e-12 * (tb - ta)
    tc = st[S_TC]
    dt_free = st[S_DT]
    rejected = st[S_REJ] != 0.0
    status = OK
    keep_ends = ends.shape[0] > 0
    while tc < tb and status == OK:
        if (
            work >= budget
            or st[S_WORK] >= max_steps
            or st[S_NLOG] + 4.0 > log.shape[0]
            or (keep_ends and st[S_NEND] >= ends.shape[0])
        ):
            status = _checkpoint(st, log, ends, work, budget, max_steps, tc)
            break
        st[S_WORK] += 1.0
        work += 1
        # dt_free is the step the error control proposes.
        dt = dt_free
        if dt > tb - tc or tb - (tc + dt) < 1e-9 * (tb - ta):
            dt = tb - tc
        dt, tn, cut, start = _attempt(
            rhs, grad, q, mode, sw, sp, sw_info, S, U, V, G, E, ta, tb, tc, dt,
            int(st[S_FRESH]), y, ynew, ytmp, u, K, ga, gb,
        )  # fmt: skip
        if start >= 0:
            # (a jump or a sliding speed at the step's start; kinks never start one)
            if grad is not None:
                status = _event(rhs, grad, q, mode, sw_info, S, U, V, G, start, tc, st, log)
            continue
        err, finite = _error(K, y, ynew, dt, rtol, atol)
        if not finite:
            status = NONFINITE
        elif err > 1.0:
            rejected = True
            dt_free = dt * max(0.2, 0.9 * err ** (-1.0 / 8.0))
            if dt_free < min_dt:
                status = _refuse(st, UNDERFLOW, tc, st[S_ERR_K], 0.0, 0.0)
        else:
            step = tn - tc
            if certify:
                _half_steps(rhs, grad, q, mode, S, U, V, G, tc, step, yf, yfm, yfn, Kf, ytmp, u)
            _keep_end(ends, st, tn)
            tc = tn
            for j in range(y.shape[0]):
                y[j] = ynew[j]
                K[0, j] = K[_NS, j]
            st[S_COUNT] += 1.0
            st[S_FRESH] = -1.0
            dt_free = _new_step(err, step, dt_free, rejected)
            rejected = False
            if grad is None:
                if cut >= 0:  # a kink: only noted, for messages
                    st[S_ERR_K] = cut
            elif cut >= 0 or mode[0] >= 0:
                status = _accept(
                    sw, sp, rhs, grad, q, mode, sw_info, S, U, V, G, E, cut, tc, st, log
                )
    st[S_TC] = tc
    st[S_DT] = dt_free
    st[S_REJ] = 1.0 if rejected else 0.0
    return status, work


@_helper
def _checkpoint(st, log, ends, work, budget, max_steps, tc):  # pragma: no cover - compiled
    """Why the steps stop before an attempt: a pause (the call's budget is spent, the
    sliding log may fill, the step ends are full), or a stalled interval."""
    if work >= budget:
        return PAUSED
    if st[S_NLOG] + 4.0 > log.shape[0]:
        return LOG_FULL
    if ends.shape[0] > 0 and st[S_NEND] >= ends.shape[0]:
        return ENDS_FULL
    return _refuse(st, STALL, tc, st[S_ERR_K], 0.0, 0.0)


@_helper
def _keep_end(ends, st, tn):  # pragma: no cover - compiled
    """The end time ``tn`` of an accepted step into ``ends``, if it keeps them."""
    if ends.shape[0] > 0:
        ends[int(st[S_NEND])] = tn
        st[S_NEND] += 1.0


@_helper
def _certify_intervals(rhs, q, mode, S, U, V, G, t, hold, X, steps, ends, diff):  # pragma: no cover
    """:func:`certify_steps` on borrowed arrays: interval n from X[n], its steps[n]
    steps ending at the next entries of ``ends``, each as two half steps."""
    yf, yfm, yfn, ytmp = V[YF], V[YFM], V[YFN], V[YTMP]
    Kf, u = V[KF : KF + _NS + 1], U[U_]
    p = 0
    for n in range(steps.shape[0]):
        for j in range(U.shape[1]):
            U[HOLD, j] = hold[n, j]
        for j in range(X.shape[1]):
            yf[j] = X[n, j]
        tc = t[n]
        for _i in range(steps[n]):
            tn = ends[p]
            p += 1
            _half_steps(rhs, None, q, mode, S, U, V, G, tc, tn - tc, yf, yfm, yfn, Kf, ytmp, u)
            tc = tn
        for j in range(X.shape[1]):
            diff[n, j] = X[n + 1, j] - yf[j]


# ------------------------------------------------------------ interval ends
@_helper
def _begin(V, X, restart, n, tc, st):  # pragma: no cover - compiled
    """Start interval n at tc from X[n] (the certifying run too, at a sample time)."""
    for j in range(X.shape[1]):
        V[Y, j] = X[n, j]
        if restart[n]:
            V[YF, j] = X[n, j]
    st[S_TC] = tc
    st[S_REJ] = 0.0
    st[S_COUNT] = 0.0
    st[S_WORK] = 0.0
    st[S_FRESH] = -1.0
    st[S_PHASE] = 1.0


@_helper
def _begin_jumps(
    rhs, grad, q, mode, sw, sp, sw_info, S, U, V, G, E, tc, st, log
):  # pragma: no cover - compiled
    """The sides of the jumps at an interval's start: at the first interval, or where
    the input moved a surface. Returns a status."""
    _input_at(U, S, tc)
    _events(sw, sp, rhs, grad, q, mode, U, V, G, S, tc, V[Y], E[GR])
    _input_rate(U, S, tc)
    status = _set_sides(rhs, grad, q, mode, sw_info, U, V, G, E[GR], tc, st, log)
    st[S_READY] = 1.0
    return status


@_helper
def _has_jumps(sw_info):  # pragma: no cover - compiled
    for k in range(sw_info.shape[0]):
        if sw_info[k, 0] >= 0:
            return True
    return False


@_helper
def _set_sides(rhs, grad, q, mode, sw_info, U, V, G, g, tc, st, log):  # pragma: no cover
    """The side of every jump from the sign of its switching value ``g`` at the run's
    start, or, later, of those that depend on the input where the input moved them
    (the value differs from the one at the end of the last interval); a value at
    exactly zero is decided by the fields (:func:`_on_surface`)."""
    first = st[S_READY] == 0.0
    for k in range(sw_info.shape[0]):
        pos = sw_info[k, 0]
        if not _moved(sw_info, g, st, k, first):
            continue
        if mode[0] == k:
            mode[0] = -1
            mode[1] = -1
            _log(log, st, tc, k, -1.0)
        if g[k] != 0.0:
            q[pos] = 1.0 if g[k] > 0.0 else -1.0
    for k in range(sw_info.shape[0]):
        if _moved(sw_info, g, st, k, first) and g[k] == 0.0 and mode[0] != k:
            status = _on_surface(rhs, grad, q, mode, sw_info, U, V, G, k, tc, V[Y], st, log)
            if status != OK:
                return status
    return OK


@njit(inline="always")
def _moved(sw_info, g, st, k, first):  # pragma: no cover - compiled
    """Jump k's side is to be set anew: at the start, or the input moved its surface."""
    return sw_info[k, 0] >= 0 and (first or (sw_info[k, 1] == 1 and g[k] != st[_S_G + k]))


@_helper
def _finish(X, steps, diff, V, st, n):  # pragma: no cover - compiled
    """Interval n is done: its end sample, its certificate difference, its steps."""
    for j in range(X.shape[1]):
        X[n + 1, j] = V[Y, j]
        diff[n, j] = V[Y, j] - V[YF, j]
    steps[n] = int(st[S_COUNT])
    st[S_N] = n + 1
    st[S_PHASE] = 0.0


@_helper
def _finish_jumps(sw, sp, rhs, grad, q, mode, S, U, V, G, E, tb, st):  # pragma: no cover
    """The switching values at an interval's end (to tell where the next interval's
    input moves a surface)."""
    _input_at(U, S, tb)
    _events(sw, sp, rhs, grad, q, mode, U, V, G, S, tb, V[Y], E[GR])
    for k in range(E.shape[1] - 2):
        st[_S_G + k] = E[GR, k]


@njit(inline="always")
def _intervals(
    rhs, grad, q, mode, sw, sp, sw_info, S, U, V, G, E, t, hold, ctl, n_stop, X, steps, diff,
    restart, st, log, ends,
):  # fmt: skip  # pragma: no cover - compiled
    """The intervals from st[S_N] to n_stop - 1 (see :func:`integrate`), on borrowed
    arrays (:func:`_borrow`)."""
    y, yf, ynew, ytmp, yfm, yfn = V[Y], V[YF], V[YNEW], V[YTMP], V[YFM], V[YFN]
    K, Kf, u, ga, gb = V[K_ : K_ + _NS + 1], V[KF : KF + _NS + 1], U[U_], E[GA], E[GB]
    jumps = _has_jumps(sw_info)
    work = np.int64(0)
    status = OK
    while int(st[S_N]) < n_stop and status == OK:
        n = int(st[S_N])
        for j in range(U.shape[1]):
            U[HOLD, j] = hold[n, j]
        if st[S_PHASE] == 0.0:
            _begin(V, X, restart, n, t[n], st)
            if grad is not None and jumps:
                status = _begin_jumps(
                    rhs, grad, q, mode, sw, sp, sw_info, S, U, V, G, E, t[n], st, log
                )
            _input_at(U, S, t[n])
            _field(rhs, grad, q, mode, S, U, V, G, t[n], y, K[0])
        if status == OK:
            status, work = _advance(
                rhs, grad, q, mode, sw, sp, sw_info, S, U, V, G, E, t[n], t[n + 1], ctl, st, log,
                ends, work, y, yf, ynew, ytmp, yfm, yfn, u, K, Kf, ga, gb,
            )  # fmt: skip
        if status == OK:
            _finish(X, steps, diff, V, st, n)
            if grad is not None and jumps:
                _finish_jumps(sw, sp, rhs, grad, q, mode, S, U, V, G, E, t[n + 1], st)
    return status


@_helper
def _keep(E, U, S, G, ctl):  # pragma: no cover - compiled
    """Nothing: a use of the arrays :func:`integrate` makes, after the loop that works on
    their borrowed copies (numba frees an array after its last use by name)."""
    return None


_F = types.float64
_A2 = types.float64[:, ::1]
_F1 = types.float64[::1]
_B1 = types.Array(types.boolean, 1, "C", readonly=True)
_I2 = types.Array(types.int64, 2, "C", readonly=True)
# Two specialisations, each compiled on first use: ``grad`` a gradient kernel (a model
# with jumps), or None (a model without: every branch on the sliding mode and the jump
# surfaces is pruned when numba compiles, so neither the Filippov machinery nor its
# helpers are compiled for the models that never need them).
_INTEGRATE_ARGS = (
    RHS_TYPE, JAC_TYPE, _F1, RO1, RO2, RO1, RO2, RO2, RO2, _F, _F, types.boolean, types.int64,
    RHS_TYPE, RO1, _I2, _A2, types.int64[::1], _A2, _B1, _F1, _A2, _A2, types.int64,
    types.int64, _F1,
)  # fmt: skip
_INTEGRATE_SIG = types.int64(*_INTEGRATE_ARGS)
_INTEGRATE_SMOOTH_SIG = types.int64(*(types.none if i == 1 else a
                                      for i, a in enumerate(_INTEGRATE_ARGS)))  # fmt: skip


def _integrate(
    rhs, grad, q, t, hold, offset, amp, freq, phase, rtol, atol, certify, n_stop, sw, sp,
    sw_info, X, steps, diff, restart, st, V, log, budget, max_steps, ends,
):  # fmt: skip  # pragma: no cover - compiled
    """Integrate the intervals [t[n], t[n+1]] from n = st[S_N] to n_stop - 1.

    Parameters (shapes: nx states, nu inputs, n_sw switching values)
    ----------------------------------------------------------------
    rhs : f(t, x, u, q, out), the branch kernel (the model's rhs if it has no jump).
    grad : rows (dg/dx, dg/dt, dg/du) of the switching values, out (n_sw, nx + 1 + nu);
        None for a model without jumps (the smooth specialisation).
    q : the parameters, then the side (-1, +1) of each jump; written (the sides).
    t : the nodes (sample times, and input breakpoints between them).
    hold, offset, amp, freq, phase : the input (held part per node, offset, sinusoids).
    sw, sp : the switching values g(t, x, u, sp, out) and their parameters.
    sw_info : (n_sw, 2) int: position of the value's side in q (-1: a kink), and 1 if
        a jump depends on the input.
    X : (N, nx) samples; X[st[S_N]] must hold the start state. steps, diff: per interval.
    restart : per node, True where the certifying run restarts from the sample.
    st, V, log : the state (:data:`STATE_SLOTS` + n_sw), the vectors
        (:data:`N_VECTORS`, nx; rows Y, YF, K0 carry over), the sliding log rows
        (t, surface, +1 start / -1 end).
    budget : step attempts in this call before it returns :data:`PAUSED`.
    max_steps : step attempts and events per interval before :data:`STALL`.
    ends : empty, or (a main run with ``certify`` False whose certifying run is
        :func:`certify_steps`) the end time of each accepted step from entry
        st[S_NEND] on; :data:`ENDS_FULL` when full.

    The certifying half-step run restarts from X[n] only where ``restart[n]`` (a sample
    time): across a breakpoint it goes on, so ``diff`` at the last node of a sampling
    interval is the difference over the whole interval. Returns a status.
    """
    nx = X.shape[1]
    nu = hold.shape[1]
    n_sw = sw_info.shape[0]
    E = np.empty((4, n_sw + 2))
    U = np.empty((4, nu))
    S = np.empty((3, nu, amp.shape[1]))
    for j in range(nu):  # (loops: a slice assignment would compile numba's shape errors)
        U[OFFSET, j] = offset[j]
        for k in range(amp.shape[1]):
            S[0, j, k] = amp[j, k]
            S[1, j, k] = freq[j, k]
            S[2, j, k] = phase[j, k]
    G = np.empty((max(n_sw, 1), nx + 1 + nu))
    ctl = np.empty(5)
    ctl[0] = rtol
    ctl[1] = atol
    ctl[2] = 1.0 if certify else 0.0
    ctl[3] = budget
    ctl[4] = max_steps
    mode = np.empty(2, dtype=np.int64)
    mode[0] = int(st[S_SLIDE])
    mode[1] = sw_info[mode[0], 0] if mode[0] >= 0 else -1
    status = _intervals(
        rhs, grad, _borrow(q), _borrow(mode), sw, _borrow(sp), _borrow(sw_info), _borrow(S),
        _borrow(U), _borrow(V), _borrow(G), _borrow(E), _borrow(t), _borrow(hold),
        _borrow(ctl), n_stop, _borrow(X), _borrow(steps), _borrow(diff), _borrow(restart),
        _borrow(st), _borrow(log), _borrow(ends),
    )  # fmt: skip
    st[S_SLIDE] = mode[0]
    _keep(E, U, S, G, ctl)  # (numba would free them after their borrowing, their last use)
    return status


# numba warns that first-class function types are experimental when it types the
# kernels passed down the helpers; they are what makes the integrator cacheable.
# One dispatcher per specialisation, each compiled for its one signature on first use
# and then closed to others: called from Python with the kernels as numba dispatchers,
# an open one would compile (and cache) a specialisation on their own types instead.
# No C entry point: compiled callers (integrate_intervals) call them directly.
# nogil: the certifying run of :func:`certify_steps` runs in another thread meanwhile.
integrate = _njit(cache=True, nogil=True, no_cfunc_wrapper=True)(_integrate)
integrate_smooth = _njit(cache=True, nogil=True, no_cfunc_wrapper=True)(_integrate)
_COMPILE_LOCK = threading.Lock()


def _certify_steps(
    rhs, q, t, hold, offset, amp, freq, phase, X, steps, ends, diff
):  # pragma: no cover - compiled
    """The certifying run of a model without jumps, done beside its main run (in
    another thread) instead of in lockstep with it: every accepted step of interval n
    (``steps[n]`` of them, ending at the next entries of ``ends``, the main run's
    step ends from :func:`integrate`) again as two half steps from X[n], and
    ``diff[n] = X[n + 1] -`` their result. The same operations in the same order as the
    lockstep run (:func:`_half_steps`): the same numbers.

    Shapes: t (n + 1,), hold (n + 1, nu), X (n + 1, nx), steps (n,), diff (n, nx);
    offset, amp, freq, phase: the input, as for :func:`integrate`."""
    nu = hold.shape[1]
    U = np.empty((4, nu))
    S = np.empty((3, nu, amp.shape[1]))
    for j in range(nu):
        U[OFFSET, j] = offset[j]
        for k in range(amp.shape[1]):
            S[0, j, k] = amp[j, k]
            S[1, j, k] = freq[j, k]
            S[2, j, k] = phase[j, k]
    V = np.empty((N_VECTORS, X.shape[1]))
    G = np.empty((1, X.shape[1] + 1 + nu))
    mode = np.full(2, -1, dtype=np.int64)
    _certify_intervals(
        rhs, _borrow(q), _borrow(mode), _borrow(S), _borrow(U), _borrow(V), _borrow(G), t,
        hold, X, steps, ends, diff,
    )  # fmt: skip
    _keep(V, U, S, G, q)  # (used after their borrowed copies: see _borrow)
    mode[0] = -1


_RI1 = types.Array(types.int64, 1, "C", readonly=True)
_CERTIFY_SIG = types.none(RHS_TYPE, _F1, RO1, RO2, RO1, RO2, RO2, RO2, RO2, _RI1, RO1, _A2)
certify_steps = _njit(cache=True, nogil=True)(_certify_steps)


def _specialisation(smooth: bool) -> tuple[Any, Any]:
    return (integrate_smooth, _INTEGRATE_SMOOTH_SIG) if smooth else (integrate, _INTEGRATE_SIG)


def _in_disk_cache(disp: Any, sig: Any) -> bool:
    """Whether numba's cache on disk holds ``disp`` compiled for ``sig`` (its index
    entry: what ``disp.compile(sig)`` would load). True when that cannot be told (a
    numba whose cache is laid out otherwise): the caller then compiles as usual."""
    try:
        cache = disp._cache
        key = cache._index_key(sig, disp.targetctx.codegen())
        return key in cache._cache_file._load_index()
    except Exception:  # numba's private cache layout changed: assume cached
        return True


#: smooth -> the forked process compiling that specialisation (:func:`compile_aside`);
#: a process forked from this one (a worker) has none: it is not that process's parent.
_ASIDE: dict[bool, Any] = {}
if hasattr(os, "register_at_fork"):  # (not on Windows, which does not fork)
    os.register_at_fork(after_in_child=_ASIDE.clear)
#: How long :func:`wait_aside` waits (the compile takes 6-7 s; a child still running
#: after this is stuck, and this process compiles the integrator itself).
_ASIDE_TIMEOUT_S = 600.0


def _compile_quietly(smooth: bool) -> None:  # pragma: no cover - runs in the child
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)  # a compile notice or a warning is the parent's to give
    os.dup2(devnull, 2)
    integrator(smooth)


def compile_aside(smooth: bool) -> None:
    """Start compiling :func:`integrator` ``(smooth)`` in a forked process, when it is
    neither compiled here nor in numba's cache on disk (a first run after an install),
    so that this process compiles the model's kernels meanwhile: the integrator is
    the longest compile (6-7 s on the 2-core development machine, against 2-3 s for a
    vehicle's kernels; docs/benchmarks.md). The child saves it in numba's cache, and
    :func:`integrator` waits for the child, then loads it from there. Linux only, and
    only from a process with no other thread running (call it before starting any);
    does nothing otherwise or when there is nothing to compile."""
    disp, sig = _specialisation(smooth)
    if (
        not sys.platform.startswith("linux")
        or threading.active_count() > 1  # a fork would copy a lock another thread holds
        or smooth in _ASIDE
        or sig.args in disp.signatures
        or _in_disk_cache(disp, sig)
    ):
        return
    import multiprocessing

    child = multiprocessing.get_context("fork").Process(
        target=_compile_quietly, args=(smooth,), name="sampledyn-compile", daemon=True
    )
    child.start()
    _ASIDE[smooth] = child


def compiling_aside() -> bool:
    """Whether a process of :func:`compile_aside` is compiling for this one."""
    return bool(_ASIDE)


def wait_aside(smooth: bool) -> None:
    """Wait for the process of :func:`compile_aside` compiling the ``smooth``
    specialisation, if any, as a numba compile event (so the compile notice of the
    command line is said if nothing else here compiled first); the process is killed
    if the wait is interrupted (Ctrl-C) or times out (``_ASIDE_TIMEOUT_S``). Waiting
    for the smooth one, this process first compiles :func:`certifier` (the certifying
    thread's kernel of the long runs, 1-2.5 s), which it would otherwise compile on the
    first such run."""
    child = _ASIDE.pop(smooth, None)
    if child is None:
        return
    if smooth and child.is_alive():
        certifier()
    from numba.core import event

    disp, sig = _specialisation(smooth)
    data = {"dispatcher": disp, "args": sig.args, "return_type": sig.return_type}
    try:
        with event.trigger_event("numba:compile", data=data):
            child.join(_ASIDE_TIMEOUT_S)
    finally:
        if child.is_alive():  # interrupted, or stuck: this process compiles it
            child.kill()
            child.join()


def integrator(smooth: bool) -> Any:
    """:func:`integrate` compiled (or loaded from numba's cache) for a model without
    jumps (``smooth``: ``integrate_smooth``, called with ``grad=None``) or with them."""
    disp, sig = _specialisation(smooth)
    if sig.args not in disp.signatures:
        wait_aside(smooth)  # then compile() loads what the child saved
        with _COMPILE_LOCK, warnings.catch_warnings():
            # numba warns that first-class function types are experimental when it
            # types the kernels passed down the helpers; they are what makes the
            # integrator cacheable.
            warnings.simplefilter("ignore", NumbaExperimentalFeatureWarning)
            if sig.args not in disp.signatures:
                disp.compile(sig)
    disp.disable_compile()
    return disp


def certifier() -> Any:
    """:func:`certify_steps` compiled (or loaded from numba's cache) for its one
    signature (compile it after :func:`integrator` ``(True)``: it reuses that one's
    compiled half steps)."""
    if _CERTIFY_SIG.args not in certify_steps.signatures:
        with _COMPILE_LOCK, warnings.catch_warnings():
            warnings.simplefilter("ignore", NumbaExperimentalFeatureWarning)  # as integrator()
            if _CERTIFY_SIG.args not in certify_steps.signatures:
                certify_steps.compile(_CERTIFY_SIG)
    certify_steps.disable_compile()
    return certify_steps


@njit(cache=True)  # compiled where it is called (compiled code: the sampled loop)
def integrate_intervals(
    rhs, p, t, x0, hold, offset, amp, freq, phase, rtol, atol, certify, n_start, n_stop,
    dt_init, sw, sp, sw_input_only, X, steps, diff, restart,
):  # fmt: skip  # pragma: no cover - compiled
    """:func:`integrate` for a model without jumps (its smooth specialisation),
    intervals n_start..n_stop-1 in one call, with the step budget of
    :data:`DEFAULT_MAX_STEPS` per interval; returns (status, the next step proposal).
    For compiled callers (the sampled loop of :func:`sampledyn.run_loop`); ``x0`` is
    not read (X[n_start] is)."""
    nx = X.shape[1]
    n_sw = sw_input_only.shape[0]
    st = np.zeros(STATE_SLOTS + n_sw)
    st[S_N] = n_start
    st[S_DT] = dt_init
    st[S_SLIDE] = -1.0
    st[S_READY] = 1.0
    st[S_ERR_K] = -1.0
    V = np.empty((N_VECTORS, nx))
    log = np.empty((4, 3))
    info = np.empty((n_sw, 2), dtype=np.int64)
    for k in range(n_sw):
        info[k, 0] = -1
        info[k, 1] = 0
    status = integrate_smooth(
        rhs, None, p.copy(), t, hold, offset, amp, freq, phase, rtol, atol, certify, n_stop,
        sw, sp, info, X, steps, diff, restart, st, V, log, 1 << 62, DEFAULT_MAX_STEPS,
        np.empty(0),
    )  # fmt: skip
    return status, st[S_DT]
