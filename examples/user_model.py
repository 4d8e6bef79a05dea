"""A model of your own: the REMUS 100 AUV in the vertical plane, through sampledyn.

Run:  python examples/user_model.py

The torpedo-shaped REMUS 100 (1.33 m, 30.5 kg) in surge, heave and pitch, driven by its
propeller thrust and its stern planes, after

    T. Prestero, "Verification of a six-degree of freedom simulation model for the
    REMUS autonomous underwater vehicle", MS thesis, MIT / WHOI, September 2001,

restricted to the vertical plane (v = p = r = 0, phi = psi = 0). State
(x, z, theta, u, w, q): position (m, z down), pitch (rad), surge and heave speed (m/s)
and pitch rate (rad/s); inputs: thrust X_prop (N) and stern-plane angle delta_s (rad).

Where every number comes from (the thesis's tables; units in UNITS below):

* W = 299 N and B = 306 N: Table 2.3 (typical values; Table A.1 gives a measured
  B = 308 N); m = W / g = 30.48 kg (g = 9.81 m/s^2); z_g = 0.0196 m: Table 2.5;
  I_yy = 3.45 kg m^2: Table 2.6. The body origin is the centre of buoyancy (sec. 3.1),
  so x_b = z_b = x_g = 0.
* every hydrodynamic coefficient: Tables 4.2 (forces) and 4.3 (moments), the values
  derived in ch. 4; X_prop = 3.86 N is the thrust at the nominal 1500 rpm (sec. 4.6.1).
* the equations: rigid body eq. (3.9), hydrostatics eq. (4.3), external forces and
  moments eq. (4.49), as in his simulator REMUS.m (Appendix E.1.2).

These are the coefficients as derived, before Prestero fitted his simulator to sea
trials: sec. 8.1.2 scales some of them (Table 8.2: Z_ww x 10, M_qq x 12.5, and K_pp,
K_pdot, Y_vv, N_rr), and Appendices B and C list the adjusted set, which does not follow
Table 8.2 for those two (Z_ww = -131 unchanged, M_qq = -188, i.e. x 20). The M_qq = -188
(with Z_ww = -1310) of some public REMUS codes, e.g. the coefficient file of Hall &
Anstee (2011), DSTO-TR-2576, is that adjusted value. Table 4.2 prints Z_uw = -28.6 kg/m
("body lift force and fin lift") although its parts in Tables C.4 and C.10 sum to
-38.2 kg/m; the printed value is used.

The model is stated once, in sympy (the block below, under 40 lines); sampledyn derives
the compiled kernel, the exact Jacobians, the switching functions of the |.| drag terms
and the linear-in-parameters form, then simulates, predicts, advises (which rule for
noisy data) and estimates with it.
"""

import numpy as np
import sympy as sp

import sampledyn as sd

# --- the model: Prestero (2001), vertical plane --------------------------------------
x, z, th, u, w, q = sp.symbols("x z theta u w q")
X_prop, d_s = sp.symbols("X_prop delta_s")
coef = {  # Prestero (2001), Tables 2.3, 2.5, 2.6, 4.2, 4.3 (m = W/g); units in UNITS
    "m": 30.48, "W": 299.0, "B": 306.0, "I_yy": 3.45, "z_g": 0.0196,
    "X_udot": -0.93, "X_uu": -1.62, "X_wq": -35.5, "X_qq": -1.93,
    "Z_wdot": -35.5, "Z_qdot": -1.93, "Z_ww": -131.0, "Z_qq": -0.632, "Z_uq": -5.22,
    "Z_uw": -28.6, "Z_uud": -9.64,
    "M_wdot": -1.93, "M_qdot": -4.88, "M_ww": 3.18, "M_qq": -9.40, "M_uq": -2.0,
    "M_uw": 24.0, "M_uud": -6.15,
}  # fmt: skip
UNITS = {
    "m": "kg", "W": "N", "B": "N", "I_yy": "kg m^2", "z_g": "m", "X_udot": "kg",
    "X_uu": "kg/m", "X_wq": "kg/rad", "X_qq": "kg m/rad", "Z_wdot": "kg",
    "Z_qdot": "kg m/rad", "Z_ww": "kg/m", "Z_qq": "kg m/rad^2", "Z_uq": "kg/rad",
    "Z_uw": "kg/m", "Z_uud": "kg/(m rad)", "M_wdot": "kg m", "M_qdot": "kg m^2/rad",
    "M_ww": "kg", "M_qq": "kg m^2/rad^2", "M_uq": "kg m/rad", "M_uw": "kg", "M_uud": "kg/rad",
}  # fmt: skip
c = {name: sp.Symbol(name) for name in coef}
m, W, B, zg = c["m"], c["W"], c["B"], c["z_g"]
# Surge, heave, pitch: forces and moment with the rigid-body coupling moved to this side
X = (
    c["X_uu"] * u * abs(u)
    + (c["X_wq"] - m) * w * q
    + c["X_qq"] * q**2
    - (W - B) * sp.sin(th)
    + X_prop
)
Z = (c["Z_ww"] * w * abs(w) + c["Z_qq"] * q * abs(q) + (c["Z_uq"] + m) * u * q + c["Z_uw"] * u * w
     + m * zg * q**2 + (W - B) * sp.cos(th) + c["Z_uud"] * u**2 * d_s)  # fmt: skip
