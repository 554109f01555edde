//! Fused passes over the columns of a raw design for the direct least-squares path
//! ([`crate::direct`]): the cross-product matrix of `[Φ y]` in one pass, and the residual
//! `y − Φβ` with `Φᵀr` and `‖r‖²` (plus `‖Φv‖²`) in another; `‖y − Φβ‖²` alone for
//! [`crate::fit`]'s objective; and the products `Φᵀv`, `Φv` of the SVR interior point's
//! iterations.
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
fn madd<const FMA: bool>(a: f64, b: f64, c: f64) -> f64 {
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

/// One T×T register tile of [`cross_products_generic`] over rows `start..end`: `s[i][j] += Σ
/// wᵣ aᵢᵣ bⱼᵣ` lane-wise. A diagonal tile (`DIAG`, `a` = `b`) loads its columns once and forms only
/// the products i ≤ j (10 of 16 at T = 4); the others are left as they are.
#[inline(always)]
fn tile<const T: usize, const L: usize, const FMA: bool, const DIAG: bool>(
    mut s: [[[f64; L]; T]; T],
    a: [&[f64]; T],
    b: [&[f64]; T],
    root_weights: Option<&[f64]>,
    start: usize,
    end: usize,
) -> [[[f64; L]; T]; T] {
    let mut r = start;
    while r < end {
        let bv: [[f64; L]; T] = std::array::from_fn(|t| lanes::<L>(b[t], r));
        let mut av: [[f64; L]; T] = if DIAG {
            bv
        } else {
            std::array::from_fn(|t| lanes::<L>(a[t], r))
        };
        if let Some(rw) = root_weights {
            // (√wᵢ aᵢ)(√wᵢ bᵢ) = wᵢ aᵢ bᵢ: one side carries the weight.
            let wl = lanes::<L>(rw, r);
            for t in 0..T {
                for l in 0..L {
                    av[t][l] *= wl[l] * wl[l];
                }
            }
        }
        for i in 0..T {
            for j in (if DIAG { i } else { 0 })..T {
                for l in 0..L {
                    s[i][j][l] = madd::<FMA>(av[i][l], bv[j][l], s[i][j][l]);
                }
            }
        }
        r += L;
    }
    s
}

/// Upper triangle (row-major pairs `i ≤ j`) of `AᵀA` for the columns of `A`, all of
/// length `n`. T×T register tiles of column pairs, L lanes per accumulator.
#[inline(always)]
fn cross_products_generic<const T: usize, const L: usize, const FMA: bool>(
    cols: &[&[f64]],
    n: usize,
    root_weights: Option<&[f64]>,
) -> Vec<f64> {
    let m = cols.len();
    let tiles = m.div_ceil(T);
    // Columns past the last are padded with copies of the last column; their products
    // are computed and discarded, which is cheaper than separate remainder kernels.
    let col = |k: usize| cols[k.min(m - 1)];
    let pairs: Vec<(usize, usize)> = (0..tiles)
        .flat_map(|a| (a..tiles).map(move |b| (a, b)))
        .collect();
    let mut acc = vec![[[[0.0f64; L]; T]; T]; pairs.len()];
    let full = n - n % L;
    let mut start = 0;
    while start < full {
        let end = (start + BLOCK_ROWS).min(full);
        for (pair, s_out) in pairs.iter().zip(acc.iter_mut()) {
            let a: [&[f64]; T] = std::array::from_fn(|t| &col(pair.0 * T + t)[..end]);
            let b: [&[f64]; T] = std::array::from_fn(|t| &col(pair.1 * T + t)[..end]);
            *s_out = if pair.0 == pair.1 {
                tile::<T, L, FMA, true>(*s_out, a, a, root_weights, start, end)
            } else {
                tile::<T, L, FMA, false>(*s_out, a, b, root_weights, start, end)
            };
        }
        start = end;
    }
    let mut out = vec![0.0; m * m];
    for (pair, s) in pairs.iter().zip(&acc) {
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
    let mut r: [[f64; L]; U] = std::array::from_fn(|u| lanes::<L>(y, r0 + u * L));
    for (c, &b) in cols.iter().zip(beta) {
        for u in 0..U {
            let x = lanes::<L>(c, r0 + u * L);
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
        for u in 0..U {
            let x = lanes::<L>(c, r0 + u * L);
            for l in 0..L {
                out[u][l] = madd::<FMA>(b, x[l], out[u][l]);
            }
        }
    }
    out
}

fn residual_at(cols: &[&[f64]], y: &[f64], beta: &[f64], i: usize) -> f64 {
    let mut r = y[i];
    for (c, &b) in cols.iter().zip(beta) {
        r -= b * c[i];
    }
    r
}

/// `(Φv)ᵢ`, the tail rows' twin of [`combination_chunk`].
fn combination_at(cols: &[&[f64]], v: &[f64], i: usize) -> f64 {
    cols.iter().zip(v).map(|(c, b)| b * c[i]).sum()
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

/// `Φᵀw` for the vector w given chunk by chunk (`chunk(r0)`: its `U·L` entries from row r0,
/// computed in registers) and entry by entry in the tail (`at(i)`): Φ is read once, and w
/// need not exist in memory.
#[inline(always)]
fn transposed_generic<const L: usize, const U: usize, const FMA: bool>(
    cols: &[&[f64]],
    n: usize,
    mut chunk: impl FnMut(usize) -> [[f64; L]; U],
    mut at: impl FnMut(usize) -> f64,
) -> Vec<f64> {
    let rows = L * U;
    let full = n - n % rows;
    let mut acc = vec![[0.0f64; L]; cols.len()];
    let mut r0 = 0;
    while r0 < full {
        let w = chunk(r0);
        for (a, c) in acc.iter_mut().zip(cols) {
            let mut s = *a;
            for u in 0..U {
                let x = lanes::<L>(c, r0 + u * L);
                for l in 0..L {
                    s[l] = madd::<FMA>(x[l], w[u][l], s[l]);
                }
            }
            *a = s;
        }
        r0 += rows;
    }
    let mut out: Vec<f64> = acc.iter().map(lane_sum).collect();
    for i in full..n {
        let w = at(i);
        for (o, c) in out.iter_mut().zip(cols) {
            *o += c[i] * w;
        }
    }
    out
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
    let (mut rr_tail, mut uu_tail) = (0.0, 0.0);
    let grad = transposed_generic::<L, U, FMA>(
        cols,
        y.len(),
        |r0| {
            let r = residual_chunk::<L, U, FMA>(cols, y, beta, r0);
            add_squares::<L, U, FMA>(&mut rr, &r);
            if let Some(w) = w {
                add_squares::<L, U, FMA>(&mut uu, &combination_chunk::<L, U, FMA>(cols, w, r0));
            }
            r
        },
        |i| {
            let r = residual_at(cols, y, beta, i);
            rr_tail += r * r;
            if let Some(w) = w {
                let u = combination_at(cols, w, i);
                uu_tail += u * u;
            }
            r
        },
    );
    (grad, lane_sum(&rr) + rr_tail, lane_sum(&uu) + uu_tail)
}

/// `Φᵀv`.
#[inline(always)]
fn transposed_product_generic<const L: usize, const U: usize, const FMA: bool>(
    cols: &[&[f64]],
    v: &[f64],
) -> Vec<f64> {
    transposed_generic::<L, U, FMA>(
        cols,
        v.len(),
        |r0| std::array::from_fn(|u| lanes::<L>(v, r0 + u * L)),
        |i| v[i],
    )
}

/// `Φv` into `out` (length n).
#[inline(always)]
fn combination_generic<const L: usize, const U: usize, const FMA: bool>(
    cols: &[&[f64]],
    v: &[f64],
    out: &mut [f64],
) {
    let n = out.len();
    let chunk = L * U;
    let full = n - n % chunk;
    let mut r0 = 0;
    while r0 < full {
        let x = combination_chunk::<L, U, FMA>(cols, v, r0);
        for u in 0..U {
            out[r0 + u * L..r0 + (u + 1) * L].copy_from_slice(&x[u]);
        }
        r0 += chunk;
    }
    for i in full..n {
        out[i] = combination_at(cols, v, i);
    }
}

/// `‖y − Φβ‖²`.
#[inline(always)]
fn residual_norm_generic<const L: usize, const U: usize, const FMA: bool>(
    cols: &[&[f64]],
    y: &[f64],
    beta: &[f64],
) -> f64 {
    let n = y.len();
    let chunk = L * U;
    let full = n - n % chunk;
    let mut rr = [0.0f64; L];
    let mut r0 = 0;
    while r0 < full {
        add_squares::<L, U, FMA>(&mut rr, &residual_chunk::<L, U, FMA>(cols, y, beta, r0));
        r0 += chunk;
    }
    let mut rr = lane_sum(&rr);
    for i in full..n {
        let r = residual_at(cols, y, beta, i);
        rr += r * r;
    }
    rr
}

macro_rules! dispatch {
    ($(#[$doc:meta])* $name:ident, $generic:ident, ($($arg:ident: $ty:ty),*) -> $ret:ty,
     avx512: <$($p512:tt),*>, avx2: <$($p2:tt),*>, base: <$($pb:tt),*>) => {
        $(#[$doc])*
        pub(crate) fn $name($($arg: $ty),*) -> $ret {
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

dispatch!(
    /// Upper triangle of `AᵀWA` (entry `(i, j)`, `i ≤ j`, at `i·m + j`; the rest is 0) for
    /// the `m` columns `cols`, each of length `n`, and `W = diag(root_weights)²` (identity
    /// without), so that a weighted Gram needs no scaled copy of A.
    cross_products, cross_products_generic,
    (cols: &[&[f64]], n: usize, root_weights: Option<&[f64]>) -> Vec<f64>,
    avx512: <4, 8, true>, avx2: <3, 4, true>, base: <2, 2, false>
);

dispatch!(
    /// `(Φᵀr, ‖r‖², ‖Φw‖²)` for `r = y − Φβ` in one pass over Φ (the last 0 without `w`).
    refinement, refinement_generic,
    (cols: &[&[f64]], y: &[f64], beta: &[f64], w: Option<&[f64]>) -> (Vec<f64>, f64, f64),
    avx512: <8, 4, true>, avx2: <4, 4, true>, base: <2, 2, false>
);

dispatch!(
    /// `‖y − Φβ‖²` in one pass over Φ.
    residual_norm, residual_norm_generic, (cols: &[&[f64]], y: &[f64], beta: &[f64]) -> f64,
    avx512: <8, 4, true>, avx2: <4, 4, true>, base: <2, 2, false>
);

dispatch!(
    /// `Φᵀv` in one pass over Φ.
    transposed_product, transposed_product_generic, (cols: &[&[f64]], v: &[f64]) -> Vec<f64>,
    avx512: <8, 4, true>, avx2: <4, 4, true>, base: <2, 2, false>
);

dispatch!(
    /// `Φv` into `out` in one pass over Φ.
    combination, combination_generic, (cols: &[&[f64]], v: &[f64], out: &mut [f64]) -> (),
    avx512: <8, 4, true>, avx2: <4, 4, true>, base: <2, 2, false>
);
