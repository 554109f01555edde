//! Fast linear ε-SVR in the q-dimensional coefficient space.
//!
//! Objective (scaled space): `F(γ) = ½‖γ‖² + C Σᵢ max(0, |rᵢ| − ε)`, `r = y − Zγ`, box
//! `lo ≤ γ ≤ hi`.
//!
//! 0. **Merging duplicates.** Exact duplicate samples `(zᵢ, yᵢ)` (stacked records at
//!    rest repeat one row hundreds of times) are merged into one sample of weight equal
//!    to their multiplicity, `C Σ wᵢ h(rᵢ)`; otherwise they all sit on the tube's edge
//!    together and the margin set exceeds q. Rows are found equal through a hash of
//!    their bits (one pass over Z) and then compared.
//! 1. **Interior point** ([`ipm`]): a Mehrotra predictor-corrector iteration whose
//!    normal equations are q × q; 13–20 iterations on the zig-zag designs, 25–70 where a
//!    steady turning circle puts thousands of nearly equal rows at the tube's edge. Once
//!    the complementarity is small, every iterate's multipliers θ propose the sets
//!    (inside, margin `0 < |θᵢ| < C wᵢ`, outside) for the exact finish (3), with a couple
//!    of corrections; the iterate itself is accepted only with a certified duality gap
//!    `F(γ) − D(θ) ≤ 1e-10 F(γ)`. Before the margin candidates fit the q coordinates, once
//!    they are a thirty-second of the samples, the problem restricted to them is solved
//!    (the decided samples enter as a shift of γ; [`shrunk`]) and its answer taken when the
//!    whole problem's exact finish or duality gap proves it: on the benchmark's turning-circle
//!    sets this ends 3–24 of 25–75 iterations early (1.05–1.35× faster per training set);
//!    where thousands of samples sit on the tube's edge, the decided sets are too often
//!    wrong for it to help.
//! 2. **Smoothing continuation** (the fallback, warm started from the last iterate, when
//!    the interior point ends uncertified): the hinge is replaced by a Huber-like `h_μ`
//!    (zero inside the tube, quadratic over a band of width μ outside it, linear beyond),
//!    `F_μ = ½‖γ‖² + C Σ h_μ(rᵢ)`, `0 ≤ F − F_μ ≤ C n μ/2`, minimised for μ = μ₀, μ₀/10, …
//!    by Newton steps (`∇²F_μ = I + (C/μ) Z_QᵀZ_Q` over the band samples Q; a box-QP step
//!    by the active-set method when bounds are present) with an exact line search. It
//!    needs 50–150 Newton steps on the benchmark designs, because the band changes a few
//!    samples at a time; the interior point replaced it as the first method for that
//!    reason.
//! 3. **Exact finish.** Given candidate sets — margin M (|r| = ε at the optimum), the
//!    samples O outside the tube, the coordinates B at a bound — the KKT conditions
//!    `γ_F = C Σ_O sᵢ zᵢ,F + Σ_M θᵢ zᵢ,F`, `zᵢγ = yᵢ − ε sᵢ (i ∈ M)` are linear in
//!    (γ_F, θ); their solution is accepted when every KKT condition (multiplier ranges,
//!    sides of the tube, bound multipliers) holds, i.e. it is the exact minimiser of F.
//!    Otherwise the sets are corrected primal-dual active-set style for a few rounds.
//!    A smoothed iterate is accepted by itself once its certified gap
//!    `F(γ) − F_μ(γ) + decrement` is below 1e-10 relative.
//!
//! Textbook dual coordinate descent and ADMM were slow or inexact on these collinear
//! designs; both Newton-type methods here are insensitive to the conditioning of Z
//! because the `I` term keeps their systems well posed.

use faer::Mat;

use crate::dense::linalg::{
    SmallQr, Tall, cholesky, cholesky_solve, col, gram, mat_vec, residual, zt_v,
};
use crate::error::EstimatorError;
use crate::problem::Problem;
use crate::solvers::active_set::{self, BoxL1};
use crate::solvers::solution::{Solution, is_unbounded, max_active_set_iterations};
use crate::types::Status;

mod data;
mod ipm;

use data::Data;

const MAX_STAGES: usize = 40;
const MAX_NEWTON_PER_STAGE: usize = 60;
const GAP_TOLERANCE: f64 = 1e-10;
/// Primal-dual active-set corrections per exact-finish attempt from an interior-point iterate.
const IPM_FINISH_ROUNDS: usize = 2;

struct Smoothed<'a> {
    pb: &'a Data,
    c: f64,
    eps: f64,
    mu: f64,
}

impl Smoothed<'_> {
    fn value(&self, gamma: &[f64], r: &[f64]) -> f64 {
        self.values(gamma, r).0
    }

    /// `(F_μ, F)` in one pass.
    fn values(&self, gamma: &[f64], r: &[f64]) -> (f64, f64) {
        let (mut smooth, mut hinge) = (0.0, 0.0);
        for (&ri, &wi) in r.iter().zip(&self.pb.w) {
            let a = ri.abs() - self.eps;
            if a > 0.0 {
                hinge += wi * a;
                smooth += wi
                    * if a < self.mu {
                        0.5 * a * a / self.mu
                    } else {
                        a - 0.5 * self.mu
                    };
            }
        }
        let reg = 0.5 * gamma.iter().map(|g| g * g).sum::<f64>();
        (reg + self.c * smooth, reg + self.c * hinge)
    }

    /// Weights `wᵢ h'_μ(rᵢ)` and the band samples Q.
    fn derivatives(&self, r: &[f64]) -> (Vec<f64>, Vec<usize>) {
        let mut w = vec![0.0; r.len()];
        let mut band = Vec::new();
        for (i, (&ri, &wi)) in r.iter().zip(&self.pb.w).enumerate() {
            let a = ri.abs() - self.eps;
            if a > 0.0 {
                if a < self.mu {
                    w[i] = wi * ri.signum() * a / self.mu;
                    band.push(i);
                } else {
                    w[i] = wi * ri.signum();
                }
            }
        }
        (w, band)
    }
}

