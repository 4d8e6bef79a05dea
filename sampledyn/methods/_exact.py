"""The exact zero-order hold, ZOH: the sampled-data system that has no model error.

With the input held over [t_n, t_n + h), the exact sampled system is the flow of the
model over one interval, ``x_{n+1} = phi_h(t_n, x_n, u_n)``. As a rule it is a
discrete-time system only (:class:`~sampledyn.methods.DiscreteTimeSystem`), the
reference a controller designed on one of the approximate rules is compared with:

* its step is the flow, integrated by the simulator's compiled Dormand-Prince 8
  interval integrator with kink location (the ``flow`` kernel that
  :func:`sampledyn.discretize` provides; rtol = atol = 1e-12, the simulator's);
* its linearisation is the zero-order-hold discretisation of the model's
  linearisation, ``[[A_d, B_d], [0, I]] = exp(h [[F, G], [0, 0]])`` (Van Loan,
  "Computing integrals involving the matrix exponential", IEEE Trans. Automat.
  Control 23 (1978) 395-404): the exact derivative of the flow at an equilibrium of
  a time-invariant model (the operating point of a design); elsewhere the flow's
  derivative also depends on how F changes along the interval.

It predicts nothing on sampled data by itself (that would be an exact integration,
which the simulation layer does), so it is no :class:`~sampledyn.methods.Predictor`,
and its ``order`` is None: it has no truncation error.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..models import Model

__all__ = ["ExactFlow", "ExactHold", "zoh_matrices"]


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
        self, model: Model, t: float, z: np.ndarray, u: np.ndarray, h: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """(A_d, B_d) of the zero-order hold of the linearisation at (t, z, u):
        :func:`zoh_matrices` of F = df/dx and G = df/du there (see the module
        docstring for where that is the flow's exact derivative)."""
        z = np.asarray(z, dtype=float)
        u = np.asarray(u, dtype=float)
        F = np.asarray(model.jacobian(float(t), z, u), dtype=float)
        G = np.asarray(model.input_jacobian(float(t), z, u), dtype=float)
        return zoh_matrices(F, G, h)

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
