"""Foundation benchmark: exact samples against SciPy, and prediction throughput.

Run:  python benchmarks/bench_foundation.py [--T 100] [--h 0.01]

Both integrators solve the same AUV-like problem (eqs. (9)-(10), multilevel input
held for h_u = 5 h) in the same run, so the reported ratio is robust to the speed of
the (shared, noisy) machine. SciPy integrates segment by segment between input jumps
(the fair way to use it with a zero-order-hold input). Accuracy of both is measured
against a third, tighter SciPy run (DOP853, rtol 1e-13, atol 1e-14).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.integrate import solve_ivp

import sampledyn as sd


def scipy_samples(model, signal, t, hold_ratio, rtol, atol):
    x = np.empty((t.size, model.nx))
    x[0] = model_x0
    u = signal(t)
    for a in range(0, t.size - 1, hold_ratio):
        b = min(a + hold_ratio, t.size - 1)
        sol = solve_ivp(
            lambda tt, xx, ua=u[a]: model.f(tt, xx, ua),
            (t[a], t[b]),
            x[a],
            method="DOP853",
            rtol=rtol,
            atol=atol,
            t_eval=t[a : b + 1],
        )
        x[a + 1 : b + 1] = sol.y.T[1:]
    return x


def best_of(fn, repeat):
    times = []
    out = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


model_x0 = np.array([1.0, 0.0])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--T", type=float, default=100.0)
    ap.add_argument("--h", type=float, default=0.01)
    ap.add_argument("--hold-ratio", type=int, default=5)
    args = ap.parse_args()
    model = sd.models.AUVLike()
    signal = sd.signals.Multilevel(hold=args.hold_ratio * args.h, seed=0)
    sd.simulate(model, signal, T=10 * args.h, h=args.h, x0=model_x0)  # JIT warm-up

    t_sd, traj = best_of(
        lambda: sd.simulate(model, signal, T=args.T, h=args.h, x0=model_x0, certify=False), 3
    )
    t_cert, traj_c = best_of(lambda: sd.simulate(model, signal, T=args.T, h=args.h, x0=model_x0), 1)
    t_sp, x_sp = best_of(
        lambda: scipy_samples(model, signal, traj.t, args.hold_ratio, 1e-10, 1e-12), 1
    )
    x_ref = scipy_samples(model, signal, traj.t, args.hold_ratio, 1e-13, 1e-14)
    err_sd = np.abs(traj.x - x_ref).max()
    err_sp = np.abs(x_sp - x_ref).max()
    n = traj.t.size - 1
    print(f"AUV-like, T = {args.T:g} s, h = {args.h:g} s, h_u/h = {args.hold_ratio}: {n} intervals")
    print(f"  sd.simulate (no certificate)   {t_sd * 1e3:9.1f} ms   max |x - ref| = {err_sd:.1e}")
    print(
        f"  sd.simulate (with certificate) {t_cert * 1e3:9.1f} ms   certificate "
        f"{traj_c.certificate.max_error:.1e}"
    )
    print(f"  solve_ivp DOP853 rtol 1e-10    {t_sp * 1e3:9.1f} ms   max |x - ref| = {err_sp:.1e}")
    print(
        f"  speed ratio solve_ivp / sd.simulate = {t_sp / t_sd:.0f}x "
        f"(with certificate: {t_sp / t_cert:.0f}x)"
    )

    print("\nOne-step prediction throughput on the same samples (best of 5):")
    t_e = None
    for name in ("E", "AB4", "RK4", "T"):
        sd.predict(name, model, traj)  # warm-up
        dt, _ = best_of(lambda name=name: sd.predict(name, model, traj), 5)
        t_e = t_e or dt
        print(f"  {name:4s} {traj.t.size / dt / 1e6:7.2f} M samples/s   cost / E = {dt / t_e:5.2f}")


if __name__ == "__main__":
    main()
