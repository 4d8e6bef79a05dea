"""What a worker runs: exact samples of one trajectory, then chunks of cells on them.

Both functions are pure (same arguments, same numbers, on any worker) and return
plain picklable values; only the client writes the results store.

A deterministic failure of a cell (e.g. the vehicle pitching through 90 deg, where
J(eta) is singular) is returned as a row with status "error" and the message, so the
sweep goes on and a rerun does not retry it (``--retry-failed`` does).
"""

from __future__ import annotations

import os
import socket
import time
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..._trajectory import Trajectory
from ...errors import error_norm, local_errors
from ...methods import ConvergenceError, get_method
from ...noise import NOISE_REFERENCE, add_noise
from ...simulate import IntegrationError, simulate
from ._plan import Chunk, Group, Setup

__all__ = ["ChunkResult", "SimResult", "compute_chunk", "simulate_trajectory"]

# Failures that are a property of the cell (deterministic), recorded as its result.
CELL_ERRORS = (ValueError, ArithmeticError, IntegrationError, ConvergenceError)
_MAX_MESSAGE = 400


@dataclass(frozen=True)
class SimResult:
    """Exact samples of one trajectory (``traj`` None if simulation failed)."""

    traj_key: str
    traj: Trajectory | None
    meta: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class ChunkResult:
    """Rows of one chunk: dicts with the key, status, norms, timing and messages."""

    traj_key: str
    sim_meta: dict[str, Any]
    rows: list[dict[str, Any]]


def _worker() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


def _messages(caught: list[warnings.WarningMessage]) -> str:
    text = "; ".join(dict.fromkeys(str(w.message) for w in caught))
    return text[:_MAX_MESSAGE]


def simulate_trajectory(setup: Setup, traj_key: str, h: float) -> SimResult:
    """Exact samples at period ``h`` with their certificate (kept in ``meta`` only)."""
    t0 = time.perf_counter()
    meta: dict[str, Any] = {"h": h, "worker": _worker()}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            traj = simulate(setup.model, setup.signal, T=setup.T, h=h, x0=setup.x0)
        except CELL_ERRORS as exc:
            meta.update(status="error", error=f"exact samples failed: {exc}"[:_MAX_MESSAGE])
            meta.update(seconds=time.perf_counter() - t0, warnings=_messages(caught))
            return SimResult(traj_key, None, meta)
    cert = traj.certificate
    meta.update(
        status="ok",
        error="",
        seconds=time.perf_counter() - t0,
        n_samples=traj.n_samples,
        certificate=cert.max_error if cert is not None else float("nan"),
        warnings=_messages(caught),
    )
    # The certificate's per-interval arrays are summarised above; do not ship them.
    return SimResult(traj_key, traj.replace(certificate=None), meta)


def _groups(units: tuple[str, ...]) -> dict[str, np.ndarray]:
    """State components of eta (positions, angles) and v (rates), by unit."""
    kind = np.array([NOISE_REFERENCE.get(u, ("", 0.0))[0] for u in units])
    return {"eta": np.flatnonzero(kind == "eta"), "v": np.flatnonzero(kind == "v")}


def _norms(
    err: np.ndarray, t: np.ndarray, norm: str, after: float, comps: dict
) -> dict[str, float]:
    out = {"err_all": error_norm(err, t, norm, after)}
    for name, idx in comps.items():
        out[f"err_{name}"] = error_norm(err, t, norm, after, idx) if idx.size else float("nan")
    return out


def _group_rows(setup: Setup, traj: Trajectory, group: Group) -> list[dict[str, Any]]:
    t_group = time.perf_counter()
    seq = np.random.SeedSequence([setup.base_seed, group.seed])
    measured = add_noise(traj, group.eta_pct, group.v_pct, seq, distribution=setup.distribution)
    comps = _groups(traj.state_units)
    cache: dict[Any, Any] = {}  # f at the samples, shared by every AB-type rule
    by_method: dict[str, list[tuple[str, str]]] = {}
    for key, name, norm in group.cells:
        by_method.setdefault(name, []).append((key, norm))
    rows: list[dict[str, Any]] = []
    shared = time.perf_counter() - t_group
    for method_name, cells in by_method.items():
        t0 = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                method = get_method(method_name)
                x_hat = np.asarray(method.predict(setup.model, measured, setup.signal, cache=cache))
                err = local_errors(x_hat, measured)
                values = [
                    (key, norm, _norms(err, measured.t, norm, setup.after, comps), "")
                    for key, norm in cells
                ]
            except CELL_ERRORS as exc:
                values = [
                    (key, norm, {}, f"{type(exc).__name__}: {exc}"[:_MAX_MESSAGE])
                    for key, norm in cells
                ]
        seconds = (time.perf_counter() - t0 + shared / len(by_method)) / len(cells)
        msgs = _messages(caught)
        for key, _norm, norms, error in values:
            rows.append(
                {
                    "key": key,
                    "status": "error" if error else "ok",
                    "err_eta": norms.get("err_eta", float("nan")),
                    "err_v": norms.get("err_v", float("nan")),
                    "err_all": norms.get("err_all", float("nan")),
                    "seconds": seconds,
                    "error": error,
                    "warnings": msgs,
                }
            )
    return rows


def compute_chunk(setup: Setup, sim: SimResult, chunk: Chunk) -> ChunkResult:
    """Every cell of ``chunk`` on the exact samples ``sim``."""
    worker = _worker()
    rows: list[dict[str, Any]] = []
    if sim.traj is None:
        for group in chunk.groups:
            for key, _method, _norm in group.cells:
                rows.append(
                    {
                        "key": key,
                        "status": "error",
                        "err_eta": float("nan"),
                        "err_v": float("nan"),
                        "err_all": float("nan"),
                        "seconds": 0.0,
                        "error": sim.meta.get("error", "exact samples failed"),
                        "warnings": sim.meta.get("warnings", ""),
                    }
                )
    else:
        for group in chunk.groups:
            rows.extend(_group_rows(setup, sim.traj, group))
    for r in rows:
        r["worker"] = worker
    return ChunkResult(chunk.traj_key, sim.meta, rows)
