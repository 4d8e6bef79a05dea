"""Files committed as a command's output are what the command writes today, on this
machine, to the digits another machine reproduces (tolerances in ``_numbers``): the
Fig. 3 CSV of docs/figures (``bash docs/regenerate_figures.sh fig3``) and the example
log (``examples/README.md``: ``write_synthetic_log('examples/rov_log.csv')``)."""

from __future__ import annotations

from pathlib import Path

import pytest
from _numbers import AUV_CERTIFICATE_BOUND, Tol, assert_csv_close, auv_tolerance

from sampledyn.cli import main
from sampledyn.logs import write_synthetic_log

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow  # the full study of Fig. 3 (T = 200 s, 7 hold ratios)
def test_the_committed_fig3_csv_is_what_reproduce_fig3_writes(tmp_path):
    assert main(["reproduce", "fig3", "--out", str(tmp_path), "-q"]) == 0
    assert_csv_close(tmp_path / "fig3.csv", ROOT / "docs" / "figures" / "fig3.csv",
                     auv_tolerance, bounds=AUV_CERTIFICATE_BOUND,
                     label=lambda r: f"{r['method']} h_u/h={r['hold_ratio']}")  # fmt: skip


# The log is written with 9 significant digits (%.9g): a change in the last bits of a
# value (another CPU) flips its 9th digit now and then (two of 8000 values between two
# machines), one unit of which is at most 1e-8 of the value; atol covers values near
# zero, whose samples are known to ~1e-14 of the vehicle's motion (1e-10 in the log's
# units, deg included).
_LOG = Tol(1e-8, 1e-10, "9 significant digits written (%.9g): the 9th may flip")


def test_the_example_log_is_what_write_synthetic_log_writes(tmp_path):
    written = write_synthetic_log(tmp_path / "rov_log.csv")
    assert_csv_close(written, ROOT / "examples" / "rov_log.csv", _LOG,
                     label=lambda r: f"t={r['t[s]']}")  # fmt: skip
