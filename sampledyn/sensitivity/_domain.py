"""The state domain over which the Jacobian bounds (19)-(23) are taken.

A box: ``|v_i| <= v_max[i]`` for the six body rates, ``|phi| <= phi_max``,
``|theta| <= theta_max`` (the Jacobians do not depend on the positions x, y, z nor
on the yaw psi), and ``|n_j| <= rpm_frac * n_max`` for every thruster.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..models import Model

__all__ = ["Domain", "check_vehicle", "pitch_guard"]

_V_NAMES = ("u", "v", "w", "p", "q", "r")


def _finite_nonneg(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise TypeError(f"`{name}` must be a number, got {type(value).__name__}.")
    v = float(value)
    if not math.isfinite(v) or v < 0:
        raise ValueError(f"`{name}` must be finite and >= 0, got {value!r}.")
    return v


@dataclass(frozen=True)
class Domain:
    """A box of states and inputs (immutable).

    Parameters
    ----------
    v_max : array_like, shape (6,)
        Bounds on ``|u|, |v|, |w|`` (m/s) and ``|p|, |q|, |r|`` (rad/s). A ball
        ``||v|| <= V`` lies inside the box with every bound V.
    phi_max_deg : float
        Bound on the roll ``|phi|`` (deg), at most 180.
    theta_max_deg : float
        Bound on the pitch ``|theta|`` (deg), below 90 (J(eta) is singular there).
    rpm_frac : float
        Bound on every thruster speed, ``|n_j| <= rpm_frac * n_max`` (fraction of the
        vehicle's maximum rpm). Default 1.
    """

    v_max: tuple[float, ...]
    phi_max_deg: float
    theta_max_deg: float
    rpm_frac: float = 1.0

    def __post_init__(self) -> None:
        v = np.asarray(self.v_max, dtype=float) if not isinstance(self.v_max, str) else None
        if v is None or v.shape != (6,) or not np.isfinite(v).all() or (v < 0).any():
            raise ValueError(
                f"`v_max` must be 6 finite numbers >= 0 (m/s, rad/s), got {self.v_max!r}."
            )
        object.__setattr__(self, "v_max", tuple(float(c) for c in v))
        phi = _finite_nonneg("phi_max_deg", self.phi_max_deg)
        if phi > 180.0:
            raise ValueError(f"`phi_max_deg` must be at most 180 deg, got {phi}.")
        theta = _finite_nonneg("theta_max_deg", self.theta_max_deg)
        if theta >= 90.0:
            raise ValueError(
                f"`theta_max_deg` must be below 90 deg, got {theta}: the Euler-angle "
                "kinematics J(eta) of eq. (6) is singular at theta = +-90 deg, so no "
                "Jacobian bound exists there (eqs. (22)-(23) grow like 1/cos(theta))."
            )
        object.__setattr__(self, "phi_max_deg", phi)
        object.__setattr__(self, "theta_max_deg", theta)
        object.__setattr__(self, "rpm_frac", _finite_nonneg("rpm_frac", self.rpm_frac))

    @property
    def v_array(self) -> np.ndarray:
        """``v_max`` as an array, shape (6,)."""
        return np.asarray(self.v_max)

    @property
    def phi_max(self) -> float:
        """Roll bound (rad)."""
        return math.radians(self.phi_max_deg)

    @property
    def theta_max(self) -> float:
        """Pitch bound (rad)."""
        return math.radians(self.theta_max_deg)

    @property
    def speed_max(self) -> float:
        """``max ||v||`` over the box: the Euclidean norm of ``v_max`` (mixed units)."""
        return float(np.linalg.norm(self.v_array))

    @classmethod
    def from_trajectory(
        cls,
        traj: Any,
        n_max: float,
        signal: Any = None,
        *,
        margin: float = 0.0,
    ) -> Domain:
        """The smallest box that holds the samples of ``traj`` (and the input).

        Parameters
        ----------
        traj : Trajectory
            Vehicle samples, ``x`` shape (N, 12) (eta then v), ``u`` shape (N, n_thr).
        n_max : float
            The vehicle's maximum rpm.
        signal : Signal, optional
            The input in continuous time; its rpm between the samples (sampled 20 times
            per period) also count, since Runge-Kutta stages use them.
        margin : float
            Relative widening of every bound (e.g. 0.1 for 10 %).
        """
        x = np.asarray(traj.x, dtype=float)
        if x.ndim != 2 or x.shape[1] < 12:
            raise ValueError(f"`traj.x` must have shape (N, 12), got {x.shape}.")
        margin = _finite_nonneg("margin", margin)
        n_max = _finite_nonneg("n_max", n_max)
        if n_max == 0:
            raise ValueError("`n_max` must be > 0 rpm.")
        grow = 1.0 + margin
        rpm = float(np.abs(traj.u).max()) if traj.u.size else 0.0
        if signal is not None:
            t_fine = np.linspace(float(traj.t[0]), float(traj.t[-1]), 20 * len(traj.t))
            for c0 in range(0, t_fine.size, 100_000):  # bounded memory on long runs
                rpm = max(rpm, float(np.abs(signal(t_fine[c0 : c0 + 100_000])).max()))
        theta = min(float(np.degrees(np.abs(x[:, 4]).max())) * grow, 89.999)
        return cls(
            v_max=tuple(np.abs(x[:, 6:12]).max(axis=0) * grow),
            phi_max_deg=min(float(np.degrees(np.abs(x[:, 3]).max())) * grow, 180.0),
            theta_max_deg=theta,
            rpm_frac=rpm * grow / n_max,
        )

    def enlarged(self, amplitudes: Any) -> Domain:
        """The box widened by noise amplitudes, so that it holds every noisy state.

        Parameters
        ----------
        amplitudes : array_like, shape (12,)
            Noise amplitude of each state component (eta then v, state units), as
            from :func:`sampledyn._noise.noise_amplitudes`.

        Raises
        ------
        ValueError
            If the widened pitch bound reaches 90 deg.
        """
        a = np.asarray(amplitudes, dtype=float)
        if a.shape[0] < 12:
            raise ValueError(f"`amplitudes` must have 12 entries (eta, v), got {a.shape}.")
        theta = self.theta_max_deg + math.degrees(a[4])
        if theta >= 90.0:
            raise ValueError(
                f"the pitch noise amplitude {math.degrees(a[4]):.3g} deg widens "
                f"`theta_max_deg` = {self.theta_max_deg:g} deg to {theta:.4g} deg, at or past "
                "the singularity at 90 deg; lower `eta_pct` or the pitch range."
            )
        return Domain(
            v_max=tuple(self.v_array + a[6:12]),
            phi_max_deg=min(self.phi_max_deg + math.degrees(a[3]), 180.0),
            theta_max_deg=theta,
            rpm_frac=self.rpm_frac,
        )

    def describe(self) -> str:
        """One line: the bounds with their units."""
        v = ", ".join(f"|{n}|<={b:.3g}" for n, b in zip(_V_NAMES, self.v_max, strict=True))
        return (
            f"{v} (m/s, rad/s); |phi|<={self.phi_max_deg:.3g} deg, "
            f"|theta|<={self.theta_max_deg:.3g} deg; |n|<={self.rpm_frac:.3g} n_max"
        )


def check_vehicle(model: Model, argument: str = "vehicle") -> None:
    """Raise unless ``model`` is a 6-DoF :class:`~sampledyn.models.Vehicle` without lag."""
    from ..models import Vehicle

    if not isinstance(model, Vehicle):
        raise TypeError(
            f"`{argument}` must be a sampledyn.models.Vehicle (the 6-DoF model of eqs. "
            f"(5)-(7)), got {type(model).__name__}; load one with "
            "sampledyn.models.load_vehicle('bluerov2_heavy')."
        )
    if model.thruster_lag:
        raise ValueError(
            f"`{argument}` has thruster_lag=True; the bounds (19)-(25) assume the thruster "
            "dynamics (3) are parasitic (section 5). Use vehicle.with_params(thruster_lag=False)."
        )


def pitch_guard(vehicle: Any, theta_deg: Any, argument: str, *, stacklevel: int = 3) -> None:
    """Raise near theta = 90 deg and warn past the vehicle's ``pitch_limit_deg``.

    ``stacklevel`` is that of the warning as seen from this function's caller's
    caller (3 points at the user's call of a public function calling this).
    """
    worst = float(np.max(np.abs(np.asarray(theta_deg, dtype=float)))) if np.size(theta_deg) else 0.0
    if worst >= 90.0 - vehicle.pitch_tolerance_deg:
        raise ValueError(
            f"`{argument}` reaches |theta| = {worst:.4g} deg, within the vehicle's "
            f"pitch_tolerance_deg = {vehicle.pitch_tolerance_deg:g} deg of 90 deg, where the "
            "Euler-angle kinematics J(eta) of eq. (6) is singular (||J|| = "
            "1/sqrt(1 - |sin theta|), eq. (22)). Keep |theta| below "
            f"{90.0 - vehicle.pitch_tolerance_deg:g} deg."
        )
    if worst > vehicle.pitch_limit_deg:
        warnings.warn(
            f"`{argument}` reaches |theta| = {worst:.3g} deg, past the vehicle's "
            f"pitch_limit_deg = {vehicle.pitch_limit_deg:g} deg: ||J|| = "
            f"{1.0 / math.sqrt(1.0 - math.sin(math.radians(worst))):.3g} and dJ/deta grow "
            "without bound towards 90 deg (eqs. (22)-(23)); the bounds there are huge.",
            stacklevel=stacklevel,
        )
