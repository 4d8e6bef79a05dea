"""Irregular logs by choice (issue 20, item 6), the T200 table between its voltages,
and the one format table that read_log dispatches through."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import sampledyn as sd
from sampledyn.cli import main
from sampledyn.exceptions import LogFormatError
from sampledyn.logs import LOG_FORMATS, detect_format, read_log
from sampledyn.logs._synthetic import survey_input
from sampledyn.logs._t200 import T200_PWM_US, _table, t200_deadband, t200_rpm

ROOT = Path(__file__).resolve().parents[2]


def _irregular_csv(path: Path) -> Path:
    """An exact BlueROV2 Heavy run sampled at steps from 0.01 to 0.34 s (a state
    estimator's output, as the AUV pool log of the issue)."""
    vehicle = sd.models.load_vehicle("bluerov2_heavy")
    rng = np.random.default_rng(3)
    t = np.concatenate([[0.0], np.cumsum(np.rint(rng.uniform(1, 34, 60)) * 0.01)])
    T = 0.01 * (round(t[-1] / 0.01) + 1)
    traj = sd.simulate(vehicle, survey_input(vehicle), T=T, h=0.01)
    # the samples at the irregular stamps, from the exact run on a 0.01 s grid
    idx = np.rint(t / 0.01).astype(int)
    cols = {"t[s]": traj.t[idx]}
    for k, (n, u) in enumerate(zip(traj.state_names, traj.state_units, strict=True)):
        cols[f"{n}[{u}]"] = traj.x[idx, k]
    for j, n in enumerate(traj.input_names):
        cols[f"{n}[rpm]"] = traj.u[idx, j]
    import pandas as pd

    pd.DataFrame(cols).to_csv(path, index=False)
    return path


def test_an_irregular_log_is_refused_naming_the_option(tmp_path):
    log = _irregular_csv(tmp_path / "pool.csv")
    vehicle = sd.models.load_vehicle("bluerov2_heavy")
    with pytest.raises(
        LogFormatError, match=r"accept irregular steps \(`irregular`=True, --irregular"
    ):
        read_log(log, vehicle)


def test_an_irregular_log_is_predicted_on_its_stamps(tmp_path, capsys):
    log = _irregular_csv(tmp_path / "pool.csv")
    vehicle = sd.models.load_vehicle("bluerov2_heavy")
    data = read_log(log, vehicle, irregular=True)
    steps = np.diff(data.traj.t)
    assert steps.min() < 0.02 and steps.max() > 0.3 and data.sampling.gaps == ()
    assert "sampling: irregular, accepted (irregular=True, --irregular)" in "\n".join(data.notes)
    code = main(
        [
            "evaluate",
            "--data",
            str(log),
            "--vehicle",
            "bluerov2_heavy",
            "--irregular",
            "--methods",
            "E,AB2,RK4",
        ]
    )
    out = capsys.readouterr().out
    assert code == 0
    assert "noise gain / (h L) on the logged steps" in out
    # AB2's gain at the log's step ratio exceeds its uniform a_2 = 2
    gain = float(out.split("AB2 ")[1].split(" ")[0])
    assert gain > 2.0


def test_t200_between_measured_voltages_is_linear_in_the_voltage():
    pwm = T200_PWM_US
    np.testing.assert_allclose(
        t200_rpm(pwm, 17.0), 0.5 * (_table(16) + _table(18)), rtol=0, atol=1e-9
    )
    np.testing.assert_array_equal(t200_rpm(pwm, 18.0), _table(18))  # a measured supply: its table
    per_sample = t200_rpm(np.array([[1700.0], [1700.0]]), np.array([[16.0], [18.0]]))
    np.testing.assert_array_equal(per_sample[:, 0], [_table(16)[150], _table(18)[150]])
    assert t200_deadband(16) == (1472.0, 1528.0)
    with pytest.raises(ValueError, match=r"supply 21 V is outside the measured 10..20 V"):
        t200_rpm([1500], 21.0)


def test_every_format_is_detected_by_the_table(tmp_path):
    from _ardusub_fixtures import BenchRun, TelemetryRun

    pytest.importorskip("pymavlink")
    pytest.importorskip("mcap")
    files = {
        "dataflash": BenchRun().write(tmp_path / "a.bin"),
        "tlog": TelemetryRun().write_tlog(tmp_path / "a.tlog"),
        "blueos": TelemetryRun().write_blueos(tmp_path / "a.mcap"),
        "csv": ROOT / "examples" / "rov_log.csv",
    }
    for name, path in files.items():
        assert detect_format(path).name == name
    assert {f.name for f in LOG_FORMATS} >= {
        "csv",
        "parquet",
        "ros1",
        "ros2",
        "dataflash",
        "tlog",
        "blueos",
    }


def test_the_tlog_is_no_longer_read_as_csv_text(tmp_path):
    """Before the format table a .tlog went to the CSV reader ('utf-8' codec can't
    decode); now it is read as MAVLink, with the [mavlink] defaults when no mapping
    is given (a note says so)."""
    from _ardusub_fixtures import TelemetryRun

    pytest.importorskip("pymavlink")
    log = TelemetryRun().write_tlog(tmp_path / "a.tlog")
    data = read_log(log, sd.models.load_vehicle("bluerov2_heavy"))
    assert data.notes[0] == "MAVLink telemetry log (.tlog)"
    assert "every key of [mavlink] at its default" in data.notes[1]


@pytest.mark.slow
def test_real_logs_example_without_its_folder_exits_0(tmp_path):
    proc = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "real_logs.py"), str(tmp_path / "absent")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0 and "no real logs to evaluate" in proc.stdout
