"""Methods benchmark: method speed on the Fig. 7 run (issue 14), the cost of asking the
method object, of the held-input rules, and of predicting on non-uniform time.

Run:  python benchmarks/bench_methods.py [--fig7-T 5000] [--T 200] [--h 0.01] [--rounds 7]
      [--fig7-only] [--json PATH]

Every number is a ratio of timings taken in the same run on the same samples,
interleaved (``--rounds`` rounds, the minimum of each), so it does not depend on the
speed of the (shared, noisy) machine.

**Issue 14 rows** (the Fig. 7 model: RexROV open loop, +1 % buoyancy, Fig. 6 thruster
input, h = 0.1 s, T = 5000 s: 50,001 samples):

* AB4 one-step prediction in samples/s, and AB4 / E;
* RK4 / (4 x f alone, batched on the samples), with the sampled input held (the rule's
  own cost) and with the Fig. 6 signal at the stage times (as ``reproduce fig7``; the
  signal's evaluation is extra work, reported separately);
* T / AB4, and how far T's predictions are from the fully converged trapezoid
  solution (Newton iterated to rounding), in units of the Newton tolerance;
* the same rules on the same samples with their stamps jittered by +-0.5 ms (the
  variable-step code), against the uniform stamps.

**API costs** (the AUV-like system, eqs. (9)-(10), multilevel input):

* a rule's ``predict`` with a warm shared ``cache`` against the bare AB filter on
  precomputed f: the price of the grid check and the cache lookup;
* AB1-AB6 predicted with one shared cache against each computing f itself;
* ABu_s and ABj_s against AB_s (extra f evaluations where the input changed).
"""

from __future__ import annotations

import argparse
import time
import warnings
from collections.abc import Callable

import numpy as np
from _rows import row, write_json

import sampledyn as sd
from sampledyn.methods import get_method
from sampledyn.methods._adams import ab_filter
from sampledyn.methods._base import grid_steps


def best_of(fn, repeat=7):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def interleaved(fns: dict[str, Callable[[], object]], rounds: int) -> dict[str, float]:
    """Minimum time (s) of each function over ``rounds`` rounds, one call each per round."""
    best = {k: float("inf") for k in fns}
    for _ in range(rounds):
        for k, fn in fns.items():
            t0 = time.perf_counter()
            fn()
            best[k] = min(best[k], time.perf_counter() - t0)
    return best


def trapezoid_reference(model, data, x_hat):
    """The trapezoid solution iterated by full Newton steps from ``x_hat`` until the
    updates stop shrinking (rounding level): the reference for T's accuracy."""
    h_fixed, steps = grid_steps(data)  # the steps the rule takes (h itself if uniform)
    t0, x0, u = data.t[:-1], data.x[:-1], data.u[:-1]
    t1 = t0 + h_fixed if h_fixed is not None else data.t[1:]
    h = steps[:, None]
    f0 = model.f(t0, x0, u)
    x = np.array(x_hat[1:])
    eye = np.eye(data.nx)
    for _ in range(4):
        g = x - x0 - 0.5 * h * (f0 + model.f(t1, x, u))
        jac = eye - 0.5 * h[:, :, None] * model.jacobian(t1, x, u)
        x = x - np.linalg.solve(jac, g[..., None])[..., 0]
    return x


