# Sourced by bench/diagnose-robustness.sh and bench/diagnose-unseen.sh (from the repository root):
# the binary, the base (built if it is the benchmark's default file and missing), a scratch
# directory W, and `line REPORT NAME CONCEALED [SECONDS]`, which prints one case's verdict, held-out
# RMSE before → after and the winner's parameters from a `shipid diagnose --json` report.
BASE=${1:-results/kvlcc2-mmg-full74-lsq-refined.toml}
B=target/release/shipid
if [ ! -x "$B" ]; then cargo test --release --workspace --no-run >/dev/null; fi
if [ "$BASE" = results/kvlcc2-mmg-full74-lsq-refined.toml ] && [ ! -f "$BASE" ]; then
    "$B" fit data/kvlcc2-mmg/dataset.toml --set full74 --estimator lsq --refine --out "$BASE" >/dev/null
fi
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT

line() {
    python3 - "$@" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
v = r["verdict"]
# Candidates of one word may come in variants, "asymmetry(rudder_offset)"; the best-scoring one won.
won = [c for c in r.get("candidates", []) if c["effect"].split("(")[0] == v and not c.get("combined_with")]
par = max(won, key=lambda c: c["score"])["parameters"] if won else {}
par = {k: x for k, x in par.items() if x != 0.0}
b, a = r["fit_before"]["position_rmse_over_l"], r["fit_after"]["position_rmse_over_l"]
secs = f"{float(sys.argv[4]):.1f} s  " if len(sys.argv) > 4 else ""
print(f"{sys.argv[2]:<14} concealed {sys.argv[3]:<34} verdict {v:<14} {b:.4f} → {a:.4f} L "
      f"({100 * (1 - a / b):.0f} %)  {secs}" + ", ".join(f"{k}={x:.4g}" for k, x in par.items()))
PY
}
