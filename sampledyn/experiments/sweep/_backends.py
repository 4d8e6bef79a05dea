"""Where the tasks of a sweep run: in this process, on local worker processes, or on
a Dask distributed cluster.

Every backend takes an iterator of tasks (:class:`Chunk`) and pulls the next one only
when it has room (a few per worker), so the caller can claim cells just before they
are computed and a grid of any size streams through in bounded memory. Each backend
yields :class:`ChunkResult`s as they finish; the shared part of a simulation
(:class:`SimPlan`: the exact samples, for a prediction study; see
:func:`prepare_shared`) is computed once, when the first task of one of its
trajectories arrives, and handed to all their tasks.

Local workers die with the process that started them (``PR_SET_PDEATHSIG`` on Linux,
and a watchdog on the parent's pid everywhere), leave Ctrl-C to it, and are terminated
at once when the sweep is interrupted.
"""

from __future__ import annotations

import ctypes
import math
import multiprocessing
import os
import re
import signal
import sys
import threading
import time
import warnings
from collections.abc import Iterator, Mapping
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from typing import Any

from ... import _checks as checks
from ..._integrator import compiling_aside
from ._cells import Chunk, Setup, SimPlan, compute_cells, prepare_shared, warm_up_cells
from ._compute import ChunkResult, SimResult

__all__ = [
    "DASK_WORKER_ENVIRON",
    "check_dask_workers",
    "check_scheduler",
    "check_timeout",
    "connect",
    "dask_backend",
    "in_process",
    "local_cluster",
    "local_processes",
    "retain_freed_memory",
    "start_pool",
    "stop_pool",
    "worker_init",
]

_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>
_WATCH_PERIOD = 0.5  # s between two looks at the parent's pid
# glibc's mallopt parameters (<malloc.h>) and the values a worker runs with.
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
_MMAP_THRESHOLD = 32 << 20  # glibc's largest: arrays up to 32 MiB come from the heap
_TRIM_THRESHOLD = 1 << 30  # give memory back only beyond 1 GiB of free heap

#: Environment a Dask nanny gives its workers that sampledyn removes: distributed sets
#: ``MALLOC_TRIM_THRESHOLD_=65536`` (``distributed.nanny.pre-spawn-environ``), which
#: makes glibc return memory to the system after every large free and multiplies the
#: page faults of a sweep task by about 7 (measured: Dask 2.1x slower than local
#: workers with it, 1.08x without). ``None`` removes the variable.
DASK_WORKER_ENVIRON: dict[str, Any] = {"MALLOC_TRIM_THRESHOLD_": None}


# -- in this process ------------------------------------------------------------------


def in_process(
    setup: Setup, sims: Mapping[str, SimPlan], tasks: Iterator[Chunk]
) -> Iterator[ChunkResult]:
    """Run every task here, in the order given."""
    bundle: dict[str, SimResult] = {}
    bundle_key = None
    for chunk in tasks:
        if bundle_key != chunk.sim_key:
            bundle = {}  # free the previous samples first
            bundle = prepare_shared(setup, sims[chunk.sim_key])
            bundle_key = chunk.sim_key
        yield compute_cells(setup, bundle[chunk.traj_key], chunk)


# -- local worker processes -----------------------------------------------------------


def _watch_parent(parent: int) -> None:
    while True:
        time.sleep(_WATCH_PERIOD)
        if os.getppid() != parent:
            os._exit(1)


def retain_freed_memory() -> bool:
    """Let glibc's malloc keep freed memory in this process (a worker) for the next
    allocation, instead of returning it to the system after each large free: arrays
    up to 32 MiB come from the heap, and the heap is trimmed only beyond 1 GiB free.

    A task allocates and frees arrays of the size of its samples many times (noise,
    predictions, errors); by default glibc maps each one afresh, and every page of it
    is faulted in again (measured on the Fig. 7 study: 10x fewer page faults and
    about 8 % less CPU time). The worker's resident memory then stays near its peak.
    Returns False where there is no glibc ``mallopt`` (nothing changes).
    """
    if not sys.platform.startswith("linux"):
        return False  # pragma: no cover - platform dependent
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):  # pragma: no cover - not glibc
        return False
    return bool(mallopt(_M_MMAP_THRESHOLD, _MMAP_THRESHOLD)) and bool(
        mallopt(_M_TRIM_THRESHOLD, _TRIM_THRESHOLD)
    )


def dask_setup(worker: Any) -> None:
    """Dask preload hook (:func:`local_cluster` preloads this module in its workers)."""
    retain_freed_memory()


