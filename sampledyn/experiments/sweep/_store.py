"""The results store: one SQLite file, one row per cell, written by the client only.

A store is marked as such: its SQLite header carries the application id
:data:`APPLICATION_ID` ("SDYN") and its table ``meta`` the schema version (3). A
file without the mark (another application's database, a text file) is refused
before anything is written to it, and left byte for byte as it was. Stores of older
schemas are read as they are (read-only) and upgraded when a run next writes to
them: schema 1 (before the mark) is recognised by its tables; schema 2 (the columns
of the prediction study: ``norm``, ``err_eta``..., other kinds' numbers as JSON in
``result``) has its rows moved to the generic layout, or is refused untouched,
with the reason, if it holds cells of a kind this process does not know.

Tables
------
cells
    One generic row per cell: (key, kind, coordinates, values). ``key`` (primary
    key) = SHA-256 of the cell's configuration (stored as JSON in ``config``), which
    includes the library version, the measure and fingerprints of the model and
    input; ``kind``, the study's cell kind ("prediction", "closed_loop",
    "multistep", ...); the coordinates every kind has (vehicle, input, T, after, h,
    method, order, eta_pct, v_pct, seed, base_seed, distribution, ``measure``: the
    norm of a prediction, the horizon "k=3" of a multistep study, ...), ``status``
    ("ok"/"error"), ``error``, ``warnings``, ``seconds`` (compute time of the cell on
    its worker), ``worker``, ``run_id`` and ``computed_at`` (Unix time); then one
    column per value a kind declares (:attr:`CellKind.columns`: ``err_eta``,
    ``err_v``, ``err_all`` of a prediction; ``depth_p95``, ``outcome``, ... of a
    closed loop), added when a kind first writes to the store, NULL in the rows of
    other kinds.
cells_<kind> (views)
    One view per kind written: the common columns, the measure under the kind's
    name for it (``norm``, ``horizon``), and the kind's own value columns.
trajectories
    One row per exact-sample trajectory: its configuration, certificate (largest
    scaled per-interval flow error), samples, simulation time and ``summary`` (JSON:
    the numbers the study asked for, e.g. the vehicle's motion).
runs
    One row per ``sweep`` invocation: start/end, status ("running", "complete",
    "interrupted", "failed", or "abandoned" once another run found it dead), backend,
    host and pid, ``heartbeat`` (Unix time, refreshed while it runs), and what it did:
    ``planned``, ``skipped`` (found stored), ``elsewhere`` (being computed by another
    run), ``computed``, ``failed``, ``duplicates`` (computed, but another run had
    stored the cell first), config.
claims
    Cells a running run is computing (``key``, ``run_id``, ``claimed_at``). A run
    claims a chunk of cells before it computes them, so concurrent runs on one store
    split the work; the claims of a run that died (its process is gone, or its
    heartbeat is older than the lease) are taken over.

A store holds data only. On every open, before anything is read from or written to
its tables, the expected objects (``meta``, ``cells``, ``trajectories``, ``runs``,
``claims``) must be plain tables; a trigger, a view other than the ``cells_<kind>``
views the store itself creates (checked by their exact SQL), or an index of another
table is refused naming the object, and the file is left untouched. Connections run
with ``PRAGMA trusted_schema = OFF``, so nothing in the schema can call functions
with side effects.

The database runs in WAL mode and every batch of rows is one transaction, so a
process killed at any moment (even SIGKILL) leaves every committed row intact and the
file consistent. A finished ("ok") row is never replaced.

SQLite errors are raised as the ``OSError`` they mean, with the store's path as
``filename``: a full disk as errno ``ENOSPC``, a read-only file or folder as
``PermissionError``, so callers can tell them apart.
"""

from __future__ import annotations

import errno
import json
import os
import re
import socket
import sqlite3
import time
import uuid
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..._files import parse_json, regular_file
from ...exceptions import NotAStoreError

__all__ = [
    "APPLICATION_ID",
    "CELL_COLUMNS",
    "Claim",
    "ResultStore",
    "inspect_store",
    "load_results",
]

#: SQLite ``application_id`` of a results store: the bytes "SDYN".
APPLICATION_ID = 0x5344594E
SCHEMA_VERSION = "3"
_OLDER_SCHEMAS = ("1", "2")  # read as they are, upgraded when written to
_SQLITE_MAGIC = b"SQLite format 3\x00"
_SIDE_FILES = ("-wal", "-shm", "-journal")

#: The columns every cell has (its kind's values follow, :attr:`CellKind.columns`).
CELL_COLUMNS: tuple[tuple[str, str], ...] = (
    ("key", "TEXT PRIMARY KEY"),
    ("kind", "TEXT"),
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
    ("measure", "TEXT"),
    ("seconds", "REAL"),
    ("worker", "TEXT"),
    ("traj_key", "TEXT"),
    ("error", "TEXT"),
    ("warnings", "TEXT"),
    ("config", "TEXT NOT NULL"),
)
#: The cells table of schema 2 (the prediction study's columns; other kinds' values as
#: JSON in ``result``), read as it is and moved to the generic layout when written to.
CELL_COLUMNS_2: tuple[tuple[str, str], ...] = (
    *((n, t) for n, t in CELL_COLUMNS if n not in ("kind", "measure")),
    ("norm", "TEXT"),
    ("err_eta", "REAL"),
    ("err_v", "REAL"),
    ("err_all", "REAL"),
    ("kind", "TEXT"),
    ("result", "TEXT"),
)
_SQL_TYPES = {float: "REAL", int: "INTEGER", bool: "INTEGER", str: "TEXT"}

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
    ("summary", "TEXT"),
)
_TRAJ_COLUMNS_ADDED = ("summary",)  # added to stores written before (same schema)

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
    ("heartbeat", "REAL"),
    ("elsewhere", "INTEGER"),
    ("duplicates", "INTEGER"),
)
_RUN_COLUMNS_ADDED_IN_2 = ("heartbeat", "elsewhere", "duplicates")

