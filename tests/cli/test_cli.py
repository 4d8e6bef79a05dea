import csv

import pytest

from sampledyn.cli import build_parser, main
from sampledyn.cli._status import EXIT_BAD_VALUE


def test_help_lists_every_command(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    for action in build_parser()._subparsers._group_actions:  # type: ignore[union-attr]
        for name in action.choices:
            assert name in out


def test_reproduce_fig3_small(tmp_path, capsys):
    code = main(
        [
            "reproduce",
            "fig3",
            "--T",
            "6",
            "--after",
            "1",
            "--ratios",
            "1,10",
            "--out",
            str(tmp_path),
            "--no-progress",
        ]
    )
    assert code == 0
    out = capsys.readouterr().out
    assert "RK4" in out and "hu/h=10" in out
    rows = list(csv.DictReader((tmp_path / "fig3.csv").open()))
    assert {r["method"] for r in rows} == {"E", "T", "RK1", "RK2", "RK3", "RK4", "Ee"}
    rk = {r["method"]: float(r["rms"]) for r in rows if r["hold_ratio"] == "10"}
    assert rk["RK4"] < rk["RK2"] < rk["E"]
    assert (tmp_path / "fig3.png").stat().st_size > 10_000


def test_bad_argument_exits_with_message(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["reproduce", "fig2", "--h", "-1", "--no-progress", "--T", "1", "--after", "0.5"])
    assert exc.value.code == EXIT_BAD_VALUE
    assert "`h`" in capsys.readouterr().err


@pytest.mark.slow
def test_estimated_rules_are_known_to_a_fresh_command():
    """The estimation layer registers Ee/ABe<s>; a command run in a new process (no
    other import first) must know them."""
    import subprocess
    import sys
    from pathlib import Path

    log = Path(__file__).resolve().parents[2] / "examples" / "rov_log.csv"
    cmd = [sys.executable, "-m", "sampledyn.cli", "evaluate", "--data", str(log),
           "--vehicle", "bluerov2_heavy", "--methods", "E", "--estimate", "ABe2",
           "--after", "2"]  # fmt: skip
    run = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert "ABe2" in run.stdout


def test_reproduce_freezes_what_it_loaded_while_the_cells_run_and_undoes_it(tmp_path):
    """While the results come in, the modules, kernels and plan loaded before are out
    of the collector's reach (gc.freeze); main() returns with nothing of it frozen, and
    a caller's own frozen objects stay frozen."""
    import gc

    seen: list[int] = []

    def watch(phase, info):
        if phase == "start":
            seen.append(gc.get_freeze_count())

    args = ["-q", "reproduce", "fig7", "--T", "40", "--after", "20", "--h", "0.5",
            "--seeds", "1", "--workers", "1"]  # fmt: skip
    gc.callbacks.append(watch)
    try:
        assert main([*args, "--out", str(tmp_path / "a")]) == 0
    finally:
        gc.callbacks.remove(watch)
    assert max(seen) > 10_000 and gc.get_freeze_count() == 0
    gc.freeze()
    try:
        mine = gc.get_freeze_count()
        assert main([*args, "--out", str(tmp_path / "b")]) == 0
        assert gc.get_freeze_count() >= mine
    finally:
        gc.unfreeze()
