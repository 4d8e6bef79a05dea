"""The vehicle kernel of sampledyn before the generated kernels (issue 23), as plain
Python: the oracle for "f equal to today's". One state at a time, every parameter read
from ``p`` and every entry of each 6 x 6 matrix visited, zeros included.

Its reads of ``p`` use the library's layout (the offsets are unchanged but for the
allocation's, after three derived values packed before it).
"""
# ruff: noqa: E501

from __future__ import annotations

import math

# The layout of the parameter array p, from the library (the one place it is defined).
from sampledyn.models._vehicle_kernels import (
    _ALLOC,
    _BUOY,
    _DL,
    _DQ,
    _K1,
    _K2,
    _LAG,
    _M,
    _MINV,
    _N,
    _NMAX,
    _RB,
    _RG,
    _TAUC,
    _TN,
    _VCB,
    _VCN,
    _W,
    _WRENCH,
)


def _saturate(n, n_max):
    """The applied rpm min(max(n, -n_max), n_max)."""
    if n > n_max:
        return n_max
    if n < -n_max:
        return -n_max
    return n


def _mass_times_v(x, p):
    """(a, b) = M v, the two 3-vectors of C(v) v = [w x a; v_lin x a + w x b]."""
    a0 = 0.0
    a1 = 0.0
    a2 = 0.0
    b0 = 0.0
    b1 = 0.0
    b2 = 0.0
    for j in range(6):
        vj = x[6 + j]
        a0 += p[_M + j] * vj
        a1 += p[_M + 6 + j] * vj
        a2 += p[_M + 12 + j] * vj
        b0 += p[_M + 18 + j] * vj
        b1 += p[_M + 24 + j] * vj
        b2 += p[_M + 30 + j] * vj
    return a0, a1, a2, b0, b1, b2


def _thruster_column(x, p, i):
    """Column i of B, ``[d_i; r_i x d_i]``, and v_a,i = B[:, i] . v."""
    c0 = p[_ALLOC + 6 * i + 0]
    c1 = p[_ALLOC + 6 * i + 1]
    c2 = p[_ALLOC + 6 * i + 2]
    c3 = p[_ALLOC + 6 * i + 3]
    c4 = p[_ALLOC + 6 * i + 4]
    c5 = p[_ALLOC + 6 * i + 5]
    va = c0 * x[6] + c1 * x[7] + c2 * x[8] + c3 * x[9] + c4 * x[10] + c5 * x[11]
    return c0, c1, c2, c3, c4, c5, va


def _damping_row(x, p, k):
    """Row k of D(v) v = D_l v + d_q |v| v."""
    acc = p[_DQ + k] * abs(x[6 + k]) * x[6 + k]
    for j in range(6):
        acc += p[_DL + 6 * k + j] * x[6 + j]
    return acc


