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
    let j_col = find(&|n| n.eq_ignore_ascii_case("j"), "J")?;
    let kt_col = find(&|n| n.replace('_', "").eq_ignore_ascii_case("kt"), "K_T")?;
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
