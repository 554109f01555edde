#!/usr/bin/env bash
# The least-squares floors measured in alternation: ROUNDS short runs of each side (ours:
# `fit_bench --cases lsq,bounded_lsq --solvers fast`; Python: numpy lstsq, scikit-learn
# LinearRegression, SciPy lsq_linear), one right after the other, the side that goes first
# alternating. bench/run.sh times the Rust side, then the Python side half an hour later;
# this machine's speed drifts by ±30 % over such spans (numpy lstsq on the same problem:
# 1.17–1.89 ms in four runs of one day), which moves a 10× ratio by as much. Pairing the
# runs within a minute puts that drift into the spread over rounds instead of the ratio.
#
#   bench/paired.sh            ROUNDS=7 (≈ 8 min on 2 cores)
#   ROUNDS=3 bench/paired.sh
#
# Needs bench/designs (bench/run.sh exports them) and the workspace test build
# (`cargo build --release -p xtask`, which builds target/release/xtask).
# Writes bench/paired.json and bench/paired.md.
set -euo pipefail
cd "$(dirname "$0")/.."
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 VECLIB_MAXIMUM_THREADS=1 \
    NUMEXPR_NUM_THREADS=1 BLIS_NUM_THREADS=1 RAYON_NUM_THREADS=1
PY=bench/.venv/bin/python
[ -x "$PY" ] || { echo "bench/.venv missing: run bench/run.sh once" >&2; exit 2; }
[ -f bench/designs/manifest.json ] || { echo "bench/designs missing: run bench/run.sh once" >&2; exit 2; }
ROUNDS=${ROUNDS:-7}
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
cargo test --release --workspace --no-run 2>/dev/null

rust() {
    target/release/xtask fit-bench --cases lsq,bounded_lsq --solvers fast --no-api-floor \
        --min-repeats 7 --min-time 0.5 --out "$WORK/rust-$1.json" 2>/dev/null
}
python() {
    "$PY" bench/python_fit.py --designs bench/designs --out "$WORK/python-$1.json" \
        --cases lsq,bounded_lsq \
        --methods "numpy.linalg.lstsq,sklearn LinearRegression,scipy lsq_linear" \
        --min-repeats 7 --min-time 0.5 2>/dev/null
}
for k in $(seq 1 "$ROUNDS"); do
    load=$(cut -d' ' -f1 /proc/loadavg)
    start=$(date -u +%H:%M:%SZ)
    if [ $((k % 2)) -eq 1 ]; then rust "$k"; python "$k"; else python "$k"; rust "$k"; fi
    echo "$k $start $load" >>"$WORK/rounds.txt"
    echo "round $k of $ROUNDS done (started $start, load $load)" >&2
done
"$PY" bench/paired_report.py "$WORK" "$ROUNDS" \
    --state "$(git rev-parse --short HEAD) $(date -u +%Y-%m-%dT%H:%MZ) $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')" \
    --json bench/paired.json --out bench/paired.md
cat bench/paired.md
