//! The direct path of `Solver::Fast` for LSQ and bounded LSQ on well-conditioned designs:
//! two passes over the raw design Φ and O(p³) work on p × p matrices, with no scaled copy
//! of Φ.
//!
//! 1. One fused pass forms the cross products of `[Φ y]`. Their diagonal holds the column
//!    sums of squares, i.e. the column scales `s_j`, and proves every value finite (NaN
//!    and ±∞ propagate into a sum of squares) — the same test as the general path's
//!    [`crate::problem`] uses, so no separate validation pass is needed.
//! 2. `G = ZᵀZ/n = S⁻¹ΦᵀΦS⁻¹/n` and `b = Zᵀy/n` by scaling the cross products
//!    symmetrically: the same documented scaled problem as the general path, without
//!    forming Z.
//! 3. Extreme eigenvalues of G ([`crate::dense::small_eig`]); the path applies when κ(Z) ≤ 1e5, the
//!    general path's own limit for the semi-normal equations, and when G has a Cholesky
//!    factor.
//! 4. Corrected semi-normal equations (Björck 1987): `Gγ₁ = b`, then one refinement step
//!    on the explicit residual (second pass: `r₁ = y − Φβ₁` with `Φᵀr₁` and `‖r₁‖²`),
//!    which squares the κ²ε error of the normal equations away. When κ(Z) is above 1e4
//!    (where the Gram eigenvalue alone is not accurate to 1e-6) the same pass gives the
//!    Rayleigh quotient `‖Zv‖²/n` of the smallest eigenvector, as in [`mod@crate::fit`]'s
//!    condition number.
//! 5. J = ‖y − Φβ‖²/2n follows from `‖r₁‖²` and the step ([`residual_after_step`]); a
//!    third pass evaluates it explicitly only when the step is not small against it.
//!
//! Anything else — zero columns, n ≤ p, values whose squares leave the safe range, worse
//! conditioning, a solution on or outside a bound — returns `None`, and the caller runs
//! the general path, which handles (and reports) every such case. Correctness never
//! depends on this path; it only decides how fast the common case is.

use faer::MatRef;

use crate::dense::kernels;
use crate::dense::linalg::{RowCholesky, col_of};
use crate::dense::small_eig::Tridiagonal;
use crate::error::EstimatorError;
use crate::params::CheckedParams;
use crate::types::{Fit, Solver, Status, status_from};

/// Below this κ(G) = κ(Z)² the Gram eigenvalues give κ(Z) to better than 1e-6 (the
/// threshold of [`mod@crate::fit`]'s condition number).
const GRAM_EIGENVALUES_SUFFICE: f64 = 1e8;
/// κ(G) limit of the semi-normal equations (κ(Z) ≤ 1e5), as in `fast::seminormal_lsq`.
const SEMINORMAL_LIMIT: f64 = 1e10;

