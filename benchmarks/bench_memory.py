"""Memory benchmark: peak memory of exact samples against the size of what is returned.

Run:  python benchmarks/bench_memory.py [--T 50000] [--h 0.01] [--vehicle rexrov] [--json PATH]

Issue 14's row "peak RSS / returned arrays, T = 50,000 s, h = 0.01 s" (5 M samples of
the `reproduce fig7` vehicle under the Fig. 6 input, +1 % buoyancy: the RexROV open
loop; ``--vehicle bluerov2_heavy`` runs the old default, the BlueROV2 Heavy with the
attitude hold): target <= 1.3x. Each case runs in a fresh subprocess, after a warm-up
run that compiles every kernel, and reports

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
from pathlib import Path

from _rows import row, write_json

CHILD = r"""
import json, sys, tracemalloc, warnings
import numpy as np
import sampledyn as sd
from sampledyn.experiments._rov import fig7_vehicle
from sampledyn.signals import fig6_thrusters
from _peak import PeakMemory

case, T, h, name = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), sys.argv[4]
with warnings.catch_warnings():
    warnings.simplefilter("ignore")  # the RexROV file's added-mass symmetry note
    vehicle = fig7_vehicle(sd.models.load_vehicle(name), 1.0)
# the Fig. 7 study's model: the BlueROV2 Heavy with its hold, any other vehicle open loop
model = sd.models.AttitudeHold(vehicle, 40.0, 6.0) if name == "bluerov2_heavy" else vehicle
signal = fig6_thrusters(vehicle)
sd.simulate(model, signal, T=1.0, h=h)  # compile and warm every kernel

peak = PeakMemory()
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
returned = sum(a.nbytes for a in result)
print(json.dumps({
    "returned": returned,
    "rss_growth": peak.growth(),
    "traced_peak": traced_peak,
    "rss_method": peak.method,
}))
"""


def run(case: str, T: float, h: float, vehicle: str) -> dict:
    out = subprocess.run(
        [sys.executable, "-c", CHILD, case, str(T), str(h), vehicle],
        check=True,
        cwd=Path(__file__).parent,
        capture_output=True,
        text=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--T", type=float, default=50_000.0, help="duration (s), default 50000")
    ap.add_argument("--h", type=float, default=0.01, help="sampling period (s), default 0.01")
    ap.add_argument("--vehicle", default="rexrov", help="vehicle (default rexrov, Fig. 7's)")
    ap.add_argument("--json", help="write the issue 14 rows here")
    args = ap.parse_args()
    n = int(round(args.T / args.h)) + 1
    print(
        f"{args.vehicle}, T = {args.T:g} s, h = {args.h:g} s: {n:,} samples "
        "(target: peak / returned <= 1.3)"
    )
    head = ("case", "returned", "RSS peak", "ratio", "traced", "ratio")
    print(f"{head[0]:22s} {head[1]:>10s} {head[2]:>10s} {head[3]:>6s} {head[4]:>10s} {head[5]:>6s}")
    found = {}
    for case, label in (
        ("signal", "signal(t)"),
        ("simulate", "simulate"),
        ("simulate_nocert", "simulate certify=False"),
    ):
        r = found[case] = run(case, args.T, args.h, args.vehicle)
        mb = 1e6
        print(
            f"{label:22s} {r['returned'] / mb:8.1f}MB {r['rss_growth'] / mb:8.1f}MB "
            f"{r['rss_growth'] / r['returned']:6.2f} {r['traced_peak'] / mb:8.1f}MB "
            f"{r['traced_peak'] / r['returned']:6.2f}"
        )
    print(f"(RSS measured with {r['rss_method']})")
    size = f"{args.vehicle}, T = {args.T:g} s, h = {args.h:g} s"
    rows = []
    for case, label in (
        ("simulate", "peak RSS / returned arrays, `simulate` (certified)"),
        ("simulate_nocert", "peak RSS / returned arrays, `simulate(certify=False)`"),
        ("signal", "peak RSS / returned array, `signal(t)`"),
    ):
        ratio = found[case]["rss_growth"] / found[case]["returned"]
        shown = f"{ratio:.2f}x ({found[case]['returned'] / 1e9:.2f} GB returned)"
        rows.append(row(f"{label}, {size}", ratio, shown, "<= 1.3x", ratio <= 1.3))
    write_json(args.json, "bench_memory", rows)


if __name__ == "__main__":
    main()
