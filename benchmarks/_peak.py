"""Peak resident memory of one stretch of code, for the memory benchmarks' subprocesses.

``PeakMemory()`` resets the peak resident set (``VmHWM``, through
``/proc/self/clear_refs``) and notes the current one; ``growth()`` is the peak reached
since, in bytes. Where the reset is not possible (not Linux, or no permission) the
process's ``ru_maxrss`` is used, which can only overstate the growth by what the
process held at its peak before. The subprocesses run with this folder as their
working directory, so ``from _peak import PeakMemory`` finds this module.
"""

from __future__ import annotations

import resource


def _status(field: str) -> int:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(field):
                return int(line.split()[1]) * 1024
    raise KeyError(field)


def _max_rss() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


class PeakMemory:
    """The growth of the peak resident set from construction to :meth:`growth`."""

    def __init__(self) -> None:
        try:
            with open("/proc/self/clear_refs", "w") as fh:
                fh.write("5")  # reset the peak RSS (VmHWM) to the current RSS
            self.method = "VmHWM"
            self._before = _status("VmRSS:")
        except OSError:
            self.method = "ru_maxrss"
            self._before = max(_status("VmRSS:"), _max_rss())

    def growth(self) -> int:
        """Bytes the peak resident set grew by since construction."""
        peak = _status("VmHWM:") if self.method == "VmHWM" else _max_rss()
        return peak - self._before
