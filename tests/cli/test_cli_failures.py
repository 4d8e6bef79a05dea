"""The ``sampledyn`` command as users meet it: one clear line and a distinct exit
status per kind of failure, every option checked before any work, the options a
command-line tool is expected to have, help for every option."""

from __future__ import annotations

import argparse
import json
import os
import pty
import re
import select
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest
from _faults import CLI, Unavailable, error_lines, remount_readonly, tmpfs
from _sweep_helpers import write_sweep

import sampledyn as sd
from sampledyn._local_errors import ERROR_NORMS
from sampledyn.cli import EXIT_STATUSES, build_parser, main
from sampledyn.cli._status import EXIT_BAD_VALUE, EXIT_FILE, EXIT_INTERNAL, EXIT_PIPE, EXIT_USAGE

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE_LOG = ROOT / "examples" / "rov_log.csv"


def _fails(args: list[str], capsys) -> tuple[int, str]:
    """Run ``main(args)``, expecting a failure: (exit status, stderr)."""
    with pytest.raises(SystemExit) as exc:
        main(args)
    err = capsys.readouterr().err
    return int(exc.value.code), err  # type: ignore[arg-type]


def _one_line(err: str) -> str:
    lines = error_lines(err)
    assert len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith("sampledyn: error: "), err
    return lines[0]


# -- 1. tracebacks -> one line and a status per kind ------------------------------------


