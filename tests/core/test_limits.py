"""Work and memory are bounded before they start (issue 24, item 4): what allocates
by T / h, an input's levels or an order estimates first and refuses beyond a stated
limit, naming the argument, the estimate and the limit; the limit can be raised."""

from __future__ import annotations

import time
import tracemalloc
from fractions import Fraction

import numpy as np
import pytest
from _faults import error_lines

import sampledyn as sd
from sampledyn import _checks as _limits
from sampledyn.exceptions import WorkLimitError
from sampledyn.methods import get_method
from sampledyn.methods._adams import ab_coefficients
from sampledyn.signals import Multilevel


@pytest.fixture(scope="module")
def auv():
    model = sd.models.AUVLike()
    return model, Multilevel(hold=0.1, seed=3)


@pytest.mark.parametrize(
    "T, h, said",
    [
        (1.0, 1e-9, "T / h = 1 s / 1e-09 s = 1e+09 samples"),
        (1e12, 0.1, "1e+13 samples"),
        (1e300, 1e-6, "more than any machine holds"),
        (1e6, 1e-3, "1e+09 samples"),
    ],
)
def test_simulate_refuses_a_run_beyond_the_memory_limit_before_allocating(auv, T, h, said):
    model, signal = auv
    tracemalloc.start()
    t0 = time.monotonic()
    with pytest.raises(WorkLimitError) as info:
        sd.simulate(model, signal, T, h)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert time.monotonic() - t0 < 5 and peak < 50e6  # refused, not attempted
    text = str(info.value)
    assert said in text and "above the limit of 4 GiB" in text
    assert "--max-memory" in text and "SAMPLEDYN_MAX_MEMORY" in text


@pytest.mark.parametrize("h", [5e-324, 4.9e-323, 1e-12, 9.9e-10])
def test_h_below_the_floor_is_refused_naming_the_floor(auv, h):
    model, signal = auv
    with pytest.raises(WorkLimitError, match=r"below the smallest sampling period 1e-09 s"):
        sd.simulate(model, signal, 1.0, h)


def test_the_limit_is_stated_and_can_be_raised(auv, monkeypatch):
    model, signal = auv
    n = 2001  # T = 2 s at h = 1 ms
    need = _limits.trajectory_bytes(n, model.nx, model.nu)
    with sd.memory_limit(need / 2), pytest.raises(WorkLimitError, match="above the limit"):
        sd.simulate(model, signal, 2.0, 1e-3)
    with sd.memory_limit("1G"):
        traj = sd.simulate(model, signal, 2.0, 1e-3)
    assert traj.n_samples == n
    monkeypatch.setenv(_limits.MEMORY_ENV, str(int(need / 2)))
    with pytest.raises(WorkLimitError, match="above the limit"):
        sd.simulate(model, signal, 2.0, 1e-3)


def test_the_estimate_covers_what_simulate_allocates(auv):
    """The estimate is an upper bound of the peak (measured by tracemalloc, which
    sees numpy's allocations), and not loose by more than a few times."""
    model, signal = auv
    sd.simulate(model, signal, 1.0, 1e-3)  # compiled and cached first
    n = 200_001
    tracemalloc.start()
    sd.simulate(model, signal, 200.0, 1e-3)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    estimate = _limits.trajectory_bytes(n, model.nx, model.nu)
    assert peak <= estimate <= 4 * peak


def test_an_inputs_levels_are_bounded_too():
    signal = Multilevel(hold=1e-9, seed=0)
    with pytest.raises(WorkLimitError, match=r"`hold` = 1e-09 s up to t = .*levels"):
        signal(np.array([0.0, 200.0]))


@pytest.mark.parametrize("size, limit", [("16G", 16 << 30), ("500M", 500 << 20), ("4096", 4096)])
def test_sizes_parse_with_binary_units(size, limit):
    assert _limits.parse_bytes(size) == limit


@pytest.mark.parametrize("size", ["", "-1G", "nan", "lots", "0"])
def test_a_bad_size_is_refused(size):
    with pytest.raises(ValueError, match="size"):
        _limits.parse_bytes(size)


def test_the_largest_adams_bashforth_order_is_where_its_reason_says():
    """MAX_AB_ORDER is the last s with a_s = sum |a_i| below 2^26 (the stated reason)."""
    s = _limits.MAX_AB_ORDER

    def a_s(k: int) -> Fraction:
        return sum((abs(a) for a in ab_coefficients(k)), Fraction(0))

    assert a_s(s) < 2**26
    with pytest.raises(WorkLimitError):
        ab_coefficients(s + 1)
    # ... where it would have been: the same recursion, unbounded, past the limit.
    from sampledyn.methods._adams import _gammas

    g = _gammas(s + 1)
    from math import comb

    beyond = [(-1) ** i * sum((comb(j, i) * g[j] for j in range(i, s + 1)), Fraction(0))
              for i in range(s + 1)]  # fmt: skip
    assert sum((abs(a) for a in beyond), Fraction(0)) > 2**26


@pytest.mark.parametrize("name", ["AB2000", "ABu100", "ABj29", "ABe40", "AB" + "9" * 5000])
def test_orders_beyond_the_bound_are_refused_at_once(name):
    t0 = time.monotonic()
    with pytest.raises(ValueError, match=r"1\.\.28|digits") as info:
        get_method(name).coefficients  # noqa: B018 - the audit's case
    assert time.monotonic() - t0 < 1
    assert "2^26" in str(info.value) or "digits" in str(info.value)


def test_workers_are_capped_at_two_per_core_with_a_note():
    cores = len(__import__("os").sched_getaffinity(0))
    assert _limits.worker_count(1) == (1, None)
    count, note = _limits.worker_count(200)
    assert count == 2 * cores and note is not None and "200 capped" in note
    with pytest.raises(ValueError, match="`workers` must be an int >= 1, got 0"):
        _limits.worker_count(0)


def test_newton_iterations_are_bounded_with_the_reason(tmp_path, capsys):
    """Tustin's max_iter (--newton-max-iter) beyond MAX_NEWTON_ITER is refused before any
    work, naming the argument, the value and the bound; the bound itself is accepted."""
    from sampledyn.cli import main
    from sampledyn.exceptions import ArgumentError
    from sampledyn.logs import write_synthetic_log

    bound = _limits.MAX_NEWTON_ITER
    assert sd.methods.Tustin(max_iter=bound).max_iter == bound
    with pytest.raises(ArgumentError, match=rf"`max_iter` = {bound + 1} .* more than {bound}"):
        sd.methods.Tustin(max_iter=bound + 1)
    with pytest.raises(ArgumentError, match="max_iter"):
        sd.methods.Tustin().with_newton(max_iter=10**12)
    log = write_synthetic_log(tmp_path / "log.csv", T=2.0, eta_pct=1.0, v_pct=1.0)
    args = ["evaluate", "--data", str(log), "--vehicle", "bluerov2_heavy", "--methods", "T"]
    with pytest.raises(SystemExit) as refused:
        main([*args, "--newton-max-iter", str(10**9)])
    assert refused.value.code == 3
    err = capsys.readouterr().err
    assert "--newton-max-iter" in err and f"more than {bound}" in err
    assert len(error_lines(err)) == 1
