"""ROV benchmark (issue: Fig. 7 on the BlueROV2 Heavy).

Run:  python benchmarks/bench_rov.py [--T-scipy 500] [--skip-fig7]

1. Exact samples of the Fig. 7 run (BlueROV2 Heavy with the roll-pitch hold, Fig. 6
   input, +1 % buoyancy, h = 0.1 s) by ``sd.simulate`` against
   ``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-10, atol 1e-12) on the same problem in
   the same run. SciPy integrates the first ``--T-scipy`` seconds (5000 takes many
   minutes here); the ratio is of wall time per simulated second. Accuracy: our
   certificate, and our per-interval flow error checked independently against SciPy at
   rtol 1e-13 on a sample of intervals, those where a velocity or an rpm changes sign
   included (component i scaled by max(1, max_n |x_i|)).
2. One-step prediction throughput of AB1 and AB4 over the 50,000 samples.
3. Wall time of the whole ``sampledyn reproduce fig7`` (its default: the RexROV open
   loop, 10 seeds), in a fresh process; ``benchmarks/bench_fig7.py`` splits it into
   phases (simulate, predict, norms, store, figure).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time

import numpy as np
from scipy.integrate import solve_ivp

import sampledyn as sd
from sampledyn.experiments import fig7_vehicle


def best_of(fn, repeat):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--T-scipy", type=float, default=500.0, help="SciPy horizon (s)")
    ap.add_argument("--checks", type=int, default=300, help="intervals checked against SciPy")
    ap.add_argument("--skip-fig7", action="store_true")
    args = ap.parse_args()

    vehicle = fig7_vehicle(sd.models.load_vehicle("bluerov2_heavy"), 1.0)
    model = sd.models.AttitudeHold(vehicle)
    signal = sd.signals.fig6_thrusters(vehicle)
    T, h = 5000.0, 0.1
    sd.simulate(model, signal, T=1.0, h=h)  # load the compiled kernels

    t_sim = best_of(
        lambda: sd.simulate(model, signal, T=T, h=h, certify=False, rtol=1e-11, atol=1e-11), 2
    )
    t0 = time.perf_counter()
    traj = sd.simulate(model, signal, T=T, h=h, rtol=1e-11, atol=1e-11)
    t_cert = time.perf_counter() - t0
    cert = traj.certificate
    scale = cert.scale

    def rhs(t, x):
        return model.f(t, x, signal(np.array([t]))[0])

    n_sp = int(round(args.T_scipy / h))
    t0 = time.perf_counter()
    sol = solve_ivp(
        rhs,
        (0.0, n_sp * h),
        traj.x[0],
        method="DOP853",
        rtol=1e-10,
        atol=1e-12,
        t_eval=traj.t[: n_sp + 1],
    )
    t_sp = time.perf_counter() - t0
    sp_dev = np.abs((sol.y.T - traj.x[: n_sp + 1]) / scale).max()

    # Independent per-interval check: intervals with a sign change of a velocity or an
    # applied rpm, plus random ones.
    applied = model.applied_rpm(traj.x, traj.u)
    sw = np.sign(np.hstack([traj.x[:, 6:12], applied]))
    kinks = np.flatnonzero((sw[1:] != sw[:-1]).any(axis=1))
    rng = np.random.default_rng(0)
    picks = np.unique(np.concatenate([
        rng.choice(kinks, min(args.checks // 2, kinks.size), replace=False),
        rng.choice(traj.n_samples - 1, args.checks // 2, replace=False),
    ]))  # fmt: skip
    worst = 0.0
    for n in picks:
        r = solve_ivp(
            rhs, (traj.t[n], traj.t[n + 1]), traj.x[n], method="DOP853", rtol=1e-13, atol=1e-14
        )
        worst = max(worst, float(np.abs((r.y[:, -1] - traj.x[n + 1]) / scale).max()))

    per_s_ours = t_sim / T
    per_s_sp = t_sp / (n_sp * h)
    print(f"Exact samples, BlueROV2 Heavy + attitude hold, Fig. 6 input, T = {T:g} s, h = {h} s")
    print(f"  sd.simulate                     {t_sim:8.2f} s  ({cert.steps.sum()} internal steps)")
    print(f"  sd.simulate with certificate    {t_cert:8.2f} s  certificate {cert.max_error:.1e}")
    print(
        f"  solve_ivp DOP853 rtol 1e-10     {t_sp:8.2f} s  for {n_sp * h:g} s "
        f"(max scaled deviation from ours {sp_dev:.1e})"
    )
    print(
        f"  speed ratio per simulated second: {per_s_sp / per_s_ours:.0f}x "
        f"(with certificate {per_s_sp / (t_cert / T):.0f}x)"
    )
    print(
        f"  independent check on {picks.size} intervals ({kinks.size} intervals have a "
        f"sign change; {min(args.checks // 2, kinks.size)} of them checked): max scaled "
        f"per-interval error {worst:.1e}"
    )

    vtraj = traj.replace(u=applied)
    n = vtraj.n_samples
    print(f"\nOne-step prediction on the {n} samples (vehicle model, applied rpm), best of 7:")
    res = {}
    for name in ("AB1", "AB4"):
        sd.predict(name, vehicle, vtraj)
        res[name] = best_of(lambda name=name: sd.predict(name, vehicle, vtraj), 7)
        print(f"  {name}: {res[name] * 1e3:6.1f} ms = {n / res[name] / 1e6:5.2f} M samples/s")
    print(f"  AB4 / AB1 cost: {res['AB4'] / res['AB1']:.2f}")

    if not args.skip_fig7:
        t0 = time.perf_counter()
        subprocess.run(
            [
                sys.executable,
                "-m",
                "sampledyn.cli",
                "reproduce",
                "fig7",
                "--no-progress",
                "--out",
                "out/bench_fig7",
            ],
            check=True,
            stdout=subprocess.DEVNULL,
        )
        print(
            f"\nsampledyn reproduce fig7 (RexROV, 10 seeds), fresh process: "
            f"{time.perf_counter() - t0:.1f} s wall"
        )


if __name__ == "__main__":
    main()