def vehicle_rhs(t, x, u, p, out):
    """x' = f(t, x, u; p) for one state; writes ``out`` (shape (nx,))."""
    nt = int(p[_N])
    lag = p[_LAG] > 0.5
    k1 = p[_K1]
    k2 = p[_K2]
    n_max = p[_NMAX]

    phi = x[3]
    theta = x[4]
    psi = x[5]
    vu = x[6]
    vv = x[7]
    vw = x[8]
    vp = x[9]
    vq = x[10]
    vr = x[11]

    cf = math.cos(phi)
    sf = math.sin(phi)
    ct = math.cos(theta)
    st = math.sin(theta)
    cp = math.cos(psi)
    sp = math.sin(psi)
    tt = st / ct

    # --- kinematics, eq. (6): eta' = R w_lin, T w_ang (+ NED current)
    w0 = vu + p[_VCB]
    w1 = vv + p[_VCB + 1]
    w2 = vw + p[_VCB + 2]
    w3 = vp + p[_VCB + 3]
    w4 = vq + p[_VCB + 4]
    w5 = vr + p[_VCB + 5]
    out[0] = cp * ct * w0 + (-sp * cf + cp * st * sf) * w1 + (sp * sf + cp * cf * st) * w2
    out[1] = sp * ct * w0 + (cp * cf + sf * st * sp) * w1 + (-cp * sf + st * sp * cf) * w2
    out[2] = -st * w0 + ct * sf * w1 + ct * cf * w2
    out[3] = w3 + sf * tt * w4 + cf * tt * w5
    out[4] = cf * w4 - sf * w5
    out[5] = (sf * w4 + cf * w5) / ct
    for k in range(6):
        out[k] += p[_VCN + k]

    # --- (a, b) = M v, for C(v) v = [nu2 x a; nu1 x a + nu2 x b]
    a0, a1, a2, b0, b1, b2 = _mass_times_v(x, p)

    # --- restoring force with the sign of eq. (5): [(W-B) k; (W r_G - B r_B) x k]
    wgt = p[_W]
    buoy = p[_BUOY]
    kx = -st
    ky = ct * sf
    kz = ct * cf
    hx = wgt * p[_RG] - buoy * p[_RB]
    hy = wgt * p[_RG + 1] - buoy * p[_RB + 1]
    hz = wgt * p[_RG + 2] - buoy * p[_RB + 2]
    wb = wgt - buoy

    # generalized force r = -C v - D v + g + tau_c (thrust added below)
    r0 = -(vq * a2 - vr * a1) + wb * kx + p[_TAUC] - _damping_row(x, p, 0)
    r1 = -(vr * a0 - vp * a2) + wb * ky + p[_TAUC + 1] - _damping_row(x, p, 1)
    r2 = -(vp * a1 - vq * a0) + wb * kz + p[_TAUC + 2] - _damping_row(x, p, 2)
    r3 = (
        -(vv * a2 - vw * a1 + vq * b2 - vr * b1)
        + (hy * kz - hz * ky)
        + p[_TAUC + 3]
        - _damping_row(x, p, 3)
    )
    r4 = (
        -(vw * a0 - vu * a2 + vr * b0 - vp * b2)
        + (hz * kx - hx * kz)
        + p[_TAUC + 4]
        - _damping_row(x, p, 4)
    )
    r5 = (
        -(vu * a1 - vv * a0 + vp * b1 - vq * b0)
        + (hx * ky - hy * kx)
        + p[_TAUC + 5]
        - _damping_row(x, p, 5)
    )

    # --- commanded wrench, tau of eq. (5) given directly (thrusters bypassed)
    if p[_WRENCH] > 0.5:
        r0 += u[0]
        r1 += u[1]
        r2 += u[2]
        r3 += u[3]
        r4 += u[4]
        r5 += u[5]

    # --- thrusters, eq. (7), tau = B T
    for i in range(nt):
        n = x[12 + i] if lag else _saturate(u[i], n_max)
        c0, c1, c2, c3, c4, c5, va = _thruster_column(x, p, i)
        thrust = k1 * n * abs(n) - k2 * va * abs(n)
        r0 += c0 * thrust
        r1 += c1 * thrust
        r2 += c2 * thrust
        r3 += c3 * thrust
        r4 += c4 * thrust
        r5 += c5 * thrust

    for k in range(6):
        row = _MINV + 6 * k
        out[6 + k] = (
            p[row] * r0
            + p[row + 1] * r1
            + p[row + 2] * r2
            + p[row + 3] * r3
            + p[row + 4] * r4
            + p[row + 5] * r5
        )

    if lag:
        inv_tn = 1.0 / p[_TN]
        for i in range(nt):
            out[12 + i] = (_saturate(u[i], n_max) - x[12 + i]) * inv_tn


def vehicle_switch(t, x, u, p, out):
    """Switching values: zero where f is not smooth, one state at a time.

    out (6 + 3 N): the body velocities (|v| v damping), the rpm inside n |n| (lag
    states, or the inputs without the lag option), then u_i - n_max and u_i + n_max
    (the saturation's corners).
    """
    nt = int(p[_N])
    lag = p[_LAG] > 0.5
    n_max = p[_NMAX]
    for k in range(6):
        out[k] = x[6 + k]
    for i in range(nt):
        out[6 + i] = x[12 + i] if lag else u[i]
        out[6 + nt + i] = u[i] - n_max
        out[6 + 2 * nt + i] = u[i] + n_max


def _minv_column(p, out, col, c0, c1, c2, c3, c4, c5):
    """out[6:12, col] = M^-1 (c0..c5)."""
    for k in range(6):
        row = _MINV + 6 * k
        out[6 + k, col] = (
            p[row] * c0
            + p[row + 1] * c1
            + p[row + 2] * c2
            + p[row + 3] * c3
            + p[row + 4] * c4
            + p[row + 5] * c5
        )


def _thrust_column(x, p, out, col, i, n):
    """out[6:12, col] = M^-1 B[:, i] dT_i/dn with dT/dn = 2 K1 |n| - K2 v_a sign(n)."""
    c0, c1, c2, c3, c4, c5, va = _thruster_column(x, p, i)
    sign = 1.0 if n > 0 else (-1.0 if n < 0 else 0.0)
    s = 2.0 * p[_K1] * abs(n) - p[_K2] * va * sign
    _minv_column(p, out, col, c0 * s, c1 * s, c2 * s, c3 * s, c4 * s, c5 * s)


