"""The results store: recognised by its mark before anything is written, foreign
files refused untouched, dry runs that write nothing, no empty file after a failed
run, read-only and shared stores, a full disk; bounded planning of huge grids."""

from __future__ import annotations

import resource
import sqlite3
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from _faults import CLI, Unavailable, error_lines, remount_readonly, tmpfs
from _sweep_helpers import rows, write_sweep

import sampledyn as sd
from sampledyn.cli import main
from sampledyn.cli._status import EXIT_BAD_VALUE, EXIT_DISK, EXIT_FILE
from sampledyn.exceptions import NotAStoreError, SweepConfigError
from sampledyn.experiments.sweep import load_config, run_sweep
from sampledyn.experiments.sweep._config import DEFAULT_MAX_CELLS
from sampledyn.experiments.sweep._plan import plan_study
from sampledyn.experiments.sweep._run import check_grid_size
from sampledyn.experiments.sweep._store import APPLICATION_ID, ResultStore


def _snapshot(folder: Path) -> dict[str, tuple[bytes, int]]:
    """Every file of ``folder`` with its bytes and mtime (ns)."""
    return {p.name: (p.read_bytes(), p.stat().st_mtime_ns) for p in sorted(folder.iterdir())}


def _foreign_db(path: Path) -> Path:
    with sqlite3.connect(path) as conn:
        conn.execute("CREATE TABLE users (id INTEGER PRIMARY KEY, name TEXT)")
        conn.execute("INSERT INTO users VALUES (1, 'ada')")
    return path


def _main_status(args: list[str]) -> int:
    with pytest.raises(SystemExit) as exc:
        main(args)
    return int(exc.value.code)  # type: ignore[arg-type]


# -- 3. foreign files -----------------------------------------------------------------


@pytest.mark.parametrize("dry", [True, False])
@pytest.mark.parametrize("kind", ["sqlite", "text"])
def test_a_foreign_file_is_refused_untouched(tmp_path, capsys, kind, dry):
    cfg = write_sweep(tmp_path / "s.toml", h="[0.02]")
    data = tmp_path / "data"
    data.mkdir()
    target = data / "other_app.db"
    if kind == "sqlite":
        _foreign_db(target)
    else:
        target.write_text("name,score\nada,1\n")
    before = _snapshot(data)
    time.sleep(0.01)  # an mtime change would show
    status = _main_status(
        [
            "sweep",
            str(cfg),
            "--store",
            str(target),
            "--no-progress",
            *(["--dry-run"] if dry else []),
        ]
    )
    assert status == EXIT_BAD_VALUE
    err = capsys.readouterr().err
    assert "other_app.db" in err and "not a sampledyn results store" in err
    assert "left untouched" in err
    assert _snapshot(data) == before  # same files, bytes and mtimes: no -wal, no -shm
    with pytest.raises(NotAStoreError):
        sd.results.load(target)
    assert _snapshot(data) == before


def test_a_new_store_carries_the_mark_from_its_first_byte(tmp_path):
    db = tmp_path / "r.db"
    run_sweep(write_sweep(tmp_path / "s.toml", h="[0.02]", seeds=1), db)
    header = db.read_bytes()[:100]
    assert int.from_bytes(header[68:72], "big") == APPLICATION_ID == int.from_bytes(b"SDYN", "big")
    with sqlite3.connect(db) as conn:
        assert conn.execute("PRAGMA application_id").fetchone()[0] == APPLICATION_ID


