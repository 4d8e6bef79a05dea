"""Evaluate the sampled-data models on real vehicle logs: one `sampledyn evaluate` per
file, each with its vehicle and the mapping file of its format from this folder.

    python examples/real_logs.py [FOLDER]

FOLDER (default: ``../shared/realdata`` beside the repository checkout) is searched for
the public logs below; each one found is evaluated and its table printed, with what
was read and what was left out. Exit status 0 when every file found was evaluated (or
the folder is absent: then it says so), 1 otherwise. The files are not part of this
repository; their sources:

* ``ardusub_log_tools/small.BIN``: clydemcqueen/ardusub_log_tools, ``testing/small.BIN``
  (MIT): ArduSub 4.1 DataFlash log of a 6-thruster BlueROV2 on a bench;
* ``ardusub_log_tools/small.tlog``: the same repository, ``testing/small.tlog``:
  QGroundControl telemetry of a BlueROV2 Heavy on a bench;
* ``saabmarine_kth/rosbag2_*/``: SAABmarine-MEX/saabmarineMEX_learning,
  ``residual_modelling/training/ros2_bags/27-5/``: a ROS 2 bag of a BlueROV2 Heavy in
  a test tank, motion capture and MAVROS RC override.
"""

from __future__ import annotations

import sys
from pathlib import Path

from sampledyn.cli import main

HERE = Path(__file__).resolve().parent
DEFAULT = HERE.parent.parent / "shared" / "realdata"

# (pattern under FOLDER, vehicle, mapping file in examples/)
LOGS = (
    ("ardusub_log_tools/*.BIN", "bluerov2", "ardusub_dataflash.toml"),
    ("ardusub_log_tools/*.tlog", "bluerov2_heavy", "ardusub_mavlink.toml"),
    ("saabmarine_kth/rosbag2_*", "bluerov2_heavy", "ros2_mavros_rc_override_bluerov2_heavy.toml"),
)


def run(folder: Path) -> int:
    if not folder.is_dir():
        print(f"no folder {folder}: no real logs to evaluate (nothing done)")
        return 0
    found = [(p, v, m) for pattern, v, m in LOGS for p in sorted(folder.glob(pattern))]
    if not found:
        print(f"{folder}: none of the known logs found (nothing done)")
        return 0
    failed = []
    for path, vehicle, mapping in found:
        print(f"=== {path.relative_to(folder)} (vehicle {vehicle}, mapping {mapping})")
        code = main(
            ["evaluate", "--data", str(path), "--vehicle", vehicle, "--mapping", str(HERE / mapping)]
        )
        print()
        if code != 0:
            failed.append(path.name)
    if failed:
        print(f"not evaluated: {', '.join(failed)}")
        return 1
    print(f"all {len(found)} logs evaluated")
    return 0


if __name__ == "__main__":
    sys.exit(run(Path(sys.argv[1]) if len(sys.argv) > 1 else DEFAULT))
