"""Messages a new user meets on the command line (the trial's findings): argparse's
errors as one line, close names suggested, values typed on the command line named as
such, Ctrl-C saying what was kept, each warning once."""

from __future__ import annotations

import re
import warnings

import pytest

from sampledyn.cli import main
from sampledyn.cli._main import _one_line_warnings
from sampledyn.cli._status import EXIT_BAD_VALUE, EXIT_INTERRUPTED, EXIT_UNAVAILABLE, EXIT_USAGE


def _fails(args: list[str], capsys) -> tuple[int, str]:
    with pytest.raises(SystemExit) as exc:
        main(args)
    return int(exc.value.code), capsys.readouterr().err  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "args, flag",
    [
        (["evaluate", "--data", "x.csv", "--vehicle", "bluerov2", "--norm", "l3"], "--norm"),
        (["reproduce", "fig8"], "study"),
        (["reproduce", "fig7", "--h", "abc"], "--h"),
        (["results", "x.db", "--format", "xml"], "--format"),
        (["frob"], "COMMAND"),
    ],
)
def test_argparse_errors_are_one_line_naming_the_option_and_help(args, flag, capsys):
    status, err = _fails(args, capsys)
    assert status == EXIT_USAGE
    assert err.count("\n") == 1 and "usage:" not in err, err
    assert err.startswith(f"sampledyn: error: {flag}"), err
    assert "--help` lists the options" in err


def test_unknown_vehicle_names_the_option_and_suggests_on_evaluate_and_advise(capsys, tmp_path):
    log = tmp_path / "log.csv"
    log.write_text("t\n0\n")
    for args in (
        ["evaluate", "--data", str(log), "--vehicle", "bluerov_heavy"],
        ["advise", "--vehicle", "BlueROV2_Heavy"],
    ):
        status, err = _fails(args, capsys)
        assert status == EXIT_BAD_VALUE
        assert err.startswith("sampledyn: error: --vehicle: unknown vehicle"), err
        assert "did you mean 'bluerov2_heavy'" in err, err


def test_unknown_method_suggests_and_keeps_the_list_short(capsys):
    status, err = _fails(["reproduce", "fig7", "--methods", "AB1,AB4,Eular", "-q"], capsys)
    assert status == EXIT_BAD_VALUE
    assert "--methods" in err and "did you mean 'E'" in err, err
    assert "RK1-RK4" in err and len(err) < 400, err  # families, not every description


@pytest.mark.parametrize(
    "option, value, text",
    [
        ("--h", "-0.1", "`h` must be a finite number > 0, got -0.1"),
        ("--T", "-1", "`T` must be a finite number > 0"),
        ("--vehicle", "bluerov_heavy", "did you mean 'bluerov2_heavy'"),
        ("--methods", "AB1,AB4,RK99", "got 99 ('RK99')"),
        ("--seeds", "0", "`seeds` must be an int >= 1, got 0"),
    ],
)
def test_fig7_values_typed_are_not_blamed_on_the_study_file(option, value, text, capsys, tmp_path):
    status, err = _fails(["-q", "reproduce", "fig7", option, value, "--out", str(tmp_path)], capsys)
    assert status == EXIT_BAD_VALUE
    assert err.startswith(f"sampledyn: error: {option}: "), err
    assert text in err, err
    assert "fig7.toml" not in err and "site-packages" not in err, err


def test_fig7_refuses_methods_without_the_tables_rules(capsys, tmp_path):
    status, err = _fails(["-q", "reproduce", "fig7", "--methods", "AB20", "--out", str(tmp_path)],
                         capsys)  # fmt: skip
    assert status == EXIT_BAD_VALUE
    assert "--methods" in err and "lacks AB1, AB4" in err and "AB1,AB4,AB20" in err, err
    assert not any(tmp_path.iterdir())


def test_ctrl_c_without_store_says_nothing_was_kept(monkeypatch, capsys, tmp_path):
    from sampledyn.experiments._studies import StudyDefinition

    def interrupted(self, *args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(StudyDefinition, "run", interrupted)
    status, err = _fails(["-q", "reproduce", "fig2", "--out", str(tmp_path)], capsys)
    assert status == EXIT_INTERRUPTED
    assert "interrupted (Ctrl-C)" in err and "were not kept" in err and "--store FILE" in err


@pytest.mark.parametrize("store", [False, True])
def test_a_dead_worker_says_where_the_finished_cells_are(store, monkeypatch, capsys, tmp_path):
    from concurrent.futures.process import BrokenProcessPool

    from sampledyn.experiments._studies import StudyDefinition

    def worker_died(self, *args, **kwargs):
        raise BrokenProcessPool("A process in the process pool was terminated abruptly")

    monkeypatch.setattr(StudyDefinition, "run", worker_died)
    db = tmp_path / "r.db"
    extra = ["--store", str(db)] if store else []
    status, err = _fails(["-q", "reproduce", "fig2", "--out", str(tmp_path), *extra], capsys)
    assert status == EXIT_UNAVAILABLE and "a worker process died" in err
    if store:
        assert f"the finished cells are in {db}; rerun the same command" in err
    else:
        assert "were not kept" in err and "are kept" not in err


def test_each_warning_text_shows_once_per_command():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with _one_line_warnings():
            for _ in range(3):
                with warnings.catch_warnings():  # resets Python's once-per-place registry
                    warnings.warn("AB20: stable only for small h", UserWarning, stacklevel=1)
            warnings.warn("another text", UserWarning, stacklevel=1)
    assert [str(w.message) for w in caught] == ["AB20: stable only for small h", "another text"]


@pytest.mark.slow
def test_fig7_says_its_cells_once_and_warns_once(capsys, tmp_path):
    args = ["reproduce", "fig7", "--T", "20", "--after", "5", "--h", "0.5", "--seeds", "1",
            "--methods", "AB1,AB4,AB20", "--workers", "1", "--no-progress",
            "--out", str(tmp_path)]  # fmt: skip
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")  # (not once per place: the command's own dedup)
        assert main(args) == 0
    out = capsys.readouterr().out
    assert len(re.findall(r"\d+ cells: \d+ computed", out)) == 1, out
    assert sum(str(w.message).startswith("AB20:") for w in caught) == 1, caught
