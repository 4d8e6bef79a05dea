"""Does noise hurt light vehicles more (section 5.2 of the paper)? Two tests.

(a) The two Fig. 7 runs, the RexROV (1863 kg, open loop) and the BlueROV2 Heavy
    (13.5 kg, with its roll-pitch hold): the AB4/AB1 ratio of the l2/N velocity error
    and of the noise excess (noisy minus noise-free error), read from the CSV files
    that ``sampledyn reproduce fig7`` writes (default: the committed ones in
    docs/figures/).
(b) One hull, mass scaled: the RexROV with mass, inertia, added mass and volume times
    k (damping and thrusters kept), the gentle Fig. 6 input, h = 0.1 s, 2 %/2 % noise,
    T = 60 s, 6 seeds (``sampledyn.experiments.inertia_sensitivity``): the largest
    noise contribution ||eps~ - eps|| and the rms error in the velocity block, for
    Euler and AB4.

Run:  python examples/heavy_vs_light.py [REXROV_FIG7_CSV BLUEROV2_FIG7_CSV]
      (about a minute; (a) alone with --no-scaled)
"""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_CSV = (
    ROOT / "docs" / "figures" / "fig7.csv",
    ROOT / "docs" / "figures" / "fig7_bluerov2_heavy" / "fig7.csv",
)
PAIRS = [(0, 2), (0, 10), (0, 20), (2, 2), (10, 10), (20, 20), (2, 0), (10, 0), (20, 0)]


def velocity_ratios(csv: Path, h: float) -> dict[tuple[int, int], tuple[float, float]]:
    """(AB4/AB1 of the l2/N velocity error, AB4/AB1 of its noise excess) per noise pair."""
    df = pd.read_csv(csv)
    df = df[df.h == h].set_index(["eta_pct", "v_pct", "method"])["vel_l2_over_n"]
    out = {}
    for eta, v in PAIRS:
        e1, e4 = df[(eta, v, "AB1")], df[(eta, v, "AB4")]
        c1, c4 = df[(0, 0, "AB1")], df[(0, 0, "AB4")]
        out[(eta, v)] = (e4 / e1, (e4 - c4) / (e1 - c1))
    return out


def fig7_table(rexrov_csv: Path, bluerov_csv: Path) -> None:
    for h in (0.1, 0.5):
        heavy, light = velocity_ratios(rexrov_csv, h), velocity_ratios(bluerov_csv, h)
        print(f"\n(a) Fig. 7 runs, h = {h} s: AB4/AB1, l2/N velocity error and noise excess")
        print(
            "noise (eta %, v %)  velocity RexROV  velocity BlueROV2  excess RexROV  excess BlueROV2"
        )
        for pair in PAIRS:
            (vh, xh), (vl, xl) = heavy[pair], light[pair]
            print(f"{str(pair):18s}  {vh:15.2f}  {vl:17.2f}  {xh:13.2f}  {xl:15.2f}")


def scaled_hull() -> None:
    from sampledyn.experiments import inertia_sensitivity
    from sampledyn.models import load_vehicle

    rexrov = load_vehicle("rexrov")
    scales = (1 / 128, 1 / 16, 1 / 4, 1.0)
    res = {
        m: inertia_sensitivity(rexrov, scales, method=m, h=0.1, eta_pct=2, v_pct=2, T=60, seeds=6)
        for m in ("E", "AB4")
    }
    print("\n(b) RexROV hull, mass scaled; h = 0.1 s, noise 2 %/2 %, T = 60 s, 6 seeds")
    print("mass (kg)  L_vv (1/s)  E: noise max / rms v  AB4: noise max / rms v  eta noise (E, AB4)")
    e, ab4 = res["E"], res["AB4"]
    for k, scale in enumerate(scales):
        print(
            f"{rexrov.mass * scale:9.1f}  {e.lipschitz[k, 1, 1]:10.3g}"
            f"  {e.measured_noise[k, 1]:.3g} / {e.measured_rms[k, 1]:.3g}"
            f"{'':9s}  {ab4.measured_noise[k, 1]:.3g} / {ab4.measured_rms[k, 1]:.3g}"
            f"{'':10s}  {e.measured_noise[k, 0]:.2g}, {ab4.measured_noise[k, 0]:.2g}"
        )


def main(argv: list[str]) -> None:
    args = [a for a in argv if a != "--no-scaled"]
    rexrov_csv, bluerov_csv = (Path(a) for a in args) if args else DEFAULT_CSV
    fig7_table(rexrov_csv, bluerov_csv)
    if "--no-scaled" not in argv:
        scaled_hull()


if __name__ == "__main__":
    main(sys.argv[1:])
