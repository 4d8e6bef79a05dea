"""Closed-loop study: does a better one-step model give a better digital controller?

For each vehicle (RexROV and BlueROV2 Heavy, open loop: both have 8 thrusters in a
fully actuated layout, so the LQR holds roll and pitch itself and no attitude hold is
needed), each sampled-data rule and each sampling period, the same discrete LQR is
designed on the rule's discrete-time model (:func:`sampledyn.discretize`) linearised at
the trim for a depth / heading / surge hold, and run against the exact plant
(:func:`sampledyn.run_loop`: input held between samples, thrusters
saturating at n_max inside the plant) with the paper's measurement noise. Measured:
the tracking residual set (95th and 100th percentile of |depth|, |heading| and |surge|
error after the transient) and the control effort. A design on the exact zero-order
hold (the registered rule ``ZOH``, :class:`sampledyn.methods.ExactHold`: its
linearisation is the matrix exponential, a perfect one-step model of the linearised
plant) is the reference row.

A run that leaves the envelope (roll or pitch beyond 80 deg, a velocity beyond 5 m/s or
5 rad/s, depth 50 m off) stops there and is reported as diverged: such a loop tumbles
or runs away, and integrating it exactly to the end would only cost time.

The study runs on the experiment engine (:mod:`sampledyn.experiments.sweep`) with cells
of kind ``closed_loop`` (:class:`ClosedLoopCells`): planned by the same planner (one
plan per vehicle: h x noise pair x seed x design), computed in this process, on local
workers or on Dask, and kept in a results store if one is given (a killed run
resumes; ``sampledyn results`` and ``report`` read it). The trim is computed once per
vehicle, the designs and one-step errors once per (vehicle, h) and shared by all
the runs; one run is a compiled loop of T/h sampling intervals with the control law
evaluated in compiled code.

Frames: the state is (eta, v) = (x, y, z, phi, theta, psi, u, v, w, p, q, r) in NED /
FRD (z down, depth = z). The positions x and y enter no other equation, so they are
removed from the design (every block of z), which is exact; they get zero gain.
"""

from __future__ import annotations

import math
import os
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._discretize import LinearLaw, discretize, run_loop
from .._discretize._model import check_rule
from ..exceptions import SingularPitchError, SweepConfigError
from ..methods import get_method
from ..models import Model
from ._studies import StudyDefinition
from .sweep import CellKind, SweepConfig
from .sweep._cells import warning_text, worker_name
from .sweep._compute import CELL_ERRORS, ChunkResult, SimResult

__all__ = [
    "CLOSED_LOOP",
    "CLOSED_LOOP_METHODS",
    "CLOSED_LOOP_STUDY",
    "ClosedLoopCells",
    "ClosedLoopStudy",
    "design_lqr",
    "run_closed_loop_study",
    "summarize_closed_loop",
    "trim",
]

CLOSED_LOOP_METHODS = ("E", "AB2", "AB4", "ABu4", "RK4", "T")
# The reference design, and the rule whose loop's motion the one-step errors are
# measured on: the exact zero-order hold.
REFERENCE = "ZOH"
# Tracked outputs: state index, name, unit.
TRACKED = ((2, "depth", "m"), (5, "heading", "rad"), (6, "surge", "m/s"))
# States kept in the design (all but the horizontal positions x, y).
_KEEP = tuple(range(2, 12))
# Bryson weights: the deviation of each kept state that costs as much as 1/2 n_max on
# one thruster (z, phi, theta, psi, u, v, w, p, q, r).
_MAX_DEV = (0.5, 0.2, 0.2, 0.3, 0.2, 0.3, 0.3, 0.5, 0.5, 0.5)
_MAX_RPM_FRAC = 0.5
# The set point of the hold and the initial error (defaults of the study and of a
# closed_loop sweep file).
_SETPOINT = {"surge": 0.5, "depth": 5.0, "heading": 0.5}  # m/s, m, rad
_OFFSET = {"depth": -0.5, "heading": -0.2}  # m, rad


