//! Primal-dual interior-point method (Mehrotra predictor-corrector) for the linear ε-SVR,
//! with q × q normal equations.
//!
//! Why an interior-point method: the smoothing continuation of [`super`] changes which
//! samples carry curvature a few at a time, so its Newton steps grow with the number of
//! samples near the tube's edge — on designs stacked with a steady turning circle,
//! thousands of nearly equal rows sit within 1e-8 of the edge and it took 100–150 steps.
//! The interior-point iteration count depends less on that structure (13–19 on the
//! zig-zag designs, 25–75 with a turning circle), and each iteration costs one weighted
//! Gram `Σ dᵢ zᵢzᵢᵀ` (a third of the time at q = 22), four passes over Z (`Zᵀu`, `ZΔγ`,
//! for predictor and corrector) and four strip-mined passes over the per-sample state,
//! which recompute the per-sample parts of the directions instead of storing them (their
//! memory traffic, not their arithmetic, was the cost).
//!
//! Formulation (scaled space, merged samples of weight wᵢ):
//!
//! ```text
//!     min ½‖γ‖² + C Σ wᵢ ξᵢ   s.t.  ξᵢ ≥ rᵢ − ε,  ξᵢ ≥ −rᵢ − ε,  ξᵢ ≥ 0,  lo ≤ γ ≤ hi
//! ```
//!
//! with `r = y − Zγ`, multipliers λ₁, λ₂, λ₃ ≥ 0 per sample (θ = λ₁ − λ₂ is the SVR dual
//! variable, `λ₁ + λ₂ + λ₃ = C wᵢ`) and λ₄, λ₅ for finite bounds. Eliminating each ξᵢ from
//! the Newton system leaves `(I + D_b + Σ dᵢ zᵢzᵢᵀ) Δγ = h` with
//! `dᵢ = (4 D₁D₂ + D₃(D₁ + D₂))/(D₁ + D₂ + D₃)`, `D_k = λ_k/s_k` (a form without
//! cancellation; dᵢ ≥ 0), so the identity keeps the system positive definite whatever the
//! collinearity of Z.
//!
//! The iteration only proposes; the caller certifies: every few iterations the sets are
//! handed to the exact KKT finish, and the iterate is accepted by itself only with a
//! duality gap `F(γ) − D(θ) ≤ 1e-10 F(γ)` for the box-clipped dual point θ, where
//! `D(θ) = yᵀθ − ε‖θ‖₁ + min_{lo≤γ≤hi} (½‖γ‖² − (Zᵀθ)ᵀγ)` is a lower bound on the optimum
//! for every θ with `|θᵢ| ≤ C wᵢ`.

// The per-sample and per-bound arrays are indexed in step; index loops say that best.
#![allow(clippy::needless_range_loop)]

use crate::dense::kernels;
use crate::dense::linalg::{cholesky, cholesky_solve, col, residual, zt_v};

use super::data::Data;

/// Outcome of [`solve`]: the iterate and its multipliers θ (for the exact finish).
pub(super) struct Iterate {
    pub(super) gamma: Vec<f64>,
    pub(super) theta: Vec<f64>,
    pub(super) r: Vec<f64>,
    pub(super) iterations: usize,
    /// Certified `F(γ) − F* ≤ gap`.
    pub(super) gap: f64,
    pub(super) f: f64,
    /// Samples whose multiplier is strictly inside its range (see [`MARGIN_FRACTION`]).
    pub(super) margin_candidates: usize,
}

const MAX_ITERATIONS: usize = 80;
/// A multiplier with `MARGIN_FRACTION < |θᵢ|/(C wᵢ) < 1 − MARGIN_FRACTION` marks a margin
/// candidate (see `sides_from_multipliers` in [`super`]).
pub(super) const MARGIN_FRACTION: f64 = 1e-3;
/// Margin candidates up to which an iterate goes to the caller for a solve restricted to
/// them (`super::shrunk`): a thirty-second of the samples (an interior point on them costs
/// about an iteration of the whole), and at least a few per coordinate.
fn shrink_limit(n: usize, q: usize) -> usize {
    (n / 32).max(4 * q)
}
/// Fraction of the distance to the boundary a step may go.
const STEP_FRACTION: f64 = 0.99;

/// `F(γ)` at residual r (the true, unsmoothed objective; also used by the continuation).
pub(super) fn primal(gamma: &[f64], r: &[f64], w: &[f64], c: f64, eps: f64) -> f64 {
    0.5 * gamma.iter().map(|g| g * g).sum::<f64>()
        + c * r
            .iter()
            .zip(w)
            .map(|(v, wi)| wi * (v.abs() - eps).max(0.0))
            .sum::<f64>()
}

/// The dual bound `D(θ)` (see the module docs); θ must lie in the box `|θᵢ| ≤ C wᵢ`.
pub(super) fn dual(pb: &Data, theta: &[f64], eps: f64, lo: &[f64], hi: &[f64]) -> f64 {
    let v = zt_v(&pb.z, theta);
    let lin: f64 =
        pb.y.iter()
            .zip(theta)
            .map(|(y, t)| y * t - eps * t.abs())
            .sum();
    let quad: f64 = v
        .iter()
        .zip(lo.iter().zip(hi))
        .map(|(&vj, (&l, &h))| {
            let g = vj.clamp(l, h);
            0.5 * g * g - vj * g
        })
        .sum();
    lin + quad
}