impl Smoothed<'_> {
    /// Minimiser over `t ∈ [0, t_max]` of the convex, piecewise-quadratic
    /// `φ(t) = F_μ(γ + t d)`, by safeguarded Newton iterations on the piecewise-linear
    /// `φ'`: a few O(n) passes, against many more for backtracking once the step changes
    /// which samples are in the band.
    fn exact_step(
        &self,
        gamma: &[f64],
        d: &[f64],
        gd_total: f64,
        r: &[f64],
        zd: &[f64],
        t_max: f64,
    ) -> f64 {
        let gd: f64 = gamma.iter().zip(d).map(|(a, b)| a * b).sum();
        let dd: f64 = d.iter().map(|v| v * v).sum();
        let (c, eps, mu) = (self.c, self.eps, self.mu);
        let wts = &self.pb.w;
        // Samples whose residual stays in one linear region of h'_μ over the whole bracket
        // contribute `k0 + k1·t` to Σ wᵢaᵢh'_μ and `kh` to its slope; once a bracket is
        // known they are folded into these sums and only the others are visited again
        // (most samples, after the first few trials).
        let mut active: Vec<u32> = (0..r.len() as u32)
            .filter(|&i| zd[i as usize] != 0.0)
            .collect();
        let (mut k0, mut k1, mut kh) = (0.0, 0.0, 0.0);
        // Region of a residual value: 0 inside, ±1 band, ±2 outside.
        let region = |v: f64| -> i8 {
            let a = v.abs() - eps;
            let s = if v < 0.0 { -1 } else { 1 };
            if a <= 0.0 {
                0
            } else if a < mu {
                s
            } else {
                2 * s
            }
        };
        let fold =
            |active: &mut Vec<u32>, lo: f64, hi: f64, k0: &mut f64, k1: &mut f64, kh: &mut f64| {
                active.retain(|&iu| {
                    let i = iu as usize;
                    let (ri, ai, wi) = (r[i], zd[i], wts[i]);
                    let g = region(ri - lo * ai);
                    if g != region(ri - hi * ai) {
                        return true;
                    }
                    match g {
                        0 => {}
                        1 | -1 => {
                            // w a (r − t a − sε)/μ
                            let sf = f64::from(g);
                            *k0 += wi * ai * (ri - sf * eps) / mu;
                            *k1 -= wi * ai * ai / mu;
                            *kh += wi * ai * ai / mu;
                        }
                        _ => *k0 += wi * ai * f64::from(g / 2),
                    }
                    false
                });
            };
        let slope = |t: f64, active: &[u32], k0: f64, k1: f64, kh: f64| -> (f64, f64) {
            let (mut s1, mut s2) = (k0 + k1 * t, kh);
            for &iu in active {
                let i = iu as usize;
                let (ri, ai, wi) = (r[i], zd[i], wts[i]);
                let rt = ri - t * ai;
                let a = rt.abs() - eps;
                if a > 0.0 {
                    if a < mu {
                        s1 += wi * ai * rt.signum() * a / mu;
                        s2 += wi * ai * ai / mu;
                    } else {
                        s1 += wi * ai * rt.signum();
                    }
                }
            }
            (gd + t * dd - c * s1, dd + c * s2)
        };
        // φ'(0) = ∇F_μ·d, already known.
        let d0 = gd_total;
        if d0.is_nan() || d0 >= 0.0 {
            return 0.0;
        }
        // Bracket [lo, hi] with φ'(lo) < 0 < φ'(hi); the Newton step t = 1 is the first
        // trial, then Newton on φ' inside the bracket, regula falsi (Illinois) outside.
        let (mut lo, mut glo) = (0.0, d0);
        let (mut hi, mut ghi) = (f64::NAN, f64::NAN);
        let mut t = 1.0f64.min(t_max);
        let mut side = 0i32;
        let mut folded = (f64::NAN, f64::NAN);
        for _ in 0..60 {
            if !hi.is_nan() && (lo, hi) != folded {
                fold(&mut active, lo, hi, &mut k0, &mut k1, &mut kh);
                folded = (lo, hi);
            }
            let (g1, h1) = slope(t, &active, k0, k1, kh);
            // Slope down by ten orders of magnitude: φ(t) is within ~1e-20·|φ'(0)|·t of
            // its minimum along d.
            if g1.abs() <= 1e-10 * d0.abs() {
                return t;
            }
            if g1 < 0.0 {
                lo = t;
                glo = g1;
                if side == -1 {
                    ghi *= 0.5;
                }
                side = -1;
            } else {
                hi = t;
                ghi = g1;
                if side == 1 {
                    glo *= 0.5;
                }
                side = 1;
            }
            if hi.is_nan() {
                if t >= t_max {
                    return t_max;
                }
                t = (t - g1 / h1).min(t_max).max(2.0 * t).min(t_max);
                continue;
            }
            if hi - lo <= 1e-12 * hi {
                break;
            }
            let newton = t - g1 / h1;
            t = if newton > lo && newton < hi {
                newton
            } else {
                let secant = lo - glo * (hi - lo) / (ghi - glo);
                if secant > lo && secant < hi {
                    secant
                } else {
                    0.5 * (lo + hi)
                }
            };
        }
        // φ' changes sign inside [lo, hi]; lo keeps φ decreasing.
        if lo > 0.0 { lo } else { t }
    }
}

