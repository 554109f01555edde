//! Dense linear algebra: the n × p kernels go through faer; the p × p work (p ≲ 50) is done
//! by small hand-written routines whose failure modes we control (no panics, explicit
//! singularity tests).

use faer::{Accum, Mat, MatMut, MatRef, Par};

use crate::error::EstimatorError;

/// faer's global setting, so that a caller running fits in parallel can switch faer to
/// `Par::Seq` once.
pub(crate) fn par() -> Par {
    faer::get_global_parallelism()
}

/// An owned column-major matrix for the tall (n-row) data. faer's `Mat::zeros` and
/// `Mat::from_fn` initialise element by element through a closure, which on a 4000 × 22
/// design costs more than the factorisation itself; a `Vec` fills at memcpy speed.
pub(crate) struct Tall {
    data: Vec<f64>,
    nrows: usize,
    ncols: usize,
}

impl Tall {
    pub(crate) fn zeros(nrows: usize, ncols: usize) -> Self {
        Tall {
            data: vec![0.0; nrows * ncols],
            nrows,
            ncols,
        }
    }

    /// `data` holds `ncols` columns of `nrows` values each.
    pub(crate) fn from_column_major(data: Vec<f64>, nrows: usize, ncols: usize) -> Self {
        debug_assert_eq!(data.len(), nrows * ncols);
        Tall { data, nrows, ncols }
    }

    /// The rows `rows` of `self`, in that order.
    pub(crate) fn select_rows(&self, rows: &[usize]) -> Tall {
        let mut out = Tall::zeros(rows.len(), self.ncols);
        for j in 0..self.ncols {
            let src = self.col(j);
            for (d, &i) in out.col_mut(j).iter_mut().zip(rows) {
                *d = src[i];
            }
        }
        out
    }

    pub(crate) fn nrows(&self) -> usize {
        self.nrows
    }

    pub(crate) fn ncols(&self) -> usize {
        self.ncols
    }

    pub(crate) fn col(&self, j: usize) -> &[f64] {
        &self.data[j * self.nrows..(j + 1) * self.nrows]
    }

    pub(crate) fn col_mut(&mut self, j: usize) -> &mut [f64] {
        &mut self.data[j * self.nrows..(j + 1) * self.nrows]
    }

    pub(crate) fn as_ref(&self) -> MatRef<'_, f64> {
        MatRef::from_column_major_slice(&self.data, self.nrows, self.ncols)
    }

    pub(crate) fn as_mut(&mut self) -> MatMut<'_, f64> {
        MatMut::from_column_major_slice_mut(&mut self.data, self.nrows, self.ncols)
    }
}

/// Column `j` of a tall matrix as a slice.
#[inline]
pub(crate) fn col(m: &Tall, j: usize) -> &[f64] {
    m.col(j)
}

/// Column `j` of any matrix view as a contiguous slice, copying only when the view is
/// not column-major.
pub(crate) fn col_of<'a>(m: MatRef<'a, f64>, j: usize) -> std::borrow::Cow<'a, [f64]> {
    match m.col(j).try_as_col_major() {
        Some(c) => std::borrow::Cow::Borrowed(c.as_slice()),
        None => std::borrow::Cow::Owned(m.col(j).iter().copied().collect()),
    }
}

/// `ZᵀZ`, exactly symmetric.
pub(crate) fn gram(z: MatRef<'_, f64>) -> Mat<f64> {
    let q = z.ncols();
    let mut g = Mat::<f64>::zeros(q, q);
    faer::linalg::matmul::matmul(g.as_mut(), Accum::Replace, z.transpose(), z, 1.0, par());
    for j in 0..q {
        for i in 0..j {
            let v = 0.5 * (g[(i, j)] + g[(j, i)]);
            g[(i, j)] = v;
            g[(j, i)] = v;
        }
    }
    g
}

