"""Discrete-time models and the sampled loop: step overhead, rollout, the LQR study.

Run:  python benchmarks/bench_discretize.py [--study] [--mpc] [--json PATH]

Every time is the best of several interleaved repeats, and the step overhead is a
difference against a reference measured in the same run (the shared 2-core machine
changes absolute numbers, not these differences by much):

* ``step``: ``DiscreteModel.step(z, u)`` of AB4 on the RexROV from Python against the
  bare compiled kernel ``vehicle_rhs(t, x, u, p, out)`` called from Python with
  prepared arrays (one f evaluation). Target (issue 12): step - f <= 5 us.
* ``rollout``: ns per sample of ``rollout(measured, k)`` (compiled over all samples)
  against k x the per-sample cost of f over the same samples (batched), AB4 and RK4,
  and ``rollout(measured, 1)`` against ``sd.predict`` with the same rule (issue 14: the
  AB4 rollout evaluates f once per sample, as predict does).
* ``--study``: the LQR closed-loop study of ``sampledyn reproduce closed-loop`` with the
  issue's grid (RexROV and BlueROV2 Heavy, ZOH + 6 rules, h = 0.1 and 0.5 s, 4 noise
  pairs, 5 seeds, 600 s each) in this process: wall time. Target: < 3 min on the
  2-core machine.
* ``--mpc``: the MPC example (``examples/mpc_casadi.py``), timed separately.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from _rows import row, write_json
from bench_models import best_per_call  # the interleaved best-of timer (same folder)

import sampledyn as sd
from sampledyn.models import load_vehicle
from sampledyn.models._base import readonly
from sampledyn.signals import fig6_thrusters


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--study", action="store_true", help="time the LQR closed-loop study")
    parser.add_argument("--mpc", action="store_true", help="time the MPC example")
    parser.add_argument("--json", help="write the issue 14 row here")
    args = parser.parse_args()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        veh = load_vehicle("rexrov").with_buoyancy(1.0)
    rhs, p = veh.kernel()
    rng = np.random.default_rng(0)
    x = readonly(rng.normal(size=12) * 0.1)
    u = readonly(rng.uniform(-0.5, 0.5, 8) * veh.n_max)
    out = np.empty(12)
    d = sd.discretize(veh, "AB4", 0.1)
    z = d.steady_state(np.asarray(x), np.asarray(u))
    d.step(z, u)
    rhs(0.0, x, u, p, out)
    t = best_per_call(
        {"f kernel": lambda: rhs(0.0, x, u, p, out), "AB4 step": lambda: d.step(z, u)}, 5000
    )
    over = 1e6 * (t["AB4 step"] - t["f kernel"])
    print(
        f"step of AB4 on the RexROV: {1e6 * t['AB4 step']:.2f} us; one compiled f from "
        f"Python {1e6 * t['f kernel']:.2f} us; overhead {over:.2f} us (target <= 5 us)"
    )

    exact = sd.simulate(veh, fig6_thrusters(veh), 600.0, 0.1, certify=False)
    meas = sd.add_noise(exact, 2, 2, seed=0)
    n = meas.n_samples
    models = {rule: sd.discretize(veh, rule, 0.1) for rule in ("AB4", "RK4")}
    fns = {"f": lambda: veh.f(meas.t, meas.x, meas.u)}
    for rule, dm in models.items():
        fns[f"predict {rule}"] = lambda rule=rule: sd.predict(rule, veh, meas)
        for k in (1, 10):
            fns[f"{rule} {k}"] = lambda dm=dm, k=k: dm.rollout(meas, k)
    for fn in fns.values():
        fn()  # compile, load
    per = {name: sec / n for name, sec in best_per_call(fns, 2, 7).items()}
    for rule in models:
        for k in (1, 10):
            evals = k * (4 if rule == "RK4" else 1)
            print(
                f"rollout {rule} k={k:2d}: {1e9 * per[f'{rule} {k}']:7.1f} ns/sample = "
                f"{per[f'{rule} {k}'] / (evals * per['f']):.2f} x ({evals} f per sample, "
                f"batched f {1e9 * per['f']:.1f} ns)"
            )
        print(
            f"rollout {rule} k= 1 / predict {rule}: {per[f'{rule} 1'] / per[f'predict {rule}']:.2f}"
        )
    ratio = per["AB4 1"] / per["predict AB4"]
    write_json(args.json, "bench_discretize", [
        row("`discretize(model, \"AB4\", h).rollout(data, 1)` / `predict(\"AB4\")` (RexROV)",
            ratio, f"{ratio:.2f}x ({per['AB4 1'] / per['f']:.2f} f per sample)",
            "one f per sample, as predict (<= 1.3x)", ratio <= 1.3),
    ])  # fmt: skip

    if args.study:
        from sampledyn.experiments import ClosedLoopStudy
        from sampledyn.experiments._closed_loop import run_closed_loop_study, summarize_closed_loop

        study = ClosedLoopStudy()
        t0 = time.perf_counter()
        rows = run_closed_loop_study(study)
        wall = time.perf_counter() - t0
        summarize_closed_loop(rows)
        print(
            f"LQR closed-loop study: {len(rows)} runs ({len(study.vehicles)} vehicles, "
            f"{len(study.methods)} designs, h {study.h}, {len(study.noise_pairs)} noise "
            f"pairs, {study.seeds} seeds, {study.T:g} s each) in {wall:.1f} s (target < 180 s)"
        )
    if args.mpc:
        script = Path(__file__).resolve().parent.parent / "examples" / "mpc_casadi.py"
        t0 = time.perf_counter()
        res = subprocess.run([sys.executable, str(script)], capture_output=True, text=True)
        print(res.stdout.strip() or res.stderr.strip()[-2000:])
        print(f"MPC example (process incl. imports): {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