/// `Σ_{i∈Q} wᵢ zᵢzᵢᵀ` over the band samples Q, kept up to date between Newton steps:
/// consecutive bands share most samples, so adding the entering and removing the leaving
/// samples' outer products costs far less than the Gram of the whole band (which
/// dominated a Newton step when the band holds thousands of samples).
struct BandGram {
    member: Vec<bool>,
    g: Mat<f64>,
    valid: bool,
}

impl BandGram {
    fn new(n: usize, q: usize) -> Self {
        BandGram {
            member: vec![false; n],
            g: Mat::zeros(q, q),
            valid: false,
        }
    }

    fn weighted_gram(z: &Tall, wts: &[f64], rows: &[usize]) -> Mat<f64> {
        let q = z.ncols();
        if rows.is_empty() {
            return Mat::zeros(q, q);
        }
        let mut zq = Tall::zeros(rows.len(), q);
        for j in 0..q {
            let src = col(z, j);
            for (d, &i) in zq.col_mut(j).iter_mut().zip(rows) {
                *d = if wts[i] == 1.0 {
                    src[i]
                } else {
                    wts[i].sqrt() * src[i]
                };
            }
        }
        gram(zq.as_ref())
    }

    fn update(&mut self, z: &Tall, wts: &[f64], band: &[usize]) {
        let mut entering = Vec::new();
        let mut in_new = vec![false; self.member.len()];
        for &i in band {
            in_new[i] = true;
            if !self.member[i] {
                entering.push(i);
            }
        }
        let leaving: Vec<usize> = (0..self.member.len())
            .filter(|&i| self.member[i] && !in_new[i])
            .collect();
        if !self.valid || entering.len() + leaving.len() >= band.len() {
            self.g = Self::weighted_gram(z, wts, band);
            self.valid = true;
        } else {
            let plus = Self::weighted_gram(z, wts, &entering);
            let minus = Self::weighted_gram(z, wts, &leaving);
            let q = z.ncols();
            for j in 0..q {
                for i in 0..q {
                    self.g[(i, j)] += plus[(i, j)] - minus[(i, j)];
                }
            }
        }
        self.member = in_new;
    }

    /// `I + weight·Σ_Q wᵢ zᵢzᵢᵀ`.
    fn hessian(&self, weight: f64) -> Mat<f64> {
        let q = self.g.nrows();
        Mat::<f64>::from_fn(q, q, |i, j| {
            weight * self.g[(i, j)] + if i == j { 1.0 } else { 0.0 }
        })
    }
}

/// Minimises `F_μ` from `gamma` (in place). Returns the number of Newton steps.
/// Returns the number of Newton steps and the last Newton decrement `−∇F_μ·d`, which
/// bounds how far `F_μ(γ)` is above its minimum (twice the quadratic model's decrease).
///
/// A stage stops once the decrement is below a thousandth of the smoothing gap
/// `F(γ) − F_μ(γ)`: solving `F_μ` more exactly than it approximates F is wasted work for
/// an intermediate μ, and for the final μ the two together certify the result.
fn newton_stage(
    s: &Smoothed<'_>,
    gamma: &mut [f64],
    lo: &[f64],
    hi: &[f64],
    band_gram: &mut BandGram,
) -> (usize, f64) {
    let pb = s.pb;
    let q = pb.q();
    let unbounded = is_unbounded(lo, hi);
    let mut r = residual(&pb.z, &pb.y, gamma);
    let (mut f, mut f_true) = s.values(gamma, &r);
    let mut steps = 0;
    let mut decrement = f64::INFINITY;
    while steps < MAX_NEWTON_PER_STAGE {
        steps += 1;
        let (w, band) = s.derivatives(&r);
        let ztw = zt_v(&pb.z, &w);
        let g: Vec<f64> = (0..q).map(|j| gamma[j] - s.c * ztw[j]).collect();
        band_gram.update(&pb.z, &pb.w, &band);
        let h = band_gram.hessian(s.c / s.mu);
        // `target` is kept so that a full step lands exactly on the bounds it reaches,
        // which the exact finish relies on to recognise bound-held coordinates.
        let (d, target): (Vec<f64>, Option<Vec<f64>>) = if unbounded {
            let Some(l) = cholesky(h.as_ref(), 0.0) else {
                break;
            };
            let mut d: Vec<f64> = g.iter().map(|v| -v).collect();
            cholesky_solve(&l, &mut d);
            (d, None)
        } else {
            // min ½xᵀHx − (Hγ − g)ᵀx over the box, x = γ + d.
            let b: Vec<f64> = (0..q)
                .map(|i| (0..q).map(|j| h[(i, j)] * gamma[j]).sum::<f64>() - g[i])
                .collect();
            let prob = BoxL1 {
                h: h.as_ref(),
                b: &b,
                alpha: 0.0,
                lo,
                hi,
                ls: None,
                chol_rel_tol: 0.0,
            };
            let out = active_set::solve(&prob, gamma, max_active_set_iterations(q));
            let d = out.x.iter().zip(gamma.iter()).map(|(x, g)| x - g).collect();
            (d, Some(out.x))
        };
        decrement = -g.iter().zip(&d).map(|(a, b)| a * b).sum::<f64>();
        if decrement.is_nan() || decrement <= (1e-15 * f.abs()).max(1e-3 * (f_true - f)) {
            break;
        }
        let zd = mat_vec(&pb.z, &d);
        // A box step cannot be extended past its target; an unconstrained one can, when
        // samples leave the band along the way and the curvature drops.
        let t_max = if unbounded { 4.0 } else { 1.0 };
        let mut t = s.exact_step(gamma, &d, -decrement, &r, &zd, t_max);
        let mut trial_gamma = vec![0.0; q];
        let mut trial_r = vec![0.0; r.len()];
        let accepted = loop {
            match &target {
                Some(x) if t == 1.0 => trial_gamma.copy_from_slice(x),
                Some(_) => {
                    for j in 0..q {
                        trial_gamma[j] = (gamma[j] + t * d[j]).clamp(lo[j], hi[j]);
                    }
                }
                None => {
                    for j in 0..q {
                        trial_gamma[j] = gamma[j] + t * d[j];
                    }
                }
            }
            for (i, tr) in trial_r.iter_mut().enumerate() {
                *tr = r[i] - t * zd[i];
            }
            let (ft, ft_true) = s.values(&trial_gamma, &trial_r);
            if ft <= f - 1e-4 * t * decrement {
                f = ft;
                f_true = ft_true;
                break true;
            }
            t *= 0.5;
            if t < 1e-12 {
                break false;
            }
            if t > 1.0 && t < 2.0 {
                t = 1.0;
            }
        };
        if !accepted {
            break;
        }
        gamma.copy_from_slice(&trial_gamma);
        std::mem::swap(&mut r, &mut trial_r);
    }
    (steps, decrement)
}

