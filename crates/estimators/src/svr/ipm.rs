//! Primal-dual interior-point method (Mehrotra predictor-corrector) for the linear ε-SVR,
//! with q × q normal equations.
//!
//! Why an interior-point method: the smoothing continuation of [`super`] changes which
//! samples carry curvature a few at a time, so its Newton steps grow with the number of
//! samples near the tube's edge — on designs stacked with a steady turning circle,
//! thousands of nearly equal rows sit within 1e-8 of the edge and it took 100–150 steps.
//! The interior-point iteration count does not depend on that structure (15–30 here),
//! and each iteration costs one weighted Gram `Σ dᵢ zᵢzᵢᵀ` plus four passes over Z.
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

use crate::kernels;
use crate::linalg::{cholesky, cholesky_solve, col, mat_vec, residual, zt_v};

use super::Data;

/// Outcome of [`solve`]: the iterate and its multipliers θ (for the exact finish).
pub(super) struct Iterate {
    pub(super) gamma: Vec<f64>,
    pub(super) theta: Vec<f64>,
    pub(super) r: Vec<f64>,
    pub(super) iterations: usize,
    /// Certified `F(γ) − F* ≤ gap`.
    pub(super) gap: f64,
    pub(super) f: f64,
}

const MAX_ITERATIONS: usize = 80;
/// A multiplier with `MARGIN_FRACTION < |θᵢ|/(C wᵢ) < 1 − MARGIN_FRACTION` marks a margin
/// candidate (see `sides_from_multipliers` in [`super`]).
pub(super) const MARGIN_FRACTION: f64 = 1e-3;
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

/// A Newton direction: the per-sample parts (Δξ, Δs₁…₃, Δλ₁…₃), the coefficient part
/// (Δγ, Δs₄,₅, Δλ₄,₅), `ZΔγ`, and the largest step that keeps s and λ positive.
struct Direction {
    dg: Vec<f64>,
    dxi: Vec<f64>,
    ds: [Vec<f64>; 3],
    dl: [Vec<f64>; 3],
    ds_b: [Vec<f64>; 2],
    dl_b: [Vec<f64>; 2],
    zd: Vec<f64>,
    step_max: f64,
    /// The same for the multipliers (`step_max` covers the slacks).
    step_max_dual: f64,
}

