//! Extreme eigenvalues of a small symmetric matrix (the p × p Gram, p ≲ 70) and an
//! eigenvector of the smallest: Householder tridiagonalisation, safeguarded Laguerre steps on
//! the characteristic polynomial (bisection on Sturm counts where they stall), inverse
//! iteration on the tridiagonal matrix.
//!
//! faer's dense eigensolvers cost about 45 µs at p = 22 (set-up and blocking meant for
//! large matrices), more than the whole least-squares fit they serve; the direct LSQ path
//! only needs λ_min, λ_max and one eigenvector, which this does in a few µs with the same
//! backward stability (eigenvalues of the tridiagonal matrix to about ε‖G‖).

use crate::dense::kernels::madd;

/// Relative width of the bracket at which the extreme-eigenvalue search stops: the callers
/// need κ = √(λ_max/λ_min) to 1e-6 relative (what [`mod@crate::fit`]'s condition number
/// promises against the SVD), and the eigenvalues of the Gram carry a rounding error of
/// ε‖G‖ anyway; 1e-10 leaves four orders of margin.
const RELATIVE_WIDTH: f64 = 1e-10;

/// `QᵀAQ = T` (tridiagonal: diagonal `d`, off-diagonal `e`), with Q kept as Householder
/// reflectors.
pub(crate) struct Tridiagonal {
    d: Vec<f64>,
    e: Vec<f64>,
    /// Row-major work matrix (row length `stride`) whose row `j`, entries `j+1..k`, holds
    /// the unit vector `v_j` of `H_j = I − 2 v_j v_jᵀ` (for `j < k − 2`; all zero when the
    /// column was already reduced): where the reduction read the column from, so it needs
    /// no other storage.
    reflectors: Vec<f64>,
    stride: usize,
}

impl Tridiagonal {
    /// `a`: symmetric `k × k`, full storage (row- or column-major alike).
    pub(crate) fn new(a: &[f64], k: usize) -> Self {
        let (d, e, reflectors, stride) = reduce(a, k);
        Tridiagonal {
            d,
            e,
            reflectors,
            stride,
        }
    }

    /// The reflector `v_j` (entries `j+1..k`).
    fn reflector(&self, j: usize) -> &[f64] {
        let start = j * self.stride;
        &self.reflectors[start + j + 1..start + self.k()]
    }

    fn k(&self) -> usize {
        self.d.len()
    }

    /// Gershgorin interval, widened by a few ulps so that it strictly contains the spectrum.
    fn gershgorin(&self) -> (f64, f64) {
        let k = self.k();
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for i in 0..k {
            let left = if i > 0 { self.e[i - 1].abs() } else { 0.0 };
            let right = if i + 1 < k { self.e[i].abs() } else { 0.0 };
            lo = lo.min(self.d[i] - left - right);
            hi = hi.max(self.d[i] + left + right);
        }
        let pad = 4.0 * f64::EPSILON * (k as f64) * lo.abs().max(hi.abs()) + self.pivmin();
        (lo - pad, hi + pad)
    }

    /// `e²ᵢ₋₁`, the squared coupling of row i to the one above it (0 for the first row).
    fn coupling_squared(&self, i: usize) -> f64 {
        if i > 0 {
            self.e[i - 1] * self.e[i - 1]
        } else {
            0.0
        }
    }

    fn pivmin(&self) -> f64 {
        f64::MIN_POSITIVE * self.e.iter().fold(1.0f64, |m, v| m.max(v * v))
    }

    /// Number of eigenvalues below each of the `L` shifts (Sturm counts of the LDLᵀ
    /// pivots, `pivmin` = [`Self::pivmin`], computed once per search). `L` independent
    /// recurrences at once, so that their divisions pipeline.
    fn counts<const L: usize>(&self, sigma: &[f64; L], pivmin: f64) -> [usize; L] {
        let mut q = [0.0; L];
        let mut cnt = [0usize; L];
        for i in 0..self.k() {
            let e2 = self.coupling_squared(i);
            for l in 0..L {
                let mut v = self.d[i] - sigma[l] - if i > 0 { e2 / q[l] } else { 0.0 };
                if v.abs() <= pivmin {
                    v = -pivmin;
                }
                q[l] = v;
                cnt[l] += usize::from(v < 0.0);
            }
        }
        cnt
    }

