"""Read a results store written by ``sampledyn sweep`` (see ``docs/sweeps.md``).

>>> import sampledyn as sd
>>> df = sd.results.load("results.db")                       # doctest: +SKIP
>>> df.groupby(["h", "eta_pct", "v_pct", "method"])["err_eta"].mean()   # doctest: +SKIP
"""

from __future__ import annotations

import os
from typing import Any

from ._store import ResultStore

__all__ = ["load"]

_TABLES = ("cells", "trajectories", "runs")
_TIME_COLUMNS = ("computed_at", "started_at", "finished_at")


def load(path: str | os.PathLike[str], table: str = "cells", *, status: str | None = None) -> Any:
    """The rows of a results store as a pandas DataFrame.

    Parameters
    ----------
    path : str or path
        The SQLite file.
    table : {"cells", "trajectories", "runs"}
        "cells": one row per cell (configuration columns, ``err_eta``, ``err_v``,
        ``err_all``, ``status``, ``run_id``, ``computed_at``, ``config`` as JSON...);
        "trajectories": the exact samples and their certificates; "runs": one row per
        sweep run.
    status : {"ok", "error"}, optional
        Keep the cells of this status only.

    Returns
    -------
    pandas.DataFrame
        Time columns (``computed_at``, ``started_at``, ``finished_at``) are UTC
        datetimes; rows are ordered as stored.

    Raises
    ------
    FileNotFoundError
        if there is no file at ``path``.
    ValueError
        for an unknown ``table`` or ``status``, or a file that is not a store.
    """
    import pandas as pd

    if table not in _TABLES:
        raise ValueError(f"unknown `table` {table!r}; valid: {', '.join(_TABLES)}.")
    if status not in (None, "ok", "error"):
        raise ValueError(f"`status` must be None, 'ok' or 'error', got {status!r}.")
    with ResultStore(path, create=False) as store:
        query = f"SELECT * FROM {table}"
        params: tuple[Any, ...] = ()
        if status is not None:
            if table != "cells":
                raise ValueError("`status` filters the 'cells' table only.")
            query += " WHERE status = ?"
            params = (status,)
        df = pd.read_sql_query(query + " ORDER BY rowid", store.connection(), params=params)
    for col in _TIME_COLUMNS:
        if col in df.columns:
            df[col] = pd.to_datetime(df[col], unit="s", utc=True)
    return df
