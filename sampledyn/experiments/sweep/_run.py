"""Run a sweep: plan the cells, claim the ones no run has stored or is computing,
compute them, store them.

The steps, in the order they happen:

1. read and check the grid; plan it lazily (:func:`plan_study`) and refuse a grid above
   ``max_cells`` with its size, before anything is opened or written;
2. a dry run only reads an existing store (read-only) to count what is stored;
3. connect to the backend (Dask scheduler, local workers); only then open the store,
   creating it if needed (a run that fails before this leaves no file behind);
4. stream the groups of cells, claim a chunk of them in the store just before it is
   computed (so concurrent runs on one store split the work), compute, write;
5. mark the run "complete", "interrupted" (KeyboardInterrupt, which the command line
   also raises for SIGTERM) or "failed", with truthful counts, and release its claims.
"""

from __future__ import annotations

import itertools
import json
import math
import os
import threading
import time
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ... import _checks as checks
from ..._files import parse_json
from ..._simulate import compile_integrator_aside
from ...exceptions import SweepConfigError
from ._backends import (
    check_dask_workers,
    check_scheduler,
    check_timeout,
    connect,
    dask_backend,
    in_process,
    local_processes,
    start_pool,
    stop_pool,
)
from ._compute import ChunkResult
from ._config import DEFAULT_MAX_CELLS, SweepConfig, load_config
from ._plan import Cell, Chunk, PlannedGroup, Study, plan_study
from ._store import CELL_COLUMNS, Claim, ResultStore, inspect_store

__all__ = [
    "LEASE_SECONDS",
    "StudyResult",
    "backend_options",
    "SweepSummary",
    "check_grid_size",
    "run_study",
    "run_sweep",
]

#: A run whose heartbeat is older than this (s) is taken for dead and its claims are
#: taken over; a run refreshes its heartbeat every LEASE_SECONDS / 6.
LEASE_SECONDS = 60.0


@dataclass(frozen=True)
class SweepSummary:
    """What a sweep did.

    Attributes
    ----------
    run_id : str
        Id of the run in the store ("" for a dry run or when there was nothing to do).
    planned : int
        Cells in the grid.
    skipped : int
        Cells found stored (not recomputed).
    computed : int
        Cells computed and stored by this run.
    failed : int
        Of those, cells stored with status "error".
    backend : str
        "in-process", "processes:N" or "dask:ADDRESS".
    wall_seconds : float
        Duration of the run.
    store_seconds : float
        Time the client spent claiming cells and writing the store.
    compute_seconds : float
        Sum over the computed cells of their compute time on the workers (the
        simulation of the exact samples excluded).
    simulate_seconds : float
        Sum over the trajectories of their simulation time.
    elsewhere : int
        Cells another live run had claimed (it computes them; not done by this run).
    duplicates : int
        Cells this run computed that another run had stored first (their rows were
        kept, this run's discarded); 0 unless a live run was taken for dead.
    status : str
        "complete", "interrupted", "failed", "dry-run" or "nothing to do".
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
    elsewhere: int = 0
    duplicates: int = 0
    status: str = "complete"

    def describe(self, store: Any = None) -> str:
        """What the run did, in one line ("N cells: C computed, S found stored ...")."""
        where = f" (store {store})" if store else ""
        return (
            f"{self.planned} cells: {self.computed} computed, {self.skipped} found "
            f"stored{where}, in {self.wall_seconds:.1f} s ({self.backend})"
        )

    @property
    def store_overhead(self) -> float:
        """Store time per cell over compute time per cell."""
        return self.store_seconds / self.compute_seconds if self.compute_seconds else math.nan


@dataclass
class _Tally:
    skipped: int = 0
    elsewhere: int = 0
    computed: int = 0
    failed: int = 0
    duplicates: int = 0
    store_s: float = 0.0
    compute_s: float = 0.0
    sim_s: float = 0.0
    pending: dict[str, Cell] = field(default_factory=dict)  # claimed, not yet written
    seen_traj: set[str] = field(default_factory=set)


def _cell_row(cell: Cell, study: Study, result: dict[str, Any], run_id: str) -> dict[str, Any]:
    """A generic stored cell: key, kind, the coordinates, the kind's values."""
    cfg = study.config
    tconf = study.trajectories[cell.traj_key]
    kind = study.setup.kind
    values = result.get("values") or {}
    bad = sorted(set(values) - {n for n, _t in kind.columns})
    if bad:
        raise ValueError(f"cell kind {kind.name!r} returned {bad[0]!r}, not one of its columns.")
    return {
        **{k: v for k, v in result.items() if k != "values"},
        **{n: values.get(n) for n, _t in kind.columns},
        "kind": kind.name,
        "run_id": run_id,
        "computed_at": time.time(),
        "version": study.version,
        "vehicle": tconf["vehicle"],
        "buoyancy_pct": cfg.buoyancy_pct,
        "input": str(tconf["input"]["name"]) if "input" in tconf else None,
        "model_fingerprint": study.model_fingerprint,
        "input_fingerprint": tconf.get("input_fingerprint"),
        "T": cfg.T,
        "after": cfg.after,
        "h": cell.h,
        "method": cell.method,
        "order": study.setup.kind.method_order(cell.method),
        "eta_pct": cell.eta_pct,
        "v_pct": cell.v_pct,
        "seed": cell.seed,
        "base_seed": cfg.base_seed,
        "distribution": cfg.distribution,
        "measure": cell.measure,
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
        "summary": json.dumps(m.get("summary") or {}, sort_keys=True),
    }