/// Where a sample sits relative to the ε-tube in the exact KKT system.
#[derive(Clone, Copy, PartialEq)]
enum Side {
    Inside,
    /// On the tube's edge, `r = ε·s`, with multiplier `θ·s ∈ [0, C w]`.
    Margin(f64),
    /// Outside, `r·s > ε`, contributing `C s zᵢ` to γ.
    Outside(f64),
}

/// A duality gap certifies an iterate only when both it and the objective are finite
/// (`∞ ≤ ∞` would accept an overflowed iterate).
fn certified(gap: f64, f: f64) -> bool {
    gap.is_finite() && f.is_finite() && gap <= GAP_TOLERANCE * f
}

/// An exact-finish candidate is taken when its true objective is no worse than that of the
/// iterate it came from (`f`), up to rounding: the finish solves the KKT system of guessed sets,
/// and a wrong guess would show as a higher objective.
fn no_worse(pb: &Data, candidate: &[f64], f: f64, c: f64, eps: f64) -> bool {
    let r = residual(&pb.z, &pb.y, candidate);
    ipm::primal(candidate, &r, &pb.w, c, eps) <= f * (1.0 + 1e-12) + f64::MIN_POSITIVE
}

/// The sets read off a smoothed solution: its band samples are the candidate margin set.
fn sides_from_band(r: &[f64], eps: f64, mu: f64) -> Vec<Side> {
    r.iter()
        .map(|&ri| {
            let a = ri.abs() - eps;
            if a <= 0.0 {
                Side::Inside
            } else if a < mu {
                Side::Margin(ri.signum())
            } else {
                Side::Outside(ri.signum())
            }
        })
        .collect()
}

/// The sets read off an interior-point iterate: a multiplier strictly inside its range
/// `0 < |θᵢ| < C wᵢ` marks a margin sample, one at either end a sample inside or outside.
fn sides_from_multipliers(theta: &[f64], r: &[f64], w: &[f64], c: f64) -> Vec<Side> {
    theta
        .iter()
        .zip(r.iter().zip(w))
        .map(|(&t, (&ri, &wi))| {
            let frac = t.abs() / (c * wi);
            if frac <= ipm::MARGIN_FRACTION {
                Side::Inside
            } else if frac >= 1.0 - ipm::MARGIN_FRACTION {
                Side::Outside(ri.signum())
            } else {
                Side::Margin(t.signum())
            }
        })
        .collect()
}

/// The samples outside the tube as `sᵢwᵢ` (0 for the others) and their pull on γ,
/// `g = C Σ_out wᵢ sᵢ zᵢ`: with their multipliers at the bound, the part of γ they fix.
fn outside_pull(pb: &Data, sides: &[Side], c: f64) -> (Vec<f64>, Vec<f64>) {
    let out_sign: Vec<f64> = sides
        .iter()
        .zip(&pb.w)
        .map(|(sd, wi)| {
            if let Side::Outside(v) = sd {
                v * wi
            } else {
                0.0
            }
        })
        .collect();
    let g = zt_v(&pb.z, &out_sign).into_iter().map(|v| c * v).collect();
    (out_sign, g)
}

/// Primal-dual active-set corrections tried per finish: enough to swap every margin
/// sample once.
fn max_finish_rounds(q: usize) -> usize {
    2 * q + 4
}