M = (c["M_ww"] * w * abs(w) + c["M_qq"] * q * abs(q) + c["M_uq"] * u * q + c["M_uw"] * u * w
     - m * zg * w * q - zg * W * sp.sin(th) + c["M_uud"] * u**2 * d_s)  # fmt: skip
mass = sp.Matrix([[m - c["X_udot"], 0, m * zg],
                  [0, m - c["Z_wdot"], -c["Z_qdot"]],
                  [m * zg, -c["M_wdot"], c["I_yy"] - c["M_qdot"]]])  # fmt: skip
accel = mass.LUsolve(sp.Matrix([X, Z, M]))
kinematics = [u * sp.cos(th) + w * sp.sin(th), -u * sp.sin(th) + w * sp.cos(th), q]
remus = sd.models.SymbolicModel(
    [x, z, th, u, w, q], [X_prop, d_s], [*kinematics, *accel],
    params={c[n]: v for n, v in coef.items()}, param_units=UNITS,
    state_units=["m", "m", "rad", "m/s", "m/s", "rad/s"], input_units=["N", "rad"],
    x0=[0.0, 5.0, 0.0, 1.5, 0.0, 0.0], name="REMUS 100, vertical plane (Prestero 2001)",
)  # fmt: skip
# --------------------------------------------------------------------------------------


def main() -> None:
    print(remus)
    print("switching functions found in f:", remus.expressions["kinks"])
    print("parameters entering f linearly:", [str(s) for s in remus.expressions["linear_params"]])

    # Open loop the REMUS pitches up (it is 7 N buoyant, and the Munk moment M_uw u w
    # destabilises pitch), so it flies with a pitch autopilot: a PD law on the stern
    # planes, delta_s = delta_s,ref + 2 theta + 1 q, closed around the symbolic model.
    gain = np.zeros((2, 6))
    gain[1, 2], gain[1, 5] = 2.0, 1.0  # rad/rad, rad/(rad/s)
    loop = sd.models.ClosedLoop(remus, sd.models.LinearFeedback(gain), name="REMUS + pitch PD")
    # References: cruise thrust 3.86 N (1500 rpm, Prestero Table 4.2), stern planes +-4.5 deg.
    signal = sd.signals.Sinusoidal(
        offset=[3.86, 0.0],
        amplitude=[[0.3, 0.0], [np.radians(3.0), np.radians(1.5)]],
        frequency_hz=[[0.05, 0.0], [0.02, 0.11]],
    )
    h = 0.1
    traj = sd.simulate(loop, signal, T=300.0, h=h)
    print(traj.certificate)
    applied = loop.applied_input(traj.t, traj.x, traj.u)  # what the vehicle's log records
    print(
        f"depth varies by {np.ptp(traj.x[:, 1]):.1f} m, |pitch| <= "
        f"{np.degrees(np.abs(traj.x[:, 2]).max()):.1f} deg, |delta_s| <= "
        f"{np.degrees(np.abs(applied[:, 1]).max()):.1f} deg, surge "
        f"{traj.x[:, 3].min():.2f}-{traj.x[:, 3].max():.2f} m/s"
    )

    print(f"\nOne-step-ahead prediction, h = {h} s (rms local error, all states, t >= 30 s):")
    for name in ("E", "AB2", "AB4", "T", "RK4"):
        err = sd.local_errors(sd.predict(name, loop, traj, signal=signal), traj)
        print(f"  {name:>4}: {sd.error_norm(err, traj.t, kind='rms', after=30.0):.2e}")

    # Which discrete-time model for a log with 1 % noise at h = 0.1 s? advise ranks the
    # rules by a first-order prediction of their largest one-step error and measures
    # them on noisy copies of the run (the states split into positions/angles and rates
    # by their units; the guaranteed bound (24)-(25) exists for 6-DoF vehicles only).
    advice = sd.advise(
        loop, h, 1.0, 1.0, ("E", "AB2", "AB4", "RK4", "T"), signal=signal, T=60.0, seeds=3
    )
    print()
    print(advice.table())

    # Identification of the vehicle from its log (states and applied inputs): the
    # cross-flow drag, body-lift and stern-plane coefficients, by AB2 least squares.
    # Noise on the states biases such fits (errors in variables; see docs/models.md).
    log = traj.replace(u=applied, input_names=remus.input_names, input_units=remus.input_units)
    free = ("Z_ww", "Z_uw", "M_qq", "M_uw", "Z_uud", "M_uud")
    for data, label in (
        (log, "exact samples"),
        (sd.add_noise(log, 0.1, 0.1, seed=1), "0.1 % noise"),
    ):
        res = sd.estimate(remus, data, structure="AB2", params=free, after=30.0)
        print(f"\nAB2 least squares on {label} (condition number {res.condition_number:.0f}):")
        for name in free:
            est, true = res.params[name], coef[name]
            print(f"  {name:>6} = {est:9.4g} {UNITS[name]:<12} (Prestero {true:g}, "
                  f"{100 * (est - true) / abs(true):+.2f} %)")  # fmt: skip


if __name__ == "__main__":
    main()