/// The coefficient part of a Newton direction (Δγ, Δs₄,₅, Δλ₄,₅) and `ZΔγ`. The per-sample parts (Δξ, Δs₁…₃, Δλ₁…₃) are not
/// stored: every pass recomputes them from `ZΔγ` and the iterate ([`At`]), which moves a
/// third of the data that storing them (and reading them back) did.
struct Direction {
    dg: Vec<f64>,
    ds_b: [Vec<f64>; 2],
    dl_b: [Vec<f64>; 2],
    zd: Vec<f64>,
}

impl Direction {
    fn new(n: usize, q: usize) -> Self {
        Direction {
            dg: vec![0.0; q],
            ds_b: std::array::from_fn(|_| vec![0.0; q]),
            dl_b: std::array::from_fn(|_| vec![0.0; q]),
            zd: vec![0.0; n],
        }
    }
}

/// The iterate: ξ, r = y − Zγ, slacks s₁…₃ and multipliers λ₁…₃ per sample, γ and the
/// slacks/multipliers of its finite bounds (index 0 lower, 1 upper).
struct State<'a> {
    pb: &'a Data,
    c: f64,
    eps: f64,
    lo: &'a [f64],
    hi: &'a [f64],
    /// Bound present (finite and not fixed), per side.
    has: [Vec<bool>; 2],
    fixed: Vec<bool>,
    /// The columns of Z.
    cols: Vec<&'a [f64]>,
    gamma: Vec<f64>,
    xi: Vec<f64>,
    r: Vec<f64>,
    s: [Vec<f64>; 3],
    l: [Vec<f64>; 3],
    s_b: [Vec<f64>; 2],
    l_b: [Vec<f64>; 2],
    // Per-iteration quantities: 1/s_k, 1/(D₁ + D₂ + D₃), D₁ − D₂, √dᵢ, and the vector u
    // whose Zᵀu is the γ part of the reduced right-hand side.
    inv_s: [Vec<f64>; 3],
    rp_b: [Vec<f64>; 2],
    a_inv: Vec<f64>,
    b: Vec<f64>,
    root_d: Vec<f64>,
    u: Vec<f64>,
    count: f64,
}

/// One sample's iterate and scalings, loaded by every pass; the Newton system's
/// per-sample algebra lives here once.
#[derive(Clone, Copy)]
struct At {
    s: [f64; 3],
    l: [f64; 3],
    inv_s: [f64; 3],
    xi: f64,
    r: f64,
    w: f64,
    a_inv: f64,
    b: f64,
}

impl At {
    /// A sample's iterate with its scalings `D_k = λ_k/s_k`: `1/(D₁ + D₂ + D₃)`, `D₁ − D₂`,
    /// and `√dᵢ` with `dᵢ = (4D₁D₂ + D₃(D₁ + D₂))/(D₁ + D₂ + D₃)` (a form without
    /// cancellation, dᵢ ≥ 0) for the normal matrix.
    #[inline(always)]
    fn prepared(s: [f64; 3], l: [f64; 3], xi: f64, r: f64, w: f64) -> (At, f64) {
        let x = [1.0 / s[0], 1.0 / s[1], 1.0 / s[2]];
        let (d1, d2, d3) = (l[0] * x[0], l[1] * x[1], l[2] * x[2]);
        let ai = 1.0 / (d1 + d2 + d3);
        let at = At {
            s,
            l,
            inv_s: x,
            xi,
            r,
            w,
            a_inv: ai,
            b: d1 - d2,
        };
        (at, ((4.0 * d1 * d2 + d3 * (d1 + d2)) * ai).sqrt())
    }

    /// The complementarity products `s∘λ` (the predictor's targets).
    #[inline(always)]
    fn products(&self) -> [f64; 3] {
        [
            self.s[0] * self.l[0],
            self.s[1] * self.l[1],
            self.s[2] * self.l[2],
        ]
    }

    /// The predictor's u (targets s∘λ) and `Σ_k s_kλ_k`.
    #[inline(always)]
    fn predictor_u(&self, eps: f64, c: f64) -> (f64, f64) {
        let rc = self.products();
        let (_, u) = self.rhs(c, rc, self.rp(eps));
        (u, rc[0] + rc[1] + rc[2])
    }

    /// Primal residuals `rp_k` of `s₁ = ξ − r + ε`, `s₂ = ξ + r + ε`, `s₃ = ξ`.
    #[inline(always)]
    fn rp(&self, eps: f64) -> [f64; 3] {
        [
            self.xi - self.r + eps - self.s[0],
            self.xi + self.r + eps - self.s[1],
            self.xi - self.s[2],
        ]
    }

    /// `(rhs_ξ, u)` for the complementarity targets `rc`: `g_k = S⁻¹ rc_k + D_k rp_k`,
    /// `rhs_ξ = −r_dξ − (g₁ + g₂ + g₃)`, `u = (λ₁ − λ₂) − (g₁ − g₂) − (b/a) rhs_ξ`.
    #[inline(always)]
    fn rhs(&self, c: f64, rc: [f64; 3], rp: [f64; 3]) -> (f64, f64) {
        let g: [f64; 3] = std::array::from_fn(|k| (rc[k] + self.l[k] * rp[k]) * self.inv_s[k]);
        let r_dxi = c * self.w - self.l[0] - self.l[1] - self.l[2];
        let rhs = -r_dxi - (g[0] + g[1] + g[2]);
        let u = (self.l[0] - self.l[1]) - (g[0] - g[1]) - self.b * self.a_inv * rhs;
        (rhs, u)
    }

