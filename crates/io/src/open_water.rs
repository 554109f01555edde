//! The propeller's open-water table (`[propeller] open_water = "…csv"`, `docs/data-format.md`): a CSV with a
//! header row, a `J` column and a `K_T` column (also written `KT` or `Kt`); other columns (K_Q, η …) are
//! ignored. The points become a least-squares quadratic K_T(J) = k0 + k1 J + k2 J², the form the MMG
//! propeller model uses.

use std::path::Path;

use crate::error::InputError;
use crate::table::parse_cell;
use crate::types::OpenWaterCurve;

/// Fewest points: three determine a quadratic, and a least-squares fit needs at least that many.
pub const MIN_POINTS: usize = 3;

/// Read an open-water CSV and fit the quadratic. `named` is the file as the data set names it (kept in
/// the result); `path` is where it was read from (named in errors).
pub fn read_open_water(path: &Path, named: &str) -> Result<([f64; 3], OpenWaterCurve), InputError> {
    let text = crate::recording::read_text(path)?;
    parse_open_water(path, named, &text)
}

/// Parse open-water text and fit the quadratic; `path` only names the source in errors.
pub fn parse_open_water(
    path: &Path,
    named: &str,
    text: &str,
) -> Result<([f64; 3], OpenWaterCurve), InputError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let Some((header_line, header)) = lines.next() else {
        return Err(InputError::file(path, "no header row"));
    };
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let find = |accept: &dyn Fn(&str) -> bool, wanted: &str| {
        names.iter().position(|n| accept(n)).ok_or_else(|| {
            InputError::line(
                path,
                header_line,
                format!(
                    "no `{wanted}` column in the header (found: {}); an open-water table needs `J` and `K_T` (or `KT`) columns",
                    names.join(", ")
                ),
            )
        })
    };
    let is_j = |n: &str| n.eq_ignore_ascii_case("j");
    let is_kt = |n: &str| n.replace('_', "").eq_ignore_ascii_case("kt");
    // Two columns that both read as J or as K_T (`J,Kt,KT`) differ in what they hold: taking the
    // first silently is a guess at which one the table means.
    for (accept, wanted) in [(&is_j as &dyn Fn(&str) -> bool, "J"), (&is_kt, "K_T")] {
        let found: Vec<usize> = (0..names.len()).filter(|&i| accept(names[i])).collect();
        if let [a, b, ..] = found[..] {
            return Err(InputError::line(
                path,
                header_line,
                format!(
                    "two `{wanted}` columns, `{}` (column {}) and `{}` (column {}): which one holds {wanted} is ambiguous; keep one, or rename the other (e.g. `{}_alt`)",
                    names[a],
                    a + 1,
                    names[b],
                    b + 1,
                    names[b]
                ),
            ));
        }
    }
    let j_col = find(&is_j, "J")?;
    let kt_col = find(&is_kt, "K_T")?;
    let mut j = Vec::new();
    let mut k_t = Vec::new();
    for (line, row) in lines {
        let fields: Vec<&str> = row.split(',').collect();
        if fields.len() != names.len() {
            // More fields than names: typically `0,25` split by a decimal comma.
            let hint = if fields.len() > names.len() {
                " (decimal commas? shipid reads `.` as the decimal mark)"
            } else {
                ""
            };
            return Err(InputError::line(
                path,
                line,
                format!(
                    "expected {} fields as in the header, found {}{hint}",
                    names.len(),
                    fields.len()
                ),
            ));
        }
        let cell = |col: usize| -> Result<f64, InputError> {
            parse_cell(fields[col])
                .map_err(|m| InputError::cell(path, line, col + 1, names[col], m))
        };
        let (x, y) = (cell(j_col)?, cell(kt_col)?);
        if let Some(&prev) = j.last()
            && x <= prev
        {
            return Err(InputError::cell(
                path,
                line,
                j_col + 1,
                names[j_col],
                format!("J must increase from row to row ({x} after {prev})"),
            ));
        }
        j.push(x);
        k_t.push(y);
    }
    if j.len() < MIN_POINTS {
        return Err(InputError::file(
            path,
            format!(
                "{} open-water points; at least {MIN_POINTS} are needed for the quadratic K_T(J)",
                j.len()
            ),
        ));
    }
    let coefficients = fit_quadratic(&j, &k_t).ok_or_else(|| {
        InputError::file(
            path,
            "the quadratic K_T(J) through the open-water points is not finite (values too large?)",
        )
    })?;
    let rms_residual = (j
        .iter()
        .zip(&k_t)
        .map(|(&x, &y)| {
            let e = coefficients[0] + x * (coefficients[1] + x * coefficients[2]) - y;
            e * e
        })
        .sum::<f64>()
        / j.len() as f64)
        .sqrt();
    if let Some(problem) = table_problem(&j, &k_t, &coefficients) {
        return Err(InputError::file(path, problem));
    }
    let curve = OpenWaterCurve {
        file: named.to_string(),
        j_min: j[0],
        j_max: j[j.len() - 1],
        j,
        k_t,
        rms_residual,
    };
    Ok((coefficients, curve))
}

