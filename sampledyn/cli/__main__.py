"""``python -m sampledyn.cli``: the ``sampledyn`` command."""

from ._main import console

console()