    /// `(Δξ, Δs, Δλ)` from `zd = zᵢΔγ`: Δs = AΔx + rp (rows of A: (1, z), (1, −z), (1, 0)),
    /// Δλ = −S⁻¹(rc + ΛΔs).
    #[inline(always)]
    fn step(&self, rc: [f64; 3], rp: [f64; 3], rhs: f64, zd: f64) -> (f64, [f64; 3], [f64; 3]) {
        let dxi = (rhs - self.b * zd) * self.a_inv;
        let ds = [dxi + zd + rp[0], dxi - zd + rp[1], dxi + rp[2]];
        let dl = std::array::from_fn(|k| -(rc[k] + self.l[k] * ds[k]) * self.inv_s[k]);
        (dxi, ds, dl)
    }

    /// The predictor's (affine-scaling) targets `s∘λ` and its `(Δs, Δλ)` from `zd_aff`.
    #[inline(always)]
    fn affine(&self, eps: f64, c: f64, zd_aff: f64) -> ([f64; 3], [f64; 3], [f64; 3]) {
        let rc = self.products();
        let rp = self.rp(eps);
        let (rhs, _) = self.rhs(c, rc, rp);
        let (_, ds, dl) = self.step(rc, rp, rhs, zd_aff);
        (rc, ds, dl)
    }

    /// The corrector's targets `s∘λ + Δs_aff∘Δλ_aff − σμ`.
    #[inline(always)]
    fn corrector_targets(&self, eps: f64, c: f64, zd_aff: f64, target: f64) -> [f64; 3] {
        let (rc, ds, dl) = self.affine(eps, c, zd_aff);
        std::array::from_fn(|k| rc[k] + ds[k] * dl[k] - target)
    }

    /// The corrector's `(Δξ, Δs, Δλ)` from `zd = zᵢΔγ` (its targets recomputed from `zd_aff`).
    #[inline(always)]
    fn corrector(
        &self,
        eps: f64,
        c: f64,
        zd_aff: f64,
        target: f64,
        zd: f64,
    ) -> (f64, [f64; 3], [f64; 3]) {
        let rc = self.corrector_targets(eps, c, zd_aff, target);
        let rp = self.rp(eps);
        let (rhs, _) = self.rhs(c, rc, rp);
        self.step(rc, rp, rhs, zd)
    }
}

/// Read-only per-sample arrays of an iteration, cut to length n (no bounds checks in the
/// passes).
#[derive(Clone, Copy)]
struct Samples<'a> {
    s: [&'a [f64]; 3],
    l: [&'a [f64]; 3],
    inv_s: [&'a [f64]; 3],
    xi: &'a [f64],
    r: &'a [f64],
    w: &'a [f64],
    a_inv: &'a [f64],
    b: &'a [f64],
}

impl Samples<'_> {
    #[inline(always)]
    fn at(&self, i: usize) -> At {
        At {
            s: [self.s[0][i], self.s[1][i], self.s[2][i]],
            l: [self.l[0][i], self.l[1][i], self.l[2][i]],
            inv_s: [self.inv_s[0][i], self.inv_s[1][i], self.inv_s[2][i]],
            xi: self.xi[i],
            r: self.r[i],
            w: self.w[i],
            a_inv: self.a_inv[i],
            b: self.b[i],
        }
    }
}

/// Lane-wise maximum (the NaN-aware `f64::max` does not vectorise).
#[inline(always)]
fn big(a: f64, b: f64) -> f64 {
    if a > b { a } else { b }
}

/// Samples per strip: each pass computes a strip's per-sample values in a plain loop
/// (which vectorises), parks the ones to be reduced in L1-resident buffers, and folds
/// them into 8 lane accumulators afterwards. Reductions inside the main loop (a float
/// sum or maximum is order-dependent) kept it scalar.
const STRIP: usize = 64;

/// `acc[l] = max(acc[l], x[8t + l])`, and the tail into lane 0.
#[inline(always)]
fn fold_max(x: &[f64], acc: &mut [f64; 8]) {
    let mut chunks = x.chunks_exact(8);
    for ch in &mut chunks {
        for l in 0..8 {
            acc[l] = big(ch[l], acc[l]);
        }
    }
    for &v in chunks.remainder() {
        acc[0] = big(v, acc[0]);
    }
}

/// `acc[l] += x[8t + l]`, and the tail into lane 0.
#[inline(always)]
fn fold_sum(x: &[f64], acc: &mut [f64; 8]) {
    let mut chunks = x.chunks_exact(8);
    for ch in &mut chunks {
        for l in 0..8 {
            acc[l] += ch[l];
        }
    }
    for &v in chunks.remainder() {
        acc[0] += v;
    }
}

/// The lane-wise largest fraction `num/den` (`den > 0`), compared by cross-multiplication
/// so that no sample needs a division.
#[inline(always)]
fn fold_fraction(num: &[f64], den: &[f64], best: &mut ([f64; 8], [f64; 8])) {
    let (bn, bd) = best;
    let mut chunks = num.chunks_exact(8).zip(den.chunks_exact(8));
    for (nc, dc) in &mut chunks {
        for l in 0..8 {
            let better = nc[l] * bd[l] > bn[l] * dc[l];
            bn[l] = if better { nc[l] } else { bn[l] };
            bd[l] = if better { dc[l] } else { bd[l] };
        }
    }
    let tail = num.len() - num.len() % 8;
    for (&nv, &dv) in num[tail..].iter().zip(&den[tail..]) {
        if nv * bd[0] > bn[0] * dv {
            bn[0] = nv;
            bd[0] = dv;
        }
    }
}

#[inline(always)]
fn sub(v: &[f64], start: usize, end: usize) -> &[f64] {
    &v[start..end]
}

fn lanes_max(acc: &[f64; 8]) -> f64 {
    acc.iter().fold(0.0f64, |m, &x| big(x, m))
}

/// Largest `num/den` over the lane pairs, 0 if none is positive.
fn lanes_fraction(best: &([f64; 8], [f64; 8])) -> f64 {
    (0..8).fold(0.0f64, |m, l| big(best.0[l] / best.1[l], m))
}

impl<'a> Samples<'a> {
    /// The samples `start..start + len`.
    #[inline(always)]
    fn strip(&self, start: usize, len: usize) -> Samples<'a> {
        let cut = |v: &'a [f64]| &v[start..start + len];
        Samples {
            s: self.s.map(cut),
            l: self.l.map(cut),
            inv_s: self.inv_s.map(cut),
            xi: cut(self.xi),
            r: cut(self.r),
            w: cut(self.w),
            a_inv: cut(self.a_inv),
            b: cut(self.b),
        }
    }
}

