"""The results store: one SQLite file, one row per cell, written by the client only.

Tables
------
cells
    One row per cell, primary key ``key`` = SHA-256 of the cell's configuration
    (stored as JSON in ``config``), which includes the library version, the norm and
    fingerprints of the model and input. Columns: the configuration spread out
    (vehicle, input, T, after, h, method, order, eta_pct, v_pct, seed, norm, ...),
    the results ``err_eta``, ``err_v``, ``err_all`` (the norm over the position/angle
    components, the rate components, all components), ``status`` ("ok"/"error"),
    ``error``, ``warnings``, ``seconds`` (compute time of the cell on its worker),
    ``worker``, ``run_id`` and ``computed_at`` (Unix time).
trajectories
    One row per exact-sample trajectory: its configuration, certificate (largest
    scaled per-interval flow error), samples and simulation time.
runs
    One row per ``sweep`` invocation: start/end, status, backend, counts, config.

The database runs in WAL mode and every batch of rows is one transaction, so a
process killed at any moment (even SIGKILL) leaves every committed row intact and the
file consistent. A finished ("ok") row is never replaced.
"""

from __future__ import annotations

import json
import os
import socket
import sqlite3
import time
import uuid
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

__all__ = ["CELL_COLUMNS", "ResultStore"]

SCHEMA_VERSION = "1"

CELL_COLUMNS: tuple[tuple[str, str], ...] = (
    ("key", "TEXT PRIMARY KEY"),
    ("run_id", "TEXT NOT NULL"),
    ("computed_at", "REAL NOT NULL"),
    ("status", "TEXT NOT NULL"),
    ("version", "TEXT NOT NULL"),
    ("vehicle", "TEXT"),
    ("buoyancy_pct", "REAL"),
    ("input", "TEXT"),
    ("model_fingerprint", "TEXT"),
    ("input_fingerprint", "TEXT"),
    ("T", "REAL"),
    ("after", "REAL"),
    ("h", "REAL"),
    ("method", "TEXT"),
    ("order", "INTEGER"),
    ("eta_pct", "REAL"),
    ("v_pct", "REAL"),
    ("seed", "INTEGER"),
    ("base_seed", "INTEGER"),
    ("distribution", "TEXT"),
    ("norm", "TEXT"),
    ("err_eta", "REAL"),
    ("err_v", "REAL"),
    ("err_all", "REAL"),
    ("seconds", "REAL"),
    ("worker", "TEXT"),
    ("traj_key", "TEXT"),
    ("error", "TEXT"),
    ("warnings", "TEXT"),
    ("config", "TEXT NOT NULL"),
)

_TRAJ_COLUMNS = (
    ("traj_key", "TEXT PRIMARY KEY"),
    ("run_id", "TEXT NOT NULL"),
    ("computed_at", "REAL NOT NULL"),
    ("status", "TEXT"),
    ("h", "REAL"),
    ("n_samples", "INTEGER"),
    ("certificate", "REAL"),
    ("seconds", "REAL"),
    ("worker", "TEXT"),
    ("error", "TEXT"),
    ("warnings", "TEXT"),
    ("config", "TEXT NOT NULL"),
)

_RUN_COLUMNS = (
    ("run_id", "TEXT PRIMARY KEY"),
    ("started_at", "REAL NOT NULL"),
    ("finished_at", "REAL"),
    ("status", "TEXT NOT NULL"),
    ("version", "TEXT NOT NULL"),
    ("backend", "TEXT"),
    ("host", "TEXT"),
    ("pid", "INTEGER"),
    ("planned", "INTEGER"),
    ("skipped", "INTEGER"),
    ("computed", "INTEGER"),
    ("failed", "INTEGER"),
    ("config", "TEXT"),
)


def _ddl(table: str, columns: Sequence[tuple[str, str]]) -> str:
    cols = ", ".join(f'"{n}" {t}' for n, t in columns)
    return f"CREATE TABLE IF NOT EXISTS {table} ({cols})"