@dataclass(frozen=True)
class ClosedLoopStudy:
    """Settings of the closed-loop study (defaults: the issue's grid).

    The grid values are checked by the engine's
    :class:`~sampledyn.experiments.sweep.SweepConfig` (one per vehicle), once.

    Attributes
    ----------
    vehicle : tuple of str
        Built-in vehicle names or vehicle files.
    methods : tuple of str
        Rules the LQR is designed on (discrete-time systems); "ZOH" is the design on
        the exact zero-order hold.
    h : tuple of float
        Sampling periods (s).
    noise_pairs : tuple of (eta %, v %)
        Measurement noise levels (:func:`sampledyn.add_noise` amplitudes).
    seeds : int
        Noise realisations per noisy cell (the noise-free cell runs once).
    T, after : float
        Duration of each run and the time after which the residual set is measured (s).
    surge, depth, heading : float
        Set point (m/s, m, rad). The run starts at the trim offset by ``offset``.
    offset : (depth m, heading rad)
        Initial error in depth and heading.
    buoyancy_pct : float
        Positive buoyancy in percent of the weight (the paper's +1 %).
    delay : bool
        Apply each command one sample late (designs then include the delay).
    seed : int
        Root of the noise seeds: seed k draws from SeedSequence([seed, k]).
    distribution : str
        Noise distribution, "uniform" (the paper's) or "gaussian".
    rtol : float
        Tolerance (relative and absolute) of the plant's exact integration between
        samples; the residual sets measured are >= 1e-7.
    """

    vehicle: tuple[str, ...] = ("rexrov", "bluerov2_heavy")
    methods: tuple[str, ...] = (REFERENCE, *CLOSED_LOOP_METHODS)
    h: tuple[float, ...] = (0.1, 0.5)
    noise_pairs: tuple[tuple[float, float], ...] = ((0, 0), (2, 2), (10, 10), (20, 20))
    seeds: int = 5
    T: float = 600.0
    after: float = 100.0
    surge: float = _SETPOINT["surge"]
    depth: float = _SETPOINT["depth"]
    heading: float = _SETPOINT["heading"]
    offset: tuple[float, float] = (_OFFSET["depth"], _OFFSET["heading"])
    buoyancy_pct: float = 1.0
    delay: bool = False
    seed: int = 0
    distribution: str = "uniform"
    rtol: float = 1e-10


_FREE = np.array([3, 4, 7, 8, 9, 10, 11])  # phi, theta, v, w, p, q, r
_TRIM_TOL = 1e-10  # |f| of an accepted trim (the state units' rounding is ~1e-16)
_CONTINUATION_STEPS = 20  # surge steps from 0 to the set point, each halved on failure
# The straight, roll-free hold: phi = v = 0 kept, theta, w, p, q, r and the rpm free.
_LEVEL = np.array([4, 8, 9, 10, 11])


def _gauss_newton(
    vehicle: Any, x: np.ndarray, n: np.ndarray, iters: int = 50, free: np.ndarray = _FREE
) -> tuple[np.ndarray, np.ndarray, float]:
    """Gauss-Newton with the minimum-norm step on the states ``free`` (default phi,
    theta, v, w, p, q, r) and rpm / n_max for f = 0 in every state but x, y; ``(x, n,
    max |f|)``, converged when max |f| < ``_TRIM_TOL``. ``x`` is updated in place."""
    rows = np.array(_KEEP)
    scale = float(vehicle.n_max)
    r = vehicle.f(0.0, x, n)[rows]
    for _ in range(iters):
        r = vehicle.f(0.0, x, n)[rows]
        if np.abs(r).max() < _TRIM_TOL:
            return x, n, float(np.abs(r).max())
        J = np.hstack(
            [
                vehicle.jacobian(0.0, x, n)[np.ix_(rows, free)],
                vehicle.input_jacobian(0.0, x, n)[rows] * scale,
            ]
        )
        step = -np.linalg.pinv(J) @ r
        x[free] += step[: free.size]
        n = n + scale * step[free.size :]
    return x, n, float(np.abs(r).max())


