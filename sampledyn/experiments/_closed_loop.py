"""Closed-loop study: does a better one-step model give a better digital controller?

For each vehicle (RexROV and BlueROV2 Heavy, open loop: both have 8 thrusters in a
fully actuated layout, so the LQR holds roll and pitch itself and no attitude hold is
needed), each sampled-data rule and each sampling period, the same discrete LQR is
designed on the rule's discrete-time model (:func:`sampledyn.discretize`) linearised at
the trim for a depth / heading / surge hold, and run against the exact plant
(:func:`sampledyn.discretize.run_loop`: input held between samples, thrusters
saturating at n_max inside the plant) with the paper's measurement noise. Measured:
the tracking residual set (95th and 100th percentile of |depth|, |heading| and |surge|
error after the transient) and the control effort. A design on the exact zero-order
hold linearisation (``ZOH``: the matrix exponential, i.e. a perfect one-step model of
the linearised plant) is the reference row.

A run that leaves the envelope (roll or pitch beyond 80 deg, a velocity beyond 5 m/s or
5 rad/s, depth 50 m off) stops there and is reported as diverged: such a loop tumbles
or runs away, and integrating it exactly to the end would only cost time.

The loop over designs is self-contained (no process pool of its own): one design
costs a trim, a linearisation and a Riccati solution (milliseconds), one run a
compiled loop of T/h sampling intervals with the control law evaluated in compiled
code; the whole default grid runs in one process.

Frames: the state is (eta, v) = (x, y, z, phi, theta, psi, u, v, w, p, q, r) in NED /
FRD (z down, depth = z). The positions x and y enter no other equation, so they are
removed from the design (every block of z), which is exact; they get zero gain.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..discretize import LinearLaw, discretize, run_loop
from ..methods import get_method

__all__ = [
    "CLOSED_LOOP_METHODS",
    "ClosedLoopStudy",
    "design_lqr",
    "run_closed_loop_study",
    "summarize_closed_loop",
    "trim",
]

CLOSED_LOOP_METHODS = ("E", "AB2", "AB4", "ABu4", "RK4", "T")
# Tracked outputs: state index, name, unit.
TRACKED = ((2, "depth", "m"), (5, "heading", "rad"), (6, "surge", "m/s"))
# States kept in the design (all but the horizontal positions x, y).
_KEEP = tuple(range(2, 12))
# Bryson weights: the deviation of each kept state that costs as much as 1/2 n_max on
# one thruster (z, phi, theta, psi, u, v, w, p, q, r).
_MAX_DEV = (0.5, 0.2, 0.2, 0.3, 0.2, 0.3, 0.3, 0.5, 0.5, 0.5)
_MAX_RPM_FRAC = 0.5


@dataclass(frozen=True)
class ClosedLoopStudy:
    """Settings of the closed-loop study (defaults: the issue's grid).

    Attributes
    ----------
    vehicles : tuple of str
        Built-in vehicle names or vehicle files.
    methods : tuple of str
        Rules the LQR is designed on; "ZOH" adds the exact zero-order-hold design.
    h_values : tuple of float
        Sampling periods (s).
    noise_pairs : tuple of (eta %, v %)
        Measurement noise levels (:func:`sampledyn.add_noise` amplitudes).
    seeds : int
        Noise realisations per noisy cell (the noise-free cell runs once).
    T, transient : float
        Duration of each run and the time after which the residual set is measured (s).
    surge, depth, heading : float
        Set point (m/s, m, rad). The run starts at the trim offset by ``offset``.
    offset : (depth m, heading rad)
        Initial error in depth and heading.
    buoyancy_pct : float
        Positive buoyancy in percent of the weight (the paper's +1 %).
    delay : bool
        Apply each command one sample late (designs then include the delay).
    """

    vehicles: tuple[str, ...] = ("rexrov", "bluerov2_heavy")
    methods: tuple[str, ...] = ("ZOH", *CLOSED_LOOP_METHODS)
    h_values: tuple[float, ...] = (0.1, 0.5)
    noise_pairs: tuple[tuple[float, float], ...] = ((0, 0), (2, 2), (10, 10), (20, 20))
    seeds: int = 5
    T: float = 600.0
    transient: float = 100.0
    surge: float = 0.5
    depth: float = 5.0
    heading: float = 0.5
    offset: tuple[float, float] = (-0.5, -0.2)
    buoyancy_pct: float = 1.0
    delay: bool = False
    base_seed: int = 0

    def __post_init__(self) -> None:
        if not 0 <= self.transient < self.T:
            raise ValueError(f"`transient` = {self.transient} s must be in [0, T = {self.T} s).")
        if self.seeds < 1:
            raise ValueError(f"`seeds` must be >= 1, got {self.seeds}.")
        for name in self.methods:
            if name != "ZOH":
                get_method(name)


def trim(vehicle: Any, surge: float, depth: float, heading: float) -> tuple[np.ndarray, np.ndarray]:
    """The equilibrium (x*, u*) of a depth / heading / surge hold: f = 0 in every state
    but the horizontal positions (x = y = 0 there), solved by Gauss-Newton with the
    minimum-norm step on (phi, theta, v, w, p, q, r, rpm), from the rpm of the
    minimum-norm thrust; converged to |f| < 1e-10.

    Raises
    ------
    ValueError
        if no trim is found (e.g. the thrusters cannot hold the set point).
    """
    x = np.zeros(12)
    x[2], x[5], x[6] = depth, heading, surge
    free = np.array([3, 4, 7, 8, 9, 10, 11])
    rows = np.array(_KEEP)
    need = -vehicle.mass_matrix @ vehicle.f(0.0, x, np.zeros(vehicle.nu))[6:]
    thrust = np.linalg.pinv(vehicle.allocation) @ need
    n = np.sign(thrust) * np.sqrt(np.abs(thrust) / vehicle.K1)
    scale = float(vehicle.n_max)
    for _ in range(50):
        r = vehicle.f(0.0, x, n)[rows]
        if np.abs(r).max() < 1e-10:
            return x, n
        J = np.hstack(
            [
                vehicle.jacobian(0.0, x, n)[np.ix_(rows, free)],
                vehicle.input_jacobian(0.0, x, n)[rows] * scale,
            ]
        )
        step = -np.linalg.pinv(J) @ r
        x[free] += step[: free.size]
        n = n + scale * step[free.size :]
    raise ValueError(
        f"no trim of {vehicle.name!r} at surge {surge} m/s, depth {depth} m, heading "
        f"{heading} rad (|f| = {np.abs(r).max():.3g} after 50 Gauss-Newton steps)."
    )


def _reduced_indices(d: Any) -> np.ndarray:
    """Entries of z that the design keeps: every block without x and y (and the held
    command with ``delay``)."""
    keep = [b * d.nx + i for b in range(len(d.layout)) for i in _KEEP]
    keep += list(range(len(d.layout) * d.nx, d.nz))
    return np.array(keep)


def _weights(d: Any, vehicle: Any) -> tuple[np.ndarray, np.ndarray]:
    """Q on the current state (first block) only, R on the thrusters."""
    keep = _reduced_indices(d)
    q = np.zeros(keep.size)
    q[: len(_KEEP)] = 1.0 / np.square(_MAX_DEV)
    r = np.full(d.nu, 1.0 / (_MAX_RPM_FRAC * vehicle.n_max) ** 2)
    return np.diag(q), np.diag(r)


def _dlqr(A: np.ndarray, B: np.ndarray, Q: np.ndarray, R: np.ndarray) -> np.ndarray:
    from scipy.linalg import solve_discrete_are

    P = solve_discrete_are(A, B, Q, R)
    return np.linalg.solve(R + B.T @ P @ B, B.T @ P @ A)


def _zoh(vehicle: Any, x: np.ndarray, u: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact zero-order-hold discretisation of the linearisation (Van Loan's block
    exponential)."""
    from scipy.linalg import expm

    A = vehicle.jacobian(0.0, x, u)
    B = vehicle.input_jacobian(0.0, x, u)
    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A, B
    E = expm(M * h)
    return E[:n, :n], E[:n, n:]


@dataclass(frozen=True)
class Design:
    """One LQR design: the law, the closed-loop spectral radius on its own model
    (``rho_design``) and with the exact plant's zero-order-hold linearisation
    (``rho_true``: the law builds z from past states and inputs as its rule does)."""

    method: str
    h: float
    law: LinearLaw
    rho_design: float
    rho_true: float


def _true_radius(law: LinearLaw, Az: np.ndarray, Bz: np.ndarray, F: np.ndarray, G: np.ndarray):
    """Spectral radius of the law on the exact linearised sampled plant x+ = Az x + Bz u.

    The law is u_n = K (z_n - z*) with z's blocks x_{n-l} or f_{n-l} = F x_{n-l} +
    G u_{n-l} (deviations); the loop state is (x_n..x_{n-H+1}, u_{n-1}..u_{n-H+1}) and
    the neutral positions x, y are left out."""
    d = law.design
    nx, nu, H = d.nx, d.nu, d.history
    if d.delay:
        return float("nan")
    Kx = np.zeros((nu, H * nx))
    Ku = np.zeros((nu, (H - 1) * nu))
    for b, (kind, lag) in enumerate(d.layout):
        Kb = law.gain[:, b * nx : (b + 1) * nx]
        if kind == "x":
            Kx[:, lag * nx : (lag + 1) * nx] += Kb
        else:
            Kx[:, lag * nx : (lag + 1) * nx] += Kb @ F
            Ku[:, (lag - 1) * nu : lag * nu] += Kb @ G
    n = H * nx + (H - 1) * nu
    M = np.zeros((n, n))
    M[:nx, : H * nx] = Bz @ Kx
    M[:nx, :nx] += Az
    M[:nx, H * nx :] = Bz @ Ku
    for lag in range(1, H):
        M[lag * nx : (lag + 1) * nx, (lag - 1) * nx : lag * nx] = np.eye(nx)
    if H > 1:
        M[H * nx : H * nx + nu, : H * nx] = Kx
        M[H * nx : H * nx + nu, H * nx :] = Ku
        for lag in range(1, H - 1):
            r, c = H * nx + lag * nu, H * nx + (lag - 1) * nu
            M[r : r + nu, c : c + nu] = np.eye(nu)
    idx = [i for i in range(n) if not (i < H * nx and i % nx in (0, 1))]
    return float(np.abs(np.linalg.eigvals(M[np.ix_(idx, idx)])).max())


def design_lqr(
    vehicle: Any, method: str, h: float, x_trim: np.ndarray, u_trim: np.ndarray, *, delay=False
) -> Design:
    """The discrete LQR of the hold designed on ``method``'s discrete-time model of
    ``vehicle`` at h ("ZOH": on the exact zero-order-hold linearisation, state x).

    u_n = u* - K (z_n - z*): z* is the model's steady state at the trim (x*, u*), K the
    LQR gain of the reduced linearisation (x, y dropped) with Bryson weights on the
    current state and the thrusters (the same Q, R for every rule).
    """
    d = discretize(vehicle, "RK4" if method == "ZOH" else method, h, delay=delay)
    z_star = d.steady_state(x_trim, u_trim)
    if method == "ZOH":
        Az, Bz = _zoh(vehicle, x_trim, u_trim, h)
        if delay:
            A = np.zeros((d.nz, d.nz))
            A[:12, :12], A[:12, 12:] = Az, Bz
            B = np.zeros((d.nz, d.nu))
            B[12:] = np.eye(d.nu)
            Az, Bz = A, B
    else:
        Az, Bz = d.linearize(z_star, u_trim)
    keep = _reduced_indices(d)
    A, B = Az[np.ix_(keep, keep)], Bz[keep]
    Q, R = _weights(d, vehicle)
    K = _dlqr(A, B, Q, R)
    gain = np.zeros((d.nu, d.nz))
    gain[:, keep] = -K
    rho = float(np.abs(np.linalg.eigvals(A - B @ K)).max())
    law = LinearLaw(d, gain, z_star, u_trim)
    F = vehicle.jacobian(0.0, x_trim, u_trim)
    G = vehicle.input_jacobian(0.0, x_trim, u_trim)
    rho_true = _true_radius(law, *_zoh(vehicle, x_trim, u_trim, h), F, G)
    return Design(method, float(h), law, rho, rho_true)


def _vehicle(name: str, buoyancy_pct: float) -> Any:
    import warnings

    from ..models import load_vehicle

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the RexROV's published M_A asymmetry, known
        return load_vehicle(name).with_buoyancy(buoyancy_pct)


# The envelope a run must stay in (deviation from the trim; x, y free): beyond it the
# loop has diverged (tumbling, or running away in depth), and the run stops there.
_ENVELOPE = (np.inf, np.inf, 50.0, 1.4, 1.4, np.inf, 5.0, 5.0, 5.0, 5.0, 5.0, 5.0)


def _envelope(x_trim: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    dev = np.array(_ENVELOPE)
    return x_trim - dev, x_trim + dev


def _run_rows(
    study: ClosedLoopStudy, vehicle: Any, design: Design, x0: np.ndarray, x_trim: np.ndarray,
    u_trim: np.ndarray, pair: tuple[float, float], seed: int,
) -> dict[str, Any]:  # fmt: skip
    run = run_loop(
        vehicle,
        design.law,
        study.T,
        design.h,
        x0,
        noise=pair if any(pair) else None,
        seed=np.random.SeedSequence([study.base_seed, seed]),
        envelope=_envelope(x_trim),
    )
    t = run.exact.t
    after = t >= study.transient
    row: dict[str, Any] = {}
    for idx, name, _unit in TRACKED:
        err = np.abs(run.exact.x[after, idx] - x_trim[idx])
        row[f"{name}_p95"] = float(np.percentile(err, 95))
        row[f"{name}_max"] = float(err.max())
    applied = np.clip(run.exact.u[after], -vehicle.n_max, vehicle.n_max)
    row["effort_rms"] = float(np.sqrt(np.mean(np.square(applied - u_trim))) / vehicle.n_max)
    row["saturated"] = float(np.mean(np.abs(run.exact.u[after]) >= vehicle.n_max))
    return row


def _one_step_errors(
    study: ClosedLoopStudy, vehicle: Any, h: float, x0: np.ndarray, x_trim: np.ndarray,
    u_trim: np.ndarray,
) -> dict[str, float]:  # fmt: skip
    """How good each rule is as a one-step model on this loop's own motion: rms (over
    the transient, the states z..r) of its one-step prediction error on the exact
    samples of the noise-free loop of the ZOH design (the same data for every rule)."""
    ref = design_lqr(vehicle, "ZOH", h, x_trim, u_trim)
    run = run_loop(vehicle, ref.law, study.transient, h, x0, envelope=_envelope(x_trim))
    out = {}
    for method in study.methods:
        if method == "ZOH":
            continue
        err = discretize(vehicle, method, h).rollout(run.exact, 1) - run.exact.x
        err = err[np.isfinite(err).all(axis=1), 2:]
        out[method] = float(np.sqrt(np.mean(np.sum(err * err, axis=1))))
    return out


def run_closed_loop_study(
    study: ClosedLoopStudy, progress: Callable[[str], None] | None = None
) -> list[dict[str, Any]]:
    """Every (vehicle, method, h, noise pair, seed) of ``study``: one row each.

    Row keys: vehicle, method, h, eta_pct, v_pct, seed, rho_design (closed-loop
    spectral radius on the design model), rho_true (on the exact plant's zero-order-
    hold linearisation), one_step_rms (the rule's one-step prediction error on the
    noise-free transient of the ZOH design's loop; NaN for ZOH), depth/heading/surge
    _p95 and _max (m, rad, m/s, after the transient), effort_rms (rms of the applied
    rpm minus the trim, in n_max), saturated (fraction of thruster-samples at n_max),
    status ("ok" or the failure, e.g. the loop diverged).
    """
    rows: list[dict[str, Any]] = []
    for vname in study.vehicles:
        vehicle = _vehicle(vname, study.buoyancy_pct)
        x_trim, u_trim = trim(vehicle, study.surge, study.depth, study.heading)
        x0 = x_trim.copy()
        x0[2] += study.offset[0]
        x0[5] += study.offset[1]
        for h in study.h_values:
            one_step = _one_step_errors(study, vehicle, h, x0, x_trim, u_trim)
            for method in study.methods:
                design = design_lqr(vehicle, method, h, x_trim, u_trim, delay=study.delay)
                if progress is not None:
                    progress(
                        f"{vname} {method} h={h:g}: closed-loop spectral radius "
                        f"{design.rho_design:.4f} on the design model, {design.rho_true:.4f} "
                        "on the exact plant (linearised)"
                    )
                for pair in study.noise_pairs:
                    for seed in range(study.seeds if any(pair) else 1):
                        base = {
                            "vehicle": vname, "method": method, "h": float(h),
                            "eta_pct": float(pair[0]), "v_pct": float(pair[1]), "seed": seed,
                            "rho_design": design.rho_design, "rho_true": design.rho_true,
                            "one_step_rms": one_step.get(method, float("nan")),
                        }  # fmt: skip
                        try:
                            base |= _run_rows(
                                study, vehicle, design, x0, x_trim, u_trim, pair, seed
                            )
                            base["status"] = "ok"
                        except RuntimeError as exc:  # EnvelopeExceeded, IntegrationError
                            base["status"] = f"diverged: {exc}"
                        rows.append(base)
    return rows


_METRICS = (
    "depth_p95", "depth_max", "heading_p95", "heading_max", "surge_p95", "surge_max",
    "effort_rms", "saturated",
)  # fmt: skip


def summarize_closed_loop(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Mean over seeds per (vehicle, method, h, eta_pct, v_pct); a cell with a
    diverged run reports NaN metrics and ``diverged`` = number of such runs."""
    groups: dict[tuple[Any, ...], list[dict[str, Any]]] = {}
    for r in rows:
        key = (r["vehicle"], r["method"], r["h"], r["eta_pct"], r["v_pct"])
        groups.setdefault(key, []).append(r)
    out = []
    for key, rs in groups.items():
        ok = [r for r in rs if r["status"] == "ok"]
        cell: dict[str, Any] = dict(
            zip(("vehicle", "method", "h", "eta_pct", "v_pct"), key, strict=True)
        )
        cell["rho_design"] = rs[0]["rho_design"]
        cell["rho_true"] = rs[0]["rho_true"]
        cell["one_step_rms"] = rs[0]["one_step_rms"]
        cell["runs"] = len(rs)
        cell["diverged"] = len(rs) - len(ok)
        for m in _METRICS:
            cell[m] = float(np.mean([r[m] for r in ok])) if len(ok) == len(rs) else float("nan")
        out.append(cell)
    return out
