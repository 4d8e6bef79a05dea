"""Real vehicle logs: read and validate a CSV/Parquet log, a ROS bag, an ArduSub
DataFlash log, a MAVLink telemetry log (.tlog) or a BlueOS MCAP log (time as logged,
dropped records, units, frames, NaN, angle wrap-around, the autopilot's own state)
and measure the local errors of sampled-data models on it. The formats are one
table, :data:`LOG_FORMATS`."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

# Public name -> defining module. They load on first use, so that importing the
# package does not load the numerical kernels.
_EXPORTS: dict[str, str] = {
    "CONVERSIONS": "._units",
    "LOG_FORMATS": "._formats",
    "LogFormat": "._formats",
    "detect_format": "._formats",
    "LogData": "._read",
    "Sampling": "._time",
    "evaluate_log": "._evaluate",
    "log_from_frame": "._read",
    "read_log": "._open",
    "synthetic_log": "._synthetic",
    "write_synthetic_log": "._synthetic",
}

__all__ = sorted(_EXPORTS)

if TYPE_CHECKING:
    from ._evaluate import evaluate_log as evaluate_log
    from ._formats import LOG_FORMATS as LOG_FORMATS
    from ._formats import LogFormat as LogFormat
    from ._formats import detect_format as detect_format
    from ._open import read_log as read_log
    from ._read import LogData as LogData
    from ._read import log_from_frame as log_from_frame
    from ._synthetic import synthetic_log as synthetic_log
    from ._synthetic import write_synthetic_log as write_synthetic_log
    from ._time import Sampling as Sampling
    from ._units import CONVERSIONS as CONVERSIONS


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'sampledyn.logs' has no attribute {name!r}")
    value = getattr(importlib.import_module(_EXPORTS[name], __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_EXPORTS})