def test_help_and_docs_list_every_exit_status(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    docs = (ROOT / "docs" / "cli.md").read_text()
    documented = {int(m) for m in re.findall(r"^\| (\d+) \|", docs, flags=re.MULTILINE)}
    assert documented == set(EXIT_STATUSES)
    for code, text in EXIT_STATUSES.items():
        assert re.search(rf"^\s+{code}\s+", out, flags=re.MULTILINE), code
        assert text.split(":")[0] in out
    assert len(set(EXIT_STATUSES)) == len(EXIT_STATUSES)


def test_missing_vehicle_file_names_option_and_path(capsys):
    status, err = _fails(["advise", "--vehicle", "nope.toml"], capsys)
    assert status == EXIT_FILE
    line = _one_line(err)
    assert "--vehicle" in line and "nope.toml" in line


def test_out_that_is_a_file_or_below_a_file_fails_before_any_work(tmp_path, capsys):
    afile = tmp_path / "afile"
    afile.write_text("x")
    t0 = time.perf_counter()
    status, err = _fails(["reproduce", "fig3", "--out", str(afile), "--T", "600"], capsys)
    assert status == EXIT_FILE and time.perf_counter() - t0 < 30  # 600 s would take longer
    line = _one_line(err)
    assert "--out" in line and str(afile) in line and "folder" in line
    assert afile.read_text() == "x"
    status, err = _fails(
        ["evaluate", "--data", str(EXAMPLE_LOG), "--vehicle", "bluerov2_heavy", "--out",
         str(afile / "t.csv")],
        capsys,
    )  # fmt: skip
    assert status == EXIT_FILE and "--out" in _one_line(err)
    db = tmp_path / "r.db"
    sqlite3.connect(db).close()
    status, err = _fails(["results", str(db), "--out", str(tmp_path)], capsys)
    assert status == EXIT_FILE and "folder" in _one_line(err)


def test_out_on_read_only_media_fails_before_any_work(tmp_path, capsys):
    media = tmp_path / "ro"
    try:
        with tmpfs(media, "1m"):
            remount_readonly(media)
            status, err = _fails(["reproduce", "fig3", "--out", str(media / "fig3")], capsys)
            assert status == EXIT_FILE
            assert "cannot write" in _one_line(err) and str(media) in err
    except Unavailable as exc:
        pytest.skip(str(exc))


def test_missing_store_and_data_files(tmp_path, capsys):
    status, err = _fails(["results", str(tmp_path / "none.db")], capsys)
    assert status == EXIT_FILE and "none.db" in _one_line(err)
    status, err = _fails(
        ["report", str(tmp_path / "none.db"), "--out", str(tmp_path / "r")], capsys
    )
    assert status == EXIT_FILE and "none.db" in _one_line(err)
    assert not (tmp_path / "none.db").exists()
    status, err = _fails(
        ["evaluate", "--data", str(tmp_path / "no.csv"), "--vehicle", "bluerov2_heavy"], capsys
    )
    assert status == EXIT_FILE and "--data" in _one_line(err) and "no.csv" in err
    assert f"--data {tmp_path / 'no.csv'}: no log there" in err  # the trial: no colon


def test_a_missing_or_folder_mapping_is_a_file_error_naming_the_option(tmp_path, capsys):
    """The new-user trial: a missing --mapping was status 3 ("no file"), a folder 4."""
    log = Path(__file__).resolve().parents[2] / "examples" / "rov_log.csv"
    base = ["evaluate", "--data", str(log), "--vehicle", "bluerov2_heavy"]
    status, err = _fails([*base, "--mapping", str(tmp_path / "nope.toml")], capsys)
    line = _one_line(err)
    assert status == EXIT_FILE and line.startswith("sampledyn: error: --mapping "), line
    assert "nope.toml: no mapping file there" in line, line
    status, err = _fails([*base, "--mapping", str(tmp_path)], capsys)
    line = _one_line(err)
    assert status == EXIT_FILE and "--mapping" in line and "is a folder" in line, line


def _store_with_rows(path: Path, n: int) -> Path:
    from sampledyn.experiments.sweep._store import ResultStore

    with ResultStore(path) as st:
        run = st.start_run(backend="test", planned=n, skipped=0, config={})
        st.write(
            [
                {"key": f"k{i}", "run_id": run, "computed_at": 0.0, "status": "ok",
                 "version": "0", "method": "AB1", "config": "{}"}
                for i in range(n)
            ]
        )  # fmt: skip
        st.finish_run(run, "complete")
    return path


@pytest.mark.slow
def test_results_into_a_closed_pipe_exits_quietly(tmp_path):
    db = _store_with_rows(tmp_path / "r.db", 20000)  # far more than a pipe buffer holds
    proc = subprocess.Popen(
        [*CLI, "results", str(db), "--format", "csv"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert proc.stdout is not None and proc.stderr is not None
    first = proc.stdout.readline()
    proc.stdout.close()  # what `| head -1` does
    err = proc.stderr.read().decode()
    proc.wait(timeout=120)
    assert first.startswith(b"key,")
    assert proc.returncode == EXIT_PIPE and err == ""


def test_debug_option_and_environment_show_the_traceback(capsys, monkeypatch):
    status, err = _fails(["advise", "--vehicle", "nope.toml", "--debug"], capsys)
    assert status == EXIT_FILE and "Traceback" in err
    assert err.strip().splitlines()[-1].startswith("sampledyn: error: --vehicle")
    monkeypatch.setenv("SAMPLEDYN_DEBUG", "1")
    status, err = _fails(["advise", "--vehicle", "nope.toml"], capsys)
    assert status == EXIT_FILE and "Traceback" in err


def test_a_bug_is_an_internal_error_with_a_hint(capsys, monkeypatch):
    from sampledyn.cli import _methods

    def broken(args):
        raise RuntimeError("something impossible")

    monkeypatch.setattr(_methods, "_cmd_methods", broken)
    status, err = _fails(["methods"], capsys)
    assert status == EXIT_INTERNAL
    line = _one_line(err)
    assert "something impossible" in line and "--debug" in line


# -- 6. options checked before any work -------------------------------------------------


def test_reproduce_refuses_a_second_h_for_a_one_h_figure(tmp_path, capsys):
    status, err = _fails(
        ["reproduce", "fig2", "--h", "0.01,0.02", "--out", str(tmp_path / "o")], capsys
    )
    assert status == EXIT_USAGE
    line = _one_line(err)
    assert "--h" in line and "0.01,0.02" in line
    assert not (tmp_path / "o").exists()


def test_reproduce_refuses_options_that_do_not_apply(tmp_path, capsys):
    args = ["reproduce", "fig2", "--vehicle", "nope", "--seeds", "5", "--no-attitude-hold"]
    status, err = _fails([*args, "--out", str(tmp_path / "o")], capsys)
    assert status == EXIT_USAGE
    line = _one_line(err)
    for flag in ("--vehicle", "--seeds", "--no-attitude-hold"):
        assert flag in line
    status, err = _fails(["reproduce", "fig7", "--ratios", "1,2"], capsys)
    assert status == EXIT_USAGE and "--ratios" in _one_line(err)
    assert not (tmp_path / "o").exists()


def test_reproduce_fig7_checks_norm_and_methods_before_computing(tmp_path, capsys):
    t0 = time.perf_counter()
    status, err = _fails(
        ["reproduce", "fig7", "--norm", "max", "--out", str(tmp_path / "o")], capsys
    )
    assert status == EXIT_USAGE and "--norm max" in _one_line(err)
    status, err = _fails(
        ["reproduce", "fig7", "--methods", "AB4,XY2", "--out", str(tmp_path / "o")], capsys
    )
    assert status == EXIT_BAD_VALUE and "XY2" in _one_line(err)
    assert time.perf_counter() - t0 < 60  # the study takes minutes
    assert not (tmp_path / "o").exists()


def test_evaluate_refuses_to_estimate_with_a_rule_that_does_not(tmp_path, capsys):
    status, err = _fails(
        [
            "evaluate",
            "--data",
            str(EXAMPLE_LOG),
            "--vehicle",
            "bluerov2_heavy",
            "--estimate",
            "AB4",
        ],
        capsys,
    )
    assert status == EXIT_USAGE
    line = _one_line(err)
    assert "--estimate AB4" in line and "does not estimate" in line
    # the registry answers, not the name: an estimating rule passes the check
    assert isinstance(sd.get_method("ABe2"), sd.methods.Estimator)
    assert not isinstance(sd.get_method("AB4"), sd.methods.Estimator)


def _options(parser: argparse.ArgumentParser, path: str = "sampledyn"):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _options(sub, f"{path} {name}")
        else:
            yield path, action


def test_every_option_of_every_command_has_help():
    missing = [
        f"{path} {'/'.join(a.option_strings) or a.dest}"
        for path, a in _options(build_parser())
        if not a.help or a.help == argparse.SUPPRESS
    ]
    assert missing == []


def test_norm_has_the_same_choices_everywhere():
    norms = [(p, a) for p, a in _options(build_parser()) if "--norm" in a.option_strings]
    assert {p for p, _ in norms} == {"sampledyn reproduce", "sampledyn evaluate"}
    for _, action in norms:
        assert tuple(action.choices) == ERROR_NORMS


# -- 7. what users expect -----------------------------------------------------------------


def test_version_and_quiet(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0 and capsys.readouterr().out.strip() == f"sampledyn {sd.__version__}"
    cfg = write_sweep(tmp_path / "s.toml", h="[0.02]", seeds=1)
    assert main(["sweep", str(cfg), "--store", str(tmp_path / "a.db")]) == 0
    assert "sweep" in capsys.readouterr().err  # the progress bar
    for args in (["--quiet", "sweep", str(cfg)], ["sweep", str(cfg), "-q"]):
        assert main([*args, "--store", str(tmp_path / "b.db")]) == 0
        assert capsys.readouterr().err == ""


@pytest.mark.slow
def test_advise_seed_and_json(tmp_path, capsys):
    base = ["advise", "--h", "0.1", "--methods", "E,AB4", "--T", "10", "--seeds", "1",
            "--format", "json", "--out", str(tmp_path)]  # fmt: skip
    docs = {}
    for seed in (0, 0, 7):
        assert main([*base, "--seed", str(seed)]) == 0
        docs.setdefault(seed, []).append(json.loads(capsys.readouterr().out))
    a, b = docs[0]
    assert a == b  # same seed, same numbers
    c = docs[7][0]
    for key in ("vehicle", "h", "noise", "tolerance", "rank_by", "seed", "seeds", "best",
                "rank_agreement", "rows", "crossings", "figure"):  # fmt: skip
        assert key in a
    assert a["seed"] == 0 and c["seed"] == 7
    meas = {r["method"]: r["measured_eta"] for r in a["rows"]}
    other = {r["method"]: r["measured_eta"] for r in c["rows"]}
    pred = {r["method"]: r["predicted_eta"] for r in a["rows"]}
    assert meas != other  # the seed reaches the Monte Carlo noise ...
    assert pred == {r["method"]: r["predicted_eta"] for r in c["rows"]}  # ... not the bound


def test_evaluate_json(capsys):
    args = ["evaluate", "--data", str(EXAMPLE_LOG), "--vehicle", "bluerov2_heavy",
            "--methods", "E,AB2", "--after", "2", "--format", "json"]  # fmt: skip
    assert main(args) == 0
    doc = json.loads(capsys.readouterr().out)
    for key in ("source", "vehicle", "samples", "h", "jitter", "t_start", "t_end", "notes",
                "norm", "after", "rows", "estimation", "warnings", "out"):  # fmt: skip
        assert key in doc
    assert [r["method"] for r in doc["rows"]] == ["hold", "kinematics", "E", "AB2"]
    assert {"order", "err_eta", "err_v", "err_all", "samples"} <= set(doc["rows"][0])
    assert doc["estimation"] is None and doc["norm"] == "rms"


def _read_all(fd: int, proc: subprocess.Popen[bytes], timeout: float) -> bytes:
    """Everything written to the pty ``fd`` until ``proc`` ends (drained as it comes,
    so the process never blocks on a full terminal)."""
    out = b""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        ready, _, _ = select.select([fd], [], [], 0.1)
        if ready:
            try:
                chunk = os.read(fd, 65536)
            except OSError:  # the follower side closed: the process ended
                break
            if not chunk:
                break
            out += chunk
        elif proc.poll() is not None:
            break
    return out


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="pty")
def test_a_terminal_hears_from_the_command_before_the_kernels_load(tmp_path):
    """The start-up line comes before numba or the models are imported (so also
    before a first run compiles them), and --quiet suppresses it."""
    cfg = write_sweep(tmp_path / "s.toml", h="[0.02]", seeds=1)
    for quiet in (False, True):
        leader, follower = pty.openpty()
        args = [*CLI[:1], "-X", "importtime", *CLI[1:], "sweep", str(cfg), "--store",
                str(tmp_path / f"{quiet}.db"), "--dry-run", *(["-q"] if quiet else [])]  # fmt: skip
        proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=follower)
        os.close(follower)
        try:
            text = _read_all(leader, proc, timeout=240).decode(errors="replace")
        finally:
            proc.wait(timeout=120)
            os.close(leader)
        numba = re.search(r"\|\s*numba\s*$", text, flags=re.MULTILINE)
        assert numba is not None, text[-2000:]
        heavy = numba.start()
        line = text.find("sampledyn sweep: loading")
        if quiet:
            assert line == -1
        else:
            assert 0 <= line < heavy


# -- issue 14: no matplotlib where nothing is drawn; Dask workers without the nanny's
#    malloc setting -------------------------------------------------------------------


@pytest.mark.slow
def test_non_plotting_commands_do_not_import_matplotlib(tmp_path):
    cfg = write_sweep(tmp_path / "s.toml", h="[0.02]", seeds=1)
    db = tmp_path / "r.db"
    commands = [
        ["methods"],
        ["sweep", str(cfg), "--store", str(db), "--no-progress"],
        ["results", str(db), "--format", "csv"],
        ["evaluate", "--data", str(EXAMPLE_LOG), "--vehicle", "bluerov2_heavy", "--methods", "E"],
    ]
    code = (
        "import sys\nfrom sampledyn.cli import main\n"
        f"for args in {commands!r}:\n"
        "    assert main(args) == 0\n"
        "    print('MPL', args[0], 'matplotlib' in sys.modules, file=sys.stderr)\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    seen = [line.split()[1:] for line in res.stderr.splitlines() if line.startswith("MPL ")]
    assert seen == [[args[0], "False"] for args in commands]


def test_a_numerical_failure_is_one_line_with_its_own_status(capsys, monkeypatch):
    """A rule that cannot solve its step on these inputs (advise running T at large h
    hit this) is not an 'internal error': exit 7, one line that says what to change."""
    from sampledyn.cli import _methods
    from sampledyn.cli._status import EXIT_NUMERICAL
    from sampledyn.exceptions import ConvergenceError

    def fails(args):
        raise ConvergenceError("Tustin's Newton iteration did not converge; use a smaller h.")

    monkeypatch.setattr(_methods, "_cmd_methods", fails)
    status, err = _fails(["methods"], capsys)
    assert status == EXIT_NUMERICAL
    line = _one_line(err)
    assert "smaller h" in line and "internal error" not in line


# -- the second new-user trial: values that passed the option types but broke later


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["reproduce", "fig3", "--h", "0.03"], "`h` = 0.03 s does not divide T = 200 s"),
        (["reproduce", "fig3", "--T", "inf"], "`T` must be a finite number, got inf"),
        (["reproduce", "fig2", "--T", "nan"], "`T` must be a finite number, got nan"),
        (["advise", "--vehicle", "bluerov2_heavy", "--T", "inf", "--no-validate"],
         "--T: reference run length `T` must be a finite number, got inf"),
        (["advise", "--vehicle", "bluerov2_heavy", "--T", "0.05", "--no-validate"],
         "`T` = 0.05 s is too short for h = 0.1 s"),
        (["advise", "--vehicle", "bluerov2_heavy", "--workers", "0"],
         "`workers` must be an int >= 1"),
    ],
)  # fmt: skip
def test_bad_durations_periods_and_workers_are_named_before_work(args, expected, tmp_path, capsys):
    code, err = _fails([*args, "--out", str(tmp_path / "o")], capsys)
    assert code == EXIT_BAD_VALUE
    assert expected in err and "Traceback" not in err
    assert not (tmp_path / "o").exists()


