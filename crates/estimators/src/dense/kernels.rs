//! Fused passes over the columns of a raw design for the direct least-squares path
//! ([`crate::solvers::direct`]): the cross-product matrix of `[Φ y]` in one pass, and the
//! residual `y − Φβ` with `Φᵀr` and `‖r‖²` (plus `‖Φv‖²`) in another; `‖y − Φβ‖²` alone
//! for [`mod@crate::fit`]'s objective; and the products `Φᵀv`, `Φv` of the SVR interior
//! point's iterations.
//!
//! At the shapes of the Abkowitz designs (n ≈ 1e3–1e4, p ≤ 22) faer's general matrix
//! product packs both operands and its matrix-vector products visit Φ once per product;
//! together they cost several times the arithmetic. Here each pass reads Φ once, in row
//! blocks that stay in L1, with register tiles of column pairs and lane-wise accumulators.
//! Every kernel is written once, portably, and compiled three times: for AVX-512 and for
//! AVX2 + FMA (chosen at run time), and for the baseline target.

// Register tiles index several fixed-size arrays in step; index loops say that best.
#![allow(clippy::needless_range_loop)]

/// Rows per block: a block of 23 columns (2 kB each) stays in a 48 kB L1 data cache.
const BLOCK_ROWS: usize = 256;

#[inline(always)]
pub(crate) fn madd<const FMA: bool>(a: f64, b: f64, c: f64) -> f64 {
    // mul_add is one instruction where FMA is enabled and a slow library call where it
    // is not, hence the separate baseline form.
    if FMA { a.mul_add(b, c) } else { a * b + c }
}

#[inline(always)]
fn lanes<const L: usize>(c: &[f64], r: usize) -> [f64; L] {
    let mut v = [0.0; L];
    v.copy_from_slice(&c[r..r + L]);
    v
}

/// One TA×TB register tile of [`cross_products_generic`] over rows `start..end`: `s[i][j] +=
/// Σ wᵣ aᵢᵣ bⱼᵣ` lane-wise. A diagonal tile (`DIAG`, `a` = `b`, TA = TB) loads its columns once
/// and forms only the products i ≤ j (10 of 16 at 4 × 4); the others are left as they are.
#[inline(always)]
fn tile<const TA: usize, const TB: usize, const L: usize, const FMA: bool, const DIAG: bool>(
    mut s: [[[f64; L]; TB]; TA],
    a: [&[f64]; TA],
    b: [&[f64]; TB],
    root_weights: Option<&[f64]>,
    start: usize,
    end: usize,
) -> [[[f64; L]; TB]; TA] {
    let mut r = start;
    while r < end {
        let bv: [[f64; L]; TB] = std::array::from_fn(|t| lanes::<L>(b[t], r));
        let mut av: [[f64; L]; TA] =
            std::array::from_fn(|t| if DIAG { bv[t] } else { lanes::<L>(a[t], r) });
        if let Some(rw) = root_weights {
            // (√wᵢ aᵢ)(√wᵢ bᵢ) = wᵢ aᵢ bᵢ: one side carries the weight.
            let wl = lanes::<L>(rw, r);
            for t in 0..TA {
                for l in 0..L {
                    av[t][l] *= wl[l] * wl[l];
                }
            }
        }
        for i in 0..TA {
            for j in (if DIAG { i } else { 0 })..TB {
                for l in 0..L {
                    s[i][j][l] = madd::<FMA>(av[i][l], bv[j][l], s[i][j][l]);
                }
            }
        }
        r += L;
    }
    s
}

/// The tiles of the last column block when it has `W < T` columns, over rows `start..end`:
/// T×W against each of the `full` whole blocks (`acc[a]`), W×W on itself (`acc[full]`), the
/// accumulators in the first rows and columns of T×T slots.
#[inline(always)]
fn narrow_tiles<const T: usize, const W: usize, const L: usize, const FMA: bool>(
    acc: &mut [[[[f64; L]; T]; T]],
    cols: &[&[f64]],
    full: usize,
    root_weights: Option<&[f64]>,
    start: usize,
    end: usize,
) {
    let b: [&[f64]; W] = std::array::from_fn(|t| &cols[full * T + t][..end]);
    for (a_block, slot) in acc.iter_mut().enumerate() {
        if a_block < full {
            let a: [&[f64]; T] = std::array::from_fn(|t| &cols[a_block * T + t][..end]);
            let s = std::array::from_fn(|i| std::array::from_fn(|j| slot[i][j]));
            let s = tile::<T, W, L, FMA, false>(s, a, b, root_weights, start, end);
            for i in 0..T {
                slot[i][..W].copy_from_slice(&s[i]);
            }
        } else {
            let s = std::array::from_fn(|i| std::array::from_fn(|j| slot[i][j]));
            let s = tile::<W, W, L, FMA, true>(s, b, b, root_weights, start, end);
            for i in 0..W {
                slot[i][..W].copy_from_slice(&s[i]);
            }
        }
    }
}

