"""Real vehicle logs: read and validate a CSV/Parquet log, a ROS bag, an ArduSub
DataFlash log, a MAVLink telemetry log (.tlog) or a BlueOS MCAP log (time as logged,
dropped records, units, frames, NaN, angle wrap-around, the autopilot's own state)
and measure the local errors of sampled-data models on it. The formats are one
table, :data:`LOG_FORMATS`."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

# Public name -> defining module. They load on first use, so that the command line can
# build its parser (which names GAP_POLICIES and TIME_TOLERANCE) before the numerical
# kernels load.
_EXPORTS: dict[str, str] = {
    "CONVERSIONS": "._units",
    "GAP_POLICIES": "._time",
    "LOG_FORMATS": "._formats",
    "LogFormat": "._formats",
    "detect_format": "._formats",
    "model_for_mapping": "._mapping",
    "t200_deadband": "._t200",
    "NAN_POLICIES": "._read",
    "T200_VOLTAGES": "._t200",
    "TIME_TOLERANCE": "._read",
    "Clock": "._time",
    "LogData": "._read",
    "LogEvaluation": "._evaluate",
    "LogFormatError": "._units",
    "MAX_H_RATE": "._evaluate",
    "Sampling": "._time",
    "evaluate_log": "._evaluate",
    "estimate_log_noise": "._evaluate",
    "ROW_KEYS": "._evaluate",
    "log_from_frame": "._read",
    "read_clock": "._time",
    "read_log": "._open",
    "survey_input": "._synthetic",
    "synthetic_log": "._synthetic",
    "t200_rpm": "._t200",
    "write_synthetic_log": "._synthetic",
}

__all__ = sorted(_EXPORTS)

if TYPE_CHECKING:
    from ._evaluate import MAX_H_RATE as MAX_H_RATE
    from ._evaluate import ROW_KEYS as ROW_KEYS
    from ._evaluate import LogEvaluation as LogEvaluation
    from ._evaluate import estimate_log_noise as estimate_log_noise
    from ._evaluate import evaluate_log as evaluate_log
    from ._formats import LOG_FORMATS as LOG_FORMATS
    from ._formats import LogFormat as LogFormat
    from ._formats import detect_format as detect_format
    from ._mapping import model_for_mapping as model_for_mapping
    from ._open import read_log as read_log
    from ._read import NAN_POLICIES as NAN_POLICIES
    from ._read import TIME_TOLERANCE as TIME_TOLERANCE
    from ._read import LogData as LogData
    from ._read import log_from_frame as log_from_frame
    from ._synthetic import survey_input as survey_input
    from ._synthetic import synthetic_log as synthetic_log
    from ._synthetic import write_synthetic_log as write_synthetic_log
    from ._t200 import T200_VOLTAGES as T200_VOLTAGES
    from ._t200 import t200_deadband as t200_deadband
    from ._t200 import t200_rpm as t200_rpm
    from ._time import GAP_POLICIES as GAP_POLICIES
    from ._time import Clock as Clock
    from ._time import Sampling as Sampling
    from ._time import read_clock as read_clock
    from ._units import CONVERSIONS as CONVERSIONS
    from ._units import LogFormatError as LogFormatError


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'sampledyn.logs' has no attribute {name!r}")
    value = getattr(importlib.import_module(_EXPORTS[name], __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_EXPORTS})
