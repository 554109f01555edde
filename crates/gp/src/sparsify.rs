//! Similarity-based sparsification of a large sample set (paper 001 §3, Tab. 1).
//!
//! The similarity of two points is d(x, s) = exp(−Σᵢ (xᵢ − sᵢ)² / lᵢ²) (paper 001 eq. 13), 1 for equal
//! points and falling towards 0 with distance; lᵢ are per-dimension scales ("the amplitude of each
//! dimension" in the paper: larger lᵢ, wider spacing along that dimension). The samples are walked in
//! order; the first is kept, and a later one is kept only if its largest similarity to the points
//! already kept is below the threshold d_gen (Tab. 1, step 5: `max d(xᵢ, S_j) < d_gen`). The result
//! depends on the order of the samples, as in the paper.

use crate::error::GpError;
use crate::points::Points;

/// Scales lᵢ of the similarity and its threshold d_gen.
#[derive(Debug, Clone, PartialEq)]
pub struct Similarity {
    /// Per-dimension scales lᵢ (> 0), in the units of the inputs.
    pub scales: Vec<f64>,
    /// Threshold d_gen in (0, 1]: a point is new information when its similarity to every kept point is
    /// below it. Lower thresholds keep fewer points.
    pub threshold: f64,
}

impl Similarity {
    /// Check the scales against the input dimension and the threshold's domain.
    pub fn check(&self, dims: usize) -> Result<(), GpError> {
        if self.scales.len() != dims {
            return Err(GpError::LengthMismatch {
                what: "similarity scales",
                expected: dims,
                got: self.scales.len(),
            });
        }
        for &l in &self.scales {
            if !(l.is_finite() && l > 0.0) {
                return Err(GpError::InvalidParameter {
                    what: "similarity scale",
                    value: l,
                });
            }
        }
        if !(self.threshold > 0.0 && self.threshold <= 1.0) {
            return Err(GpError::InvalidParameter {
                what: "similarity threshold d_gen (must be in (0, 1])",
                value: self.threshold,
            });
        }
        Ok(())
    }

    /// d(a, b) = exp(−Σᵢ (aᵢ − bᵢ)² / lᵢ²).
    pub fn similarity(&self, a: &[f64], b: &[f64]) -> f64 {
        (-self.scaled_sq_distance(a, b)).exp()
    }

    /// True when some point of `kept` is at least d_gen similar to `x` (the walk's own test, so every
    /// sample it walked is covered by the points it kept: a kept one by itself, another by the point
    /// that made it redundant).
    pub fn covered(&self, kept: &Points, x: &[f64]) -> bool {
        (0..kept.len()).any(|j| self.similarity(x, kept.row(j)) >= self.threshold)
    }

    fn scaled_sq_distance(&self, a: &[f64], b: &[f64]) -> f64 {
        a.iter()
            .zip(b)
            .zip(&self.scales)
            .map(|((x, s), l)| ((x - s) / l).powi(2))
            .sum()
    }
}

/// Indices (in increasing order) of the points kept by the similarity walk of paper 001 Tab. 1.
pub fn sparsify(points: &Points, similarity: &Similarity) -> Result<Vec<usize>, GpError> {
    similarity.check(points.dims())?;
    if points.is_empty() {
        return Err(GpError::Empty {
            points: 0,
            dims: points.dims(),
        });
    }
    let mut kept = vec![0usize];
    for i in 1..points.len() {
        let x = points.row(i);
        let is_new = kept
            .iter()
            .all(|&j| similarity.similarity(x, points.row(j)) < similarity.threshold);
        if is_new {
            kept.push(i);
        }
    }
    Ok(kept)
}

/// Half the range (max − min)/2 of every input dimension: the default similarity scales ("amplitude of
/// each dimension", paper 001 §3). A constant dimension gets scale 1 so that it cannot divide by zero.
pub fn half_ranges(points: &Points) -> Vec<f64> {
    (0..points.dims())
        .map(|d| {
            let (lo, hi) =
                (0..points.len()).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), i| {
                    let v = points.row(i)[d];
                    (lo.min(v), hi.max(v))
                });
            let h = 0.5 * (hi - lo);
            if h.is_finite() && h > 0.0 { h } else { 1.0 }
        })
        .collect()
}
