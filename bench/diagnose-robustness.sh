#!/usr/bin/env bash
# Verdicts of `shipid diagnose` on recordings at other sampling rates and noise levels than the
# generator's (10 Hz, tank noise): a stand-in for concealed-effect recordings made elsewhere.
# One control and five effects (one seed each), each as generated, decimated to 5 Hz and 2 Hz
# (bench/resample.py keeps every k-th row), with three times the tank noise, and unevenly sampled
# (40 % of the rows dropped at random: steps of 0.1–0.5 s and more); diagnosed against
# BASE (default: the benchmark's refined full74 base; `mmg:kvlcc2` for the exact model).
#
#   bench/diagnose-robustness.sh [BASE]      # ≈ 1.5 min; prints one line per case
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/diagnose_common.sh
cases=("ctrl 11" "cur 12 current:speed=0.02,from=200" "lag 13 rudder_lag:tau=0.8"
       "wind 14 wind:speed=4.5,from=60" "asym 15 asymmetry:offset=1"
       "shal 16 shallow_water:h_over_t=1.5")
for c in "${cases[@]}"; do
    set -- $c
    name=$1 seed=$2
    "$B" generate --out "$W/$name" --noise "$seed" ${3:+--effect "$3"} >/dev/null
    python3 bench/resample.py "$W/$name" "$W/${name}_5hz" 2
    python3 bench/resample.py "$W/$name" "$W/${name}_2hz" 5
    python3 bench/resample.py "$W/$name" "$W/${name}_3x-noise" 1 2.83 7
    python3 bench/resample.py "$W/$name" "$W/${name}_uneven" 1 0 7 0.4
    for v in "" _5hz _2hz _3x-noise _uneven; do
        "$B" diagnose "$BASE" "$W/$name$v/dataset.toml" --json "$W/r.json" >/dev/null || true
        line "$W/r.json" "$name$v" "${3:-none}"
    done
done
