"""Dask workers started by sampledyn run without the nanny's MALLOC_TRIM_THRESHOLD_
(which made sweep tasks 2x slower); workers started with it are detected and named."""

from __future__ import annotations

import os

import pytest

from sampledyn.experiments.sweep import local_cluster
from sampledyn.experiments.sweep._backends import DASK_WORKER_ENVIRON, check_dask_workers

pytestmark = pytest.mark.slow  # a dask cluster of worker processes

distributed = pytest.importorskip("distributed")


def _environ(client):
    return client.run(os.environ.get, "MALLOC_TRIM_THRESHOLD_")


@pytest.fixture
def environ_restored():
    """distributed < 2024.8 applies a nanny's pre-spawn environment to the parent's
    os.environ (OMP/MKL/OPENBLAS_NUM_THREADS=1, PYTHONHASHSEED, ...): restore it, or
    every process a later test starts runs single-threaded BLAS, whose sums round
    otherwise than this process's (cells of a killed run then differ in the last bits
    from those computed here)."""
    before = dict(os.environ)
    yield
    os.environ.clear()
    os.environ.update(before)


def test_local_cluster_workers_run_without_the_malloc_setting(monkeypatch, environ_restored):
    assert "MALLOC_TRIM_THRESHOLD_" in DASK_WORKER_ENVIRON
    # A nanny run in this process leaves the variable in its environment (as one does
    # for the plain cluster below): local_cluster must not pass it on either.
    monkeypatch.setenv("MALLOC_TRIM_THRESHOLD_", "65536")
    kw = {"host": "127.0.0.1", "dashboard_address": None}
    with local_cluster(1, **kw) as cluster, distributed.Client(cluster) as client:
        assert list(_environ(client).values()) == [None]
        assert check_dask_workers(client) == []
    assert "MALLOC_TRIM_THRESHOLD_" not in os.environ
    try:
        # a plain LocalCluster's nanny sets it, and the check names it with the fix
        with (
            distributed.LocalCluster(n_workers=1, threads_per_worker=1, **kw) as cluster,
            distributed.Client(cluster) as client,
        ):
            assert list(_environ(client).values()) == ["65536"]
            with pytest.warns(RuntimeWarning, match="MALLOC_TRIM_THRESHOLD_=65536.*--no-nanny"):
                msgs = check_dask_workers(client)
            assert len(msgs) == 1
    finally:
        os.environ.pop("MALLOC_TRIM_THRESHOLD_", None)  # the nanny set it here too
