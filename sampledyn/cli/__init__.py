"""The ``sampledyn`` command: parse, validate every option before work, call one
library function, print. Errors end with one line and an exit status per kind
(:data:`EXIT_STATUSES`).

Importing this package is light (standard library only), so the command can speak
before the numerical kernels load or compile.
"""

from ._main import build_parser as build_parser
from ._main import main as main
from ._status import EXIT_BAD_VALUE as EXIT_BAD_VALUE
from ._status import EXIT_DISK as EXIT_DISK
from ._status import EXIT_FILE as EXIT_FILE
from ._status import EXIT_INTERNAL as EXIT_INTERNAL
from ._status import EXIT_INTERRUPTED as EXIT_INTERRUPTED
from ._status import EXIT_NUMERICAL as EXIT_NUMERICAL
from ._status import EXIT_OK as EXIT_OK
from ._status import EXIT_PIPE as EXIT_PIPE
from ._status import EXIT_STATUSES as EXIT_STATUSES
from ._status import EXIT_TERMINATED as EXIT_TERMINATED
from ._status import EXIT_UNAVAILABLE as EXIT_UNAVAILABLE
from ._status import EXIT_USAGE as EXIT_USAGE

__all__ = [
    "EXIT_BAD_VALUE",
    "EXIT_DISK",
    "EXIT_FILE",
    "EXIT_INTERNAL",
    "EXIT_INTERRUPTED",
    "EXIT_NUMERICAL",
    "EXIT_OK",
    "EXIT_PIPE",
    "EXIT_STATUSES",
    "EXIT_TERMINATED",
    "EXIT_UNAVAILABLE",
    "EXIT_USAGE",
    "build_parser",
    "main",
]