/// Upper triangle (row-major pairs `i ≤ j`) of `AᵀA` for the columns of `A`, all of
/// length `n`. T×T register tiles of column pairs, L lanes per accumulator; a last block
/// of fewer than T columns gets tiles of its own width, so no product is formed twice or
/// thrown away (at 23 columns and T = 4, padding would cost 300 tile products for 276).
#[inline(always)]
fn cross_products_generic<const T: usize, const L: usize, const FMA: bool>(
    cols: &[&[f64]],
    n: usize,
    root_weights: Option<&[f64]>,
) -> Vec<f64> {
    let m = cols.len();
    let full_blocks = m / T;
    let width = m % T;
    let pairs: Vec<(usize, usize)> = (0..full_blocks)
        .flat_map(|a| (a..full_blocks).map(move |b| (a, b)))
        .collect();
    let mut acc = vec![[[[0.0f64; L]; T]; T]; pairs.len()];
    let mut narrow = vec![[[[0.0f64; L]; T]; T]; if width > 0 { full_blocks + 1 } else { 0 }];
    let full = n - n % L;
    let mut start = 0;
    while start < full {
        let end = (start + BLOCK_ROWS).min(full);
        for (pair, s_out) in pairs.iter().zip(acc.iter_mut()) {
            let a: [&[f64]; T] = std::array::from_fn(|t| &cols[pair.0 * T + t][..end]);
            let b: [&[f64]; T] = std::array::from_fn(|t| &cols[pair.1 * T + t][..end]);
            *s_out = if pair.0 == pair.1 {
                tile::<T, T, L, FMA, true>(*s_out, a, a, root_weights, start, end)
            } else {
                tile::<T, T, L, FMA, false>(*s_out, a, b, root_weights, start, end)
            };
        }
        let (nw, rw) = (&mut narrow[..], root_weights);
        // `width < T`; the arms for widths a parameter set cannot have are never taken.
        match width {
            0 => {}
            1 => narrow_tiles::<T, 1, L, FMA>(nw, cols, full_blocks, rw, start, end),
            2 if T > 2 => narrow_tiles::<T, 2, L, FMA>(nw, cols, full_blocks, rw, start, end),
            3 if T > 3 => narrow_tiles::<T, 3, L, FMA>(nw, cols, full_blocks, rw, start, end),
            _ => unreachable!("column block width {width} ≥ tile size {T}"),
        }
        start = end;
    }
    let mut out = vec![0.0; m * m];
    let last = full_blocks;
    let slots = pairs
        .iter()
        .copied()
        .zip(&acc)
        .chain((0..narrow.len()).map(|a| (a, last)).zip(&narrow));
    for (pair, s) in slots {
        for i in 0..T {
            for j in 0..T {
                let (ci, cj) = (pair.0 * T + i, pair.1 * T + j);
                if ci < m && cj < m && ci <= cj {
                    let mut v = 0.0;
                    for lane in s[i][j] {
                        v += lane;
                    }
                    for r in full..n {
                        let w = root_weights.map_or(1.0, |rw| rw[r] * rw[r]);
                        v += (cols[ci][r] * w) * cols[cj][r];
                    }
                    out[ci * m + cj] = v;
                }
            }
        }
    }
    out
}