def test_a_store_of_schema_1_is_recognised_and_upgraded(tmp_path):
    """Stores written before the mark (no application id, schema 1) stay usable."""
    from sampledyn.experiments.sweep._store import _RUN_COLUMNS, _TRAJ_COLUMNS, CELL_COLUMNS_2

    def ddl(table, cols):
        return f"CREATE TABLE {table} (" + ", ".join(f'"{n}" {t}' for n, t in cols) + ")"

    db = tmp_path / "old.db"
    with sqlite3.connect(db) as conn:
        conn.execute("CREATE TABLE meta (name TEXT PRIMARY KEY, value TEXT)")
        conn.execute("INSERT INTO meta VALUES ('schema_version', '1')")
        conn.execute(ddl("cells", CELL_COLUMNS_2[:-2]))  # schema 1: no kind, no result
        conn.execute(ddl("trajectories", _TRAJ_COLUMNS))
        conn.execute(ddl("runs", _RUN_COLUMNS[:13]))  # schema 1: no heartbeat, no counts
    cfg = write_sweep(tmp_path / "s.toml", h="[0.02]", seeds=1)
    s = run_sweep(cfg, db)
    assert s.computed == s.planned > 0
    assert int.from_bytes(db.read_bytes()[68:72], "big") == APPLICATION_ID
    assert len(sd.results.load(db, "runs")) == 1


def test_dry_run_writes_nothing_at_all(tmp_path, capsys):
    cfg = write_sweep(tmp_path / "s.toml", h="[0.02]")
    data = tmp_path / "data"
    data.mkdir()
    new = data / "new.db"
    assert main(["sweep", str(cfg), "--store", str(new), "--dry-run"]) == 0
    assert "0 already in" in capsys.readouterr().out
    assert list(data.iterdir()) == []  # not even the store file
    existing = data / "r.db"
    stored = run_sweep(write_sweep(tmp_path / "half.toml", h="[0.02]", seeds=1), existing).computed
    before = _snapshot(data)
    time.sleep(0.01)
    assert main(["sweep", str(cfg), "--store", str(existing), "--dry-run"]) == 0
    out = capsys.readouterr().out
    planned = plan_study(load_config(cfg)).n_cells
    assert f"{planned} cells" in out and f"{stored} already in" in out
    assert _snapshot(data) == before


def test_failed_runs_leave_no_store_file(tmp_path, capsys, monkeypatch):
    data = tmp_path / "data"
    data.mkdir()
    db = data / "r.db"
    bad = write_sweep(tmp_path / "bad.toml", h="[0.02]").read_text()
    (tmp_path / "bad.toml").write_text(bad.replace('"auv_like"', '"no_such_vehicle"'))
    assert _main_status(["sweep", str(tmp_path / "bad.toml"), "--store", str(db)]) == (
        EXIT_BAD_VALUE
    )
    assert list(data.iterdir()) == []

    # a failure after the store was created (here: every task crashes) removes it
    import sampledyn.experiments.sweep._backends as backends

    def crash(*args, **kwargs):
        raise RuntimeError("worker crashed")

    monkeypatch.setattr(backends, "compute_cells", crash)
    with pytest.raises(RuntimeError, match="worker crashed"):
        run_sweep(write_sweep(tmp_path / "s.toml", h="[0.02]"), db)
    assert list(data.iterdir()) == []


def test_store_path_that_is_a_folder_or_below_a_file(tmp_path, capsys):
    cfg = write_sweep(tmp_path / "s.toml", h="[0.02]")
    assert _main_status(["sweep", str(cfg), "--store", str(tmp_path)]) == EXIT_FILE
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and str(tmp_path) in err and "folder" in err
    afile = tmp_path / "afile"
    afile.write_text("x")
    assert _main_status(["sweep", str(cfg), "--store", str(afile / "r.db")]) == EXIT_FILE
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "afile" in err


# -- 4. read-only and shared stores ---------------------------------------------------


def test_a_store_is_read_in_read_only_mode(tmp_path):
    db = tmp_path / "r.db"
    run_sweep(write_sweep(tmp_path / "s.toml", h="[0.02]", seeds=1), db)
    with ResultStore(db, readonly=True) as st:
        assert st.count() > 0
        with pytest.raises(sqlite3.OperationalError, match="readonly"):
            st.connection().execute("CREATE TABLE x (a)")
    with pytest.raises(FileNotFoundError):
        ResultStore(tmp_path / "none.db", readonly=True)
    assert not (tmp_path / "none.db").exists()