    /// `(λ_min, λ_max)`. The two searches run in lockstep, so that their chains of
    /// dependent divisions ([`Self::resolvent_moments`], [`Self::counts`]) pipeline; each
    /// takes exactly the steps it would take alone.
    pub(crate) fn extremes(&self) -> (f64, f64) {
        self.extremes_with_work().0
    }

    /// [`Self::extremes`] and the passes it took: `(moment passes, Sturm-count rounds)`.
    fn extremes_with_work(&self) -> ((f64, f64), (usize, usize)) {
        let mut work = (0, 0);
        if self.k() == 0 {
            return ((0.0, 0.0), work);
        }
        let start = Start::new(self);
        let mut searches = [Search::new(&start, true), Search::new(&start, false)];
        for _ in 0..100 {
            let active = searches.map(|s| !s.done());
            if active == [false, false] {
                break;
            }
            work.0 += 1;
            let moments = self.resolvent_moments(&searches.map(|s| s.outer()), start.pivmin);
            for (search, (&on, &(s1, s2, below))) in
                searches.iter_mut().zip(active.iter().zip(&moments))
            {
                if !on {
                    continue;
                }
                match search.unverified.take() {
                    // 0 was not below the spectrum after all (a Gram with a rounding-level
                    // negative eigenvalue): back to the Gershgorin start; the step from 0
                    // does not hold.
                    Some(gershgorin_lo) if !below => {
                        search.lo = gershgorin_lo;
                        search.width = search.hi - search.lo;
                    }
                    _ => search.step(s1, s2, self.k()),
                }
            }
            let slow = std::array::from_fn::<_, 2, _>(|i| active[i] && searches[i].slow());
            match slow {
                [true, true] => {
                    work.1 += 1;
                    let (a, b) = (searches[0].shifts(), searches[1].shifts());
                    let sigma: [f64; 14] =
                        std::array::from_fn(|l| if l < 7 { a[l] } else { b[l - 7] });
                    let cnt = self.counts(&sigma, start.pivmin);
                    searches[0].multisection(&a, &cnt[..7]);
                    searches[1].multisection(&b, &cnt[7..]);
                }
                [true, false] | [false, true] => {
                    work.1 += 1;
                    let s = &mut searches[usize::from(slow[1])];
                    let sigma = s.shifts();
                    let cnt = self.counts(&sigma, start.pivmin);
                    s.multisection(&sigma, &cnt);
                }
                [false, false] => {}
            }
        }
        ((searches[0].midpoint(), searches[1].midpoint()), work)
    }

    /// `(s₁(x), s₂(x), below)` with `s₁ = Σⱼ 1/(λⱼ − x) = −det′/det` and
    /// `s₂ = Σⱼ 1/(λⱼ − x)² = s₁′` of `T − xI` at each of the `L` points, from the LDLᵀ pivots
    /// qᵢ and their first two derivatives (`s₁ = −Σ qᵢ′/qᵢ`, `s₂ = Σ (qᵢ′/qᵢ)² − qᵢ″/qᵢ`);
    /// `below`: every pivot above `pivmin`, i.e. the Sturm count of [`Self::counts`] is 0
    /// and x lies below the spectrum. Only meaningful outside the spectrum (then, by
    /// interlacing, no pivot of a leading block vanishes). One division per row and point,
    /// and `L` recurrences at once, so that the divisions pipeline.
    fn resolvent_moments<const L: usize>(
        &self,
        x: &[f64; L],
        pivmin: f64,
    ) -> [(f64, f64, bool); L] {
        let (mut inv, mut dq, mut ddq) = ([0.0f64; L], [0.0f64; L], [0.0f64; L]);
        let (mut s1, mut s2) = ([0.0f64; L], [0.0f64; L]);
        let mut below = [true; L];
        for i in 0..self.k() {
            let e2 = self.coupling_squared(i);
            for l in 0..L {
                // qᵢ = dᵢ − x − e²/qᵢ₋₁, so qᵢ′ = −1 + e² qᵢ₋₁′/qᵢ₋₁² and
                // qᵢ″ = e² (qᵢ₋₁″ − 2 qᵢ₋₁′²/qᵢ₋₁)/qᵢ₋₁².
                let (q, d1, d2) = if i == 0 {
                    (self.d[0] - x[l], -1.0, 0.0)
                } else {
                    let iv = inv[l];
                    let t = e2 * iv * iv;
                    (
                        self.d[i] - x[l] - e2 * iv,
                        -1.0 + t * dq[l],
                        t * (ddq[l] - 2.0 * dq[l] * dq[l] * iv),
                    )
                };
                below[l] &= q > pivmin;
                let iq = 1.0 / q;
                let ratio = d1 * iq;
                s1[l] -= ratio;
                s2[l] += ratio * ratio - d2 * iq;
                inv[l] = iq;
                dq[l] = d1;
                ddq[l] = d2;
            }
        }
        std::array::from_fn(|l| (s1[l], s2[l], below[l]))
    }