/// `Zᵀv` for an owned column-major `Z` (faer's SIMD kernels; several times faster than a
/// scalar dot product per column).
pub(crate) fn zt_v(z: &Tall, v: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; z.ncols()];
    faer::linalg::matmul::matmul(
        MatMut::from_column_major_slice_mut(&mut out, z.ncols(), 1),
        Accum::Replace,
        z.as_ref().transpose(),
        MatRef::from_column_major_slice(v, v.len(), 1),
        1.0,
        par(),
    );
    out
}

/// `y − Zγ`.
pub(crate) fn residual(z: &Tall, y: &[f64], gamma: &[f64]) -> Vec<f64> {
    let mut r = y.to_vec();
    faer::linalg::matmul::matmul(
        MatMut::from_column_major_slice_mut(&mut r, y.len(), 1),
        Accum::Add,
        z.as_ref(),
        MatRef::from_column_major_slice(gamma, gamma.len(), 1),
        -1.0,
        par(),
    );
    r
}

/// `Zd`.
pub(crate) fn mat_vec(z: &Tall, d: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; z.nrows()];
    faer::linalg::matmul::matmul(
        MatMut::from_column_major_slice_mut(&mut out, z.nrows(), 1),
        Accum::Replace,
        z.as_ref(),
        MatRef::from_column_major_slice(d, d.len(), 1),
        1.0,
        par(),
    );
    out
}

/// Lower Cholesky factor of a symmetric matrix read from its lower triangle. Fails when a
/// pivot is not positive or is at most `rel_tol` times its original diagonal entry (the
/// pivot over the diagonal is 1 − R² of that column against the preceding ones, so the
/// test rejects numerically dependent columns).
pub(crate) fn cholesky(a: MatRef<'_, f64>, rel_tol: f64) -> Option<Mat<f64>> {
    let n = a.nrows();
    let mut l = Mat::<f64>::zeros(n, n);
    for j in 0..n {
        let mut d = a[(j, j)];
        for k in 0..j {
            d -= l[(j, k)] * l[(j, k)];
        }
        if !d.is_finite() || d <= rel_tol * a[(j, j)] {
            return None;
        }
        let d = d.sqrt();
        l[(j, j)] = d;
        for i in j + 1..n {
            let mut s = a[(i, j)];
            for k in 0..j {
                s -= l[(i, k)] * l[(j, k)];
            }
            l[(i, j)] = s / d;
        }
    }
    Some(l)
}

/// Solves `L x = b` in place.
pub(crate) fn solve_lower(l: &Mat<f64>, b: &mut [f64]) {
    let n = l.nrows();
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[(i, k)] * b[k];
        }
        b[i] = s / l[(i, i)];
    }
}

/// Solves `Lᵀ x = b` in place.
pub(crate) fn solve_lower_transpose(l: &Mat<f64>, b: &mut [f64]) {
    let n = l.nrows();
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= l[(k, i)] * b[k];
        }
        b[i] = s / l[(i, i)];
    }
}

/// Solves `(LLᵀ) x = b` in place.
pub(crate) fn cholesky_solve(l: &Mat<f64>, b: &mut [f64]) {
    solve_lower(l, b);
    solve_lower_transpose(l, b);
}

/// `Σ aᵢbᵢ` over the common length in four interleaved partial sums, so that short dot
/// products are not one chain of dependent additions.
#[inline]
fn dot4(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for l in 0..4 {
            acc[l] += x[l] * y[l];
        }
    }
    let mut tail = 0.0;
    for (x, y) in ra.iter().zip(rb) {
        tail += x * y;
    }
    (acc[0] + acc[2]) + (acc[1] + acc[3]) + tail
}

/// Lower Cholesky factor of a small symmetric positive definite matrix, row-major: the
/// direct LSQ path's p × p Gram, factored and solved twice per fit. Row storage makes every
/// inner product of the factorisation and of the forward solve contiguous, and the backward
/// solve runs as updates along rows; [`cholesky`] on a faer matrix reads the same products
/// with a stride.
pub(crate) struct RowCholesky {
    n: usize,
    /// Row-major `n × n`; entries above the diagonal are 0.
    l: Vec<f64>,
    inv_diag: Vec<f64>,
}

