"""The log formats sampledyn reads: one table of (name, detection, reader).

:func:`read_log` asks :func:`detect_format` which format a path is and calls its
reader; the command line, the docs and the tests iterate :data:`LOG_FORMATS`.
Detection looks at the content where the suffix is ambiguous: a DataFlash log starts
with the record header 0xA3 0x95; an MCAP file starts with its magic ``\\x89MCAP0\\r\\n``
and is a ROS 2 bag when its channels carry CDR messages, a BlueOS log when they carry
MAVLink JSON on ``mavlink/out``.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..exceptions import LogFormatError
from ..models import Model

__all__ = ["FORMATS_RECOGNISED", "LOG_FORMATS", "LogFormat", "detect_format"]

_MCAP_MAGIC = b"\x89MCAP0\r\n"
_DATAFLASH_MAGIC = b"\xa3\x95"


@dataclass(frozen=True)
class LogFormat:
    """One log format.

    Attributes
    ----------
    name : str
        Short name ("csv", "ros2", "tlog", ...).
    description : str
        What it is, for listings.
    detect : callable
        ``detect(path) -> bool``.
    reader : str
        "module:function" of the reader, ``reader(path, model, *, mapping, **options)
        -> LogData`` (imported when used, so that the optional extras load only then).
    extra : str or None
        The pip extra the reader needs (``pip install 'sampledyn[EXTRA]'``).
    """

    name: str
    description: str
    detect: Callable[[Path], bool]
    reader: str
    extra: str | None = None

    def read(self, path: Path, model: Model, **kwargs: Any) -> Any:
        """The log at ``path`` read by this format's reader for ``model`` (``kwargs``:
        the reader's options, as :func:`sampledyn.logs.read_log` takes them)."""
        module, function = self.reader.split(":")
        return getattr(importlib.import_module(module, __package__), function)(
            path, model, **kwargs
        )


def _head(path: Path, n: int) -> bytes:
    if not path.is_file():
        return b""
    with path.open("rb") as fh:
        return fh.read(n)


def _mcap_encodings(path: Path) -> set[tuple[str, str]]:
    """(topic, message encoding) of the channels of an MCAP file."""
    try:
        from mcap.reader import make_reader
    except ImportError:  # pragma: no cover - depends on the installation
        return set()
    with path.open("rb") as fh:
        try:
            summary = make_reader(fh).get_summary()
        except Exception:  # noqa: BLE001 - any unreadable summary: decided by the reader
            return set()
    if summary is None:
        return set()
    return {(c.topic, c.message_encoding) for c in summary.channels.values()}


def _is_mcap(path: Path) -> bool:
    return _head(path, 8) == _MCAP_MAGIC


def _is_blueos(path: Path) -> bool:
    return _is_mcap(path) and any(
        topic == "mavlink/out" and enc == "json" for topic, enc in _mcap_encodings(path)
    )


def _is_ros2(path: Path) -> bool:
    if path.is_dir():
        return (path / "metadata.yaml").is_file() or any(
            p.suffix in (".db3", ".mcap") for p in path.iterdir()
        )
    if path.suffix.lower() == ".db3":
        return True
    return _is_mcap(path) and not _is_blueos(path)


def _is_dataflash(path: Path) -> bool:
    return _head(path, 2) == _DATAFLASH_MAGIC


def _is_tlog(path: Path) -> bool:
    """A .tlog: records of an 8-byte big-endian time (us) then a MAVLink frame (0xFE
    v1, 0xFD v2)."""
    head = _head(path, 9)
    return path.suffix.lower() == ".tlog" or (len(head) == 9 and head[8] in (0xFE, 0xFD))


def _suffix(*suffixes: str) -> Callable[[Path], bool]:
    return lambda path: path.is_file() and path.suffix.lower() in suffixes


LOG_FORMATS: tuple[LogFormat, ...] = (
    LogFormat(
        "dataflash",
        "ArduPilot/ArduSub DataFlash log (.bin)",
        _is_dataflash,
        "._ardusub:read_dataflash",
        "ardusub",
    ),
    LogFormat(
        "ros2",
        "ROS 2 bag: a directory (metadata.yaml), a .db3, or an .mcap file alone",
        _is_ros2,
        "._ros:read_bag",
        "ros",
    ),
    LogFormat(
        "blueos",
        "BlueOS MCAP log (MAVLink as JSON on mavlink/out)",
        _is_blueos,
        "._mavlink:read_blueos",
        "blueos",
    ),
    LogFormat("ros1", "ROS 1 bag (.bag)", _suffix(".bag"), "._ros:read_bag", "ros"),
    LogFormat(
        "tlog",
        "MAVLink telemetry log of a ground station (QGroundControl, MAVProxy .tlog)",
        _is_tlog,
        "._mavlink:read_tlog",
        "ardusub",
    ),
    LogFormat(
        "parquet",
        "table, one row per sample (.parquet)",
        _suffix(".parquet", ".pq"),
        "._read:read_table_log",
        "parquet",
    ),  # fmt: skip
    LogFormat(
        "csv", "table, one row per sample (CSV)", lambda p: p.is_file(), "._read:read_table_log"
    ),
)


#: How :func:`detect_format` tells the formats apart, for the message of a file that is
#: none of them (in the order tried).
FORMATS_RECOGNISED = (
    "ArduSub DataFlash .bin (starts with the bytes 0xA3 0x95), ROS 2 bag (a folder with "
    "metadata.yaml or a .db3/.mcap, a .db3 file, or an MCAP file of CDR messages), "
    "BlueOS MCAP (MCAP magic 0x89 'MCAP0', MAVLink JSON on mavlink/out), ROS 1 bag "
    "(suffix .bag), MAVLink .tlog (suffix .tlog, or a MAVLink frame 0xFE/0xFD after an "
    "8-byte time), Parquet (suffix .parquet/.pq), CSV (any other file: UTF-8 text)"
)


def detect_format(path: Path) -> LogFormat:
    """The first format of :data:`LOG_FORMATS` whose detection accepts ``path``.

    Raises
    ------
    FileNotFoundError
        if nothing is at ``path``.
    LogFormatError
        for a directory that is no ROS 2 bag.
    """
    if not path.exists():
        raise FileNotFoundError(f"no log file {str(path)!r}.")
    for fmt in LOG_FORMATS:
        if fmt.detect(path):
            return fmt
    raise LogFormatError(
        "data",
        f"{str(path)!r} is a directory but no ROS 2 bag (no metadata.yaml, .db3 or .mcap); "
        "formats read: " + "; ".join(f.description for f in LOG_FORMATS) + ".",
    )