def worker_init(parent: int) -> None:
    """Initializer of a local worker process (``parent`` = the pid that starts it).

    The worker ignores SIGINT (a Ctrl-C reaches the whole process group; the parent
    handles it and terminates the workers), takes SIGTERM's default action (a forked
    worker would inherit a handler of the parent), and dies with the parent: on Linux
    the kernel sends it SIGKILL when the parent exits (``prctl(PR_SET_PDEATHSIG)``),
    and everywhere a thread exits the worker once its parent pid changes (the parent
    died and the worker was re-parented). It keeps freed memory for its next task
    (:func:`retain_freed_memory`).
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    if os.getppid() != parent:  # the parent died before the line above
        os._exit(1)
    threading.Thread(target=_watch_parent, args=(parent,), daemon=True).start()
    retain_freed_memory()


def start_pool(
    setup: Setup,
    workers: int,
    warm_up_h: float | None = None,
    first: tuple[SimPlan, Chunk] | None = None,
) -> ProcessPoolExecutor:
    """A pool of ``workers`` processes, started now (see :func:`worker_init`).

    On Linux the workers fork from this process after compiling the kernels once (at
    period ``warm_up_h``); elsewhere they are spawned (fork is unsafe on macOS) and
    compile on their own. While the integrator compiles in another process (a first
    run: :func:`sampledyn._simulate.compile_integrator_aside`), the cells' kernels of
    the ``first`` task (its simulation and chunk) compile here, on stand-in samples.
    """
    checks.count(workers, "workers")
    if sys.platform.startswith("linux"):
        if first is not None and compiling_aside():
            setup.kind.warm_up_cells(setup, *first)
        if warm_up_h is not None:
            # Compile here once: the workers fork from this process and inherit the
            # compiled code (numba compiles per process otherwise).
            setup.kind.warm_up(setup, warm_up_h)
        ctx = multiprocessing.get_context("fork")
    else:  # pragma: no cover - platform dependent
        ctx = multiprocessing.get_context("spawn")
    pool = ProcessPoolExecutor(
        max_workers=workers, mp_context=ctx, initializer=worker_init, initargs=(os.getpid(),)
    )
    # Start every worker now, before the caller starts threads (e.g. a progress bar).
    for fut in [pool.submit(os.getpid) for _ in range(workers)]:
        fut.result()
    return pool


def stop_pool(pool: ProcessPoolExecutor, *, terminate: bool) -> None:
    """Shut ``pool`` down: after its running tasks, or, with ``terminate``, at once
    (SIGTERM to every worker, SIGKILL to any still there after 5 s)."""
    if not terminate:
        pool.shutdown(wait=True, cancel_futures=True)
        return
    # Python 3.14 has ``pool.terminate_workers()``; before, the pool's process table.
    procs = list((getattr(pool, "_processes", None) or {}).values())
    for p in procs:
        if p.is_alive():
            p.terminate()
    for p in procs:
        p.join(5.0)
        if p.is_alive():
            p.kill()
            p.join(5.0)
    pool.shutdown(wait=True, cancel_futures=True)


def local_processes(
    pool: ProcessPoolExecutor,
    setup: Setup,
    sims: Mapping[str, SimPlan],
    tasks: Iterator[Chunk],
    *,
    in_flight: int,
    warm_up: bool = False,
) -> Iterator[ChunkResult]:
    """Run on a pool of local processes (:func:`start_pool`), at most ``in_flight``
    tasks pulled and not finished. Each simulation runs on one worker when the first
    task of one of its trajectories arrives (its tasks then go out with their
    trajectory's samples), and the next simulation of ``sims`` (in plan order) runs
    meanwhile, so no worker waits for exact samples between trajectories. With
    ``warm_up`` (a pool of two workers or more) another worker compiles the cells'
    kernels on a short case (stand-in samples) while the first simulation runs
    (:meth:`~sampledyn.experiments.sweep._cells.CellKind.warm_up_cells`), so a first
    run after an install compiles them once, not once per worker, and not after the
    exact samples.
    """
    order = {key: i for i, key in enumerate(sims)}
    keys = list(sims)
    bundles: dict[str, dict[str, SimResult]] = {}
    simulating: dict[Future[Any], str] = {}
    parked: dict[str, list[Chunk]] = {}
    running: dict[Future[Any], str] = {}
    exhausted = False
    last = ""
    warming: list[Future[Any]] = []  # the cells compiled on a short case (not waited for)

    def start(key: str) -> None:
        if key not in bundles and key not in simulating.values():
            simulating[pool.submit(prepare_shared, setup, sims[key])] = key

    def submit(chunk: Chunk) -> None:
        sim = bundles[chunk.sim_key][chunk.traj_key]
        running[pool.submit(compute_cells, setup, sim, chunk)] = chunk.sim_key

    while True:
        while not exhausted and len(running) + sum(map(len, parked.values())) < in_flight:
            chunk = next(tasks, None)
            if chunk is None:
                exhausted = True
                break
            last = chunk.sim_key
            if last in bundles:
                submit(chunk)
                continue
            start(last)
            if warm_up and not warming:
                warming.append(pool.submit(warm_up_cells, setup, sims[last], chunk))
            parked.setdefault(last, []).append(chunk)
            if order[last] + 1 < len(keys):
                start(keys[order[last] + 1])  # one simulation ahead
        if not running and not simulating:
            return
        done, _ = wait([*running, *simulating], return_when=FIRST_COMPLETED)
        for fut in done:
            if fut in simulating:
                key = simulating.pop(fut)
                bundles[key] = fut.result()
                for chunk in parked.pop(key, []):
                    submit(chunk)
            else:
                running.pop(fut)
                yield fut.result()
        # Keep the samples of running tasks, of the simulation being pulled and of
        # the one simulated ahead of it.
        here = order.get(last, -1)
        busy = {last, *running.values()}
        for key in [k for k in bundles if k not in busy and order[k] <= here]:
            del bundles[key]


# -- Dask -----------------------------------------------------------------------------


_SCHEMES = ("tcp", "tls", "ucx", "ws", "wss", "inproc")
_ADDRESS = re.compile(
    r"(?P<scheme>[a-z]+)://(?P<host>\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9._-]+):(?P<port>[0-9]{1,5})"
)


def check_scheduler(address: Any, *, warn: bool = True) -> None:
    """Refuse a Dask scheduler address that is not ``SCHEME://HOST:PORT`` (scheme one
    of tcp, tls, ucx, ws, wss; port 1..65535), before Dask tries it; warn when a
    ``tcp://`` address is not on this machine (loopback): a Dask scheduler and its
    workers exchange pickles, which run code in the client, in the clear.

    Raises
    ------
    ValueError
        naming the address and the expected form.
    """
    m = _ADDRESS.fullmatch(address) if isinstance(address, str) else None
    if m is None or m["scheme"] not in _SCHEMES or not 1 <= int(m["port"]) <= 65535:
        raise ValueError(
            f"`scheduler` {address!r} is not a Dask scheduler address SCHEME://HOST:PORT "
            f"(scheme {', '.join(_SCHEMES[:-1])}; port 1..65535), e.g. tcp://127.0.0.1:8786."
        )
    if warn and m["scheme"] == "tcp" and not _loopback(m["host"].strip("[]")):
        warnings.warn(
            f"`scheduler` {address!r}: a Dask scheduler runs pickled code from its workers in "
            "this process, and tcp:// is neither encrypted nor authenticated; use it only on a "
            "trusted network, or a tls:// address (docs/sweeps.md, 'Trust').",
            stacklevel=3,
        )


def check_timeout(timeout: Any) -> None:
    """Refuse a ``connect_timeout`` that is not a finite number of seconds > 0."""
    if (
        isinstance(timeout, bool)
        or not isinstance(timeout, int | float)
        or not (math.isfinite(timeout) and timeout > 0)
    ):
        raise ValueError(
            f"`connect_timeout` must be a finite number of seconds > 0, got {timeout!r}; e.g. 30."
        )


def _loopback(host: str) -> bool:
    import ipaddress

    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def connect(address: str, timeout: float = 30.0) -> Any:
    """A Dask distributed client of the scheduler at ``address``.

    Raises
    ------
    ValueError
        if Dask distributed is not installed, the address is malformed
        (:func:`check_scheduler`) or the timeout not a positive number.
    ConnectionError
        naming the address, if the scheduler does not answer within ``timeout`` s.
    """
    try:
        from distributed import Client
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ValueError(
            "`scheduler` needs Dask distributed: pip install 'sampledyn[dask]'."
        ) from exc
    check_scheduler(address, warn=False)
    check_timeout(timeout)
    try:
        return Client(address, timeout=timeout, set_as_default=False)
    except (OSError, TimeoutError) as exc:
        raise ConnectionError(
            f"`scheduler` {address!r}: no Dask scheduler answered within {timeout:g} s ({exc}); "
            "start one with `dask scheduler` or check the address."
        ) from exc


def _worker_environ(names: tuple[str, ...]) -> dict[str, str | None]:
    return {n: os.environ.get(n) for n in names}


def check_dask_workers(client: Any) -> list[str]:
    """Warn (and return the messages) if the cluster's workers run with an environment
    that :data:`DASK_WORKER_ENVIRON` removes, with the way to start them without it."""
    names = tuple(DASK_WORKER_ENVIRON)
    found = client.run(_worker_environ, names)
    msgs = []
    for name in names:
        bad = sorted(w for w, env in found.items() if env.get(name) is not None)
        if bad:
            value = found[bad[0]][name]
            msgs.append(
                f"{len(bad)} of {len(found)} Dask workers run with {name}={value} (set by the "
                "Dask nanny), which makes sampledyn's tasks about 2x slower; start them with "
                "`dask worker --no-nanny ...`, or with a Dask config file that sets "
                f"distributed.nanny.pre-spawn-environ.{name}: null (see docs/sweeps.md)."
            )
    for msg in msgs:
        warnings.warn(msg, RuntimeWarning, stacklevel=2)
    return msgs


def local_cluster(n_workers: int = 2, threads_per_worker: int = 1, **kwargs: Any) -> Any:
    """A ``distributed.LocalCluster`` of worker processes started without the
    variables of :data:`DASK_WORKER_ENVIRON`, whether Dask's nanny or this process's
    environment would give them; they are removed from this process's environment
    too (other keyword arguments are passed on). The workers keep freed memory as
    local workers do (:func:`retain_freed_memory`, run by a preload of this module).

    Use it as ``with local_cluster(2) as cluster:`` and pass
    ``scheduler=cluster.scheduler_address`` to :func:`run_sweep`.
    """
    import dask
    from distributed import LocalCluster

    config = {f"distributed.nanny.pre-spawn-environ.{k}": v for k, v in DASK_WORKER_ENVIRON.items()}
    # A nanny also sets its variables in the process that runs it (here), and the
    # workers inherit this process's environment. glibc read them when this process
    # started, so they act only on processes started later: remove them for good.
    for name in DASK_WORKER_ENVIRON:
        os.environ.pop(name, None)
    with dask.config.set(config):
        kwargs.setdefault("preload", [__name__])
        return LocalCluster(
            n_workers=n_workers,
            threads_per_worker=threads_per_worker,
            processes=True,
            **kwargs,
        )


def _pick(bundle: Mapping[str, SimResult], traj_key: str) -> SimResult:
    return bundle[traj_key]


def dask_backend(
    client: Any,
    setup: Setup,
    sims: Mapping[str, SimPlan],
    tasks: Iterator[Chunk],
    run_id: str,
    *,
    in_flight: int,
) -> Iterator[ChunkResult]:
    """Run on a Dask distributed cluster (``client`` from :func:`connect`, closed at
    the end), at most ``in_flight`` tasks submitted and not finished.

    The exact samples stay on the cluster: a task depends on its trajectory's future,
    so Dask moves the samples between workers and the client receives rows only.
    """
    from distributed import as_completed

    futures: set[Any] = set()
    bundle: dict[str, Any] = {}  # sim_key -> future of the simulation
    trajs: dict[str, Any] = {}  # traj_key -> future of its samples
    try:
        [setup_f] = client.scatter([setup], broadcast=True, hash=False)
        queue = as_completed([], loop=client.loop)
        exhausted = False
        n = 0
        while True:
            while not exhausted and len(futures) < in_flight:
                chunk = next(tasks, None)
                if chunk is None:
                    exhausted = True
                    break
                if chunk.sim_key not in bundle:
                    # Tasks come simulation by simulation: the cluster keeps the
                    # samples of earlier ones while their tasks run, not longer.
                    bundle = {
                        chunk.sim_key: client.submit(
                            prepare_shared,
                            setup_f,
                            sims[chunk.sim_key],
                            key=f"sampledyn-sim-{run_id}-{chunk.sim_key[:16]}",
                            pure=False,
                        )
                    }
                    trajs = {}
                if chunk.traj_key not in trajs:
                    trajs[chunk.traj_key] = client.submit(
                        _pick,
                        bundle[chunk.sim_key],
                        chunk.traj_key,
                        key=f"sampledyn-traj-{run_id}-{chunk.traj_key[:16]}",
                        pure=False,
                    )
                fut = client.submit(
                    compute_cells,
                    setup_f,
                    trajs[chunk.traj_key],
                    chunk,
                    key=f"sampledyn-cells-{run_id}-{n}",
                    pure=False,
                )
                n += 1
                futures.add(fut)
                queue.add(fut)
            if not futures:
                return
            fut = next(queue)
            futures.discard(fut)
            result = fut.result()
            fut.release()
            yield result
    finally:
        client.cancel(list(futures) + list(bundle.values()) + list(trajs.values()))
        client.close()
