"""What ``evaluate`` checks before it predicts on a log: a sampling period far beyond
the model's fastest rate (a time column in the wrong unit), input columns the vehicle
has no thruster for (or too few), logs too short for a rule, a non-finite ``after``;
and a singular pitch that a rule formed between samples is told from one in the data."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from _log_fixtures import vehicle_without

import sampledyn as sd
from sampledyn.cli import main
from sampledyn.cli._status import EXIT_BAD_VALUE
from sampledyn.exceptions import LogFormatError, SingularPitchError
from sampledyn.logs import evaluate_log, read_log
from sampledyn.logs._evaluate import MAX_H_RATE

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "rov_log.csv"


def _evaluate_cli(log, vehicle="bluerov2_heavy", *extra):
    return main(["evaluate", "--data", str(log), "--vehicle", str(vehicle), "--quiet", *extra])


def _refused(capsys, log, vehicle="bluerov2_heavy", *extra) -> str:
    with pytest.raises(SystemExit) as exc:
        _evaluate_cli(log, vehicle, *extra)
    assert exc.value.code == EXIT_BAD_VALUE
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0, err  # one line
    return err


# -- 1. the sampling period against the model's fastest rate ---------------------------


@pytest.mark.parametrize(
    ("label", "scale", "h", "fix"),
    [("t[s]", 1000.0, 100.0, "t[ms]"), ("t[min]", 1.0, 6.0, "t[s]")],
    ids=["ms-labelled-s", "s-labelled-min"],
)
def test_a_time_column_in_the_wrong_unit_is_refused_with_the_fix(
    vehicle, frame, tmp_path, capsys, label, scale, h, fix
):
    log = tmp_path / "log.csv"
    f = frame.rename(columns={"t[s]": label})
    f[label] = f[label] * scale
    f.to_csv(log, index=False)
    data = read_log(log, vehicle)
    assert math.isclose(data.traj.h, h)
    with pytest.raises(LogFormatError) as exc:
        evaluate_log(vehicle, data, ["E", "AB2"])
    assert exc.value.argument == label
    msg = str(exc.value)
    assert f"h = {h:g} s (time column {label!r} read in {label[2:-1]})" in msg
    assert f"label it {fix}" in msg
    # the fastest time constant is the model's on the logged states (the time unit does
    # not enter the Jacobian), so h / tau scales with the mislabelled h
    tau = sd.sensitivity.fastest_time_constant(vehicle, data.traj)
    assert f"is {h / tau:.3g} times" in msg and h / tau > MAX_H_RATE
    # the command line says the same in one line, before predicting
    err = _refused(capsys, log, "bluerov2_heavy", "--methods", "E,AB2")
    assert err.startswith("sampledyn: error: log.csv: sampling period") and f"{fix}" in err
    # the check can be turned off: then the (meaningless) errors are computed
    row = evaluate_log(vehicle, data, ["E"], max_h_rate=math.inf).row("E")
    assert row["err_all"] > 1.0


def test_a_plausible_period_passes_and_is_reported(vehicle):
    data = read_log(EXAMPLE, vehicle)
    notes = evaluate_log(vehicle, data, ["E"]).notes
    tau = sd.sensitivity.fastest_time_constant(vehicle, data.traj)
    assert 0.2 < tau < 0.3  # s, the BlueROV2 Heavy on the example's motion
    assert any(f"h / tau = {0.1 / tau:.3g}" in n for n in notes), notes


def _pitch_spike(vehicle, k: int, theta_deg: float, q: float):
    """The example log with sample k at pitch ``theta_deg``, zero roll and yaw rate,
    and pitch rate ``q`` (rad/s): theta' = q there."""
    tr = read_log(EXAMPLE, vehicle).traj
    x = tr.x.copy()
    x[k, 3], x[k, 4], x[k, 9], x[k, 10], x[k, 11] = 0.0, math.radians(theta_deg), 0.0, q, 0.0
    return tr.replace(x=x)