def _velocity_column(x, u, p, out, j, ab):
    """out[6:12, 6 + j] = M^-1 column j of -(d(C(v) v)/dv + d(D(v) v)/dv) + d tau/dv
    (eqs. (13) and (16)); ``ab`` = M v as its two 3-vectors."""
    nt = int(p[_N])
    lag = p[_LAG] > 0.5
    k2 = p[_K2]
    n_max = p[_NMAX]
    a0, a1, a2, b0, b1, b2 = ab
    vu = x[6]
    vv = x[7]
    vw = x[8]
    vp = x[9]
    vq = x[10]
    vr = x[11]
    # column j of d(C v)/dv = [S(nu2) M_top; S(nu1) M_top + S(nu2) M_bot]_j + extra
    m0 = p[_M + j]
    m1 = p[_M + 6 + j]
    m2 = p[_M + 12 + j]
    n0 = p[_M + 18 + j]
    n1 = p[_M + 24 + j]
    n2 = p[_M + 30 + j]
    d0 = vq * m2 - vr * m1
    d1 = vr * m0 - vp * m2
    d2 = vp * m1 - vq * m0
    d3 = vv * m2 - vw * m1 + vq * n2 - vr * n1
    d4 = vw * m0 - vu * m2 + vr * n0 - vp * n2
    d5 = vu * m1 - vv * m0 + vp * n1 - vq * n0
    # the derivative through the explicit nu1 / nu2 factors: e_k x a (and e_k x b)
    if j == 0:
        d4 -= a2
        d5 += a1
    elif j == 1:
        d3 += a2
        d5 -= a0
    elif j == 2:
        d3 -= a1
        d4 += a0
    elif j == 3:
        d1 -= a2
        d2 += a1
        d4 -= b2
        d5 += b1
    elif j == 4:
        d0 += a2
        d2 -= a0
        d3 += b2
        d5 -= b0
    else:
        d0 -= a1
        d1 += a0
        d3 -= b1
        d4 += b0
    # damping: d(D(v) v)/dv = D_l + diag(2 d_q |v|)
    c0 = -d0 - p[_DL + j]
    c1 = -d1 - p[_DL + 6 + j]
    c2 = -d2 - p[_DL + 12 + j]
    c3 = -d3 - p[_DL + 18 + j]
    c4 = -d4 - p[_DL + 24 + j]
    c5 = -d5 - p[_DL + 30 + j]
    dq = 2.0 * p[_DQ + j] * abs(x[6 + j])
    if j == 0:
        c0 -= dq
    elif j == 1:
        c1 -= dq
    elif j == 2:
        c2 -= dq
    elif j == 3:
        c3 -= dq
    elif j == 4:
        c4 -= dq
    else:
        c5 -= dq
    # thrusters: d tau / dv = -K2 B diag(|n|) B^T, eq. (16)
    for i in range(nt):
        n = x[12 + i] if lag else _saturate(u[i], n_max)
        s = -k2 * abs(n) * p[_ALLOC + 6 * i + j]
        c0 += p[_ALLOC + 6 * i + 0] * s
        c1 += p[_ALLOC + 6 * i + 1] * s
        c2 += p[_ALLOC + 6 * i + 2] * s
        c3 += p[_ALLOC + 6 * i + 3] * s
        c4 += p[_ALLOC + 6 * i + 4] * s
        c5 += p[_ALLOC + 6 * i + 5] * s
    _minv_column(p, out, 6 + j, c0, c1, c2, c3, c4, c5)