    /// Unit eigenvector of the original matrix for the eigenvalue `lambda` of T (from
    /// [`Self::extremes`]): two steps of inverse iteration on `T − λI` (Gaussian
    /// elimination with partial pivoting, zero pivots replaced by ε‖T‖), then `Q x`.
    /// `None` if the iteration produced no finite vector.
    pub(crate) fn eigenvector(&self, lambda: f64) -> Option<Vec<f64>> {
        let k = self.k();
        if k == 0 {
            return None;
        }
        let tnorm = self
            .d
            .iter()
            .chain(&self.e)
            .fold(0.0f64, |m, v| m.max(v.abs()));
        let tiny = (f64::EPSILON * tnorm).max(f64::MIN_POSITIVE);
        // A start vector without structure, so that it is not orthogonal to the answer.
        let mut x: Vec<f64> = (0..k)
            .map(|i| 1.0 + 0.5 * ((i as f64 + 1.0) * 0.7548776662).fract())
            .collect();
        for _ in 0..2 {
            x = self.shifted_solve(lambda, &x, tiny);
            let norm = x.iter().map(|v| v * v).sum::<f64>().sqrt();
            if !(norm.is_finite() && norm > 0.0) {
                return None;
            }
            for v in x.iter_mut() {
                *v /= norm;
            }
        }
        for j in (0..k.saturating_sub(2)).rev() {
            let v = self.reflector(j);
            let tail = &mut x[j + 1..];
            let s: f64 = 2.0 * v.iter().zip(tail.iter()).map(|(a, b)| a * b).sum::<f64>();
            for (t, a) in tail.iter_mut().zip(v) {
                *t -= s * a;
            }
        }
        Some(x)
    }

    /// Solves `(T − λI) x = b` by Gaussian elimination with partial pivoting.
    fn shifted_solve(&self, lambda: f64, b: &[f64], tiny: f64) -> Vec<f64> {
        let k = self.k();
        let mut sub: Vec<f64> = self.e.clone();
        let mut diag: Vec<f64> = self.d.iter().map(|v| v - lambda).collect();
        let mut sup: Vec<f64> = self.e.clone();
        sup.push(0.0);
        let mut sup2 = vec![0.0; k];
        let mut rhs = b.to_vec();
        for i in 0..k.saturating_sub(1) {
            if sub[i].abs() > diag[i].abs() {
                std::mem::swap(&mut diag[i], &mut sub[i]);
                std::mem::swap(&mut sup[i], &mut diag[i + 1]);
                sup2[i] = sup[i + 1];
                sup[i + 1] = 0.0;
                rhs.swap(i, i + 1);
            }
            if diag[i] == 0.0 {
                diag[i] = tiny;
            }
            let m = sub[i] / diag[i];
            diag[i + 1] -= m * sup[i];
            sup[i + 1] -= m * sup2[i];
            rhs[i + 1] -= m * rhs[i];
        }
        if diag[k - 1] == 0.0 {
            diag[k - 1] = tiny;
        }
        let mut x = vec![0.0; k];
        for i in (0..k).rev() {
            let mut s = rhs[i];
            if i + 1 < k {
                s -= sup[i] * x[i + 1];
            }
            if i + 2 < k {
                s -= sup2[i] * x[i + 2];
            }
            x[i] = s / diag[i];
        }
        x
    }
}

