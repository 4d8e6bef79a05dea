"""The roll-pitch hold's gains are per vehicle: the Fig. 7 study table tunes the law for
each vehicle (``feedback_tuning``), ``--attitude-hold`` takes those gains and
``--hold-gains KP,KD`` overrides them, checked before any work."""

from __future__ import annotations

import pytest

from sampledyn.cli import main
from sampledyn.cli._status import EXIT_BAD_VALUE, EXIT_USAGE
from sampledyn.exceptions import SweepConfigError
from sampledyn.experiments import ROVStudy
from sampledyn.experiments._rov import FIG7_STUDY_FILE
from sampledyn.experiments.sweep import SweepConfig
from sampledyn.experiments.sweep._plan import plan_study
from sampledyn.models import AttitudeHold, load_vehicle

_HOLD = "roll_pitch_hold"


def _status(args: list[str]) -> int:
    with pytest.raises(SystemExit) as exc:
        main(args)
    return int(exc.value.code)  # type: ignore[arg-type]


def test_each_vehicle_gets_the_gains_of_its_table_entry(tmp_path):
    # The RexROV runs open loop; switched on, the hold has the RexROV's gains, not the
    # BlueROV2's defaults.
    assert ROVStudy(vehicle="rexrov").config().feedback is None
    rex = ROVStudy(vehicle="rexrov", attitude_hold=True).config()
    assert (rex.feedback["kp"], rex.feedback["kd"]) == (16000.0, 7200.0)
    blue = ROVStudy(vehicle="bluerov2_heavy").config()
    assert (blue.feedback["kp"], blue.feedback["kd"]) == (40.0, 6.0)
    # Gains given here win over the table's.
    mixed = ROVStudy(vehicle="rexrov", attitude_hold=True, hold_gains=(9000.0, 5000.0)).config()
    assert (mixed.feedback["kp"], mixed.feedback["kd"]) == (9000.0, 5000.0)
    # A vehicle the table does not list: the law's defaults.
    own = tmp_path / "my_rov.toml"
    own.write_text((FIG7_STUDY_FILE.parents[2] / "models" / "vehicles" / "rexrov.toml").read_text())
    other = ROVStudy(vehicle=str(own), attitude_hold=True).config()
    assert (other.feedback["kp"], other.feedback["kd"]) == (40.0, 6.0)
    # The planned model is the hold with those gains.
    model = plan_study(rex).setup.model
    assert isinstance(model, AttitudeHold) and (model.kp, model.kd) == (16000.0, 7200.0)


def test_the_rexrov_gains_follow_the_stated_rule():
    """kp = J (2 pi f_n)^2, kd = 2 (0.7) J (2 pi f_n) with f_n = 0.5 Hz on the RexROV's
    pitch inertia with added inertia (the study file's comment), rounded; the
    BlueROV2's 40 and 6 are the same rule at 1.5 Hz on 0.45 kg m^2."""
    import math

    rex = load_vehicle("rexrov")
    J = rex.inertia_tensor[1, 1] + rex.added_mass_matrix[4, 4]
    w = 2 * math.pi * 0.5
    assert J * w**2 == pytest.approx(16000.0, rel=0.01)
    assert 2 * 0.7 * J * w == pytest.approx(7200.0, rel=0.001)
    w = 2 * math.pi * 1.5
    assert 0.45 * w**2 == pytest.approx(40.0, rel=0.001)
    assert 2 * 0.7 * 0.45 * w == pytest.approx(6.0, rel=0.02)


def test_reproduce_fig7_hold_gains(tmp_path, capsys):
    args = ["reproduce", "fig7", "--vehicle", "rexrov", "--T", "20", "--after", "5",
            "--seeds", "1", "--h", "0.5", "--methods", "AB1", "--workers", "1", "-q"]  # fmt: skip
    assert main([*args, "--attitude-hold", "--out", str(tmp_path / "a")]) == 0
    assert "closed by roll_pitch_hold kp 16000, kd 7200" in capsys.readouterr().out
    # The RexROV's default is open loop: the hold must be switched on.
    assert _status([*args, "--hold-gains", "8000,3600", "--out", str(tmp_path / "b")]) == (
        EXIT_BAD_VALUE
    )
    assert "--attitude-hold" in capsys.readouterr().err
    assert main([*args, "--attitude-hold", "--hold-gains", "8000,3600",
                 "--out", str(tmp_path / "c")]) == 0  # fmt: skip
    assert "closed by roll_pitch_hold kp 8000, kd 3600" in capsys.readouterr().out


@pytest.mark.parametrize(
    "extra, status, message",
    [
        (
            ["--no-attitude-hold", "--hold-gains", "1,2"],
            EXIT_BAD_VALUE,
            "--hold-gains: `hold_gains` are gains of the attitude hold, and `attitude_hold` "
            "(--attitude-hold) switches it off",
        ),
        (["--hold-gains", "40"], EXIT_BAD_VALUE, "two numbers > 0"),
        (["--hold-gains", "40,-6"], EXIT_BAD_VALUE, "got 40,-6"),
        (["--hold-gains", "40,nan"], EXIT_BAD_VALUE, "two numbers > 0"),
    ],
)
def test_bad_hold_gains_are_refused_before_any_work(tmp_path, capsys, extra, status, message):
    out = tmp_path / "out"
    assert _status(["reproduce", "fig7", "--vehicle", "bluerov2_heavy", *extra,
                    "--out", str(out)]) == status  # fmt: skip
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_hold_gains_apply_to_fig7_only(capsys):
    assert _status(["reproduce", "fig2", "--hold-gains", "40,6"]) == EXIT_USAGE
    assert "does not use --hold-gains" in capsys.readouterr().err


def _config(**entries):
    base = {"vehicle": "bluerov2_heavy", "input": "fig6", "T": 1.0, "after": 0.0, "h": 0.5,
            "methods": ["AB1"]}  # fmt: skip
    return SweepConfig.from_mapping({**base, **entries})


def test_feedback_tuning_in_a_sweep_file():
    tuned = {"feedback_tuning": {_HOLD: {"kp": 30.0, "kd": 5.0}}}
    assert _config(**tuned).feedback is None  # a tuning alone closes no loop
    fb = _config(feedback={"law": _HOLD}, **tuned).feedback
    assert (fb["kp"], fb["kd"], fb["n_lin_frac"]) == (30.0, 5.0, 0.3)
    fb = _config(feedback={"law": _HOLD, "kd": 7.0}, **tuned).feedback  # given wins
    assert (fb["kp"], fb["kd"]) == (30.0, 7.0)
    per_vehicle = {"per_vehicle": {"bluerov2_heavy": tuned}}
    fb = _config(feedback={"law": _HOLD}, **per_vehicle).feedback
    assert (fb["kp"], fb["kd"]) == (30.0, 5.0)


@pytest.mark.parametrize(
    "tuning, key, message",
    [
        ({"no_such_law": {"kp": 1.0}}, "feedback_tuning", "unknown feedback law"),
        ({_HOLD: {"kq": 1.0}}, "feedback_tuning", "no parameter 'kq'"),
        ({_HOLD: {"kp": "high"}}, "feedback_tuning.roll_pitch_hold.kp", "finite number"),
        ({_HOLD: 40.0}, "feedback_tuning", "table of tables"),
    ],
)
def test_bad_feedback_tuning_is_refused(tuning, key, message):
    with pytest.raises(SweepConfigError, match=message) as info:
        _config(feedback_tuning=tuning)
    assert info.value.key == key