def _groups_per_chunk(groups_per_traj: int, workers: int) -> int:
    # About 4 tasks per worker and trajectory: enough to balance the load, few enough
    # that shipping the samples with each task stays cheap.
    return max(1, min(32, math.ceil(groups_per_traj / (4 * workers))))


def check_grid_size(study: Study, max_cells: int | None = None) -> None:
    """Refuse a grid of more than ``max_cells`` cells (default: the config's
    ``max_cells``, else :data:`DEFAULT_MAX_CELLS`), naming its size and the limit.

    Raises
    ------
    SweepConfigError
        (key "max_cells") if the grid is too large.
    """
    limit = max_cells if max_cells is not None else study.config.max_cells
    limit = DEFAULT_MAX_CELLS if limit is None else limit
    if isinstance(limit, bool) or not isinstance(limit, int) or limit < 1:
        raise ValueError(f"`max_cells` must be an int >= 1, got {limit!r}.")
    n = study.n_cells
    if n > limit:
        raise SweepConfigError(
            "max_cells",
            f"the grid of {study.config.source} has {n:,} cells ({study.size_text()}), above "
            f"the limit of {limit:,} cells; shrink the grid, or raise the limit with "
            "`max_cells` in the sweep file or --max-cells.",
        )


def _count_stored(study: Study, path: Path, retry_failed: bool) -> int:
    """Cells of ``study`` stored at ``path`` (read-only; 0 if there is no store)."""
    if not path.exists() or path.stat().st_size == 0:
        return 0
    with ResultStore(path, readonly=True, no_side_files=True) as st:
        if st.count("cells") == 0:
            return 0
        found = 0
        batch: list[str] = []
        groups = study.iter_groups()
        while True:
            group = next(groups, None)
            if group is not None:
                batch.extend(c.key for c in group.cells)
            if batch and (group is None or len(batch) >= 5000):
                status = st.statuses(batch)
                found += sum(1 for s in status.values() if s == "ok" or not retry_failed)
                batch = []
            if group is None:
                return found