@pytest.fixture
def readonly_store(tmp_path):
    """A valid store on a read-only file system (a tmpfs remounted read-only)."""
    media = tmp_path / "media"
    try:
        with tmpfs(media, "20m"):
            db = media / "r.db"
            run_sweep(write_sweep(tmp_path / "s.toml", h="[0.02]", seeds=1), db)
            remount_readonly(media)
            yield db
    except Unavailable as exc:
        pytest.skip(str(exc))


def test_results_and_report_read_a_store_on_read_only_media(readonly_store, tmp_path, capsys):
    db = readonly_store
    assert not Path(str(db) + "-shm").exists()  # what mode=ro alone would need
    df = sd.results.load(db)
    assert len(df) > 0 and set(df["status"]) == {"ok"}
    assert main(["results", str(db), "--format", "csv"]) == 0
    assert capsys.readouterr().out.count("\n") == len(df) + 1
    assert main(["report", str(db), "--out", str(tmp_path / "rep")]) == 0
    assert (tmp_path / "rep" / "index.html").is_file()
    # writing is refused before any work, naming the store
    cfg = write_sweep(tmp_path / "more.toml", h="[0.02]", seeds=2)
    assert _main_status(["sweep", str(cfg), "--store", str(db)]) == EXIT_FILE
    assert str(db) in capsys.readouterr().err
    assert _main_status(["sweep", str(cfg), "--store", str(db.parent / "new.db")]) == EXIT_FILE
    assert "new.db" in capsys.readouterr().err


def test_claims_of_a_dead_run_are_taken_over_and_of_a_live_one_respected(tmp_path):
    cfg = write_sweep(tmp_path / "s.toml", h="[0.02]", seeds=1)
    study = plan_study(load_config(cfg))
    keys = [c.key for c in study.iter_cells()]
    db = tmp_path / "r.db"
    with ResultStore(db) as st:
        live = st.start_run(backend="in-process", planned=len(keys), skipped=0, config={})
        assert len(st.claim(live, keys[:4]).keys) == 4
        dead = st.start_run(backend="in-process", planned=len(keys), skipped=0, config={})
        assert len(st.claim(dead, keys[4:10]).keys) == 6
        # silent for an hour, on another host (its pid cannot be checked)
        st.connection().execute(
            "UPDATE runs SET heartbeat = heartbeat - 3600, host = 'elsewhere' WHERE run_id = ?",
            (dead,),
        )
    s = run_sweep(cfg, db, lease=60.0)
    assert (s.elsewhere, s.computed) == (4, len(keys) - 4)  # the live run's 4 left to it
    with sqlite3.connect(db) as conn:
        status = dict(conn.execute("SELECT run_id, status FROM runs"))
        assert status[dead] == "abandoned" and status[live] == "running"
        stored = {k for (k,) in conn.execute("SELECT key FROM cells")}
    assert stored == set(keys[4:])


# -- full disk ------------------------------------------------------------------------


def test_full_disk_injected_is_one_line_and_keeps_the_finished_cells(tmp_path, capsys, monkeypatch):
    calls = {"n": 0}

    class FillsUp:
        """The store's connection, whose third batch of cells meets a full disk."""

        def __init__(self, conn):
            self._conn = conn

        def executemany(self, sql, params):
            if sql.startswith("INSERT INTO cells"):
                calls["n"] += 1
                if calls["n"] == 3:
                    raise sqlite3.OperationalError("database or disk is full")
            return self._conn.executemany(sql, params)

        def __getattr__(self, name):
            return getattr(self._conn, name)

    real_connect = ResultStore._connect
    monkeypatch.setattr(ResultStore, "_connect", lambda self: FillsUp(real_connect(self)))
    db = tmp_path / "r.db"
    cfg = write_sweep(tmp_path / "s.toml")
    assert _main_status(["sweep", str(cfg), "--store", str(db), "--no-progress"]) == EXIT_DISK
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "no space left" in err and str(db) in err
    finished = rows(db)
    assert len(finished) > 0 and {r[-1] for r in finished.values()} == {"ok"}
    assert sd.results.load(db, "runs")["status"].tolist() == ["failed"]
    monkeypatch.setattr(ResultStore, "_connect", real_connect)
    resumed = run_sweep(cfg, db)  # space again: the rerun completes the grid
    assert resumed.skipped == len(finished) and len(rows(db)) == resumed.planned