/// `y − Φβ` on the `U·L` rows from `r0`, held in registers while every column streams
/// past once (a column-by-column update of a residual buffer would load and store the
/// buffer once per column).
#[inline(always)]
fn residual_chunk<const L: usize, const U: usize, const FMA: bool>(
    cols: &[&[f64]],
    y: &[f64],
    beta: &[f64],
    r0: usize,
) -> [[f64; L]; U] {
    let y = &y[r0..r0 + U * L];
    let mut r: [[f64; L]; U] = std::array::from_fn(|u| lanes::<L>(y, u * L));
    for (c, &b) in cols.iter().zip(beta) {
        // One bounds check per column and chunk; the constant offsets below need none.
        let c = &c[r0..r0 + U * L];
        for u in 0..U {
            let x = lanes::<L>(c, u * L);
            for l in 0..L {
                r[u][l] = madd::<FMA>(-b, x[l], r[u][l]);
            }
        }
    }
    r
}

/// `Φv` on the `U·L` rows from `r0`.
#[inline(always)]
fn combination_chunk<const L: usize, const U: usize, const FMA: bool>(
    cols: &[&[f64]],
    v: &[f64],
    r0: usize,
) -> [[f64; L]; U] {
    let mut out = [[0.0f64; L]; U];
    for (c, &b) in cols.iter().zip(v) {
        let c = &c[r0..r0 + U * L];
        for u in 0..U {
            let x = lanes::<L>(c, u * L);
            for l in 0..L {
                out[u][l] = madd::<FMA>(b, x[l], out[u][l]);
            }
        }
    }
    out
}

/// `acc_j += Σ_rows Φ_j ⊙ w` lane-wise, for the `U·L` rows from `r0` and the chunk `w` of a
/// vector held in registers.
#[inline(always)]
fn transposed_chunk<const L: usize, const U: usize, const FMA: bool>(
    acc: &mut [[f64; L]],
    cols: &[&[f64]],
    w: &[[f64; L]; U],
    r0: usize,
) {
    for (a, c) in acc.iter_mut().zip(cols) {
        let c = &c[r0..r0 + U * L];
        let mut s = *a;
        for u in 0..U {
            let x = lanes::<L>(c, u * L);
            for l in 0..L {
                s[l] = madd::<FMA>(x[l], w[u][l], s[l]);
            }
        }
        *a = s;
    }
}

/// Adds the squares of a chunk's `U·L` values to lane-wise accumulators.
#[inline(always)]
fn add_squares<const L: usize, const U: usize, const FMA: bool>(
    acc: &mut [f64; L],
    chunk: &[[f64; L]; U],
) {
    for x in chunk {
        for l in 0..L {
            acc[l] = madd::<FMA>(x[l], x[l], acc[l]);
        }
    }
}

/// The sum of lane-wise accumulators, lane by lane in order.
fn lane_sum<const L: usize>(acc: &[f64; L]) -> f64 {
    acc.iter().fold(0.0, |s, v| s + v)
}

/// The last rows (from `from`) of every column and of a per-row vector, zero-padded to
/// `rows` rows, so that a pass ends with one more full chunk through the same register
/// kernels instead of a scalar loop (zero rows add nothing to a product or a sum; at
/// n = 1332 and 64-row chunks the scalar tail had cost a third as much as the rest).
struct PaddedTail {
    /// Column after column, then the per-row vector; `rows` values each.
    data: Vec<f64>,
    rows: usize,
    columns: usize,
}

impl PaddedTail {
    /// Without a `row_vector`, [`Self::row_vector`] is all zeros.
    fn new(cols: &[&[f64]], row_vector: Option<&[f64]>, from: usize, rows: usize) -> Self {
        let mut data = vec![0.0; rows * (cols.len() + 1)];
        for (dst, src) in data
            .chunks_exact_mut(rows)
            .zip(cols.iter().chain(&row_vector))
        {
            let src = &src[from..];
            dst[..src.len()].copy_from_slice(src);
        }
        PaddedTail {
            data,
            rows,
            columns: cols.len(),
        }
    }

    fn cols(&self) -> Vec<&[f64]> {
        self.data
            .chunks_exact(self.rows)
            .take(self.columns)
            .collect()
    }

    fn row_vector(&self) -> &[f64] {
        &self.data[self.columns * self.rows..]
    }
}

