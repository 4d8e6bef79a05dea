"""Run a sweep: plan the cells, skip the stored ones, compute the rest, store them."""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from ._backends import connect, dask_backend, in_process, local_processes, start_pool
from ._compute import ChunkResult
from ._config import SweepConfig, load_config
from ._plan import Cell, Study, cell_order, plan_study, vehicle_label
from ._store import ResultStore

__all__ = ["SweepSummary", "run_sweep"]


@dataclass(frozen=True)
class SweepSummary:
    """What a sweep did.

    Attributes
    ----------
    run_id : str
        Id of the run in the store ("" for a dry run).
    planned : int
        Cells in the grid.
    skipped : int
        Cells already in the store (not recomputed).
    computed : int
        Cells computed and stored by this run.
    failed : int
        Of those, cells stored with status "error".
    backend : str
        "in-process", "processes:N" or "dask:ADDRESS".
    wall_seconds : float
        Duration of the run.
    store_seconds : float
        Time the client spent writing the store.
    compute_seconds : float
        Sum over the computed cells of their compute time on the workers (the
        simulation of the exact samples excluded).
    simulate_seconds : float
        Sum over the trajectories of their simulation time.
    """

    run_id: str
    planned: int
    skipped: int
    computed: int
    failed: int
    backend: str
    wall_seconds: float
    store_seconds: float
    compute_seconds: float
    simulate_seconds: float

    @property
    def store_overhead(self) -> float:
        """Store time per cell over compute time per cell."""
        return self.store_seconds / self.compute_seconds if self.compute_seconds else math.nan


def _cell_row(cell: Cell, study: Study, result: dict[str, Any], run_id: str) -> dict[str, Any]:
    cfg = study.config
    return {
        **result,
        "run_id": run_id,
        "computed_at": time.time(),
        "version": study.version,
        "vehicle": vehicle_label(cfg.vehicle),
        "buoyancy_pct": cfg.buoyancy_pct,
        "input": str(cfg.input["name"]),
        "model_fingerprint": study.model_fingerprint,
        "input_fingerprint": study.input_fingerprint,
        "T": cfg.T,
        "after": cfg.after,
        "h": cell.h,
        "method": cell.method,
        "order": cell_order(cell.method),
        "eta_pct": cell.eta_pct,
        "v_pct": cell.v_pct,
        "seed": cell.seed,
        "base_seed": cfg.base_seed,
        "distribution": cfg.distribution,
        "norm": cell.norm,
        "traj_key": cell.traj_key,
        "config": cell.config,
    }


def _traj_row(study: Study, res: ChunkResult, run_id: str) -> dict[str, Any]:
    m = res.sim_meta
    return {
        "traj_key": res.traj_key,
        "run_id": run_id,
        "computed_at": time.time(),
        "status": m.get("status"),
        "h": m.get("h"),
        "n_samples": m.get("n_samples"),
        "certificate": m.get("certificate"),
        "seconds": m.get("seconds"),
        "worker": m.get("worker"),
        "error": m.get("error"),
        "warnings": m.get("warnings"),
        "config": json.dumps(study.trajectories[res.traj_key], sort_keys=True),
    }


