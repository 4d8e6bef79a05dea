"""The ``sampledyn`` command: parse, validate every option before work, call one
library function, print. Errors end with one line and an exit status per kind
(:data:`EXIT_STATUSES`).

Importing this package is light (standard library only), so the command can speak
before the numerical kernels load or compile.
"""

from ._main import build_parser as build_parser
from ._main import main as main
from ._status import EXIT_STATUSES as EXIT_STATUSES

__all__ = [
    "EXIT_STATUSES",
    "build_parser",
    "main",
]