impl RowCholesky {
    /// Factors the row-major `n × n` matrix `a` from its lower triangle, with the same
    /// pivot test as [`cholesky`].
    pub(crate) fn new(a: &[f64], n: usize, rel_tol: f64) -> Option<Self> {
        let mut l = vec![0.0; n * n];
        let mut inv_diag = vec![0.0; n];
        // Column by column: the entries of a column depend only on earlier columns, so
        // their inner products are independent and pipeline.
        for j in 0..n {
            let rest = &mut l[j * n..];
            let row_j = &rest[..j];
            let d = a[j * n + j] - dot4(row_j, row_j);
            if !d.is_finite() || d <= rel_tol * a[j * n + j] {
                return None;
            }
            let d = d.sqrt();
            rest[j] = d;
            let inv = 1.0 / d;
            inv_diag[j] = inv;
            let (row_j, below) = rest.split_at_mut(n);
            for (t, row_i) in below.chunks_exact_mut(n).enumerate() {
                let i = j + 1 + t;
                row_i[j] = (a[i * n + j] - dot4(&row_i[..j], &row_j[..j])) * inv;
            }
        }
        Some(RowCholesky { n, l, inv_diag })
    }

    /// Solves `(LLᵀ) x = b` in place.
    pub(crate) fn solve(&self, b: &mut [f64]) {
        let n = self.n;
        for i in 0..n {
            let row = &self.l[i * n..i * n + i];
            b[i] = (b[i] - dot4(row, &b[..i])) * self.inv_diag[i];
        }
        for i in (0..n).rev() {
            let x = b[i] * self.inv_diag[i];
            b[i] = x;
            let row = &self.l[i * n..i * n + i];
            for (bk, &lik) in b[..i].iter_mut().zip(row) {
                *bk -= lik * x;
            }
        }
    }
}

/// Householder QR of a small `m × k` matrix (`m ≥ k`), LAPACK-style compact storage.
pub(crate) struct SmallQr {
    qr: Mat<f64>,
    tau: Vec<f64>,
}

impl SmallQr {
    pub(crate) fn new(mut a: Mat<f64>) -> Self {
        let (m, k) = (a.nrows(), a.ncols());
        let mut tau = vec![0.0; k.min(m)];
        for j in 0..k.min(m) {
            let mut norm2 = 0.0;
            for i in j..m {
                norm2 += a[(i, j)] * a[(i, j)];
            }
            let norm = norm2.sqrt();
            if norm == 0.0 {
                continue;
            }
            let alpha = a[(j, j)];
            let beta = if alpha >= 0.0 { -norm } else { norm };
            // v = x − βe₁ scaled so that v₀ = 1; H = I − τ v vᵀ.
            let v0 = alpha - beta;
            for i in j + 1..m {
                a[(i, j)] /= v0;
            }
            tau[j] = (beta - alpha) / beta;
            a[(j, j)] = beta;
            for c in j + 1..k {
                let mut s = a[(j, c)];
                for i in j + 1..m {
                    s += a[(i, j)] * a[(i, c)];
                }
                s *= tau[j];
                a[(j, c)] -= s;
                for i in j + 1..m {
                    let vij = a[(i, j)];
                    a[(i, c)] -= s * vij;
                }
            }
        }
        SmallQr { qr: a, tau }
    }

    pub(crate) fn ncols(&self) -> usize {
        self.qr.ncols()
    }

    /// `v ← Qᵀ v`.
    pub(crate) fn apply_qt(&self, v: &mut [f64]) {
        let m = self.qr.nrows();
        for (j, &t) in self.tau.iter().enumerate() {
            if t == 0.0 {
                continue;
            }
            let mut s = v[j];
            for (i, vi) in v.iter().enumerate().take(m).skip(j + 1) {
                s += self.qr[(i, j)] * vi;
            }
            s *= t;
            v[j] -= s;
            for (i, vi) in v.iter_mut().enumerate().take(m).skip(j + 1) {
                *vi -= s * self.qr[(i, j)];
            }
        }
    }

