"""Real vehicle logs: read and validate a CSV/Parquet log, a ROS bag or an ArduSub
DataFlash log (time as logged, dropped records, units, frames, NaN, angle
wrap-around) and measure the local errors of sampled-data models on it."""

from ._evaluate import LogEvaluation as LogEvaluation
from ._evaluate import evaluate_log as evaluate_log
from ._read import NAN_POLICIES as NAN_POLICIES
from ._read import TIME_TOLERANCE as TIME_TOLERANCE
from ._read import LogData as LogData
from ._read import log_from_frame as log_from_frame
from ._read import read_log as read_log
from ._synthetic import survey_input as survey_input
from ._synthetic import synthetic_log as synthetic_log
from ._synthetic import write_synthetic_log as write_synthetic_log
from ._t200 import T200_VOLTAGES as T200_VOLTAGES
from ._t200 import t200_rpm as t200_rpm
from ._time import GAP_POLICIES as GAP_POLICIES
from ._time import Clock as Clock
from ._time import Sampling as Sampling
from ._time import read_clock as read_clock
from ._units import CONVERSIONS as CONVERSIONS
from ._units import LogFormatError as LogFormatError

__all__ = [
    "CONVERSIONS",
    "GAP_POLICIES",
    "NAN_POLICIES",
    "T200_VOLTAGES",
    "TIME_TOLERANCE",
    "Clock",
    "LogData",
    "LogEvaluation",
    "LogFormatError",
    "Sampling",
    "evaluate_log",
    "log_from_frame",
    "read_clock",
    "read_log",
    "survey_input",
    "synthetic_log",
    "t200_rpm",
    "write_synthetic_log",
]
