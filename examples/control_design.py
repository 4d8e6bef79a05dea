"""From a vehicle file to a digital LQR, run on the exact plant.

    python examples/control_design.py [vehicle file or name] [rule] [h]

1. load the vehicle (a TOML vehicle file, or a built-in name);
2. find the trim of a depth / heading / surge hold;
3. discretize it with a sampled-data rule (AB4 or RK4 here) and linearise it there;
4. design a discrete LQR with python-control (x, y positions left out: nothing depends
   on them);
5. run the law against the exact plant (input held between samples, thrusters
   saturating at n_max) with the paper's measurement noise, and print the residual
   set after the transient.

Needs `pip install 'sampledyn[control]'`. Adapt the set point, the weights Q, R or the
rule; any rule with a discrete state works (E, AB<s>, ABu<s>, RK<s>, T).
"""

from __future__ import annotations

import sys

import control
import numpy as np

import sampledyn as sd
from sampledyn import LinearLaw, run_loop
from sampledyn.experiments import trim
from sampledyn.models import load_vehicle

vehicle_file = sys.argv[1] if len(sys.argv) > 1 else "rexrov"
rule = sys.argv[2] if len(sys.argv) > 2 else "AB4"
h = float(sys.argv[3]) if len(sys.argv) > 3 else 0.1

vehicle = load_vehicle(vehicle_file).with_buoyancy(1.0)

# 1-2. trim: surge 0.5 m/s at 5 m depth, heading 0.5 rad
x_star, u_star = trim(vehicle, surge=0.5, depth=5.0, heading=0.5)

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
