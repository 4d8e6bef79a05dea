"""Big and strange files (issue 24, item 5): only regular files are read, with a size
limit per kind; a log is read in chunks (memory: its arrays and one chunk); a damaged
DataFlash log is refused before pymavlink loops on it; nesting limits give exit 3
naming the file; and what was silently wrong is said (items 6, 7)."""

from __future__ import annotations

import os
import subprocess
import sys
import tracemalloc
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _faults import error_lines
from _sweep_helpers import write_sweep

import sampledyn as sd
from sampledyn import _files
from sampledyn.cli import main
from sampledyn.cli._status import EXIT_BAD_VALUE, EXIT_FILE
from sampledyn.exceptions import FileContentError, LogFormatError
from sampledyn.logs import evaluate_log, log_from_frame, read_log

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE_LOG = ROOT / "examples" / "rov_log.csv"
VEHICLES = ROOT / "sampledyn" / "models" / "vehicles"
CLI = [sys.executable, "-m", "sampledyn.cli"]


@pytest.fixture(scope="module")
def heavy():
    return sd.models.load_vehicle("bluerov2_heavy")


def _status(args: list[str], capsys) -> tuple[int, str]:
    with pytest.raises(SystemExit) as exc:
        main(args)
    lines = error_lines(capsys.readouterr().err)
    assert len(lines) == 1 and lines[0].startswith("sampledyn: error: "), lines
    return int(exc.value.code), lines[0]  # type: ignore[arg-type]


# -- regular files only ---------------------------------------------------------------


def _fifo_cases(tmp: Path) -> dict[str, tuple[list[str], str]]:
    fifo = tmp / "pipe"
    os.mkfifo(fifo)
    bag = tmp / "bag"
    bag.mkdir()
    os.mkfifo(bag / "metadata.yaml")
    cfg = write_sweep(tmp / "s.toml", T=2.0, after=0.5, h="[0.02]")
    return {
        "vehicle FIFO": (["advise", "--vehicle", str(fifo) + ".toml"], "a FIFO"),
        "vehicle /dev/zero": (
            ["evaluate", "--data", str(EXAMPLE_LOG), "--vehicle", "/dev/zero"],
            "a device",
        ),  # fmt: skip
        "sweep FIFO": (["sweep", str(fifo), "--store", str(tmp / "x.db")], "a FIFO"),
        "store FIFO": (["results", str(fifo)], "a FIFO"),
        "store /dev/zero": (["sweep", str(cfg), "--store", "/dev/zero"], "a device"),
        "log FIFO": (["evaluate", "--data", str(fifo), "--vehicle", "bluerov2_heavy"], "a FIFO"),
        "bag metadata FIFO": (
            [
                "evaluate",
                "--data",
                str(bag),
                "--vehicle",
                "bluerov2_heavy",
                "--mapping",
                str(ROOT / "examples" / "ros2_bluerov2_heavy.toml"),
            ],
            "no ROS 2 bag",
        ),  # fmt: skip (a FIFO is no metadata file)
        "mapping FIFO": (
            [
                "evaluate",
                "--data",
                str(EXAMPLE_LOG),
                "--vehicle",
                "bluerov2_heavy",
                "--mapping",
                str(fifo),
            ],
            "a FIFO",
        ),  # fmt: skip
    }


@pytest.mark.slow
@pytest.mark.parametrize("case", [
    "vehicle FIFO", "vehicle /dev/zero", "sweep FIFO", "store FIFO", "store /dev/zero",
    "log FIFO", "bag metadata FIFO", "mapping FIFO",
])  # fmt: skip
def test_fifos_and_devices_are_refused_without_blocking(tmp_path, case):
    if case == "vehicle FIFO":
        os.mkfifo(tmp_path / "pipe.toml")
    args, said = _fifo_cases(tmp_path)[case]
    if case == "bag metadata FIFO":
        pytest.importorskip("rosbags")
    done = subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=120)
    lines = error_lines(done.stderr)
    assert done.returncode in (EXIT_FILE, EXIT_BAD_VALUE), done.stderr
    assert len(lines) == 1 and said in lines[0], lines
    assert "regular file" in lines[0] or case == "bag metadata FIFO", lines


def test_a_file_above_its_kinds_size_limit_is_refused_before_it_is_read(tmp_path):
    big = tmp_path / "huge.toml"
    with big.open("wb") as fh:
        fh.truncate(_files.SIZE_LIMITS["vehicle file"] + 1)  # sparse: no disk used
    tracemalloc.start()
    with pytest.raises(ValueError, match=r"vehicle file .* is 16\.0 MiB, above the 16 MiB"):
        sd.models.load_vehicle(big)
    assert tracemalloc.get_traced_memory()[1] < 1e6
    tracemalloc.stop()