/// The exact KKT solve, starting from the sets read off a smoothed solution and
/// correcting them primal-dual active-set style (moving each sample or coordinate whose
/// KKT condition fails to the set that condition points to). `None` when the sets do
/// not settle within a few rounds or the margin system is singular; the caller then
/// continues the continuation.
fn exact_finish(
    s: &Smoothed<'_>,
    gamma: &[f64],
    mut side: Vec<Side>,
    lo: &[f64],
    hi: &[f64],
    scale: f64,
    rounds: usize,
) -> Option<(Vec<f64>, Vec<Side>)> {
    let pb = s.pb;
    let (z, y, n, q) = (&pb.z, &pb.y, pb.n, pb.q());
    let wts = &pb.w;
    let (c, eps) = (s.c, s.eps);
    // Coordinates held at a bound: Some(value).
    let mut held: Vec<Option<f64>> = (0..q)
        .map(|j| (gamma[j] == lo[j] || gamma[j] == hi[j]).then_some(gamma[j]))
        .collect();
    let tol_w = 1e-9 * c;
    let tol_r = 1e-9 * scale;

    for _ in 0..rounds {
        let margin: Vec<usize> = (0..n)
            .filter(|&i| matches!(side[i], Side::Margin(_)))
            .collect();
        let free: Vec<usize> = (0..q).filter(|&j| held[j].is_none()).collect();
        let m = margin.len();
        if m > free.len() {
            return None;
        }
        let (_, g_out) = outside_pull(pb, &side, c);
        let mut new_gamma: Vec<f64> = (0..q).map(|j| held[j].unwrap_or(g_out[j])).collect();
        let mut theta = vec![0.0; m];
        if m > 0 {
            // γ_F = g_F + Kθ with K = Z_{M,F}ᵀ, and Z_M γ = y_M − ε s_M.
            let k_mat = Mat::<f64>::from_fn(free.len(), m, |t, k| col(z, free[t])[margin[k]]);
            let mut rhs: Vec<f64> = margin
                .iter()
                .map(|&i| {
                    let si = if let Side::Margin(v) = side[i] {
                        v
                    } else {
                        0.0
                    };
                    let mut v = y[i] - eps * si;
                    for (j, g) in new_gamma.iter().enumerate() {
                        v -= col(z, j)[i] * g;
                    }
                    v
                })
                .collect();
            let qr = SmallQr::new(k_mat.clone());
            if !qr.is_full_rank(1e-12) {
                return None;
            }
            qr.solve_rt(&mut rhs);
            qr.solve_r(&mut rhs);
            theta = rhs;
            for (t, &j) in free.iter().enumerate() {
                new_gamma[j] += (0..m).map(|k| k_mat[(t, k)] * theta[k]).sum::<f64>();
            }
        }

        // One correction per round, the worst violation first, dual (multiplier)
        // violations before primal ones: changing many sets at once makes the
        // primal-dual active-set iteration oscillate on these designs.
        let mut worst_dual: Option<(f64, usize, bool)> = None; // (size, index, is_sample)
        for (k, &i) in margin.iter().enumerate() {
            let Side::Margin(si) = side[i] else { continue };
            let w = si * theta[k];
            let cap = c * wts[i];
            let v = if w < -tol_w {
                -w
            } else if w > cap + tol_w {
                w - cap
            } else {
                0.0
            };
            if v > 0.0 && worst_dual.is_none_or(|(b, _, _)| v / c > b) {
                worst_dual = Some((v / c, k, true));
            }
        }
        let gmax = new_gamma
            .iter()
            .chain(&g_out)
            .fold(f64::MIN_POSITIVE, |a, v| a.max(v.abs()));
        let tol_g = 1e-9 * gmax;
        for j in 0..q {
            let Some(v) = held[j] else { continue };
            if lo[j] == hi[j] {
                continue;
            }
            let zm: f64 = margin
                .iter()
                .zip(&theta)
                .map(|(&i, th)| col(z, j)[i] * th)
                .sum();
            let deriv = new_gamma[j] - g_out[j] - zm;
            let size = if v == lo[j] { -deriv } else { deriv };
            if size > tol_g && worst_dual.is_none_or(|(b, _, _)| size / gmax > b) {
                worst_dual = Some((size / gmax, j, false));
            }
        }
        if let Some((_, k, is_sample)) = worst_dual {
            if is_sample {
                let i = margin[k];
                let Side::Margin(si) = side[i] else {
                    return None;
                };
                side[i] = if si * theta[k] < 0.0 {
                    Side::Inside
                } else {
                    Side::Outside(si)
                };
            } else {
                held[k] = None;
            }
            continue;
        }
        let mut worst_primal: Option<(f64, usize, bool)> = None;
        for &j in &free {
            let tol_b = 1e-12 * (1.0 + new_gamma[j].abs());
            let v = (lo[j] - new_gamma[j]).max(new_gamma[j] - hi[j]);
            if v > tol_b && worst_primal.is_none_or(|(b, _, _)| v / gmax > b) {
                worst_primal = Some((v / gmax, j, false));
            }
        }
        let r_new = residual(z, y, &new_gamma);
        for i in 0..n {
            let v = match side[i] {
                Side::Outside(si) => eps - si * r_new[i],
                Side::Inside => r_new[i].abs() - eps,
                Side::Margin(_) => 0.0,
            };
            if v > tol_r && worst_primal.is_none_or(|(b, _, _)| v / scale > b) {
                worst_primal = Some((v / scale, i, true));
            }
        }
        match worst_primal {
            None => {
                for j in 0..q {
                    new_gamma[j] = new_gamma[j].clamp(lo[j], hi[j]);
                }
                return Some((new_gamma, side));
            }
            Some((_, i, true)) => {
                side[i] = match side[i] {
                    Side::Outside(si) => Side::Margin(si),
                    _ => Side::Margin(r_new[i].signum()),
                };
            }
            Some((_, j, false)) => {
                held[j] = Some(if new_gamma[j] < lo[j] { lo[j] } else { hi[j] });
            }
        }
    }
    None
}

/// Rounds of [`shrunk`]: restricted solves, each after adding the decided samples the last
/// one contradicted.
const SHRINK_ROUNDS: usize = 4;

/// What a restricted solve ([`shrunk`]) proved about its answer.
enum Shrunk {
    /// Every KKT condition of the whole problem holds (its exact finish): the minimiser.
    Exact(Vec<f64>),
    /// Within the certified duality gap of the whole problem.
    Certified(Vec<f64>),
}

