"""From a vehicle file to a digital LQR, run on the exact plant.

    python examples/control_design.py [vehicle] [rule] [h] [--surge U] [--depth Z] [--heading PSI]

(vehicle: a vehicle file or a built-in name, default rexrov; rule default AB4; h in s,
default 0.1; the set point: surge U m/s, depth Z m, heading PSI rad, default 0.5, 5,
0.5.)

1. load the vehicle (a TOML vehicle file, or a built-in name);
2. find the trim of a depth / heading / surge hold;
3. discretize it with a sampled-data rule (AB4 or RK4 here) and linearise it there;
4. design a discrete LQR with python-control (x, y positions left out: nothing depends
   on them);
5. run the law against the exact plant (input held between samples, thrusters
   saturating at n_max) with the paper's measurement noise, and print the residual
   set after the transient.

Needs `pip install 'sampledyn[control]'`. Adapt the weights Q, R or the rule; any
rule with a discrete state works (E, AB<s>, ABu<s>, RK<s>, T). A set point the vehicle
cannot hold (no trim, or one pitched beyond the vehicle's limit) ends the script with
the reason.
"""

from __future__ import annotations

import argparse
import sys

import control
import numpy as np

import sampledyn as sd
from sampledyn import LinearLaw, run_loop
from sampledyn.experiments import trim
from sampledyn.models import load_vehicle

parser = argparse.ArgumentParser(description="digital LQR from a vehicle file")
parser.add_argument("vehicle", nargs="?", default="rexrov", help="vehicle file or built-in name")
parser.add_argument("rule", nargs="?", default="AB4", help="sampled-data rule (default AB4)")
parser.add_argument("h", nargs="?", type=float, default=0.1, help="sampling period in s")
parser.add_argument("--surge", type=float, default=0.5, help="set-point surge in m/s (0.5)")
parser.add_argument("--depth", type=float, default=5.0, help="set-point depth in m (5)")
parser.add_argument("--heading", type=float, default=0.5, help="set-point heading in rad (0.5)")
args = parser.parse_args()
rule, h = args.rule, args.h

vehicle = load_vehicle(args.vehicle).with_buoyancy(1.0)

# 1-2. trim of the set point (the equilibrium found is verified: |f| < 1e-10, thrusters
# within n_max, pitch within the vehicle's limit; otherwise trim says why there is none)
try:
    x_star, u_star = trim(vehicle, surge=args.surge, depth=args.depth, heading=args.heading)
except ValueError as exc:
    sys.exit(f"control_design: {exc}")
print(
    f"trim: surge {args.surge} m/s, depth {args.depth} m, heading {args.heading} rad; "
    f"theta* = {np.degrees(x_star[4]):.3g} deg"
)

# 3. the discrete-time model and its linearisation at the trim
model = sd.discretize(vehicle, rule, h)
z_star = model.steady_state(x_star, u_star)
lin = model.to_control(z0=z_star, u0=u_star)  # a python-control StateSpace, dt = h

# 4. LQR on z without the x, y entries of each block (Bryson weights on the current state)
keep = [b * 12 + i for b in range(len(model.layout)) for i in range(2, 12)]
A, B = lin.A[np.ix_(keep, keep)], lin.B[keep]
q = np.zeros(len(keep))
q[:10] = 1 / np.square([0.5, 0.2, 0.2, 0.3, 0.2, 0.3, 0.3, 0.5, 0.5, 0.5])
R = np.eye(vehicle.nu) / (0.5 * vehicle.n_max) ** 2
K, _, poles = control.dlqr(A, B, np.diag(q), R)
print(
    f"{vehicle.name}, {rule}, h = {h} s: nz = {model.nz}, |closed-loop poles| <= "
    f"{np.abs(poles).max():.4f} on the design model"
)

gain = np.zeros((vehicle.nu, model.nz))
gain[:, keep] = -K
law = LinearLaw(model, gain, z_star, u_star)  # u = u* + gain (z - z*), evaluated compiled

# 5. closed loop on the exact plant, 0.5 m depth and 0.2 rad heading off, 2 %/2 % noise
x0 = x_star.copy()
x0[2] -= 0.5
x0[5] -= 0.2
run = run_loop(vehicle, law, 300.0, h, x0, noise=(2, 2), seed=0)
after = run.exact.t >= 100.0
for idx, name, unit in ((2, "depth", "m"), (5, "heading", "rad"), (6, "surge", "m/s")):
    err = np.abs(run.exact.x[after, idx] - x_star[idx])
    print(
        f"  {name:8s} error after 100 s: 95th pct {np.percentile(err, 95):.3g} {unit}, "
        f"max {err.max():.3g} {unit}"
    )
applied = np.clip(run.exact.u[after], -vehicle.n_max, vehicle.n_max)
print(
    f"  effort: rms(n - n*) = {np.sqrt(np.mean((applied - u_star) ** 2)) / vehicle.n_max:.3g} n_max"
)