_CLAIM_COLUMNS = (
    ("key", "TEXT PRIMARY KEY"),
    ("run_id", "TEXT NOT NULL"),
    ("claimed_at", "REAL NOT NULL"),
)
_TABLES = ("cells", "trajectories", "runs")
_BATCH = 500  # keys per SQL statement (SQLite's variable limit is 32766 since 3.32)


@dataclass(frozen=True)
class Claim:
    """What :meth:`ResultStore.claim` did with a list of cell keys.

    Attributes
    ----------
    keys : tuple of str
        The keys now claimed by the calling run (to compute).
    done : int
        Keys already stored (not to compute).
    elsewhere : int
        Keys claimed by another run that is still alive.
    """

    keys: tuple[str, ...]
    done: int
    elsewhere: int


def _ddl(table: str, columns: Sequence[tuple[str, str]]) -> str:
    cols = ", ".join(f'"{n}" {t}' for n, t in columns)
    return f"CREATE TABLE IF NOT EXISTS {table} ({cols})"


def _uri(path: Path, **params: str) -> str:
    query = "&".join(f"{k}={v}" for k, v in params.items())
    return f"{path.resolve().as_uri()}?{query}"


def os_error(exc: sqlite3.Error, path: Path) -> Exception:
    """The ``OSError`` (or ``ValueError``) an SQLite error on the store at ``path`` means."""
    text = str(exc)
    low = text.lower()
    name = str(path)
    if "full" in low:
        return OSError(errno.ENOSPC, f"no space left to write the results store ({text})", name)
    if "readonly" in low or "read-only" in low:
        return PermissionError(
            errno.EROFS,
            f"the results store is read-only ({text}); copy it somewhere writable",
            name,
        )
    if "unable to open" in low:
        return PermissionError(errno.EACCES, f"cannot open the results store ({text})", name)
    if "disk i/o" in low:
        return OSError(errno.EIO, f"I/O error on the results store ({text})", name)
    if "locked" in low or "busy" in low:
        return OSError(
            errno.EBUSY, f"the results store stayed locked by another process ({text})", name
        )
    if "not a database" in low or "malformed" in low or "corrupt" in low:
        return NotAStoreError(f"{name!r} is damaged or not a results store: {text}.")
    return OSError(errno.EIO, f"results store error ({text})", name)


@contextmanager
def _translated(path: Path) -> Iterator[None]:
    try:
        yield
    except sqlite3.Error as exc:
        raise os_error(exc, path) from exc


_EXPECTED = ("meta", *("cells", "trajectories", "runs"), "claims")
# The exact form of a view the store creates (see ResultStore._view_sql): quoted
# column names of ``cells``, the measure under the kind's name, one kind.
_VIEW_COLUMN = r'"[A-Za-z0-9_]+"(?: AS "[A-Za-z0-9_]+")?'
_VIEW_SQL = re.compile(
    r'CREATE VIEW "cells_(?P<kind>[A-Za-z0-9_]+)" AS SELECT '
    rf"(?P<cols>{_VIEW_COLUMN}(?:, {_VIEW_COLUMN})*)"
    r" FROM cells WHERE kind = '(?P=kind)'"
)


def _secure(conn: sqlite3.Connection) -> sqlite3.Connection:
    """No function with side effects from the schema (views, triggers, defaults)."""
    conn.execute("PRAGMA trusted_schema = OFF")
    return conn


def _schema_problem(rows: Sequence[tuple[Any, ...]], cell_columns: set[str]) -> str | None:
    """What in a store's ``sqlite_master`` rows (type, name, tbl_name, sql) is not
    data, or None: an expected object that is not a table, then any trigger, then a
    view that is not one the store creates. (Indexes and other tables are data; with
    the schema untrusted an index can call no function with side effects.)"""
    for typ, name, _table, _sql in rows:
        if name in _EXPECTED and typ != "table":
            return f"its {name!r} is a {typ}, not a table"
    for typ, name, table, _sql in rows:
        if typ == "trigger":
            return f"it has a trigger {name!r} (on {table!r})"
    for typ, name, _table, sql in rows:
        if typ != "view":
            continue
        match = _VIEW_SQL.fullmatch(sql or "")
        if match is None or name != f"cells_{match['kind']}":
            return f"it has a view {name!r} that the store does not create"
        used = {c.split(" AS ")[0].strip('"') for c in match["cols"].split(", ")}
        if not used <= cell_columns:
            return f"its view {name!r} names columns that cells does not have"
    return None


