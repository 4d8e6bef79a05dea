"""A rule's step as data (StepProgram): the compiled step, the vector blocks and the
linearisation all come from it, so a rule written only as a program is complete."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
import sympy as sp

from sampledyn._discretize import discretize
from sampledyn.methods import Combination, DiscreteTimeSystem, Stage, StepProgram, get_method
from sampledyn.models import SymbolicModel


@dataclass(frozen=True)
class Ralston:
    """Ralston's second-order Runge-Kutta rule (c_2 = 2/3, b = (1/4, 3/4)), known to
    the package only as this program (Hairer, Norsett & Wanner I, Sec. II.1)."""

    name: str = "Ralston"
    family: str = "Ralston"
    order: int = 2
    history: int = 1
    label: str = "Ralston"

    @property
    def discrete_step(self) -> StepProgram:
        return StepProgram(
            self.name,
            (("x", 0),),
            (Stage(0.0, ("z", 0)), Stage(2 / 3, Combination(("z", 0), ((2 / 3, ("k", 0)),)))),
            Combination(("z", 0), ((0.25, ("k", 0)), (0.75, ("k", 1))), outside=True),
        )


def _pendulum():
    th, om, tau = sp.symbols("theta omega tau")
    rhs = [om, -sp.sin(th) - 0.3 * om + tau]
    return SymbolicModel((th, om), (tau,), rhs, name="pendulum")


def test_a_rule_given_as_a_program_is_a_discrete_time_system():
    rule = Ralston()
    assert isinstance(rule, DiscreteTimeSystem) and get_method(rule) is rule
    model = _pendulum()
    d = discretize(model, rule, 0.1)
    rng = np.random.default_rng(0)
    for _ in range(5):
        x, u = rng.normal(size=2), rng.normal(size=1)
        # the compiled step and the numpy blocks run the same operations in the same order
        blocks = rule.discrete_step.blocks(model.f, 0.0, [x], u, 0.1)
        np.testing.assert_array_equal(d.step(x, u), blocks[0])
        # and the linearisation is the derivative of that step (central differences,
        # eps 1e-6: truncation ~1e-12, rounding ~1e-10)
        A, B = d.linearize(x, u)
        eps = 1e-6
        for i in range(2):
            dx = np.zeros(2)
            dx[i] = eps
            col = (d.step(x + dx, u) - d.step(x - dx, u)) / (2 * eps)
            np.testing.assert_allclose(A[:, i], col, rtol=0, atol=1e-8)
        col = (d.step(x, u + eps) - d.step(x, u - eps)) / (2 * eps)
        np.testing.assert_allclose(B[:, 0], col, rtol=0, atol=1e-8)


def test_built_in_programs_are_their_rules_steps():
    # The compiled step of a built-in rule equals its vector blocks bit for bit
    # (explicit rules) and, for Tustin, its Newton solution to the tolerance 1e-12.
    model = _pendulum()
    x, u = np.array([0.4, -0.2]), np.array([0.1])
    for name in ("E", "AB3", "ABu3", "RK3", "RK4", "T"):
        prog = get_method(name).discrete_step
        d = discretize(model, name, 0.05)
        z = d.steady_state(x, u) + 0.01 * np.arange(d.nz)
        blocks = [z[b * 2 : (b + 1) * 2] for b in range(len(prog.layout))]
        if name == "T":

            class Newton:
                def implicit(self, residual, guess):
                    from scipy.optimize import fsolve

                    return fsolve(residual, guess, xtol=1e-14)

            got = np.concatenate(prog.blocks(model.f, 0.0, blocks, u, 0.05, Newton()))
            np.testing.assert_allclose(d.step(z, u), got, rtol=1e-12, atol=1e-14)
        else:
            got = np.concatenate(prog.blocks(model.f, 0.0, blocks, u, 0.05))
            np.testing.assert_array_equal(d.step(z, u), got)


def test_a_program_that_refers_to_nothing_is_refused():
    with pytest.raises(ValueError, match=r"stage 1 refers to \('k', 1\)"):
        StepProgram("bad", (("x", 0),), (Stage(0.0, ("z", 0)), Stage(1.0, ("k", 1))), ("k", 0))
    with pytest.raises(ValueError, match="z must start with the state"):
        StepProgram("bad", (("f", 1),), (Stage(0.0, ("z", 0)),), ("k", 0))
    with pytest.raises(ValueError, match="`carry` needs 1 blocks"):
        StepProgram("bad", (("x", 0), ("x", 1)), (Stage(0.0, ("z", 0)),), ("k", 0))
    with pytest.raises(ValueError, match="implicit stage 0 needs an explicit stage 0"):
        StepProgram("bad", (("x", 0),), (Stage(1.0, ("z", 0), implicit=0.5),), ("y", 0))
    with pytest.raises(ValueError, match="is implicit"):
        get_method("T").discrete_step.blocks(lambda t, x, u: x, 0.0, [np.zeros(1)], 0.0, 0.1)
