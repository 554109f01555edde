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
BASE=${1:-results/kvlcc2-mmg-full74-lsq-refined.toml}
B=target/release/shipid
if [ ! -x "$B" ]; then cargo test --release --workspace --no-run >/dev/null; fi
if [ "$BASE" = results/kvlcc2-mmg-full74-lsq-refined.toml ] && [ ! -f "$BASE" ]; then
    "$B" fit data/kvlcc2-mmg/dataset.toml --set full74 --estimator lsq --refine --out "$BASE" >/dev/null
fi
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
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
        python3 - "$W/r.json" "$name$v" "${3:-none}" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
v = r["verdict"]
# Candidates of one word may come in variants, "asymmetry(rudder_offset)"; the best-scoring one won.
won = [c for c in r.get("candidates", []) if c["effect"].split("(")[0] == v]
par = max(won, key=lambda c: c["score"])["parameters"] if won else {}
par = {k: x for k, x in par.items() if x != 0.0}
b, a = r["fit_before"]["position_rmse_over_l"], r["fit_after"]["position_rmse_over_l"]
print(f"{sys.argv[2]:<14} concealed {sys.argv[3]:<34} verdict {v:<14} {b:.4f} → {a:.4f} L "
      f"({100 * (1 - a / b):.0f} %)  " + ", ".join(f"{k}={x:.4g}" for k, x in par.items()))
PY
    done
done
