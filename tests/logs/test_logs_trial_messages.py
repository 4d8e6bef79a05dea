"""What a new user met reading logs (the new-user trial, findings 4, 8-12, 16, 18, 19):
a missing or folder mapping is a file error, a file of no format read says which are
read and how they are recognised, an empty CSV says it is empty, a mapping for another
log format says which section it has and which the log needs, the autopilot logs read
with their defaults without a mapping, missing inputs name the columns that look like
inputs, a period far below the model's time constant is warned about, the stable-h
legend comes with its marks only, and a damped mode is not called undamped."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import sampledyn as sd
from sampledyn.exceptions import LogFormatError
from sampledyn.logs import evaluate_log, read_log
from sampledyn.sensitivity._stability import StabilityLimit

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
EXAMPLE_LOG = EXAMPLES / "rov_log.csv"


@pytest.fixture(scope="module")
def heavy():
    return sd.models.load_vehicle("bluerov2_heavy")


def test_a_missing_or_folder_mapping_is_a_file_error(heavy, tmp_path):
    with pytest.raises(FileNotFoundError, match="no mapping file there"):
        read_log(EXAMPLE_LOG, heavy, mapping=tmp_path / "nope.toml")
    with pytest.raises(IsADirectoryError, match="is a folder"):
        read_log(EXAMPLE_LOG, heavy, mapping=tmp_path)


def test_bytes_of_no_format_name_the_formats_and_how_they_are_recognised(heavy, tmp_path):
    junk = tmp_path / "junk.bin"
    junk.write_bytes(bytes(np.random.default_rng(1).integers(128, 256, 4000, dtype=np.uint8)))
    with pytest.raises(LogFormatError) as exc:
        read_log(junk, heavy)
    text = str(exc.value)
    assert "not UTF-8 text (byte 0" in text and "codec" not in text
    for said in ("0xA3 0x95", ".tlog", "MCAP", "metadata.yaml", ".bag", "CSV"):
        assert said in text, said


def test_an_empty_csv_says_it_is_empty(heavy, tmp_path):
    (tmp_path / "empty.csv").write_text("")
    with pytest.raises(LogFormatError, match=r"'.*empty.csv' is empty \(no header, no rows\)"):
        read_log(tmp_path / "empty.csv", heavy)


def test_missing_inputs_name_the_columns_that_look_like_inputs():
    with pytest.raises(LogFormatError) as exc:
        read_log(EXAMPLE_LOG, sd.models.AUVLike())
    text = str(exc.value)
    assert "the model has 1 input (u1 [m/s^2])" in text, text
    assert "its 8 numbered columns ('n1[rpm]'" in text and "'n8[rpm]')" in text, text
    assert "0 input columns" not in text


def _tlog(tmp_path: Path) -> Path:
    pytest.importorskip("pymavlink")
    from _ardusub_fixtures import TelemetryRun

    return TelemetryRun().write_tlog(tmp_path / "a.tlog")


def test_a_tlog_without_a_mapping_is_read_with_the_defaults_and_says_so(heavy, tmp_path):
    log = _tlog(tmp_path)
    plain = read_log(log, heavy)
    mapped = read_log(log, heavy, mapping=EXAMPLES / "ardusub_mavlink.toml")
    np.testing.assert_array_equal(plain.traj.x, mapped.traj.x)  # same code path, same run
    np.testing.assert_array_equal(plain.traj.u, mapped.traj.u)
    assert "no mapping file: every key of [mavlink] at its default" in plain.notes[1]
    assert not any("no mapping file" in n for n in mapped.notes)


def test_a_dataflash_log_without_a_mapping_is_read_with_the_defaults(heavy, tmp_path):
    pytest.importorskip("pymavlink")
    from _ardusub_fixtures import BenchRun

    six = sd.models.load_vehicle("bluerov2")
    log = BenchRun().write(tmp_path / "bench.BIN")
    plain = read_log(log, six)
    mapped = read_log(log, six, mapping=EXAMPLES / "ardusub_dataflash.toml")
    np.testing.assert_array_equal(plain.traj.x, mapped.traj.x)
    np.testing.assert_array_equal(plain.traj.u, mapped.traj.u)
    assert any("every key of [ardusub] at its default" in n for n in plain.notes)


def test_a_mapping_for_another_format_says_which_section_it_has_and_which_is_needed(
    heavy, tmp_path
):
    log = _tlog(tmp_path)
    mapping = EXAMPLES / "ardusub_dataflash.toml"
    with pytest.raises(LogFormatError) as exc:
        read_log(log, heavy, mapping=mapping)
    text = str(exc.value)
    assert f"mapping file {str(mapping)!r} has [ardusub]" in text, text
    assert "a .tlog needs [mavlink]" in text and "allowed" not in text, text


def test_a_period_far_below_the_time_constant_is_warned_about_naming_the_unit(heavy, tmp_path):
    from sampledyn.logs._evaluate import MIN_H_RATE

    frame = pd.read_csv(EXAMPLE_LOG)
    good = evaluate_log(heavy, read_log(EXAMPLE_LOG, heavy), ["E"])
    assert not any("below h/tau" in w for w in good.warnings)
    frame.rename(columns={"t[s]": "t[ms]"}).to_csv(tmp_path / "ms.csv", index=False)
    ev = evaluate_log(heavy, read_log(tmp_path / "ms.csv", heavy), ["E", "RK4"])
    said = [w for w in ev.warnings if f"below h/tau = {MIN_H_RATE:g}" in w]
    assert len(said) == 1, ev.warnings
    assert "'t[ms]' read in ms" in said[0] and "label it t[s]" in said[0], said[0]


def test_the_stable_h_legend_comes_only_with_a_mark(heavy):
    data = read_log(EXAMPLE_LOG, heavy)
    stable = evaluate_log(heavy, data, ["T"])  # A-stable: no row beyond its limit
    assert all(r["stable"] is not False for r in stable.rows)
    assert "stable h:" not in stable.table()
    marked = evaluate_log(heavy, data, ["AB4"])  # h = 0.1 s beyond AB4's 0.069 s
    assert marked.row("AB4")["stable"] is False
    assert "stable h:" in marked.table()


@pytest.mark.parametrize(("lam", "kind"), [(-0.26 + 0j, "damped"), (1.5j, "undamped")])
def test_a_real_negative_eigenvalue_is_a_damped_mode(lam, kind):
    lim = StabilityLimit("AB28", 0.1, 0.0, lam, 1, 4.8, 12, 0)
    text = lim.message()
    assert f"on the {kind} mode" in text, text
    assert "or a shorter step avoids it" not in text  # none is short enough
