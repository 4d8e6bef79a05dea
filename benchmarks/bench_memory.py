"""Memory benchmark: peak memory of exact samples against the size of what is returned.

Run:  python benchmarks/bench_memory.py [--T 50000] [--h 0.01]

Issue 14's row "peak RSS / returned arrays, T = 50,000 s, h = 0.01 s" (5 M samples of
the BlueROV2 Heavy with the attitude hold under the Fig. 6 input, the `reproduce fig7`
vehicle): target <= 1.3x. Each case runs in a fresh subprocess, after a warm-up run
that compiles every kernel, and reports

* RSS: the growth of the peak resident set during the call (``VmHWM``, reset through
  ``/proc/self/clear_refs`` just before it; ``ru_maxrss`` where that is not possible),
  over the bytes of the arrays the call returns;
* traced: the peak of numpy/Python allocations during the call (``tracemalloc``) over
  the same bytes: the part of the RSS peak the library's own arrays explain.

Cases: ``signal(t)`` alone (returns u), ``simulate`` with and without the certificate
(returns t, x, u, and the certificate's per-interval errors and step counts).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

CHILD = r"""
import json, resource, sys, tracemalloc
import numpy as np
import sampledyn as sd
from sampledyn.signals import fig6_thrusters

case, T, h = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
vehicle = sd.models.load_vehicle("bluerov2_heavy")
model = sd.models.AttitudeHold(vehicle, 40.0, 6.0)  # the Fig. 7 study's gains
signal = fig6_thrusters(vehicle)
sd.simulate(model, signal, T=1.0, h=h)  # compile and warm every kernel

def rss(field):
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(field):
                return int(line.split()[1]) * 1024
    raise KeyError(field)

try:
    with open("/proc/self/clear_refs", "w") as fh:
        fh.write("5")  # reset the peak RSS (VmHWM) to the current RSS
    reset = True
except OSError:
    reset = False
before = rss("VmRSS:")
before_max = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
tracemalloc.start()
if case == "signal":
    t = np.arange(int(round(T / h)) + 1, dtype=float) * h
    tracemalloc.reset_peak()
    result = [signal(t)]
else:
    traj = sd.simulate(model, signal, T=T, h=h, certify=(case == "simulate"))
    result = [traj.t, traj.x, traj.u]
    if traj.certificate is not None:
        result += [traj.certificate.per_interval, traj.certificate.steps]
traced_peak = tracemalloc.get_traced_memory()[1]
tracemalloc.stop()
peak = rss("VmHWM:") if reset else resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
returned = sum(a.nbytes for a in result)
print(json.dumps({
    "returned": returned,
    "rss_growth": peak - (before if reset else max(before, before_max)),
    "traced_peak": traced_peak,
    "rss_method": "VmHWM" if reset else "ru_maxrss",
}))
"""


def run(case: str, T: float, h: float) -> dict:
    out = subprocess.run(
        [sys.executable, "-c", CHILD, case, str(T), str(h)],
        check=True,
        capture_output=True,
        text=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--T", type=float, default=50_000.0, help="duration (s), default 50000")
    ap.add_argument("--h", type=float, default=0.01, help="sampling period (s), default 0.01")
    args = ap.parse_args()
    n = int(round(args.T / args.h)) + 1
    print(f"T = {args.T:g} s, h = {args.h:g} s: {n:,} samples (target: peak / returned <= 1.3)")
    head = ("case", "returned", "RSS peak", "ratio", "traced", "ratio")
    print(f"{head[0]:22s} {head[1]:>10s} {head[2]:>10s} {head[3]:>6s} {head[4]:>10s} {head[5]:>6s}")
    for case, label in (
        ("signal", "signal(t)"),
        ("simulate", "simulate"),
        ("simulate_nocert", "simulate certify=False"),
    ):
        r = run(case, args.T, args.h)
        mb = 1e6
        print(
            f"{label:22s} {r['returned'] / mb:8.1f}MB {r['rss_growth'] / mb:8.1f}MB "
            f"{r['rss_growth'] / r['returned']:6.2f} {r['traced_peak'] / mb:8.1f}MB "
            f"{r['traced_peak'] / r['returned']:6.2f}"
        )
    print(f"(RSS measured with {r['rss_method']})")


if __name__ == "__main__":
    main()