@pytest.mark.slow
def test_full_disk_on_a_small_tmpfs(tmp_path):
    media = tmp_path / "small"
    cfg = write_sweep(tmp_path / "s.toml", T=60.0, seeds=4)
    try:
        with tmpfs(media, "160k"):
            db = media / "r.db"
            res = subprocess.run(
                [*CLI, "sweep", str(cfg), "--store", str(db), "--no-progress"],
                capture_output=True,
                text=True,
                timeout=300,
            )
            assert res.returncode == EXIT_DISK, res.stderr
            # one line, besides the compile notice of a run that compiled (cli._main)
            err = error_lines(res.stderr)
            assert len(err) == 1 and "no space left" in err[0]
            with sqlite3.connect(f"file:{db}?mode=ro", uri=True) as conn:
                assert conn.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
                kept = conn.execute("SELECT COUNT(*) FROM cells").fetchone()[0]
            assert kept > 0
    except Unavailable as exc:
        pytest.skip(str(exc))


# -- 5. bounded planning --------------------------------------------------------------

HUGE = {
    "h": "[0.005, 0.01, 0.02, 0.05, 0.1]",
    "eta": "[" + ", ".join(str(i) for i in range(100)) + "]",
    "v": "[" + ", ".join(str(i) for i in range(100)) + "]",
    "seeds": 1_000_000_000,
}


def test_a_huge_grid_is_counted_by_arithmetic_and_refused_with_its_size(tmp_path):
    cfg = load_config(write_sweep(tmp_path / "huge.toml", **HUGE))
    tracemalloc.start()
    study = plan_study(cfg)
    n = study.n_cells
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    # 5 h x (1 noise-free pair + 9999 pairs x 1e9 seeds) x 4 methods x 1 norm
    assert n == 5 * (1 + 9999 * 1_000_000_000) * 4
    assert peak < 20e6  # nothing listed
    with pytest.raises(SweepConfigError) as exc:
        check_grid_size(study)
    msg = str(exc.value)
    assert f"{n:,}" in msg and f"{DEFAULT_MAX_CELLS:,}" in msg and "max_cells" in msg
    check_grid_size(study, max_cells=n)  # a limit raised on purpose lets it through


@pytest.mark.slow
def test_a_grid_streams_in_the_memory_of_a_group(tmp_path):
    def peak_of(seeds: int) -> tuple[int, int]:
        cfg = load_config(write_sweep(tmp_path / f"g{seeds}.toml", h="[0.01]", seeds=seeds))
        study = plan_study(cfg)
        tracemalloc.start()
        count = sum(len(g.cells) for g in study.iter_groups())
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert count == study.n_cells
        return count, peak

    small, peak_small = peak_of(50)
    large, peak_large = peak_of(1000)
    assert large > 15 * small
    assert peak_large < 2 * peak_small + 1e6  # not growing with the grid


def _limit_memory() -> None:
    import signal

    signal.signal(signal.SIGINT, signal.SIG_DFL)
    resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="RLIMIT_AS")