def test_fig7_of_another_vehicle_does_not_overwrite_the_default_output():
    from sampledyn.experiments._rov import fig7_out

    assert fig7_out("rexrov") == "out/fig7"
    assert fig7_out("bluerov2_heavy") == "out/fig7_bluerov2_heavy"
    assert fig7_out("/home/me/my_rov.toml") == "out/fig7_my_rov"


@pytest.mark.slow
def test_advise_does_not_blame_the_data_for_an_rk_stage_at_a_large_trial_period(tmp_path, capsys):
    """The h_max search runs RK4 at periods up to 2 s, where a stage leaves the data's
    pitch range (the RexROV's Fig. 6 run stays within 22 deg; stages reached 85 deg and
    the vehicle warned as if the data had): no pitch warning, the domain says the truth."""
    assert main(["advise", "--vehicle", "rexrov", "--input", "fig6", "--h", "0.1",
                 "--methods", "RK4", "--no-validate", "--out", str(tmp_path)]) == 0  # fmt: skip
    out, err = capsys.readouterr()
    assert "pitch |theta|" not in err
    theta = float(re.search(r"\|theta\|<=([0-9.]+) deg", out).group(1))
    assert theta < 30.0


@pytest.mark.parametrize(
    ("args", "status", "expected"),
    [
        (["reproduce", "closed-loop", "--methods", "Ee"], EXIT_BAD_VALUE,
         "'Ee' estimates the model's parameters"),
        (["reproduce", "multistep", "--methods", "ABj4"], EXIT_BAD_VALUE,
         "'ABj4' cannot be discretized"),
        (["reproduce", "closed-loop", "--T", "50"], EXIT_BAD_VALUE,
         "`after` must be in [0, T=50) s, got 100.0"),
        (["reproduce", "multistep", "--T", "-3"], EXIT_BAD_VALUE,
         "--T: `T` must be a finite number > 0, got -3.0"),
        (["reproduce", "fig3", "--seed", "-1"], EXIT_BAD_VALUE,
         "--seed: the multilevel input's `seed` must be an int >= 0, got -1"),
        (["advise", "--vehicle", "bluerov2_heavy", "--seed", "-1"], EXIT_BAD_VALUE,
         "--seed: `base_seed` must be an int >= 0"),
        (["advise", "--vehicle", "bluerov2_heavy", "--methods", ""], EXIT_USAGE,
         "`--methods` is empty"),
        (["evaluate", "--data", str(EXAMPLE_LOG), "--vehicle", "bluerov2_heavy",
          "--max-missing", "3"], EXIT_USAGE, "`--max-missing` applies to `--gaps bridge`"),
    ],
)  # fmt: skip
def test_third_trial_values_are_refused_before_work(args, status, expected, tmp_path, capsys):
    out = [] if args[0] == "evaluate" else ["--out", str(tmp_path / "o")]
    code, err = _fails([*args, *out], capsys)
    assert code == status
    assert expected in _one_line(err)
    assert not (tmp_path / "o").exists()