def _claimed_chunks(
    study: Study,
    st: Any,
    run_id: str,
    groups_per_chunk: int,
    retry_failed: bool,
    tally: _Tally,
    lease: float,
    progress: list[Any],
    order: list[str] | None = None,
) -> Iterator[Chunk]:
    """Chunks of cells this run has claimed, claimed one chunk at a time as the
    backend asks for the next (so concurrent runs interleave). Cells found stored or
    claimed elsewhere advance the progress bar in ``progress``, once there is one.
    The key of every planned cell is appended to ``order`` (if given), in plan order."""
    batch: list[PlannedGroup] = []

    def claim() -> Chunk | None:
        keys = [c.key for g in batch for c in g.cells]
        t0 = time.perf_counter()
        got = st.claim(run_id, keys, retry_failed=retry_failed, lease=lease)
        tally.store_s += time.perf_counter() - t0
        tally.skipped += got.done
        tally.elsewhere += got.elsewhere
        if progress and got.done + got.elsewhere:
            progress[0].update(got.done + got.elsewhere)
        mine = set(got.keys)
        groups = []
        for g in batch:
            for c in g.cells:
                if c.key in mine:
                    tally.pending[c.key] = c
            group = g.task_group(mine)
            if group.cells:
                groups.append(group)
        first = batch[0]
        batch.clear()
        return Chunk(first.traj_key, first.h, tuple(groups), first.sim_key) if groups else None

    for group in study.iter_groups():
        if order is not None:
            order.extend(c.key for c in group.cells)
        if batch and batch[0].traj_key != group.traj_key:
            chunk = claim()
            if chunk is not None:
                yield chunk
        batch.append(group)
        if len(batch) >= groups_per_chunk:
            chunk = claim()
            if chunk is not None:
                yield chunk
    if batch:
        chunk = claim()
        if chunk is not None:
            yield chunk


class _Heartbeat:
    """Refresh a run's heartbeat from a thread, on its own connection, while cells
    take long to compute."""

    def __init__(self, path: Path, run_id: str, period: float) -> None:
        self._stop = threading.Event()
        self._thread = threading.Thread(
            target=self._beat, args=(path, run_id, period), name="sampledyn-heartbeat", daemon=True
        )
        self._thread.start()

    def _beat(self, path: Path, run_id: str, period: float) -> None:
        store: ResultStore | None = None
        try:
            while not self._stop.wait(period):
                try:
                    if store is None:
                        store = ResultStore(path, create=False)
                    store.heartbeat(run_id)
                except (OSError, ValueError):
                    continue  # the main thread meets the same problem and reports it
        finally:
            if store is not None:
                store.close()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join()


class MemoryStore:
    """The results of a run kept in this process (a study run without a store file):
    the part of :class:`ResultStore` that a run uses, with nothing to share."""

    path = None

    def __init__(self) -> None:
        self.cells: dict[str, dict[str, Any]] = {}
        self.trajectories: dict[str, dict[str, Any]] = {}

    def start_run(self, *, backend: str, planned: int, skipped: int, config: Any) -> str:
        return "memory"

    def ensure_kind(self, kind: Any) -> None:
        return None

    def claim(self, run_id: str, keys: Any, *, retry_failed: bool, lease: float) -> Claim:
        todo = [k for k in keys if k not in self.cells]
        return Claim(tuple(todo), len(keys) - len(todo), 0)

    def write(self, cells: Any, trajectories: Any = ()) -> int:
        for t in trajectories:
            self.trajectories.setdefault(t["traj_key"], t)
        for c in cells:
            self.cells[c["key"]] = c
        return len(cells)

    def finish_run(self, run_id: str, status: str, **_: Any) -> None:
        return None

    def forget_run(self, run_id: str) -> None:
        return None

    def rows(self, table: str, keys: Any) -> list[dict[str, Any]]:
        data = self.cells if table == "cells" else self.trajectories
        return [data[k] for k in keys if k in data]

    def close(self) -> None:
        return None

    def discard_if_unused(self) -> bool:
        return False


