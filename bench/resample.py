"""Copy a data set with every recording decimated by K (keep every K-th row) and/or with extra
Gaussian noise scaled by F on the noisy channels, and/or with a share D of its rows dropped at random
(uneven sampling, which the data format allows; first and last rows kept): a stand-in for recordings made
elsewhere at another sampling rate or noise level. Columns in SI units as `shipid generate` writes them;
the noise levels are those of the KVLCC2 model (L = 7 m, U0 = 1.179 m/s).
Usage: resample.py SRC_DIR DST_DIR K [F SEED [D]]"""
import sys, shutil, csv, random
from pathlib import Path
src, dst, k = Path(sys.argv[1]), Path(sys.argv[2]), int(sys.argv[3])
f = float(sys.argv[4]) if len(sys.argv) > 4 else 0.0
seed = int(sys.argv[5]) if len(sys.argv) > 5 else 0
drop = float(sys.argv[6]) if len(sys.argv) > 6 else 0.0
dst.mkdir(parents=True, exist_ok=True)
shutil.copy(src / "dataset.toml", dst / "dataset.toml")
# extra noise levels (SI, model scale KVLCC2 L = 7 m, U0 = 1.179 m/s) = F × the tank levels
sig = {"x0": 7e-3, "y0": 7e-3, "psi": 0.1 * 3.14159 / 180, "u": 2e-3 * 1.179, "v": 2e-3 * 1.179,
       "r": 5e-3 * 1.179 / 7.0, "delta": 0.05 * 3.14159 / 180}
for p in sorted(src.glob("*.csv")):
    # One stream per file, seeded from SEED and its name (as `shipid generate` does), so the draws do
    # not depend on the order the directory lists the files in.
    rng = random.Random(f"{seed}:{p.name}")
    lines = p.read_text().splitlines()
    comments = [l for l in lines if l.startswith("#")]
    rows = [l for l in lines if not l.startswith("#")]
    head = rows[0].split(",")
    out = comments + [rows[0]]
    last = len(rows) - 2
    for i, l in enumerate(rows[1:]):
        if i % k:
            continue
        if 0 < i < last and drop > 0 and rng.random() < drop:
            continue
        vals = l.split(",")
        if f > 0:
            for j, h in enumerate(head):
                name = h.split("[")[0]
                if name in sig:
                    vals[j] = repr(float(vals[j]) + rng.gauss(0.0, f * sig[name]))
        out.append(",".join(vals))
    (dst / p.name).write_text("\n".join(out) + "\n")
