"""The peer benchmark (benchmarks/bench_peers.py): its reference and its optional peers.

The benchmark judges every solver by a reference, so the reference itself is checked
here against an independent integrator; and it must run where the optional peers
(numbalsoda, jax/diffrax: the `bench` extra, not installed in CI) are missing.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

import sampledyn as sd

_PATH = Path(__file__).resolve().parents[2] / "benchmarks" / "bench_peers.py"


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("bench_peers", _PATH)
    module = importlib.util.module_from_spec(spec)
    sys.modules["bench_peers"] = module  # dataclasses look their module up
    sys.path.insert(0, str(_PATH.parent))  # its sibling `_rows`, as when run as a script
    try:
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(_PATH.parent))
    yield module
    sys.modules.pop("bench_peers", None)
    sys.modules.pop("_rows", None)


@pytest.fixture(scope="module")
def rexrov(bench):
    return bench.make_problem("rexrov")


def test_reference_matches_simulate_on_kink_intervals(bench, rexrov):
    """SciPy DOP853 split at kinks by terminal events vs sd.simulate at rtol 1e-13, on
    intervals where a velocity or an rpm changes sign, some with two kinks. Taking the
    state at a kink from the dense output of the step across it (instead of landing on
    the kink) makes this fail (2.2e-12; up to 5e-11 on the BlueROV2 hold run)."""
    pb = rexrov
    traj = sd.simulate(pb.model, pb.signal, T=30.0, h=bench.H, x0=pb.x0, rtol=1e-13, atol=1e-13)
    assert traj.certificate.max_error < 1e-13
    t = traj.t
    signs = np.sign(np.array([pb.switch(t[i], traj.x[i]) for i in range(t.size)]))
    changes = (signs[1:] != signs[:-1]).sum(axis=1)
    kink = bench.kink_intervals(pb, traj.x)
    np.testing.assert_array_equal(kink, changes > 0)
    double = np.flatnonzero(changes >= 2)
    assert double.size >= 2
    picks = np.unique(np.concatenate([np.flatnonzero(kink)[:12], double[:6]]))
    ref = bench.reference_states(pb, traj.x, picks)
    err = np.abs(traj.x[picks + 1] - ref) / traj.certificate.scale
    assert err.max() < 2e-13


def test_runs_and_reports_peers_that_cannot_import(bench, monkeypatch, capsys):
    """Without numbalsoda and jax the benchmark still runs (SciPy, sd.simulate), and
    says why each missing peer was skipped."""
    monkeypatch.setitem(sys.modules, "numbalsoda", None)  # import raises ImportError
    monkeypatch.setitem(sys.modules, "jax", None)
    argv = ["bench_peers.py", "--T", "3", "--T-calibrate", "2", "--checks", "6",
            "--repeat", "1", "--vehicles", "rexrov", "--only", "lsoda", "numbalsoda",
            "diffrax", "--markdown"]  # fmt: skip
    monkeypatch.setattr(sys, "argv", argv)
    bench.main()
    out = capsys.readouterr().out
    rows = {line.split(" | ")[0].lstrip("| "): line for line in out.splitlines() if "|" in line}
    assert "skipped: numbalsoda not importable" in rows["numbalsoda DOP853"]
    assert "skipped: numbalsoda not importable" in rows["numbalsoda DOP853 + kinks"]
    assert "skipped: jax/diffrax not importable" in rows["diffrax Dopri8 (JAX)"]
    lsoda = rows["scipy solve_ivp LSODA"].split(" | ")
    assert float(lsoda[3]) > 0 and lsoda[4].endswith("x")  # timed, with a ratio
    assert float(lsoda[5]) < 1e-6  # its measured per-interval error
    assert "scipy solve_ivp DOP853" not in rows  # --only