    /// True when the triangular factor is square and its smallest diagonal entry exceeds
    /// `rel_tol` times its largest.
    pub(crate) fn is_full_rank(&self, rel_tol: f64) -> bool {
        let k = self.qr.ncols();
        if self.qr.nrows() < k {
            return false;
        }
        let diag: Vec<f64> = (0..k).map(|j| self.qr[(j, j)].abs()).collect();
        let max = diag.iter().cloned().fold(0.0, f64::max);
        diag.iter().all(|&d| d > rel_tol * max && d.is_finite())
    }

    /// Solves `R x = b` in place (first `k` entries of `b`).
    pub(crate) fn solve_r(&self, b: &mut [f64]) {
        let k = self.qr.ncols();
        for i in (0..k).rev() {
            let mut s = b[i];
            for (c, bc) in b.iter().enumerate().take(k).skip(i + 1) {
                s -= self.qr[(i, c)] * bc;
            }
            b[i] = s / self.qr[(i, i)];
        }
    }

    /// Solves `Rᵀ x = b` in place.
    pub(crate) fn solve_rt(&self, b: &mut [f64]) {
        let k = self.qr.ncols();
        for i in 0..k {
            let mut s = b[i];
            for (r, br) in b.iter().enumerate().take(i) {
                s -= self.qr[(r, i)] * br;
            }
            b[i] = s / self.qr[(i, i)];
        }
    }
}

/// Singular values, largest first.
pub(crate) fn singular_values(a: MatRef<'_, f64>) -> Result<Vec<f64>, EstimatorError> {
    if a.nrows() == 0 || a.ncols() == 0 {
        return Ok(Vec::new());
    }
    let mut s = a.singular_values()?;
    s.sort_by(|x, y| y.total_cmp(x));
    Ok(s)
}

/// σ_max/σ_min over `min(rows, cols)` singular values, padded with zeros when the matrix
/// is wide (a wide matrix is rank deficient as a regression design).
pub(crate) fn condition_from_singular_values(s: &[f64], ncols: usize) -> f64 {
    if s.is_empty() {
        return f64::INFINITY;
    }
    let max = s[0];
    let min = if s.len() < ncols { 0.0 } else { s[s.len() - 1] };
    if max == 0.0 || min <= 0.0 {
        f64::INFINITY
    } else {
        max / min
    }
}

/// Extreme eigenvalues (min, max) of a symmetric matrix (read from the lower triangle).
/// Extreme eigenvalues (min, max) of a symmetric matrix and a unit eigenvector of the
/// smallest.
pub(crate) fn sym_eig_min_vector(
    a: MatRef<'_, f64>,
) -> Result<(f64, f64, Vec<f64>), EstimatorError> {
    let k = a.nrows();
    if k == 0 {
        return Ok((0.0, 0.0, Vec::new()));
    }
    let evd = a.self_adjoint_eigen(faer::Side::Lower)?;
    let s = evd.S().column_vector();
    // Eigenvalues come sorted in nondecreasing order.
    let v = (0..k).map(|i| evd.U()[(i, 0)]).collect();
    Ok((s[0], s[k - 1], v))
}

pub(crate) fn sym_eig_extremes(a: MatRef<'_, f64>) -> Result<(f64, f64), EstimatorError> {
    if a.nrows() == 0 {
        return Ok((0.0, 0.0));
    }
    let e = a.self_adjoint_eigenvalues(faer::Side::Lower)?;
    let min = e.iter().cloned().fold(f64::INFINITY, f64::min);
    let max = e.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    Ok((min, max))
}

/// A least-squares objective compressed to `k ≤ q + 1` rows: `‖Zγ − y‖² = ‖Aγ − c‖² + const`.
/// `A` is the triangular factor R of a QR of Z when n > q, and Z itself otherwise.
#[derive(Debug, Clone)]
pub(crate) struct LsFactor {
    pub(crate) a: Mat<f64>,
    pub(crate) c: Vec<f64>,
}

