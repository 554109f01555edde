#!/usr/bin/env bash
# Fit-time benchmark: shipid's estimators vs paper 000's Python stack (see bench/README.md).
#
#   bench/run.sh            full run (≈ 15–25 min on 2 cores): designs, Rust, Python, report
#   QUICK=1 bench/run.sh    fewer repeats (a smoke run, a few minutes)
#   SKIP_RUST=1 / SKIP_PYTHON=1 reuse the previous results_*.json of that side
#
# Writes bench/results_rust.json, bench/results_python.json and bench/results.md; the designs
# go to bench/designs/ (git-ignored). Run it on an otherwise idle machine: both sides are
# timed on one core each, one after the other, and other load shows up in the times.
set -euo pipefail
cd "$(dirname "$0")/.."

# One thread for every numerical library on both sides.
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 VECLIB_MAXIMUM_THREADS=1 \
    NUMEXPR_NUM_THREADS=1 BLIS_NUM_THREADS=1 RAYON_NUM_THREADS=1

PY=bench/.venv/bin/python
if [ ! -x "$PY" ]; then
    "${PYTHON:-python3}" -m venv bench/.venv
    bench/.venv/bin/pip install --quiet -r bench/requirements.txt
fi

if [ -n "${QUICK:-}" ]; then
    RUST_REPEATS=(--min-repeats 3 --min-time 0.05)
    PY_REPEATS=(--min-repeats 3 --min-time 0.05 --max-time 5)
else
    RUST_REPEATS=(--min-repeats 7 --min-time 0.5)
    PY_REPEATS=(--min-repeats 7 --min-time 0.5 --max-time 20)
fi

state() {
    echo "when: $(date -u +%Y-%m-%dT%H:%MZ)"
    echo "git HEAD: $(git rev-parse --short HEAD 2>/dev/null || echo '?')"
    echo "uncommitted changes under crates/estimators, crates/model, crates/shipid/src: $(git status --short -- crates/estimators crates/model crates/shipid/src 2>/dev/null | wc -l) files"
    echo "crates/estimators/src fingerprint (sha256 of the concatenated *.rs): $(find crates/estimators/src -name "*.rs" | sort | xargs cat | sha256sum | cut -c1-16)"
    echo "rustc: $(rustc --version)"
    echo "cpu: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(getconf _NPROCESSORS_ONLN) cores"
}

if [ -z "${SKIP_RUST:-}" ]; then
    state > bench/source_state.txt
    echo "load average before the Rust run: $(cut -d' ' -f1-3 /proc/loadavg)" >> bench/source_state.txt
    # The workspace test build compiles the examples with the workspace's feature set;
    # `cargo build -p shipid` alone would unify features differently and rebuild polars.
    cargo test --release --workspace --no-run
    target/release/xtask fit-bench \
        --export bench/designs --out bench/results_rust.json "${RUST_REPEATS[@]}" 2> bench/fit_bench.log
    echo "load average after the Rust run: $(cut -d' ' -f1-3 /proc/loadavg)" >> bench/source_state.txt
    echo "Rust side done (log: bench/fit_bench.log)"
fi
if [ -z "${SKIP_PYTHON:-}" ]; then
    echo "load average before the Python run: $(cut -d' ' -f1-3 /proc/loadavg)" >> bench/source_state.txt
    "$PY" bench/python_fit.py --designs bench/designs --out bench/results_python.json \
        "${PY_REPEATS[@]}" 2> bench/python_fit.log
    echo "load average after the Python run: $(cut -d' ' -f1-3 /proc/loadavg)" >> bench/source_state.txt
    echo "Python side done (log: bench/python_fit.log)"
fi
"$PY" bench/report.py --designs bench/designs --rust bench/results_rust.json \
    --python bench/results_python.json --state bench/source_state.txt --out bench/results.md
echo "wrote bench/results.md"