impl Direction {
    fn new(n: usize, q: usize) -> Self {
        Direction {
            dg: vec![0.0; q],
            dxi: vec![0.0; n],
            ds: std::array::from_fn(|_| vec![0.0; n]),
            dl: std::array::from_fn(|_| vec![0.0; n]),
            ds_b: std::array::from_fn(|_| vec![0.0; q]),
            dl_b: std::array::from_fn(|_| vec![0.0; q]),
            zd: vec![0.0; n],
            step_max: 0.0,
            step_max_dual: 0.0,
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
    gamma: Vec<f64>,
    xi: Vec<f64>,
    r: Vec<f64>,
    s: [Vec<f64>; 3],
    l: [Vec<f64>; 3],
    s_b: [Vec<f64>; 2],
    l_b: [Vec<f64>; 2],
    // Per-iteration quantities.
    inv_s: [Vec<f64>; 3],
    inv_l: [Vec<f64>; 3],
    rp: [Vec<f64>; 3],
    rp_b: [Vec<f64>; 2],
    a_inv: Vec<f64>,
    b: Vec<f64>,
    root_d: Vec<f64>,
    rhs_xi: Vec<f64>,
    u: Vec<f64>,
    count: f64,
}

// The per-sample loops are free functions of slices: as arguments, `&mut` slices carry
// no-alias information into the inlined loop, without which the vectoriser gives up on
// a dozen streams that might overlap.

#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn prepare_samples(
    eps: f64,
    s: [&[f64]; 3],
    l: [&[f64]; 3],
    xi: &[f64],
    r: &[f64],
    inv_s: [&mut [f64]; 3],
    inv_l: [&mut [f64]; 3],
    rp: [&mut [f64]; 3],
    a_inv: &mut [f64],
    b: &mut [f64],
    root_d: &mut [f64],
) {
    let n = xi.len();
    let [s1, s2, s3] = s.map(|v| &v[..n]);
    let [l1, l2, l3] = l.map(|v| &v[..n]);
    let [is1, is2, is3] = inv_s;
    let [il1, il2, il3] = inv_l;
    let [rp1, rp2, rp3] = rp;
    let (is1, is2, is3, il1, il2, il3) = (
        &mut is1[..n],
        &mut is2[..n],
        &mut is3[..n],
        &mut il1[..n],
        &mut il2[..n],
        &mut il3[..n],
    );
    let (rp1, rp2, rp3) = (&mut rp1[..n], &mut rp2[..n], &mut rp3[..n]);
    let (a_inv, b, root_d, r) = (&mut a_inv[..n], &mut b[..n], &mut root_d[..n], &r[..n]);
    for i in 0..n {
        let (x1, x2, x3) = (1.0 / s1[i], 1.0 / s2[i], 1.0 / s3[i]);
        is1[i] = x1;
        is2[i] = x2;
        is3[i] = x3;
        il1[i] = 1.0 / l1[i];
        il2[i] = 1.0 / l2[i];
        il3[i] = 1.0 / l3[i];
        let (d1, d2, d3) = (l1[i] * x1, l2[i] * x2, l3[i] * x3);
        let ai = 1.0 / (d1 + d2 + d3);
        a_inv[i] = ai;
        b[i] = d1 - d2;
        root_d[i] = ((4.0 * d1 * d2 + d3 * (d1 + d2)) * ai).sqrt();
        rp1[i] = xi[i] - r[i] + eps - s1[i];
        rp2[i] = xi[i] + r[i] + eps - s2[i];
        rp3[i] = xi[i] - s3[i];
    }
}

/// `rhs_ξ` and the vector u whose `Zᵀu` is the γ part of the reduced right-hand side.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn rhs_samples(
    rc: [&[f64]; 3],
    c: f64,
    w: &[f64],
    l: [&[f64]; 3],
    inv_s: [&[f64]; 3],
    rp: [&[f64]; 3],
    b: &[f64],
    a_inv: &[f64],
    rhs_xi: &mut [f64],
    u: &mut [f64],
) {
    let n = w.len();
    let [rc1, rc2, rc3] = rc.map(|v| &v[..n]);
    let [l1, l2, l3] = l.map(|v| &v[..n]);
    let [is1, is2, is3] = inv_s.map(|v| &v[..n]);
    let [rp1, rp2, rp3] = rp.map(|v| &v[..n]);
    let (b, a_inv, rhs_xi, u) = (&b[..n], &a_inv[..n], &mut rhs_xi[..n], &mut u[..n]);
    for i in 0..n {
        let g1 = (rc1[i] + l1[i] * rp1[i]) * is1[i];
        let g2 = (rc2[i] + l2[i] * rp2[i]) * is2[i];
        let g3 = (rc3[i] + l3[i] * rp3[i]) * is3[i];
        let r_dxi = c * w[i] - l1[i] - l2[i] - l3[i];
        let rhs = -r_dxi - (g1 + g2 + g3);
        rhs_xi[i] = rhs;
        u[i] = (l1[i] - l2[i]) - (g1 - g2) - b[i] * a_inv[i] * rhs;
    }
}