def vehicle_jac(t, x, u, p, out):
    """df/dx for one state; writes ``out`` (shape (nx, nx)).

    Blocks: eta rows (eqs. (17)-(18)), v rows (eqs. (13)-(16)), lag rows (eq. (3)).
    """
    nt = int(p[_N])
    lag = p[_LAG] > 0.5
    nx = out.shape[0]
    for i in range(nx):
        for j in range(nx):
            out[i, j] = 0.0

    phi = x[3]
    theta = x[4]
    psi = x[5]
    cf = math.cos(phi)
    sf = math.sin(phi)
    ct = math.cos(theta)
    st = math.sin(theta)
    cp = math.cos(psi)
    sp = math.sin(psi)
    tt = st / ct
    ict = 1.0 / ct

    w0 = x[6] + p[_VCB]
    w1 = x[7] + p[_VCB + 1]
    w2 = x[8] + p[_VCB + 2]
    w4 = x[10] + p[_VCB + 4]
    w5 = x[11] + p[_VCB + 5]

    # --- d f_eta / d v = J(eta), eq. (17)
    out[0, 6] = cp * ct
    out[0, 7] = -sp * cf + cp * st * sf
    out[0, 8] = sp * sf + cp * cf * st
    out[1, 6] = sp * ct
    out[1, 7] = cp * cf + sf * st * sp
    out[1, 8] = -cp * sf + st * sp * cf
    out[2, 6] = -st
    out[2, 7] = ct * sf
    out[2, 8] = ct * cf
    out[3, 9] = 1.0
    out[3, 10] = sf * tt
    out[3, 11] = cf * tt
    out[4, 10] = cf
    out[4, 11] = -sf
    out[5, 10] = sf * ict
    out[5, 11] = cf * ict

    # --- d f_eta / d eta = d(J(eta) w)/d eta, eq. (18)
    # d R / d phi
    out[0, 3] = (sp * sf + cp * cf * st) * w1 + (sp * cf - cp * sf * st) * w2
    out[1, 3] = (-cp * sf + cf * st * sp) * w1 + (-cp * cf - st * sp * sf) * w2
    out[2, 3] = ct * cf * w1 - ct * sf * w2
    # d R / d theta
    out[0, 4] = -cp * st * w0 + cp * ct * sf * w1 + cp * cf * ct * w2
    out[1, 4] = -sp * st * w0 + sf * ct * sp * w1 + ct * sp * cf * w2
    out[2, 4] = -ct * w0 - st * sf * w1 - st * cf * w2
    # d R / d psi
    out[0, 5] = -sp * ct * w0 + (-cp * cf - sp * st * sf) * w1 + (cp * sf - sp * cf * st) * w2
    out[1, 5] = cp * ct * w0 + (-sp * cf + sf * st * cp) * w1 + (sp * sf + st * cp * cf) * w2
    # d T / d phi
    out[3, 3] = cf * tt * w4 - sf * tt * w5
    out[4, 3] = -sf * w4 - cf * w5
    out[5, 3] = (cf * w4 - sf * w5) * ict
    # d T / d theta
    ict2 = ict * ict
    out[3, 4] = (sf * w4 + cf * w5) * ict2
    out[5, 4] = (sf * w4 + cf * w5) * st * ict2

    # --- d f_v / d eta = M^-1 d g / d eta, eq. (14)
    wgt = p[_W]
    buoy = p[_BUOY]
    wb = wgt - buoy
    hx = wgt * p[_RG] - buoy * p[_RB]
    hy = wgt * p[_RG + 1] - buoy * p[_RB + 1]
    hz = wgt * p[_RG + 2] - buoy * p[_RB + 2]
    # dk/dphi = (0, ct cf, -ct sf)
    kx = 0.0
    ky = ct * cf
    kz = -ct * sf
    _minv_column(
        p,
        out,
        3,
        wb * kx,
        wb * ky,
        wb * kz,
        hy * kz - hz * ky,
        hz * kx - hx * kz,
        hx * ky - hy * kx,
    )
    # dk/dtheta = (-ct, -st sf, -st cf)
    kx = -ct
    ky = -st * sf
    kz = -st * cf
    _minv_column(
        p,
        out,
        4,
        wb * kx,
        wb * ky,
        wb * kz,
        hy * kz - hz * ky,
        hz * kx - hx * kz,
        hx * ky - hy * kx,
    )

    # --- d f_v / d v, eqs. (13) and (16)
    ab = _mass_times_v(x, p)
    for j in range(6):
        _velocity_column(x, u, p, out, j, ab)

    if lag:
        # d f_v / d n = M^-1 B diag(dT/dn), and the lag rows, eq. (3)
        inv_tn = 1.0 / p[_TN]
        for i in range(nt):
            _thrust_column(x, p, out, 12 + i, i, x[12 + i])
            out[12 + i, 12 + i] = -inv_tn


def vehicle_input_jac(t, x, u, p, out):
    """df/du for one state; writes ``out`` (shape (nx, nu)).

    d sat(u)/du is 1 on [-n_max, n_max] and 0 outside. Without the lag option the
    input enters through the thrust, column i = M^-1 B[:, i] dT_i/dn; with it only
    the lag row, d n_i'/d u_i = 1/T_n. A wrench input enters linearly: df_v/dtau =
    M^-1.
    """
    nt = int(p[_N])
    lag = p[_LAG] > 0.5
    n_max = p[_NMAX]
    for a in range(out.shape[0]):
        for b in range(out.shape[1]):
            out[a, b] = 0.0
    if p[_WRENCH] > 0.5:
        for k in range(6):
            for j in range(6):
                out[6 + k, j] = p[_MINV + 6 * k + j]
    for i in range(nt):
        inside = 1.0 if abs(u[i]) <= n_max else 0.0
        if lag:
            out[12 + i, i] = inside / p[_TN]
        elif inside > 0.0:
            _thrust_column(x, p, out, i, i, u[i])