/// Householder QR of `[Z y]` through faer: R and `Qᵀy` come out of one factorisation, and
/// the factorisation is backward stable whatever the conditioning.
pub(crate) fn householder_factor(z: &Tall, y: &[f64]) -> LsFactor {
    let (n, q) = (z.nrows(), z.ncols());
    if n <= q {
        return LsFactor {
            a: z.as_ref().to_owned(),
            c: y.to_vec(),
        };
    }
    let mut aug = Tall::zeros(n, q + 1);
    for j in 0..q {
        aug.col_mut(j).copy_from_slice(z.col(j));
    }
    aug.col_mut(q).copy_from_slice(y);
    let qr = aug.as_ref().qr();
    let r = qr.thin_R();
    let a = Mat::<f64>::from_fn(q, q, |i, j| if i <= j { r[(i, j)] } else { 0.0 });
    let c = (0..q).map(|i| r[(i, q)]).collect();
    LsFactor { a, c }
}

/// CholeskyQR2 (Yamamoto et al. 2015): R from two Cholesky passes over Gram matrices. About
/// four times faster than Householder at n = 4000, p = 22, and as accurate as long as the
/// first pass leaves Q₁ well conditioned, which is checked: `‖Q₁ᵀQ₁ − I‖_F ≤ ½` bounds
/// κ(Q₁) ≤ √3, for which the second pass is backward stable. Returns `None` otherwise;
/// the caller then uses Householder.
pub(crate) fn cholesky_qr2(z: &Tall, y: &[f64]) -> Option<LsFactor> {
    let (n, q) = (z.nrows(), z.ncols());
    if n <= q {
        return None;
    }
    let g1 = gram(z.as_ref());
    let l1 = cholesky(g1.as_ref(), 0.0)?;
    // Q₁ = Z R₁⁻¹ = Z L₁⁻ᵀ as one matrix product (several times faster than a
    // substitution at these shapes; Q₁ is re-orthogonalised by the second pass anyway).
    let mut linv = Mat::<f64>::zeros(q, q);
    for c in 0..q {
        let mut e = vec![0.0; q];
        e[c] = 1.0;
        solve_lower(&l1, &mut e);
        for (i, v) in e.into_iter().enumerate() {
            linv[(i, c)] = v;
        }
    }
    let mut q1 = Tall::zeros(n, q);
    faer::linalg::matmul::matmul(
        q1.as_mut(),
        Accum::Replace,
        z.as_ref(),
        linv.transpose(),
        1.0,
        par(),
    );
    let g2 = gram(q1.as_ref());
    let mut dev = 0.0;
    for j in 0..q {
        for i in 0..q {
            let e = g2[(i, j)] - if i == j { 1.0 } else { 0.0 };
            dev += e * e;
        }
    }
    if dev.is_nan() || dev.sqrt() > 0.5 {
        return None;
    }
    let l2 = cholesky(g2.as_ref(), 0.0)?;
    // R = R₂R₁ = L₂ᵀL₁ᵀ, upper triangular.
    let mut a = Mat::<f64>::zeros(q, q);
    for i in 0..q {
        for j in i..q {
            let mut s = 0.0;
            for k in i..=j {
                s += l2[(k, i)] * l1[(j, k)];
            }
            a[(i, j)] = s;
        }
    }
    // c = Qᵀy with Q = Q₁R₂⁻¹, i.e. c = L₂⁻¹(Q₁ᵀy).
    let mut c = zt_v(&q1, y);
    solve_lower(&l2, &mut c);
    Some(LsFactor { a, c })
}