def _check_objects(conn: sqlite3.Connection, path: Path) -> None:
    """Refuse (:class:`NotAStoreError`, file untouched) a store whose schema holds
    anything but data (see :func:`_schema_problem`)."""
    rows = conn.execute("SELECT type, name, tbl_name, sql FROM sqlite_master").fetchall()
    columns = (
        {r[1] for r in conn.execute("PRAGMA table_info(cells)")}
        if any(r[0] == "table" and r[1] == "cells" for r in rows)
        else set()
    )
    problem = _schema_problem(rows, columns)
    if problem is not None:
        raise NotAStoreError(
            f"{str(path)!r} is refused as a results store: {problem}; a store holds data "
            "only, never code that runs on reading or writing. It was left untouched."
        )


def _process_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else
        return True
    return True


def inspect_store(path: Path) -> str:
    """What is at ``path``: "missing", "empty" (0 bytes), "store" or "older" (a store
    of schema 1, unmarked); anything else raises (``NotAStoreError``,
    ``IsADirectoryError``). Reads the file's header and, only for a database without
    an application id, its table names (immutable: nothing is created or written)."""
    if path.is_dir():
        raise IsADirectoryError(
            errno.EISDIR,
            "is a folder; give the results store a file name, e.g. results.db",
            str(path),
        )
    if not path.exists():
        return "missing"
    regular_file(path, "results store", limit=None)  # a FIFO would block, /dev/zero fill
    with path.open("rb") as fh:
        head = fh.read(100)
    if not head:
        return "empty"
    untouched = "it was left untouched; give another file name"
    if len(head) < 100 or not head.startswith(_SQLITE_MAGIC):
        raise NotAStoreError(
            f"{str(path)!r} is not a sampledyn results store (not an SQLite database); {untouched}."
        )
    app_id = int.from_bytes(head[68:72], "big", signed=False)
    if app_id == APPLICATION_ID:
        return "store"
    tables = _table_names(path) if app_id == 0 else set()
    if app_id == 0 and {"meta", *_TABLES} <= tables:
        problem = _schema_problem(_read_only_query(path, _MASTER), set())
        if problem is not None and "view" not in problem:  # older stores have no views
            raise NotAStoreError(f"{str(path)!r} is refused as a results store: {problem}; "
                                 f"{untouched}.")  # fmt: skip
    if {"meta", *_TABLES} <= tables and _meta_version(path) in (SCHEMA_VERSION, *_OLDER_SCHEMAS):
        return "older"
    what = f"application id {app_id:#010x}" if app_id else "no sampledyn mark"
    listed = f"; tables: {', '.join(sorted(tables))}" if tables else ""
    raise NotAStoreError(
        f"{str(path)!r} is an SQLite database of another application ({what}{listed}), not a "
        f"sampledyn results store; {untouched}."
    )


def _read_only_query(path: Path, sql: str) -> list[tuple[Any, ...]]:
    """Run ``sql`` on a database opened immutable (no lock, no side file); if the
    tables are still in an unmerged write-ahead log, read it in read-only mode."""
    modes = [{"immutable": "1"}]
    if Path(str(path) + "-wal").exists():
        modes.append({"mode": "ro"})
    rows: list[tuple[Any, ...]] = []
    for params in modes:
        conn = _secure(sqlite3.connect(_uri(path, **params), uri=True))
        try:
            rows = conn.execute(sql).fetchall()
        except sqlite3.Error:
            rows = []
        finally:
            conn.close()
        if rows:
            break
    return rows


_MASTER = "SELECT type, name, tbl_name, sql FROM sqlite_master"


def _table_names(path: Path) -> set[str]:
    return {
        r[0] for r in _read_only_query(path, "SELECT name FROM sqlite_master WHERE type='table'")
    }


def _meta_version(path: Path) -> str | None:
    rows = _read_only_query(path, "SELECT value FROM meta WHERE name = 'schema_version'")
    return str(rows[0][0]) if rows else None


def _remove_store_files(path: Path) -> None:
    for suffix in ("", *_SIDE_FILES):
        try:
            Path(str(path) + suffix).unlink()
        except FileNotFoundError:
            pass