/// Runs `chunk(cols, row_vector, r0)` on every `rows`-row chunk of a pass, the last one on a
/// [`PaddedTail`]. Callers mark the closure `#[inline(always)]`: a closure is a function of
/// its own, and one left out of line loses the caller's `target_feature`s, which turns every
/// `mul_add` into a library call (eight times slower).
#[inline(always)]
fn for_each_chunk(
    cols: &[&[f64]],
    row_vector: &[f64],
    rows: usize,
    mut chunk: impl FnMut(&[&[f64]], &[f64], usize),
) {
    let n = row_vector.len();
    let full = n - n % rows;
    let mut r0 = 0;
    while r0 < full {
        chunk(cols, row_vector, r0);
        r0 += rows;
    }
    if full < n {
        let tail = PaddedTail::new(cols, Some(row_vector), full, rows);
        chunk(&tail.cols(), tail.row_vector(), 0);
    }
}

/// `(Φᵀr, ‖r‖², ‖Φw‖²)` for `r = y − Φβ`, the last only when `w` is given: the direct
/// path's refinement pass, which also yields what its objective and condition number need.
#[inline(always)]
fn refinement_generic<const L: usize, const U: usize, const FMA: bool>(
    cols: &[&[f64]],
    y: &[f64],
    beta: &[f64],
    w: Option<&[f64]>,
) -> (Vec<f64>, f64, f64) {
    let (mut rr, mut uu) = ([0.0f64; L], [0.0f64; L]);
    let mut grad = vec![[0.0f64; L]; cols.len()];
    for_each_chunk(
        cols,
        y,
        L * U,
        #[inline(always)]
        |cols, y, r0| {
            let r = residual_chunk::<L, U, FMA>(cols, y, beta, r0);
            add_squares::<L, U, FMA>(&mut rr, &r);
            if let Some(w) = w {
                add_squares::<L, U, FMA>(&mut uu, &combination_chunk::<L, U, FMA>(cols, w, r0));
            }
            transposed_chunk::<L, U, FMA>(&mut grad, cols, &r, r0);
        },
    );
    (
        grad.iter().map(lane_sum).collect(),
        lane_sum(&rr),
        lane_sum(&uu),
    )
}

/// `Φᵀv`.
#[inline(always)]
fn transposed_product_generic<const L: usize, const U: usize, const FMA: bool>(
    cols: &[&[f64]],
    v: &[f64],
) -> Vec<f64> {
    let mut acc = vec![[0.0f64; L]; cols.len()];
    for_each_chunk(
        cols,
        v,
        L * U,
        #[inline(always)]
        |cols, v, r0| {
            let v = &v[r0..r0 + U * L];
            let w: [[f64; L]; U] = std::array::from_fn(|u| lanes::<L>(v, u * L));
            transposed_chunk::<L, U, FMA>(&mut acc, cols, &w, r0);
        },
    );
    acc.iter().map(lane_sum).collect()
}

/// `Φv` into `out` (length n).
#[inline(always)]
fn combination_generic<const L: usize, const U: usize, const FMA: bool>(
    cols: &[&[f64]],
    v: &[f64],
    out: &mut [f64],
) {
    let n = out.len();
    let rows = L * U;
    let full = n - n % rows;
    let mut r0 = 0;
    while r0 < full {
        let x = combination_chunk::<L, U, FMA>(cols, v, r0);
        for (dst, src) in out[r0..r0 + rows].chunks_exact_mut(L).zip(&x) {
            dst.copy_from_slice(src);
        }
        r0 += rows;
    }
    if full < n {
        let tail = PaddedTail::new(cols, None, full, rows);
        let x = combination_chunk::<L, U, FMA>(&tail.cols(), v, 0);
        for (dst, src) in out[full..].iter_mut().zip(x.as_flattened()) {
            *dst = *src;
        }
    }
}

/// `‖y − Φβ‖²`.
#[inline(always)]
fn residual_norm_generic<const L: usize, const U: usize, const FMA: bool>(
    cols: &[&[f64]],
    y: &[f64],
    beta: &[f64],
) -> f64 {
    let mut rr = [0.0f64; L];
    for_each_chunk(
        cols,
        y,
        L * U,
        #[inline(always)]
        |cols, y, r0| {
            add_squares::<L, U, FMA>(&mut rr, &residual_chunk::<L, U, FMA>(cols, y, beta, r0));
        },
    );
    lane_sum(&rr)
}