/// Minimum-norm least-squares solution of `A x ≈ c` by SVD, discarding singular values
/// below `max(k, q) ε σ_max` (the numerical rank).
pub(crate) fn min_norm_lstsq(a: MatRef<'_, f64>, c: &[f64]) -> Result<Vec<f64>, EstimatorError> {
    let q = a.ncols();
    let svd = a.thin_svd()?;
    let (u, s, v) = (svd.U(), svd.S().column_vector(), svd.V());
    let smax = (0..s.nrows()).map(|i| s[i]).fold(0.0, f64::max);
    let cut = (a.nrows().max(q) as f64) * f64::EPSILON * smax;
    let mut x = vec![0.0; q];
    for i in 0..s.nrows() {
        if s[i] > cut {
            let mut uc = 0.0;
            for (r, &cr) in c.iter().enumerate() {
                uc += u[(r, i)] * cr;
            }
            let w = uc / s[i];
            for (j, xj) in x.iter_mut().enumerate() {
                *xj += w * v[(j, i)];
            }
        }
    }
    Ok(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn row_cholesky_solves_like_the_faer_factor_and_rejects_dependent_columns() {
        for n in [1, 2, 3, 4, 5, 8, 9, 15, 22, 23, 40] {
            // BᵀB of a smooth, collinear B: symmetric positive definite, κ up to ~1e6.
            let b = Mat::<f64>::from_fn(3 * n, n, |i, j| {
                ((i as f64 * 0.05 + 0.3) * (j as f64 + 1.0)).sin() + 0.1 * (i == j) as u8 as f64
            });
            let g = b.transpose() * &b;
            let a: Vec<f64> = (0..n * n).map(|t| g[(t / n, t % n)]).collect();
            let rhs: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).cos()).collect();
            let mut x = rhs.clone();
            RowCholesky::new(&a, n, 0.0)
                .expect("positive definite")
                .solve(&mut x);
            let mut reference = rhs.clone();
            cholesky_solve(&cholesky(g.as_ref(), 0.0).unwrap(), &mut reference);
            let scale = reference.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (u, v) in x.iter().zip(&reference) {
                assert!((u - v).abs() <= 1e-9 * scale, "n={n}: {u:e} vs {v:e}");
            }
            // Residual of the solve itself, relative to ‖G‖‖x‖.
            let gnorm = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for i in 0..n {
                let gx: f64 = (0..n).map(|j| a[i * n + j] * x[j]).sum();
                assert!((gx - rhs[i]).abs() <= 1e-12 * n as f64 * gnorm * scale);
            }
        }
        // A repeated column: the second pivot is rounding noise, not above the tolerance.
        let a = [4.0, 4.0, 1.0, 4.0, 4.0, 1.0, 1.0, 1.0, 3.0];
        assert!(RowCholesky::new(&a, 3, 1e-12).is_none());
        assert!(RowCholesky::new(&[f64::NAN], 1, 0.0).is_none());
    }

    #[test]
    fn small_qr_solves_least_squares() {
        let a = Mat::<f64>::from_fn(6, 3, |i, j| {
            ((i * 3 + j) as f64).sin() + (i == j) as u8 as f64
        });
        let b: Vec<f64> = (0..6).map(|i| (i as f64).cos()).collect();
        let qr = SmallQr::new(a.clone());
        let mut x = b.clone();
        qr.apply_qt(&mut x);
        qr.solve_r(&mut x);
        x.truncate(3);
        // Normal equations hold at the least-squares solution.
        let r: Vec<f64> = (0..6)
            .map(|i| b[i] - (0..3).map(|j| a[(i, j)] * x[j]).sum::<f64>())
            .collect();
        for j in 0..3 {
            let g: f64 = (0..6).map(|i| a[(i, j)] * r[i]).sum();
            assert!(g.abs() < 1e-13, "{g}");
        }
    }

    #[test]
    fn cholesky_qr2_matches_householder() {
        let mut z = Tall::zeros(200, 4);
        for j in 0..4 {
            for (i, v) in z.col_mut(j).iter_mut().enumerate() {
                *v = ((i as f64) * 0.05 * (j + 1) as f64).sin() + 0.1 * j as f64;
            }
        }
        let y: Vec<f64> = (0..200).map(|i| (i as f64 * 0.01).exp()).collect();
        let h = householder_factor(&z, &y);
        let c = cholesky_qr2(&z, &y).expect("well conditioned");
        for i in 0..4 {
            // R is unique up to the sign of each row.
            let sign = (h.a[(i, i)] * c.a[(i, i)]).signum();
            for j in 0..4 {
                assert!((h.a[(i, j)] - sign * c.a[(i, j)]).abs() < 1e-10 * h.a[(0, 0)].abs());
            }
            assert!(
                (h.c[i] - sign * c.c[i]).abs()
                    < 1e-10 * y.iter().map(|v| v * v).sum::<f64>().sqrt()
            );
        }
    }
}