def _attempt(
    vehicle: Any, x: np.ndarray, n: np.ndarray, free: np.ndarray = _FREE
) -> tuple[np.ndarray, np.ndarray, float]:
    """:func:`_gauss_newton`, a diverging attempt (non-finite, or through the singular
    pitch) returned with an infinite residual."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the pitch warnings of a diverging iterate
            xs, ns, res = _gauss_newton(vehicle, x.copy(), np.array(n, dtype=float), free=free)
    except (SingularPitchError, FloatingPointError):
        return x, n, math.inf
    if not (np.isfinite(xs).all() and np.isfinite(ns).all()):
        return x, n, math.inf
    return xs, ns, res


def _set_point(surge: float, depth: float, heading: float) -> np.ndarray:
    x = np.zeros(12)
    x[2], x[5], x[6] = depth, heading, surge
    return x


def _continuation(
    vehicle: Any, surge: float, depth: float, heading: float
) -> tuple[np.ndarray, np.ndarray, float]:
    """The trim reached from hovering (surge 0) by raising the surge step by step, each
    solve starting at the previous trim (a step that fails is halved, down to 1/32 of
    it): the equilibrium on the branch of the level hover."""
    x, n, res = _attempt(
        vehicle, _set_point(0.0, depth, heading), _start_rpm(vehicle, 0.0, depth, heading), _LEVEL
    )
    if not res < _TRIM_TOL:
        return x, n, res
    done, step, last = 0.0, surge / _CONTINUATION_STEPS, res
    while done != surge and abs(step) >= abs(surge) / (32 * _CONTINUATION_STEPS):
        target = done + step if abs(done + step) < abs(surge) else surge
        trial = x.copy()
        trial[6] = target
        xs, ns, res = _attempt(vehicle, trial, n, free=_LEVEL)
        if res < _TRIM_TOL:
            x, n, done, last = xs, ns, target, res
        else:
            step /= 2
    return x, n, (last if done == surge else math.inf)


def _start_rpm(vehicle: Any, surge: float, depth: float, heading: float) -> np.ndarray:
    """The rpm of the minimum-norm thrust that holds the set point level."""
    x = _set_point(surge, depth, heading)
    need = -vehicle.mass_matrix @ vehicle.f(0.0, x, np.zeros(vehicle.nu))[6:]
    thrust = np.linalg.pinv(vehicle.allocation) @ need
    return np.asarray(np.sign(thrust) * np.sqrt(np.abs(thrust) / vehicle.K1))


def _multistart(
    vehicle: Any, surge: float, depth: float, heading: float, free: np.ndarray
) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Trims from level-thrust starts at pitch angles -60..60 deg (every 5 deg)."""
    found = []
    n0 = _start_rpm(vehicle, surge, depth, heading)
    for theta in np.radians(np.arange(-60.0, 61.0, 5.0)):
        x = _set_point(surge, depth, heading)
        x[4] = theta
        found.append(_attempt(vehicle, x, n0, free))
    return found


