//! Block length of the moving-block bootstrap.
//!
//! Equation-error residuals of a manoeuvre are smooth in time (the model error follows the state,
//! which changes over tens of seconds), so neighbouring rows are not independent evidence. A block
//! must be long enough that rows in different blocks are nearly uncorrelated: we take the first lag
//! at which the residual autocorrelation falls inside the ±2/√n band of white noise (the lag beyond
//! which the data cannot tell the residuals from independent ones), never shorter than n^(1/3) (the
//! rate that keeps the block bootstrap's variance estimate consistent, Künsch 1989; Lahiri 2003) and
//! never longer than n/4, so that one recording still yields at least four blocks to resample.

use serde::Serialize;

/// The chosen block length and why.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BlockLength {
    /// Rows per block.
    pub rows: usize,
    /// First lag [rows] at which the autocorrelation fell inside ±2/√n (None: never within n/4).
    pub decorrelation_lag: Option<usize>,
    /// The floor n^(1/3) [rows].
    pub floor_rows: usize,
    /// The cap n/4 [rows].
    pub cap_rows: usize,
}

/// Sample autocorrelation of `x` at `lag` (biased estimator, mean removed).
fn autocorrelation(x: &[f64], mean: f64, variance_sum: f64, lag: usize) -> f64 {
    let s: f64 = x[lag..]
        .iter()
        .zip(x)
        .map(|(a, b)| (a - mean) * (b - mean))
        .sum();
    s / variance_sum
}

/// The block length for residuals `residual` of one recording (rows in time order). Non-finite
/// residuals are ignored for the autocorrelation; fewer than 8 rows give blocks of one row.
pub fn block_length(residual: &[f64]) -> BlockLength {
    let x: Vec<f64> = residual.iter().copied().filter(|v| v.is_finite()).collect();
    let n = x.len();
    let floor_rows = (n as f64).cbrt().ceil().max(1.0) as usize;
    let cap_rows = (n / 4).max(1);
    if n < 8 {
        return BlockLength {
            rows: 1,
            decorrelation_lag: None,
            floor_rows,
            cap_rows,
        };
    }
    let mean = x.iter().sum::<f64>() / n as f64;
    let variance_sum: f64 = x.iter().map(|v| (v - mean) * (v - mean)).sum();
    let white = 2.0 / (n as f64).sqrt();
    let decorrelation_lag = if variance_sum > 0.0 {
        (1..=cap_rows).find(|&lag| autocorrelation(&x, mean, variance_sum, lag).abs() < white)
    } else {
        Some(1)
    };
    let rows = decorrelation_lag
        .unwrap_or(cap_rows)
        .clamp(floor_rows.min(cap_rows), cap_rows);
    BlockLength {
        rows,
        decorrelation_lag,
        floor_rows,
        cap_rows,
    }
}