/// The direct LSQ fit, or `None` when the general path must decide. The bounds' length is
/// checked here once the data are known to be valid, so that errors come in the same order
/// as on the general path.
pub(crate) fn try_lsq(
    design: MatRef<'_, f64>,
    y: &[f64],
    params: &CheckedParams,
) -> Option<Result<Fit, EstimatorError>> {
    let (estimator, bounds) = (params.estimator(), params.bounds());
    let (n, p) = (design.nrows(), design.ncols());
    if p == 0 || n <= p || y.len() != n {
        return None;
    }
    let columns: Vec<std::borrow::Cow<'_, [f64]>> = (0..p).map(|j| col_of(design, j)).collect();
    let mut all: Vec<&[f64]> = columns.iter().map(|c| c.as_ref()).collect();
    all.push(y);
    let m = p + 1;
    let cross = kernels::cross_products(&all, n, None);
    let phi = &all[..p];
    // Every column sum of squares finite and far from underflow and overflow (then every
    // value is finite, and so is every cross product); y only needs to be finite.
    let safe = |v: f64| v.is_finite() && (1e-150..=1e290).contains(&v);
    if !(0..p).all(|j| safe(cross[j * m + j])) {
        return None;
    }
    let yy = cross[p * m + p];
    if !(yy.is_finite() && yy <= 1e290) {
        return None;
    }
    if let Err(e) = params.check_columns(p) {
        return Some(Err(e));
    }
    let nf = n as f64;
    let scales: Vec<f64> = (0..p).map(|j| (cross[j * m + j] / nf).sqrt()).collect();
    // 1/√(ΦⱼᵀΦⱼ) = 1/(√n s_j): G_ij = (ΦᵢᵀΦⱼ)/(n s_i s_j).
    let inv_root: Vec<f64> = (0..p).map(|j| 1.0 / cross[j * m + j].sqrt()).collect();
    let mut g = vec![0.0; p * p];
    for i in 0..p {
        for j in i..p {
            let v = cross[i * m + j] * inv_root[i] * inv_root[j];
            g[i * p + j] = v;
            g[j * p + i] = v;
        }
    }
    let inv_root_n = 1.0 / nf.sqrt();
    let b: Vec<f64> = (0..p)
        .map(|j| cross[j * m + p] * inv_root[j] * inv_root_n)
        .collect();

    let tri = Tridiagonal::new(&g, p);
    let (emin, emax) = tri.extremes();
    // NaN fails the test too.
    if emin.partial_cmp(&(emax / SEMINORMAL_LIMIT)) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let l = RowCholesky::new(&g, p, 0.0)?;
    let mut gamma = b;
    l.solve(&mut gamma);
    let beta1: Vec<f64> = gamma.iter().zip(&scales).map(|(x, s)| x / s).collect();
    // ‖Zv‖²/n on Z itself is accurate to about (ε κ(G))² relative, the Gram's λ_min only
    // to ε κ(G); v does not depend on β, so the refinement pass computes it on the way.
    let rayleigh_vector: Option<Vec<f64>> = if emin > emax / GRAM_EIGENVALUES_SUFFICE {
        None
    } else {
        let v = tri.eigenvector(emin)?;
        Some(v.iter().zip(&scales).map(|(x, s)| x / s).collect())
    };
    let (grad, rr1, uu) = kernels::refinement(phi, y, &beta1, rayleigh_vector.as_deref());
    // Zᵀr/n = S⁻¹Φᵀr/n.
    let mut dx: Vec<f64> = grad
        .iter()
        .zip(&inv_root)
        .map(|(v, ir)| v * ir * inv_root_n)
        .collect();
    l.solve(&mut dx);
    for (x, d) in gamma.iter_mut().zip(&dx) {
        *x += d;
    }
    if gamma.iter().any(|v| !v.is_finite()) {
        return None;
    }

    // A coordinate on (within the status logic's margin of) or beyond a bound belongs to
    // the active-set solver and to the effective condition number of the free columns.
    if let Some(bd) = bounds {
        let gmax = gamma.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        for j in 0..p {
            let (lo, hi) = (bd.lower[j] * scales[j], bd.upper[j] * scales[j]);
            let near = |bound: f64| {
                bound.is_finite() && (gamma[j] - bound).abs() <= 1e-8 * gmax.max(bound.abs())
            };
            if !(lo < gamma[j] && gamma[j] < hi) || near(lo) || near(hi) {
                return None;
            }
        }
    }
    let beta: Vec<f64> = gamma.iter().zip(&scales).map(|(x, s)| x / s).collect();
    let rr = residual_after_step(&cross, m, &grad, rr1, &beta1, &beta)
        .unwrap_or_else(|| kernels::residual_norm(phi, y, &beta));
    let kappa = match rayleigh_vector {
        None => (emax / emin).sqrt(),
        Some(_) => (emax / (uu / nf)).sqrt(),
    };
    Some(Ok(Fit {
        coefficients: beta,
        objective: 0.5 * rr / nf,
        status: status_from(Status::Ok, Some(kappa)),
        iterations: 2,
        solver: Solver::Fast,
        estimator: *estimator,
        condition_number: Some(kappa),
        zero_columns: Vec::new(),
    }))
}

/// `‖y − Φβ‖²` from the refinement pass's `‖r₁‖²` and `g = Φᵀr₁` at `β₁`, without another
/// pass over Φ: with `d = β − β₁` (an exact difference, the two being close),
/// `‖r₁ − Φd‖² = ‖r₁‖² − 2dᵀg + dᵀ(ΦᵀΦ)d`, the cross products `ΦᵀΦ` being the upper
/// triangle of the first pass's `cross` (row length `m`). Accurate to rounding when the
/// step's change is small against ‖r₁‖² — the semi-normal equations' point — and `None`
/// otherwise (e.g. a noise-free fit whose residual is all rounding), when the caller
/// evaluates the residual explicitly.
fn residual_after_step(
    cross: &[f64],
    m: usize,
    grad: &[f64],
    rr1: f64,
    beta1: &[f64],
    beta: &[f64],
) -> Option<f64> {
    let p = beta.len();
    let d: Vec<f64> = beta.iter().zip(beta1).map(|(b, b1)| b - b1).collect();
    let mut quad = 0.0;
    for i in 0..p {
        let mut row = 0.5 * cross[i * m + i] * d[i];
        for j in i + 1..p {
            row += cross[i * m + j] * d[j];
        }
        quad += 2.0 * d[i] * row;
    }
    let lin: f64 = d.iter().zip(grad).map(|(a, g)| a * g).sum();
    let change = quad - 2.0 * lin;
    (change.abs() <= 1e-3 * rr1 && rr1.is_finite()).then_some(rr1 + change)
}
