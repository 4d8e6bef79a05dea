"""Memory benchmark of reading a large CSV log: peak memory against the arrays kept.

Run:  python benchmarks/bench_log_memory.py [--rows 10000000] [--keep FILE] [--json PATH]

Issue 24's row "peak memory / arrays kept, a 10-million-row CSV log": target <= 2x.
Writes a CSV log of ``--rows`` rows with the columns of ``examples/rov_log.csv`` (t as
Unix-time decimal text at 100 Hz, the 12 states of the BlueROV2 Heavy with angles in
deg, 8 thruster speeds in rpm; smooth random walks), then, each in a fresh subprocess
after a warm-up read of a small log:

* ``read_log`` (chunked): the growth of the peak resident set during the call
  (``VmHWM``, reset through ``/proc/self/clear_refs`` just before it; ``ru_maxrss``
  where that is not possible) over the bytes of the arrays the LogData keeps (t, x,
  u, valid, rows), and the traced peak (``tracemalloc``: numpy's and Python's own
  allocations) over the same bytes;
* ``whole file`` (for comparison, with ``--whole``): ``pandas.read_csv`` of the file
  and ``log_from_frame``, the way the log was read before it was chunked.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _rows import row, write_json

HEADER = (
    "t[s],x[m],y[m],z[m],phi[deg],theta[deg],psi[deg],u[m/s],v[m/s],w[m/s],p[deg/s],"
    "q[deg/s],r[deg/s]," + ",".join(f"n{i}[rpm]" for i in range(1, 9))
)


def write_log(path: Path, rows: int, block: int = 500_000) -> None:
    """A CSV log of ``rows`` rows (written in blocks, constant memory)."""
    import numpy as np
    import pandas as pd

    rng = np.random.default_rng(24)
    level = np.zeros(20)
    with path.open("w") as fh:
        fh.write(HEADER + "\n")
        for start in range(0, rows, block):
            n = min(block, rows - start)
            steps = rng.normal(0.0, 0.01, (n, 20))
            walk = level + np.cumsum(steps, axis=0)
            level = walk[-1]
            walk[:, 3:5] = 20.0 * np.tanh(walk[:, 3:5] / 20.0)  # roll, pitch within +-20 deg
            walk[:, 12:] *= 1000.0  # rpm
            k = np.arange(start, start + n)
            t = np.char.add(np.char.add((1_700_000_000 + k // 100).astype(str), "."),
                            np.char.zfill((k % 100).astype(str), 2))  # fmt: skip
            frame = pd.DataFrame(walk)
            frame.insert(0, "t", t)
            frame.to_csv(fh, header=False, index=False, float_format="%.6g")


CHILD = r"""
import json, sys, tracemalloc, warnings
import numpy as np
import pandas as pd
import sampledyn as sd
from sampledyn.logs import read_log, log_from_frame
from _peak import PeakMemory

case, path, small = sys.argv[1], sys.argv[2], sys.argv[3]
vehicle = sd.models.load_vehicle("bluerov2_heavy")
read_log(small, vehicle)  # import and warm everything on a small log

peak = PeakMemory()
tracemalloc.start()
if case == "chunked":
    data = read_log(path, vehicle)
else:
    frame = pd.read_csv(path, skipinitialspace=True, dtype={"t[s]": str})
    data = log_from_frame(frame, vehicle, csv=True)
    del frame
traced = tracemalloc.get_traced_memory()[1]
tracemalloc.stop()
tr = data.traj
kept = tr.t.nbytes + tr.x.nbytes + tr.u.nbytes + data.valid.nbytes + data.rows.nbytes
print(json.dumps({
    "rows": int(tr.n_samples), "kept": kept, "rss_growth": peak.growth(),
    "traced_peak": traced, "rss_method": peak.method,
}))
"""


def run(case: str, path: Path, small: Path) -> dict:
    t0 = time.perf_counter()
    out = subprocess.run(
        [sys.executable, "-c", CHILD, case, str(path.resolve()), str(small.resolve())],
        check=True,
        cwd=Path(__file__).parent,
        capture_output=True,
        text=True,
    )
    found = json.loads(out.stdout.strip().splitlines()[-1])
    found["seconds"] = time.perf_counter() - t0
    return found


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--rows", type=int, default=10_000_000, help="rows of the log (10 M)")
    ap.add_argument("--keep", help="write the log here and keep it (default: a temporary file)")
    ap.add_argument("--whole", action="store_true", help="also read it whole (needs ~8x RAM)")
    ap.add_argument("--json", help="write the issue 24 rows here")
    args = ap.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="sampledyn-logbench-"))
    path = Path(args.keep) if args.keep else folder / "big.csv"
    small = folder / "small.csv"
    write_log(small, 400)
    if not path.exists():
        t0 = time.perf_counter()
        write_log(path, args.rows)
        print(f"wrote {path} in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    size = path.stat().st_size
    print(f"{args.rows:,} rows, {size / 1e9:.2f} GB CSV (target: peak / kept <= 2)")
    print(f"{'case':12s} {'kept':>9s} {'RSS peak':>9s} {'ratio':>6s} {'traced':>9s} {'ratio':>6s}"
          f" {'time':>7s}  (load {' '.join(f'{x:.1f}' for x in os.getloadavg())})")  # fmt: skip
    rows = []
    for case in ("chunked", "whole") if args.whole else ("chunked",):
        r = run(case, path, small)
        print(
            f"{case:12s} {r['kept'] / 1e9:7.2f}GB {r['rss_growth'] / 1e9:7.2f}GB "
            f"{r['rss_growth'] / r['kept']:6.2f} {r['traced_peak'] / 1e9:7.2f}GB "
            f"{r['traced_peak'] / r['kept']:6.2f} {r['seconds']:6.0f}s"
        )
        ratio = r["rss_growth"] / r["kept"]
        rows.append(row(
            f"peak RSS / arrays kept, read_log of a {args.rows:,}-row CSV ({size / 1e9:.2f} GB)"
            + ("" if case == "chunked" else ", read whole (before)"),
            ratio, f"{ratio:.2f}x ({r['kept'] / 1e9:.2f} GB kept)", "<= 2x",
            ratio <= 2.0 if case == "chunked" else None,
        ))  # fmt: skip
    print(f"(RSS measured with {r['rss_method']})")
    write_json(args.json, "bench_log_memory", rows)
    if not args.keep:
        path.unlink(missing_ok=True)
    small.unlink(missing_ok=True)
    folder.rmdir() if not any(folder.iterdir()) else None


if __name__ == "__main__":
    main()