/// Advance ratios of an open-water table end well below this: a propeller's thrust vanishes at J of
/// about 0.7 … 1.5, so a table running to J 10 or 80 holds J in percent or another quantity.
pub const MAX_TABLE_J: f64 = 3.0;

/// K_T at J = 0 of a real propeller lies between about 0.15 (low pitch) and 0.6 (high pitch, many
/// blades); outside this range the curve is in another unit (K_T × 100, 10 K_Q in the K_T column).
pub const K_T0_RANGE: (f64, f64) = (0.05, 1.0);

/// Slope dK_T/dJ up to which a curve counts as flat: a least-squares quadratic through real points
/// may turn up a little at one end of the table, a curve that rises (heavy-pitch tables do not) is
/// not an open-water curve.
const RISING_SLOPE: f64 = 0.02;

/// Why the quadratic `k` = [k0, k1, k2] is no propeller's open-water curve K_T(J) over the advance
/// ratios `j_lo` … `j_hi` (the table's range, or for coefficients given directly the range the curve
/// thrusts over), or `None`. K_T(0) must lie within [`K_T0_RANGE`] and K_T must fall with J: a rising
/// curve or one a hundred times too large puts the mmg fit's propeller at J ≈ 0 or at several times
/// its thrust, with exit 0. The data set's `propeller.k_t` and a model file's are held to it too.
pub fn k_t_problem(k: &[f64; 3], j_lo: f64, j_hi: f64) -> Option<String> {
    let [k0, k1, k2] = *k;
    if !(k0 > K_T0_RANGE.0 && k0 < K_T0_RANGE.1) {
        let hint = if k0 >= 10.0 * K_T0_RANGE.1 {
            "K_T × 100 (in percent)?"
        } else if k0 >= K_T0_RANGE.1 {
            "K_T × 10, or 10 K_Q in the K_T column?"
        } else if k0 <= 0.0 {
            "it must be positive"
        } else {
            "K_T ÷ 10 or ÷ 100, or another coefficient (K_Q?) in its place?"
        };
        return Some(format!(
            "K_T at J = 0 is {}, outside the {} … {} of a propeller's open-water curve ({hint})",
            four_digits(k0),
            K_T0_RANGE.0,
            K_T0_RANGE.1
        ));
    }
    // The slope is linear in J: its largest value over the range is at one of the ends.
    let slope = |j: f64| k1 + 2.0 * k2 * j;
    let (at, steepest) =
        [j_lo, j_hi]
            .into_iter()
            .map(|j| (j, slope(j)))
            .fold(
                (j_lo, f64::NEG_INFINITY),
                |a, b| if b.1 > a.1 { b } else { a },
            );
    if steepest > RISING_SLOPE {
        return Some(format!(
            "K_T rises with J (dK_T/dJ = {:.3} at J = {}, over J = {} … {}): a propeller's thrust coefficient falls as the advance ratio grows (K_T and J swapped, or another column?)",
            steepest,
            crate::error::number(at),
            crate::error::number(j_lo),
            crate::error::number(j_hi)
        ));
    }
    None
}

/// `x` to four significant digits, for a message (a fitted coefficient's last digits are noise).
fn four_digits(x: f64) -> String {
    let s = format!("{x:.3e}");
    s.parse::<f64>().map_or(s, crate::error::number)
}

/// [`k_t_problem`] of coefficients given without a table (a data set's `propeller.k_t`, a model
/// file's), over the range they thrust ([`thrusting_range`]).
pub fn k_t_coefficients_problem(k: &[f64; 3]) -> Option<String> {
    let (lo, hi) = thrusting_range(k);
    k_t_problem(k, lo, hi)
}