def test_an_empty_file_is_no_store_to_read(tmp_path, capsys):
    empty = tmp_path / "e.db"
    empty.touch()
    for cmd in (["results", str(empty)], ["report", str(empty), "--out", str(tmp_path / "r")]):
        code, err = _fails(cmd, capsys)
        assert code == EXIT_BAD_VALUE and "is an empty file, not a results store" in _one_line(err)
    assert empty.stat().st_size == 0


@pytest.mark.slow
def test_closed_loop_takes_the_vehicles_its_help_lists(tmp_path, capsys):
    assert main(["-q", "reproduce", "closed-loop", "--vehicle", "rexrov,bluerov2_heavy",
                 "--h", "0.5", "--methods", "RK4", "--seeds", "1", "--T", "20", "--after", "5",
                 "--out", str(tmp_path)]) == 0  # fmt: skip
    table = (tmp_path / "closed_loop.md").read_text()
    assert "| rexrov | 0.5 | RK4 |" in table and "| bluerov2_heavy | 0.5 | RK4 |" in table


def test_a_misspelt_per_vehicle_section_is_said(tmp_path, capsys):
    cfg = write_sweep(tmp_path / "s.toml", h="[0.02]", seeds=1)
    cfg.write_text(cfg.read_text() + "\n[per_vehicle.rexrow]\nbuoyancy_pct = 1.0\n")
    with pytest.warns(UserWarning, match=r"`per_vehicle.rexrow`.*did you mean 'rexrov'"):
        assert main(["sweep", str(cfg), "--store", str(tmp_path / "r.db"), "--dry-run"]) == 0


def test_an_input_table_without_a_name_asks_for_one(capsys):
    code, err = _fails(["advise", "--vehicle", "bluerov2_heavy", "--input", "{ scale = 0.3 }"],
                       capsys)  # fmt: skip
    assert code == EXIT_BAD_VALUE
    assert "has no `name`; give one of fig6, gentle" in _one_line(err)