def run_sweep(
    config: SweepConfig | Study | str | os.PathLike[str],
    store: ResultStore | MemoryStore | str | os.PathLike[str] | None,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    groups_per_chunk: int | None = None,
    retry_failed: bool = False,
    progress: bool = False,
    dry_run: bool = False,
    connect_timeout: float = 30.0,
    max_cells: int | None = None,
    lease: float = LEASE_SECONDS,
    on_start: Callable[[], object] | None = None,
    order: list[str] | None = None,
) -> SweepSummary:
    """Compute the cells of a sweep that the store lacks, and store them.

    Parameters
    ----------
    config : SweepConfig, a planned Study, or path of a sweep TOML file
    store : ResultStore, path of the SQLite file (created when the run starts), or None
        Where the cells go; None keeps them in this process only (nothing to resume;
        see :func:`run_study`, which returns them).
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
        Show a tqdm progress bar with ETA (on stderr).
    dry_run : bool
        Count the cells to compute, compute nothing, write nothing (an existing store
        is only read; a missing one is not created).
    connect_timeout : float
        Seconds to wait for the Dask scheduler.
    max_cells : int, optional
        Refuse a larger grid (default: the config's ``max_cells``, else
        :data:`DEFAULT_MAX_CELLS`).
    lease : float
        Seconds without a heartbeat after which another run's claims are taken over.
    on_start : callable, optional
        Called once without arguments when the computation has started (local
        workers forked, the progress bar shown), before the first result is waited
        for; not called when there is nothing to compute. It should return at once:
        a caller with work that can overlap the cells (e.g. a report's imports)
        starts a thread of its own there (after the fork, which must not copy a
        thread in flight).
    order : list, optional
        The key of every planned cell is appended to it, in plan order, as the run
        lists the grid (all of them unless the run stops early; none for a dry run):
        :func:`run_study` returns the cells in that order without listing the grid
        again.

    Returns
    -------
    SweepSummary

    Raises
    ------
    SweepConfigError
        for a bad sweep file, or a grid above ``max_cells``.
    ValueError
        for bad arguments, a vehicle or input that cannot be built, or a file that
        is not a results store (``NotAStoreError``, the file left untouched).
    FileNotFoundError, IsADirectoryError, PermissionError
        for a store path that cannot be created or written.
    OSError
        with errno ``ENOSPC`` if the disk fills up (finished cells are kept).
    ConnectionError
        if the Dask scheduler does not answer.
    KeyboardInterrupt
        passed on after the run is marked "interrupted" (finished cells kept, local
        workers terminated, claims released).
    """
    backend, n_workers = _backend(workers, scheduler, groups_per_chunk, lease)
    if scheduler is not None:
        check_timeout(connect_timeout)
    t_start = time.perf_counter()
    if isinstance(config, Study):
        study = config
    else:
        study = plan_study(
            config if isinstance(config, SweepConfig) else load_config(config),
            on_model=_compile_ahead(workers),
        )
    check_grid_size(study, max_cells)
    if store is None:
        store = MemoryStore()
    opened = isinstance(store, ResultStore | MemoryStore)
    if dry_run:
        found = _found(study, store, retry_failed)
        return SweepSummary(
            "", study.n_cells, found, 0, 0, backend, time.perf_counter() - t_start,
            0.0, 0.0, 0.0, status="dry-run",
        )  # fmt: skip
    st: ResultStore | MemoryStore
    if not isinstance(store, ResultStore | MemoryStore):
        _inspect_before_work(Path(store))
    client = connect(scheduler, connect_timeout) if scheduler is not None else None
    own = not opened
    try:
        st = store if isinstance(store, ResultStore | MemoryStore) else ResultStore(store)
    except BaseException:
        if client is not None:
            client.close()
        raise
    try:
        if client is not None:
            check_dask_workers(client)
            n_workers = max(1, sum(client.nthreads().values()))
        if groups_per_chunk is None:
            groups_per_chunk = (
                1
                if backend == "in-process"
                else _groups_per_chunk(study.groups_per_trajectory, n_workers)
            )
        workers = _capped_workers(workers, study, groups_per_chunk)
        if workers is not None:
            backend = f"processes:{workers}"
        summary = _run(
            study, st, backend, workers, client, groups_per_chunk, retry_failed, progress, lease,
            on_start, order,
        )  # fmt: skip
    except BaseException:
        if own and st.discard_if_unused():
            own = False
        raise
    finally:
        if client is not None:
            client.close()
        if own:
            st.close()
    return SweepSummary(
        summary.run_id, summary.planned, summary.skipped, summary.computed, summary.failed,
        summary.backend, time.perf_counter() - t_start, summary.store_seconds,
        summary.compute_seconds, summary.simulate_seconds, summary.elsewhere,
        summary.duplicates, summary.status,
    )  # fmt: skip