def test_cli_refuses_a_huge_grid_at_once_naming_size_and_limit(tmp_path):
    """The grid of the issue (21.6 M cells) and larger: refused at once, in bounded
    memory (the process runs under a 4 GB address-space limit), writing nothing."""
    cfg = write_sweep(tmp_path / "huge.toml", **HUGE)
    db = tmp_path / "r.db"
    for extra in (["--dry-run"], ["--max-cells", "50000000"]):
        res = subprocess.run(
            [*CLI, "sweep", str(cfg), "--store", str(db), "--no-progress", *extra],
            capture_output=True,
            text=True,
            timeout=120,
            preexec_fn=_limit_memory,
        )
        assert res.returncode == EXIT_BAD_VALUE, res.stderr
        err = res.stderr.strip()
        assert err.count("\n") == 0
        assert "199,980,000,000,020 cells" in err
        limit = "50,000,000" if extra[1:] else f"{DEFAULT_MAX_CELLS:,}"
        assert f"limit of {limit} cells" in err
        assert not db.exists()


def test_a_transaction_left_open_by_an_interrupt_does_not_stop_marking_the_run(tmp_path):
    """A Ctrl-C between a BEGIN and its try leaves the connection in a transaction; the
    run must still be marked "interrupted" (it stayed "running" once in a loaded test)."""
    with ResultStore(tmp_path / "r.db") as st:
        run = st.start_run(backend="in-process", planned=3, skipped=0, config={})
        st.connection().execute("BEGIN IMMEDIATE")  # as the interrupted write left it
        st.finish_run(run, "interrupted")
        [(status,)] = st.connection().execute("SELECT status FROM runs").fetchall()
    assert status == "interrupted"


def test_a_run_is_marked_with_the_cells_stored_under_it(tmp_path):
    """A SIGTERM between a write's commit and its caller's count left a run's "computed"
    short of its stored cells once (60 stored, 30 counted): the store counts them."""

    def cell(key: str, run: str, status: str) -> dict:
        return {"key": key, "run_id": run, "computed_at": 0.0, "status": status,
                "version": "0", "method": "AB1", "config": "{}"}  # fmt: skip

    with ResultStore(tmp_path / "r.db") as st:
        run = st.start_run(backend="in-process", planned=4, skipped=0, config={})
        other = st.start_run(backend="in-process", planned=4, skipped=0, config={})
        st.write([cell("a", run, "ok"), cell("b", run, "error"), cell("c", run, "ok")])
        st.write([cell("d", other, "ok")])
        st.finish_run(run, "interrupted")  # no count from the caller
        st.finish_run(other, "interrupted")
        rows = st.connection().execute("SELECT run_id, computed, failed FROM runs").fetchall()
    assert {r: (c, f) for r, c, f in rows} == {run: (3, 1), other: (1, 0)}


# -- the generic cell: schema 3, views per kind, older stores ---------------------------


def _schema_2_store(path: Path, rows: list[dict]) -> Path:
    """A store as schema 2 wrote it: the prediction study's columns (norm, err_eta...)
    and the named results of other kinds as JSON in ``result``."""
    from sampledyn.experiments.sweep._store import (
        _CLAIM_COLUMNS,
        _RUN_COLUMNS,
        _TRAJ_COLUMNS,
        CELL_COLUMNS_2,
    )

    def ddl(table, cols):
        return f"CREATE TABLE {table} (" + ", ".join(f'"{n}" {t}' for n, t in cols) + ")"

    with sqlite3.connect(path) as conn:
        conn.execute(f"PRAGMA application_id = {APPLICATION_ID}")
        conn.execute("CREATE TABLE meta (name TEXT PRIMARY KEY, value TEXT)")
        conn.execute("INSERT INTO meta VALUES ('schema_version', '2')")
        for table, cols in (("cells", CELL_COLUMNS_2), ("trajectories", _TRAJ_COLUMNS),
                            ("runs", _RUN_COLUMNS), ("claims", _CLAIM_COLUMNS)):  # fmt: skip
            conn.execute(ddl(table, cols))
        for r in rows:
            row = {"run_id": "r", "computed_at": 0.0, "status": "ok", "version": "0", "h": 0.5,
                   "method": "AB2", "config": "{}", **r}  # fmt: skip
            cols = ", ".join(f'"{k}"' for k in row)
            conn.execute(f"INSERT INTO cells ({cols}) VALUES ({','.join('?' * len(row))})",
                         tuple(row.values()))  # fmt: skip
    return path


