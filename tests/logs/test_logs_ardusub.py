"""ArduSub logs as they come off real vehicles (issue 20, items 1-3): a 6-thruster
DataFlash log read through the log's own parameters, with its disarmed stretch, its
estimator status, its depth, its battery voltage and its deadband; an older log
without instance fields; a QGroundControl .tlog and a BlueOS MCAP log on the vehicle's
own clock. The files are written by tests/_ardusub_fixtures.py."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import sampledyn as sd
from sampledyn.cli import main
from sampledyn.exceptions import LogFormatError
from sampledyn.logs import detect_format, read_log
from sampledyn.logs._t200 import t200_rpm

pytest.importorskip("pymavlink")

from _ardusub_fixtures import (  # noqa: E402  (after the optional extras are known)
    FORMATS_41,
    IMU,
    BenchRun,
    TelemetryRun,
    dataflash,
)

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
DATAFLASH = EXAMPLES / "ardusub_dataflash.toml"
MAVLINK = EXAMPLES / "ardusub_mavlink.toml"
# ArduSub's motor k pushes against the vehicle files' thruster T_k for a positive output
# (factors of AP_Motors6DOF against the vB22 directions; docs/logs.md "Signs")
GEOMETRIC = -1.0


@pytest.fixture(scope="module")
def bluerov2():
    return sd.models.load_vehicle("bluerov2")


def test_six_thruster_log_read_through_its_own_parameters(bluerov2, tmp_path):
    run = BenchRun()
    log = run.write(tmp_path / "00000001.BIN")
    data = read_log(log, bluerov2, mapping=DATAFLASH)
    notes = "\n".join(data.notes)
    # disarmed stretch left out and said: armed for the first 40 states, the first of
    # which has no command before it
    assert data.traj.n_samples == BenchRun.ARMED - 1
    assert "armed in 40 of 60 state samples" in notes and "20 samples left out" in notes
    assert "flight mode(s) while used: MANUAL" in notes
    # frame, motor map and directions from the parameters
    assert "frame: vectored (FRAME_CONFIG 1) from the log's parameters" in notes
    assert "MOT_n_DIRECTION -1, +1, +1, +1, +1, +1" in notes
    assert "outputs 7, 8, 9, 10, 11, 12, 13, 14 drive no motor (SERVOn_FUNCTION): skipped" in notes
    # the inputs: held outputs through the T200 table at the logged 17.4 V, signed
    t_us = run.t_us[1 : BenchRun.ARMED]
    signs = GEOMETRIC * np.array([-1, 1, 1, 1, 1, 1])
    volts = float(np.float32(17.4))  # BAT.Volt is a float32 field
    expected = signs * t200_rpm(run.held_pwm(t_us), volts)
    np.testing.assert_array_equal(data.traj.u, expected)
    assert "T200 table at 17.4 V (logged battery voltage, BAT.Volt)" in notes
    # 17.4 V lies between the 16 V and 18 V tables: 70 % of the way
    between = 0.3 * t200_rpm([1700], 16) + 0.7 * t200_rpm([1700], 18)
    np.testing.assert_allclose(t200_rpm([1700], 17.4), between, rtol=1e-15)
    assert "thruster commands lie in the T200 deadband 1472..1528 us" in notes
    # no horizontal position fix: x, y not counted, and said
    assert data.unmeasured == ("x", "y")
    assert "a valid horizontal position in 0 of 40 samples, constant-position mode in 40" in notes
    # on the bench: depth about 0 throughout
    assert any("recorded in air or at the surface" in w for w in data.warnings)


def test_six_thruster_log_evaluates_without_x_y(bluerov2, tmp_path, capsys):
    log = BenchRun().write(tmp_path / "bench.BIN")
    code = main(
        ["evaluate", "--data", str(log), "--vehicle", "bluerov2", "--mapping", str(DATAFLASH)]
    )
    out = capsys.readouterr().out
    assert code == 0
    assert "without x, y (not measured)" in out
    assert "warning: bench.BIN: the depth stays below 0.1 m throughout" in out


def test_x_y_count_again_with_a_position_fix_under_water(bluerov2, tmp_path):
    from _ardusub_fixtures import SS_GOOD, SS_NO_POSITION

    run = BenchRun(depth=2.0)
    recs = [(n, (v[0], v[1], SS_GOOD) if n == "XKF4" else v) for n, v in run.records()]
    assert any(n == "XKF4" for n, _ in recs) and SS_NO_POSITION != SS_GOOD
    log = tmp_path / "dive.BIN"
    log.write_bytes(dataflash(FORMATS_41, recs))
    data = read_log(log, bluerov2, mapping=DATAFLASH)
    assert data.unmeasured == () and data.warnings == ()


def test_the_heavy_refuses_a_six_thruster_log_naming_the_vehicle(tmp_path):
    log = BenchRun().write(tmp_path / "bench.BIN")
    heavy = sd.models.load_vehicle("bluerov2_heavy")
    with pytest.raises(
        LogFormatError, match=r"FRAME_CONFIG is 1 \(vectored, 6 motors\).*--vehicle bluerov2"
    ):
        read_log(log, heavy, mapping=DATAFLASH)


def test_old_log_without_instance_fields_reads_as_instance_0(bluerov2, tmp_path):
    run = BenchRun()
    log = run.write(tmp_path / "old.BIN", old=True)
    mapping = {"ardusub": {"states": "NKF1", "status": "NKF4", "thrusters": {"unit": "pwm"}}}
    data = read_log(log, bluerov2, mapping=mapping)
    notes = "\n".join(data.notes)
    assert "no instance field IMU.I, NKF1.C, NKF4.C (an older log): read as instance 0" in notes
    assert "arming: the log holds no arming record" in notes
    assert "battery: no BAT.Volt voltage in the log; T200 table at 16 V" in notes
    assert data.traj.n_samples == BenchRun.N - 1


def test_a_missing_field_names_message_field_record_and_time(bluerov2, tmp_path):
    formats = {**FORMATS_41, "IMU": ("QBff", "TimeUS,I,GyrX,GyrY")}
    recs = [(n, v[:4] if n == "IMU" else v) for n, v in BenchRun().records()]
    assert IMU[1].endswith("AccZ")
    log = tmp_path / "x.BIN"
    log.write_bytes(dataflash(formats, recs))
    with pytest.raises(
        LogFormatError, match=r"IMU record 1 \(TimeUS 30000000 us\) has no field 'GyrZ'"
    ):
        read_log(log, bluerov2, mapping=DATAFLASH)


@pytest.fixture(scope="module")
def heavy():
    return sd.models.load_vehicle("bluerov2_heavy")


def _check_telemetry(data, run, boot_ms):
    notes = "\n".join(data.notes)
    tr = data.traj
    # LOCAL_POSITION_NED at 5 Hz, armed 2..8 s: the vehicle's stamps, not the receive times
    assert tr.h == pytest.approx(0.2, abs=1e-12) and data.sampling.uniform
    assert "not the ground station's receive stamps" in notes
    assert (
        "messages of other components left out: 1/220 (GPS_INPUT 40); 255/190 (HEARTBEAT 10)"
        in notes
    )
    assert "frame: vectored_6dof (FRAME_CONFIG 2)" in notes
    assert (
        "estimator status (EKF_STATUS_REPORT flags): attitude, velocity and horizontal "
        "position valid" in notes
    )
    assert "T200 table at 16 V (logged battery voltage, SYS_STATUS voltage)" in notes
    # inputs: the SERVO_OUTPUT_RAW before each state stamp, signed per motor
    first_us = int(tr.origin.split()[0]) % (2**32 * 1000)
    sent = (first_us / 1000 - 3 - boot_ms) % 2**32 / 1000 + tr.t  # s: the run's time of each state
    t_cmd = np.array([k / 20 for k in range(int(run.SECONDS * 20)) if k % 10 == 7])
    stamp = t_cmd + 0.002  # SERVO_OUTPUT_RAW stamped 2 ms after its ATTITUDE's ms
    held_t = t_cmd[np.searchsorted(stamp, sent + 0.003, side="right") - 1]
    pwm = np.array([run.pwm(t) for t in held_t])
    signs = GEOMETRIC * np.array([-1, 1, 1, 1, 1, 1, 1, 1])
    np.testing.assert_allclose(tr.u, signs * t200_rpm(pwm, 16.0), rtol=0, atol=0)
    t_state = sent
    np.testing.assert_allclose(tr.x[:, 0], 0.1 * t_state, atol=1e-6)  # x = 0.1 t


def test_tlog_on_the_vehicle_clock_autopilot_only(heavy, tmp_path, capsys):
    run = TelemetryRun()
    log = run.write_tlog(tmp_path / "dive.tlog")
    assert detect_format(log).name == "tlog"
    data = read_log(log, heavy, mapping=MAVLINK)
    _check_telemetry(data, run, run.boot_ms)
    code = main(
        ["evaluate", "--data", str(log), "--vehicle", "bluerov2_heavy", "--mapping", str(MAVLINK)]
    )
    assert code == 0 and "RK4" in capsys.readouterr().out


def test_tlog_across_the_wrap_of_the_32_bit_clocks(heavy, tmp_path):
    boot = 2**32 - 4_000  # time_boot_ms wraps 4 s into the run; time_usec wraps too
    run = TelemetryRun(boot_ms=boot)
    data = read_log(run.write_tlog(tmp_path / "wrap.tlog"), heavy, mapping=MAVLINK)
    assert "a 32-bit clock wrap unwrapped" in "\n".join(data.notes)
    assert data.traj.h == pytest.approx(0.2, abs=1e-12) and data.sampling.uniform


def test_blueos_mcap_reads_as_the_tlog(heavy, tmp_path):
    pytest.importorskip("mcap")
    run = TelemetryRun()
    log = run.write_blueos(tmp_path / "dive.mcap")
    assert detect_format(log).name == "blueos"
    data = read_log(log, heavy, mapping=MAVLINK)
    assert "BlueOS MCAP log (mavlink/out)" in data.notes[0]
    _check_telemetry(data, run, run.boot_ms)
    tlog = read_log(run.write_tlog(tmp_path / "same.tlog"), heavy, mapping=MAVLINK)
    np.testing.assert_array_equal(data.traj.u, tlog.traj.u)
    np.testing.assert_allclose(data.traj.x, tlog.traj.x, rtol=0, atol=1e-6)  # float32 in the tlog


def test_a_disarmed_log_is_refused_naming_the_option(bluerov2, tmp_path):
    run = BenchRun()
    recs = [(n, v) for n, v in run.records() if n not in ("ARM", "EV")]
    t = int(run.T0 - 1)
    log = tmp_path / "off.BIN"
    log.write_bytes(
        dataflash(
            FORMATS_41,
            [
                ("ARM", (t, 1)),
                *[r for r in recs if r[0] == "PARM"],
                ("ARM", (t + 1, 0)),
                *[r for r in recs if r[0] != "PARM"],
            ],
        )
    )
    with pytest.raises(LogFormatError, match=r"disarmed at every state sample.*armed_only = false"):
        read_log(log, bluerov2, mapping=DATAFLASH)
