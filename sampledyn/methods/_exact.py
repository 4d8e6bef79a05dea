"""The exact zero-order hold, ZOH: the sampled-data system that has no model error.

With the input held over [t_n, t_n + h), the exact sampled system is the flow of the
model over one interval, ``x_{n+1} = phi_h(t_n, x_n, u_n)``. As a rule it is a
discrete-time system only (:class:`~sampledyn.methods.DiscreteTimeSystem`), the
reference a controller designed on one of the approximate rules is compared with:

* its step is the flow, integrated by the simulator's compiled Dormand-Prince 8
  interval integrator with kink location (the ``flow`` kernel that
  :func:`sampledyn.discretize` provides; rtol = atol = 1e-12, the simulator's);
* its linearisation is the derivative of that flow, ``A_d = d phi_h / d x_n``,
  ``B_d = d phi_h / d u_n``: the variational equations ``Phi' = f_x(t, x(t), u) Phi``,
  ``Gamma' = f_x Gamma + f_u`` from ``(I, 0)``, integrated along the flow by the same
  compiled integrator (the ``flow_jacobian`` that :func:`sampledyn.discretize`
  provides; rtol = atol = 1e-12 on the state and every entry of Phi and Gamma).
  Where f_x is constant over the interval (a trim: an equilibrium, or a motion in
  states that f does not depend on, as the horizontal positions of a vehicle holding
  surge; and every linear model at an equilibrium), that derivative is the
  zero-order-hold discretisation of the linearisation, ``[[A_d, B_d], [0, I]] =
  exp(h [[F, G], [0, 0]])`` (Van Loan, "Computing integrals involving the matrix
  exponential", IEEE Trans. Automat. Control 23 (1978) 395-404), which is then used
  (:func:`jacobian_constant` says when).

It predicts nothing on sampled data by itself (that would be an exact integration,
which the simulation layer does), so it is no :class:`~sampledyn.methods.Predictor`,
and its ``order`` is None: it has no truncation error.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..models import Model

__all__ = ["CONSTANT_JACOBIAN_RTOL", "ExactFlow", "ExactHold", "jacobian_constant", "zoh_matrices"]

# Relative size of a change that counts as none for :func:`jacobian_constant`: a state
# that moves by less over the interval, and a change of df/dx between the interval's
# ends below this (times 1 + max |df/dx|). By Gronwall's inequality a change dF of
# df/dx along the interval moves the flow's derivative from exp(F h) by at most
# h |dF| exp(h |F|): at 1e-10 that is the size of the variational integration's own
# error at rtol 1e-12 (local 1e-12 per step over tens to hundreds of steps).
CONSTANT_JACOBIAN_RTOL = 1e-10


def zoh_matrices(F: np.ndarray, G: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """``(A_d, B_d) = (e^{F h}, int_0^h e^{F s} ds G)``, shapes (n, n) and (n, m), from
    Van Loan's block exponential ``exp(h [[F, G], [0, 0]])`` (scipy's Pade
    scaling-and-squaring ``expm``)."""
    from scipy.linalg import expm

    n, m = G.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = F, G
    E = expm(M * h)
    return E[:n, :n], E[:n, n:]


def jacobian_constant(
    model: Model, t: float, x: np.ndarray, u: np.ndarray, h: float, F: np.ndarray, flow: Any
) -> bool:
    """True if ``F = df/dx(t, x, u)`` stays constant over the interval [t, t + h] with
    u held, so that ``exp(F h)`` is the flow's derivative (to
    :data:`CONSTANT_JACOBIAN_RTOL`): every state that moves over the interval
    (``h |f_k| > rtol (1 + |x_k|)``) is one f does not depend on here (column k of F
    zero), and df/dx at the interval's end, ``(t + h, flow(t, x, u, h))``, equals F to
    ``rtol (1 + max |F|)`` (this catches f's explicit time dependence and states
    that enter F only away from this point). F is not evaluated inside the interval:
    a df/dx that changes and comes back by t + h is taken as constant.

    Parameters
    ----------
    model : Model
    t : float
        t_n (s).
    x, u : ndarray, shapes (nx,) and (nu,)
        The state at t_n and the held input.
    h : float
        The interval (s).
    F : ndarray, shape (nx, nx)
        df/dx at (t, x, u).
    flow : callable
        ``flow(t, x, u, h)``: the state at t + h.
    """
    rtol = CONSTANT_JACOBIAN_RTOL
    f = np.asarray(model.f(float(t), x, u), dtype=float)
    moving = h * np.abs(f) > rtol * (1.0 + np.abs(x))
    if np.any(F[:, moving] != 0.0):
        return False
    end = np.asarray(flow(float(t), x, u, h), dtype=float)
    if not np.isfinite(end).all():
        return False
    F_end = np.asarray(model.jacobian(float(t) + h, end, u), dtype=float)
    return bool(np.abs(F_end - F).max() <= rtol * (1.0 + np.abs(F).max()))


_STEP = """RTOL = {rtol!r}
ATOL = {atol!r}