/// One extreme-eigenvalue search of [`Tridiagonal::extremes`]: λ_min (`smallest`) or λ_max
/// by safeguarded Laguerre steps on det(T − xI) from outside the spectrum, to a relative
/// width of [`RELATIVE_WIDTH`] or the backward error ε‖T‖.
///
/// From `x` outside the spectrum, the first two moments of the resolvent give a certified
/// bracket around the nearest eigenvalue ([`Search::step`]) whose both ends converge
/// (cubically and quadratically) unless that eigenvalue is clustered, when a multisection
/// round on Sturm counts takes over. Costs three or four O(k) passes instead of the ~17
/// multisection rounds of plain bisection.
#[derive(Clone, Copy)]
struct Search {
    smallest: bool,
    /// Index of the wanted eigenvalue in ascending order.
    t: usize,
    /// `[lo, hi]` contains the eigenvalue; the end outside the spectrum is the one the
    /// Laguerre steps move (count(lo) = 0 below λ₁, count(hi) = k above λ_max).
    lo: f64,
    hi: f64,
    /// Rounding floor of the width, ε‖T‖ + pivmin.
    floor: f64,
    /// Bracket width before the last Laguerre step.
    width: f64,
    /// The Gershgorin lower bound while `lo` is a tentative 0 that the first moment pass
    /// has yet to prove below the spectrum.
    unverified: Option<f64>,
}

/// What both searches start from, computed once.
struct Start {
    k: usize,
    gershgorin: (f64, f64),
    pivmin: f64,
    dmin: f64,
    dmax: f64,
}

impl Start {
    fn new(tri: &Tridiagonal) -> Self {
        Start {
            k: tri.k(),
            gershgorin: tri.gershgorin(),
            pivmin: tri.pivmin(),
            dmin: tri.d.iter().fold(f64::INFINITY, |m, &v| m.min(v)),
            dmax: tri.d.iter().fold(f64::NEG_INFINITY, |m, &v| m.max(v)),
        }
    }
}

impl Search {
    fn new(start: &Start, smallest: bool) -> Self {
        let (glo, ghi) = start.gershgorin;
        let floor = f64::EPSILON * glo.abs().max(ghi.abs()) + start.pivmin;
        let (mut lo, hi) = if smallest {
            (glo, ghi.min(start.dmin + floor))
        } else {
            (glo.max(start.dmax - floor), ghi)
        };
        // A Gram matrix is positive semi-definite: 0 is usually a far better outer start
        // than the Gershgorin bound, which may lie ‖T‖ below it. The first moment pass
        // checks that it is below the spectrum (its pivots are the Sturm count's).
        let mut unverified = None;
        if smallest && lo < 0.0 && 0.0 < hi {
            unverified = Some(lo);
            lo = 0.0;
        }
        Search {
            smallest,
            t: if smallest { 0 } else { start.k - 1 },
            lo,
            hi,
            floor,
            width: hi - lo,
            unverified,
        }
    }

    fn done(&self) -> bool {
        self.hi - self.lo <= RELATIVE_WIDTH * self.lo.abs().max(self.hi.abs()) + self.floor
    }

    fn outer(&self) -> f64 {
        if self.smallest { self.lo } else { self.hi }
    }