class ResultStore:
    """A results store at ``path``.

    Parameters
    ----------
    path : str or path
        The SQLite file.
    create : bool
        Create the store if there is no file at ``path`` (its folder too).
    readonly : bool
        Open for reading only (SQLite ``mode=ro``; on read-only media where SQLite
        cannot create its shared-memory file, ``immutable=1``). The store is never
        written; SQLite may create its ``-wal``/``-shm`` side files next to it.
    no_side_files : bool
        With ``readonly``: if no other connection has the store open (no ``-wal``
        file), read it immutable, creating no side file at all (for dry runs).

    Attributes
    ----------
    path : Path
    readonly : bool
    created : bool
        True if this object created the file.

    Raises
    ------
    FileNotFoundError
        if there is no file at ``path`` and ``create`` is False (or ``readonly``).
    IsADirectoryError
        if ``path`` is a folder.
    PermissionError
        if the file or its folder cannot be written (or read).
    NotAStoreError
        (a ``ValueError``) if the file is not a sampledyn store; it is left untouched.
    ValueError
        for a store of a newer schema.
    OSError
        with errno ``ENOSPC`` if the disk is full.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        create: bool = True,
        readonly: bool = False,
        no_side_files: bool = False,
    ) -> None:
        self.path = Path(path)
        self.readonly = readonly
        self._no_side_files = no_side_files
        self.created = False
        kind = inspect_store(self.path)
        if kind == "missing" and (readonly or not create):
            raise FileNotFoundError(errno.ENOENT, "no results store", str(self.path))
        if kind == "empty" and readonly:
            raise NotAStoreError(
                f"{str(self.path)!r} is an empty file, not a results store (nothing to read; "
                "`sampledyn sweep FILE --store PATH` writes one)."
            )
        if readonly:
            self._conn = self._connect_readonly()
        elif kind == "missing":
            self._conn = self._create()
        else:
            self._conn = self._connect()
            with _translated(self.path):
                try:
                    _check_objects(self._conn, self.path)  # before anything runs on it
                except NotAStoreError:
                    self._conn.close()
                    raise
                if kind == "empty":
                    self._init_schema()
                elif kind == "older":
                    self._upgrade()
                    self._migrate()
                else:
                    self._add_columns()
                    self._migrate()
        try:
            self._check_schema()
        except (ValueError, OSError):
            self._conn.close()
            raise

    # -- opening ------------------------------------------------------------------

    def _connect(self) -> sqlite3.Connection:
        with _translated(self.path):
            # Autocommit; writes use explicit BEGIN IMMEDIATE ... COMMIT.
            conn = _secure(sqlite3.connect(self.path, timeout=60.0, isolation_level=None))
            conn.execute("PRAGMA busy_timeout = 60000")
            # NORMAL in WAL mode: a killed process loses nothing committed; a power cut
            # may lose the last commits but never corrupts the file.
            conn.execute("PRAGMA synchronous = NORMAL")
        return conn

    def _connect_readonly(self) -> sqlite3.Connection:
        last: sqlite3.Error | None = None
        modes = [{"mode": "ro"}, {"immutable": "1"}]
        if self._no_side_files and not Path(str(self.path) + "-wal").exists():
            # No write-ahead log: no connection has the store open, the file holds
            # everything, and an immutable open reads it without creating -wal/-shm.
            modes.reverse()
        for params in modes:
            conn = _secure(sqlite3.connect(_uri(self.path, **params), uri=True, timeout=60.0))
            try:
                conn.execute("SELECT COUNT(*) FROM sqlite_master").fetchone()
            except sqlite3.OperationalError as exc:
                # mode=ro needs the -shm file of a WAL store; on read-only media SQLite
                # cannot create it, and only an immutable open reads the file.
                conn.close()
                last = exc
                continue
            try:
                _check_objects(conn, self.path)  # before anything is read from it
                conn.execute("SELECT COUNT(*) FROM meta").fetchone()
                return conn
            except NotAStoreError:
                conn.close()
                raise
            except sqlite3.OperationalError as exc:
                conn.close()
                last = exc
        assert last is not None
        raise os_error(last, self.path) from last

    def _create(self) -> sqlite3.Connection:
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666)
        except FileExistsError:  # another run created it just now: open theirs
            return self._connect()
        os.close(fd)
        self.created = True
        try:
            conn = self._connect()
            self._conn = conn
            with _translated(self.path):
                # The mark and the schema go to the file itself (rollback journal) before
                # it switches to WAL, so the header is marked from the first moment.
                self._init_schema()
        except BaseException:
            _remove_store_files(self.path)
            raise
        return conn

    def _init_schema(self) -> None:
        conn = self._conn
        conn.execute(f"PRAGMA application_id = {APPLICATION_ID}")
        with self._transaction():
            conn.execute("CREATE TABLE IF NOT EXISTS meta (name TEXT PRIMARY KEY, value TEXT)")
            conn.execute(
                "INSERT OR IGNORE INTO meta VALUES ('schema_version', ?)", (SCHEMA_VERSION,)
            )
            conn.execute(_ddl("cells", CELL_COLUMNS))
            conn.execute(_ddl("trajectories", _TRAJ_COLUMNS))
            conn.execute(_ddl("runs", _RUN_COLUMNS))
            conn.execute(_ddl("claims", _CLAIM_COLUMNS))
            conn.execute("CREATE INDEX IF NOT EXISTS cells_run ON cells (run_id)")
            conn.execute("CREATE INDEX IF NOT EXISTS claims_run ON claims (run_id)")
        self._wal()

    def _wal(self) -> None:
        self._conn.execute("PRAGMA journal_mode = WAL")

    def _upgrade(self) -> None:
        """Mark a schema-1 store and add what schema 2 has (claims, run counts)."""
        conn = self._conn
        with self._transaction():
            have = {r[1] for r in conn.execute("PRAGMA table_info(runs)")}
            for name in _RUN_COLUMNS_ADDED_IN_2:
                if name not in have:
                    kind = dict(_RUN_COLUMNS)[name]
                    conn.execute(f'ALTER TABLE runs ADD COLUMN "{name}" {kind}')
            conn.execute(_ddl("claims", _CLAIM_COLUMNS))
            conn.execute("CREATE INDEX IF NOT EXISTS claims_run ON claims (run_id)")
            for table, name, kind in self._missing_columns():
                conn.execute(f'ALTER TABLE {table} ADD COLUMN "{name}" {kind}')
            conn.execute("UPDATE meta SET value = '2' WHERE name = 'schema_version'")
            conn.execute(f"PRAGMA application_id = {APPLICATION_ID}")
        self._wal()
        # Move the marked header from the log into the file itself.
        conn.execute("PRAGMA wal_checkpoint(TRUNCATE)")

    def _missing_columns(self) -> list[tuple[str, str, str]]:
        """(table, column, type) of the columns added since a store was written."""
        out = []
        for table, columns, added in (
            ("trajectories", _TRAJ_COLUMNS, _TRAJ_COLUMNS_ADDED),
            ("cells", CELL_COLUMNS_2, ("kind", "result")),
        ):
            have = {r[1] for r in self._conn.execute(f"PRAGMA table_info({table})")}
            if have:
                out += [(table, n, dict(columns)[n]) for n in added if n not in have]
        return out

    def _add_columns(self) -> None:
        """Add the columns of this version that the store lacks."""
        missing = [m for m in self._missing_columns() if m[0] != "cells"]
        if missing:
            with self._transaction():
                for table, name, kind in missing:
                    self._conn.execute(f'ALTER TABLE {table} ADD COLUMN "{name}" {kind}')

    def _version(self) -> str | None:
        row = self._conn.execute("SELECT value FROM meta WHERE name = 'schema_version'").fetchone()
        return None if row is None else str(row[0])

    def _migrate(self) -> None:
        """Move the cells of a schema-2 store to the generic layout (schema 3), in one
        transaction: ``norm`` becomes ``measure``, a NULL kind "prediction", the JSON
        ``result`` of other kinds their own value columns. A store holding a kind this
        process does not know is refused, untouched, with the reason."""
        conn = self._conn
        with self._transaction():
            if self._version() != "2":
                return  # already migrated (by another run), or newer: refused later
            have = {r[1] for r in conn.execute("PRAGMA table_info(cells)")}
            for name in ("kind", "result"):
                if name not in have:
                    conn.execute(f'ALTER TABLE cells ADD COLUMN "{name}" TEXT')
            conn.execute("UPDATE cells SET kind = 'prediction' WHERE kind IS NULL")
            names = [r[0] for r in conn.execute("SELECT DISTINCT kind FROM cells")]
            kinds = [_kind_of(name, self.path) for name in names]
            conn.execute('ALTER TABLE cells RENAME COLUMN "norm" TO "measure"')
            for kind in kinds:
                self._add_kind_columns(kind)
            rows = conn.execute(
                "SELECT key, kind, result FROM cells WHERE result IS NOT NULL AND result <> ''"
            ).fetchall()
            for key, kind_name, text in rows:
                declared = {n for n, _t in _kind_of(kind_name, self.path).columns}
                found = parse_json(text, f"results store {str(self.path)!r}: cell {key}")
                named = {k: v for k, v in dict(found).items() if k in declared}
                if named:
                    sets = ", ".join(f'"{k}" = ?' for k in named)
                    conn.execute(f"UPDATE cells SET {sets} WHERE key = ?", (*named.values(), key))
            conn.execute('ALTER TABLE cells DROP COLUMN "result"')
            for kind in kinds:
                self._create_view(kind)
            conn.execute(
                "UPDATE meta SET value = ? WHERE name = 'schema_version'", (SCHEMA_VERSION,)
            )

    def _add_kind_columns(self, kind: Any) -> None:
        have = {r[1]: r[2] for r in self._conn.execute("PRAGMA table_info(cells)")}
        for name, typ in kind.columns:
            sql = _SQL_TYPES[typ]
            if name not in have:
                self._conn.execute(f'ALTER TABLE cells ADD COLUMN "{name}" {sql}')
            elif have[name].upper() != sql:
                raise ValueError(
                    f"cell kind {kind.name!r} stores {name!r} as {sql}, but the results store "
                    f"{str(self.path)!r} has it as {have[name]} (another kind's); rename the "
                    "kind's column."
                )

    @staticmethod
    def _view_sql(kind: Any) -> str:
        """The SQL of the view of ``kind``, as SQLite keeps it (checked on open
        against :data:`_VIEW_SQL`)."""
        common = [n for n, _t in CELL_COLUMNS]
        cols = [f'"{n}"' if n != "measure" else f'"measure" AS "{kind.measure_name}"'
                for n in common]  # fmt: skip
        cols += [f'"{n}"' for n, _t in kind.columns if n not in common]
        return (
            f'CREATE VIEW "cells_{kind.name}" AS SELECT {", ".join(cols)} '
            f"FROM cells WHERE kind = '{kind.name}'"
        )

    def _create_view(self, kind: Any) -> None:
        sql = self._view_sql(kind)
        self._conn.execute(sql.replace("CREATE VIEW", "CREATE VIEW IF NOT EXISTS", 1))

    def ensure_kind(self, kind: Any) -> None:
        """Make the store ready for cells of ``kind``: its value columns and its view
        (created by the first run of that kind).

        Raises
        ------
        ValueError
            if a column of the kind exists with another type (another kind's).
        """
        have = {r[1] for r in self._conn.execute("PRAGMA table_info(cells)")}
        views = {
            r[0] for r in self._conn.execute("SELECT name FROM sqlite_master WHERE type='view'")
        }
        if all(n in have for n, _t in kind.columns) and f"cells_{kind.name}" in views:
            return
        with _translated(self.path), self._transaction():
            self._add_kind_columns(kind)
            self._create_view(kind)

    def _check_schema(self) -> None:
        with _translated(self.path):
            try:
                row = self._conn.execute(
                    "SELECT value FROM meta WHERE name = 'schema_version'"
                ).fetchone()
            except sqlite3.OperationalError:
                row = None
        if row is None:
            raise NotAStoreError(f"{str(self.path)!r} has no store schema version.")
        if row[0] not in (SCHEMA_VERSION, *_OLDER_SCHEMAS):
            raise ValueError(
                f"{str(self.path)!r} has store schema {row[0]}, this library reads "
                f"{SCHEMA_VERSION}; use the library version that wrote it."
            )
        self.schema = str(row[0])

    @contextmanager
    def _transaction(self) -> Iterator[None]:
        conn = self._conn
        if conn.in_transaction:
            # Left open by a Ctrl-C that landed between a BEGIN and its try (the write
            # it began never ran): without this, marking the run interrupted would fail.
            conn.execute("ROLLBACK")
        conn.execute("BEGIN IMMEDIATE")
        try:
            yield
        except BaseException:
            conn.execute("ROLLBACK")
            raise
        conn.execute("COMMIT")

    # -- reading ------------------------------------------------------------------

    def statuses(self, keys: Iterable[str]) -> dict[str, str]:
        """``status`` of each of ``keys`` present in the store."""
        keys = list(keys)
        out: dict[str, str] = {}
        with _translated(self.path):
            for i in range(0, len(keys), _BATCH):
                part = keys[i : i + _BATCH]
                marks = ",".join("?" * len(part))
                q = f"SELECT key, status FROM cells WHERE key IN ({marks})"
                out.update(dict(self._conn.execute(q, part).fetchall()))
        return out

    def rows(self, table: str, keys: Iterable[str]) -> list[dict[str, Any]]:
        """The rows of ``table`` ("cells" or "trajectories") whose key is in ``keys``,
        as dicts (in no particular order)."""
        if table not in ("cells", "trajectories"):
            raise ValueError(f"`table` must be 'cells' or 'trajectories', got {table!r}.")
        column = "key" if table == "cells" else "traj_key"
        keys = list(keys)
        out: list[dict[str, Any]] = []
        with _translated(self.path):
            for i in range(0, len(keys), _BATCH):
                part = keys[i : i + _BATCH]
                marks = ",".join("?" * len(part))
                cur = self._conn.execute(f"SELECT * FROM {table} WHERE {column} IN ({marks})", part)
                names = [d[0] for d in cur.description]
                out.extend(dict(zip(names, r, strict=True)) for r in cur.fetchall())
        if table == "cells" and self.schema != SCHEMA_VERSION:
            out = [_generic_row(r) for r in out]  # an older store, read as it is
        return out

    def count(self, table: str = "cells") -> int:
        """Number of rows of ``table`` ("cells", "trajectories", "runs" or "claims")."""
        if table not in (*_TABLES, "claims"):
            raise ValueError(
                f"unknown `table` {table!r}; valid: cells, trajectories, runs, claims."
            )
        with _translated(self.path):
            return int(self._conn.execute(f"SELECT COUNT(*) FROM {table}").fetchone()[0])

    def connection(self) -> sqlite3.Connection:
        """The underlying connection (for reading, e.g. with pandas)."""
        return self._conn

    # -- writing (client only) ----------------------------------------------------

    def start_run(self, *, backend: str, planned: int, skipped: int, config: Any) -> str:
        """Record a new run; returns its id."""
        from ..._version import __version__

        run_id = uuid.uuid4().hex
        now = time.time()
        row = {
            "run_id": run_id,
            "started_at": now,
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
            "heartbeat": now,
            "elsewhere": 0,
            "duplicates": 0,
        }
        with _translated(self.path), self._transaction():
            self._insert("runs", row, conflict="ABORT")
        return run_id

    def heartbeat(self, run_id: str) -> None:
        """Tell other runs that ``run_id`` is alive (its claims hold)."""
        with _translated(self.path), self._transaction():
            self._conn.execute(
                "UPDATE runs SET heartbeat = ? WHERE run_id = ?", (time.time(), run_id)
            )

    def finish_run(
        self,
        run_id: str,
        status: str,
        *,
        skipped: int | None = None,
        elsewhere: int = 0,
        duplicates: int = 0,
    ) -> None:
        """Mark a run "complete", "interrupted" or "failed", with its counts, and
        release its claims.

        The run's ``computed`` and ``failed`` counts are those of the cells stored under
        its id, counted here in the same transaction: a run stopped (SIGTERM, Ctrl-C)
        after a write committed but before its caller counted the rows still reports
        every cell it stored.
        """
        with _translated(self.path), self._transaction():
            computed, failed = self._conn.execute(
                "SELECT COUNT(*), COALESCE(SUM(status <> 'ok'), 0) FROM cells WHERE run_id = ?",
                (run_id,),
            ).fetchone()
            self._conn.execute(
                "UPDATE runs SET finished_at = ?, status = ?, computed = ?, failed = ?, "
                "skipped = COALESCE(?, skipped), elsewhere = ?, duplicates = ? WHERE run_id = ?",
                (time.time(), status, computed, failed, skipped, elsewhere, duplicates, run_id),
            )
            self._conn.execute("DELETE FROM claims WHERE run_id = ?", (run_id,))

    def forget_run(self, run_id: str) -> None:
        """Delete the record and claims of a run that computed nothing."""
        with _translated(self.path), self._transaction():
            self._conn.execute("DELETE FROM claims WHERE run_id = ?", (run_id,))
            self._conn.execute(
                "DELETE FROM runs WHERE run_id = ? AND NOT EXISTS "
                "(SELECT 1 FROM cells WHERE cells.run_id = runs.run_id)",
                (run_id,),
            )

    def _alive(self, run_id: str, lease: float, now: float) -> bool:
        row = self._conn.execute(
            "SELECT status, host, pid, heartbeat, started_at FROM runs WHERE run_id = ?", (run_id,)
        ).fetchone()
        if row is None or row[0] != "running":
            return False
        status, host, pid, beat, started = row
        if host == socket.gethostname() and pid is not None and not _process_alive(int(pid)):
            return False
        return now - float(beat if beat is not None else started) <= lease

    def claim(
        self, run_id: str, keys: Sequence[str], *, retry_failed: bool = False, lease: float = 60.0
    ) -> Claim:
        """Claim for ``run_id`` the cells of ``keys`` that are neither stored nor being
        computed by another live run, in one transaction (so two runs never claim the
        same cell). Claims of dead runs (process gone on this host, or no heartbeat for
        ``lease`` seconds) are taken over and those runs marked "abandoned"."""
        now = time.time()
        with _translated(self.path), self._transaction():
            stored: dict[str, str] = {}
            owners: dict[str, str] = {}
            for i in range(0, len(keys), _BATCH):
                part = list(keys[i : i + _BATCH])
                marks = ",".join("?" * len(part))
                stored.update(
                    self._conn.execute(
                        f"SELECT key, status FROM cells WHERE key IN ({marks})", part
                    ).fetchall()
                )
                owners.update(
                    self._conn.execute(
                        f"SELECT key, run_id FROM claims WHERE key IN ({marks})", part
                    ).fetchall()
                )
            todo = [k for k in keys if k not in stored or (retry_failed and stored[k] != "ok")]
            alive = {r: self._alive(r, lease, now) for r in set(owners.values()) - {run_id}}
            dead = [r for r, ok in alive.items() if not ok]
            for r in dead:
                self._conn.execute("DELETE FROM claims WHERE run_id = ?", (r,))
                self._conn.execute(
                    "UPDATE runs SET status = 'abandoned' WHERE run_id = ? AND status = 'running'",
                    (r,),
                )
            mine = [k for k in todo if k not in owners or not alive.get(owners[k], False)]
            self._conn.executemany(
                "INSERT OR REPLACE INTO claims (key, run_id, claimed_at) VALUES (?, ?, ?)",
                [(k, run_id, now) for k in mine],
            )
            self._conn.execute("UPDATE runs SET heartbeat = ? WHERE run_id = ?", (now, run_id))
        return Claim(tuple(mine), len(keys) - len(todo), len(todo) - len(mine))

    def write(
        self,
        cells: Sequence[dict[str, Any]],
        trajectories: Sequence[dict[str, Any]] = (),
    ) -> int:
        """Insert rows in one transaction and release their claims. A cell whose key is
        already stored with status "ok" is left as it is; an "error" row is replaced.

        Returns
        -------
        int
            Cells written (the others were stored "ok" already, by another run).
        """
        common = [n for n, _ in CELL_COLUMNS]
        names = common + list(dict.fromkeys(k for c in cells for k in c if k not in common))
        cols = ", ".join(f'"{n}"' for n in names)
        updates = ", ".join(f'"{n}" = excluded."{n}"' for n in names[1:])
        cell_sql = (
            f"INSERT INTO cells ({cols}) VALUES ({','.join('?' * len(names))}) "
            f"ON CONFLICT(key) DO UPDATE SET {updates} WHERE cells.status <> 'ok'"
        )
        with _translated(self.path), self._transaction():
            for t in trajectories:
                self._insert("trajectories", t, conflict="IGNORE")
            cur = self._conn.executemany(cell_sql, [tuple(c.get(n) for n in names) for c in cells])
            written = max(cur.rowcount, 0)
            run_ids = {c.get("run_id") for c in cells}
            self._conn.executemany(
                "DELETE FROM claims WHERE key = ? AND run_id = ?",
                [(c["key"], c.get("run_id")) for c in cells],
            )
            for r in run_ids:
                self._conn.execute(
                    "UPDATE runs SET heartbeat = ? WHERE run_id = ?", (time.time(), r)
                )
        return written

    def _insert(self, table: str, row: dict[str, Any], conflict: str) -> None:
        cols = ", ".join(f'"{k}"' for k in row)
        marks = ",".join("?" * len(row))
        self._conn.execute(
            f"INSERT OR {conflict} INTO {table} ({cols}) VALUES ({marks})", tuple(row.values())
        )

    def discard_if_unused(self) -> bool:
        """Close and delete the file if this object created it, it holds no cell and no
        run is running on it (so a failed run leaves no empty store behind). Returns
        True if deleted."""
        if not self.created:
            return False
        try:
            with _translated(self.path):
                running = self._conn.execute(
                    "SELECT COUNT(*) FROM runs WHERE status = 'running'"
                ).fetchone()[0]
            used = self.count("cells") + running > 0
        except OSError:
            used = False
        if used:
            return False
        self.close()
        _remove_store_files(self.path)
        return True

    def close(self) -> None:
        """Close the store's connection (a ``with`` block does it on exit)."""
        self._conn.close()

    def __enter__(self) -> ResultStore:
        return self

    def __exit__(self, *_: Any) -> None:
        self.close()


def _kind_of(name: str, path: Path) -> Any:
    """The registered cell kind of the rows of a store (refusing an unknown one)."""
    from ._cells import get_cell_kind

    try:
        return get_cell_kind(name)
    except ValueError as exc:
        raise ValueError(
            f"{str(path)!r} holds cells of kind {name!r}, which this process does not know "
            f"({exc}); register the kind (register_cell_kind) before writing to the store, or "
            "read it read-only (sampledyn results); it was left untouched."
        ) from exc


def _generic_row(row: dict[str, Any]) -> dict[str, Any]:
    """A cell row of a schema-2 store in the generic layout: ``norm`` as ``measure``,
    a NULL kind as "prediction", the JSON ``result`` as value columns."""
    out = {k: v for k, v in row.items() if k not in ("norm", "result")}
    out["measure"] = row.get("norm")
    out["kind"] = row.get("kind") or "prediction"
    text = row.get("result")
    if isinstance(text, str) and text:
        out.update(parse_json(text, "a schema-2 store's result column"))
    return out


def load_results(
    path: str | os.PathLike[str],
    table: str = "cells",
    *,
    kind: str | None = None,
    status: str | None = None,
) -> Any:
    """The rows of a results store as a pandas DataFrame (see :func:`sampledyn.results.load`).

    The store is opened read-only: it may sit on read-only media or be written by a
    running sweep meanwhile. ``table="cells"``: every cell, generic (the common
    columns, ``measure``, and the value columns of every kind, NaN/None where a row's
    kind has no such value); with ``kind``, the view of that kind: its cells only,
    the common columns, the measure under the kind's name for it (``norm``,
    ``horizon``) and the kind's own values. A store of an older schema is read as it
    is, in the same layout.
    """
    import pandas as pd

    if table not in _TABLES:
        raise ValueError(f"unknown `table` {table!r}; valid: {', '.join(_TABLES)}.")
    if status not in (None, "ok", "error"):
        raise ValueError(f"`status` must be None, 'ok' or 'error', got {status!r}.")
    if (status is not None or kind is not None) and table != "cells":
        raise ValueError("`status` and `kind` select from the 'cells' table only.")
    cell_kind = None if kind is None else _kind_of(kind, Path(path))
    with ResultStore(path, readonly=True) as store:
        query = f"SELECT * FROM {table}"
        params: tuple[Any, ...] = ()
        if status is not None:
            query += " WHERE status = ?"
            params = (status,)
        with _translated(store.path):
            df = pd.read_sql_query(query + " ORDER BY rowid", store.connection(), params=params)
        schema = store.schema
    for col in ("computed_at", "started_at", "finished_at", "heartbeat"):
        if col in df.columns:
            df[col] = pd.to_datetime(df[col], unit="s", utc=True)
    if table == "cells" and schema != SCHEMA_VERSION:
        df = _generic_frame(df)
    return df if cell_kind is None else _kind_view(df, cell_kind)


def _kind_view(df: Any, kind: Any) -> Any:
    """The rows of ``kind`` as its view of the store shows them."""
    rows = df[df["kind"] == kind.name]
    common = [n for n, _t in CELL_COLUMNS if n in rows.columns]
    values = [n for n, _t in kind.columns if n not in common]
    view = rows[common + [n for n in values if n in rows.columns]].copy()
    for name, typ in kind.columns:
        if name not in view.columns:
            view[name] = None
        elif typ is bool:
            view[name] = [None if v is None or v != v else bool(v) for v in view[name]]
    return view.rename(columns={"measure": kind.measure_name}).reset_index(drop=True)


def _generic_frame(df: Any) -> Any:
    """The cells of a schema-2 store in the generic layout (see :func:`_generic_row`)."""
    import pandas as pd

    df = df.rename(columns={"norm": "measure"})
    if "kind" in df.columns:
        df["kind"] = df["kind"].fillna("prediction")
    else:
        df["kind"] = "prediction"
    if "result" not in df.columns:
        return df
    parsed = [parse_json(t, "a schema-2 store's result column") if isinstance(t, str) and t else {}
              for t in df["result"]]  # fmt: skip
    df = df.drop(columns="result")
    names = [n for n in dict.fromkeys(k for r in parsed for k in r) if n not in df.columns]
    if names:
        extra = pd.DataFrame([{n: r.get(n) for n in names} for r in parsed], index=df.index)
        df = pd.concat([df, extra], axis=1)
    return df