/// The problem restricted to the undecided samples of an interior-point iterate, which the
/// exact finish cannot take yet because they outnumber the q coordinates.
///
/// With the samples outside the tube (multiplier at ±C wᵢ) and inside it (0) taken as
/// decided, each outside sample's loss is linear in γ, `C wᵢ (sᵢ(yᵢ − zᵢγ) − ε)`, and
/// `½‖γ‖² − gᵀγ = ½‖γ − g‖² + const` with `g = C Σ_out wᵢ sᵢ zᵢ`. So `δ = γ − g` solves the
/// same SVR on the undecided samples alone, with targets `yᵢ − zᵢg` and the box shifted by
/// g: an interior point on a few hundred samples instead of thousands. Its answer is only
/// taken with a proof for the whole problem: its exact sets, with the decided ones, pass
/// the exact finish of the whole problem (every KKT condition checked), or its dual point,
/// completed by the decided multipliers, certifies the whole problem's duality gap. A
/// decided sample the answer contradicts (an "outside" one inside the tube or an "inside"
/// one outside it) joins the undecided ones for the next round. A wrong guess costs the
/// attempt, never the answer. (LIBSVM's shrinking rests on the same observation.)
fn shrunk(
    whole: &Smoothed<'_>,
    mut sides: Vec<Side>,
    lo: &[f64],
    hi: &[f64],
    scale: f64,
    limit: usize,
) -> Option<Shrunk> {
    let (pb, c, eps) = (whole.pb, whole.c, whole.eps);
    let q = pb.q();
    let tol_r = 1e-9 * scale;
    for _ in 0..SHRINK_ROUNDS {
        let undecided: Vec<usize> = (0..pb.n)
            .filter(|&i| matches!(sides[i], Side::Margin(_)))
            .collect();
        if undecided.is_empty() || undecided.len() > limit {
            return None;
        }
        let (out_sign, g) = outside_pull(pb, &sides, c);
        // y − Zg: the restricted targets, and what the decided samples contribute to k.
        let y_shifted = residual(&pb.z, &pb.y, &g);
        let sub = Data {
            z: pb.z.select_rows(&undecided),
            y: undecided.iter().map(|&i| y_shifted[i]).collect(),
            w: undecided.iter().map(|&i| pb.w[i]).collect(),
            n: undecided.len(),
        };
        let (sub_lo, sub_hi): (Vec<f64>, Vec<f64>) =
            (0..q).map(|j| (lo[j] - g[j], hi[j] - g[j])).unzip();
        let restricted = Smoothed {
            pb: &sub,
            c,
            eps,
            mu: 0.0,
        };
        // F(g + δ) = F_restricted(δ) + k while the decided sets hold, k = ½‖g‖² + C Σ_out wᵢ
        // (sᵢ(yᵢ − zᵢg) − ε): the restricted gap is judged against the whole objective,
        // which can be far smaller than the restricted one (‖δ‖ ≈ ‖g‖).
        let k = 0.5 * g.iter().map(|v| v * v).sum::<f64>()
            + c * (0..pb.n)
                .filter(|&i| out_sign[i] != 0.0)
                .map(|i| pb.w[i] * (out_sign[i].signum() * y_shifted[i] - eps))
                .sum::<f64>();
        let mut exact: Option<(Vec<f64>, Vec<Side>)> = None;
        let last = ipm::solve(&sub, c, eps, &sub_lo, &sub_hi, scale, |it| {
            let sd = sides_from_multipliers(&it.theta, &it.r, &sub.w, c);
            if let Some((delta, sd)) = exact_finish(
                &restricted,
                &it.gamma,
                sd,
                &sub_lo,
                &sub_hi,
                scale,
                IPM_FINISH_ROUNDS,
            ) && no_worse(&sub, &delta, it.f, c, eps)
            {
                exact = Some((delta, sd));
                return true;
            }
            certified(it.gap, it.f + k)
        });
        let shifted = |delta: &[f64]| -> Vec<f64> {
            (0..q)
                .map(|j| (delta[j] + g[j]).clamp(lo[j], hi[j]))
                .collect()
        };
        let gamma = if let Some((delta, inner_sides)) = exact {
            let mut all = sides.clone();
            for (&i, sd) in undecided.iter().zip(inner_sides) {
                all[i] = sd;
            }
            let gamma = shifted(&delta);
            if let Some((g, _)) = exact_finish(whole, &gamma, all, lo, hi, scale, IPM_FINISH_ROUNDS)
            {
                return Some(Shrunk::Exact(g));
            }
            gamma
        } else if certified(last.gap, last.f + k) {
            let gamma = shifted(&last.gamma);
            let mut theta: Vec<f64> = out_sign.iter().map(|v| c * v).collect();
            for (&i, t) in undecided.iter().zip(&last.theta) {
                theta[i] = *t;
            }
            let r = residual(&pb.z, &pb.y, &gamma);
            let f = ipm::primal(&gamma, &r, &pb.w, c, eps);
            if certified(f - ipm::dual(pb, &theta, eps, lo, hi), f) {
                return Some(Shrunk::Certified(gamma));
            }
            gamma
        } else {
            return None;
        };
        let r = residual(&pb.z, &pb.y, &gamma);
        let mut grew = false;
        for (sd, &ri) in sides.iter_mut().zip(&r) {
            let contradicted = match *sd {
                Side::Outside(si) => si * ri < eps - tol_r,
                Side::Inside => ri.abs() > eps + tol_r,
                Side::Margin(_) => false,
            };
            if contradicted {
                *sd = Side::Margin(ri.signum());
                grew = true;
            }
        }
        if !grew {
            return None;
        }
    }
    None
}

