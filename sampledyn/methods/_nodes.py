"""Adams weights on the actual sample times (variable-step AB_s, ABu_s, ABj_s).

On non-uniform nodes t_n, t_{n-1}, ..., t_{n-s+1} the Adams-Bashforth prediction is

    x_{n+1} = x_n + h_n sum_{i<s} beta_{n,i} f_{n-i},   h_n = t_{n+1} - t_n,

with ``beta_{n,i}`` the integral over [0, 1] of the Lagrange basis polynomial of node
i on the nodes ``tau_i = (t_{n-i} - t_n) / h_n`` (Hairer, Norsett & Wanner, Solving
ODEs I, Sec. III.5: the variable-step Adams methods are the integrals of the
interpolant of the f-history; their divided-difference form is the same polynomial).
On a uniform grid tau_i = -i and beta_{n,i} = a_i, the fixed coefficients.

How it is computed, and why it is stable. Time is scaled by the predicted step, so the
nodes are O(1) apart (a jittered 10 Hz log has tau_i within 1 % of -i) and no power of
t is ever formed: each basis polynomial is evaluated by its product formula
``prod_{j != i} (tau - tau_j) / (tau_i - tau_j)`` (every factor carries one rounding
error, whatever s), and integrated by Gauss-Legendre quadrature with ceil(s/2) points,
exact for its degree s - 1. No Vandermonde matrix is solved (its condition grows
like 10^s for these nodes). On a uniform grid the weights agree with the exact
fractions to a few rounding units (tested up to s = 12).

The same integrals over [tau_j, 0] rebuild ABj_s's history on non-uniform nodes.

Noise gains on non-uniform grids. The increment moves by at most
``h_n sum_i |beta_{n,i}| L`` per unit of noise. Over all step patterns whose steps
lie within a factor ``ratio`` of each other (and below h_max), the supremum of
``h_n sum_i |beta_{n,i}|`` is attained at a corner of the box of steps: every step
either h_max or h_max / ratio (checked against random and locally optimised interior
patterns in the tests). For s >= 5 the worst corner is not the evenly compressed
history; so all 2^s corners are evaluated (s <= :data:`MAX_GAIN_ORDER`).
"""

from __future__ import annotations

import itertools
from functools import lru_cache

import numpy as np

__all__ = [
    "MAX_GAIN_ORDER",
    "corner_patterns",
    "history_nodes",
    "lagrange_integrals",
    "pattern_nodes",
]

# Largest order whose variable-step noise gain is computed (2^s corner patterns).
MAX_GAIN_ORDER = 12


@lru_cache(maxsize=32)
def _gauss_legendre(m: int) -> tuple[np.ndarray, np.ndarray]:
    x, w = np.polynomial.legendre.leggauss(m)
    x.setflags(write=False)
    w.setflags(write=False)
    return x, w


def lagrange_integrals(
    nodes: np.ndarray, lower: np.ndarray | float, upper: np.ndarray | float
) -> np.ndarray:
    """``w[r, k]``: integral over [lower_r, upper_r] of the Lagrange basis polynomial of
    node k on the nodes ``nodes[r]``, in scaled time (see the module docstring).

    Parameters
    ----------
    nodes : ndarray, shape (R, s)
        Distinct nodes per row, O(1) apart (time in units of a step).
    lower, upper : ndarray, shape (R,) or scalars
        Integration bounds per row, same units.

    Returns
    -------
    ndarray, shape (R, s); the rows sum to ``upper - lower`` (the basis sums to 1).
    """
    nodes = np.asarray(nodes, dtype=float)
    rows, s = nodes.shape
    x, wq = _gauss_legendre((s + 1) // 2)
    lo = np.broadcast_to(np.asarray(lower, dtype=float), (rows,))
    hi = np.broadcast_to(np.asarray(upper, dtype=float), (rows,))
    half = 0.5 * (hi - lo)
    tq = (0.5 * (hi + lo))[:, None] + half[:, None] * x[None, :]  # (R, m) points
    out = np.empty((rows, s))
    for k in range(s):
        basis = np.ones_like(tq)
        for j in range(s):
            if j != k:
                basis *= (tq - nodes[:, j, None]) / (nodes[:, k] - nodes[:, j])[:, None]
        out[:, k] = half * (basis @ wq)
    return out


def history_nodes(t: np.ndarray, s: int, n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Scaled nodes and steps of the predictions of x_{n+1} for the indices ``n``
    (each >= s - 1 and < N - 1).

    Returns
    -------
    tau : ndarray, shape (len(n), s)
        ``tau[r, i] = (t_{n-i} - t_n) / h_n`` (tau[:, 0] = 0).
    h : ndarray, shape (len(n),)
        ``h_n = t_{n+1} - t_n`` (s).
    """
    n = np.asarray(n)
    h = t[n + 1] - t[n]
    tau = (t[n[:, None] - np.arange(s)[None, :]] - t[n][:, None]) / h[:, None]
    return tau, h


def pattern_nodes(steps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and predicted steps of step patterns ``steps[p] = (h_n, h_{n-1}, ...,
    h_{n-s+1})``, shape (P, s): ``(tau (P, s), h_n (P,))`` as :func:`history_nodes`."""
    hn = steps[:, 0]
    back = np.concatenate([np.zeros((steps.shape[0], 1)), np.cumsum(steps[:, 1:], axis=1)], 1)
    return -back / hn[:, None], hn


@lru_cache(maxsize=128)
def corner_patterns(s: int, ratio: float) -> np.ndarray:
    """Every step pattern ``(h_n, ..., h_{n-s+1})`` with each step 1 or 1/ratio (units
    of the largest step), shape (2^s, s): the corners of the box of steps on which the
    variable-step noise gains take their supremum (see the module docstring).

    Raises
    ------
    ValueError
        for s > :data:`MAX_GAIN_ORDER`.
    """
    if s > MAX_GAIN_ORDER:
        raise ValueError(
            f"the noise gain on a non-uniform grid is computed for orders s <= "
            f"{MAX_GAIN_ORDER} (2^s step patterns), got s = {s}; resample to a uniform grid "
            "or use a lower order."
        )
    out = np.array(list(itertools.product((1.0, 1.0 / ratio), repeat=s)), dtype=float)
    out.setflags(write=False)
    return out
