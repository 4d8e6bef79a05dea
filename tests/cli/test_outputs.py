"""Outputs never destroy inputs, and outputs are safe to open (issue 24, items 2, 8):
an ``--out`` that is (or resolves to) an input is refused before any work; the
report removes only its own files and writes into no linked folder; report.md
escapes markup as index.html does; CSV cells a spreadsheet would run are text."""

from __future__ import annotations

import csv
import io
import json
import os
import shutil
import sqlite3
import time
from pathlib import Path

import pytest
from _sweep_helpers import write_sweep

from sampledyn.cli import main
from sampledyn.cli._status import EXIT_FILE, EXIT_USAGE
from sampledyn.experiments.sweep import load_config, run_sweep
from sampledyn.report._sweep_report import MANIFEST
from sampledyn.report._tables import write_csv

EXAMPLE_LOG = Path(__file__).resolve().parents[2] / "examples" / "rov_log.csv"
VEHICLE = Path(__file__).resolve().parents[2] / "sampledyn" / "models" / "vehicles"
SMALL = {"T": 2.0, "after": 0.5, "h": "[0.02]", "methods": '["AB1", "AB2"]', "eta": "[0]",
         "v": "[0]", "seeds": 1}  # fmt: skip


@pytest.fixture(scope="module")
def store(tmp_path_factory) -> Path:
    work = tmp_path_factory.mktemp("outputs")
    db = work / "s.db"
    run_sweep(load_config(write_sweep(work / "s.toml", **SMALL)), db, progress=False)
    with sqlite3.connect(db) as conn:
        conn.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    return db


@pytest.fixture
def db(store, tmp_path) -> Path:
    (tmp_path / "data").mkdir()
    target = tmp_path / "data" / "s.db"
    shutil.copy(store, target)
    return target


def _status(args: list[str]) -> int:
    with pytest.raises(SystemExit) as exc:
        main(args)
    return int(exc.value.code)  # type: ignore[arg-type]


def _snapshot(folder: Path) -> dict[str, tuple[bytes, int]]:
    return {
        str(p.relative_to(folder)): (p.read_bytes(), p.stat().st_mtime_ns)
        for p in sorted(folder.rglob("*"))
        if p.is_file() and not p.is_symlink()
    }


def _one_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


@pytest.mark.parametrize("fmt", ["csv", "parquet", "table"])
@pytest.mark.parametrize("how", ["same", "relative", "symlink", "hardlink", "wal"])
def test_results_out_over_its_store_is_refused_before_work(db, capsys, monkeypatch, fmt, how):
    data = db.parent
    if how == "wal":
        with sqlite3.connect(db) as conn:  # an open reader keeps the -wal file
            conn.execute("PRAGMA journal_mode = WAL")
            conn.execute("UPDATE meta SET value = value")
            before = _snapshot(data)
            out = Path(str(db) + "-wal")
            assert out.exists()
            status = _status(["results", str(db), "--format", fmt, "--out", str(out)])
            assert _snapshot(data) == before
    else:
        out = {"same": db, "relative": Path("data/./s.db")}.get(how, data / "other.db")
        if how == "symlink":
            out.symlink_to(db)
        elif how == "hardlink":
            os.link(db, out)
        monkeypatch.chdir(data.parent)
        before = _snapshot(data)
        time.sleep(0.01)
        status = _status(["results", str(db), "--format", fmt, "--out", str(out)])
        assert _snapshot(data) == before
    assert status == EXIT_USAGE
    line = _one_line(capsys)
    assert "would overwrite the input STORE" in line and "nothing was written" in line


@pytest.mark.parametrize("which", ["--data", "--vehicle", "--mapping"])
def test_evaluate_out_over_an_input_is_refused_before_work(tmp_path, capsys, which):
    log = tmp_path / "log.csv"
    shutil.copy(EXAMPLE_LOG, log)
    vehicle = tmp_path / "v.toml"
    shutil.copy(VEHICLE / "bluerov2_heavy.toml", vehicle)
    mapping = tmp_path / "map.toml"
    mapping.write_text("")
    out = {"--data": log, "--vehicle": vehicle, "--mapping": mapping}[which]
    before = _snapshot(tmp_path)
    t0 = time.monotonic()
    args = ["evaluate", "--data", str(log), "--vehicle", str(vehicle), "--methods", "E",
            "--out", str(out)]  # fmt: skip
    if which == "--mapping":
        args += ["--mapping", str(mapping)]
    assert _status(args) == EXIT_USAGE
    assert time.monotonic() - t0 < 20  # before the log is read and the kernels loaded
    assert f"would overwrite the input {which}" in _one_line(capsys)
    assert _snapshot(tmp_path) == before


def test_evaluate_out_over_its_log_by_a_relative_name_is_refused(tmp_path, capsys, monkeypatch):
    """The new-user trial: `--data good.csv --out ./good.csv` overwrote the log."""
    shutil.copy(EXAMPLE_LOG, tmp_path / "good.csv")
    monkeypatch.chdir(tmp_path)
    before = _snapshot(tmp_path)
    args = ["evaluate", "--data", "good.csv", "--vehicle", "bluerov2_heavy", "--out"]
    assert _status([*args, "./good.csv"]) == EXIT_USAGE
    assert "would overwrite the input --data 'good.csv'" in _one_line(capsys)
    assert _snapshot(tmp_path) == before


def test_evaluate_out_inside_a_bag_folder_is_refused(tmp_path, capsys):
    bag = tmp_path / "bag"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    out = bag / "metadata.yaml"
    args = ["evaluate", "--data", str(bag), "--vehicle", "bluerov2_heavy", "--out", str(out)]
    assert _status(args) == EXIT_USAGE
    assert "would overwrite the input --data" in _one_line(capsys)