@pytest.mark.parametrize("kind", ["vehicle", "sweep"])
def test_a_file_that_is_not_utf8_is_one_line_naming_it_and_the_byte(tmp_path, capsys, kind):
    path = tmp_path / f"{kind}.toml"
    path.write_bytes(b'name = "caf\xe9"\n')
    args = (["advise", "--vehicle", str(path)] if kind == "vehicle"
            else ["sweep", str(path), "--store", str(tmp_path / "s.db")])  # fmt: skip
    code, line = _status(args, capsys)
    assert code == EXIT_BAD_VALUE
    assert f"{kind} file" in line and str(path) in line and "not UTF-8 text (byte 11" in line


@pytest.mark.parametrize("kind", ["vehicle", "sweep"])
def test_deep_nesting_is_exit_3_naming_the_file(tmp_path, capsys, kind):
    path = tmp_path / f"{kind}.toml"
    path.write_text("a = " + "[" * 5000 + "]" * 5000 + "\n")
    args = (["advise", "--vehicle", str(path)] if kind == "vehicle"
            else ["sweep", str(path), "--store", str(tmp_path / "s.db")])  # fmt: skip
    code, line = _status(args, capsys)
    assert code == EXIT_BAD_VALUE and str(path) in line and "nested too deep" in line


def test_nesting_below_the_parsers_limit_is_still_bounded():
    text = "a = " + "[" * 100 + "]" * 100  # parses, but deeper than any sampledyn file
    with pytest.raises(FileContentError, match="deeper than 64 levels"):
        _files.parse_toml(text, "x.toml")
    with pytest.raises(FileContentError, match="nested too deep"):
        _files.parse_json("[" * 200_000 + "]" * 200_000, "message")
    with pytest.raises(FileContentError, match="integer too long to read"):
        _files.parse_toml("a = 1" + "0" * 5000, "x.toml")


# -- logs in chunks -------------------------------------------------------------------


@pytest.fixture(scope="module")
def long_log(tmp_path_factory) -> Path:
    """The example log repeated to 40,000 rows (t continued), written once."""
    frame = pd.read_csv(EXAMPLE_LOG)
    reps = 100
    h = float(frame["t[s]"].iloc[1] - frame["t[s]"].iloc[0])
    big = pd.concat([frame] * reps, ignore_index=True)
    big["t[s]"] = np.round(np.arange(len(big)) * h, 6)
    path = tmp_path_factory.mktemp("long") / "long.csv"
    big.to_csv(path, index=False)
    return path


def test_a_log_read_in_chunks_equals_it_read_whole(long_log, heavy, monkeypatch):
    import sampledyn.logs._read as reader

    whole = log_from_frame(pd.read_csv(long_log, dtype={"t[s]": str}), heavy, csv=True)
    monkeypatch.setattr(reader, "CHUNK_ROWS", 997)  # many chunks, none aligned to anything
    chunked = read_log(long_log, heavy)
    for name in ("t", "x", "u"):
        np.testing.assert_array_equal(getattr(chunked.traj, name), getattr(whole.traj, name))
    assert chunked.notes == whole.notes and chunked.traj.origin == whole.traj.origin
    np.testing.assert_array_equal(chunked.rows, whole.rows)


def test_nan_rows_at_the_ends_and_inside_are_handled_across_chunks(long_log, heavy, tmp_path,
                                                                  monkeypatch):  # fmt: skip
    import sampledyn.logs._read as reader

    frame = pd.read_csv(long_log, dtype={"t[s]": str})
    frame.loc[:2500, "p[deg/s]"] = np.nan  # a leading stretch longer than chunks
    frame.loc[20_000, "x[m]"] = np.nan  # inside
    frame.loc[len(frame) - 1500 :, "n3[rpm]"] = np.nan  # a trailing stretch
    path = tmp_path / "holes.csv"
    frame.to_csv(path, index=False)
    whole = log_from_frame(frame, heavy, csv=True, nan="drop")
    monkeypatch.setattr(reader, "CHUNK_ROWS", 1000)
    chunked = read_log(path, heavy, nan="drop")
    assert chunked.notes == whole.notes
    assert "2501 rows with NaN at the ends" not in chunked.notes  # both ends: one number
    np.testing.assert_array_equal(chunked.traj.x, whole.traj.x)
    np.testing.assert_array_equal(chunked.valid, whole.valid)
    assert chunked.rows[0] == 2501 and chunked.rows[-1] == len(frame) - 1501
    with pytest.raises(LogFormatError, match=r"is NaN at data row 1 \(line 2\) \(4002 rows"):
        read_log(path, heavy)


def test_reading_a_log_keeps_memory_near_its_arrays(long_log, heavy):
    """traced peak (numpy and Python allocations) of a chunked read, over the bytes of
    the arrays kept: bounded by 2 (what benchmarks/bench_log_memory.py measures at 10
    million rows, as RSS)."""
    read_log(long_log, heavy)  # imports and caches first
    tracemalloc.start()
    data = read_log(long_log, heavy)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    tr = data.traj
    kept = tr.t.nbytes + tr.x.nbytes + tr.u.nbytes + data.valid.nbytes + data.rows.nbytes
    assert peak < 2 * kept + 24e6  # + one chunk of text and frames (65,536 rows)