// The per-sample passes are free functions of slices: as arguments, `&mut` slices carry
// no-alias information into the inlined loop, without which the vectoriser gives up on
// a dozen streams that might overlap.
// Hence pass 1 and the step pass each write the scalings through their own slices: the
// same writes through one struct of `&mut` slices made the solver 1.5× slower.

/// Pass 1 of the first iteration (later ones get it from the step, pass 5): the scalings of
/// the iterate ([`At::prepared`]) and the predictor's u (targets s∘λ). Returns `Σ s∘λ`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn prepare_samples(
    eps: f64,
    c: f64,
    s: [&[f64]; 3],
    l: [&[f64]; 3],
    xi: &[f64],
    r: &[f64],
    w: &[f64],
    inv_s: [&mut [f64]; 3],
    a_inv: &mut [f64],
    b: &mut [f64],
    root_d: &mut [f64],
    u: &mut [f64],
) -> f64 {
    let n = xi.len();
    let [is1, is2, is3] = inv_s;
    let mut acc = [0.0f64; 8];
    let mut start = 0;
    while start < n {
        let len = STRIP.min(n - start);
        let end = start + len;
        let cut = |v| sub(v, start, end);
        let ([s1, s2, s3], [l1, l2, l3]) = (s.map(cut), l.map(cut));
        let (xi, r, w) = (cut(xi), cut(r), cut(w));
        let (is1, is2, is3) = (
            &mut is1[start..start + len],
            &mut is2[start..start + len],
            &mut is3[start..start + len],
        );
        let (a_inv, b, root_d, u) = (
            &mut a_inv[start..start + len],
            &mut b[start..start + len],
            &mut root_d[start..start + len],
            &mut u[start..start + len],
        );
        let mut sl = [0.0f64; STRIP];
        let sl = &mut sl[..len];
        for t in 0..len {
            let (at, rd) = At::prepared(
                [s1[t], s2[t], s3[t]],
                [l1[t], l2[t], l3[t]],
                xi[t],
                r[t],
                w[t],
            );
            [is1[t], is2[t], is3[t]] = at.inv_s;
            a_inv[t] = at.a_inv;
            b[t] = at.b;
            root_d[t] = rd;
            (u[t], sl[t]) = at.predictor_u(eps, c);
        }
        fold_sum(sl, &mut acc);
        start += len;
    }
    acc.iter().sum()
}

/// What the predictor step decides on: the largest `−Δs/s` and `−Δλ/λ` over the samples,
/// and the coefficients of `Σ (s + αΔs)∘(λ + αΔλ) = c₀ + c₁α + c₂α²`.
struct AffineSummary {
    worst: f64,
    worst_dual: f64,
    poly: [f64; 3],
}

/// Pass 2: the predictor's direction from `zd_aff`, summarised.
#[inline(always)]
fn affine_samples(v: Samples<'_>, eps: f64, c: f64, zd_aff: &[f64]) -> AffineSummary {
    let n = v.xi.len();
    let (mut worst, mut worst_d) = ([0.0f64; 8], [0.0f64; 8]);
    let mut poly = [[0.0f64; 8]; 3];
    let mut start = 0;
    while start < n {
        let len = STRIP.min(n - start);
        let vs = v.strip(start, len);
        let zd = &zd_aff[start..start + len];
        let mut buf = [[0.0f64; STRIP]; 5];
        let [b0, b1, b2, b3, b4] = &mut buf;
        let (b0, b1, b2, b3, b4) = (
            &mut b0[..len],
            &mut b1[..len],
            &mut b2[..len],
            &mut b3[..len],
            &mut b4[..len],
        );
        for t in 0..len {
            let at = vs.at(t);
            let (rc, ds, dl) = at.affine(eps, c, zd[t]);
            let ratio: [f64; 3] = std::array::from_fn(|k| -ds[k] * at.inv_s[k]);
            // Δλ = −λ∘(s + Δs)/s for these targets: −Δλ/λ without a division.
            let ratio_d: [f64; 3] = std::array::from_fn(|k| (at.s[k] + ds[k]) * at.inv_s[k]);
            b0[t] = big(big(ratio[0], ratio[1]), ratio[2]);
            b1[t] = big(big(ratio_d[0], ratio_d[1]), ratio_d[2]);
            b2[t] = rc[0] + rc[1] + rc[2];
            b3[t] = (at.s[0] * dl[0] + at.l[0] * ds[0])
                + (at.s[1] * dl[1] + at.l[1] * ds[1])
                + (at.s[2] * dl[2] + at.l[2] * ds[2]);
            b4[t] = ds[0] * dl[0] + ds[1] * dl[1] + ds[2] * dl[2];
        }
        fold_max(b0, &mut worst);
        fold_max(b1, &mut worst_d);
        fold_sum(b2, &mut poly[0]);
        fold_sum(b3, &mut poly[1]);
        fold_sum(b4, &mut poly[2]);
        start += len;
    }
    AffineSummary {
        worst: lanes_max(&worst),
        worst_dual: lanes_max(&worst_d),
        poly: poly.map(|p| p.iter().sum()),
    }
}