def test_a_singular_pitch_a_rule_formed_names_the_rule_and_the_sample(vehicle):
    k, h = 120, 0.1
    # RK4's second stage x_k + h/2 k_1 lands at theta = 75 + 15 = 90 deg
    tr = _pitch_spike(vehicle, k, 75.0, math.radians(15.0) / (h / 2))
    sd.predict("E", vehicle, tr)  # Euler forms no state between samples: no error
    with pytest.raises(SingularPitchError) as exc:
        sd.predict("RK4", vehicle, tr)
    msg = str(exc.value)
    assert msg.startswith(f"RK4's prediction of sample {k + 1} (t = {tr.t[k + 1]:g} s, over a "
                          f"step of 0.1 s from sample {k})"), msg  # fmt: skip
    assert "The measured states are clear of it" in msg and "use a smaller h" in msg
    assert exc.value.sample == k + 1
    assert abs(abs(math.degrees(exc.value.theta)) - 90.0) < 0.5


def test_a_singular_pitch_in_the_data_is_said_to_be_in_the_data(vehicle):
    tr = _pitch_spike(vehicle, 7, 89.9, 0.0)
    with pytest.raises(SingularPitchError, match=r"^`measured` \(the data, not a prediction\): "
                       r"pitch angle theta = 89.9 deg \(sample 7\)"):  # fmt: skip
        sd.predict("RK4", vehicle, tr)


# -- 2. input columns against the vehicle's thrusters -----------------------------------


def test_thruster_columns_the_vehicle_does_not_have_are_refused(vehicle, tmp_path, capsys):
    six = vehicle_without(tmp_path)
    err = _refused(capsys, EXAMPLE, six)
    assert re.search(
        r"column\(s\) 'n7\[rpm\]', 'n8\[rpm\]' look like inputs \(thrusters\) the model does "
        r"not have: vehicle '\w+' has 6 thrusters \(inputs n_r1\.\.n_r6\)",
        err,
    ), err


def test_thruster_columns_of_thrusters_that_were_off_are_left_out_with_a_note(
    vehicle, frame, tmp_path
):
    six = sd.models.load_vehicle(vehicle_without(tmp_path))
    f = frame.copy()
    f["n7[rpm]"] = 0.0
    f["n8[rpm]"] = 0.0
    f.to_csv(tmp_path / "log.csv", index=False)
    data = read_log(tmp_path / "log.csv", six)
    assert data.traj.nu == 6
    assert any("'n7[rpm]', 'n8[rpm]' are 0 throughout" in n for n in data.notes), data.notes
    f.loc[5, "n8[rpm]"] = 100.0  # one sample that is not off is enough to refuse
    f.to_csv(tmp_path / "log.csv", index=False)
    with pytest.raises(LogFormatError, match=r"column\(s\) 'n8\[rpm\]' look like inputs"):
        read_log(tmp_path / "log.csv", six)


def test_too_few_thruster_columns_name_the_vehicles_count(frame, tmp_path, capsys):
    frame.drop(columns=["n7[rpm]", "n8[rpm]"]).to_csv(tmp_path / "log.csv", index=False)
    err = _refused(capsys, tmp_path / "log.csv")
    assert "missing input column 'n_r7' or 'u7' or 'n7' (and 1 more): vehicle " in err
    assert "has 8 thrusters (inputs n_r1..n_r8), the log has 6 input columns" in err


def test_a_mapping_file_cannot_map_a_column_to_a_thruster_the_vehicle_lacks(frame, tmp_path):
    six = sd.models.load_vehicle(vehicle_without(tmp_path))
    f = frame.rename(columns={f"n{i}[rpm]": f"thr{i}" for i in range(1, 9)})
    f.to_csv(tmp_path / "log.csv", index=False)
    (tmp_path / "map.toml").write_text(
        "".join(f'[columns.thr{i}]\nname = "n{i}"\nunit = "rpm"\n' for i in range(1, 9))
    )
    with pytest.raises(LogFormatError, match=r"column 'thr7' is given the name 'n7'"):
        read_log(tmp_path / "log.csv", six, mapping=tmp_path / "map.toml")


# -- 3. logs too short -----------------------------------------------------------------