def _compile_ahead(workers: int | None) -> Callable[[Any], None] | None:
    """``plan_study``'s ``on_model`` for a run on local processes (``workers``): on a
    first run after an install the integrator compiles in a forked process while this
    one plans and compiles the model's kernels (the workers fork later from here and
    inherit both; the cells' kernels compile here too, :func:`start_pool`): the first
    ``reproduce fig7`` took 11.8-16.2 s (median 13.0) instead of 16.7-16.9 s
    (docs/benchmarks.md).
    Not for Dask (its workers compile on their own) nor in process."""
    return compile_integrator_aside if workers is not None else None


def _backend(
    workers: int | None, scheduler: str | None, groups_per_chunk: int | None, lease: float
) -> tuple[str, int]:
    """The backend's name and worker count, the run's arguments checked."""
    if workers is not None and scheduler is not None:
        raise ValueError("give `workers` or `scheduler`, not both.")
    if workers is not None:
        checks.count(workers, "workers")
    if groups_per_chunk is not None:
        checks.count(groups_per_chunk, "groups_per_chunk")
    checks.positive(lease, "lease", unit="s")
    if scheduler is not None:
        check_scheduler(scheduler)  # malformed: refused; tcp:// off this machine: a warning
        return f"dask:{scheduler}", 1
    if workers is not None:
        return f"processes:{workers}", workers
    return "in-process", 1


def _capped_workers(workers: int | None, study: Study, groups_per_chunk: int) -> int | None:
    """``workers`` capped at the cores (:func:`sampledyn._checks.worker_count`) and at
    the tasks of the grid, with a warning that says so."""
    if workers is None:
        return None
    count, note = checks.worker_count(workers, "workers")
    tasks = max(1, len(study.trajectories) * math.ceil(study.groups_per_trajectory
                                                        / groups_per_chunk))  # fmt: skip
    if tasks < count:
        count, note = tasks, f"workers {workers} capped at {tasks}: the grid has {tasks} tasks"
    if note is not None:
        warnings.warn(note, stacklevel=3)
    return count


def _found(study: Study, store: Any, retry_failed: bool) -> int:
    """Cells of ``study`` already in ``store`` (a dry run: read-only)."""
    if isinstance(store, MemoryStore):
        return 0
    path = store.path if isinstance(store, ResultStore) else Path(store)
    return _count_stored(study, path, retry_failed)


def _inspect_before_work(path: Path) -> None:
    """Fail now, before any work, on a store path that cannot become a store."""
    if inspect_store(path) != "missing":  # raises for a folder or a foreign file
        if not os.access(path, os.W_OK):
            raise PermissionError(13, "the results store is not writable", str(path))
        return
    parent = path.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        raise NotADirectoryError(20, "the store's folder is a file", str(parent))
    if not os.access(parent, os.W_OK | os.X_OK):
        raise PermissionError(13, "cannot create the results store in this folder", str(path))