/// Δξ, Δs, Δλ per sample from `ZΔγ`; returns the largest `−Δs/s` and `−Δλ/λ` (0 if none
/// is negative).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn step_samples(
    rc: [&[f64]; 3],
    l: [&[f64]; 3],
    inv_s: [&[f64]; 3],
    inv_l: [&[f64]; 3],
    rp: [&[f64]; 3],
    b: &[f64],
    a_inv: &[f64],
    rhs_xi: &[f64],
    zd: &[f64],
    dxi_out: &mut [f64],
    ds_out: [&mut [f64]; 3],
    dl_out: [&mut [f64]; 3],
) -> (f64, f64) {
    let n = zd.len();
    let [rc1, rc2, rc3] = rc.map(|v| &v[..n]);
    let [l1, l2, l3] = l.map(|v| &v[..n]);
    let [is1, is2, is3] = inv_s.map(|v| &v[..n]);
    let [il1, il2, il3] = inv_l.map(|v| &v[..n]);
    let [rp1, rp2, rp3] = rp.map(|v| &v[..n]);
    let (b, a_inv, rhs_xi, dxi_out) = (&b[..n], &a_inv[..n], &rhs_xi[..n], &mut dxi_out[..n]);
    let [ds1o, ds2o, ds3o] = ds_out;
    let [dl1o, dl2o, dl3o] = dl_out;
    let (ds1o, ds2o, ds3o) = (&mut ds1o[..n], &mut ds2o[..n], &mut ds3o[..n]);
    let (dl1o, dl2o, dl3o) = (&mut dl1o[..n], &mut dl2o[..n], &mut dl3o[..n]);
    for i in 0..n {
        let dxi = (rhs_xi[i] - b[i] * zd[i]) * a_inv[i];
        dxi_out[i] = dxi;
        let ds1 = dxi + zd[i] + rp1[i];
        let ds2 = dxi - zd[i] + rp2[i];
        let ds3 = dxi + rp3[i];
        ds1o[i] = ds1;
        ds2o[i] = ds2;
        ds3o[i] = ds3;
        dl1o[i] = -(rc1[i] + l1[i] * ds1) * is1[i];
        dl2o[i] = -(rc2[i] + l2[i] * ds2) * is2[i];
        dl3o[i] = -(rc3[i] + l3[i] * ds3) * is3[i];
    }
    (
        largest_ratio([ds1o, ds2o, ds3o], [is1, is2, is3]),
        largest_ratio([dl1o, dl2o, dl3o], [il1, il2, il3]),
    )
}

