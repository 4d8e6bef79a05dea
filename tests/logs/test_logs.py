"""Real vehicle logs: validation (each malformed log is a clear error and writes
nothing), units, NaN policies, angle unwrapping, and ``sampledyn evaluate``."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from sampledyn.cli import main
from sampledyn.cli._status import EXIT_BAD_VALUE
from sampledyn.exceptions import LogFormatError
from sampledyn.logs import evaluate_log, read_log, synthetic_log

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "rov_log.csv"


def _errors(model, data, methods=("E", "AB2", "RK4")):
    return {r["method"]: r for r in evaluate_log(model, data, list(methods), after=2.0).rows}


def test_example_log_is_what_the_generator_makes(frame):
    assert 300 <= len(frame) <= 500
    fresh = synthetic_log()
    assert list(fresh.columns) == list(frame.columns)
    assert np.allclose(fresh.to_numpy(), frame.to_numpy(), rtol=1e-6, atol=1e-9)
    psi = frame["psi[deg]"].to_numpy()
    assert psi.max() < 180 and psi.min() >= -180 and np.abs(np.diff(psi)).max() > 300  # wraps


def test_example_log_reads_in_model_units_with_heading_unwrapped(vehicle):
    data = read_log(EXAMPLE, vehicle)
    tr = data.traj
    assert tr.n_samples == 401 and math.isclose(tr.h, 0.1)
    assert "psi unwrapped" in data.notes
    assert np.abs(np.diff(tr.x[:, 5])).max() < 0.2  # rad, no 2 pi jump left
    assert tr.x[-1, 5] > 2 * math.pi  # more than a full turn
    raw = pd.read_csv(EXAMPLE)
    assert np.allclose(tr.x[:, 3], np.radians(raw["phi[deg]"]))
    assert np.allclose(tr.u, raw[[f"n{i}[rpm]" for i in range(1, 9)]].to_numpy())


def test_without_unwrapping_every_predictor_fails_at_the_wrap(vehicle):
    good = _errors(vehicle, read_log(EXAMPLE, vehicle))
    bad = _errors(vehicle, read_log(EXAMPLE, vehicle, unwrap=False))
    assert bad["AB2"]["err_eta"] > 10 * good["AB2"]["err_eta"]


def test_units_are_converted_and_parquet_reads_like_csv(vehicle, frame, tmp_path):
    ref = _errors(vehicle, read_log(EXAMPLE, vehicle))
    other = frame.rename(columns={"x[m]": "x[cm]", "u[m/s]": "u[km/h]", "t[s]": "t[ms]"})
    other["x[cm]"] *= 100.0
    other["u[km/h]"] *= 3.6
    other["t[ms]"] *= 1000.0
    other.to_parquet(tmp_path / "log.parquet", index=False)
    data = read_log(tmp_path / "log.parquet", vehicle)
    assert any("x[cm] (cm -> m)" in n for n in data.notes)
    got = _errors(vehicle, data)
    for m in ref:
        assert got[m]["err_all"] == pytest.approx(ref[m]["err_all"], rel=1e-9)


def test_a_mapping_file_names_and_units_columns(vehicle, frame, tmp_path):
    renamed = frame.rename(columns={"t[s]": "time_ms", "x[m]": "North", "n1[rpm]": "motor 1"})
    renamed["time_ms"] *= 1000.0
    renamed.to_csv(tmp_path / "log.csv", index=False)
    (tmp_path / "map.toml").write_text(
        '[columns]\ntime_ms = { name = "t", unit = "ms" }\nNorth = { name = "x", unit = "m" }\n'
        '"motor 1" = { name = "n1", unit = "rpm" }\n'
    )
    data = read_log(tmp_path / "log.csv", vehicle, mapping=tmp_path / "map.toml")
    ref = read_log(EXAMPLE, vehicle)
    assert np.allclose(data.traj.x, ref.traj.x) and np.allclose(data.traj.u, ref.traj.u)


def test_jitter_within_the_tolerance_is_accepted(vehicle, frame, tmp_path):
    jittered = frame.copy()
    rng = np.random.default_rng(0)
    jittered["t[s]"] += rng.uniform(-0.002, 0.002, len(frame))  # 2 % of h peak-to-peak
    jittered.to_csv(tmp_path / "log.csv", index=False)
    data = read_log(tmp_path / "log.csv", vehicle, time_tolerance=0.05)
    assert 0.01 < data.jitter < 0.05
    with pytest.raises(LogFormatError, match="not uniformly sampled"):
        read_log(tmp_path / "log.csv", vehicle, time_tolerance=0.01)


def test_nan_policies(vehicle, frame, tmp_path):
    holed = frame.copy()
    holed.loc[100, "u[m/s]"] = np.nan
    holed.loc[0, "p[deg/s]"] = np.nan  # at the start: trimmed
    holed.to_csv(tmp_path / "log.csv", index=False)
    with pytest.raises(LogFormatError, match=r"'p\[deg/s\]' is NaN at data row 1 \(line 2\)"):
        read_log(tmp_path / "log.csv", vehicle)
    interp = read_log(tmp_path / "log.csv", vehicle, nan="interpolate")
    assert interp.traj.n_samples == 400 and interp.valid.all()
    assert interp.traj.x[99, 6] == pytest.approx(
        0.5 * (frame.loc[99, "u[m/s]"] + frame.loc[101, "u[m/s]"])
    )
    dropped = read_log(tmp_path / "log.csv", vehicle, nan="drop")
    assert dropped.traj.n_samples == 400 and (~dropped.valid).sum() == 1
    full = _errors(vehicle, interp, ("E", "AB4"))
    part = _errors(vehicle, dropped, ("E", "AB4"))
    # the NaN sample is neither a target nor in the history of a counted prediction
    assert full["E"]["samples"] - part["E"]["samples"] == 2
    assert full["AB4"]["samples"] - part["AB4"]["samples"] == 5


def _malformed(frame: pd.DataFrame, case: str) -> pd.DataFrame:
    f = frame.copy()
    if case == "non-monotonic":
        f.loc[[50, 51], "t[s]"] = f.loc[[51, 50], "t[s]"].to_numpy()
    elif case == "gap":
        f = f.drop(index=range(200, 203))
    elif case == "nan":
        f.loc[30, "x[m]"] = np.nan
    elif case == "nan-time":
        f.loc[7, "t[s]"] = np.nan
    elif case == "missing":
        f = f.drop(columns="q[deg/s]")
    elif case == "unknown-unit":
        f = f.rename(columns={"x[m]": "x[furlong]"})
    elif case == "wrong-kind":
        f = f.rename(columns={"x[m]": "x[deg]"})
    elif case == "deg-as-rad":
        f = f.rename(columns={"theta[deg]": "theta[rad]"})
    elif case == "no-unit":
        f = f.rename(columns={"y[m]": "y"})
    return f


MALFORMED = {
    "non-monotonic": r"not strictly increasing at data row 52 \(line 53\)",
    "gap": r"dropped records: 3 records missing between data row 200 \(line 201\) and data "
    r"row 201 \(line 202\) \(t = 19\.9 s to 20\.3 s\)\. Nothing is resampled.*--gaps",
    "nan": r"column 'x\[m\]' is NaN at data row 31 \(line 32\).*--nan",
    "nan-time": r"t is NaN or inf at data row 8 \(line 9\)",
    "missing": r"missing column 'q'",
    "unknown-unit": r"column 'x\[furlong\]': unknown unit 'furlong' for x \(a length\)",
    "wrong-kind": r"column 'x\[deg\]': unit 'deg' is an angle, but x is a length",
    "deg-as-rad": r"column 'theta\[rad\]'.*is the column in deg, not rad\?",
    "no-unit": r"column 'y' \(y\) has no unit",
}


@pytest.mark.parametrize("case", sorted(MALFORMED))
def test_malformed_logs_are_clear_errors_and_write_nothing(frame, tmp_path, capsys, case):
    log = tmp_path / "log.csv"
    _malformed(frame, case).to_csv(log, index=False)
    out = tmp_path / "table.csv"
    with pytest.raises(SystemExit) as exc:
        main(["evaluate", "--data", str(log), "--vehicle", "bluerov2_heavy", "--out", str(out)])
    assert exc.value.code == EXIT_BAD_VALUE
    err = capsys.readouterr().err
    assert err.startswith("sampledyn: error: log.csv: ")
    import re

    assert re.search(MALFORMED[case], err), err
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["log.csv"]


def test_evaluate_cli_prints_the_table_and_estimates(tmp_path, capsys):
    out = tmp_path / "table.csv"
    code = main(
        [
            "evaluate",
            "--data",
            str(EXAMPLE),
            "--vehicle",
            "bluerov2_heavy",
            "--methods",
            "E,AB2,AB4,RK4,T",
            "--estimate",
            "ABe2",
            "--after",
            "2",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    text = capsys.readouterr().out
    for name in ("E ", "AB2", "AB4", "RK4", "T ", "ABe2", "psi unwrapped", "AB2 estimate"):
        assert name in text
    table = {r["method"]: r for r in csv.DictReader(out.open())}
    assert list(table) == ["hold", "kinematics", "E", "AB2", "AB4", "RK4", "T", "ABe2"]
    # the estimated model fits its own one-step errors at least as well as the file's
    assert float(table["ABe2"]["err_v"]) <= float(table["AB2"]["err_v"])