def _groups_per_chunk(n_groups: int, n_traj: int, workers: int) -> int:
    # About 4 tasks per worker and trajectory: enough to balance the load, few enough
    # that shipping the samples with each task stays cheap.
    per_traj = max(1, n_groups // max(1, n_traj))
    return max(1, min(32, math.ceil(per_traj / (4 * workers))))


def run_sweep(
    config: SweepConfig | str | os.PathLike[str],
    store: ResultStore | str | os.PathLike[str],
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    groups_per_chunk: int | None = None,
    retry_failed: bool = False,
    progress: bool = False,
    dry_run: bool = False,
    connect_timeout: float = 30.0,
) -> SweepSummary:
    """Compute the cells of a sweep that the store lacks, and store them.

    Parameters
    ----------
    config : SweepConfig or path of a sweep TOML file
    store : ResultStore or path of the SQLite file (created if missing)
    workers : int, optional
        Run on this many local worker processes (default: in this process).
    scheduler : str, optional
        Address of a Dask distributed scheduler, e.g. "tcp://127.0.0.1:8786".
    groups_per_chunk : int, optional
        Measured trajectories (noise pair x seed) per task; default: about 4 tasks
        per worker and trajectory, 1 in-process.
    retry_failed : bool
        Recompute the cells stored with status "error".
    progress : bool
        Show a tqdm progress bar with ETA.
    dry_run : bool
        Plan only: count the cells to compute, compute nothing.
    connect_timeout : float
        Seconds to wait for the Dask scheduler.

    Returns
    -------
    SweepSummary
    """
    if workers is not None and scheduler is not None:
        raise ValueError("give `workers` or `scheduler`, not both.")
    if workers is not None and workers < 1:
        raise ValueError(f"`workers` must be >= 1, got {workers}.")
    cfg = config if isinstance(config, SweepConfig) else load_config(config)
    own_store = not isinstance(store, ResultStore)
    st = ResultStore(store) if not isinstance(store, ResultStore) else store
    try:
        return _run(
            cfg,
            st,
            workers,
            scheduler,
            groups_per_chunk,
            retry_failed,
            progress,
            dry_run,
            connect_timeout,
        )
    finally:
        if own_store:
            st.close()


def _run(
    cfg: SweepConfig,
    st: ResultStore,
    workers: int | None,
    scheduler: str | None,
    groups_per_chunk: int | None,
    retry_failed: bool,
    progress: bool,
    dry_run: bool,
    connect_timeout: float,
) -> SweepSummary:
    t_start = time.perf_counter()
    study = plan_study(cfg)
    status = st.statuses(c.key for c in study.cells)
    todo = [
        c for c in study.cells if c.key not in status or (retry_failed and status[c.key] != "ok")
    ]
    skipped = len(study.cells) - len(todo)
    client = None
    if scheduler is not None:
        backend, n_workers = f"dask:{scheduler}", 1
        if todo and not dry_run:
            client = connect(scheduler, connect_timeout)
            n_workers = max(1, sum(client.nthreads().values()))
    elif workers is not None:
        backend, n_workers = f"processes:{workers}", workers
    else:
        backend, n_workers = "in-process", 1
    if dry_run or not todo:
        return SweepSummary(
            "",
            len(study.cells),
            skipped,
            0,
            0,
            backend,
            time.perf_counter() - t_start,
            0.0,
            0.0,
            0.0,
        )
    n_groups = len({(c.traj_key, c.eta_pct, c.v_pct, c.seed) for c in todo})
    n_traj = len({c.traj_key for c in todo})
    if groups_per_chunk is None:
        groups_per_chunk = (
            1 if backend == "in-process" else _groups_per_chunk(n_groups, n_traj, n_workers)
        )
    chunks = study.chunks(todo, groups_per_chunk)
    run_id = st.start_run(
        backend=backend, planned=len(study.cells), skipped=skipped, config=cfg.as_dict()
    )
    results: Iterator[ChunkResult]
    pool = None
    if client is not None:
        results = dask_backend(client, study.setup, chunks, run_id)
    elif workers is not None:
        pool = start_pool(study.setup, chunks, workers)
        results = local_processes(pool, study.setup, chunks)
    else:
        results = in_process(study.setup, chunks)
    by_key = {c.key: c for c in todo}
    seen_traj: set[str] = set()
    computed = failed = 0
    store_s = compute_s = sim_s = 0.0
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(todo), desc="sweep", unit="cell", smoothing=0.05)
    outcome = "failed"
    try:
        for res in results:
            rows = [_cell_row(by_key[r["key"]], study, r, run_id) for r in res.rows]
            trajs = [] if res.traj_key in seen_traj else [_traj_row(study, res, run_id)]
            t0 = time.perf_counter()
            st.write(rows, trajs)
            store_s += time.perf_counter() - t0
            if trajs:
                seen_traj.add(res.traj_key)
                sim_s += float(res.sim_meta.get("seconds", 0.0))
            computed += len(rows)
            failed += sum(r["status"] != "ok" for r in rows)
            compute_s += sum(float(r["seconds"]) for r in rows)
            if bar is not None:
                bar.update(len(rows))
        outcome = "complete"
    except KeyboardInterrupt:
        outcome = "interrupted"
        raise
    finally:
        if bar is not None:
            bar.close()
        close = getattr(results, "close", None)
        if close is not None:
            close()
        # A generator closed before its first step skips its own cleanup.
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)
        if client is not None:
            client.close()
        st.finish_run(run_id, outcome, computed, failed)
    return SweepSummary(
        run_id,
        len(study.cells),
        skipped,
        computed,
        failed,
        backend,
        time.perf_counter() - t_start,
        store_s,
        compute_s,
        sim_s,
    )
