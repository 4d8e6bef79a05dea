#!/usr/bin/env bash
# Regenerate every committed file in docs/figures/ with the commands the README and
# the docs pages show, writing into docs/figures/ instead of out/.
# Run from the repository root:  bash docs/regenerate_figures.sh [NAME ...]
# NAME: fig2 fig3 fig7 fig7_bluerov2_heavy closed-loop multistep sensitivity
# (default: all of them; about 15 minutes on a 2-core machine, most of it the
# sensitivity report and the multistep study).
set -euo pipefail
cd "$(dirname "$0")/.."
out=docs/figures
sd() { python -m sampledyn.cli "$@"; }
names=("$@")
[ ${#names[@]} -gt 0 ] || names=(fig2 fig3 fig7 fig7_bluerov2_heavy closed-loop multistep sensitivity)
for name in "${names[@]}"; do
    echo "== $name" >&2
    case "$name" in
        fig2 | fig3 | fig7 | closed-loop | multistep) sd reproduce "$name" --out "$out" ;;
        fig7_bluerov2_heavy) sd reproduce fig7 --vehicle bluerov2_heavy --out "$out/fig7_bluerov2_heavy" ;;
        sensitivity) sd advise --report "$out" --T 100 --seeds 5 ;;
        *) echo "unknown figure '$name'" >&2; exit 2 ;;
    esac
done
