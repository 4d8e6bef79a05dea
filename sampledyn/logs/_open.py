"""Open a log of any supported format: a table (CSV, Parquet), a ROS bag, or an ArduSub
DataFlash log; each reader turns it into the same validated :class:`LogData`."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from .._files import regular_file
from ..models import Model
from ._formats import detect_format
from ._read import TIME_TOLERANCE, LogData

__all__ = ["read_log"]


def read_log(
    path: str | os.PathLike[str],
    model: Model,
    *,
    mapping: Any = None,
    nan: str = "error",
    time_tolerance: float = TIME_TOLERANCE,
    unwrap: bool = True,
    gaps: str = "refuse",
    max_missing: int = 1,
    irregular: bool = False,
) -> LogData:
    """Read a log of ``model`` and validate it (module docstring).

    Parameters
    ----------
    path : str or path
        Any format of :data:`sampledyn.logs.LOG_FORMATS` (detected from the content
        where the suffix is ambiguous): a table (``.csv``, any other suffix is read as
        CSV too, or ``.parquet``/``.pq``); a ROS 2 bag (its directory, a ``.db3``, or
        an ``.mcap`` file with or without ``metadata.yaml``) or a ROS 1 ``.bag``
        (extra ``sampledyn[ros]``); an ArduSub DataFlash log or a MAVLink ``.tlog``
        (extra ``sampledyn[ardusub]``); a BlueOS MCAP log (extra
        ``sampledyn[blueos]``). Bags need a ``mapping`` (``docs/logs.md``); the
        ArduSub logs are read with their mapping's defaults without one (a note says
        so). Bytes of none of these formats are refused naming how each is
        recognised (:data:`sampledyn.logs._formats.FORMATS_RECOGNISED`).
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
    irregular : bool
        Accept a log whose steps are no whole numbers of one period (default False:
        refused): the rules predict on the logged stamps as they are.

    Raises
    ------
    LogFormatError (a ValueError)
        naming the column, option or the first bad row.
    FileNotFoundError, IsADirectoryError
        if there is no file at ``path``, or ``mapping`` names no file or a folder.
    OSError
        (errno EINVAL) for a FIFO, a device or a socket.
    """
    path = Path(path)
    options: dict[str, Any] = {
        "nan": nan,
        "time_tolerance": time_tolerance,
        "unwrap": unwrap,
        "gaps": gaps,
        "max_missing": max_missing,
        "irregular": irregular,
    }
    # A FIFO or a device would block or never end in the format detection or a reader;
    # a folder is a bag. No size limit: logs are read in chunks.
    regular_file(path, "log", folder_ok=True)
    fmt = detect_format(path)
    return fmt.read(path, model, mapping=mapping, **options)
