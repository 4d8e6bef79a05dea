"""The vehicle's f against a straight-line reference kernel written here (issue 23).

Run:  python benchmarks/bench_kernels.py [--vehicle rexrov] [--n 50001] [--rounds 9]
      [--json PATH]

The **reference** is written by this script from the vehicle's public matrices
(``mass_matrix``, ``minv``, ``linear_damping_matrix``, ``quadratic_damping``,
``allocation``, ``weight``, ``buoyancy``, ``r_G``, ``r_B``, ``K1``, ``K2``, ``n_max``)
with Fossen's formulas of eqs. (5)-(7), not with the library's generator: every number
a literal in the code, every product with a zero left out, plain numba (no fastmath),
one loop over the states with the body inline. It must equal ``model.f`` to rounding
(printed: the largest difference in eps of the largest value of its component).

Rows, each a ratio of two CPU timings of the same run (interleaved repeats, minima), on
``--n`` random states of the Fig. 7 model (RexROV, +1 % buoyancy):

* ``model.f`` on the batch / the reference on the batch (target <= 1.3x);
* one f inside a compiled loop, the kernel called through a function pointer with work
  arrays as the exact-sample integrator calls it (the loop's copies into and out of
  them included, and printed alone) / the reference per state (target <= 1.5x);
* an RK4 stage: RK4's one-step prediction on samples, per f it evaluates (4 per
  sample: stage points, f, the increment) / the reference per state (target <= 1.5x).

:func:`reference_cost` is also what ``bench_fig7.py`` prices the study's f floor with.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from _rows import row, write_json
from numba import njit, types

import sampledyn as sd
from sampledyn.models._base import RHS_TYPE, RO1, RO2, readonly


# -------------------------------------------------------------- the reference writer
def _lit(v: float) -> str:
    return repr(float(v))


def _dot(coeffs: Any, names: list[str]) -> str:
    """sum_j c_j * names_j without the zero c_j ("0.0" if all are zero)."""
    terms = [f"{_lit(c)} * {n}" for c, n in zip(coeffs, names, strict=True) if c != 0.0]
    return " + ".join(terms) if terms else "0.0"


def reference_source(v: Any) -> str:
    """Source of ``ref_batch(x, u, out)``: f of vehicle ``v`` for every row of x, u.

    Fossen's form: eta' = J(eta) v (eq. 6); v' = M^-1 (tau - C(v) v - D(v) v + g(eta)),
    C(v) v = [w x a; v_lin x a + w x b] with (a, b) = M v (Fossen 2011, eq. 3.46),
    D(v) v = D_l v + d_q |v| v, g = [(W - B) k; (W r_G - B r_B) x k] with
    k = (-sin theta, cos theta sin phi, cos theta cos phi) (the paper's sign), tau = B T,
    T_i = K1 n_i |n_i| - K2 v_a,i |n_i|, n_i = clip(u_i, -n_max, n_max) (eq. 7).
    """
    if any(c != 0.0 for c in (*v.current, *v.cable_force)) or v.thruster_lag or v.wrench_input:
        raise ValueError("the reference covers the open-loop vehicle without current/cable/lag")
    M, Minv, Dl = v.mass_matrix, v.minv, v.linear_damping_matrix
    dq, B = np.asarray(v.quadratic_damping), v.allocation
    W, Bu = v.weight, v.buoyancy
    h = W * np.asarray(v.r_G) - Bu * np.asarray(v.r_B)
    vel = ["vu", "vv", "vw", "vp", "vq", "vr"]
    body = [
        "cf = math.cos(x[k, 3])", "sf = math.sin(x[k, 3])", "ct = math.cos(x[k, 4])",
        "st = math.sin(x[k, 4])", "cp = math.cos(x[k, 5])", "sp = math.sin(x[k, 5])",
        *(f"{n} = x[k, {6 + j}]" for j, n in enumerate(vel)),
        "out[k, 0] = cp * ct * vu + (cp * st * sf - sp * cf) * vv + (sp * sf + cp * cf * st) * vw",
        "out[k, 1] = sp * ct * vu + (cp * cf + sp * st * sf) * vv + (sp * st * cf - cp * sf) * vw",
        "out[k, 2] = -st * vu + ct * sf * vv + ct * cf * vw",
        "out[k, 3] = vp + (sf * vq + cf * vr) * st / ct",
        "out[k, 4] = cf * vq - sf * vr",
        "out[k, 5] = (sf * vq + cf * vr) / ct",
        *(f"{n} = {_dot(M[i], vel)}" for i, n in enumerate(["a0", "a1", "a2", "b0", "b1", "b2"])),
        "kx = -st", "ky = ct * sf", "kz = ct * cf",
    ]  # fmt: skip
    for i in range(B.shape[1]):
        body += [f"n{i} = min(max(u[k, {i}], {_lit(-v.n_max)}), {_lit(v.n_max)})",
                 f"T{i} = {_lit(v.K1)} * n{i} * abs(n{i})"]  # fmt: skip
        if v.K2 != 0.0:
            body.append(f"T{i} -= {_lit(v.K2)} * ({_dot(B[:, i], vel)}) * abs(n{i})")
    cor = ["vq * a2 - vr * a1", "vr * a0 - vp * a2", "vp * a1 - vq * a0",
           "vv * a2 - vw * a1 + vq * b2 - vr * b1", "vw * a0 - vu * a2 + vr * b0 - vp * b2",
           "vu * a1 - vv * a0 + vp * b1 - vq * b0"]  # fmt: skip
    g = [f"{_lit(W - Bu)} * kx", f"{_lit(W - Bu)} * ky", f"{_lit(W - Bu)} * kz",
         f"{_lit(h[1])} * kz - {_lit(h[2])} * ky", f"{_lit(h[2])} * kx - {_lit(h[0])} * kz",
         f"{_lit(h[0])} * ky - {_lit(h[1])} * kx"]  # fmt: skip
    thr = [f"T{i}" for i in range(B.shape[1])]
    for r in range(6):
        damp = _dot(Dl[r], vel) + (f" + {_lit(dq[r])} * abs({vel[r]}) * {vel[r]}" if dq[r] else "")
        body.append(f"r{r} = {_dot(B[r], thr)} + {g[r]} - ({cor[r]}) - ({damp})")
    rs = [f"r{r}" for r in range(6)]
    body += [f"out[k, {6 + r}] = {_dot(Minv[r], rs)}" for r in range(6)]
    lines = "\n".join(f"        {b}" for b in body)
    return (
        "import math\nfrom numba import njit\n\n\n@njit(cache=False)\n"
        f"def ref_batch(x, u, out):\n    for k in range(x.shape[0]):\n{lines}\n"
    )


def reference_kernel(v: Any) -> Callable[..., None]:
    """The compiled reference ``ref_batch(x, u, out)`` of vehicle ``v``."""
    folder = Path(tempfile.mkdtemp(prefix="sampledyn-bench-ref-"))
    path = folder / "reference_kernel.py"
    path.write_text(reference_source(v))
    spec = importlib.util.spec_from_file_location("reference_kernel", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.ref_batch


# ------------------------------------------------------------------------- timing
def interleaved(fns: dict[str, Callable[[], object]], rounds: int) -> dict[str, float]:
    """Minimum CPU time (s) of each function over ``rounds`` interleaved rounds (CPU
    time of this process: single-threaded code, so time spent descheduled on a loaded
    machine does not count)."""
    best = dict.fromkeys(fns, float("inf"))
    for _ in range(rounds):
        for name, fn in fns.items():
            t0 = time.process_time()
            fn()
            best[name] = min(best[name], time.process_time() - t0)
    return best


@njit(types.float64[:, ::1](RHS_TYPE, RO1, RO2, RO2, RO1), cache=False)
def integrator_calls(rhs, t, x, u, p):  # pragma: no cover - compiled
    """f at every row through a function pointer, called as the exact-sample
    integrator calls it: state, input and output in work arrays of its own."""
    n, nx = x.shape
    nu = u.shape[1]
    out = np.empty((n, nx))
    y = np.empty(nx)
    ui = np.empty(nu)
    k = np.empty(nx)
    for i in range(n):
        for j in range(nx):
            y[j] = x[i, j]
        for j in range(nu):
            ui[j] = u[i, j]
        rhs(t[i], y, ui, p, k)
        for j in range(nx):
            out[i, j] = k[j]
    return out


@njit(types.float64[:, ::1](RO2, RO2), cache=False)
def copies_only(x, u):  # pragma: no cover - compiled
    """The copies of :func:`integrator_calls` without the call (printed beside it)."""
    n, nx = x.shape
    nu = u.shape[1]
    out = np.empty((n, nx))
    y = np.empty(nx)
    ui = np.empty(nu)
    for i in range(n):
        for j in range(nx):
            y[j] = x[i, j]
        for j in range(nu):
            ui[j] = u[i, j]
        for j in range(nx):
            out[i, j] = y[j] + ui[j % nu]
    return out


def fig7_model(name: str = "rexrov") -> Any:
    """The Fig. 7 model (the RexROV, +1 % buoyancy), or another built-in vehicle so."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the RexROV file's added-mass symmetry note
        return sd.models.load_vehicle(name).with_buoyancy(1.0)


def random_states(v: Any, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """States and inputs of the Fig. 7 run's size: angles within +-0.5 rad, velocities
    within +-0.5, rpm within +-1.2 n_max (some saturated)."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-0.5, 0.5, size=(n, v.nx))
    u = rng.uniform(-1.2 * v.n_max, 1.2 * v.n_max, size=(n, v.nu))
    return np.zeros(n), x, u


def reference_cost(v: Any, n: int = 50_001, rounds: int = 9) -> float:
    """Seconds per state of the reference kernel (minimum of interleaved rounds)."""
    ref = reference_kernel(v)
    _, x, u = random_states(v, n)
    out = np.empty_like(x)
    ref(x, u, out)
    return interleaved({"ref": lambda: ref(x, u, out)}, rounds)["ref"] / n


def agreement(f: np.ndarray, ref: np.ndarray) -> float:
    """max |f - ref| in units of eps times the largest |ref| of its component over the
    batch."""
    scale = np.abs(ref).max(axis=0, keepdims=True)
    return float(np.max(np.abs(f - ref) / scale) / np.finfo(float).eps)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--n", type=int, default=50_001, help="states in the batch")
    ap.add_argument("--rounds", type=int, default=9, help="interleaved rounds")
    ap.add_argument("--vehicle", default="rexrov", help="built-in vehicle (rows: the RexROV)")
    ap.add_argument("--json", help="write the table rows here")
    args = ap.parse_args()
    v = fig7_model(args.vehicle)
    t, x, u = random_states(v, args.n)
    ref = reference_kernel(v)
    out = np.empty_like(x)
    ref(x, u, out)
    f = v.f(t, x, u)
    ulps = agreement(f, out)
    print(
        f"Fig. 7 model (RexROV, +1 % buoyancy), {args.n} random states; model.f against the "
        f"reference: largest difference {ulps:.2f} eps of its component's largest value"
    )

    rhs, p = v.kernel()
    rt, rx, ru, rp = readonly(t), readonly(x), readonly(u), readonly(p)
    same = np.array_equal(integrator_calls(rhs, rt, rx, ru, rp), f)
    copies_only(rx, ru)
    data = sd.Trajectory(np.arange(args.n) * 0.1, x, u, 0.1, v.state_names, v.state_units)
    rk4 = sd.methods.get_method("RK4")
    rk4.predict(v, data)
    best = interleaved(
        {
            "reference": lambda: ref(x, u, out),
            "model.f": lambda: v.f(t, x, u),
            "function pointer": lambda: integrator_calls(rhs, rt, rx, ru, rp),
            "copies": lambda: copies_only(rx, ru),
            "RK4": lambda: rk4.predict(v, data),
        },
        args.rounds,
    )
    n = args.n
    per = {k: s / n * 1e9 for k, s in best.items()}
    per["RK4"] /= 4
    copies = per.pop("copies")
    load = os.getloadavg()[0]
    print(f"  (f through the function pointer equal to model.f bit for bit: {same})")
    for k, ns in per.items():
        print(f"  {k:<18s} {ns:7.1f} ns per f   ({ns / per['reference']:.2f}x the reference)")
    print(f"  (the function-pointer loop's own copies alone: {copies:.1f} ns per state, "
          f"included above; load average {load:.2f})")  # fmt: skip
    r_f = per["model.f"] / per["reference"]
    r_ptr = per["function pointer"] / per["reference"]
    r_rk = per["RK4"] / per["reference"]
    where = f"{args.vehicle}, {n} states; reference {per['reference']:.0f} ns"
    rows = [
        row("`model.f` on the RexROV (50,001 states) / straight-line reference kernel, same run",
            r_f, f"{r_f:.2f}x ({per['model.f']:.0f} / {per['reference']:.0f} ns)", "<= 1.3x",
            r_f <= 1.3, where=where, eps=ulps),
        row("one f inside the integrator (compiled loop, function pointer) / the reference",
            r_ptr, f"{r_ptr:.2f}x ({per['function pointer']:.0f} ns)", "<= 1.5x", r_ptr <= 1.5,
            where=where),
        row("one f inside the RK stages (RK4 prediction per f) / the reference", r_rk,
            f"{r_rk:.2f}x ({per['RK4']:.0f} ns)", "<= 1.5x", r_rk <= 1.5, where=where),
    ]  # fmt: skip
    write_json(args.json, "bench_kernels", rows)


if __name__ == "__main__":
    main()
