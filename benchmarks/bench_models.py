"""Model evaluation from Python: one f call, a batch of one, large batches, kernels.

Run:  python benchmarks/bench_models.py [--n 100000] [--cache] [--json PATH]

Every time is the best of several repeats, and every ratio is against a reference
measured in the same run, so the numbers are robust to the speed of a shared machine:

* ``single``: ``model.f(t, x, u)`` for one state (x shape (nx,)), against the bare
  compiled kernel called from Python with prepared arrays, ``rhs(t, x, u, p, out)``.
  Target (issue "Performance"): <= 5 us.
* ``batch of one``: ``model.f(t, x, u)`` with x shape (1, nx); before, the batch
  evaluator took the kernel as a function-pointer argument (about 35 us of numba
  dispatch, measured here as ``fn-pointer``); now it is bound to the kernel as a global.
  Target <= 5 us.
* ``jacobian``: ``model.jacobian(t, x, u)`` for one state and a batch of one (the
  vehicle's pitch check runs on a float there, as in ``f``); the closed loop (BlueROV2
  Heavy + attitude hold) against the open-loop vehicle.

The issue 14 rows are those of the Fig. 7 model, the RexROV open loop.
* ``large batch``: ns per sample of ``model.f`` on N states against the function-
  pointer evaluator on the same states. Target: no slower (ratio <= 1).
* ``kernel``: ns per call of the model's kernel inside a compiled loop through a
  function pointer (as the exact simulator calls it); the closed loop (attitude hold
  composed with the vehicle) against the open-loop vehicle.
* ``--cache``: construction of a symbolic model in a fresh process with an empty kernel
  cache (sympy derivation, code generation, numba compilation) and again with the
  cache filled (load only).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import textwrap
import time
import warnings
from pathlib import Path

import numpy as np
from _rows import row, write_json

import sampledyn as sd
from sampledyn.experiments._rov import fig7_vehicle
from sampledyn.models._base import _batch_rhs, readonly


def best_per_call(fns: dict, calls: int, repeat: int = 9) -> dict[str, float]:
    """Best mean time per call (s) of each function over ``repeat`` loops of ``calls``
    calls, the functions interleaved so that a load change hits all of them alike."""
    best = dict.fromkeys(fns, float("inf"))
    for _ in range(repeat):
        for name, fn in fns.items():
            t0 = time.perf_counter()
            for _ in range(calls):
                fn()
            best[name] = min(best[name], (time.perf_counter() - t0) / calls)
    return best


def one_state(model, rng) -> tuple[np.ndarray, ...]:
    """A random state and input as a batch of one (t1, x1, u1) and as one state (x0, u0)."""
    nx, nu = model.nx, model.nu
    x1 = rng.normal(size=(1, nx)) * (0.1 if nx > 2 else 1.0)
    u1 = rng.normal(size=(1, nu)) * (500.0 if nu > 1 else 5.0)
    return np.zeros(1), x1, u1, x1[0].copy(), u1[0].copy()


def python_calls(name: str, model, rng) -> dict[str, float]:
    t1, x1, u1, x0, u0 = one_state(model, rng)
    rhs, p = model.kernel()
    p = readonly(p)
    out = np.empty(model.nx)
    model.f(0.0, x0, u0)  # compile / load
    model.f(t1, x1, u1)
    rt, rx, ru = readonly(t1), readonly(x1), readonly(u1)
    _batch_rhs(rhs, rt, rx, ru, p)
    times = best_per_call(
        {
            "bare": lambda: rhs(0.0, x0, u0, p, out),
            "single": lambda: model.f(0.0, x0, u0),
            "batch1": lambda: model.f(t1, x1, u1),
        },
        5000,
    )
    bare, single, batch1 = times["bare"], times["single"], times["batch1"]
    pointer1 = best_per_call({"p": lambda: _batch_rhs(rhs, rt, rx, ru, p)}, 200)["p"]
    print(
        f"{name:<28} bare {bare * 1e6:6.2f} us | single {single * 1e6:6.2f} us "
        f"({single / bare:5.1f}x bare) | batch of one {batch1 * 1e6:6.2f} us "
        f"({batch1 / bare:5.1f}x bare; fn-pointer {pointer1 * 1e6:6.1f} us, "
        f"{pointer1 / batch1:5.1f}x slower)"
    )
    return {"bare_us": bare * 1e6, "single_us": single * 1e6, "batch1_us": batch1 * 1e6}


def python_jacobian_calls(name: str, model, rng) -> dict[str, float]:
    t1, x1, u1, x0, u0 = one_state(model, rng)
    model.jacobian(0.0, x0, u0)  # compile / load
    model.jacobian(t1, x1, u1)
    times = best_per_call(
        {
            "single": lambda: model.jacobian(0.0, x0, u0),
            "batch1": lambda: model.jacobian(t1, x1, u1),
        },
        5000,
    )
    print(
        f"{name:<28} jacobian: single {times['single'] * 1e6:6.2f} us | batch of one "
        f"{times['batch1'] * 1e6:6.2f} us"
    )
    return {"single_us": times["single"] * 1e6, "batch1_us": times["batch1"] * 1e6}


def large_batch(name: str, model, rng, n: int) -> None:
    x = rng.normal(size=(n, model.nx)) * (0.1 if model.nx > 2 else 1.0)
    u = rng.normal(size=(n, model.nu)) * (500.0 if model.nu > 1 else 5.0)
    t = np.zeros(n)
    rhs, p = model.kernel()
    args = readonly(t), readonly(x), readonly(u), readonly(p)
    new = model.f(t, x, u)
    old = _batch_rhs(rhs, *args)
    same = np.array_equal(new, old)
    times = best_per_call(
        {"new": lambda: model.f(t, x, u), "old": lambda: _batch_rhs(rhs, *args)}, 2, repeat=7
    )
    t_new, t_old = times["new"], times["old"]
    print(
        f"{name:<28} N = {n}: {t_new / n * 1e9:6.1f} ns/sample, fn-pointer "
        f"{t_old / n * 1e9:6.1f} ns/sample, ratio {t_new / t_old:4.2f} (target <= 1); "
        f"bit-identical: {same}"
    )


def kernel_cost(vehicle, hold, rng, n: int) -> None:
    """Kernels through a function pointer in a compiled loop, as the simulator calls."""
    x = rng.normal(size=(n, 12)) * 0.1
    u = rng.normal(size=(n, vehicle.nu)) * 500.0
    t = np.zeros(n)
    fns = {}
    for name, model in (("vehicle", vehicle), ("vehicle + attitude hold", hold)):
        rhs, p = model.kernel()
        args = readonly(t), readonly(x), readonly(u), readonly(p)
        _batch_rhs(rhs, *args)
        fns[name] = lambda rhs=rhs, args=args: _batch_rhs(rhs, *args)
    rows = best_per_call(fns, 2, repeat=7)
    v, c = rows["vehicle"] / n, rows["vehicle + attitude hold"] / n
    print(
        f"kernel per call (compiled loop): vehicle {v * 1e9:.1f} ns, closed loop "
        f"{c * 1e9:.1f} ns ({c / v:.2f}x: the law, its stack buffer and the inlined plant)"
    )


_CACHE_SCRIPT = textwrap.dedent(
    """
    import json, time
    t0 = time.perf_counter()
    import numpy as np, sympy as sp, sampledyn as sd
    t1 = time.perf_counter()
    x, v, u, c, k = sp.symbols("x v u c k")
    m = sd.models.SymbolicModel([x, v], [u], [v, -k * sp.sin(x) - c * v * sp.Abs(v) + u],
                                params={c: 0.5, k: 2.0})
    t2 = time.perf_counter()
    m.f(np.zeros(4), np.ones((4, 2)), np.ones((4, 1)))
    m.jacobian(np.zeros(4), np.ones((4, 2)), np.ones((4, 1)))
    sig = sd.signals.Multilevel(low=-1, high=1, hold=0.5, seed=0)
    sd.simulate(m, sig, T=1.0, h=0.1)
    t3 = time.perf_counter()
    print(json.dumps({"import": t1 - t0, "derive": t2 - t1, "compile_or_load": t3 - t2}))
    """
)


def cache_cost() -> None:
    repo = Path(__file__).resolve().parents[1]
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, SAMPLEDYN_CACHE_DIR=tmp, PYTHONPATH=str(repo))
        env.pop("NUMBA_CACHE_DIR", None)
        for label in ("empty kernel cache", "filled kernel cache"):
            done = subprocess.run(
                [sys.executable, "-c", _CACHE_SCRIPT], env=env, capture_output=True, text=True
            )
            if done.returncode != 0:
                print(done.stderr)
                return
            r = json.loads(done.stdout.strip().splitlines()[-1])
            print(
                f"symbolic model, {label:<19}: import {r['import']:.2f} s, sympy derivation "
                f"{r['derive']:.2f} s, kernels (f, jacobian, simulate) {r['compile_or_load']:.2f} s"
            )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--n", type=int, default=100_000, help="large batch size")
    ap.add_argument("--cache", action="store_true", help="also time cold and warm construction")
    ap.add_argument("--json", help="write the issue 14 rows here")
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    vehicle = sd.models.load_vehicle("bluerov2_heavy")
    hold = sd.models.AttitudeHold(vehicle)
    auv = sd.models.AUVLike()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the RexROV file's added-mass symmetry note
        rexrov = fig7_vehicle(sd.models.load_vehicle("rexrov"), 1.0)
    models = (
        ("RexROV (the Fig. 7 model)", rexrov),
        ("AUV-like (symbolic)", auv),
        ("BlueROV2 Heavy + hold", hold),
        ("BlueROV2 Heavy (open loop)", vehicle),
    )
    print("One f evaluation from Python (target: single and batch of one <= 5 us)")
    f_us = {name: python_calls(name, model, rng) for name, model in models}
    print("\nOne Jacobian evaluation from Python")
    jac_us = {name: python_jacobian_calls(name, model, rng) for name, model in models}
    fig7 = f_us["RexROV (the Fig. 7 model)"]
    hold_j = jac_us["BlueROV2 Heavy + hold"]
    open_j = jac_us["BlueROV2 Heavy (open loop)"]
    ratio = hold_j["single_us"] / open_j["single_us"]
    rows = [
        row("one f evaluation from Python, single state (RexROV)", fig7["single_us"],
            f"{fig7['single_us']:.2f} us", "<= 5 us", fig7["single_us"] <= 5.0),
        row("one f evaluation from Python, batch of one (RexROV)", fig7["batch1_us"],
            f"{fig7['batch1_us']:.2f} us", "<= 5 us", fig7["batch1_us"] <= 5.0),
        row("closed-loop Jacobian from Python, one state (BlueROV2 Heavy + hold)",
            hold_j["single_us"], f"{hold_j['single_us']:.1f} us ({ratio:.1f}x the open-loop "
            f"vehicle's {open_j['single_us']:.1f} us)", "near the open-loop vehicle's", None),
    ]  # fmt: skip
    write_json(args.json, "bench_models", rows)
    print("\nLarge batches")
    for name, model in models:
        large_batch(name, model, rng, args.n)
    print()
    kernel_cost(vehicle, hold, rng, args.n)
    if args.cache:
        print()
        cache_cost()


if __name__ == "__main__":
    main()
