"""A sweep, a study or advise refuses oversized work before it starts (issue 24,
items 4 and 6): periods, horizons, seeds, masks, workers and the Dask address are
checked when the grid is read, in one line naming the input."""

from __future__ import annotations

import time

import pytest
from _faults import error_lines
from _sweep_helpers import write_sweep

from sampledyn.cli import main
from sampledyn.cli._status import EXIT_BAD_VALUE, EXIT_UNAVAILABLE, EXIT_USAGE
from sampledyn.exceptions import SweepConfigError
from sampledyn.experiments.sweep import load_config

SMALL = {"T": 2.0, "after": 0.5, "h": "[0.02]", "methods": '["AB1", "AB2"]', "eta": "[0]",
         "v": "[0]", "seeds": 1}  # fmt: skip


def _fails(args: list[str], capsys) -> tuple[int, str]:
    t0 = time.monotonic()
    with pytest.raises(SystemExit) as exc:
        main(args)
    assert time.monotonic() - t0 < 60  # refused before the work, not after it
    lines = error_lines(capsys.readouterr().err)
    assert len(lines) == 1 and lines[0].startswith("sampledyn: error: "), lines
    return int(exc.value.code), lines[0]  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "change, said",
    [
        ({"h": "[1e-9]", "T": 1.0}, "the exact samples and one group of cells would need"),
        ({"h": "[5e-324]", "T": 1.0}, "below the smallest sampling period 1e-09 s"),
        ({"h": "[0.001]", "T": 1e7, "after": 0.0}, "1e+10 samples per trajectory"),
        ({"seeds": f"[{2**63}]"}, "beyond 9223372036854775807"),
        ({"norm": '"rms@away_from_jumps(0.5)"'}, "HISTORY must be a whole number"),
        ({"norm": '"rms@smooth(-5)"'}, "HISTORY must be a whole number"),
        ({"norm": '"max@pitch_deg(0, 5, 1e9)"'}, "WINDOW must be a whole number"),
        ({"methods": '["AB100000"]'}, "must be in 1..28"),
    ],
)
def test_oversized_or_meaningless_grids_are_refused_before_work(tmp_path, capsys, change, said):
    cfg = write_sweep(tmp_path / "s.toml", **{**SMALL, **change})
    store = tmp_path / "s.db"
    code, line = _fails(["sweep", str(cfg), "--store", str(store), "--no-progress"], capsys)
    assert code == EXIT_BAD_VALUE and said in line
    assert not store.exists()


def test_a_multistep_horizon_is_bounded(tmp_path):
    path = tmp_path / "m.toml"
    path.write_text(
        'kind = "multistep"\nvehicle = "auv_like"\ninput = { name = "multilevel", hold = 0.1 }\n'
        'T = 2.0\nafter = 0.5\nh = [0.1]\nmethods = ["E"]\nhorizon = 1000000000\n'
    )
    with pytest.raises(SweepConfigError, match=r"`horizon` = 1e\+09 is above 1000"):
        load_config(path)


def test_the_memory_limit_option_raises_and_lowers_the_limit(tmp_path, capsys):
    cfg = write_sweep(tmp_path / "s.toml", **{**SMALL, "T": 200.0, "h": "[0.001]"})
    store = tmp_path / "s.db"
    code, line = _fails(
        ["--max-memory", "10M", "sweep", str(cfg), "--store", str(store), "--dry-run"], capsys
    )
    assert code == EXIT_BAD_VALUE and "above the limit of 10 MiB" in line
    assert main(["--max-memory", "1G", "sweep", str(cfg), "--store", str(store), "--dry-run"]) == 0
    code, line = _fails(["--max-memory", "lots", "sweep", str(cfg), "--store", str(store)], capsys)
    assert code == EXIT_USAGE and "--max-memory 'lots' is not a size" in line


@pytest.mark.parametrize(
    "args, said",
    [
        (["reproduce", "fig2", "--h", "1e-9"], "`h` = 1e-09 s with `T` (--T) = 200 s"),
        (["reproduce", "fig2", "--T", "1e12"], "1e+14 samples per trajectory"),
        (["reproduce", "fig7", "--h", "1e-7"], "above the limit of 4 GiB"),
        (["advise", "--h", "1e-9"], "T / h = 60 s / 1e-09 s = 6e+10 samples"),
        (["advise", "--h", "1e-10"], "below the smallest sampling period"),
        (["advise", "--seeds", "100000000"], "`seeds` must be an int in 1..10000"),
    ],
)
def test_studies_and_advise_refuse_oversized_work_before_it_starts(tmp_path, capsys, args, said):
    code, line = _fails([*args, "--out", str(tmp_path / "o")], capsys)
    assert code == EXIT_BAD_VALUE and said in line
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    "extra, status, said",
    [
        (["--scheduler", "nonsense"], EXIT_BAD_VALUE, "is not a Dask scheduler address"),
        (["--scheduler", "tcp://127.0.0.1"], EXIT_BAD_VALUE, "is not a Dask scheduler address"),
        (["--scheduler", "tcp://127.0.0.1:99999"], EXIT_BAD_VALUE, "port 1..65535"),
        (["--scheduler", "tcp://127.0.0.1:8786", "--connect-timeout", "nan"], EXIT_BAD_VALUE,
         "`connect_timeout` must be a finite number of seconds > 0, got nan"),
        (["--scheduler", "tcp://127.0.0.1:8786", "--connect-timeout", "-1"], EXIT_BAD_VALUE,
         "got -1.0"),
        (["--scheduler", "tcp://127.0.0.1:1", "--connect-timeout", "0.5"], EXIT_UNAVAILABLE,
         "no Dask scheduler answered within 0.5 s"),
    ],
)  # fmt: skip
def test_a_bad_scheduler_or_timeout_is_one_line_naming_it(tmp_path, capsys, extra, status, said):
    pytest.importorskip("distributed")
    cfg = write_sweep(tmp_path / "s.toml", **SMALL)
    code, line = _fails(["sweep", str(cfg), "--store", str(tmp_path / "s.db"), *extra], capsys)
    assert code == status and said in line


def test_a_tcp_scheduler_off_this_machine_is_warned_about(tmp_path, capsys):
    pytest.importorskip("distributed")
    cfg = write_sweep(tmp_path / "s.toml", **SMALL)
    args = [
        "sweep",
        str(cfg),
        "--store",
        str(tmp_path / "s.db"),
        "--scheduler",
        "tcp://192.0.2.1:8786",
        "--connect-timeout",
        "0.5",
    ]  # fmt: skip (TEST-NET-1)
    with pytest.warns(UserWarning) as caught, pytest.raises(SystemExit) as exc:
        main(args)
    assert exc.value.code == EXIT_UNAVAILABLE
    said = [str(w.message) for w in caught if "pickled code" in str(w.message)]
    assert len(said) == 1 and "tls://" in said[0] and "192.0.2.1" in said[0]


@pytest.mark.slow
def test_more_workers_than_tasks_or_cores_are_capped_with_a_note(tmp_path, capsys):
    cfg = write_sweep(tmp_path / "s.toml", **SMALL)  # 1 trajectory x 1 group: 1 task
    with pytest.warns(UserWarning, match="workers 200 capped at 1: the grid has 1 tasks"):
        assert main(["sweep", str(cfg), "--store", str(tmp_path / "s.db"), "--workers", "200",
                     "--no-progress"]) == 0  # fmt: skip
    captured = capsys.readouterr()
    assert "2 computed" in captured.out and "processes:1" in captured.out
