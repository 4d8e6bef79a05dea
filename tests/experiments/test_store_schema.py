"""A store is data, not a program (issue 24, item 3): a file with the store's mark
whose tables are views, or that carries triggers or views of its own, is refused
on open, naming the object, and left untouched; its own ``cells_<kind>`` views are
accepted by their exact SQL; connections do not trust the schema."""

from __future__ import annotations

import shutil
import sqlite3
import time
from pathlib import Path

import pytest
from _sweep_helpers import write_sweep

from sampledyn.cli import main
from sampledyn.cli._status import EXIT_BAD_VALUE
from sampledyn.exceptions import NotAStoreError
from sampledyn.experiments.sweep import load_config, run_sweep
from sampledyn.experiments.sweep._store import ResultStore

SMALL = {"T": 2.0, "after": 0.5, "h": "[0.02]", "methods": '["AB1", "AB2"]', "eta": "[0]",
         "v": "[0]", "seeds": 1}  # fmt: skip


@pytest.fixture(scope="module")
def store(tmp_path_factory) -> Path:
    work = tmp_path_factory.mktemp("store")
    cfg = write_sweep(work / "s.toml", **SMALL)
    db = work / "s.db"
    run_sweep(load_config(cfg), db, progress=False)
    with sqlite3.connect(db) as conn:  # one file, no side files
        conn.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    return db


def _copy(store: Path, folder: Path, *sql: str) -> Path:
    (folder / "db").mkdir(exist_ok=True)
    db = folder / "db" / "tampered.db"
    shutil.copy(store, db)
    conn = sqlite3.connect(db, isolation_level=None)
    try:
        for statement in sql:
            conn.execute(statement)
        conn.execute("PRAGMA journal_mode = DELETE")
    finally:
        conn.close()
    return db


def _status(args: list[str]) -> int:
    with pytest.raises(SystemExit) as exc:
        main(args)
    return int(exc.value.code)  # type: ignore[arg-type]


def _state(db: Path) -> tuple[bytes, int, list[str]]:
    return db.read_bytes(), db.stat().st_mtime_ns, sorted(p.name for p in db.parent.iterdir())


RECURSIVE_CELLS = (
    "ALTER TABLE cells RENAME TO cells_data",
    "CREATE VIEW cells AS WITH RECURSIVE r(n) AS (SELECT 1 UNION ALL SELECT n + 1 FROM r) "
    "SELECT n AS key FROM r",
)
EMPTYING_TRIGGER = ("CREATE TRIGGER wipe AFTER INSERT ON cells BEGIN DELETE FROM cells; END",)


@pytest.mark.parametrize(
    "sql, named",
    [
        (RECURSIVE_CELLS, "its 'cells' is a view, not a table"),
        (EMPTYING_TRIGGER, "a trigger 'wipe' (on 'cells')"),
        (("CREATE TRIGGER t2 BEFORE UPDATE ON runs BEGIN SELECT 1; END",), "trigger 't2'"),
        (("CREATE VIEW extra AS SELECT * FROM cells",), "a view 'extra' that the store does"),
        (
            (
                'DROP VIEW "cells_prediction"',
                'CREATE VIEW "cells_prediction" AS WITH RECURSIVE r(n) AS (SELECT 1 UNION ALL '
                "SELECT n + 1 FROM r) SELECT n AS key FROM r",
            ),
            "a view 'cells_prediction' that the store does not create",
        ),
        (
            (
                'DROP VIEW "cells_prediction"',
                'CREATE VIEW "cells_prediction" AS SELECT "key" FROM cells WHERE kind = '
                "'multistep'",
            ),
            "a view 'cells_prediction' that the store does not create",
        ),
        (("CREATE INDEX sneaky ON cells (abs(h))",), None),  # an index of a store table: data
    ],
)
@pytest.mark.parametrize("command", ["results", "sweep", "report"])
def test_code_in_a_store_is_refused_naming_the_object(store, tmp_path, capsys, sql, named, command):
    db = _copy(store, tmp_path, *sql)
    before = _state(db)
    time.sleep(0.01)
    cfg = write_sweep(tmp_path / "s.toml", **SMALL)
    args = {
        "results": ["results", str(db), "--format", "csv"],
        "sweep": ["sweep", str(cfg), "--store", str(db), "--no-progress"],
        "report": ["report", str(db), "--out", str(tmp_path / "rep")],
    }[command]
    if named is None:
        assert main(args) == 0
        return
    t0 = time.monotonic()
    assert _status(args) == EXIT_BAD_VALUE
    assert time.monotonic() - t0 < 60  # refused on open, not after filling a disk
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and named in err[0] and str(db) in err[0]
    assert "left untouched" in err[0]
    assert _state(db) == before


def test_the_stores_own_views_are_accepted_and_the_schema_is_not_trusted(store, tmp_path):
    db = _copy(store, tmp_path)
    with ResultStore(db, readonly=True) as s:
        conn = s.connection()
        views = [r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type='view'")]
        assert views == ["cells_prediction"]
        assert conn.execute("PRAGMA trusted_schema").fetchone()[0] == 0
    with ResultStore(db) as s:
        assert s.connection().execute("PRAGMA trusted_schema").fetchone()[0] == 0
        assert s.count() == 2


def test_a_trigger_never_runs_on_a_sweep(store, tmp_path):
    """The audit's case: with the trigger, a sweep reported "4 computed" and kept 0."""
    db = _copy(store, tmp_path, "DELETE FROM cells", *EMPTYING_TRIGGER)
    with pytest.raises(NotAStoreError, match="trigger 'wipe'"):
        run_sweep(load_config(write_sweep(tmp_path / "s.toml", **SMALL)), db, progress=False)
    with sqlite3.connect(db) as conn:
        assert conn.execute("SELECT COUNT(*) FROM cells").fetchone()[0] == 0