/// Pass 3: the corrector's u (targets `s∘λ + Δs_aff∘Δλ_aff − target`).
#[inline(always)]
fn corrector_rhs_samples(
    v: Samples<'_>,
    eps: f64,
    c: f64,
    zd_aff: &[f64],
    target: f64,
    u: &mut [f64],
) {
    let n = v.xi.len();
    let (zd_aff, u) = (&zd_aff[..n], &mut u[..n]);
    for i in 0..n {
        let at = v.at(i);
        let rc = at.corrector_targets(eps, c, zd_aff[i], target);
        let (_, ui) = at.rhs(c, rc, at.rp(eps));
        u[i] = ui;
    }
}

/// Pass 4: the largest `−Δs/s` and `−Δλ/λ` of the corrector's direction from `zd`.
#[inline(always)]
fn corrector_ratios(
    v: Samples<'_>,
    eps: f64,
    c: f64,
    zd_aff: &[f64],
    target: f64,
    zd: &[f64],
) -> (f64, f64) {
    let n = v.xi.len();
    let mut worst = [0.0f64; 8];
    let mut best = ([0.0f64; 8], [1.0f64; 8]);
    let mut start = 0;
    while start < n {
        let len = STRIP.min(n - start);
        let vs = v.strip(start, len);
        let (za, zc) = (&zd_aff[start..start + len], &zd[start..start + len]);
        let mut buf = [[0.0f64; STRIP]; 3];
        let [b0, b1, b2] = &mut buf;
        let (b0, b1, b2) = (&mut b0[..len], &mut b1[..len], &mut b2[..len]);
        for t in 0..len {
            let at = vs.at(t);
            let (_, ds, dl) = at.corrector(eps, c, za[t], target, zc[t]);
            let ratio: [f64; 3] = std::array::from_fn(|k| -ds[k] * at.inv_s[k]);
            b0[t] = big(big(ratio[0], ratio[1]), ratio[2]);
            // The largest −Δλ_k/λ_k of the three as a fraction (λ > 0).
            let (mut num, mut den) = (-dl[0], at.l[0]);
            for k in 1..3 {
                let better = -dl[k] * den > num * at.l[k];
                num = if better { -dl[k] } else { num };
                den = if better { at.l[k] } else { den };
            }
            b1[t] = num;
            b2[t] = den;
        }
        fold_max(b0, &mut worst);
        fold_fraction(b1, b2, &mut best);
        start += len;
    }
    (lanes_max(&worst), lanes_fraction(&best))
}

/// Pass 5: the corrector step of length `alpha`, in place, and pass 1 of the next
/// iteration on the new iterate (its scalings and predictor's u overwrite this
/// iteration's once a sample's step is taken). Returns the new `Σ s∘λ`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn step_samples(
    eps: f64,
    c: f64,
    w: &[f64],
    zd_aff: &[f64],
    target: f64,
    zd: &[f64],
    alpha: f64,
    s: [&mut [f64]; 3],
    l: [&mut [f64]; 3],
    xi: &mut [f64],
    r: &mut [f64],
    inv_s: [&mut [f64]; 3],
    a_inv: &mut [f64],
    b: &mut [f64],
    root_d: &mut [f64],
    u: &mut [f64],
) -> f64 {
    let n = xi.len();
    let [s1, s2, s3] = s;
    let [l1, l2, l3] = l;
    let [is1, is2, is3] = inv_s;
    let mut acc = [0.0f64; 8];
    let mut start = 0;
    while start < n {
        let len = STRIP.min(n - start);
        let end = start + len;
        let cut = |v| sub(v, start, end);
        let (w, za, zc) = (cut(w), cut(zd_aff), cut(zd));
        let (s1, s2, s3) = (
            &mut s1[start..end],
            &mut s2[start..end],
            &mut s3[start..end],
        );
        let (l1, l2, l3) = (
            &mut l1[start..end],
            &mut l2[start..end],
            &mut l3[start..end],
        );
        let (is1, is2, is3) = (
            &mut is1[start..end],
            &mut is2[start..end],
            &mut is3[start..end],
        );
        let (xi, r) = (&mut xi[start..end], &mut r[start..end]);
        let (a_inv, b, root_d, u) = (
            &mut a_inv[start..end],
            &mut b[start..end],
            &mut root_d[start..end],
            &mut u[start..end],
        );
        let mut sl = [0.0f64; STRIP];
        let sl = &mut sl[..len];
        for t in 0..len {
            let at = At {
                s: [s1[t], s2[t], s3[t]],
                l: [l1[t], l2[t], l3[t]],
                inv_s: [is1[t], is2[t], is3[t]],
                xi: xi[t],
                r: r[t],
                w: w[t],
                a_inv: a_inv[t],
                b: b[t],
            };
            let (dxi, ds, dl) = at.corrector(eps, c, za[t], target, zc[t]);
            let sn: [f64; 3] = std::array::from_fn(|k| at.s[k] + alpha * ds[k]);
            let ln: [f64; 3] = std::array::from_fn(|k| at.l[k] + alpha * dl[k]);
            let (xn, rn) = (at.xi + alpha * dxi, at.r - alpha * zc[t]);
            [s1[t], s2[t], s3[t]] = sn;
            [l1[t], l2[t], l3[t]] = ln;
            xi[t] = xn;
            r[t] = rn;
            let (next, rd) = At::prepared(sn, ln, xn, rn, at.w);
            [is1[t], is2[t], is3[t]] = next.inv_s;
            a_inv[t] = next.a_inv;
            b[t] = next.b;
            root_d[t] = rd;
            (u[t], sl[t]) = next.predictor_u(eps, c);
        }
        fold_sum(sl, &mut acc);
        start = end;
    }
    acc.iter().sum()
}

