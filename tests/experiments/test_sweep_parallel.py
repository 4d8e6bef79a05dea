"""The same sweep on local processes and on a real Dask cluster: the same rows, bit for
bit, and exact samples computed once per trajectory."""

from __future__ import annotations

import pytest
from _sweep_helpers import rows, write_sweep

import sampledyn as sd
from sampledyn.cli import main
from sampledyn.cli._status import EXIT_UNAVAILABLE
from sampledyn.experiments.sweep import run_sweep

pytestmark = pytest.mark.slow  # worker processes and dask clusters

distributed = pytest.importorskip("distributed")


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The in-process run."""
    d = tmp_path_factory.mktemp("ref")
    cfg = write_sweep(d / "s.toml", seeds=3)
    db = d / "ref.db"
    summary = run_sweep(cfg, db)
    assert summary.failed == 0
    return cfg, rows(db)


def test_local_processes_give_the_same_rows(tmp_path, reference):
    cfg, ref = reference
    db = tmp_path / "p.db"
    s = run_sweep(cfg, db, workers=2, groups_per_chunk=2)
    assert s.backend == "processes:2" and s.computed == len(ref)
    assert rows(db) == ref  # floats compared exactly
    workers = set(sd.results.load(db)["worker"])
    assert len(workers) == 2  # both processes did work


def test_dask_cluster_gives_the_same_rows_bit_for_bit(tmp_path, reference, capsys):
    cfg, ref = reference
    db = tmp_path / "d.db"
    with distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=False,
        host="127.0.0.1",
        protocol="tcp",
        dashboard_address=None,
    ) as cluster:
        address = cluster.scheduler_address
        assert address.startswith("tcp://127.0.0.1:")
        code = main(
            ["sweep", str(cfg), "--store", str(db), "--scheduler", address, "--no-progress"]
        )
        assert code == 0
        assert f"dask:{address}" in capsys.readouterr().out
        with distributed.Client(address) as client:
            # only the client writes the store; the workers hold no leftover tasks
            assert not any(client.processing().values())
    assert rows(db) == ref
    trajs = sd.results.load(db, "trajectories")
    assert len(trajs) == 2 and trajs["traj_key"].is_unique  # one simulation per h


def test_scheduler_that_is_not_there_is_a_clear_error(tmp_path, capsys):
    cfg = write_sweep(tmp_path / "s.toml", h="[0.02]")
    with pytest.raises(SystemExit) as exc:
        main(
            [
                "sweep",
                str(cfg),
                "--store",
                str(tmp_path / "x.db"),
                "--scheduler",
                "tcp://127.0.0.1:9",
                "--connect-timeout",
                "2",
                "--no-progress",
            ]
        )
    assert exc.value.code == EXIT_UNAVAILABLE
    assert "tcp://127.0.0.1:9" in capsys.readouterr().err