/// `max(0, max_{k,i} −v_k,i · inv_k,i)`, in lanes of 8 with plain comparisons (the
/// NaN-aware `f64::max` does not vectorise).
#[inline(always)]
fn largest_ratio(v: [&[f64]; 3], inv: [&[f64]; 3]) -> f64 {
    let big = |a: f64, b: f64| if a > b { a } else { b };
    let mut lanes = [0.0f64; 8];
    for k in 0..3 {
        for (vc, ic) in v[k].chunks_exact(8).zip(inv[k].chunks_exact(8)) {
            for l in 0..8 {
                lanes[l] = big(-vc[l] * ic[l], lanes[l]);
            }
        }
        let tail = v[k].len() - v[k].len() % 8;
        for (x, y) in v[k][tail..].iter().zip(&inv[k][tail..]) {
            lanes[0] = big(-x * y, lanes[0]);
        }
    }
    lanes.iter().fold(0.0f64, |a, &x| big(x, a))
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

    /// Mean complementarity `sᵀλ / m`.
    #[inline(always)]
    fn complementarity(&self) -> f64 {
        let n = self.pb.n;
        let (s1, s2, s3) = (&self.s[0][..n], &self.s[1][..n], &self.s[2][..n]);
        let (l1, l2, l3) = (&self.l[0][..n], &self.l[1][..n], &self.l[2][..n]);
        let mut acc = [0.0f64; 8];
        for i in 0..n {
            acc[i % 8] += s1[i] * l1[i] + s2[i] * l2[i] + s3[i] * l3[i];
        }
        (acc.iter().sum::<f64>() + self.bounds_complementarity()) / self.count
    }

    /// Scalings `D_k = λ_k/s_k`, the eliminated-ξ coefficients and the primal residuals.
    #[inline(always)]
    fn prepare(&mut self) {
        let n = self.pb.n;
        let eps = self.eps;
        let [s1, s2, s3] = &self.s;
        let [l1, l2, l3] = &self.l;
        let (s1, s2, s3, l1, l2, l3) = (&s1[..n], &s2[..n], &s3[..n], &l1[..n], &l2[..n], &l3[..n]);
        let (xi, r) = (&self.xi[..n], &self.r[..n]);
        let [is1, is2, is3] = &mut self.inv_s;
        let [il1, il2, il3] = &mut self.inv_l;
        let [rp1, rp2, rp3] = &mut self.rp;
        let (is1, is2, is3) = (&mut is1[..n], &mut is2[..n], &mut is3[..n]);
        let (il1, il2, il3) = (&mut il1[..n], &mut il2[..n], &mut il3[..n]);
        let (rp1, rp2, rp3) = (&mut rp1[..n], &mut rp2[..n], &mut rp3[..n]);
        let (a_inv, b, root_d) = (
            &mut self.a_inv[..n],
            &mut self.b[..n],
            &mut self.root_d[..n],
        );
        prepare_samples(
            eps,
            [s1, s2, s3],
            [l1, l2, l3],
            xi,
            r,
            [is1, is2, is3],
            [il1, il2, il3],
            [rp1, rp2, rp3],
            a_inv,
            b,
            root_d,
        );
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
    fn factor(&self, sz: &mut [f64]) -> Option<faer::Mat<f64>> {
        let (n, q) = (self.pb.n, self.pb.q());
        for j in 0..q {
            let dst = &mut sz[j * n..(j + 1) * n];
            for ((o, &z), &rd) in dst.iter_mut().zip(col(&self.pb.z, j)).zip(&self.root_d) {
                *o = z * rd;
            }
        }
        let cols: Vec<&[f64]> = (0..q).map(|j| &sz[j * n..(j + 1) * n]).collect();
        let up = kernels::cross_products(&cols, n);
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

    /// The Newton direction for the complementarity targets `rc(i)` (per sample) and
    /// `rc_b` (per bound side), into `out`.
    #[inline(always)]
    fn direction(
        &mut self,
        chol: &faer::Mat<f64>,
        rc: [&[f64]; 3],
        rc_b: &[Vec<f64>; 2],
        out: &mut Direction,
    ) {
        let (n, q) = (self.pb.n, self.pb.q());
        let c = self.c;
        {
            let w = &self.pb.w[..n];
            let [l1, l2, l3] = &self.l;
            let (l1, l2, l3) = (&l1[..n], &l2[..n], &l3[..n]);
            let [is1, is2, is3] = &self.inv_s;
            let (is1, is2, is3) = (&is1[..n], &is2[..n], &is3[..n]);
            let [rp1, rp2, rp3] = &self.rp;
            let (rp1, rp2, rp3) = (&rp1[..n], &rp2[..n], &rp3[..n]);
            let (b, a_inv) = (&self.b[..n], &self.a_inv[..n]);
            let (rhs_xi, u) = (&mut self.rhs_xi[..n], &mut self.u[..n]);
            // g_k = S⁻¹ rc_k + D_k rp_k; rhs_ξ = −r_dξ − (g₁ + g₂ + g₃); the γ part goes
            // through Zᵀ: (λ₁ − λ₂) − (g₁ − g₂) − (b/a) rhs_ξ.
            rhs_samples(
                rc,
                c,
                w,
                [l1, l2, l3],
                [is1, is2, is3],
                [rp1, rp2, rp3],
                b,
                a_inv,
                rhs_xi,
                u,
            );
        }
        let ztu = zt_v(&self.pb.z, &self.u);
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
        out.zd = mat_vec(&self.pb.z, &out.dg);
        // Δs = A Δx + r_p (rows of A: (1, z), (1, −z), (1, 0)); Δλ = −S⁻¹(rc + Λ Δs);
        // the step limit from the largest −Δv/v (lane-wise maxima, so that it vectorises).
        let (mut worst, mut worst_d): (f64, f64);
        {
            let [l1, l2, l3] = &self.l;
            let (l1, l2, l3) = (&l1[..n], &l2[..n], &l3[..n]);
            let [is1, is2, is3] = &self.inv_s;
            let (is1, is2, is3) = (&is1[..n], &is2[..n], &is3[..n]);
            let [il1, il2, il3] = &self.inv_l;
            let (il1, il2, il3) = (&il1[..n], &il2[..n], &il3[..n]);
            let [rp1, rp2, rp3] = &self.rp;
            let (rp1, rp2, rp3) = (&rp1[..n], &rp2[..n], &rp3[..n]);
            let (b, a_inv, rhs_xi) = (&self.b[..n], &self.a_inv[..n], &self.rhs_xi[..n]);
            let zd = &out.zd[..n];
            let dxi_out = &mut out.dxi[..n];
            let [ds1o, ds2o, ds3o] = &mut out.ds;
            let (ds1o, ds2o, ds3o) = (&mut ds1o[..n], &mut ds2o[..n], &mut ds3o[..n]);
            let [dl1o, dl2o, dl3o] = &mut out.dl;
            let (dl1o, dl2o, dl3o) = (&mut dl1o[..n], &mut dl2o[..n], &mut dl3o[..n]);
            (worst, worst_d) = step_samples(
                rc,
                [l1, l2, l3],
                [is1, is2, is3],
                [il1, il2, il3],
                [rp1, rp2, rp3],
                b,
                a_inv,
                rhs_xi,
                zd,
                dxi_out,
                [ds1o, ds2o, ds3o],
                [dl1o, dl2o, dl3o],
            );
        }

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
        out.step_max = if worst > 0.0 {
            1.0 / worst
        } else {
            f64::INFINITY
        };
        out.step_max_dual = if worst_d > 0.0 {
            1.0 / worst_d
        } else {
            f64::INFINITY
        };
    }

    /// Mean complementarity after a step `alpha` along `d`.
    #[inline(always)]
    fn complementarity_after(&self, d: &Direction, alpha: f64) -> f64 {
        let n = self.pb.n;
        let mut acc = [0.0f64; 8];
        for k in 0..3 {
            let (s, l, ds, dl) = (
                &self.s[k][..n],
                &self.l[k][..n],
                &d.ds[k][..n],
                &d.dl[k][..n],
            );
            for i in 0..n {
                acc[i % 8] += (s[i] + alpha * ds[i]) * (l[i] + alpha * dl[i]);
            }
        }
        let mut t: f64 = acc.iter().sum();
        for side in 0..2 {
            for j in 0..self.gamma.len() {
                if self.has[side][j] {
                    t += (self.s_b[side][j] + alpha * d.ds_b[side][j])
                        * (self.l_b[side][j] + alpha * d.dl_b[side][j]);
                }
            }
        }
        t / self.count
    }

    #[inline(always)]
    fn step(&mut self, d: &Direction, alpha: f64) {
        for j in 0..self.gamma.len() {
            self.gamma[j] += alpha * d.dg[j];
            for side in 0..2 {
                if self.has[side][j] {
                    self.s_b[side][j] += alpha * d.ds_b[side][j];
                    self.l_b[side][j] += alpha * d.dl_b[side][j];
                }
            }
        }
        for (v, dv) in self.xi.iter_mut().zip(&d.dxi) {
            *v += alpha * dv;
        }
        for (v, dv) in self.r.iter_mut().zip(&d.zd) {
            *v -= alpha * dv;
        }
        for k in 0..3 {
            for (v, dv) in self.s[k].iter_mut().zip(&d.ds[k]) {
                *v += alpha * dv;
            }
            for (v, dv) in self.l[k].iter_mut().zip(&d.dl[k]) {
                *v += alpha * dv;
            }
        }
    }
}

/// Runs the interior-point iteration until `stop` accepts an iterate or the iteration
/// limit is reached. `stop(iterate)` is called after every iteration once the mean
/// complementarity has fallen below `1e-6` of its start; it returns true to finish.
pub(super) fn solve(
    pb: &Data,
    c: f64,
    eps: f64,
    lo: &[f64],
    hi: &[f64],
    scale: f64,
    stop: impl FnMut(&Iterate) -> bool,
) -> Iterate {
    // The per-sample loops are most of the work; compiled for the widest vector unit
    // available (chosen at run time), as the kernels of [`crate::kernels`] are.
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            #[target_feature(enable = "avx512f,avx2,fma")]
            fn avx512(
                pb: &Data,
                c: f64,
                eps: f64,
                lo: &[f64],
                hi: &[f64],
                scale: f64,
                stop: impl FnMut(&Iterate) -> bool,
            ) -> Iterate {
                solve_generic(pb, c, eps, lo, hi, scale, stop)
            }
            // SAFETY: the CPU supports AVX-512F (checked just above).
            return unsafe { avx512(pb, c, eps, lo, hi, scale, stop) };
        }
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            #[target_feature(enable = "avx2,fma")]
            fn avx2(
                pb: &Data,
                c: f64,
                eps: f64,
                lo: &[f64],
                hi: &[f64],
                scale: f64,
                stop: impl FnMut(&Iterate) -> bool,
            ) -> Iterate {
                solve_generic(pb, c, eps, lo, hi, scale, stop)
            }
            // SAFETY: the CPU supports AVX2 and FMA (checked just above).
            return unsafe { avx2(pb, c, eps, lo, hi, scale, stop) };
        }
    }
    solve_generic(pb, c, eps, lo, hi, scale, stop)
}

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
        gamma,
        xi,
        r,
        s,
        l: [l0.clone(), l0.clone(), l0],
        s_b,
        l_b,
        inv_s: [zeros(), zeros(), zeros()],
        inv_l: [zeros(), zeros(), zeros()],
        rp: [zeros(), zeros(), zeros()],
        rp_b: [vec![0.0; q], vec![0.0; q]],
        a_inv: zeros(),
        b: zeros(),
        root_d: zeros(),
        rhs_xi: zeros(),
        u: zeros(),
        count,
    };
    let mu0 = st.complementarity();
    let mut sz = vec![0.0; n * q];
    let mut aff = Direction::new(n, q);
    let mut cor = Direction::new(n, q);
    let mut rc: [Vec<f64>; 3] = [zeros(), zeros(), zeros()];
    let mut rc_b: [Vec<f64>; 2] = [vec![0.0; q], vec![0.0; q]];
    let mut last = Iterate {
        gamma: st.gamma.clone(),
        theta: vec![0.0; n],
        r: st.r.clone(),
        iterations: 0,
        gap: f64::INFINITY,
        f: f64::INFINITY,
    };
    for it in 1..=MAX_ITERATIONS {
        let mu = st.complementarity();
        st.prepare();
        let Some(chol) = st.factor(&mut sz) else {
            break;
        };
        // Predictor (affine scaling): rc = s∘λ.
        for side in 0..2 {
            for j in 0..q {
                rc_b[side][j] = st.s_b[side][j] * st.l_b[side][j];
            }
        }
        for k in 0..3 {
            for ((o, a), b) in rc[k].iter_mut().zip(&st.s[k]).zip(&st.l[k]) {
                *o = a * b;
            }
        }
        st.direction(&chol, [&rc[0], &rc[1], &rc[2]], &rc_b, &mut aff);
        // One step length for slacks and multipliers (separate ones made no difference
        // on the benchmark designs, and one keeps the dual residual of γ linear).
        let alpha_aff = aff.step_max.min(aff.step_max_dual).min(1.0);
        let mu_aff = st.complementarity_after(&aff, alpha_aff);
        let sigma = (mu_aff / mu).powi(3).clamp(0.0, 1.0);
        // Corrector: rc = s∘λ + Δs_aff∘Δλ_aff − σμ.
        let target = sigma * mu;
        for side in 0..2 {
            for j in 0..q {
                rc_b[side][j] += aff.ds_b[side][j] * aff.dl_b[side][j] - target;
            }
        }
        for k in 0..3 {
            for ((o, a), b) in rc[k].iter_mut().zip(&aff.ds[k]).zip(&aff.dl[k]) {
                *o += a * b - target;
            }
        }
        st.direction(&chol, [&rc[0], &rc[1], &rc[2]], &rc_b, &mut cor);
        let alpha = (STEP_FRACTION * cor.step_max.min(cor.step_max_dual)).min(1.0);
        if !(alpha > 0.0 && alpha.is_finite()) {
            break;
        }
        st.step(&cor, alpha);
        let mu_now = st.complementarity();
        // The full check (two passes over Z, and the exact finish) only when it can
        // succeed: the margin candidates fit the q coordinates (the finish needs that), or
        // the complementarity — the interior point's own estimate of the duality gap — is
        // within ten times the certificate's tolerance.
        let worth_checking = || {
            let candidates = (0..n)
                .filter(|&i| {
                    let frac = (st.l[0][i] - st.l[1][i]).abs() / (c * w[i]);
                    frac > MARGIN_FRACTION && frac < 1.0 - MARGIN_FRACTION
                })
                .count();
            candidates <= q || mu_now * st.count <= 1e-9 * primal(&st.gamma, &st.r, w, c, eps)
        };
        if (mu_now <= 1e-6 * mu0 && worth_checking()) || it == MAX_ITERATIONS {
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
            };
            if stop(&last) {
                return last;
            }
        }
    }
    last
}