@pytest.mark.parametrize(
    ("rows", "methods", "message"),
    [
        (0, "E", r"log\.csv: the log has no data rows \(a header only\)"),
        (1, "E", r"log\.csv: the log has 1 sample with data; at least 3 are needed"),
        (2, "E", r"log\.csv: the log has 2 samples with data; at least 3 are needed"),
        (
            3,
            "E,AB4",
            r"log\.csv: the log has 3 samples; AB4 needs at least 5 for one "
            r"prediction \(4 before the sample it predicts\)",
        ),  # fmt: skip
        (4, "AB4", r"the log has 4 samples; AB4 needs at least 5"),
    ],
)
def test_a_log_too_short_says_so(frame, tmp_path, capsys, rows, methods, message):
    frame.iloc[:rows].to_csv(tmp_path / "log.csv", index=False)
    err = _refused(capsys, tmp_path / "log.csv", "bluerov2_heavy", "--methods", methods)
    assert re.search(message, err), err


def test_a_log_just_long_enough_gives_one_prediction(vehicle, frame, tmp_path):
    frame.iloc[:5].to_csv(tmp_path / "log.csv", index=False)
    result = evaluate_log(vehicle, read_log(tmp_path / "log.csv", vehicle), ["AB4"])
    assert result.row("AB4")["samples"] == 1


# -- 4. after --------------------------------------------------------------------------


@pytest.mark.parametrize("after", ["nan", "inf", "-inf"])
def test_a_non_finite_after_is_refused(vehicle, capsys, after):
    log = EXAMPLE
    err = _refused(capsys, log, "bluerov2_heavy", f"--after={after}")
    assert err == (
        f"sampledyn: error: `--after` must be a finite time in s (log time), got {after}; "
        "e.g. --after 2 counts the errors on t >= 2 s."
    )
    with pytest.raises(ValueError, match=r"`after` must be a finite time \(s\) or None"):
        evaluate_log(vehicle, read_log(log, vehicle), ["E"], after=float(after))


def test_no_prediction_without_after_does_not_blame_after():
    errors = np.full((4, 2), np.nan)
    with pytest.raises(ValueError, match=r"^no sample of the 4 has a prediction; lengthen"):
        sd.error_norm(errors, np.arange(4.0) * 0.1)


# -- the third trial: a period too short to be real, and a column named twice ----------


def test_seconds_labelled_ns_are_refused_with_the_fix(frame, tmp_path, capsys):
    log = tmp_path / "log.csv"
    frame.rename(columns={"t[s]": "t[ns]"}).to_csv(log, index=False)  # h = 0.1 ns
    err = _refused(capsys, log)
    assert "h = 1e-10 s (time column 't[ns]' read in ns) is below 1e-06 s" in err
    assert "label it t[s]" in err


def test_a_column_named_twice_is_refused_naming_both(frame, tmp_path, capsys):
    log = tmp_path / "log.csv"
    f = frame.copy()
    f.insert(0, "x[m] ", f["x[m]"] + 1000.0)  # the same name once stripped
    f.to_csv(log, index=False)
    text = log.read_text().replace("x[m] ,", "x[m],", 1)
    log.write_text(text)
    err = _refused(capsys, log)
    assert "'x[m]' (columns 1, 3) more than once" in err


def test_columns_the_model_does_not_use_are_named_in_the_notes(vehicle, frame, tmp_path):
    log = tmp_path / "log.csv"
    f = frame.copy()
    f["battery[V]"] = 15.8
    f["mode"] = "manual"
    f.to_csv(log, index=False)
    notes = read_log(log, vehicle).notes
    assert "columns not used by the model: battery[V], mode" in notes
    frame.to_csv(log, index=False)
    assert not any("not used" in n for n in read_log(log, vehicle).notes)


def test_iso_text_under_a_seconds_header_says_to_drop_the_unit(vehicle, frame, tmp_path, capsys):
    log = tmp_path / "log.csv"
    f = frame.copy()
    assert frame["t[s]"].max() < 60.0
    f["t[s]"] = [f"2024-05-02T10:00:{t:09.6f}+02:00" for t in frame["t[s]"]]
    f.to_csv(log, index=False)
    err = _refused(capsys, log)
    assert "column 't[s]' is not numeric" in err and "drop the unit ('t' in the header" in err
    f.rename(columns={"t[s]": "t"}).to_csv(log, index=False)
    assert read_log(log, vehicle).traj.h == pytest.approx(0.1)