pub(crate) fn solve(
    problem: &Problem,
    c: f64,
    eps: f64,
    lo: &[f64],
    hi: &[f64],
) -> Result<Solution, EstimatorError> {
    let q = problem.q();
    let gamma: Vec<f64> = (0..q).map(|j| 0.0f64.clamp(lo[j], hi[j])).collect();
    if c == 0.0 {
        // Only ½‖γ‖² remains.
        return Ok(Solution {
            gamma,
            status: Status::Ok,
            iterations: 0,
        });
    }
    let data = Data::new(problem);
    let pb = &data;
    let n = problem.n as f64;
    let rms_y = (problem.y.iter().map(|v| v * v).sum::<f64>() / n).sqrt();
    let mut scale = eps.max(rms_y);
    if scale == 0.0 {
        scale = 1.0;
    }
    let mut iterations = 0;
    // The interior-point method first; its sets go to the exact finish (a few corrections
    // only: the next iterate brings better sets sooner than many corrections would).
    let s0 = Smoothed {
        pb,
        c,
        eps,
        mu: 0.0,
    };
    let mut finished: Option<Vec<f64>> = None;
    let out = ipm::solve(pb, c, eps, lo, hi, scale, |it| {
        let sides = sides_from_multipliers(&it.theta, &it.r, &pb.w, c);
        let shrinkable = it.margin_candidates > q;
        if let Some((cand, _)) = exact_finish(
            &s0,
            &it.gamma,
            sides.clone(),
            lo,
            hi,
            scale,
            IPM_FINISH_ROUNDS,
        ) && no_worse(pb, &cand, it.f, c, eps)
        {
            finished = Some(cand);
            return true;
        }
        if shrinkable {
            // An exact answer is taken as the exact finish's are; a certified one needs no
            // comparison with the iterate.
            match shrunk(&s0, sides, lo, hi, scale, 2 * it.margin_candidates) {
                Some(Shrunk::Exact(cand)) if no_worse(pb, &cand, it.f, c, eps) => {
                    finished = Some(cand);
                    return true;
                }
                Some(Shrunk::Certified(cand)) => {
                    finished = Some(cand);
                    return true;
                }
                _ => {}
            }
        }
        certified(it.gap, it.f)
    });
    iterations += out.iterations;
    if let Some(g) = finished {
        return Ok(Solution {
            gamma: g,
            status: Status::Ok,
            iterations,
        });
    }
    if certified(out.gap, out.f) {
        return Ok(Solution {
            gamma: out.gamma,
            status: Status::Ok,
            iterations,
        });
    }
    // Not certified (iteration limit, or a normal matrix that lost positive
    // definiteness): the smoothing continuation, warm started from the last iterate.
    // An iterate that went non-finite (overflow on extreme data) is no warm start.
    let start = if out.gamma.iter().all(|v| v.is_finite()) {
        out.gamma
    } else {
        gamma
    };
    let mut sol = continuation(pb, start, c, eps, lo, hi, scale);
    sol.iterations += iterations;
    Ok(sol)
}

