"""A small nonlinear MPC on a sampled-data model, solved with CasADi's IPOPT.

    python examples/mpc_casadi.py [rule] [h] [horizon]

The model F(z, u) is ``sd.discretize(vehicle, rule, h).to_casadi()``: a CasADi
Function derived from the vehicle kernel's own source (no second copy of the
equations). A multiple-shooting problem over the horizon is built once with
``casadi.nlpsol(..., "ipopt", ...)`` and solved at every sample from the measured state
(warm-started); the first input is applied to the exact plant by
``sampledyn.run_loop`` (held over the interval, thrusters saturating at
n_max inside the plant). The same Function can be handed to do-mpc as its discrete-time
model (``model_type="discrete"``, rhs = F(z, u)). acados is not on the package index,
so that route is untested here.

Needs `pip install 'sampledyn[control]'`. A demonstration: about 0.05-0.3 s per solve.
"""

from __future__ import annotations

import sys
import time

import casadi as ca
import numpy as np

import sampledyn as sd
from sampledyn import run_loop
from sampledyn.experiments import trim
from sampledyn.models import load_vehicle

rule = sys.argv[1] if len(sys.argv) > 1 else "RK4"
h = float(sys.argv[2]) if len(sys.argv) > 2 else 0.5
N = int(sys.argv[3]) if len(sys.argv) > 3 else 10

vehicle = load_vehicle("rexrov").with_buoyancy(1.0)
x_star, u_star = trim(vehicle, surge=0.5, depth=5.0, heading=0.5)
model = sd.discretize(vehicle, rule, h)
F = model.to_casadi()
nz, nu, n_max = model.nz, model.nu, vehicle.n_max

# cost on the current state's block (x, y positions free), inputs relative to the trim
w = 1 / np.square([0.5, 0.2, 0.2, 0.3, 0.2, 0.3, 0.3, 0.5, 0.5, 0.5])
Z = ca.MX.sym("Z", nz, N + 1)
U = ca.MX.sym("U", nu, N)
z0 = ca.MX.sym("z0", nz)
cost = 0
g = [Z[:, 0] - z0]
for k in range(N):
    dx = Z[2:12, k + 1] - x_star[2:12]
    du = (U[:, k] - u_star) / (0.5 * n_max)
    cost += ca.dot(w * dx, dx) + ca.dot(du, du)
    g.append(Z[:, k + 1] - F(Z[:, k], U[:, k]))
nlp = {"x": ca.veccat(Z, U), "p": z0, "f": cost, "g": ca.vertcat(*g)}
solver = ca.nlpsol(
    "mpc",
    "ipopt",
    nlp,
    {"ipopt.print_level": 0, "print_time": 0, "ipopt.sb": "yes", "ipopt.max_iter": 100},
)
n_var = nz * (N + 1) + nu * N
lbx = np.full(n_var, -np.inf)
ubx = np.full(n_var, np.inf)
lbx[nz * (N + 1) :], ubx[nz * (N + 1) :] = -n_max, n_max
guess = np.concatenate([np.tile(model.steady_state(x_star, u_star), N + 1), np.tile(u_star, N)])
history: list[tuple[np.ndarray, np.ndarray]] = []
solve_times: list[float] = []


def mpc(t: float, y: np.ndarray) -> np.ndarray:
    global guess
    past_u = history[-1][1] if history else u_star
    history.append((y, past_u))
    xs = [history[max(len(history) - 1 - i, 0)][0] for i in range(model.history)]
    us = [history[max(len(history) - 1 - i, 0)][1] for i in range(model.history)]
    z = model.state_from_history(np.array(xs), np.array(us), t=t)
    t0 = time.perf_counter()
    sol = solver(x0=guess, p=z, lbx=lbx, ubx=ubx, lbg=0, ubg=0)
    solve_times.append(time.perf_counter() - t0)
    guess = np.asarray(sol["x"]).ravel()
    u = guess[nz * (N + 1) : nz * (N + 1) + nu]
    history[-1] = (y, u)
    return u


x0 = x_star.copy()
x0[2] -= 0.5
x0[5] -= 0.2
t0 = time.perf_counter()
run = run_loop(vehicle, mpc, 60.0, h, x0, noise=(2, 2), seed=0)
wall = time.perf_counter() - t0
after = run.exact.t >= 30.0
print(
    f"MPC on {rule}, h = {h} s, horizon {N} ({N * h:g} s), nz = {nz}: {len(solve_times)} "
    f"solves, median {1e3 * np.median(solve_times):.0f} ms, max "
    f"{1e3 * np.max(solve_times):.0f} ms; run {wall:.1f} s"
)
for idx, name, unit in ((2, "depth", "m"), (5, "heading", "rad"), (6, "surge", "m/s")):
    err = np.abs(run.exact.x[after, idx] - x_star[idx])
    print(
        f"  {name:8s} error after 30 s: 95th pct {np.percentile(err, 95):.3g} {unit}, "
        f"max {err.max():.3g} {unit}"
    )
