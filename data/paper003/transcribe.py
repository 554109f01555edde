"""Transcribe paper 003 Tab. 1 (20 ships) from the extracted paper text into ships.toml.

Run from the repository root: python3 data/paper003/transcribe.py ../shared/papers/003_*.txt
The table appears in the text as one value per line: a 'Parameter' header, the ship ids, then per row
the parameter name followed by its ten values (S1..S10, then a second block S11..S20).
"""
import sys

KEYS = [
    ("L/B", "l_over_b"), ("B/d", "b_over_d"), ("CB", "cb"), ("xG/L (%)", "xg_over_l_percent"),
    ("Dp/d", "dp_over_d"), ("AR/Ld", "ar_over_ld_percent"), ("DP/H", "dp_over_h"),
    ("X′ββ", "x_bb"), ("X′βr − m′y", "x_br_minus_my"), ("X′rr + x′Gm′y", "x_rr_plus_xg_my"),
    ("X′ββββ", "x_bbbb"), ("Y′β", "y_b"), ("Y′r − m′x", "y_r_minus_mx"), ("Y′βββ", "y_bbb"),
    ("Y′ββr", "y_bbr"), ("Y′βrr", "y_brr"), ("Y′rrr", "y_rrr"), ("N′β", "n_b"), ("N′r", "n_r"),
    ("N′βββ", "n_bbb"), ("N′ββr", "n_bbr"), ("N′βrr", "n_brr"), ("N′rrr", "n_rrr"),
    ("1 − tR", "one_minus_t_r"), ("aH", "a_h"), ("x′H", "x_h"), ("ε", "epsilon"), ("kx", "kappa"),
    ("γR+", "gamma_r_pos"), ("γR−", "gamma_r_neg"), ("l′R", "l_r"),
]

lines = [l.strip() for l in open(sys.argv[1], encoding="utf-8")]
ships = {}
starts = [i for i, l in enumerate(lines) if l == "Parameter" and lines[i + 1] in ("S1", "S11")]
assert len(starts) == 2, starts
for s in starts:
    ids = lines[s + 1 : s + 11]
    i = s + 11
    for label, key in KEYS:
        assert lines[i] == label, (lines[i], label)
        vals = [float(v.replace("−", "-")) for v in lines[i + 1 : i + 11]]
        for sid, v in zip(ids, vals):
            ships.setdefault(sid, {})[key] = v
        i += 11

out = ["# Paper 003 (Guzelbulut 2025, J. Mar. Sci. Eng. 13, 496) Table 1, adapted there from Yoshimura et al.",
       "# (ref. [23], MMG hydrodynamic database). Written by data/paper003/transcribe.py from the paper text.",
       "# Conventions (as in the paper, Yoshimura's database form): drift β = −v'/… positive when the bow points",
       "# to port of the track (Y'_β > 0), r' = r L/U positive to starboard; forces ÷ ½ρLdU², moment ÷ ½ρL²dU².",
       "# The hull terms include the added-mass Munk terms: X'_βr − m'_y, X'_rr + x'_G m'_y, Y'_r − m'_x.",
       "# kappa is the table's 'kx' (κ of the MMG standard method); gamma_r_pos/neg are γ_R+ (β_R > 0) and γ_R−.",
       "# Ambiguities: 'AR/Ld' (1.24–3.08) and 'xG/L (%)' are read as percent; 'Dp/d' is propeller diameter",
       "# over draft and 'DP/H' propeller diameter over rudder height. Only the hull and interaction rows",
       "# enter the SVD; the main particulars are kept for reference.", ""]
for sid in [f"S{k}" for k in range(1, 21)]:
    out.append("[[ship]]")
    out.append(f'id = "{sid}"')
    for _, key in KEYS:
        out.append(f"{key} = {ships[sid][key]!r}")
    out.append("")
open("data/paper003/ships.toml", "w", encoding="utf-8").write("\n".join(out))
print("wrote", len(ships), "ships")