def fig7_rows(T: float, rounds: int) -> list[dict]:
    """The issue 14 rows on the Fig. 7 model (see the module docstring); printed, and
    returned as table rows."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the RexROV file's added-mass symmetry note
        vehicle = sd.models.load_vehicle("rexrov").with_buoyancy(1.0)
    signal = sd.signals.fig6_thrusters(vehicle)
    t0 = time.perf_counter()
    data = sd.simulate(vehicle, signal, T=T, h=0.1, certify=False)
    print(
        f"Fig. 7 model (RexROV open loop, +1 % buoyancy, Fig. 6 input), h = 0.1 s, T = {T:g} s: "
        f"{data.n_samples} samples (simulated in {time.perf_counter() - t0:.1f} s)"
    )
    rng = np.random.default_rng(0)
    jitter = data.t + rng.uniform(-5e-4, 5e-4, data.n_samples)
    jitter[0] = 0.0
    jittered = data.replace(t=jitter)  # the variable-step code on the same states
    rules = {n: get_method(n) for n in ("E", "AB4", "RK4", "T")}
    for m in rules.values():  # compile, warm caches
        m.predict(vehicle, data)
        m.predict(vehicle, jittered)
        m.predict(vehicle, data, signal)
    fns: dict[str, Callable[[], object]] = {
        "f": lambda: vehicle.f(data.t, data.x, data.u),
        **{n: (lambda m=m: m.predict(vehicle, data)) for n, m in rules.items()},
        "RK4 + signal": lambda: rules["RK4"].predict(vehicle, data, signal),
        "signal at stages": lambda: [signal.intersample(data.t[:-1], c) for c in (0.05, 0.1)],
        **{f"{n} jittered": (lambda m=m: m.predict(vehicle, jittered)) for n, m in rules.items()},
    }
    best = interleaved(fns, rounds)
    n = data.n_samples
    rows = [
        ("AB4 one-step prediction", f"{n / best['AB4'] / 1e6:.2f} M samples/s", ">= 5 M/s"),
        ("AB4 / E", f"{best['AB4'] / best['E']:.2f}", "<= 1.1"),
        (
            "RK4 / (4 x f alone, batched), input held",
            f"{best['RK4'] / (4 * best['f']):.2f}",
            "<= 1.15",
        ),
        (
            "RK4 with the Fig. 6 signal / (4 x f + signal at the stage times)",
            f"{best['RK4 + signal'] / (4 * best['f'] + best['signal at stages']):.2f}",
            "",
        ),
        (
            "T / AB4 (50k samples)" if n > 40000 else "T / AB4",
            f"{best['T'] / best['AB4']:.1f}",
            "<= 15",
        ),
    ]
    for name in rules:
        rows.append(
            (
                f"{name}: jittered stamps / uniform stamps",
                f"{best[name + ' jittered'] / best[name]:.2f}",
                "",
            )
        )
    x_t = rules["T"].predict(vehicle, data)
    ref = trapezoid_reference(vehicle, data, x_t)
    dev = float(np.max(np.abs(x_t[1:] - ref) / (1.0 + np.abs(ref))))
    tol = rules["T"].tol
    rows.append(
        ("T: max |x - trapezoid| / (1 + |x|)", f"{dev:.1e} (= {dev / tol:.2f} tol)", "<= tol")
    )
    width = max(len(r[0]) for r in rows)
    print(f"  {'measure':{width}s}  {'value':>22s}  target")
    for label, value, target in rows:
        print(f"  {label:{width}s}  {value:>22s}  {target}")
    ms = best["f"] * 1e3
    print(f"  (f alone: {ms:.1f} ms per batch of {n}; one run on a shared machine: noisy)")
    ab4 = n / best["AB4"] / 1e6
    ab4_e = best["AB4"] / best["E"]
    rk4 = best["RK4"] / (4 * best["f"])
    t_ab4 = best["T"] / best["AB4"]
    where = f"RexROV Fig. 7 run, {n} samples"
    return [
        row("T one-step prediction, 50k samples, time / AB4's", t_ab4, f"{t_ab4:.1f}x",
            "<= 15x", t_ab4 <= 15.0, where=where, t_vs_trapezoid_tol=dev / tol),
        row("RK4 one-step prediction, time / (4 x f alone, batched)", rk4, f"{rk4:.2f}x",
            "<= 1.15x", rk4 <= 1.15, where=where),
        row("AB4 one-step prediction", ab4, f"{ab4:.2f} M samples/s", ">= 5 M/s", ab4 >= 5.0,
            where=where),
        row("AB4 / E (one-step prediction)", ab4_e, f"{ab4_e:.2f}", "<= 1.1", ab4_e <= 1.1,
            where=where),
    ]  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--T", type=float, default=200.0)
    parser.add_argument("--h", type=float, default=0.01)
    parser.add_argument("--fig7-T", type=float, default=5000.0)
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--fig7-only", action="store_true", help="only the issue 14 rows")
    parser.add_argument("--json", help="write the issue 14 rows here")
    args = parser.parse_args()
    rows = fig7_rows(args.fig7_T, args.rounds)
    write_json(args.json, "bench_methods", rows)
    if args.fig7_only:
        return
    print()
    model = sd.models.AUVLike()
    runs = {}
    for ratio in (1, 10, 100):
        signal = sd.signals.Multilevel(-10.0, 10.0, hold=ratio * args.h, seed=0)
        runs[ratio] = sd.simulate(model, signal, T=args.T, h=args.h, x0=np.array([1.0, 0.0]))
    data = runs[10]
    print(f"AUV-like, {data.n_samples} samples, h = {args.h} s")

    f = model.f(data.t, data.x, data.u)
    cache: dict = {}
    ab4 = get_method("AB4")
    ab4.predict(model, data, cache=cache)  # warm: compiled filter, cached f
    bare = best_of(lambda: ab_filter(data.x, f, data.h, ab4.weights))
    asked = best_of(lambda: ab4.predict(model, data, cache=cache))
    print(f"AB4.predict (warm cache) / bare ab_filter:          {asked / bare:6.2f}")

    names = [f"AB{s}" for s in range(1, 7)]

    def shared():
        c: dict = {}
        for n in names:
            get_method(n).predict(model, data, cache=c)

    def separate():
        for n in names:
            get_method(n).predict(model, data)

    ratio = best_of(shared) / best_of(separate)
    print(f"AB1-AB6, one shared cache / each its own f:         {ratio:6.2f}")

    print("held-input rules against AB_s (same s), by h_u/h:")
    for ratio, d in runs.items():
        cells = []
        for s in (2, 4, 6):
            ab = best_of(lambda s=s, d=d: get_method(f"AB{s}").predict(model, d), 5)
            abu = best_of(lambda s=s, d=d: get_method(f"ABu{s}").predict(model, d), 5)
            abj = best_of(lambda s=s, d=d: get_method(f"ABj{s}").predict(model, d), 5)
            cells.append(f"s={s}: ABu {abu / ab:5.1f}, ABj {abj / ab:5.1f}")
        print(f"  h_u/h = {ratio:3d}:  " + ";  ".join(cells))


if __name__ == "__main__":
    main()