    /// Narrows the bracket from the outer end x, where `s1 = Σ 1/(λⱼ − x)` and
    /// `s2 = Σ 1/(λⱼ − x)²`. With `a = |s1|` and `t = 1/|λ − x|` for the wanted (nearest)
    /// eigenvalue λ, the largest of the k terms:
    /// * `t ≤ (a + D)/k`, `D = √((k − 1)(k s2 − a²))` (Cauchy–Schwarz on the other k − 1
    ///   terms): λ is at least `k/(a + D)` away — Laguerre's step, cubically convergent;
    /// * `t ≥ s2/a` (each term at most t): λ is at most `a/s2` away, which converges
    ///   quadratically as well (`k/a`, the Newton form, only linearly).
    ///
    /// Both hold exactly when `a²/k ≤ s2 ≤ a²`; rounded moments outside that range fall back
    /// to the Newton bounds `1/a` and `k/a`.
    fn step(&mut self, s1: f64, s2: f64, k: usize) {
        self.width = self.hi - self.lo;
        let a = s1.abs();
        let kf = k as f64;
        let (near, far) = if a * a <= kf * s2 && s2 <= a * a {
            let d = ((kf - 1.0) * (kf * s2 - a * a)).max(0.0).sqrt();
            (kf / (a + d), a / s2)
        } else {
            (1.0 / a, kf / a)
        };
        if !(near.is_finite() && far.is_finite() && near > 0.0) {
            return;
        }
        let outer = self.outer();
        // s1 > 0 below the spectrum, < 0 above it: both steps point inwards.
        if self.smallest {
            self.lo = self.lo.max((outer + near).min(self.hi));
            self.hi = self.hi.min((outer + far).max(self.lo));
        } else {
            self.hi = self.hi.min((outer - near).max(self.lo));
            self.lo = self.lo.max((outer - far).min(self.hi));
        }
    }

    /// Slow progress (clustered extreme eigenvalues): the step did not quarter the bracket.
    fn slow(&self) -> bool {
        !self.done() && self.hi - self.lo > 0.25 * self.width
    }

    /// The seven interior points of a multisection round.
    fn shifts(&self) -> [f64; 7] {
        let h = (self.hi - self.lo) / 8.0;
        std::array::from_fn(|l| self.lo + (l + 1) as f64 * h)
    }

    /// Keeps the eighth of the bracket where the count passes `t` (`cnt`: Sturm counts at
    /// `sigma`).
    fn multisection(&mut self, sigma: &[f64; 7], cnt: &[usize]) {
        match (0..7).find(|&l| cnt[l] > self.t) {
            Some(0) => self.hi = sigma[0],
            Some(l) => {
                self.lo = sigma[l - 1];
                self.hi = sigma[l];
            }
            None => self.lo = sigma[6],
        }
    }

    fn midpoint(&self) -> f64 {
        0.5 * (self.lo + self.hi)
    }
}

/// `Σ aᵢbᵢ` for slices whose common length is a multiple of `W`, in `W` lane-wise partial
/// sums (vector FMAs, no chain of dependent scalar additions).
#[inline(always)]
fn dot_chunks<const W: usize, const FMA: bool>(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0; W];
    for (x, y) in a.chunks_exact(W).zip(b.chunks_exact(W)) {
        for l in 0..W {
            acc[l] = madd::<FMA>(x[l], y[l], acc[l]);
        }
    }
    acc.iter().sum()
}

