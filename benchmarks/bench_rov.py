"""Exact samples of the Fig. 7 run: the cost of the certificate.

Run:  python benchmarks/bench_rov.py [--vehicle rexrov] [--rounds 5] [--json PATH]

The Fig. 7 run: the RexROV open loop (``reproduce fig7``'s default; ``--vehicle
bluerov2_heavy`` runs the BlueROV2 Heavy with the attitude hold, the old default), Fig. 6
input, +1 % buoyancy, T = 5000 s, h = 0.1 s, rtol = atol = 1e-11 (the study's setting).

``sd.simulate`` with the certificate (the default) against ``certify=False``,
interleaved over ``--rounds`` rounds, minima: issue 14's row "simulate with certificate /
without" (2.41x when it was filed: no worse; the certificate keeps its definition, a
second run in lockstep with every accepted step halved).

(Before issue 14's work this script also compared SciPy on ``model.f`` from Python,
checked intervals against SciPy stepping across the kinks, and timed AB1/AB4 and the
whole ``reproduce fig7``: the peers at equal accuracy, with a reference that lands on
every kink, are ``bench_peers.py``; the rest ``bench_methods.py`` and ``bench_fig7.py``.)
"""

from __future__ import annotations

import argparse
import time
import warnings

from _rows import row, write_json

import sampledyn as sd
from sampledyn.experiments._rov import fig7_vehicle

TOL = 1e-11
T, H = 5000.0, 0.1


def fig7_model(name: str):
    """(model, vehicle, signal) of the Fig. 7 study for vehicle ``name``."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the RexROV file's added-mass symmetry note
        vehicle = fig7_vehicle(sd.models.load_vehicle(name), 1.0)
    model = sd.models.AttitudeHold(vehicle, 40.0, 6.0) if name == "bluerov2_heavy" else vehicle
    return model, vehicle, sd.signals.fig6_thrusters(vehicle)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--vehicle", default="rexrov")
    ap.add_argument("--rounds", type=int, default=5, help="interleaved timing rounds")
    ap.add_argument("--json", help="write the issue 14 row here")
    args = ap.parse_args()

    model, _vehicle, signal = fig7_model(args.vehicle)
    sd.simulate(model, signal, T=1.0, h=H)  # load the compiled kernels
    best = {"without": float("inf"), "with": float("inf")}
    traj = None
    for _ in range(args.rounds):
        for name, certify in (("without", False), ("with", True)):
            t0 = time.perf_counter()
            out = sd.simulate(model, signal, T=T, h=H, rtol=TOL, atol=TOL, certify=certify)
            best[name] = min(best[name], time.perf_counter() - t0)
            if certify:
                traj = out
    assert traj is not None and traj.certificate is not None
    cert = traj.certificate
    ratio = best["with"] / best["without"]
    print(f"Exact samples, {model.name}, Fig. 6 input, +1 % buoyancy, T = {T:g} s, h = {H} s")
    print(f"  sd.simulate                  {best['without']:7.2f} s  ({cert.steps.sum()} steps)")
    print(f"  sd.simulate with certificate {best['with']:7.2f} s  certificate {cert.max_error:.1e}")
    print(f"  with / without: {ratio:.2f}x  (issue 14: 2.41x, no worse)")

    write_json(args.json, "bench_rov", [
        row(f"simulate with certificate / without ({args.vehicle}, Fig. 7 run)", ratio,
            f"{ratio:.2f}x", "no worse than 2.41x", ratio <= 2.41,
            certificate=cert.max_error),
    ])  # fmt: skip


if __name__ == "__main__":
    main()