_OLD_ROWS = [
    {"key": "a", "norm": "rms", "err_eta": 1.5e-4, "err_v": 2.5e-4, "err_all": 3e-4},
    {"key": "b", "kind": "closed_loop", "norm": "tracking",
     "result": '{"depth_p95": 0.125, "one_step_rms": NaN, "outcome": "ok"}'},
    {"key": "c", "kind": "multistep", "norm": "k=2", "err_eta": 0.5, "err_v": 0.25,
     "result": '{"k": 2, "diverged": false}'},
]  # fmt: skip


def test_a_schema_2_store_is_read_as_it_is_and_moved_to_the_generic_layout(tmp_path):
    db = _schema_2_store(tmp_path / "old.db", _OLD_ROWS)
    before = db.read_bytes()
    df = sd.results.load(db)  # read-only: the file is not changed
    assert db.read_bytes() == before
    assert list(df["kind"]) == ["prediction", "closed_loop", "multistep"]
    assert list(df["measure"]) == ["rms", "tracking", "k=2"] and "norm" not in df.columns
    assert df.loc[1, "depth_p95"] == 0.125 and df.loc[0, "err_eta"] == 1.5e-4
    cl = sd.results.load(db, kind="closed_loop")
    assert list(cl["measure"]) == ["tracking"] and "err_eta" not in cl.columns
    assert cl.loc[0, "outcome"] == "ok" and np.isnan(cl.loc[0, "one_step_rms"])
    ms = sd.results.load(db, kind="multistep")
    assert list(ms["horizon"]) == ["k=2"] and ms["diverged"].tolist() == [False]
    assert list(sd.results.load(db, kind="prediction")["norm"]) == ["rms"]
    # Opened to write, it becomes schema 3: the generic table and a view per kind.
    ResultStore(db).close()
    with sqlite3.connect(db) as conn:
        assert conn.execute("SELECT value FROM meta").fetchone()[0] == "3"
        columns = {r[1] for r in conn.execute("PRAGMA table_info(cells)")}
        assert {"measure", "depth_p95", "k"} <= columns and not {"norm", "result"} & columns
        assert conn.execute("SELECT depth_p95, outcome FROM cells_closed_loop").fetchall() == [
            (0.125, "ok")
        ]
        assert conn.execute("SELECT norm, err_eta FROM cells_prediction").fetchall() == [
            ("rms", 1.5e-4)
        ]
        assert conn.execute("SELECT horizon, k FROM cells_multistep").fetchall() == [("k=2", 2)]
    after = sd.results.load(db)
    assert after.loc[1, "depth_p95"] == 0.125 and list(after["measure"]) == list(df["measure"])


def test_a_schema_2_store_of_an_unknown_kind_is_refused_untouched(tmp_path):
    db = _schema_2_store(tmp_path / "old.db", [{"key": "x", "kind": "mystery", "norm": "m"}])
    before = db.read_bytes()
    with pytest.raises(ValueError, match="kind 'mystery'.*left untouched"):
        ResultStore(db)
    assert db.read_bytes() == before
    assert list(sd.results.load(db)["kind"]) == ["mystery"]  # still readable


def test_new_stores_have_one_cells_table_and_a_view_per_kind(tmp_path):
    db = tmp_path / "r.db"
    run_sweep(write_sweep(tmp_path / "s.toml", h="[0.02]", seeds=1), db)
    with sqlite3.connect(db) as conn:
        views = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type='view'")}
        n = conn.execute("SELECT COUNT(*) FROM cells").fetchone()[0]
        assert views == {"cells_prediction"}
        assert conn.execute("SELECT COUNT(*) FROM cells_prediction").fetchone()[0] == n > 0
        kinds = {r[0] for r in conn.execute("SELECT DISTINCT kind FROM cells")}
    assert kinds == {"prediction"}