/// The Householder reduction of [`Tridiagonal::new`]: `(d, e, reflectors, stride)`.
///
/// The trailing block is kept in full symmetric storage, row-major, so that `A₂₂v` is a dot
/// product per row and the rank-2 update runs along rows. Rows are `W − 1` entries longer
/// than `k` and zero there, and `v`, `A₂₂v` and `q` are zero past their `m` live entries, so
/// every loop runs over whole `W`-wide chunks of the live span: no remainder loops, which at
/// p ≈ 22 cost more than the arithmetic, and the padding stays zero (every update it gets
/// is a product with a zero).
#[inline(always)]
fn reduce_generic<const FMA: bool, const W: usize>(
    a: &[f64],
    k: usize,
) -> (Vec<f64>, Vec<f64>, Vec<f64>, usize) {
    let stride = k + W - 1;
    let mut w = vec![0.0; k * stride];
    for (row, src) in w.chunks_exact_mut(stride).zip(a.chunks_exact(k)) {
        row[..k].copy_from_slice(src);
    }
    let mut d = vec![0.0; k];
    let mut e = vec![0.0; k.saturating_sub(1)];
    let mut av = vec![0.0; k + W];
    let mut qv = vec![0.0; k + W];
    for j in 0..k.saturating_sub(2) {
        let m = k - j - 1;
        let span = m.div_ceil(W) * W;
        d[j] = w[j * stride + j];
        // Row j right of the diagonal (= column j below it) becomes v_j in place; the
        // trailing block is rows j+1.. . Entries past k in the span are the row's padding.
        let (head, trailing) = w.split_at_mut((j + 1) * stride);
        let v = &mut head[j * stride + j + 1..j * stride + j + 1 + span];
        let norm = dot_chunks::<W, FMA>(v, v).sqrt();
        if norm == 0.0 {
            e[j] = 0.0;
            continue;
        }
        let alpha = if v[0] > 0.0 { -norm } else { norm };
        // ‖v − αe₁‖² = ‖v‖² − 2αv₀ + α² = 2‖v‖(‖v‖ + |v₀|): α has v₀'s opposite sign, so
        // the sum has no cancellation and needs no second pass.
        let inv_vnorm = 1.0 / (2.0 * norm * (norm + v[0].abs())).sqrt();
        v[0] -= alpha;
        for t in v.iter_mut() {
            *t *= inv_vnorm;
        }
        // A₂₂ ← H A₂₂ H = A₂₂ − v qᵀ − q vᵀ with q = 2(A₂₂v − (vᵀA₂₂v) v).
        let (av, qv) = (&mut av[..span], &mut qv[..span]);
        for (c, o) in av[..m].iter_mut().enumerate() {
            let row = &trailing[c * stride + j + 1..c * stride + j + 1 + span];
            *o = dot_chunks::<W, FMA>(row, v);
        }
        av[m..].fill(0.0);
        let vav = dot_chunks::<W, FMA>(av, v);
        for ((qr, a), b) in qv.iter_mut().zip(av.iter()).zip(v.iter()) {
            *qr = 2.0 * (a - vav * b);
        }
        for c in 0..m {
            let (vc, qc) = (v[c], qv[c]);
            let row = &mut trailing[c * stride + j + 1..c * stride + j + 1 + span];
            for ((o, &vr), &qr) in row.iter_mut().zip(v.iter()).zip(qv.iter()) {
                *o = madd::<FMA>(-qr, vc, madd::<FMA>(-vr, qc, *o));
            }
        }
        e[j] = alpha;
    }
    if k >= 2 {
        d[k - 2] = w[(k - 2) * stride + k - 2];
        e[k - 2] = w[(k - 1) * stride + k - 2];
    }
    if k >= 1 {
        d[k - 1] = w[(k - 1) * stride + k - 1];
    }
    (d, e, w, stride)
}