/// The smoothing continuation from `gamma`: Newton stages on `F_μ` for μ = scale,
/// scale/10, …, each followed by an exact-finish attempt from its band samples.
fn continuation(
    pb: &Data,
    mut gamma: Vec<f64>,
    c: f64,
    eps: f64,
    lo: &[f64],
    hi: &[f64],
    scale: f64,
) -> Solution {
    let q = pb.q();
    let mut iterations = 0;
    let mut mu = scale;
    let mut band_gram = BandGram::new(pb.n, q);
    for _ in 0..MAX_STAGES {
        let s = Smoothed { pb, c, eps, mu };
        let (st, decrement) = newton_stage(&s, &mut gamma, lo, hi, &mut band_gram);
        iterations += st;
        let r = residual(&pb.z, &pb.y, &gamma);
        let f_true = ipm::primal(&gamma, &r, &pb.w, c, eps);

        let f_smooth = s.value(&gamma, &r);
        let sides = sides_from_band(&r, eps, mu);
        if let Some((candidate, _)) =
            exact_finish(&s, &gamma, sides, lo, hi, scale, max_finish_rounds(q))
            && no_worse(pb, &candidate, f_true, c, eps)
        {
            return Solution {
                gamma: candidate,
                status: Status::Ok,
                iterations,
            };
        }
        // F(γ) − F* ≤ [F(γ) − F_μ(γ)] + [F_μ(γ) − min F_μ], the latter at most the decrement.
        if certified((f_true - f_smooth) + decrement, f_true) {
            return Solution {
                gamma,
                status: Status::Ok,
                iterations,
            };
        }
        mu *= 0.1;
        if mu < 1e-14 * scale {
            break;
        }
    }
    Solution {
        gamma,
        status: Status::MaxIterations,
        iterations,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    /// A collinear design with repeated rows (as stacked records at rest produce), a
    /// target with outliers, and the problem in the scaled space.
    fn problem(n: usize) -> Problem {
        let phi = Mat::<f64>::from_fn(n, 5, |i, j| {
            let t = (i % (n - 20)) as f64 * 0.02;
            match j {
                0 => t.sin(),
                1 => t.sin() + 1e-3 * t.cos(),
                2 => (2.0 * t).cos(),
                3 => t.sin() * t.cos(),
                _ => 1.0,
            }
        });
        let y: Vec<f64> = (0..n)
            .map(|i| {
                let t = (i % (n - 20)) as f64 * 0.02;
                let outlier = if i % 37 == 0 { 0.5 } else { 0.0 };
                0.3 * t.sin() - 0.2 * (2.0 * t).cos() + 0.1 + outlier
            })
            .collect();
        Problem::new(phi.as_ref(), &y).unwrap()
    }

    fn check(lo: &[f64], hi: &[f64]) {
        let pb = problem(300);
        let data = Data::new(&pb);
        assert!(data.n < pb.n, "the repeated rows are merged");
        let (c, eps) = (2.0, 0.02);
        let scale = (pb.y.iter().map(|v| v * v).sum::<f64>() / pb.n as f64).sqrt();
        let start: Vec<f64> = (0..pb.q()).map(|j| 0.0f64.clamp(lo[j], hi[j])).collect();
        let slow = continuation(&data, start, c, eps, lo, hi, scale);
        let fast = solve(&pb, c, eps, lo, hi).unwrap();
        assert_eq!(slow.status, Status::Ok);
        assert_eq!(fast.status, Status::Ok);
        let value = |g: &[f64]| {
            let r = residual(&data.z, &data.y, g);
            ipm::primal(g, &r, &data.w, c, eps)
        };
        let (fs, ff) = (value(&slow.gamma), value(&fast.gamma));
        // Both end on a certified or exact optimum of a strongly convex problem.
        assert!((fs - ff).abs() <= 1e-9 * fs, "{fs:e} vs {ff:e}");
        for j in 0..pb.q() {
            assert!(lo[j] <= fast.gamma[j] && fast.gamma[j] <= hi[j]);
        }
    }

    #[test]
    fn continuation_and_interior_point_agree_unbounded() {
        check(&[f64::NEG_INFINITY; 5], &[f64::INFINITY; 5]);
    }

    #[test]
    fn bounds_near_the_largest_float_do_not_overflow_the_start() {
        // The interior point starts midway between finite bounds; lo + hi would be +∞.
        check(
            &[1e-3, -1e3, -1e3, -1e3, -1e3],
            &[1.7e308, 1e3, 1e3, 1e3, 1e3],
        );
    }

    #[test]
    fn continuation_and_interior_point_agree_with_bounds() {
        // One coordinate fixed, one one-sided, one boxed.
        let lo = [f64::NEG_INFINITY, 0.05, 0.0, -0.1, f64::NEG_INFINITY];
        let hi = [f64::INFINITY, 0.05, f64::INFINITY, 0.1, f64::INFINITY];
        check(&lo, &hi);
    }

    /// The sets of the optimum of `problem(300)` (by the continuation, which shares no code
    /// with the restricted solve), with `undecided` of them opened up, and the restricted
    /// solve's answer against the optimum.
    fn restricted(
        lo: &[f64],
        hi: &[f64],
        corrupt: impl Fn(&mut Vec<Side>),
    ) -> (Option<Shrunk>, f64, f64) {
        let pb = problem(300);
        let data = Data::new(&pb);
        let (c, eps) = (2.0, 0.02);
        let scale = (pb.y.iter().map(|v| v * v).sum::<f64>() / pb.n as f64).sqrt();
        let start: Vec<f64> = (0..pb.q()).map(|j| 0.0f64.clamp(lo[j], hi[j])).collect();
        let best = continuation(&data, start, c, eps, lo, hi, scale);
        let r = residual(&data.z, &data.y, &best.gamma);
        let value = |g: &[f64]| {
            let r = residual(&data.z, &data.y, g);
            ipm::primal(g, &r, &data.w, c, eps)
        };
        // Outside and inside by the residual; everything within 10 % of ε of the edge undecided.
        let mut sides: Vec<Side> = r
            .iter()
            .map(|&ri| {
                let a = ri.abs() - eps;
                if a.abs() <= 0.1 * eps {
                    Side::Margin(ri.signum())
                } else if a > 0.0 {
                    Side::Outside(ri.signum())
                } else {
                    Side::Inside
                }
            })
            .collect();
        corrupt(&mut sides);
        let whole = Smoothed {
            pb: &data,
            c,
            eps,
            mu: 0.0,
        };
        let out = shrunk(&whole, sides, lo, hi, scale, data.n);
        let f = match &out {
            Some(Shrunk::Exact(g) | Shrunk::Certified(g)) => value(g),
            None => f64::NAN,
        };
        (out, f, value(&best.gamma))
    }

    #[test]
    fn the_restricted_solve_finds_the_optimum_from_its_undecided_samples() {
        for (lo, hi) in [
            ([f64::NEG_INFINITY; 5], [f64::INFINITY; 5]),
            (
                [f64::NEG_INFINITY, 0.05, 0.0, -0.1, f64::NEG_INFINITY],
                [f64::INFINITY, 0.05, f64::INFINITY, 0.1, f64::INFINITY],
            ),
        ] {
            let (out, f, best) = restricted(&lo, &hi, |_| {});
            assert!(out.is_some(), "{lo:?}");
            assert!((f - best).abs() <= 1e-9 * best, "{f:e} vs {best:e}");
        }
    }

    #[test]
    fn a_wrongly_decided_sample_costs_the_attempt_never_the_answer() {
        // Samples well inside the tube declared outside (and the reverse): the answer that
        // comes back, if any, is still the optimum; the growth rounds put them right here.
        let (out, f, best) = restricted(&[f64::NEG_INFINITY; 5], &[f64::INFINITY; 5], |sides| {
            let mut flipped = 0;
            for sd in sides.iter_mut() {
                *sd = match *sd {
                    Side::Inside if flipped < 3 => {
                        flipped += 1;
                        Side::Outside(1.0)
                    }
                    Side::Outside(_) if flipped < 6 => {
                        flipped += 1;
                        Side::Inside
                    }
                    other => other,
                };
            }
        });
        assert!(out.is_some());
        assert!((f - best).abs() <= 1e-9 * best, "{f:e} vs {best:e}");
    }
}
