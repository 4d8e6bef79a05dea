"""Time as logged (issue 11, items 1-2): any clock gives the same evaluation as t from
0; jitter is kept, never snapped; dropped records are refused, bridged or split as the
policy says, nothing resampled; mapping files and thruster limits are checked
(issue 13, item 6)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import sampledyn as sd
from sampledyn.cli import main
from sampledyn.exceptions import LogFormatError
from sampledyn.logs import evaluate_log, log_from_frame, read_log

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "rov_log.csv"
METHODS = "E,AB2,AB4,RK4,T"


def _table(path, capsys, *extra):
    """The printed table of `sampledyn evaluate` (the lines after its heading)."""
    code = main(
        ["evaluate", "--data", str(path), "--vehicle", "bluerov2_heavy", "--methods", METHODS]
        + ["--after", "2", *extra]
    )
    assert code == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("method"))
    # the heading, its rule, the two baselines and a blank line, then the rules
    return lines[start : start + 5 + len(METHODS.split(","))], out


def _with_time(frame, column, values):
    out = frame.drop(columns="t[s]")
    out.insert(0, column, values)
    return out


def test_every_clock_gives_the_table_of_t_from_zero(frame, tmp_path, capsys):
    ref, _ = _table(EXAMPLE, capsys)
    k = np.arange(len(frame))
    assert np.allclose(frame["t[s]"], 0.1 * k)
    epoch_ns = 1_700_000_000_000_000_000 + 100_000_000 * k  # 10 Hz from 2023-11-14
    logs = {}
    # Unix seconds printed with 9 decimals (as ROS exports do), read exactly
    logs["epoch_s.csv"] = _with_time(
        frame, "t[s]", [f"{v // 10**9}.{v % 10**9:09d}" for v in epoch_ns]
    )
    logs["epoch_ns.csv"] = _with_time(frame, "t[ns]", epoch_ns)
    logs["counter_us.csv"] = _with_time(frame, "t[us]", 51_234_000 + 100_000 * k)
    stamps = pd.to_datetime(epoch_ns, unit="ns", utc=True)
    logs["datetime64.parquet"] = _with_time(frame, "t", stamps)
    zone = stamps.tz_convert("Europe/Berlin")  # +01:00 in November
    logs["iso.csv"] = _with_time(frame, "time", [s.isoformat() for s in zone])
    for name, table in logs.items():
        path = tmp_path / name
        if name.endswith(".parquet"):
            table.to_parquet(path, index=False)
        else:
            table.to_csv(path, index=False)
        got, out = _table(path, capsys)
        assert got == ref, name
        assert "sampling: uniform, h = 0.1 s\n" in out, name
    assert (
        "decimal text in s (read exactly); t = 0 at 1700000000.000000000 s"
        in _table(tmp_path / "epoch_s.csv", capsys)[1]
    )
    # the absolute start is kept
    data = read_log(tmp_path / "iso.csv", sd.models.load_vehicle("bluerov2_heavy"))
    assert data.traj.origin == "2023-11-14T22:13:20+00:00"
    assert data.traj.t[0] == 0.0 and data.traj.t[-1] == 40.0


def test_epoch_seconds_as_float64_are_uniform_to_their_resolution(vehicle, frame):
    k = np.arange(len(frame))
    t = 1.7e9 + 0.1 * k  # float64: 2.4e-7 s resolution at 1.7e9 s
    data = log_from_frame(_with_time(frame, "t[s]", t), vehicle)
    assert data.sampling is not None and data.sampling.uniform
    assert abs(data.traj.h - 0.1) < 1e-8
    assert data.traj.is_uniform()
    # The failure of issue 11 ("not uniformly sampled with h=0.10000000194627412 s:
    # t[2] - t[1] = 0.1 s") is gone: prediction accepts the log.
    rows = evaluate_log(vehicle, data, ["AB2"], after=2.0).rows
    assert np.isfinite(rows[0]["err_all"])


def test_a_datetime_column_never_passes_as_a_number(vehicle, frame):
    k = np.arange(len(frame))
    stamps = pd.to_datetime(1_700_000_000 * 10**9 + 10**8 * k, unit="ns")
    table = _with_time(frame, "t", stamps)
    with pytest.raises(LogFormatError, match=r"holds date-times \(datetime64\[ns\]\), not numbers"):
        log_from_frame(table, vehicle, mapping={"columns": {"t": {"unit": "s"}}})
    data = log_from_frame(table, vehicle, mapping={"columns": {"t": {"unit": "datetime"}}})
    assert data.traj.h == 0.1 and data.traj.origin.endswith("(no time zone)")


def test_iso_times_with_and_without_zone_are_refused(vehicle, frame):
    k = np.arange(len(frame))
    text = [f"2024-01-01T00:00:{v / 10:04.1f}" for v in k[:60]] + [
        f"2024-01-01T00:{6 + v // 600:02d}:{(v % 600) / 10:04.1f}Z" for v in k[60:] - 60
    ]
    with pytest.raises(LogFormatError, match="mixes ISO-8601 times with and without a time zone"):
        log_from_frame(_with_time(frame, "time", text), vehicle)


def _jittered(frame, amplitude=0.0005, seed=0):
    rng = np.random.default_rng(seed)
    t = 0.1 * np.arange(len(frame)) + rng.uniform(-amplitude, amplitude, len(frame))
    return _with_time(frame, "t[s]", t), t


def test_jitter_is_kept_as_logged_and_evaluate_names_it(vehicle, frame, tmp_path, capsys):
    table, t = _jittered(frame)
    data = log_from_frame(table, vehicle)
    np.testing.assert_array_equal(data.traj.t, t - t[0])  # the logged stamps, not a grid
    assert data.sampling is not None and not data.sampling.uniform
    assert 0.005 < data.jitter < 0.011 and abs(data.traj.h - 0.1) < 2e-4
    assert any("jittered" in n and "not snapped" in n for n in data.notes)
    # the rules predict on the logged stamps; a rule that cannot is refused by name
    result = evaluate_log(vehicle, data, ["AB4", "RK4"])
    assert result.notes[0].startswith("time base: the logged time stamps (jittered by up to")
    assert any(n.strip().startswith("AB4: Adams weights of the actual nodes") for n in result.notes)
    assert any(n.strip().startswith("RK4: step h_n") for n in result.notes)
    # the estimated rules too: their regressions use the weights of the actual nodes
    assert evaluate_log(vehicle, data, ["ABe2"]).estimation is not None
    table.to_csv(tmp_path / "jitter.csv", index=False)
    main(["evaluate", "--data", str(tmp_path / "jitter.csv"), "--vehicle", "bluerov2_heavy"])
    out = capsys.readouterr().out
    assert "time base: the logged time stamps" in out and "E, AB2, AB4: Adams weights" in out
    main(
        ["evaluate", "--data", str(tmp_path / "jitter.csv"), "--vehicle", "bluerov2_heavy"]
        + ["--estimate", "ABe2"]
    )
    assert "AB2 estimate, l_2 norm" in capsys.readouterr().out


def test_irregular_steps_are_refused(vehicle, frame):
    table, _ = _jittered(frame, amplitude=0.02)  # steps up to 40 % off
    with pytest.raises(LogFormatError, match=r"not within 25\.00% of a whole number of periods"):
        log_from_frame(table, vehicle)
    assert log_from_frame(table, vehicle, time_tolerance=0.45).jitter > 0.25


@pytest.fixture(scope="module")
def dropped(frame):
    """The example log with 1 record dropped at row 100 and 3 at rows 250-252."""
    return frame.drop(index=[100, 250, 251, 252]).reset_index(drop=True)


def test_dropped_records_are_refused_by_default(vehicle, dropped):
    with pytest.raises(
        LogFormatError,
        match=r"1 record missing between data row 100 and data row 101 \(t = 9\.9 s to "
        r"10\.1 s\) and 1 more gap\(s\), 4 in all\. Nothing is resampled",
    ):
        log_from_frame(dropped, vehicle)


def test_bridging_keeps_the_logged_samples_and_times(vehicle, frame, dropped):
    with pytest.raises(LogFormatError, match=r"3 records missing .* more than `max_missing` = 1"):
        log_from_frame(dropped, vehicle, gaps="bridge")
    data = log_from_frame(dropped, vehicle, gaps="bridge", max_missing=3)
    assert data.traj.n_samples == len(frame) - 4
    np.testing.assert_allclose(data.traj.t, dropped["t[s]"], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(data.traj.u, dropped[[f"n{i}[rpm]" for i in range(1, 9)]])
    np.testing.assert_allclose(data.traj.x[:, 0], dropped["x[m]"], rtol=0, atol=0)
    assert data.sampling is not None and data.sampling.gaps == ((99, 1), (248, 3))
    assert any(n.startswith("gaps: bridged 2 gap(s)") for n in data.notes)
    # evaluated on the logged times: the sample after a gap is predicted over its step
    result = evaluate_log(vehicle, data, ["E"])
    assert "2 bridged gap(s)" in result.notes[0] and "steps 0.1..0.4 s" in result.notes[0]


def test_split_evaluates_each_segment_on_its_own(vehicle, frame, dropped, tmp_path, capsys):
    data = log_from_frame(dropped, vehicle, gaps="split")
    assert data.segments == ((0, 100), (100, 249), (249, 397))
    np.testing.assert_allclose(data.traj.t, dropped["t[s]"], rtol=0, atol=1e-12)
    full = {r["method"]: r for r in evaluate_log(vehicle, data, ["E", "AB4"], baselines=False).rows}
    # the same numbers as the three segments evaluated as logs of their own
    total = {"E": [0, 0.0], "AB4": [0, 0.0]}
    for a, b in data.segments:
        seg = log_from_frame(dropped.iloc[a:b], vehicle)
        for r in evaluate_log(vehicle, seg, ["E", "AB4"], baselines=False).rows:
            total[r["method"]][0] += r["samples"]
            total[r["method"]][1] += r["samples"] * r["err_all"] ** 2
    for m, (n, ss) in total.items():
        assert full[m]["samples"] == n
        assert full[m]["err_all"] == pytest.approx(np.sqrt(ss / n), rel=1e-12)
    assert full["E"]["samples"] == len(dropped) - 3  # one start per segment
    dropped.to_csv(tmp_path / "dropped.csv", index=False)
    _, out = _table(tmp_path / "dropped.csv", capsys, "--gaps", "split")
    assert "gaps: split at 2 gap(s) of dropped records (4 missing" in out
    assert "into 3 segments of 100, 149, 148 samples" in out


@pytest.mark.parametrize(
    ("mapping", "message"),
    [
        (
            {"colums": {"x[m]": {"name": "x"}}},
            r"unknown section \[colums\] \(did you mean 'columns'",
        ),
        ({"columns": {"x[m]": {"nmae": "x"}}, "units": {}}, r"unknown key\(s\) in the top level"),
        (
            {"columns": {"x[m]": {"nmae": "x"}}},
            r"unknown key\(s\) in the entry for column 'x\[m\]': ",
        ),
        (
            {"columns": {"North": {"name": "x"}}},
            r"names column 'North'.*which the log does not have",
        ),
        ({"columns": {"x[m]": {"name": "xx"}}}, r"given the name 'xx' \(did you mean 'x'\?\)"),
    ],
)
def test_misspelt_mapping_files_are_errors(vehicle, frame, mapping, message):
    with pytest.raises(LogFormatError, match=message):
        log_from_frame(frame, vehicle, mapping=mapping)


def test_evaluate_warns_naming_the_rows_beyond_n_max(vehicle, frame):
    fast = frame.copy()
    fast.loc[10:12, "n3[rpm]"] = -5000.0
    fast.loc[40, "n1[rpm]"] = 3600.0
    result = evaluate_log(vehicle, log_from_frame(fast, vehicle), ["E"])
    (msg,) = [w for w in result.warnings if "limits" in w]
    assert re.search(
        r"logged inputs beyond the model's limits in 4 of 401 samples \(data rows 11-13, 41\); "
        r"largest: n_r3 = -5000 rpm, limits \[-3533, 3533\] rpm \(the vehicle's n_max\)",
        msg,
    ), msg
    clean = evaluate_log(vehicle, log_from_frame(frame, vehicle), ["E"])
    assert not any("limits" in w for w in clean.warnings)
