#!/usr/bin/env bash
# Verdicts of `shipid diagnose` on manoeuvres the base model was not identified from: the benchmark's
# base is fitted on the six default recordings (ZZ10/10 PS, ZZ20/20 PS, ZZ35/35 PS and SB, TC35 PS
# and SB); here every case is a data set of six other manoeuvres (ZZ10/10 SB, ZZ15/15 PS and SB,
# ZZ25/25 SB, TC20 PS and SB) with tank noise, effect-free controls and each effect at a weak and a
# strong magnitude, other directions and signs than the benchmark's. A stand-in for recordings made
# elsewhere, whose manoeuvres need not be the ones the base saw; the false alarms on the controls
# are the first thing to look at. Diagnosed against BASE (default: the refined full74 base of
# `cargo xtask bench-diagnose --base full74`; `mmg:kvlcc2` for the exact model, or a sparse-GP model file).
#
#   bench/diagnose-unseen.sh [BASE]      # ≈ 2 min; prints one line per case
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/diagnose_common.sh
M=(--manoeuvre zigzag:10/10:starboard --manoeuvre zigzag:15/15:port --manoeuvre zigzag:15/15:starboard
   --manoeuvre zigzag:25/25:starboard --manoeuvre turning:20:port --manoeuvre turning:20:starboard)
cases=("ctrl 31" "ctrl 32" "ctrl 33"
       "cur 34 current:speed=0.01,from=330" "cur 35 current:speed=0.03,from=75"
       "lag 36 rudder_lag:tau=0.5" "lag 37 rudder_lag:tau=1.2"
       "wind 38 wind:speed=3.5,from=250" "wind 39 wind:speed=5,from=20"
       "asym 40 asymmetry:offset=-0.6" "asym 41 asymmetry:offset=1.5"
       "shal 42 shallow_water:h_over_t=2.2" "shal 43 shallow_water:h_over_t=1.6")
for c in "${cases[@]}"; do
    set -- $c
    name=$1 seed=$2
    "$B" generate --out "$W/$name" --noise "$seed" ${3:+--effect "$3"} "${M[@]}" >/dev/null 2>&1
    start=$(date +%s.%N)
    "$B" diagnose "$BASE" "$W/$name/dataset.toml" --json "$W/r.json" >/dev/null || true
    secs=$(echo "$(date +%s.%N) - $start" | bc)
    line "$W/r.json" "$name-$seed" "${3:-none}" "$secs"
done