def _run(
    study: Study,
    st: Any,
    backend: str,
    workers: int | None,
    client: Any,
    groups_per_chunk: int,
    retry_failed: bool,
    progress: bool,
    lease: float,
    on_start: Callable[[], object] | None = None,
    order: list[str] | None = None,
) -> SweepSummary:
    t_start = time.perf_counter()
    st.ensure_kind(study.setup.kind)
    run_id = st.start_run(
        backend=backend, planned=study.n_cells, skipped=0, config=study.config.as_dict()
    )
    tally = _Tally()
    bar: list[Any] = []  # the progress bar, once there is one
    claimed = _claimed_chunks(
        study, st, run_id, groups_per_chunk, retry_failed, tally, lease, bar, order
    )
    results: Iterator[ChunkResult] | None = None
    pool = None
    heartbeat = None
    outcome = "failed"
    try:
        first = next(claimed, None)
        if first is None:  # every cell stored or being computed by another run
            outcome = "nothing to do"
            return SweepSummary(
                "", study.n_cells, tally.skipped, 0, 0, backend, time.perf_counter() - t_start,
                tally.store_s, 0.0, 0.0, tally.elsewhere, 0, outcome,
            )  # fmt: skip
        tasks = itertools.chain([first], claimed)
        setup, sims = study.setup, study.sims
        if client is not None:
            results = dask_backend(client, setup, sims, tasks, run_id, in_flight=2 * _n(client) + 2)
        elif workers is not None:
            # Fork the workers before this process starts any thread (heartbeat, bar).
            h = next(iter(sims.values())).h
            pool = start_pool(setup, workers, warm_up_h=h, first=(sims[first.sim_key], first))
            results = local_processes(
                pool, setup, sims, tasks, in_flight=2 * workers, warm_up=workers > 1
            )
        else:
            results = in_process(setup, sims, tasks)
        if st.path is not None:
            heartbeat = _Heartbeat(st.path, run_id, lease / 6.0)
        if progress:
            from tqdm.auto import tqdm

            bar.append(tqdm(total=study.n_cells, desc="sweep", unit="cell", smoothing=0.05))
            bar[0].update(tally.skipped + tally.elsewhere)
        if on_start is not None:
            on_start()
        for res in results:
            _store_result(res, study, st, run_id, tally)
            if bar:
                bar[0].update(len(res.rows))
        outcome = "complete"
    except KeyboardInterrupt:
        outcome = "interrupted"
        raise
    finally:
        if heartbeat is not None:
            heartbeat.stop()
        if bar:
            bar[0].close()
        close = getattr(results, "close", None)
        if close is not None:
            close()
        if pool is not None:
            # Interrupted or failed: stop the workers now, not after their tasks.
            stop_pool(pool, terminate=outcome != "complete")
        _record(st, run_id, outcome, tally)
    return SweepSummary(
        run_id, study.n_cells, tally.skipped, tally.computed, tally.failed, backend,
        time.perf_counter() - t_start, tally.store_s, tally.compute_s, tally.sim_s,
        tally.elsewhere, tally.duplicates, outcome,
    )  # fmt: skip


def _record(st: Any, run_id: str, outcome: str, tally: _Tally) -> None:
    """Mark the run with its outcome and counts (a run that did nothing: no record)."""
    try:
        if outcome == "nothing to do":
            st.forget_run(run_id)
        else:
            st.finish_run(
                run_id, outcome, skipped=tally.skipped, elsewhere=tally.elsewhere,
                duplicates=tally.duplicates,
            )  # fmt: skip
    except OSError:
        if outcome == "complete":
            raise
        # The run's own error (e.g. a full disk) is the one to report.


def _n(client: Any) -> int:
    return max(1, sum(client.nthreads().values()))


def _store_result(res: ChunkResult, study: Study, st: Any, run_id: str, tally: _Tally) -> None:
    rows = [_cell_row(tally.pending.pop(r["key"]), study, r, run_id) for r in res.rows]
    trajs = [] if res.traj_key in tally.seen_traj else [_traj_row(study, res, run_id)]
    t0 = time.perf_counter()
    written = st.write(rows, trajs)
    tally.store_s += time.perf_counter() - t0
    if trajs:
        tally.seen_traj.add(res.traj_key)
        tally.sim_s += float(res.sim_meta.get("seconds", 0.0))
    tally.computed += written
    tally.duplicates += len(rows) - written
    tally.failed += sum(r["status"] != "ok" for r in rows)
    tally.compute_s += sum(float(r["seconds"]) for r in rows)


@dataclass(frozen=True)
class StudyResult:
    """The cells of a study, computed now or found in the store.

    Attributes
    ----------
    study : Study
        The plan.
    cells : list of dict
        One row per planned cell, in plan order, as the kind's view of the store
        shows it: the common columns (``h``, ``eta_pct``, ``v_pct``, ``seed``,
        ``method``, ``traj_key``, ``kind``, ``status``, ``error``, ...), the measure
        under the kind's name for it (``norm`` of a prediction, ``horizon`` of a
        multistep study) and the kind's values, typed (:attr:`CellKind.columns`:
        ``err_eta``, ``err_v``, ``err_all`` of a prediction; NaN for a float the
        cell has not).
    trajectories : dict
        traj_key -> its row: ``certificate``, ``n_samples``, ``summary`` (a dict),
        ``h``, ``status``, ``error``.
    summary : SweepSummary
        What this run did (computed, found stored, ...).
    """

    study: Study
    cells: list[dict[str, Any]]
    trajectories: dict[str, dict[str, Any]]
    summary: SweepSummary

    def certificates(self) -> dict[float, float]:
        """h -> certificate of the exact samples (NaN where there is none)."""
        out: dict[float, float] = {}
        for t in sorted(self.trajectories.values(), key=lambda r: r["h"]):
            cert = t.get("certificate")
            out[float(t["h"])] = math.nan if cert is None else float(cert)
        return out

    def summaries(self) -> dict[float, dict[str, Any]]:
        """h -> the numbers stored with the exact samples (``summaries`` of the grid)."""
        return {
            float(t["h"]): dict(t.get("summary") or {})
            for t in sorted(self.trajectories.values(), key=lambda r: r["h"])
        }


