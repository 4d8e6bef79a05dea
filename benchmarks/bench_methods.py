"""Methods benchmark: the cost of asking the method object, and of the held-input rules.

Run:  python benchmarks/bench_methods.py [--T 200] [--h 0.01]

Every number is a ratio of two timings taken in the same run on the same samples (the
AUV-like system, eqs. (9)-(10), multilevel input), so it does not depend on the speed
of the (shared, noisy) machine:

* a rule's ``predict`` with a warm shared ``cache`` against the bare AB filter on
  precomputed f (what the sweep and ROV engines ran before the method API): the price
  of the uniform-grid check and the cache lookup;
* AB1-AB6 predicted with one shared cache against each computing f itself;
* ABu_s and ABj_s against AB_s (extra f evaluations where the input changed).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import sampledyn as sd
from sampledyn.methods import ab_filter, get_method


def best_of(fn, repeat=7):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--T", type=float, default=200.0)
    parser.add_argument("--h", type=float, default=0.01)
    args = parser.parse_args()
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
