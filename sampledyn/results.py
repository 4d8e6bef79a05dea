"""Read a results store written by ``sampledyn sweep`` (see ``docs/sweeps.md``).

>>> import sampledyn as sd
>>> df = sd.results.load("results.db")                       # doctest: +SKIP
>>> df = sd.results.load("results.db", kind="prediction")      # doctest: +SKIP
>>> df.groupby(["h", "eta_pct", "v_pct", "method", "norm"])["err_eta"].mean()  # doctest: +SKIP
"""

from __future__ import annotations

import os
from typing import Any

from .experiments.sweep._store import ResultStore, load_results

__all__ = ["ResultStore", "load"]


def load(
    path: str | os.PathLike[str],
    table: str = "cells",
    *,
    kind: str | None = None,
    status: str | None = None,
) -> Any:
    """The rows of a results store as a pandas DataFrame.

    The store is opened read-only (SQLite ``mode=ro``, or ``immutable`` on read-only
    media): reading never changes it, and works while a sweep writes to it.

    Parameters
    ----------
    path : str or path
        The SQLite file.
    table : {"cells", "trajectories", "runs"}
        "cells": one generic row per cell: ``key``, ``kind``, the coordinates
        (vehicle, h, method, eta_pct, v_pct, seed, ``measure``, ...), ``status``,
        ``error``, ``run_id``, ``computed_at``, ``config`` as JSON, and the value
        columns of every kind (``err_eta``, ``err_v``, ``err_all`` of a prediction;
        ``depth_p95``, ``outcome``, ... of ``reproduce closed-loop``), NaN/None where a
        row's kind has no such value;
        "trajectories": the exact samples and their certificates; "runs": one row per
        sweep run (with what it computed, found stored, and left to other runs).
    kind : str, optional
        The view of one cell kind ("prediction", "closed_loop", "multistep"): its
        cells, the common columns, the measure under the kind's name for it
        (``norm``, ``horizon``) and its own values only.
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
    return load_results(path, table, kind=kind, status=status)