/// The read-only sample view of a state, borrowing its fields one by one (so that `u`
/// stays free for a pass to write).
macro_rules! samples {
    ($st:expr) => {{
        let n = $st.pb.n;
        Samples {
            s: [&$st.s[0][..n], &$st.s[1][..n], &$st.s[2][..n]],
            l: [&$st.l[0][..n], &$st.l[1][..n], &$st.l[2][..n]],
            inv_s: [&$st.inv_s[0][..n], &$st.inv_s[1][..n], &$st.inv_s[2][..n]],
            xi: &$st.xi[..n],
            r: &$st.r[..n],
            w: &$st.pb.w[..n],
            a_inv: &$st.a_inv[..n],
            b: &$st.b[..n],
        }
    }};
}

impl State<'_> {
    #[inline(always)]
    fn bounds_complementarity(&self) -> f64 {
        let mut t = 0.0;
        for side in 0..2 {
            for j in 0..self.gamma.len() {
                if self.has[side][j] {
                    t += self.s_b[side][j] * self.l_b[side][j];
                }
            }
        }
        t
    }

    /// Scalings, the predictor's u and the bounds' primal residuals; returns the mean
    /// complementarity.
    #[inline(always)]
    fn prepare(&mut self) -> f64 {
        let n = self.pb.n;
        let [s1, s2, s3] = &self.s;
        let [l1, l2, l3] = &self.l;
        let [is1, is2, is3] = &mut self.inv_s;
        let sum = prepare_samples(
            self.eps,
            self.c,
            [&s1[..n], &s2[..n], &s3[..n]],
            [&l1[..n], &l2[..n], &l3[..n]],
            &self.xi[..n],
            &self.r[..n],
            &self.pb.w[..n],
            [&mut is1[..n], &mut is2[..n], &mut is3[..n]],
            &mut self.a_inv[..n],
            &mut self.b[..n],
            &mut self.root_d[..n],
            &mut self.u[..n],
        );
        self.prepare_bounds();
        (sum + self.bounds_complementarity()) / self.count
    }

    /// The bounds' primal residuals.
    #[inline(always)]
    fn prepare_bounds(&mut self) {
        for j in 0..self.gamma.len() {
            self.rp_b[0][j] = if self.has[0][j] {
                self.gamma[j] - self.lo[j] - self.s_b[0][j]
            } else {
                0.0
            };
            self.rp_b[1][j] = if self.has[1][j] {
                self.hi[j] - self.gamma[j] - self.s_b[1][j]
            } else {
                0.0
            };
        }
    }

    /// `I + D_b + Σ dᵢ zᵢzᵢᵀ`, Cholesky-factored; `None` if not numerically positive definite.
    #[inline(always)]
    fn factor(&self) -> Option<faer::Mat<f64>> {
        let (n, q) = (self.pb.n, self.pb.q());
        let up = kernels::cross_products(&self.cols, n, Some(&self.root_d));
        let h = faer::Mat::<f64>::from_fn(q, q, |i, j| {
            if self.fixed[i] || self.fixed[j] {
                // A fixed coordinate does not move: its row and column are the identity.
                return if i == j { 1.0 } else { 0.0 };
            }
            let mut v = if i <= j { up[i * q + j] } else { up[j * q + i] };
            if i == j {
                v += 1.0;
                for side in 0..2 {
                    if self.has[side][j] {
                        v += self.l_b[side][j] / self.s_b[side][j];
                    }
                }
            }
            v
        });
        cholesky(h.as_ref(), 0.0)
    }

    /// The coefficient part of the Newton direction for the current u (built by a pass
    /// for the wanted sample targets) and the bound targets `rc_b`, into `out`; returns
    /// the bounds' largest `−Δs/s` and `−Δλ/λ`.
    #[inline(always)]
    fn coefficient_direction(
        &self,
        chol: &faer::Mat<f64>,
        rc_b: &[Vec<f64>; 2],
        out: &mut Direction,
    ) -> (f64, f64) {
        let q = self.pb.q();
        let ztu = kernels::transposed_product(&self.cols, &self.u);
        for j in 0..q {
            out.dg[j] = if self.fixed[j] {
                0.0
            } else {
                let mut v = -self.gamma[j] + self.l_b[0][j] - self.l_b[1][j] + ztu[j];
                if self.has[0][j] {
                    v -= (rc_b[0][j] + self.l_b[0][j] * self.rp_b[0][j]) / self.s_b[0][j];
                }
                if self.has[1][j] {
                    v += (rc_b[1][j] + self.l_b[1][j] * self.rp_b[1][j]) / self.s_b[1][j];
                }
                v
            };
        }
        cholesky_solve(chol, &mut out.dg);
        for j in 0..q {
            if self.fixed[j] {
                out.dg[j] = 0.0;
            }
        }
        kernels::combination(&self.cols, &out.dg, &mut out.zd);
        let (mut worst, mut worst_d) = (0.0f64, 0.0f64);
        for side in 0..2 {
            for j in 0..q {
                if !self.has[side][j] {
                    out.ds_b[side][j] = 0.0;
                    out.dl_b[side][j] = 0.0;
                    continue;
                }
                let sign = if side == 0 { 1.0 } else { -1.0 };
                let ds = sign * out.dg[j] + self.rp_b[side][j];
                let dl = -(rc_b[side][j] + self.l_b[side][j] * ds) / self.s_b[side][j];
                out.ds_b[side][j] = ds;
                out.dl_b[side][j] = dl;
                worst = worst.max(-ds / self.s_b[side][j]);
                worst_d = worst_d.max(-dl / self.l_b[side][j]);
            }
        }
        (worst, worst_d)
    }

    /// `Σ (s_b + αΔs_b)(λ_b + αΔλ_b)` over the bounds.
    #[inline(always)]
    fn bounds_complementarity_after(&self, d: &Direction, alpha: f64) -> f64 {
        let mut t = 0.0;
        for side in 0..2 {
            for j in 0..self.gamma.len() {
                if self.has[side][j] {
                    t += (self.s_b[side][j] + alpha * d.ds_b[side][j])
                        * (self.l_b[side][j] + alpha * d.dl_b[side][j]);
                }
            }
        }
        t
    }

    /// The corrector step of length `alpha` (γ, bounds, samples); returns the new mean
    /// complementarity.
    #[inline(always)]
    fn step(&mut self, aff: &Direction, target: f64, d: &Direction, alpha: f64) -> f64 {
        for j in 0..self.gamma.len() {
            self.gamma[j] += alpha * d.dg[j];
            for side in 0..2 {
                if self.has[side][j] {
                    self.s_b[side][j] += alpha * d.ds_b[side][j];
                    self.l_b[side][j] += alpha * d.dl_b[side][j];
                }
            }
        }
        let n = self.pb.n;
        let [is1, is2, is3] = &mut self.inv_s;
        let [s1, s2, s3] = &mut self.s;
        let [l1, l2, l3] = &mut self.l;
        let sum = step_samples(
            self.eps,
            self.c,
            &self.pb.w[..n],
            &aff.zd[..n],
            target,
            &d.zd[..n],
            alpha,
            [&mut s1[..n], &mut s2[..n], &mut s3[..n]],
            [&mut l1[..n], &mut l2[..n], &mut l3[..n]],
            &mut self.xi[..n],
            &mut self.r[..n],
            [&mut is1[..n], &mut is2[..n], &mut is3[..n]],
            &mut self.a_inv[..n],
            &mut self.b[..n],
            &mut self.root_d[..n],
            &mut self.u[..n],
        );
        self.prepare_bounds();
        (sum + self.bounds_complementarity()) / self.count
    }
}

