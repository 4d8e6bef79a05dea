"""Read a results store written by ``sampledyn sweep`` (see ``docs/sweeps.md``).

>>> import sampledyn as sd
>>> df = sd.results.load("results.db")                       # doctest: +SKIP
>>> df.groupby(["h", "eta_pct", "v_pct", "method"])["err_eta"].mean()   # doctest: +SKIP
"""

from __future__ import annotations

import os
from typing import Any

from .experiments.sweep import NotAStoreError, ResultStore, load_results

__all__ = ["NotAStoreError", "ResultStore", "load"]


def load(path: str | os.PathLike[str], table: str = "cells", *, status: str | None = None) -> Any:
    """The rows of a results store as a pandas DataFrame.

    The store is opened read-only (SQLite ``mode=ro``, or ``immutable`` on read-only
    media): reading never changes it, and works while a sweep writes to it.

    Parameters
    ----------
    path : str or path
        The SQLite file.
    table : {"cells", "trajectories", "runs"}
        "cells": one row per cell (configuration columns, ``err_eta``, ``err_v``,
        ``err_all``, ``status``, ``run_id``, ``computed_at``, ``config`` as JSON,
        ``kind``, and one column per named result of the controller studies, e.g.
        ``depth_p95`` of ``reproduce closed-loop``...);
        "trajectories": the exact samples and their certificates; "runs": one row per
        sweep run (with what it computed, found stored, and left to other runs).
    status : {"ok", "error"}, optional
        Keep the cells of this status only.

    Returns
    -------
    pandas.DataFrame
        Time columns (``computed_at``, ``started_at``, ``finished_at``, ``heartbeat``)
        are UTC datetimes; rows are ordered as stored.

    Raises
    ------
    FileNotFoundError
        if there is no file at ``path``.
    NotAStoreError
        (a ``ValueError``) if the file is not a sampledyn results store.
    ValueError
        for an unknown ``table`` or ``status``.
    """
    return load_results(path, table, status=status)
