"""Models whose f jumps: the branches sampledyn derives, and f on a surface."""

from __future__ import annotations

import numpy as np
import sympy as sp

import sampledyn as sd
from sampledyn.models import SymbolicModel

x, y, v, u = sp.symbols("x y v u")


def test_jumps_are_the_state_dependent_sign_heaviside_and_piecewise():
    model = SymbolicModel(
        [x, y],
        [u],
        [sp.sign(x - 1) + sp.Abs(y) + sp.Heaviside(u), sp.Piecewise((x, y > 0.5), (0, True))],
    )
    # Abs is a kink only; Heaviside(u) jumps in time only (the input), needs no branch
    assert {str(g) for g in model.expressions["kinks"]} == {"x - 1", "y", "u", "y - 0.5"}
    assert {str(g) for g in model.expressions["jumps"]} == {"x - 1", "y - 0.5"}
    branch, grad, q, info = model.jump_kernel()
    names = model.switching_names()
    sides = {names[k]: int(info[k, 0]) for k in range(len(names)) if info[k, 0] >= 0}
    assert set(sides) == {"x - 1", "y - 0.5"} and q.size == 2
    # The branch of each side, wherever the state is: at x = 2 (x - 1 > 0) the
    # negative side's branch gives sign = -1; the formula's own value never enters.
    state, inp = np.array([2.0, 0.25]), np.array([-3.0])
    out = np.empty(2)
    for s_x, s_y in ((1.0, 1.0), (-1.0, 1.0), (1.0, -1.0)):
        qq = q.copy()
        qq[sides["x - 1"]], qq[sides["y - 0.5"]] = s_x, s_y
        branch(0.0, state, inp, qq, out)
        np.testing.assert_array_equal(out, [s_x + 0.25 + 0.0, 2.0 if s_y > 0 else 0.0])
    # gradients: rows (dg/dx, dg/dy, dg/dt, dg/du)
    G = np.empty((len(names), 4))
    grad(0.0, state, inp, q, G)
    np.testing.assert_array_equal(G[names.index("x - 1")], [1.0, 0.0, 0.0, 0.0])
    np.testing.assert_array_equal(G[names.index("u")], [0.0, 0.0, 0.0, 1.0])


def test_f_on_a_surface_is_never_the_formulas_value_there():
    # x' = -sign(x) (sliding at 0), x' = 1 - sign(x)/2 (crossing upwards), and
    # x' = sign(x) (repelling): sign(0) = 0 is the formula's value at 0.
    sliding = SymbolicModel([x], [u], [-sp.sign(x)])
    crossing = SymbolicModel([x], [u], [1 - sp.sign(x) / 2])
    heaviside = SymbolicModel([x], [u], [1 - sp.Heaviside(x) / 4])  # 1/2 at 0 not used
    zero, nothing = np.array([0.0]), np.array([0.0])
    assert sliding.f(0.0, zero, nothing)[0] == 0.0  # Filippov's sliding vector
    assert crossing.f(0.0, zero, nothing)[0] == 0.5  # the side it moves into: x > 0
    assert heaviside.f(0.0, zero, nothing)[0] == 0.75
    # off the surface: the branch of the side the state is on
    assert crossing.f(0.0, np.array([-1e-300]), nothing)[0] == 1.5
    np.testing.assert_array_equal(
        sliding.f(np.zeros(3), np.array([[-1.0], [0.0], [2.0]]), np.zeros((3, 1)))[:, 0],
        [1.0, 0.0, -1.0],
    )


def test_models_without_jumps_keep_their_kernels():
    # Kinks only: no branch kernel, the generated source as before (no surface code).
    model = SymbolicModel([x, v], [u], [v, -x - v * sp.Abs(v) + u])
    assert model.jump_kernel() is None and model.expressions["jumps"] == ()
    assert "branch" not in open(model.source_file).read()
    assert getattr(sd.models.AUVLike(), "jump_kernel", None) is None  # kinks only