crate::dense::kernels::dispatch!(
    /// Runs the interior-point iteration until `stop` accepts an iterate or the iteration
    /// limit is reached. `stop(iterate)` is called after every iteration once the mean
    /// complementarity has fallen below `1e-6` of its start; it returns true to finish.
    /// The per-sample loops are most of the work, hence the widest vector unit available.
    pub(super) fn solve, solve_generic,
    (
        pb: &Data,
        c: f64,
        eps: f64,
        lo: &[f64],
        hi: &[f64],
        scale: f64,
        stop: impl FnMut(&Iterate) -> bool
    ) -> Iterate,
    avx512: <>, avx2: <>, base: <>
);

#[inline(always)]
fn solve_generic(
    pb: &Data,
    c: f64,
    eps: f64,
    lo: &[f64],
    hi: &[f64],
    scale: f64,
    mut stop: impl FnMut(&Iterate) -> bool,
) -> Iterate {
    let (n, q) = (pb.n, pb.q());
    let w = &pb.w;
    let fixed: Vec<bool> = (0..q).map(|j| lo[j] == hi[j]).collect();
    let has_lo: Vec<bool> = (0..q).map(|j| lo[j].is_finite() && !fixed[j]).collect();
    let has_hi: Vec<bool> = (0..q).map(|j| hi[j].is_finite() && !fixed[j]).collect();
    // Start at the point of the box nearest to 0, moved strictly inside by up to one unit
    // (half the width for narrower boxes): far bounds leave the start at 0 (a start
    // midway between bounds near ±f64::MAX would overflow every residual).
    let gamma: Vec<f64> = (0..q)
        .map(|j| {
            if fixed[j] {
                return lo[j];
            }
            // Halves first: hi − lo may overflow.
            let margin = if has_lo[j] && has_hi[j] {
                (0.5 * hi[j] - 0.5 * lo[j]).min(1.0)
            } else {
                1.0
            };
            let lower = if has_lo[j] {
                lo[j] + margin
            } else {
                f64::NEG_INFINITY
            };
            let upper = if has_hi[j] {
                hi[j] - margin
            } else {
                f64::INFINITY
            };
            0.0f64.max(lower).min(upper)
        })
        .collect();
    let r = residual(&pb.z, &pb.y, &gamma);
    // Slacks of the order of the data, multipliers splitting C wᵢ evenly (so r_dξ = 0).
    let delta = scale;
    let xi: Vec<f64> = r.iter().map(|v| (v.abs() - eps).max(0.0) + delta).collect();
    let s = [
        (0..n).map(|i| xi[i] - r[i] + eps).collect::<Vec<f64>>(),
        (0..n).map(|i| xi[i] + r[i] + eps).collect(),
        xi.clone(),
    ];
    let l0: Vec<f64> = w.iter().map(|wi| c * wi / 3.0).collect();
    let mu_start = c * delta / 3.0;
    let s_b = [
        (0..q)
            .map(|j| {
                if has_lo[j] {
                    (gamma[j] - lo[j]).max(1.0)
                } else {
                    1.0
                }
            })
            .collect::<Vec<f64>>(),
        (0..q)
            .map(|j| {
                if has_hi[j] {
                    (hi[j] - gamma[j]).max(1.0)
                } else {
                    1.0
                }
            })
            .collect(),
    ];
    let l_b = [
        (0..q)
            .map(|j| if has_lo[j] { mu_start / s_b[0][j] } else { 0.0 })
            .collect::<Vec<f64>>(),
        (0..q)
            .map(|j| if has_hi[j] { mu_start / s_b[1][j] } else { 0.0 })
            .collect(),
    ];
    let count = (3 * n
        + has_lo.iter().filter(|&&b| b).count()
        + has_hi.iter().filter(|&&b| b).count()) as f64;
    let zeros = || vec![0.0; n];
    let mut st = State {
        pb,
        c,
        eps,
        lo,
        hi,
        has: [has_lo, has_hi],
        fixed,
        cols: (0..q).map(|j| col(&pb.z, j)).collect(),
        gamma,
        xi,
        r,
        s,
        l: [l0.clone(), l0.clone(), l0],
        s_b,
        l_b,
        inv_s: [zeros(), zeros(), zeros()],
        rp_b: [vec![0.0; q], vec![0.0; q]],
        a_inv: zeros(),
        b: zeros(),
        root_d: zeros(),
        u: zeros(),
        count,
    };
    let mut aff = Direction::new(n, q);
    let mut cor = Direction::new(n, q);
    let mut rc_b: [Vec<f64>; 2] = [vec![0.0; q], vec![0.0; q]];
    let mut last = Iterate {
        gamma: st.gamma.clone(),
        theta: vec![0.0; n],
        r: st.r.clone(),
        iterations: 0,
        gap: f64::INFINITY,
        f: f64::INFINITY,
        margin_candidates: n,
    };
    let mut mu = st.prepare();
    let mu0 = mu;
    let mut handed_out = usize::MAX;
    for it in 1..=MAX_ITERATIONS {
        let Some(chol) = st.factor() else {
            break;
        };
        // Predictor (affine scaling): targets s∘λ (the u of `prepare`).
        for side in 0..2 {
            for j in 0..q {
                rc_b[side][j] = st.s_b[side][j] * st.l_b[side][j];
            }
        }
        let (wb, wbd) = st.coefficient_direction(&chol, &rc_b, &mut aff);
        let summary = affine_samples(samples!(st), eps, c, &aff.zd);
        let inv = |w: f64| if w > 0.0 { 1.0 / w } else { f64::INFINITY };
        // The largest steps that keep the slacks and the multipliers positive.
        let (step_max, step_max_dual) =
            (inv(summary.worst.max(wb)), inv(summary.worst_dual.max(wbd)));
        // One step length for slacks and multipliers (separate ones made no difference
        // on the benchmark designs, and one keeps the dual residual of γ linear).
        let alpha_aff = step_max.min(step_max_dual).min(1.0);
        let [p0, p1, p2] = summary.poly;
        let mu_aff = (p0
            + alpha_aff * (p1 + alpha_aff * p2)
            + st.bounds_complementarity_after(&aff, alpha_aff))
            / st.count;
        let sigma = (mu_aff / mu).powi(3).clamp(0.0, 1.0);
        // Corrector: targets s∘λ + Δs_aff∘Δλ_aff − σμ.
        let target = sigma * mu;
        for side in 0..2 {
            for j in 0..q {
                rc_b[side][j] += aff.ds_b[side][j] * aff.dl_b[side][j] - target;
            }
        }
        corrector_rhs_samples(samples!(st), eps, c, &aff.zd, target, &mut st.u);
        let (wb, wbd) = st.coefficient_direction(&chol, &rc_b, &mut cor);
        let (ws, wd) = corrector_ratios(samples!(st), eps, c, &aff.zd, target, &cor.zd);
        let alpha = (STEP_FRACTION * inv(ws.max(wb)).min(inv(wd.max(wbd)))).min(1.0);
        if !(alpha > 0.0 && alpha.is_finite()) {
            break;
        }
        let mu_now = st.step(&aff, target, &cor, alpha);
        mu = mu_now;
        // The full check (two passes over Z, and the exact finish) only when it can
        // succeed: the margin candidates fit the q coordinates (the finish needs that), or
        // the complementarity — the interior point's own estimate of the duality gap — is
        // within ten times the certificate's tolerance.
        // Or, earlier, when the candidates have halved since the last such hand-out and are few
        // enough for the caller to solve the problem restricted to them (`super::shrunk`):
        // an attempt then costs about an iteration, and the attempts form a geometric series.
        let mut candidates = n;
        let worth_checking = mu_now <= 1e-4 * mu0 && {
            candidates = (0..n)
                .filter(|&i| {
                    let frac = (st.l[0][i] - st.l[1][i]).abs() / (c * w[i]);
                    frac > MARGIN_FRACTION && frac < 1.0 - MARGIN_FRACTION
                })
                .count();
            let shrinkable = candidates <= shrink_limit(n, q) && 2 * candidates <= handed_out;
            if shrinkable {
                handed_out = candidates;
            }
            shrinkable
                || (mu_now <= 1e-6 * mu0
                    && (candidates <= q
                        || mu_now * st.count <= 1e-9 * primal(&st.gamma, &st.r, w, c, eps)))
        };
        if worth_checking || it == MAX_ITERATIONS {
            let g: Vec<f64> = (0..q).map(|j| st.gamma[j].clamp(lo[j], hi[j])).collect();
            let rr = residual(&pb.z, &pb.y, &g);
            let theta: Vec<f64> = (0..n)
                .map(|i| (st.l[0][i] - st.l[1][i]).clamp(-c * w[i], c * w[i]))
                .collect();
            let f = primal(&g, &rr, w, c, eps);
            let gap = f - dual(pb, &theta, eps, lo, hi);
            last = Iterate {
                gamma: g,
                theta,
                r: rr,
                iterations: it,
                gap,
                f,
                margin_candidates: candidates,
            };
            if stop(&last) {
                return last;
            }
        }
    }
    last
}
