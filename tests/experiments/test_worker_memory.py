"""Sweep workers keep the memory they free (retain_freed_memory)."""

from __future__ import annotations

import pytest
from _processes import run_python


@pytest.mark.slow
def test_workers_keep_freed_memory():
    """A worker allocates and frees arrays of one size over and over (noise, predictions,
    errors of each cell). glibc maps each afresh (4 MB is above its mmap threshold,
    which it raises only to the size freed) and faults every page in again; after
    retain_freed_memory they come from the heap and are reused."""
    code = """
        import json, resource, sys
        import numpy as np
        from sampledyn.experiments.sweep._backends import retain_freed_memory
        ok = retain_freed_memory() if sys.argv[-1] == "retain" else None

        def faults():
            f0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
            for _ in range(20):
                a = np.ones(500_000)  # 4 MB
                b = a + 1.0
                del a, b
            return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0

        faults()
        print(json.dumps({"ok": ok, "faults": faults()}))
    """
    plain = run_python(code)
    kept = run_python(code.replace('sys.argv[-1] == "retain"', "True"))
    assert kept["ok"] is True
    assert plain["faults"] > 10_000 > 20 * kept["faults"], (plain, kept)
