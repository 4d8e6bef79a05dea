"""The engine's default cell kind: one-step prediction on noisy exact samples.

Shared per trajectory: the exact samples of the model under the study's input
(:func:`._compute.simulate_trajectory`, once per simulation; multiples of the smallest
h take every k-th sample). A cell: one rule's one-step prediction on the samples with
one noise pair and seed, measured by one norm (:func:`._compute.compute_chunk`).
"""

from __future__ import annotations

import dataclasses
import warnings
from typing import Any

import numpy as np

from ..._simulate import initial_state, simulate
from ..._trajectory import Trajectory
from ._cells import CellKind, Chunk, Setup, SimPlan
from ._compute import ChunkResult, SimResult, compute_chunk, simulate_trajectory

__all__ = ["PREDICTION", "PredictionCells"]


class PredictionCells(CellKind):
    """One rule's one-step prediction on noisy exact samples, measured by a norm."""

    name = "prediction"
    description = "one-step predictions of each rule on noisy exact samples, by norm"
    measure_label = "norms"
    measure_name = "norm"
    columns: tuple[tuple[str, type], ...] = (
        ("err_eta", float), ("err_v", float), ("err_all", float)
    )  # fmt: skip

    def measures(self, config: Any) -> tuple[str, ...]:
        return tuple(config.norms)

    def prepare(self, setup: Setup, sim: SimPlan) -> dict[str, SimResult]:
        return simulate_trajectory(setup, sim)

    def compute(self, setup: Setup, shared: SimResult, chunk: Chunk) -> ChunkResult:
        return compute_chunk(setup, shared, chunk)

    def warm_up(self, setup: Setup, h: float) -> None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                traj = simulate(setup.model, setup.signal, T=h, h=h, x0=setup.x0)
                setup.model.f(traj.t, traj.x, traj.u)
            except (ValueError, ArithmeticError, RuntimeError):
                pass  # a real failure is reported by the task that meets it

    def warm_up_cells(self, setup: Setup, sim: SimPlan, chunk: Chunk) -> None:
        # The first group of the chunk on 20 samples at the chunk's period, the norms
        # over the last 10, after every rule's history, as in a study. The samples are
        # stand-ins (the input's, the state held at x0), so the integrator is not
        # needed: on a first run it is still compiling elsewhere (start_pool). They
        # are a Trajectory as exact samples are (the same argument types: the same
        # compiled specialisations), taken every k-th as the study's are.
        k = max(k for _key, _h, k in sim.members)
        n = 20 * k + 1
        part = Chunk(chunk.traj_key, chunk.h, chunk.groups[:1], chunk.sim_key)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                stand_in = _stand_in(setup, sim, n)
                short = dataclasses.replace(
                    setup, T=(n - 1) * sim.h, after=10 * k * sim.h, reference=stand_in
                )
                shared = simulate_trajectory(short, sim)[chunk.traj_key]
                compute_chunk(short, shared, part)
            except Exception:  # a real failure is reported by the cells that meet it
                pass


def _stand_in(setup: Setup, sim: SimPlan, n: int) -> Trajectory:
    """``n`` samples at period ``sim.h`` of the study's input with the state held at
    the initial state: what :meth:`PredictionCells.warm_up_cells` compiles on."""
    model = setup.model
    signal = setup.signals[sim.input_index]
    t = np.arange(n) * sim.h
    x = np.tile(initial_state(model, setup.x0), (n, 1))
    return Trajectory(
        t=t, x=x, u=signal(t), h=sim.h, state_names=model.state_names,
        state_units=model.state_units, input_names=model.input_names,
        input_units=model.input_units, signal=signal,
    )  # fmt: skip


#: The registered prediction kind (the default of every sweep file).
PREDICTION = PredictionCells()
