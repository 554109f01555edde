#!/usr/bin/env bash
# The diagnosis on effects implemented otherwise than its candidates (other windage areas, a pure delay,
# a propeller side force, another shallow-water yaw factor) and on two concealed effects at once; the
# README's table "Other implementations of the effects, and two effects at once".
#
#   bench/diagnose-variants.sh [BASE]     BASE: a model file or mmg:kvlcc2
#                                         (default results/kvlcc2-mmg-full74-lsq-refined.toml, made by
#                                         `shipid fit data/kvlcc2-mmg/dataset.toml --set full74
#                                         --estimator lsq --refine --out <that file>`, the base of
#                                         `cargo xtask bench-diagnose --base full74`)
#
# Prints one markdown row per case: concealed effects | noise seed | verdict | found | before → after.
# Needs target/release/shipid (`cargo test --release --workspace --no-run`) and python3.
set -euo pipefail
cd "$(dirname "$0")/.."
S=target/release/shipid
B=${1:-results/kvlcc2-mmg-full74-lsq-refined.toml}
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

run() { # name seed effect...
    local name=$1 seed=$2
    shift 2
    local args=()
    for e in "$@"; do args+=(--effect "$e"); done
    "$S" generate --out "$WORK/$name-s$seed" --noise "$seed" "${args[@]}" >"$WORK/log" 2>&1 ||
        { cat "$WORK/log" >&2; exit 2; }
    "$S" diagnose "$B" "$WORK/$name-s$seed/dataset.toml" --json "$WORK/$name-s$seed.json" >/dev/null
    python3 - "$WORK/$name-s$seed.json" "$*" "$seed" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
b = r["fit_before"]["position_rmse_over_l"]
a = r["fit_after"]["position_rmse_over_l"]
print(f"| {sys.argv[2]} | {sys.argv[3]} | {r['verdict']} | {' '.join(r['effects'])} | {b:.4f} → {a:.4f} ({100 * (1 - a / b):.0f} %) |")
PY
}

for s in 1 2; do
    run wind-areas "$s" wind:speed=4.5,from=120,af=0.35,al=2.2
    run lag-delay "$s" rudder_lag:tau=0,delay=0.8
    run sideforce "$s" asymmetry:y0=2,n0=-4.5
    run shallow-fyaw "$s" shallow_water:h_over_t=2,f_yaw=1.2
    run current-lag "$s" current:speed=0.02,from=200 rudder_lag:tau=0.8
    run wind-current "$s" wind:speed=4.5,from=300 current:speed=0.02,from=45
done