@pytest.mark.parametrize("inside", ["index.html", "report.md", "figures/s.db"])
def test_report_into_the_folder_of_its_store_is_refused_where_it_would_overwrite(
    store, tmp_path, capsys, inside
):
    rep = tmp_path / "rep"
    target = rep / inside
    target.parent.mkdir(parents=True)
    shutil.copy(store, target)
    before = _snapshot(rep)
    assert _status(["report", str(target), "--out", str(rep)]) == EXIT_USAGE
    assert "would overwrite the input STORE" in _one_line(capsys)
    assert _snapshot(rep) == before
    # A store elsewhere in the folder is not in the way.
    other = rep / "kept.db"
    shutil.copy(store, other)
    assert main(["report", str(other), "--out", str(rep)]) == 0


def test_the_report_removes_only_the_figures_its_manifest_lists(db, tmp_path):
    rep = tmp_path / "rep"
    figures = rep / "figures"
    figures.mkdir(parents=True)
    theirs = figures / "study1_mine.png"
    theirs.write_bytes(b"someone's figure")
    assert main(["report", str(db), "--out", str(rep)]) == 0
    listed = json.loads((rep / MANIFEST).read_text())["figures"]
    assert listed and all((figures / n).is_file() for n in listed)
    assert theirs.read_bytes() == b"someone's figure"
    # An earlier report's figure of a study no longer there: removed (it was listed).
    old = figures / "study9_order.png"
    old.write_bytes(b"old")
    (rep / MANIFEST).write_text(json.dumps({"figures": [*listed, old.name, "../s.db"]}))
    assert main(["report", str(db), "--out", str(rep)]) == 0
    assert not old.exists() and theirs.exists() and db.exists()


def test_the_report_does_not_follow_a_linked_figures_folder(db, tmp_path, capsys):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "study1_order.png").write_bytes(b"precious")
    rep = tmp_path / "rep"
    rep.mkdir()
    (rep / "figures").symlink_to(elsewhere)
    before = _snapshot(elsewhere)
    assert _status(["report", str(db), "--out", str(rep)]) == EXIT_FILE
    assert "symbolic link" in _one_line(capsys)
    assert _snapshot(elsewhere) == before


def test_the_report_replaces_linked_files_instead_of_writing_through_them(db, tmp_path):
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    rep = tmp_path / "rep"
    (rep / "figures").mkdir(parents=True)
    (rep / "index.html").symlink_to(victim)
    (rep / "figures" / "study1_order.png").symlink_to(victim)
    assert main(["report", str(db), "--out", str(rep)]) == 0
    assert victim.read_text() == "precious"
    assert not (rep / "index.html").is_symlink()
    assert not (rep / "figures" / "study1_order.png").is_symlink()


def test_report_md_escapes_markup_as_index_html_does(db, tmp_path):
    with sqlite3.connect(db) as conn:
        conn.execute("UPDATE cells SET vehicle = '<img src=x onerror=alert(1)> & co'")
    rep = tmp_path / "rep"
    assert main(["report", str(db), "--out", str(rep), "--title", "<b>T</b> & more"]) == 0
    md = (rep / "report.md").read_text()
    page = (rep / "index.html").read_text()
    assert "<img src=x" not in md and "<b>T</b>" not in md
    assert "&lt;img src=x onerror=alert(1)&gt; &amp; co" in md
    assert "# &lt;b&gt;T&lt;/b&gt; &amp; more" in md
    assert "<img src=x" not in page


def test_csv_exports_neutralise_formulas_in_text_cells_only(db, capsys):
    with sqlite3.connect(db) as conn:
        conn.execute("UPDATE cells SET vehicle = '=HYPERLINK(\"http://x\")', error = '@SUM(A1)'")
        conn.execute("UPDATE cells SET err_eta = -1.5")
    assert main(["results", str(db), "--format", "csv"]) == 0
    table = list(csv.DictReader(io.StringIO(capsys.readouterr().out)))
    assert table and all(r["vehicle"] == '\'=HYPERLINK("http://x")' for r in table)
    assert all(r["error"] == "'@SUM(A1)" for r in table)
    assert all(float(r["err_eta"]) == -1.5 for r in table)  # numbers stay numbers


def test_write_csv_takes_every_rows_keys_and_neutralises_text(tmp_path):
    rows = [{"method": "AB2", "err": 1.0}, {"method": "-cmd|' /C calc'!A0", "error": "boom"}]
    path = write_csv(rows, tmp_path / "t.csv")
    back = list(csv.DictReader(path.open()))
    assert list(back[0]) == ["method", "err", "error"]
    assert back[0]["error"] == "" and back[1]["err"] == ""
    assert back[1]["method"] == "'-cmd|' /C calc'!A0" and back[1]["error"] == "boom"


@pytest.mark.slow
def test_fig7_of_a_vehicle_whose_cells_fail_writes_its_tables(tmp_path):
    """The audit's case: a BlueROV2 Heavy file under another name runs open loop (no
    attitude hold for it), tumbles, and some cells fail; the runs table then has an
    ``error`` column that the first row lacks, and is written (it crashed)."""
    vehicle = tmp_path / "my_rov.toml"
    shutil.copy(VEHICLE / "bluerov2_heavy.toml", vehicle)
    out = tmp_path / "fig7"
    args = ["reproduce", "fig7", "--vehicle", str(vehicle), "--T", "100", "--after", "20",
            "--seeds", "1", "--workers", "1", "--out", str(out)]  # fmt: skip
    assert main(args) == 0
    runs = list(csv.DictReader((out / "fig7_runs.csv").open()))
    failed = [r for r in runs if r["error"]]
    assert "error" in runs[0] and failed and len(failed) < len(runs)