def run_study(
    config: SweepConfig | str | os.PathLike[str],
    store: str | os.PathLike[str] | None = None,
    **options: Any,
) -> StudyResult:
    """Run a study on the engine and return every cell of it.

    Parameters
    ----------
    config : SweepConfig or path of a sweep TOML file
    store : path of a results store, optional
        Keep the cells there: a rerun after a crash or a kill computes only the
        missing ones, and the returned rows include those stored earlier. None keeps
        them in this process.
    **options
        Passed to :func:`run_sweep` (``workers``, ``scheduler``, ``progress``,
        ``retry_failed``, ``max_cells``, ``groups_per_chunk``, ``on_start``).

    Returns
    -------
    StudyResult

    Raises
    ------
    Whatever :func:`run_sweep` raises; ``ValueError`` if a planned cell is missing
    afterwards (another run still computing it).
    """
    cfg = config if isinstance(config, SweepConfig) else load_config(config)
    study = plan_study(cfg, on_model=_compile_ahead(options.get("workers")))
    mem = MemoryStore() if store is None else None
    order: list[str] = []  # the cells' keys in plan order, as the run lists them
    summary = run_sweep(study, mem if mem is not None else store, order=order, **options)
    # (listed whole unless the run stopped early: a dry run lists none)
    keys = order if len(order) == study.n_cells else [c.key for c in study.iter_cells()]
    if mem is not None:
        cells = mem.rows("cells", keys)
        trajs = mem.rows("trajectories", list(study.trajectories))
    else:
        with ResultStore(Path(store), readonly=True) as st:  # type: ignore[arg-type]
            by_key = {r["key"]: r for r in st.rows("cells", keys)}
            cells = [by_key[k] for k in keys if k in by_key]
            trajs = st.rows("trajectories", list(study.trajectories))
    if len(cells) != len(keys):
        raise ValueError(
            f"{len(keys) - len(cells)} of the study's {len(keys)} cells are not in the store "
            "(another run is computing them); run again when it has finished."
        )
    cells = [_view_row(study.setup.kind, c) for c in cells]
    traj_rows = {}
    for t in trajs:
        row = dict(t)
        row["summary"] = _decoded(row.get("summary"))
        traj_rows[row["traj_key"]] = row
    return StudyResult(study, cells, traj_rows, summary)


def _view_row(kind: Any, row: dict[str, Any]) -> dict[str, Any]:
    """A stored cell as its kind's view shows it: the common columns, the measure
    under the kind's name for it (``norm``, ``horizon``), the kind's values typed."""
    common = {k: v for k, v in row.items() if k in _COMMON}
    common[kind.measure_name] = common.pop("measure")
    return {**common, **kind.decode(row)}


_COMMON = frozenset(name for name, _type in CELL_COLUMNS)


def backend_options(
    workers: int | None = None, scheduler: str | None = None, progress: bool = False
) -> dict[str, Any]:
    """The :func:`run_study` options of a built-in study's ``workers`` / ``scheduler``:
    a Dask scheduler if given, else local workers if more than one, else this process
    (``workers`` None or 1)."""
    options: dict[str, Any] = {"progress": progress}
    if scheduler is not None:
        options["scheduler"] = scheduler
    elif workers is not None and workers > 1:
        options["workers"] = workers
    return options


def _decoded(text: Any) -> dict[str, Any]:
    """A JSON column (``summary``, ``result``) as a dict (empty if NULL)."""
    return (
        dict(parse_json(text, "a results store's JSON column"))
        if isinstance(text, str) and text
        else {}
    )