def trim(
    vehicle: Any,
    surge: float,
    depth: float,
    heading: float,
    *,
    max_pitch_deg: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The equilibrium (x*, u*) of a depth / heading / surge hold: f = 0 in every state
    but the horizontal positions (x = y = 0 there).

    Each solve is Gauss-Newton with the minimum-norm step (the rpm scaled by n_max) to
    |f| < 1e-10. The equilibria form a family (more unknowns than equations; a solve
    may land on a strongly tilted one, or on none from a poor start), so the hold is
    sought as straight, roll-free motion first: phi = v = 0, theta, w, p, q, r and the
    rpm free, by continuation in the surge from hovering (steps from 0, each solve from
    the last trim; a step that fails is halved) and from starts at pitch -60..60 deg
    (every 5 deg); the least pitched of these is the level trim. The direct solve with
    every attitude and rate free (phi, theta, v, w, p, q, r), from the rpm of the
    minimum-norm level thrust, is taken when it agrees with the level trim's attitude to
    1 deg (or no level trim exists), otherwise the level trim, with a warning. A trim
    counts when |f| < 1e-10 (recomputed), every thruster is within +-n_max and |theta|
    <= ``max_pitch_deg``.

    Parameters
    ----------
    vehicle : Vehicle
    surge, depth, heading : float
        Set point (m/s, m, rad).
    max_pitch_deg : float, optional
        Largest |theta| accepted (deg); default the vehicle's ``pitch_limit_deg``
        (beyond it J(eta) is near its singularity).

    Raises
    ------
    ValueError
        if no trim is found (e.g. the thrusters cannot hold the set point), giving the
        smallest residual |f| reached; or if the only trims found have a pitch beyond
        ``max_pitch_deg`` (naming it; give a larger ``max_pitch_deg`` to accept it).
    """
    limit = float(vehicle.pitch_limit_deg if max_pitch_deg is None else max_pitch_deg)
    n0 = _start_rpm(vehicle, surge, depth, heading)
    direct = _attempt(vehicle, _set_point(surge, depth, heading), n0)
    level = [
        _continuation(vehicle, surge, depth, heading),
        *_multistart(vehicle, surge, depth, heading, _LEVEL),
    ]
    where = f"{vehicle.name!r} at surge {surge} m/s, depth {depth} m, heading {heading} rad"
    return _choose(vehicle, direct, level, limit, where)


_SAME_TILT_DEG = 1.0  # the direct solve's trim is the level trim's when within this


def _converged(vehicle: Any, trial: tuple[np.ndarray, np.ndarray, float]) -> bool:
    """|f| < 1e-10 (recomputed) with every thruster within +-n_max."""
    x, n, res = trial
    if not res < _TRIM_TOL or (np.abs(n) > vehicle.n_max).any():
        return False
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        again = np.abs(vehicle.f(0.0, x, n)[np.array(_KEEP)]).max()
    return bool(again < _TRIM_TOL)


def _pitch(trial: tuple[np.ndarray, np.ndarray, float]) -> float:
    return abs(float(np.degrees(trial[0][4])))


def _choose(
    vehicle: Any,
    direct: tuple[np.ndarray, np.ndarray, float],
    level: list[tuple[np.ndarray, np.ndarray, float]],
    limit: float,
    where: str,
) -> tuple[np.ndarray, np.ndarray]:
    """The trim :func:`trim` returns (see there), or why there is none."""
    converged = [t for t in (direct, *level) if _converged(vehicle, t)]
    within = [t for t in converged if _pitch(t) <= limit]
    flat = [t for t in within if t is not direct]
    best = min(flat, key=_pitch) if flat else None
    if any(t is direct for t in within) and (
        best is None or np.degrees(np.abs(direct[0][3:5] - best[0][3:5])).max() <= _SAME_TILT_DEG
    ):
        return direct[0], direct[1]
    if best is not None:
        if any(t is direct for t in converged):
            warnings.warn(
                f"trim of {where}: the direct solve found an equilibrium at theta = "
                f"{np.degrees(direct[0][4]):.3g} deg, phi = {np.degrees(direct[0][3]):.3g} "
                f"deg; the straight, roll-free hold (phi = v = 0) at theta = "
                f"{np.degrees(best[0][4]):.3g} deg is taken.",
                UserWarning,
                stacklevel=3,
            )
        return best[0], best[1]
    if converged:
        t = min(converged, key=_pitch)
        raise ValueError(
            f"the only trims found of {where} have a pitch beyond the limit {limit:g} deg "
            f"(the least: theta = {np.degrees(t[0][4]):.3g} deg, phi = "
            f"{np.degrees(t[0][3]):.3g} deg, thrusters {np.array2string(t[1], precision=0)} "
            "rpm): hardly a hold to design for; give max_pitch_deg=... to accept it, or "
            "another set point."
        )
    residual = min(t[2] for t in (direct, *level))
    raise ValueError(
        f"no trim of {where}: the direct solve, the continuation from hovering and starts "
        f"at pitch -60..60 deg all fail (smallest |f| reached {residual:.3g}; 1e-10 "
        f"needed); the thrusters (n_max {vehicle.n_max:g} rpm) may not hold the set point: "
        "try a smaller surge."
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
    ``vehicle`` at h ("ZOH": on the exact zero-order hold, whose linearisation is the
    matrix exponential).

    u_n = u* - K (z_n - z*): z* is the model's steady state at the trim (x*, u*), K the
    LQR gain of the reduced linearisation (x, y dropped) with Bryson weights on the
    current state and the thrusters (the same Q, R for every rule).
    """
    d = discretize(vehicle, method, h, delay=delay)
    z_star = d.steady_state(x_trim, u_trim)
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
    exact = discretize(vehicle, REFERENCE, h).linearize(x_trim, u_trim)
    rho_true = _true_radius(law, *exact, F, G)
    return Design(method, float(h), law, rho, rho_true)


# The envelope a run must stay in (deviation from the trim; x, y free): beyond it the
# loop has diverged (tumbling, or running away in depth), and the run stops there.
_ENVELOPE = (np.inf, np.inf, 50.0, 1.4, 1.4, np.inf, 5.0, 5.0, 5.0, 5.0, 5.0, 5.0)


def _envelope(x_trim: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    dev = np.array(_ENVELOPE)
    return x_trim - dev, x_trim + dev


def _tracking(
    vehicle: Any, law: LinearLaw, h: float, setup: Any, pair: tuple[float, float], seed: int
) -> dict[str, float]:
    """One run of ``law`` on the exact plant with the noise pair and seed: the residual
    set after the transient and the effort (raises RuntimeError if it diverges)."""
    data = setup.data
    x_trim, u_trim = data["x_trim"], data["u_trim"]
    run = run_loop(
        vehicle,
        law,
        setup.T,
        h,
        data["x0"],
        noise=pair if any(pair) else None,
        seed=np.random.SeedSequence([setup.base_seed, seed]),
        distribution=setup.distribution,
        envelope=_envelope(x_trim),
        rtol=setup.rtol,
        atol=setup.rtol,
    )
    t = run.exact.t
    after = t >= setup.after
    row: dict[str, float] = {}
    for idx, name, _unit in TRACKED:
        err = np.abs(run.exact.x[after, idx] - x_trim[idx])
        row[f"{name}_p95"] = float(np.percentile(err, 95))
        row[f"{name}_max"] = float(err.max())
    applied = np.clip(run.exact.u[after], -vehicle.n_max, vehicle.n_max)
    row["effort_rms"] = float(np.sqrt(np.mean(np.square(applied - u_trim))) / vehicle.n_max)
    row["saturated"] = float(np.mean(np.abs(run.exact.u[after]) >= vehicle.n_max))
    return row


def _one_step_errors(vehicle: Any, h: float, setup: Any) -> dict[str, float]:
    """How good each rule is as a one-step model on this loop's own motion: rms (over
    the transient, the states z..r) of its one-step prediction error on the exact
    samples of the noise-free loop of the ZOH design (the same data for every rule)."""
    data = setup.data
    x_trim, u_trim = data["x_trim"], data["u_trim"]
    ref = design_lqr(vehicle, REFERENCE, h, x_trim, u_trim)
    run = run_loop(
        vehicle, ref.law, setup.after, h, data["x0"], envelope=_envelope(x_trim),
        rtol=setup.rtol, atol=setup.rtol,
    )  # fmt: skip
    out = {}
    for method in data["methods"]:
        if get_method(method).order is None:
            continue  # an exact map (ZOH) has no one-step model error
        err = discretize(vehicle, method, h).rollout(run.exact, 1) - run.exact.x
        err = err[np.isfinite(err).all(axis=1), 2:]
        out[method] = float(np.sqrt(np.mean(np.sum(err * err, axis=1))))
    return out


def _table(key: str, value: Any, defaults: dict[str, float]) -> dict[str, float]:
    if not isinstance(value, dict):
        raise SweepConfigError(
            key, f"`{key}` must be a table of {', '.join(defaults)}, got {value!r}."
        )
    bad = sorted(set(value) - set(defaults))
    if bad:
        raise SweepConfigError(
            key, f"`{key}` has no entry `{bad[0]}`; its entries: {', '.join(defaults)}."
        )
    out = {**defaults}
    for name, v in value.items():
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise SweepConfigError(key, f"`{key}.{name}` must be a finite number, got {v!r}.")
        out[name] = float(v)
    return out


class ClosedLoopCells(CellKind):
    """The cells of the closed-loop study: one LQR design run against the exact plant.

    Shared: the trim (once per study, on the client), and per h the LQR design on
    every rule and each rule's one-step error on the ZOH loop's motion (once per h,
    on one worker). A cell: one (rule, noise pair, seed) run of its design on the
    exact plant (:func:`sampledyn.run_loop`), measured as the residual set
    after the transient (``after``) and the effort; a diverged run is a result
    (``outcome`` "diverged: ..."), not a failed cell.

    Sweep-file keys of its own: ``setpoint = { surge = 0.5, depth = 5.0, heading =
    0.5 }`` (m/s, m, rad), ``offset = { depth = -0.5, heading = -0.2 }`` (the initial
    error, m and rad), ``delay = false`` (each command one sample late). ``methods``
    may name ``ZOH``, the design on the exact zero-order-hold linearisation; ``rtol``
    is the tolerance of the plant's integration between samples.
    """

    name = "closed_loop"
    description = "the same discrete LQR designed on each rule's model, run on the exact plant"
    uses = frozenset(
        ("buoyancy_pct", "methods", "orders", "eta_pct", "v_pct", "noise", "seeds",
         "base_seed", "distribution", "rtol")
    )  # fmt: skip
    option_keys = ("setpoint", "offset", "delay")
    needs_input = False
    subsample = False
    measure_label = "measures"
    columns = (
        *((n, float) for n in ("rho_design", "rho_true", "one_step_rms")),
        *((n, float) for n in ("depth_p95", "depth_max", "heading_p95", "heading_max",
                               "surge_p95", "surge_max", "effort_rms", "saturated")),
        ("outcome", str),
    )  # fmt: skip

    def check_options(self, options: Mapping[str, Any]) -> dict[str, Any]:
        delay = options.get("delay", False)
        if not isinstance(delay, bool):
            raise SweepConfigError("delay", f"`delay` must be true or false, got {delay!r}.")
        return {
            "setpoint": _table("setpoint", options.get("setpoint", {}), _SETPOINT),
            "offset": _table("offset", options.get("offset", {}), _OFFSET),
            "delay": delay,
        }

    def check_method(self, name: str) -> None:
        check_rule(name, None)  # the grid's check names `methods`

    def method_order(self, name: str) -> int | None:
        return get_method(name).order

    def measures(self, config: Any) -> tuple[str, ...]:
        return ("tracking",)

    def setup_data(self, config: Any, model: Model) -> dict[str, Any]:
        sp, off = config.options["setpoint"], config.options["offset"]
        x_trim, u_trim = trim(model, sp["surge"], sp["depth"], sp["heading"])
        x0 = x_trim.copy()
        x0[2] += off["depth"]
        x0[5] += off["heading"]
        return {
            "x_trim": x_trim,
            "u_trim": u_trim,
            "x0": x0,
            "methods": tuple(config.methods),
            "delay": bool(config.options["delay"]),
        }

    def prepare(self, setup: Any, sim: Any) -> dict[str, SimResult]:
        (traj_key, h, _k), = sim.members  # fmt: skip
        data = setup.data
        t0 = time.perf_counter()
        designs: dict[str, dict[str, Any]] = {}
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            for method in data["methods"]:
                try:
                    d = design_lqr(
                        setup.model, method, h, data["x_trim"], data["u_trim"],
                        delay=data["delay"],
                    )  # fmt: skip
                    designs[method] = {
                        "gain": d.law.gain, "z_ref": d.law.z_ref,
                        "rho_design": d.rho_design, "rho_true": d.rho_true,
                    }  # fmt: skip
                except CELL_ERRORS as exc:
                    designs[method] = {"error": f"LQR design failed: {type(exc).__name__}: {exc}"}
            try:
                one_step = _one_step_errors(setup.model, h, setup)
            except CELL_ERRORS as exc:
                one_step = {}
                warnings.warn(f"one-step errors on the ZOH loop failed: {exc}", stacklevel=1)
        summary = {
            "one_step_rms": one_step,
            "rho_design": {m: d["rho_design"] for m, d in designs.items() if "error" not in d},
            "rho_true": {m: d["rho_true"] for m, d in designs.items() if "error" not in d},
        }
        meta = {
            "h": h, "worker": worker_name(), "status": "ok", "error": "",
            "seconds": time.perf_counter() - t0, "n_samples": int(round(setup.T / h)) + 1,
            "certificate": math.nan, "simulated_h": h, "summary": summary,
            "warnings": warning_text(caught),
        }  # fmt: skip
        shared = {"designs": designs, "one_step": one_step}
        return {traj_key: SimResult(traj_key, None, meta, None, 0, shared)}

    def compute(self, setup: Any, shared: SimResult, chunk: Any) -> ChunkResult:
        vehicle, h, data = setup.model, chunk.h, setup.data
        designs, one_step = shared.data["designs"], shared.data["one_step"]
        laws: dict[str, LinearLaw] = {}
        rows = []
        for group in chunk.groups:
            pair = (group.eta_pct, group.v_pct)
            for key, method, _measure in group.cells:
                t0 = time.perf_counter()
                design = designs[method]
                values: dict[str, Any] = {}
                error = design.get("error", "")
                with warnings.catch_warnings(record=True) as caught:
                    warnings.simplefilter("always")
                    if not error:
                        values = {
                            "rho_design": design["rho_design"], "rho_true": design["rho_true"],
                            "one_step_rms": one_step.get(method, math.nan),
                        }  # fmt: skip
                        try:
                            if method not in laws:
                                model = discretize(vehicle, method, h, delay=data["delay"])
                                laws[method] = LinearLaw(
                                    model, design["gain"], design["z_ref"], data["u_trim"]
                                )
                            values |= _tracking(vehicle, laws[method], h, setup, pair, group.seed)
                            values["outcome"] = "ok"
                        except RuntimeError as exc:  # EnvelopeExceeded, IntegrationError
                            values["outcome"] = f"diverged: {exc}"
                        except CELL_ERRORS as exc:
                            error = f"{type(exc).__name__}: {exc}"[:400]
                rows.append(
                    {
                        "key": key, "status": "error" if error else "ok", "values": values,
                        "seconds": time.perf_counter() - t0, "error": error,
                        "warnings": warning_text(caught), "worker": worker_name(),
                    }
                )  # fmt: skip
        return ChunkResult(chunk.traj_key, shared.meta, rows)

    def warm_up(self, setup: Any, h: float) -> None:
        data = setup.data
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                ref = design_lqr(setup.model, REFERENCE, h, data["x_trim"], data["u_trim"])
                run_loop(setup.model, ref.law, h, h, data["x0"], rtol=setup.rtol)
                for method in data["methods"]:
                    discretize(setup.model, method, h, delay=data["delay"])
            except (*CELL_ERRORS, NotImplementedError):
                pass  # a real failure is reported by the task that meets it


CLOSED_LOOP = ClosedLoopCells()


def _config(study: ClosedLoopStudy, vehicle: str) -> SweepConfig:
    """The engine's grid of ``study`` on one vehicle (checked when made)."""
    return SweepConfig(
        kind=CLOSED_LOOP.name,
        vehicle=vehicle,
        buoyancy_pct=study.buoyancy_pct,
        T=study.T,
        after=study.after,
        h=tuple(study.h),
        methods=tuple(study.methods),
        noise=tuple((float(e), float(v)) for e, v in study.noise_pairs),
        seeds=range(study.seeds) if isinstance(study.seeds, int) else study.seeds,
        base_seed=study.seed,
        distribution=study.distribution,
        rtol=study.rtol,
        options={
            "setpoint": {"surge": study.surge, "depth": study.depth, "heading": study.heading},
            "offset": {"depth": study.offset[0], "heading": study.offset[1]},
            "delay": study.delay,
        },
    )


def study_order(study: Any) -> Callable[[dict[str, Any]], tuple[int, int, int, int]]:
    """Sort key of an engine cell in a controller study's own order: h, method, noise
    pair (as the study lists them), seed (the order of the rows the studies' own
    loops wrote, which the engine's plan, h-noise-seed-method, is not)."""
    hs = {float(h): i for i, h in enumerate(study.h)}
    methods = {m: i for i, m in enumerate(study.methods)}
    pairs = {(float(e), float(v)): i for i, (e, v) in enumerate(study.noise_pairs)}

    def key(c: dict[str, Any]) -> tuple[int, int, int, int]:
        return hs[c["h"]], methods[c["method"]], pairs[(c["eta_pct"], c["v_pct"])], c["seed"]

    return key


def _rows(vehicle: str, study: ClosedLoopStudy, cells: list[dict[str, Any]]) -> list[dict]:
    """The engine's cells as the study's rows, in the study's order."""
    out = []
    for r in sorted(cells, key=study_order(study)):
        row: dict[str, Any] = {
            "vehicle": vehicle, "method": r["method"], "h": float(r["h"]),
            "eta_pct": float(r["eta_pct"]), "v_pct": float(r["v_pct"]), "seed": int(r["seed"]),
            "rho_design": r["rho_design"], "rho_true": r["rho_true"],
            "one_step_rms": r["one_step_rms"],
        }  # fmt: skip
        if r["status"] != "ok":
            row["status"] = f"error: {r.get('error') or 'failed'}"
        elif r["outcome"] == "ok":
            row |= {k: r[k] for k in _METRICS}
            row["status"] = "ok"
        else:
            row["status"] = r["outcome"]
        out.append(row)
    return out


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


class ClosedLoopDefinition(StudyDefinition):
    """The closed-loop study: one engine run per vehicle."""

    name = "closed-loop"
    settings_type = ClosedLoopStudy

    def configs(self, settings: ClosedLoopStudy) -> tuple[SweepConfig, ...]:
        return tuple(_config(settings, vehicle) for vehicle in settings.vehicle)

    def rows(self, settings: ClosedLoopStudy, results: Sequence[Any]) -> list[dict[str, Any]]:
        return [
            row
            for vehicle, result in zip(settings.vehicle, results, strict=True)
            for row in _rows(vehicle, settings, result.cells)
        ]

    def summary(self, settings: ClosedLoopStudy, rows: list[dict[str, Any]]) -> list[dict]:
        return summarize_closed_loop(rows)


#: The registered study ``reproduce closed-loop``.
CLOSED_LOOP_STUDY = ClosedLoopDefinition()


def run_closed_loop_study(
    study: ClosedLoopStudy,
    progress: Callable[[str], None] | None = None,
    *,
    store: str | os.PathLike[str] | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    progress_bar: bool = False,
) -> list[dict[str, Any]]:
    """Every (vehicle, method, h, noise pair, seed) of ``study``: one row each,
    computed on the experiment engine (one run per vehicle, cells of kind
    ``closed_loop``; :meth:`StudyDefinition.run` of :data:`CLOSED_LOOP_STUDY`).

    Parameters
    ----------
    study : ClosedLoopStudy
    progress : callable, optional
        Called with one line per vehicle: what the engine computed and found stored.
    store : path, optional
        Results store: the cells are kept there, a rerun (after a kill) computes only
        the missing ones, and ``sampledyn results`` / ``report`` read them.
    workers : int, optional
        Local worker processes (default: this process).
    scheduler : str, optional
        Address of a Dask scheduler instead.
    progress_bar : bool
        Show the engine's progress bar.

    Returns
    -------
    list of dict
        Row keys: vehicle, method, h, eta_pct, v_pct, seed, rho_design (closed-loop
        spectral radius on the design model), rho_true (on the exact plant's
        zero-order-hold linearisation), one_step_rms (the rule's one-step prediction
        error on the noise-free transient of the ZOH design's loop; NaN for ZOH),
        depth/heading/surge _p95 and _max (m, rad, m/s, after the transient),
        effort_rms (rms of the applied rpm minus the trim, in n_max), saturated
        (fraction of thruster-samples at n_max), status ("ok", "diverged: ..." when
        the loop left the envelope, or "error: ..." when the design failed).
    """
    return CLOSED_LOOP_STUDY.run(
        study, store=store, workers=workers, scheduler=scheduler, progress=progress_bar,
        say=progress,
    ).rows  # fmt: skip