@njit(cache=CACHE, error_model="numpy")
def step(t, z, u, p, h, out):
    flow(t, z, u, p, h, RTOL, ATOL, out)
"""


@dataclass(frozen=True)
class ExactFlow:
    """The step of ZOH as data (a :class:`~sampledyn.methods.DiscreteStep`): z = x,
    z+ the flow over h with u held; ``rtol``, ``atol`` the integration tolerances."""

    rtol: float = 1e-12
    atol: float = 1e-12
    layout: tuple[tuple[str, int], ...] = (("x", 0),)
    kernels: frozenset[str] = field(default=frozenset({"flow"}))
    takes_f0: bool = False

    def source(self) -> str:
        """numba source of ``step(t, z, u, p, h, out)``: the ``flow(t, x, u, p, h, rtol,
        atol, out)`` kernel (NaN where the integration fails)."""
        return _STEP.format(rtol=float(self.rtol), atol=float(self.atol))

    def blocks(
        self, f: Any, t: Any, blocks: list[Any], u: Any, h: float, solver: Any = None
    ) -> list[Any]:
        """``[solver.flow(x, u, h)]``: the caller's integrator (e.g. CasADi's).

        Raises
        ------
        ValueError
            without a ``solver`` that integrates.
        """
        if solver is None or not hasattr(solver, "flow"):
            raise ValueError(
                "ZOH's step is the exact flow: a `solver` with flow(x, u, h) is needed."
            )
        return [solver.flow(blocks[0], u, h)]

    def linearize(
        self,
        model: Model,
        t: float,
        z: np.ndarray,
        u: np.ndarray,
        h: float,
        solver: Any = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """(A_d, B_d) = (d phi_h / d x, d phi_h / d u) at (t, z, u), shapes (nx, nx) and
        (nx, nu): the derivative of the flow over one interval with u held. Where
        :func:`jacobian_constant` holds, :func:`zoh_matrices` of F = df/dx and G =
        df/du there; elsewhere ``solver.flow_jacobian``, the variational equations
        integrated along the flow (see the module docstring).

        Raises
        ------
        ValueError
            without a ``solver`` that has ``flow(t, x, u, h)`` and
            ``flow_jacobian(t, x, u, h, rtol, atol)`` (:func:`sampledyn.discretize`
            gives one).
        JacobianUnavailableError
            if the model has no df/dx or df/du.
        """
        if solver is None or not hasattr(solver, "flow_jacobian"):
            raise ValueError(
                "ZOH's linearisation is the derivative of the exact flow: a `solver` "
                "with flow(t, x, u, h) and flow_jacobian(t, x, u, h, rtol, atol) is "
                "needed (sampledyn.discretize(model, 'ZOH', h).linearize gives one)."
            )
        z = np.asarray(z, dtype=float)
        u = np.asarray(u, dtype=float)
        F = np.asarray(model.jacobian(float(t), z, u), dtype=float)
        G = np.asarray(model.input_jacobian(float(t), z, u), dtype=float)
        if jacobian_constant(model, t, z, u, h, F, solver.flow):
            return zoh_matrices(F, G, h)
        A, B = solver.flow_jacobian(float(t), z, u, h, self.rtol, self.atol)
        return np.asarray(A, dtype=float), np.asarray(B, dtype=float)

    def steady_state(
        self, model: Model, x: np.ndarray, u: np.ndarray, t: float = 0.0
    ) -> np.ndarray:
        """z = x."""
        return np.array(x, dtype=float)


@dataclass(frozen=True)
class ExactHold:
    """ZOH: the exact sampled-data system with the input held (see the module
    docstring). A :class:`~sampledyn.methods.DiscreteTimeSystem`; ``order`` None."""

    name: str = "ZOH"
    rtol: float = 1e-12

    @property
    def family(self) -> str:
        return "ZOH"

    @property
    def order(self) -> None:
        """None: the exact map has no truncation error, hence no order."""
        return None

    @property
    def history(self) -> int:
        return 1

    @property
    def label(self) -> str:
        return self.name

    @property
    def discrete_step(self) -> ExactFlow:
        return ExactFlow(self.rtol, self.rtol)

    def amplification(self, z: Any) -> np.ndarray:
        """``|e^z|``: the exact flow grows a mode exactly as the model does (stable for
        Re lambda <= 0 at every step)."""
        zz = np.asarray(z, dtype=complex)
        return np.asarray(np.exp(np.minimum(zz.real, 700.0)))  # |e^z| = e^Re z, no overflow