crate::dense::kernels::dispatch!(
    /// [`reduce_generic`] with FMA and wide vectors where the CPU has them.
    pub(crate) fn reduce, reduce_generic,
    (a: &[f64], k: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>, usize),
    avx512: <true, 8>, avx2: <true, 4>, base: <false, 2>
);

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    fn sample(k: usize, seed: f64) -> Vec<f64> {
        // BᵀB of a smooth, collinear B: a Gram matrix with a wide spectrum.
        let b = Mat::<f64>::from_fn(3 * k, k, |i, j| {
            ((i as f64 * 0.05 + seed) * (j as f64 + 1.0)).sin() + 0.3 * (j as f64 * seed).cos()
        });
        let g = b.transpose() * &b;
        let mut a = vec![0.0; k * k];
        for i in 0..k {
            for j in 0..k {
                a[i * k + j] = g[(i, j)];
            }
        }
        a
    }

    /// `max_i |(Av − λv)_i|` for the row-major `k × k` matrix `a`: the eigenpair's residual.
    fn eigen_residual(a: &[f64], k: usize, lambda: f64, v: &[f64]) -> f64 {
        (0..k)
            .map(|i| {
                let av: f64 = (0..k).map(|j| a[i * k + j] * v[j]).sum();
                (av - lambda * v[i]).abs()
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn extremes_and_eigenvector_match_faer() {
        for (k, seed) in [(1, 0.3), (2, 0.7), (3, 1.1), (9, 0.4), (22, 0.9), (40, 1.3)] {
            let a = sample(k, seed);
            let m = Mat::<f64>::from_fn(k, k, |i, j| a[i * k + j]);
            let ev = m
                .as_ref()
                .self_adjoint_eigenvalues(faer::Side::Lower)
                .unwrap();
            let (lo, hi) = (ev[0], ev[k - 1]);
            let t = Tridiagonal::new(&a, k);
            let (emin, emax) = t.extremes();
            // Both are backward stable (eigenvalues to a few ε‖A‖), and the search stops at a
            // relative bracket width of RELATIVE_WIDTH.
            let tol = |v: f64| 1e3 * f64::EPSILON * hi.abs() + RELATIVE_WIDTH * v.abs();
            assert!((emin - lo).abs() <= tol(lo), "k={k}: {emin:e} vs {lo:e}");
            assert!((emax - hi).abs() <= tol(hi), "k={k}: {emax:e} vs {hi:e}");
            let v = t.eigenvector(emin).unwrap();
            let res = eigen_residual(&a, k, emin, &v);
            assert!(res <= tol(emin), "k={k}: residual {res:e}");
            let norm: f64 = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            assert!((norm - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn every_instruction_set_width_reduces_to_the_same_tridiagonal() {
        // The dispatched reduction runs one of three chunk widths (AVX-512 8, AVX2 4,
        // baseline 2, the last without FMA); each must cover every live entry whatever
        // k mod W, and leave the padding zero.
        for k in 1..=25 {
            let a = sample(k, 0.2 + 0.03 * k as f64);
            let m = Mat::<f64>::from_fn(k, k, |i, j| a[i * k + j]);
            let ev = m
                .as_ref()
                .self_adjoint_eigenvalues(faer::Side::Lower)
                .unwrap();
            let norm = ev[k - 1].abs().max(ev[0].abs());
            let variants = [
                reduce_generic::<true, 8>(&a, k),
                reduce_generic::<true, 4>(&a, k),
                reduce_generic::<false, 2>(&a, k),
            ];
            for (d, e, reflectors, stride) in variants {
                for (row, chunk) in reflectors.chunks_exact(stride).enumerate() {
                    assert!(
                        chunk[k..].iter().all(|&v| v == 0.0),
                        "k={k}: row {row} padding"
                    );
                }
                let t = Tridiagonal {
                    d,
                    e,
                    reflectors,
                    stride,
                };
                let (emin, emax) = t.extremes();
                // Backward stable to a few ε‖A‖; the search stops at RELATIVE_WIDTH.
                let tol = |v: f64| 1e3 * f64::EPSILON * norm + RELATIVE_WIDTH * v.abs();
                assert!(
                    (emin - ev[0]).abs() <= tol(ev[0]),
                    "k={k} stride {stride}: {emin:e} vs {:e}",
                    ev[0]
                );
                assert!(
                    (emax - ev[k - 1]).abs() <= tol(ev[k - 1]),
                    "k={k} stride {stride}: {emax:e} vs {:e}",
                    ev[k - 1]
                );
                let v = t.eigenvector(emin).unwrap();
                let res = eigen_residual(&a, k, emin, &v);
                assert!(res <= tol(emin), "k={k} stride {stride}: residual {res:e}");
            }
        }
    }

    #[test]
    fn separated_extremes_take_few_passes() {
        // Both ends of the Laguerre bracket converge superlinearly, so a well-separated
        // extreme eigenvalue needs three or four moment passes and at most one Sturm round
        // (the Newton bracket's inner end converged only linearly: six passes and three or
        // four rounds on these matrices).
        for (k, seed) in [(9, 0.4), (15, 0.5), (22, 0.9), (40, 1.3)] {
            let (_, (passes, rounds)) = Tridiagonal::new(&sample(k, seed), k).extremes_with_work();
            assert!(
                passes <= 4 && rounds <= 1,
                "k={k}: {passes} passes, {rounds} rounds"
            );
        }
    }

    /// `Q diag(λ) Qᵀ` for a fixed orthogonal Q (Householder reflector of a dense vector).
    fn rotated(lambda: &[f64]) -> Vec<f64> {
        let k = lambda.len();
        let u: Vec<f64> = (0..k).map(|i| ((i as f64 + 1.0) * 1.37).sin()).collect();
        let uu: f64 = u.iter().map(|x| x * x).sum();
        let q = |i: usize, j: usize| f64::from(u8::from(i == j)) - 2.0 * u[i] * u[j] / uu;
        let mut a = vec![0.0; k * k];
        for i in 0..k {
            for j in 0..k {
                a[i * k + j] = (0..k).map(|t| q(i, t) * lambda[t] * q(j, t)).sum();
            }
        }
        a
    }

    fn check_extremes(lambda: &[f64]) {
        let k = lambda.len();
        let (lo, hi) = lambda
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        let (emin, emax) = Tridiagonal::new(&rotated(lambda), k).extremes();
        let tol = |v: f64| 1e3 * f64::EPSILON * hi.abs() + RELATIVE_WIDTH * v.abs();
        assert!(
            (emin - lo).abs() <= tol(lo),
            "{lambda:?}: {emin:e} vs {lo:e}"
        );
        assert!(
            (emax - hi).abs() <= tol(hi),
            "{lambda:?}: {emax:e} vs {hi:e}"
        );
    }

    #[test]
    fn a_zero_start_inside_the_spectrum_falls_back_to_gershgorin() {
        // λ_min's search starts tentatively at 0 (below the spectrum of any Gram matrix);
        // the first moment pass must catch a symmetric matrix with negative eigenvalues,
        // or a Gram whose rounding left one just below 0.
        check_extremes(&[-0.3, 0.2, 1.0, 2.0]);
        check_extremes(&[-1e-13, 1e-3, 0.5, 1.0, 1.5]);
        check_extremes(&[-2.0, -1.0, -0.5]);
    }

    #[test]
    fn clustered_extreme_eigenvalues_fall_back_to_multisection() {
        // Laguerre steps on det converge only linearly into a cluster; the Sturm rounds finish.
        check_extremes(&[
            1e-6,
            1e-6 * (1.0 + 1e-12),
            1e-6 * (1.0 + 1e-9),
            0.3,
            2.0,
            2.0,
            2.0,
        ]);
        check_extremes(&[1.0; 6]);
        check_extremes(&[-3.0, -3.0, 0.5, 4.0, 4.0 - 1e-13]);
    }

    #[test]
    fn wide_spectrum_of_an_ill_conditioned_gram() {
        // κ(G) = 1e10, the direct path's limit, and the same spectrum shifted by −0.5 (indefinite).
        let lambda: Vec<f64> = (0..22)
            .map(|i| 10f64.powf(-10.0 + i as f64 * 10.0 / 21.0))
            .collect();
        check_extremes(&lambda);
        let shifted: Vec<f64> = lambda.iter().map(|v| v - 0.5).collect();
        check_extremes(&shifted);
    }

    #[test]
    fn diagonal_matrix_with_repeated_eigenvalues() {
        let k = 5;
        let mut a = vec![0.0; k * k];
        for (i, v) in [3.0, 1.0, 1.0, 7.0, 3.0].into_iter().enumerate() {
            a[i * k + i] = v;
        }
        let t = Tridiagonal::new(&a, k);
        let (emin, emax) = t.extremes();
        assert!((emin - 1.0).abs() < 1e-10 && (emax - 7.0).abs() < 7e-10);
        let v = t.eigenvector(emin).unwrap();
        // Any unit vector of the eigenspace of 1 (coordinates 1 and 2).
        assert!((v[1] * v[1] + v[2] * v[2] - 1.0).abs() < 1e-12, "{v:?}");
    }
}
