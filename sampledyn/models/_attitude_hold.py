"""A vehicle with a roll-pitch attitude hold on its vertical thrusters.

Not in the paper: its Fig. 6 input is open loop. On a vehicle with a small righting
arm (the BlueROV2 Heavy has BG = 1 cm, a maximum righting moment W BG = 1.3 N m) the
Fig. 6 forward thrust, applied 8.5 cm below the centre of gravity, pitches the vehicle
over, and the vertical thrusters' sinusoids drive roll near its natural frequency. A
PD hold on roll and pitch keeps the attitude small, as in the paper's run, while the
Fig. 6 rpm stay the reference of every thruster:

    n = n_ref + Delta n(x),   Delta n = P (-(k_p (phi, theta) + k_d (p, q))) / (2 K1 n_lin)

P (N_thr x 2) maps desired roll and pitch moments (N m) to vertical thrust increments
(minimum norm, no net heave); the division converts thrust to rpm about the operating
point n_lin. The applied rpm ``n`` is what the thrusters turn at and what a log would
record; the model's input is the reference ``n_ref``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numba import njit

from ._base import RHS_SIG, CompiledModel
from ._vehicle_kernels import vehicle_rhs, vehicle_switch

__all__ = ["AttitudeHold"]


# p = [len(p_vehicle), p_vehicle..., G (N x 12, row-major)]: the loop computes the
# applied rpm n = u + G x[:12] and calls the plant's own kernels with it, so the
# vehicle kernel knows nothing about the controller.


@njit(cache=True)
def _applied(x, u, p):  # pragma: no cover - compiled
    nv = int(p[0])
    nt = u.shape[0]
    g0 = 1 + nv
    n = np.empty(nt)
    for i in range(nt):
        acc = u[i]
        for j in range(12):
            acc += p[g0 + 12 * i + j] * x[j]
        n[i] = acc
    return n


@njit(RHS_SIG, cache=True)
def _hold_rhs(t, x, u, p, out):  # pragma: no cover - compiled
    vehicle_rhs(t, x, _applied(x, u, p), p[1 : 1 + int(p[0])], out)


@njit(RHS_SIG, cache=True)
def _hold_switch(t, x, u, p, out):  # pragma: no cover - compiled
    # The plant's switching values (|v| v, n |n|, saturation) at the applied rpm.
    vehicle_switch(t, x, _applied(x, u, p), p[1 : 1 + int(p[0])], out)


@dataclass(frozen=True)
class AttitudeHold(CompiledModel):
    """``vehicle`` with a roll-pitch PD hold on its vertical thrusters.

    Parameters
    ----------
    vehicle : Vehicle
        The open-loop vehicle (without the thruster-lag option).
    kp : float
        Moment per radian of roll or pitch (N m/rad). Default 40: with the BlueROV2
        Heavy's roll inertia and added inertia (0.45 kg m^2) the loop's natural
        frequency is about 1.5 Hz, above the Fig. 6 sinusoids (0.15-0.3 Hz).
    kd : float
        Moment per rad/s of roll or pitch rate (N m s/rad). Default 6 (damping ratio
        about 0.7 on that inertia).
    n_lin_frac : float
        Operating point n_lin of the thrust-to-rpm conversion, as a fraction of n_max.
    """

    vehicle: Any
    kp: float = 40.0
    kd: float = 6.0
    n_lin_frac: float = 0.3
    gains: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        v = self.vehicle
        if getattr(v, "thruster_lag", False):
            raise ValueError("`vehicle` must not use the thruster-lag option here.")
        for name in ("kp", "kd", "n_lin_frac"):
            if not getattr(self, name) > 0:
                raise ValueError(f"`{name}` must be > 0, got {getattr(self, name)}.")
        d = np.asarray(v.thruster_directions, dtype=float)
        vertical = np.abs(d[:, 2]) > np.hypot(d[:, 0], d[:, 1])
        if vertical.sum() < 2:
            raise ValueError("the attitude hold needs at least 2 vertical thrusters.")
        alloc = np.asarray(v.allocation)  # rows: X, Y, Z, K, M, N
        sub = alloc[3:5][:, vertical]  # roll and pitch moment per unit thrust
        rows = np.vstack([alloc[2][vertical], sub])  # keep heave out of the correction
        pinv = np.linalg.pinv(rows)[:, 1:]  # (n_vertical, 2): moments -> thrusts
        p_map = np.zeros((d.shape[0], 2))
        p_map[vertical] = pinv
        scale = 1.0 / (2.0 * v.K1 * self.n_lin_frac * v.n_max)  # rpm per N
        gains = np.zeros((d.shape[0], 4))
        gains[:, 0:2] = -self.kp * p_map * scale  # roll, pitch angle
        gains[:, 2:4] = -self.kd * p_map * scale  # roll, pitch rate
        object.__setattr__(self, "gains", gains)

    # The model protocol, delegating names and sizes to the vehicle.
    @property
    def nx(self) -> int:  # type: ignore[override]
        return int(self.vehicle.nx)

    @property
    def nu(self) -> int:  # type: ignore[override]
        return int(self.vehicle.nu)

    @property
    def state_names(self) -> tuple[str, ...]:  # type: ignore[override]
        return tuple(self.vehicle.state_names)

    @property
    def state_units(self) -> tuple[str, ...]:  # type: ignore[override]
        return tuple(self.vehicle.state_units)

    @property
    def input_names(self) -> tuple[str, ...]:  # type: ignore[override]
        return tuple(f"{n}_ref" for n in self.vehicle.input_names)

    @property
    def input_units(self) -> tuple[str, ...]:  # type: ignore[override]
        return tuple(self.vehicle.input_units)

    @property
    def name(self) -> str:
        return f"{self.vehicle.name} + attitude hold"

    def _p(self) -> np.ndarray:
        pv = np.asarray(self.vehicle.kernel()[1], dtype=float)
        feedback = np.zeros((self.gains.shape[0], 12))
        feedback[:, [3, 4, 9, 10]] = self.gains
        return np.concatenate([[float(pv.shape[0])], pv, feedback.ravel()])

    def kernel(self) -> tuple[Any, np.ndarray]:
        return _hold_rhs, self._p()

    def switch_kernel(self) -> tuple[Any, np.ndarray, np.ndarray]:
        """The vehicle's switching values at the applied rpm."""
        _, _, input_only = self.vehicle.switch_kernel()
        # the applied rpm depend on the state through the feedback
        return _hold_switch, self._p(), np.zeros_like(input_only)

    def applied_rpm(self, x: Any, u_ref: Any) -> np.ndarray:
        """Applied rpm n = n_ref + Delta n(x), shape (N, N_thr)."""
        x = np.atleast_2d(np.asarray(x, dtype=float))
        att = x[:, [3, 4, 9, 10]]
        return np.asarray(u_ref, dtype=float) + att @ self.gains.T

    def jacobian(self, t: Any, x: Any, u: Any) -> np.ndarray:
        """df/dx by central differences (step 1e-6 relative); the open-loop vehicle
        has the analytic Jacobian."""
        single = np.ndim(x) == 1
        x = np.atleast_2d(np.asarray(x, dtype=float))
        u = np.broadcast_to(np.asarray(u, dtype=float), (x.shape[0], self.nu))
        out = np.empty((x.shape[0], self.nx, self.nx))
        for j in range(self.nx):
            step = 1e-6 * np.maximum(1.0, np.abs(x[:, j]))
            xp, xm = x.copy(), x.copy()
            xp[:, j] += step
            xm[:, j] -= step
            out[:, :, j] = (self.f(t, xp, u) - self.f(t, xm, u)) / (2 * step[:, None])
        return out[0] if single else out
