"""Where the tasks of a sweep run: in this process, on local worker processes, or on
a Dask distributed cluster. Each backend yields :class:`ChunkResult`s as they finish;
the exact samples of a trajectory are computed once and handed to all its chunks.
"""

from __future__ import annotations

import multiprocessing
import sys
import warnings
from collections.abc import Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from typing import Any

from ...simulate import simulate
from ._compute import ChunkResult, SimResult, compute_chunk, simulate_trajectory
from ._plan import Chunk, Setup

__all__ = ["connect", "dask_backend", "in_process", "local_processes", "start_pool"]


def _by_traj(chunks: Sequence[Chunk]) -> dict[str, list[Chunk]]:
    out: dict[str, list[Chunk]] = {}
    for c in chunks:
        out.setdefault(c.traj_key, []).append(c)
    return out


def in_process(setup: Setup, chunks: Sequence[Chunk]) -> Iterator[ChunkResult]:
    """Run every task here, one trajectory at a time."""
    for traj_key, group in _by_traj(chunks).items():
        sim = simulate_trajectory(setup, traj_key, group[0].h)
        for chunk in group:
            yield compute_chunk(setup, sim, chunk)


def _warm_up(setup: Setup, h: float) -> None:
    """Compile the simulator and f here once, before the workers fork from this
    process and inherit the compiled code (numba compiles per process otherwise)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            traj = simulate(setup.model, setup.signal, T=h, h=h, x0=setup.x0)
            setup.model.f(traj.t, traj.x, traj.u)
        except (ValueError, ArithmeticError, RuntimeError):
            pass  # a real failure is reported by the task that meets it


def start_pool(setup: Setup, chunks: Sequence[Chunk], workers: int) -> ProcessPoolExecutor:
    """A pool of ``workers`` processes, started (and warmed up) now.

    On Linux the workers fork from this process after :func:`_warm_up`; elsewhere they
    are spawned (fork is unsafe on macOS) and compile on their own.
    """
    if workers < 1:
        raise ValueError(f"`workers` must be >= 1, got {workers}.")
    if sys.platform.startswith("linux"):
        if chunks:
            _warm_up(setup, chunks[0].h)
        ctx = multiprocessing.get_context("fork")
    else:  # pragma: no cover - platform dependent
        ctx = multiprocessing.get_context("spawn")
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx)
    # Start every worker now, before the caller starts threads (e.g. a progress bar).
    for fut in [pool.submit(_noop) for _ in range(workers)]:
        fut.result()
    return pool


def _noop() -> None:
    return None


def local_processes(
    pool: ProcessPoolExecutor, setup: Setup, chunks: Sequence[Chunk]
) -> Iterator[ChunkResult]:
    """Run on a pool of local processes (:func:`start_pool`): each trajectory is
    simulated by one worker, then its chunks are sent out with the samples. The pool
    is shut down at the end."""
    by_traj = _by_traj(chunks)
    pending: dict[Future[Any], str] = {}
    try:
        for traj_key, group in by_traj.items():
            pending[pool.submit(simulate_trajectory, setup, traj_key, group[0].h)] = "sim"
        while pending:
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                kind = pending.pop(fut)
                if kind == "sim":
                    sim: SimResult = fut.result()
                    for chunk in by_traj[sim.traj_key]:
                        pending[pool.submit(compute_chunk, setup, sim, chunk)] = "chunk"
                else:
                    yield fut.result()
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def connect(address: str, timeout: float = 30.0) -> Any:
    """A Dask distributed client of the scheduler at ``address``.

    Raises
    ------
    ValueError
        naming the address, if Dask is missing or the scheduler does not answer
        within ``timeout`` seconds.
    """
    try:
        from distributed import Client
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ValueError(
            "`scheduler` needs Dask distributed: pip install 'sampledyn[dask]'."
        ) from exc
    try:
        return Client(address, timeout=timeout, set_as_default=False)
    except (OSError, TimeoutError) as exc:
        raise ValueError(f"`scheduler` {address!r}: cannot connect ({exc}).") from exc


def dask_backend(
    client: Any, setup: Setup, chunks: Sequence[Chunk], run_id: str
) -> Iterator[ChunkResult]:
    """Run on a Dask distributed cluster (``client`` from :func:`connect`, closed at
    the end).

    The exact samples stay on the cluster: a chunk task depends on its trajectory's
    future, so Dask moves the samples between workers and the client receives rows
    only.
    """
    from distributed import as_completed

    futures: list[Any] = []
    try:
        [setup_f] = client.scatter([setup], broadcast=True, hash=False)
        sims = {}
        for traj_key, group in _by_traj(chunks).items():
            sims[traj_key] = client.submit(
                simulate_trajectory,
                setup_f,
                traj_key,
                group[0].h,
                key=f"sampledyn-sim-{run_id}-{traj_key[:16]}",
                pure=False,
            )
        for i, chunk in enumerate(chunks):
            futures.append(
                client.submit(
                    compute_chunk,
                    setup_f,
                    sims[chunk.traj_key],
                    chunk,
                    key=f"sampledyn-cells-{run_id}-{i}",
                    pure=False,
                )
            )
        for fut in as_completed(futures, loop=client.loop):
            result = fut.result()
            fut.release()
            yield result
    finally:
        client.cancel(futures)
        client.close()
