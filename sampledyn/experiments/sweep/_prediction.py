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

from ..._simulate import simulate
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
        # The first group of the chunk on 20 samples at the chunk's period (the same
        # argument types as the real cells: the same compiled specialisations), the
        # norms over the last 10, after every rule's history, as in a study.
        k = max(k for _key, _h, k in sim.members)
        short = dataclasses.replace(setup, T=20 * k * sim.h, after=10 * k * sim.h, reference=None)
        part = Chunk(chunk.traj_key, chunk.h, chunk.groups[:1], chunk.sim_key)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                shared = simulate_trajectory(short, sim)[chunk.traj_key]
                compute_chunk(short, shared, part)
            except Exception:  # a real failure is reported by the cells that meet it
                pass


#: The registered prediction kind (the default of every sweep file).
PREDICTION = PredictionCells()
