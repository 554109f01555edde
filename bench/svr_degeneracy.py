"""Why the ε-SVR fits of the turning-circle training sets take 25–75 interior-point iterations.

For each exported design (bench/designs, `fit_bench --export`) solves the SVR QP with Clarabel through
CVXPY at tight tolerances and prints one markdown row: n, n after merging exact duplicate rows, where
the samples sit at the optimum relative to the tube's edge (|r| = ε), Clarabel's iteration count, and
the same after merging rows equal to a relative tolerance τ (weights = multiplicities), with the
objective excess of that merged solution on the original problem.

Usage: bench/.venv/bin/python bench/svr_degeneracy.py [--designs DIR] [ID_SUBSTRING ...]
"""

import argparse
import json
import warnings
from pathlib import Path

import cvxpy as cp
import numpy as np

warnings.filterwarnings("ignore")


def solve(z, y, w, c, eps):
    g = cp.Variable(z.shape[1])
    r = y - z @ g
    obj = 0.5 * cp.sum_squares(g) + c * cp.sum(cp.multiply(w, cp.pos(cp.abs(r) - eps)))
    pr = cp.Problem(cp.Minimize(obj))
    pr.solve(solver="CLARABEL", tol_gap_abs=1e-14, tol_gap_rel=1e-13, tol_feas=1e-12)
    return np.asarray(g.value), pr.solver_stats.num_iters


def objective(z, y, g, c, eps):
    return 0.5 * g @ g + c * np.maximum(np.abs(y - z @ g) - eps, 0.0).sum()


def merged(zy, tau):
    if tau == 0.0:
        _, inv, cnt = np.unique(zy, axis=0, return_inverse=True, return_counts=True)
    else:
        sc = np.abs(zy).max(axis=0)
        sc[sc == 0] = 1.0
        _, inv, cnt = np.unique(np.round(zy / sc / tau).astype(np.int64), axis=0,
                                return_inverse=True, return_counts=True)
    inv = inv.ravel()
    m = np.zeros((len(cnt), zy.shape[1]))
    np.add.at(m, inv, zy)
    return m / cnt[:, None], cnt.astype(float)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--designs", default=str(Path(__file__).parent / "designs"))
    ap.add_argument("only", nargs="*", default=["TC35"])
    a = ap.parse_args()
    d = Path(a.designs)
    man = json.load(open(d / "manifest.json"))
    print("| design | n | n merged (exact) | within 1e-2 ε of the edge | within 1e-1 ε | inside / outside "
          "| Clarabel iterations | merged at τ = 1e-6: n, iterations, F excess |")
    print("|---|---|---|---|---|---|---|---|")
    for pb in man["problems"]:
        if not any(s in pb["id"] for s in a.only):
            continue
        phi = np.loadtxt(d / pb["phi"], delimiter=",", skiprows=1, ndmin=2)
        y = np.loadtxt(d / pb["y"], delimiter=",", skiprows=1)
        cols = np.genfromtxt(d / pb["columns"], delimiter=",", names=True, dtype=None,
                             encoding="utf-8")
        z = phi / np.asarray(cols["scale"], dtype=float)
        c, eps = pb["c"], pb["epsilon"]
        zy = np.hstack([z, y[:, None]])
        exact, w = merged(zy, 0.0)
        g, its = solve(exact[:, :-1], exact[:, -1], w, c, eps)
        f_opt = objective(z, y, g, c, eps)
        dist = (np.abs(exact[:, -1] - exact[:, :-1] @ g) - eps) / eps
        near2 = int(w[np.abs(dist) < 1e-2].sum())
        near1 = int(w[np.abs(dist) < 1e-1].sum())
        inside, outside = int(w[dist < 0].sum()), int(w[dist > 0].sum())
        m6, w6 = merged(zy, 1e-6)
        g6, its6 = solve(m6[:, :-1], m6[:, -1], w6, c, eps)
        excess = (objective(z, y, g6, c, eps) - f_opt) / f_opt
        print(f"| {pb['id']} | {len(y)} | {len(w)} | {near2} | {near1} | {inside} / {outside} "
              f"| {its} | {len(w6)}, {its6}, {excess:+.1e} |")


if __name__ == "__main__":
    main()