/// The J range over which coefficients given without a table thrust: from 0 to where K_T first
/// vanishes, at most [`MAX_TABLE_J`].
pub fn thrusting_range(k: &[f64; 3]) -> (f64, f64) {
    let [k0, k1, k2] = *k;
    let steps = 300;
    let j_zero = (1..=steps)
        .map(|i| MAX_TABLE_J * i as f64 / steps as f64)
        .find(|&j| k0 + j * (k1 + j * k2) <= 0.0)
        .unwrap_or(MAX_TABLE_J);
    (0.0, j_zero)
}

/// What makes the table's points (`j`, `k_t`) and their quadratic `k` no open-water curve, or `None`.
fn table_problem(j: &[f64], k_t: &[f64], k: &[f64; 3]) -> Option<String> {
    let (lo, hi) = (j[0], j[j.len() - 1]);
    if hi > MAX_TABLE_J || lo < -MAX_TABLE_J {
        let hint = if hi >= 10.0 {
            "J in percent?"
        } else {
            "J in another unit, or another column under `J`?"
        };
        return Some(format!(
            "the table's J runs from {} to {}; a propeller's advance ratio stays below {MAX_TABLE_J} ({hint})",
            crate::error::number(lo),
            crate::error::number(hi)
        ));
    }
    // K_T(0) ≤ 0 keeps its own message at the data set (`dataset::propeller_data`).
    if k[0] <= 0.0 {
        return None;
    }
    // The points themselves must not rise overall, whatever the quadratic does between them.
    if k_t[k_t.len() - 1] > k_t[0] {
        return Some(format!(
            "K_T rises from {} at J = {} to {} at J = {}: a propeller's thrust coefficient falls as the advance ratio grows (K_T and J swapped, or another column?)",
            crate::error::number(k_t[0]),
            crate::error::number(lo),
            crate::error::number(k_t[k_t.len() - 1]),
            crate::error::number(hi)
        ));
    }
    k_t_problem(k, lo.max(0.0), hi)
        .map(|m| format!("the quadratic through the open-water points: {m}"))
}

/// Least-squares y ≈ k0 + k1 x + k2 x² through at least three distinct x. The abscissa is centred and
/// scaled to [-1, 1] first so that the normal equations stay well conditioned whatever the J range;
/// None when the result is not finite.
pub fn fit_quadratic(x: &[f64], y: &[f64]) -> Option<[f64; 3]> {
    let (lo, hi) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    let centre = 0.5 * (lo + hi);
    let half = 0.5 * (hi - lo);
    if !(half.is_finite() && half > 0.0) {
        return None;
    }
    // Normal equations in the scaled abscissa s = (x − centre) / half.
    let mut a = [[0.0f64; 3]; 3];
    let mut b = [0.0f64; 3];
    for (&xi, &yi) in x.iter().zip(y) {
        let s = (xi - centre) / half;
        let phi = [1.0, s, s * s];
        for r in 0..3 {
            b[r] += phi[r] * yi;
            for c in 0..3 {
                a[r][c] += phi[r] * phi[c];
            }
        }
    }
    let [c0, c1, c2] = solve3(a, b)?;
    // Back to x: c0 + c1 s + c2 s² with s = (x − m)/h.
    let (m, h) = (centre, half);
    let k2 = c2 / (h * h);
    let k1 = c1 / h - 2.0 * c2 * m / (h * h);
    let k0 = c0 - c1 * m / h + c2 * m * m / (h * h);
    let k = [k0, k1, k2];
    k.iter().all(|v| v.is_finite()).then_some(k)
}

/// Gaussian elimination with partial pivoting; None for a (numerically) singular system.
fn solve3(mut a: [[f64; 3]; 3], mut b: [f64; 3]) -> Option<[f64; 3]> {
    let scale = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    for col in 0..3 {
        let pivot = (col..3).max_by(|&p, &q| a[p][col].abs().total_cmp(&a[q][col].abs()))?;
        let size = a[pivot][col].abs();
        // NaN entries fail this test too.
        if size.is_nan() || size <= 1e-12 * scale {
            return None;
        }
        a.swap(col, pivot);
        b.swap(col, pivot);
        let pivot_row = a[col];
        for row in col + 1..3 {
            let f = a[row][col] / pivot_row[col];
            for (x, p) in a[row].iter_mut().zip(pivot_row).skip(col) {
                *x -= f * p;
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = [0.0; 3];
    for row in (0..3).rev() {
        let tail: f64 = (row + 1..3).map(|c| a[row][c] * x[c]).sum();
        x[row] = (b[row] - tail) / a[row][row];
    }
    Some(x)
}
