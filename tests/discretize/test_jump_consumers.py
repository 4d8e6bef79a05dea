"""Consumers of models whose f jumps: the CasADi export, linearize at a surface."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

import sampledyn as sd
from sampledyn.models import SymbolicModel

x, y, u = sp.symbols("x y u")


def test_casadi_exports_piecewise_as_if_else():
    pytest.importorskip("casadi")
    from sampledyn._discretize._casadi import casadi_rhs

    model = SymbolicModel(
        [x, y],
        [u],
        [
            sp.Piecewise((-2, x > y), (2, True)) + u,
            sp.Piecewise((-3, (y > x) & (u < 1)), (1.5 * x, y < -1), (0.5, True)),
        ],
    )
    F = casadi_rhs(model)
    rng = np.random.default_rng(2)
    for _ in range(50):
        xx, uu = rng.normal(size=2) * 2, rng.normal(size=1) * 2
        # the same branch selection as the compiled kernel; the values are constants
        # and 1.5 x, so the two agree to the last bit
        np.testing.assert_array_equal(np.asarray(F(xx, uu)).ravel(), model.f(0.0, xx, uu))


def test_linearize_refuses_a_state_on_a_jump_surface():
    model = SymbolicModel([x, y], [u], [y, -x - 0.15 * sp.sign(y) + u])
    dm = sd.discretize(model, "E", 0.1)
    with pytest.raises(ValueError, match=r"switching surface y = 0.*no Jacobian"):
        dm.linearize([0.3, 0.0], [0.0])
    A, _ = dm.linearize([0.3, 0.2], [0.0])  # off the surface: the branch's Jacobian
    np.testing.assert_allclose(A, np.eye(2) + 0.1 * np.array([[0.0, 1.0], [-1.0, 0.0]]))
