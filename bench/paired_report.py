#!/usr/bin/env python3
"""Report of bench/paired.sh: speed-ups per round and their spread over rounds.

A training set's time is the sum over its three DOFs of the median wall time of one fit (as
in report.py); the speed-up of a round is Python time / our time, both from that round.

Usage: paired_report.py WORKDIR ROUNDS [--state TEXT] [--json FILE] [--out FILE]
"""

import argparse
import json
import statistics
from collections import defaultdict
from pathlib import Path

METHODS = {"lsq": ["numpy.linalg.lstsq", "sklearn LinearRegression"],
           "bounded_lsq": ["scipy lsq_linear"]}
FLOOR = 10.0


def per_training_set(records, key):
    """{(case, method-or-solver, set, training_set): summed median time [s]}, only for the
    training sets whose every DOF has a time (a failed DOF would shorten the sum, as report.py
    shows such a set as "—")."""
    out = defaultdict(float)
    failed = set()
    for r in records:
        k = (r["case"], r[key], r["set"], r["training_set"])
        if "time_s" in r:
            out[k] += r["time_s"]
        else:
            failed.add(k)
    return {k: t for k, t in out.items() if k not in failed}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("work", type=Path)
    ap.add_argument("rounds", type=int)
    ap.add_argument("--state", default="")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--out", type=Path)
    a = ap.parse_args()

    rounds = {}
    for line in (a.work / "rounds.txt").read_text().split("\n"):
        if line.strip():
            k, start, load = line.split()
            rounds[int(k)] = (start, load)
    rows = []  # (round, case, method, set, training set, ours [s], python [s], speed-up)
    for k in range(1, a.rounds + 1):
        ours = per_training_set(json.loads((a.work / f"rust-{k}.json").read_text())["records"],
                                "solver")
        py = per_training_set(json.loads((a.work / f"python-{k}.json").read_text())["records"],
                              "method")
        for (case, method, cset, ts), t_py in sorted(py.items()):
            t_ours = ours.get((case, "fast", cset, ts))
            if t_ours:
                rows.append((k, case, method, cset, ts, t_ours, t_py, t_py / t_ours))

    lines = ["# Least-squares floors, Rust and Python runs in alternation (bench/paired.sh)", ""]
    if a.state:
        lines += [f"Run: {a.state}; {a.rounds} rounds, the side that goes first alternating.", ""]
    lines += ["Speed-up = Python time / our Fast time, both summed over X, Y, N (medians of "
              "≥ 7 repeats and ≥ 0.5 s per DOF) and both from the same round.", ""]
    lines += ["| round | started (UTC) | load | " + " | ".join(
        f"{m}: worst set (speed-up)" for c in METHODS for m in METHODS[c]) + " |",
              "|---" * (3 + sum(len(v) for v in METHODS.values())) + "|"]
    worst = defaultdict(list)  # method -> [worst speed-up per round]
    for k in range(1, a.rounds + 1):
        cells = []
        for case, methods in METHODS.items():
            for m in methods:
                rs = [r for r in rows if r[0] == k and r[1] == case and r[2] == m]
                w = min(rs, key=lambda r: r[7])
                worst[m].append(w[7])
                cells.append(f"{w[3]} {w[4]}: {w[5] * 1e3:.3g} vs {w[6] * 1e3:.3g} ms "
                             f"({w[7]:.1f}×)")
        start, load = rounds.get(k, ("?", "?"))
        lines.append(f"| {k} | {start} | {load} | " + " | ".join(cells) + " |")
    lines += ["", "| case | Python method | worst-set speed-up: median over rounds | "
              "lowest | highest | rounds ≥ 10× |", "|---|---|---|---|---|---|"]
    summary = {}
    for case, methods in METHODS.items():
        for m in methods:
            v = worst[m]
            ok = sum(x >= FLOOR for x in v)
            summary[m] = {"case": case, "median": statistics.median(v), "min": min(v),
                          "max": max(v), "rounds_at_floor": ok, "rounds": len(v)}
            lines.append(f"| {case} | {m} | {statistics.median(v):.1f}× | {min(v):.1f}× | "
                         f"{max(v):.1f}× | {ok} of {len(v)} |")
    text = "\n".join(lines) + "\n"
    if a.out:
        a.out.write_text(text)
    if a.json:
        a.json.write_text(json.dumps({"state": a.state, "summary": summary, "rows": [
            dict(zip(("round", "case", "method", "set", "training_set", "ours_s",
                      "python_s", "speed_up"), r)) for r in rows]}, indent=1))
    print(text, end="")


if __name__ == "__main__":
    main()