// One copy of the run-time instruction-set choice for every kernel of the crate (the SVR
// interior point's per-sample loops included): an unsafe call guarded by a feature test is
// easy to get subtly wrong, so it is written once. `$generic` must be `#[inline(always)]`
// so that it is compiled inside each `target_feature` wrapper.
macro_rules! dispatch {
    ($(#[$doc:meta])* $vis:vis fn $name:ident, $generic:ident,
     ($($arg:ident: $ty:ty),*) -> $ret:ty,
     avx512: <$($p512:literal),*>, avx2: <$($p2:literal),*>, base: <$($pb:literal),*>) => {
        $(#[$doc])*
        $vis fn $name($($arg: $ty),*) -> $ret {
            #[cfg(target_arch = "x86_64")]
            {
                if std::arch::is_x86_feature_detected!("avx512f") {
                    #[target_feature(enable = "avx512f,avx2,fma")]
                    fn avx512($($arg: $ty),*) -> $ret {
                        $generic::<$($p512),*>($($arg),*)
                    }
                    // SAFETY: the CPU supports AVX-512F (checked just above).
                    return unsafe { avx512($($arg),*) };
                }
                if std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
                {
                    #[target_feature(enable = "avx2,fma")]
                    fn avx2($($arg: $ty),*) -> $ret {
                        $generic::<$($p2),*>($($arg),*)
                    }
                    // SAFETY: the CPU supports AVX2 and FMA (checked just above).
                    return unsafe { avx2($($arg),*) };
                }
            }
            $generic::<$($pb),*>($($arg),*)
        }
    };
}

pub(crate) use dispatch;

dispatch!(
    /// Upper triangle of `AᵀWA` (entry `(i, j)`, `i ≤ j`, at `i·m + j`; the rest is 0) for
    /// the `m` columns `cols`, each of length `n`, and `W = diag(root_weights)²` (identity
    /// without), so that a weighted Gram needs no scaled copy of A.
    pub(crate) fn cross_products, cross_products_generic,
    (cols: &[&[f64]], n: usize, root_weights: Option<&[f64]>) -> Vec<f64>,
    avx512: <4, 8, true>, avx2: <3, 4, true>, base: <2, 2, false>
);

dispatch!(
    /// `(Φᵀr, ‖r‖², ‖Φw‖²)` for `r = y − Φβ` in one pass over Φ (the last 0 without `w`).
    pub(crate) fn refinement, refinement_generic,
    (cols: &[&[f64]], y: &[f64], beta: &[f64], w: Option<&[f64]>) -> (Vec<f64>, f64, f64),
    avx512: <8, 8, true>, avx2: <4, 4, true>, base: <2, 2, false>
);

dispatch!(
    /// `‖y − Φβ‖²` in one pass over Φ.
    pub(crate) fn residual_norm, residual_norm_generic,
    (cols: &[&[f64]], y: &[f64], beta: &[f64]) -> f64,
    avx512: <8, 4, true>, avx2: <4, 4, true>, base: <2, 2, false>
);

dispatch!(
    /// `Φᵀv` in one pass over Φ.
    pub(crate) fn transposed_product, transposed_product_generic,
    (cols: &[&[f64]], v: &[f64]) -> Vec<f64>,
    avx512: <8, 4, true>, avx2: <4, 4, true>, base: <2, 2, false>
);

dispatch!(
    /// `Φv` into `out` in one pass over Φ.
    pub(crate) fn combination, combination_generic,
    (cols: &[&[f64]], v: &[f64], out: &mut [f64]) -> (),
    avx512: <8, 4, true>, avx2: <4, 4, true>, base: <2, 2, false>
);

#[cfg(test)]
mod tests {
    use super::*;

    /// Columns of smooth, unrelated values (exact sums in no order, so the check needs a
    /// tolerance) with `n` rows.
    fn columns(n: usize, m: usize) -> Vec<Vec<f64>> {
        (0..m)
            .map(|j| {
                (0..n)
                    .map(|i| ((i as f64 + 1.0) * 0.37 * (j as f64 + 1.0)).sin() + 0.1 * j as f64)
                    .collect()
            })
            .collect()
    }

    fn close(got: f64, want: f64, what: &str, n: usize) {
        assert!(
            (got - want).abs() <= 1e-12 * (1.0 + want.abs()),
            "{what} at n = {n}: {got} against {want}"
        );
    }

    /// Every pass against plain loops, at row counts that leave every tail length of the
    /// 64-row (AVX-512), 16-row (AVX2) and 4-row (baseline) chunks, including n shorter
    /// than one chunk; each instruction set's parameters, whichever this CPU dispatches to.
    #[test]
    fn every_pass_counts_every_row_whatever_the_tail() {
        for n in (1..=140).chain([1332]) {
            check_passes::<4, 8, 8, true>(n);
            check_passes::<3, 4, 4, true>(n);
            check_passes::<2, 2, 2, false>(n);
        }
    }

    /// The cross products at every column count from 1 to 13 (every width of a narrow last
    /// block, for each instruction set's tile size) and at row counts below one vector, in
    /// one block and across several, with and without weights, against plain loops.
    #[test]
    fn cross_products_cover_every_column_count() {
        for m in 1..=13 {
            for n in [1, 7, 37, 300, 1332] {
                check_cross::<4, 8, true>(n, m);
                check_cross::<3, 4, true>(n, m);
                check_cross::<2, 2, false>(n, m);
            }
        }
    }

    fn check_cross<const T: usize, const L: usize, const FMA: bool>(n: usize, m: usize) {
        let data = columns(n, m + 1);
        let cols: Vec<&[f64]> = data[..m].iter().map(|c| c.as_slice()).collect();
        let root_w: Vec<f64> = data[m].iter().map(|v| 1.0 + 0.5 * v).collect();
        for weighted in [false, true] {
            let w = |i: usize| if weighted { root_w[i] * root_w[i] } else { 1.0 };
            let rw = weighted.then_some(root_w.as_slice());
            let cross = cross_products_generic::<T, L, FMA>(&cols, n, rw);
            for a in 0..m {
                for b in 0..m {
                    let want = if a <= b {
                        (0..n).map(|i| cols[a][i] * w(i) * cols[b][i]).sum::<f64>()
                    } else {
                        0.0
                    };
                    let what = format!("T={T} m={m} weighted={weighted} ({a}, {b})");
                    close(cross[a * m + b], want, &what, n);
                }
            }
        }
    }

    /// T: cross-product tile, L: lanes, U: chunks per pass.
    fn check_passes<const T: usize, const L: usize, const U: usize, const FMA: bool>(n: usize) {
        let m = 5;
        let data = columns(n, m + 2);
        let cols: Vec<&[f64]> = data[..m].iter().map(|c| c.as_slice()).collect();
        let (y, v) = (&data[m], &data[m + 1]);
        let beta: Vec<f64> = (0..m).map(|j| 0.3 - 0.1 * j as f64).collect();
        let w: Vec<f64> = (0..m).map(|j| 1.0 / (j as f64 + 2.0)).collect();
        let r: Vec<f64> = (0..n)
            .map(|i| y[i] - (0..m).map(|j| beta[j] * cols[j][i]).sum::<f64>())
            .collect();
        let phi_w: Vec<f64> = (0..n)
            .map(|i| (0..m).map(|j| w[j] * cols[j][i]).sum())
            .collect();
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();

        let (grad, rr, uu) = refinement_generic::<L, U, FMA>(&cols, y, &beta, Some(&w));
        for j in 0..m {
            close(grad[j], dot(cols[j], &r), "Φᵀr", n);
        }
        close(rr, dot(&r, &r), "‖r‖²", n);
        close(uu, dot(&phi_w, &phi_w), "‖Φw‖²", n);
        let rn = residual_norm_generic::<L, U, FMA>(&cols, y, &beta);
        close(rn, dot(&r, &r), "‖y − Φβ‖²", n);
        let t = transposed_product_generic::<L, U, FMA>(&cols, v);
        for j in 0..m {
            close(t[j], dot(cols[j], v), "Φᵀv", n);
        }
        let mut out = vec![f64::NAN; n];
        combination_generic::<L, U, FMA>(&cols, &w, &mut out);
        for i in 0..n {
            close(out[i], phi_w[i], "Φw", n);
        }
        let all: Vec<&[f64]> = data.iter().map(|c| c.as_slice()).collect();
        let cross = cross_products_generic::<T, L, FMA>(&all, n, None);
        for a in 0..all.len() {
            for b in a..all.len() {
                close(cross[a * all.len() + b], dot(all[a], all[b]), "AᵀA", n);
            }
        }
    }
}
