"""The ``sampledyn evaluate`` commands printed in docs/logs.md and examples/README.md run
as printed, on logs the tests write under the names the commands use (``my_bag/``,
``run.bag``, ``00000042.BIN``; ``examples/rov_log.csv`` is in the repository), from a
folder where ``examples/`` is the repository's. The commands that name an estimated
rule also run in a fresh process, as a user runs them: a rule that a module of another
test registered (the estimated ABe_s) is not there for the user."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("rosbags")
pytest.importorskip("pymavlink")

from _ardusub_fixtures import BenchRun, TelemetryRun  # noqa: E402
from _log_fixtures import (  # noqa: E402  (after the optional extras are known)
    simulate_run,
    write_ros1_bag,
    write_ros2_bag,
)
from _ros_fixtures import write_tank_bag  # noqa: E402


def _mavlink(path, run):
    telemetry = TelemetryRun()
    return telemetry.write_tlog(path) if path.suffix == ".tlog" else telemetry.write_blueos(path)


ROOT = Path(__file__).resolve().parents[2]
DOCS = (ROOT / "docs" / "logs.md", ROOT / "examples" / "README.md")
WRITERS = {
    "ros2_bluerov2_heavy.toml": write_ros2_bag,
    "ros1_mavros_bluerov2_heavy.toml": write_ros1_bag,
    "ardusub_dataflash.toml": lambda path, run: BenchRun(depth=2.0).write(path),
    "ardusub_mavlink.toml": _mavlink,
    "ros2_mavros_rc_override_bluerov2_heavy.toml": lambda path, run: write_tank_bag(path),
}


def _documented() -> list[str]:
    found: dict[str, None] = {}
    for doc in DOCS:
        text = doc.read_text(encoding="utf-8").replace("\\\n", " ")
        for match in re.finditer(r"sampledyn evaluate [^`|\n]+", text):
            found[" ".join(match.group(0).split())] = None
    return list(found)


COMMANDS = _documented()


def test_the_docs_print_a_command_for_every_log_format():
    for mapping in (*WRITERS, None):
        assert any(
            (mapping or "--mapping") in c if mapping else "--mapping" not in c for c in COMMANDS
        ), mapping


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    """A folder with ``examples`` (the repository's) and the logs the commands name."""
    work = tmp_path_factory.mktemp("documented")
    (work / "examples").symlink_to(ROOT / "examples")
    run = simulate_run()
    for cmd in COMMANDS:
        args = shlex.split(cmd)
        data = args[args.index("--data") + 1]
        mapping = Path(args[args.index("--mapping") + 1]).name if "--mapping" in args else None
        if mapping is not None and not (work / data).exists():
            WRITERS[mapping](work / data.rstrip("/"), run)
    return work


def _fresh(command: str, workdir: Path) -> str:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.run(
        [sys.executable, "-m", "sampledyn.cli", *shlex.split(command)[1:]],
        cwd=workdir,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


@pytest.mark.parametrize(
    "command",
    # a command that runs in a fresh process (below) is slow
    [pytest.param(c, marks=pytest.mark.slow) if "--estimate" in c else c for c in COMMANDS],
)
def test_documented_command_runs(workdir, command, monkeypatch, capsys):
    from sampledyn.cli import main

    args = shlex.split(command)
    if "--estimate" in args:
        out = _fresh(command, workdir)
    else:
        monkeypatch.chdir(workdir)
        assert main(args[1:]) == 0
        out = capsys.readouterr().out
    assert "rms of the one-step local errors" in out
    methods = args[args.index("--methods") + 1].split(",") if "--methods" in args else ["E"]
    estimated = args[args.index("--estimate") + 1].split(",") if "--estimate" in args else []
    for name in (*methods, *estimated):
        assert re.search(rf"^{re.escape(name)}\s+\d", out, re.MULTILINE), (name, out)
