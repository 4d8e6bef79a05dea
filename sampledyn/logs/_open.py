"""Open a log of any supported format: a table (CSV, Parquet), a ROS bag, or an ArduSub
DataFlash log; each reader turns it into the same validated :class:`LogData`."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from ._read import TIME_TOLERANCE, LogData, log_from_frame, read_table

__all__ = ["read_log"]


def read_log(
    path: str | os.PathLike[str],
    model: Any,
    *,
    mapping: Any = None,
    nan: str = "error",
    time_tolerance: float = TIME_TOLERANCE,
    unwrap: bool = True,
    gaps: str = "refuse",
    max_missing: int = 1,
) -> LogData:
    """Read a log of ``model`` and validate it (module docstring).

    Parameters
    ----------
    path : str or path
        A table: ``.csv`` (any other suffix is read as CSV too) or ``.parquet``/``.pq``;
        a ROS bag: a ROS 2 bag directory (``metadata.yaml``), a ``.db3``/``.mcap`` file,
        or a ROS 1 ``.bag`` (extra ``sampledyn[ros]``); an ArduSub DataFlash log
        ``.bin`` (extra ``sampledyn[ardusub]``). Bags and DataFlash logs need a
        ``mapping`` (see ``docs/logs.md``).
    model : Model
        The vehicle the log is of; its state and input names and units are expected.
    mapping : path or mapping, optional
        Column names and units for tables whose header does not follow ``name[unit]``;
        topics and frames for bags; messages and the servo-to-thruster curve for
        DataFlash logs.
    nan : {"error", "drop", "interpolate"}
    time_tolerance : float
        Largest accepted deviation of a time step from a whole number of periods, as a
        fraction of h (default 0.25); a step farther off is an error.
    unwrap : bool
        Unwrap angles (default True).
    gaps : {"refuse", "bridge", "split"}
        Dropped records (a step of m > 1 periods): refuse (default), bridge gaps of up
        to ``max_missing`` records (the samples keep their logged times), or split the
        log into segments evaluated on their own. Nothing is ever interpolated.
    max_missing : int
        Longest run of missing records ``gaps="bridge"`` accepts (default 1).

    Raises
    ------
    LogFormatError (a ValueError)
        naming the column, option or the first bad row.
    FileNotFoundError
        if there is no file at ``path``.
    """
    path = Path(path)
    options: dict[str, Any] = {
        "nan": nan,
        "time_tolerance": time_tolerance,
        "unwrap": unwrap,
        "gaps": gaps,
        "max_missing": max_missing,
    }
    if path.is_dir() or path.suffix.lower() in (".bag", ".db3", ".mcap"):
        from ._ros import read_bag

        return read_bag(path, model, mapping=mapping, **options)
    if not path.is_file():
        raise FileNotFoundError(f"no log file {str(path)!r}.")
    if path.suffix.lower() in (".bin", ".log") and _is_dataflash(path):
        from ._ardusub import read_dataflash

        return read_dataflash(path, model, mapping=mapping, **options)
    frame, csv = read_table(path, model, mapping)
    return log_from_frame(frame, model, source=path.name, mapping=mapping, csv=csv, **options)


def _is_dataflash(path: Path) -> bool:
    """A binary DataFlash log starts with a message header 0xA3 0x95."""
    with path.open("rb") as fh:
        return fh.read(2) == b"\xa3\x95"
