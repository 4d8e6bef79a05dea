"""``python -m sampledyn.cli``: the ``sampledyn`` command."""

import sys

from . import main

sys.exit(main())