def test_exact_decimal_stamps_survive_chunks_of_different_precision(heavy, tmp_path,
                                                                    monkeypatch):  # fmt: skip
    import sampledyn.logs._read as reader

    frame = pd.read_csv(EXAMPLE_LOG)
    n = len(frame)
    stamps = [f"{1_700_000_000 + k // 10}.{k % 10}" for k in range(n)]  # 0.1 s, 1 decimal
    stamps[-3:] = [f"{1_700_000_000 + k // 10}.{k % 10}00000000" for k in range(n - 3, n)]
    frame["t[s]"] = stamps
    path = tmp_path / "unix.csv"
    frame.to_csv(path, index=False)
    monkeypatch.setattr(reader, "CHUNK_ROWS", 50)
    data = read_log(path, heavy)
    assert "decimal text in s (read exactly)" in "\n".join(data.notes)
    assert data.traj.origin.startswith("1700000000.0 s")
    np.testing.assert_allclose(np.diff(data.traj.t), 0.1, rtol=1e-12)


# -- DataFlash ------------------------------------------------------------------------


def test_a_dataflash_fmt_of_length_0_is_refused_before_pymavlink_loops(tmp_path):
    pytest.importorskip("pymavlink")
    sys.path.insert(0, str(ROOT / "tests"))
    from _ardusub_fixtures import BenchRun

    log = BenchRun().write(tmp_path / "bad.BIN")
    data = bytearray(log.read_bytes())
    at = data.find(b"\xa3\x95\x80")
    data[at + 4] = 0  # the first FMT record's Length
    log.write_bytes(bytes(data))
    bluerov2 = sd.models.load_vehicle("bluerov2")
    with pytest.raises(LogFormatError, match=r"FMT record at byte 0 declares message \w+ .*0 "
                                             r"bytes long.*not read"):  # fmt: skip
        read_log(log, bluerov2, mapping=ROOT / "examples" / "ardusub_dataflash.toml")


# -- silently wrong, made loud ---------------------------------------------------------


def test_radians_under_deg_headers_are_said(heavy, tmp_path):
    frame = pd.read_csv(EXAMPLE_LOG)
    good = evaluate_log(heavy, read_log(EXAMPLE_LOG, heavy), ["E"], norm="rms", after=2.0)
    assert not any("as fast as the logged rates" in w for w in good.warnings)
    for col in ("phi[deg]", "theta[deg]", "psi[deg]"):
        frame[col] = np.radians(frame[col])
    path = tmp_path / "rad.csv"
    frame.to_csv(path, index=False)
    result = evaluate_log(heavy, read_log(path, heavy), ["E"], norm="rms", after=2.0)
    said = [w for w in result.warnings if "as fast as the logged rates" in w]
    assert said and all("rad under a [deg] header" in w for w in said)
    assert any(w.startswith("rad.csv: phi changes 0.01") for w in said)  # 1/57.3 = 0.0175


def test_a_trajectory_whose_h_is_not_its_spacing_is_refused():
    t = np.arange(100) * 0.01
    kw = {"x": np.zeros((100, 1)), "u": np.zeros((100, 1)), "state_names": ("a",),
          "state_units": ("m",)}  # fmt: skip
    with pytest.raises(ValueError, match=r"`h` = 0.1 s disagrees with the spacing of `t`, 0.01"):
        sd.Trajectory(t=t, h=0.1, **kw)
    jittered = t + 1e-4 * (np.arange(100) % 3)
    sd.Trajectory(t=jittered, h=0.01, **kw)  # a nominal period: accepted
    with pytest.raises(ValueError, match=r"median step 0.01"):
        sd.Trajectory(t=jittered, h=0.05, **kw)


def test_tustins_discrete_step_raises_where_predict_does():
    model = sd.models.AUVLike()
    dm = sd.discretize(model, "T", 1.0)
    with pytest.raises(sd.exceptions.ConvergenceError, match=r"T: the step from t = 0 s .* not "
                                                          r"finite"):  # fmt: skip
        dm.step(np.array([1.0, 100.0]), np.array([0.0]))
    z = dm.step(np.array([1.0, 0.1]), np.array([0.0]))  # a step Newton solves: numbers
    assert np.isfinite(z).all()


@pytest.mark.parametrize("pct", [1e308, 1001.0])
def test_noise_levels_beyond_the_motion_are_refused(pct):
    from sampledyn._noise import noise_amplitudes

    with pytest.raises(ValueError, match=r"above 1000 %"):
        noise_amplitudes(("m", "m/s"), pct, 0.0)


def test_a_mapping_names_message_fields_only(tmp_path):
    pytest.importorskip("rosbags")
    from sampledyn.logs._ros import _field

    class _Msg:
        __dataclass_fields__ = {"x": None, "__msgtype__": None}
        x = 1.0
        __msgtype__ = "std_msgs/msg/Float64"

    assert _field(_Msg(), "x", "/t") == 1.0
    for path in ("__class__.__mro__", "__init__", "__msgtype__"):
        with pytest.raises(LogFormatError, match=r"have no field .* is not among x"):
            _field(_Msg(), path, "/t")
