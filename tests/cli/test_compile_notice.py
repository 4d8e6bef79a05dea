"""A first run says that it compiles, on any stream (issue 23): the notice is printed
when numba starts compiling, once, and not when the kernels load from the cache."""

from __future__ import annotations

import io
import os
import subprocess
import sys
import time

import numpy as np
import pytest
from numba import njit

from sampledyn.cli._main import compile_notice


def test_the_notice_comes_once_when_numba_compiles_and_not_after_it_stops():
    stream = io.StringIO()
    stop = compile_notice("sweep", stream)
    try:
        assert stream.getvalue() == ""  # listening compiles nothing

        @njit(cache=False)
        def first(x):
            return x + 1.0

        @njit(cache=False)
        def second(x):
            return x * 2.0

        first(np.float64(1.0))
        second(np.float64(1.0))
    finally:
        stop()
    lines = stream.getvalue().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("sampledyn sweep: compiling the numerical kernels")

    @njit(cache=False)
    def third(x):
        return x - 1.0

    third(np.float64(1.0))
    assert len(stream.getvalue().splitlines()) == 1  # stopped listening


@pytest.mark.slow
def test_a_first_run_into_a_pipe_says_it_is_compiling_before_its_output(tmp_path):
    """stderr a pipe, empty kernel caches: the notice is the first line, long before
    the command's own output (which the compilation delays)."""
    env = dict(os.environ, SAMPLEDYN_CACHE_DIR=str(tmp_path / "k"),
               NUMBA_CACHE_DIR=str(tmp_path / "numba"))  # fmt: skip
    t0 = time.monotonic()
    proc = subprocess.Popen(
        [sys.executable, "-m", "sampledyn.cli", "reproduce", "fig2", "--out", str(tmp_path / "o"),
         "--no-progress"],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env,
    )  # fmt: skip
    try:
        first = proc.stderr.readline()
        said = time.monotonic() - t0
        rest = proc.stderr.read()
        assert proc.wait(timeout=600) == 0, rest
    finally:
        proc.kill()
    done = time.monotonic() - t0
    assert "compiling the numerical kernels" in first, first + rest
    assert "compiling" not in rest  # once
    assert said < done / 2  # said while compiling, not at the end