class ResultStore:
    """A results store at ``path`` (created if missing, unless ``create`` is False).

    Raises
    ------
    FileNotFoundError
        if ``create`` is False and there is no file at ``path``.
    ValueError
        if the file is not a sampledyn store (or of a newer schema).
    """

    def __init__(self, path: str | os.PathLike[str], *, create: bool = True) -> None:
        self.path = Path(path)
        if not create and not self.path.is_file():
            raise FileNotFoundError(f"no results store at {str(self.path)!r}.")
        if create:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        # Autocommit; writes use explicit BEGIN IMMEDIATE ... COMMIT.
        self._conn = sqlite3.connect(self.path, timeout=60.0, isolation_level=None)
        try:
            self._conn.execute("PRAGMA busy_timeout = 60000")
            if create:
                self._conn.execute("PRAGMA journal_mode = WAL")
                # NORMAL in WAL mode: a killed process loses nothing committed; a power
                # cut may lose the last commits but never corrupts the file.
                self._conn.execute("PRAGMA synchronous = NORMAL")
                self._init_schema()
            self._check_schema()
        except sqlite3.DatabaseError as exc:
            self._conn.close()
            raise ValueError(f"{str(self.path)!r} is not a sampledyn results store: {exc}") from exc

    # -- schema -------------------------------------------------------------------

    def _init_schema(self) -> None:
        with self._transaction():
            self._conn.execute(
                "CREATE TABLE IF NOT EXISTS meta (name TEXT PRIMARY KEY, value TEXT)"
            )
            self._conn.execute(
                "INSERT OR IGNORE INTO meta VALUES ('schema_version', ?)", (SCHEMA_VERSION,)
            )
            self._conn.execute(_ddl("cells", CELL_COLUMNS))
            self._conn.execute(_ddl("trajectories", _TRAJ_COLUMNS))
            self._conn.execute(_ddl("runs", _RUN_COLUMNS))
            self._conn.execute("CREATE INDEX IF NOT EXISTS cells_run ON cells (run_id)")

    def _check_schema(self) -> None:
        try:
            row = self._conn.execute(
                "SELECT value FROM meta WHERE name = 'schema_version'"
            ).fetchone()
        except sqlite3.OperationalError:
            row = None
        if row is None:
            raise sqlite3.DatabaseError("no schema_version in table meta")
        if row[0] != SCHEMA_VERSION:
            raise ValueError(
                f"{str(self.path)!r} has store schema {row[0]}, this library reads "
                f"{SCHEMA_VERSION}; use the library version that wrote it."
            )

    def _transaction(self) -> Any:
        conn = self._conn

        class _Tx:
            def __enter__(self) -> None:
                conn.execute("BEGIN IMMEDIATE")

            def __exit__(self, exc_type: Any, *_: Any) -> None:
                conn.execute("ROLLBACK" if exc_type else "COMMIT")

        return _Tx()

    # -- reading ------------------------------------------------------------------

    def statuses(self, keys: Iterable[str]) -> dict[str, str]:
        """``status`` of each of ``keys`` present in the store."""
        keys = list(keys)
        out: dict[str, str] = {}
        for i in range(0, len(keys), 500):
            part = keys[i : i + 500]
            marks = ",".join("?" * len(part))
            q = f"SELECT key, status FROM cells WHERE key IN ({marks})"
            out.update(dict(self._conn.execute(q, part).fetchall()))
        return out

    def count(self, table: str = "cells") -> int:
        """Number of rows of ``table`` ("cells", "trajectories" or "runs")."""
        if table not in ("cells", "trajectories", "runs"):
            raise ValueError(f"unknown `table` {table!r}; valid: cells, trajectories, runs.")
        return int(self._conn.execute(f"SELECT COUNT(*) FROM {table}").fetchone()[0])

    def connection(self) -> sqlite3.Connection:
        """The underlying connection (for reading, e.g. with pandas)."""
        return self._conn

    # -- writing (client only) ----------------------------------------------------

    def start_run(self, *, backend: str, planned: int, skipped: int, config: Any) -> str:
        """Record a new run; returns its id."""
        from ..._version import __version__

        run_id = uuid.uuid4().hex
        row = {
            "run_id": run_id,
            "started_at": time.time(),
            "status": "running",
            "version": __version__,
            "backend": backend,
            "host": socket.gethostname(),
            "pid": os.getpid(),
            "planned": planned,
            "skipped": skipped,
            "computed": 0,
            "failed": 0,
            "config": json.dumps(config, sort_keys=True),
        }
        with self._transaction():
            self._insert("runs", row, conflict="ABORT")
        return run_id

    def finish_run(self, run_id: str, status: str, computed: int, failed: int) -> None:
        """Mark a run "complete", "interrupted" or "failed"."""
        with self._transaction():
            self._conn.execute(
                "UPDATE runs SET finished_at = ?, status = ?, computed = ?, failed = ? "
                "WHERE run_id = ?",
                (time.time(), status, computed, failed, run_id),
            )

    def write(
        self,
        cells: Sequence[dict[str, Any]],
        trajectories: Sequence[dict[str, Any]] = (),
    ) -> None:
        """Insert rows in one transaction. A cell whose key is already stored with
        status "ok" is left as it is; an "error" row is replaced."""
        names = [n for n, _ in CELL_COLUMNS]
        cols = ", ".join(f'"{n}"' for n in names)
        updates = ", ".join(f'"{n}" = excluded."{n}"' for n in names[1:])
        cell_sql = (
            f"INSERT INTO cells ({cols}) VALUES ({','.join('?' * len(names))}) "
            f"ON CONFLICT(key) DO UPDATE SET {updates} WHERE cells.status <> 'ok'"
        )
        with self._transaction():
            for t in trajectories:
                self._insert("trajectories", t, conflict="IGNORE")
            self._conn.executemany(cell_sql, [tuple(c.get(n) for n in names) for c in cells])

    def _insert(self, table: str, row: dict[str, Any], conflict: str) -> None:
        cols = ", ".join(f'"{k}"' for k in row)
        marks = ",".join("?" * len(row))
        self._conn.execute(
            f"INSERT OR {conflict} INTO {table} ({cols}) VALUES ({marks})", tuple(row.values())
        )

    def close(self) -> None:
        self._conn.close()

    def __enter__(self) -> ResultStore:
        return self

    def __exit__(self, *_: Any) -> None:
        self.close()
