//! Acceleration estimation from velocity signals: a smoothing differentiator.
//!
//! Method: local polynomial least squares — the Savitzky–Golay filter generalised to uneven sampling. At
//! every sample a cubic in (t − tᵢ) is fitted to the `2h+1` nearest samples (the window is shifted, not
//! shortened, at the ends of the record) and its slope at tᵢ is the derivative. On evenly sampled data
//! away from the ends this is exactly Savitzky–Golay of order 3.
//!
//! Window: its duration is a fixed fraction of the ship's time scale L/U0 ([`WINDOW_FRACTION_OF_L_OVER_U0`]),
//! so that model and full scale are smoothed alike, and its number of samples follows from the sampling
//! rate: h = round(T_w / (2 Δt_median)), at least 3. For KVLCC2 at model scale (L/U0 = 5.94 s) the window
//! is 1.78 s: 19 samples at 10 Hz, 37 at 20 Hz. A coarsely sampled recording gets a longer window than
//! asked for (7 samples at least: 30 s at 5 s sampling); [`EstimationWindow`] says which it got.

use crate::types::{Accelerations, Recording, Ship};

/// Window duration as a fraction of L/U0. Zig-zag periods are 5–8 L/U0; over 0.3 L/U0 a cubic follows
/// them with a bias below 0.1 % while averaging sensor noise over ~20 samples at 10 Hz. Rudder executes
/// (about 2 s at model scale) are smeared over the same window.
pub const WINDOW_FRACTION_OF_L_OVER_U0: f64 = 0.3;

/// Polynomial degree of the local fit.
pub const DEGREE: usize = 3;

/// An effective window longer than this many times the one asked for is too coarse a sampling for
/// the estimate: beyond it the cubic smooths over a good part of a zig-zag's half period.
pub const COARSE_FACTOR: f64 = 1.5;

/// The window a recording's accelerations are estimated over: the one asked for and the one its
/// sampling gives (whole samples, at least [`DEGREE`] on each side, at most the whole record), which
/// is what a model file must state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EstimationWindow {
    /// Asked for [s]: [`WINDOW_FRACTION_OF_L_OVER_U0`] × L/U0.
    pub requested_s: f64,
    /// Spanned by the samples of one window [s]: (samples − 1) × the median step.
    pub effective_s: f64,
    /// Samples in one window.
    pub samples: usize,
    /// Median time step [s].
    pub step_s: f64,
}

impl EstimationWindow {
    /// The project's default window for `ship` on the clock `t`, as [`Differentiator::for_ship`] uses.
    pub fn of(t: &[f64], ship: &Ship) -> EstimationWindow {
        let requested_s = WINDOW_FRACTION_OF_L_OVER_U0 * ship.lpp / ship.u0;
        let d = Differentiator::for_window(t, requested_s);
        let step_s = median_step(t).unwrap_or(0.0);
        let samples = (2 * d.half_width + 1).min(t.len());
        EstimationWindow {
            requested_s,
            effective_s: samples.saturating_sub(1) as f64 * step_s,
            samples,
            step_s,
        }
    }

    /// The sampling is too coarse for the window asked for ([`COARSE_FACTOR`]).
    pub fn too_coarse(&self) -> bool {
        self.effective_s > COARSE_FACTOR * self.requested_s
    }
}

/// A smoothing differentiator with a fixed half-width in samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Differentiator {
    /// Samples on each side of the centre.
    pub half_width: usize,
}

impl Differentiator {
    /// Half-width chosen from the sampling rate of `t` and the window duration `window_s`.
    pub fn for_window(t: &[f64], window_s: f64) -> Differentiator {
        let dt = median_step(t).unwrap_or(1.0);
        let h = (window_s / (2.0 * dt)).round();
        let h = if h.is_finite() { h as usize } else { 3 };
        Differentiator {
            half_width: h.max(DEGREE),
        }
    }

    /// The project's default window for a ship: 0.3 L/U0.
    pub fn for_ship(t: &[f64], ship: &Ship) -> Differentiator {
        Self::for_window(t, WINDOW_FRACTION_OF_L_OVER_U0 * ship.lpp / ship.u0)
    }

    /// dy/dt at every sample of `t`. Signals shorter than the window use all their samples.
    ///
    /// The samples within `half_width` of either end share one window (it is shifted, not shortened),
    /// so one cubic serves them all. Inside, the window's power sums move one sample at a time
    /// ([`SlidingMoments`]): a sample added, one removed and a 4 × 4 solve per sample instead of a fit
    /// over all 2h + 1, which is what keeps a high-rate recording (windows of thousands of samples)
    /// from taking minutes. Each window's cubic is the least-squares one to rounding (1e-10 relative).
    pub fn derivative(&self, t: &[f64], y: &[f64]) -> Vec<f64> {
        let n = t.len().min(y.len());
        let m = (2 * self.half_width + 1).min(n);
        if m < DEGREE + 1 {
            return vec![f64::NAN; n];
        }
        let (t, y) = (&t[..n], &y[..n]);
        let h = self.half_width.min((m - 1) / 2);
        let mut out = vec![f64::NAN; n];
        // Window [lo, lo + m) of sample i: lo = clamp(i − h, 0, n − m).
        let head_end = (h + 1).min(n); // samples 0..=h start at 0
        let tail_start = (n - m + h).max(head_end); // samples from here start at n − m
        let end_slopes = |lo: usize, range: std::ops::Range<usize>, out: &mut [f64]| {
            if let Some(fit) = LocalCubic::fit(&t[lo..lo + m], &y[lo..lo + m]) {
                for i in range {
                    out[i] = fit.slope_at(t[i]);
                }
            }
        };
        end_slopes(0, 0..head_end, &mut out);
        end_slopes(n - m, tail_start..n, &mut out);
        let mut sliding: Option<SlidingMoments> = None;
        for i in head_end..tail_start {
            let lo = i - h;
            let moved = sliding
                .as_mut()
                .is_some_and(|s| s.lo + 1 == lo && s.slide(t, y, m));
            if !moved {
                sliding = Some(SlidingMoments::new(t, y, lo, m));
            }
            out[i] = sliding
                .as_ref()
                .and_then(SlidingMoments::cubic)
                .map_or(f64::NAN, |c| c.slope_at(t[i]));
        }
        out
    }

    /// Estimated accelerations of a recording (u̇, v̇ [m/s²], ṙ [rad/s²]).
    pub fn accelerations(&self, rec: &Recording) -> Accelerations {
        Accelerations {
            u_dot: self.derivative(&rec.t, &rec.u),
            v_dot: self.derivative(&rec.t, &rec.v),
            r_dot: self.derivative(&rec.t, &rec.r),
        }
    }
}

/// Half-widths a [`SlidingMoments`] window moves before its sums are recomputed about a new anchor.
const REANCHOR: f64 = 1.0;

/// Power sums of one window [lo, lo + m) in scaled time τ = (t − anchor)/scale, moved one sample at a
/// time: Σ τᵖ (p ≤ 6) and Σ τᵖ y (p ≤ 3) are the normal equations of the window's cubic, so an unevenly
/// sampled window costs a sample added, one removed and a 4 × 4 solve instead of a fit over all m.
struct SlidingMoments {
    anchor: f64,
    scale: f64,
    anchor_lo: usize,
    lo: usize,
    tau_powers: [f64; 2 * DEGREE + 1],
    y_moments: [f64; DEGREE + 1],
}

impl SlidingMoments {
    fn new(t: &[f64], y: &[f64], lo: usize, m: usize) -> SlidingMoments {
        let mut s = SlidingMoments {
            anchor: 0.5 * (t[lo] + t[lo + m - 1]),
            scale: 0.5 * (t[lo + m - 1] - t[lo]),
            anchor_lo: lo,
            lo,
            tau_powers: [0.0; 2 * DEGREE + 1],
            y_moments: [0.0; DEGREE + 1],
        };
        for j in lo..lo + m {
            s.add(t[j], y[j], 1.0);
        }
        s
    }

    fn add(&mut self, t: f64, y: f64, sign: f64) {
        let tau = (t - self.anchor) / self.scale;
        let mut p = sign;
        for k in 0..=2 * DEGREE {
            self.tau_powers[k] += p;
            if k <= DEGREE {
                self.y_moments[k] += p * y;
            }
            p *= tau;
        }
    }

    /// Move the window on by one sample; `false` when it should be re-anchored instead: every
    /// [`REANCHOR`] × (m − 1)/2 samples, so that the sums carry no rounding from far back, and when a
    /// gap in the clock enters or leaves the window (the new sample beyond τ = 3, or the window's span
    /// off the anchor's by more than a factor 2): the powers up to τ⁶ of a far sample would drown the
    /// others, and a window much shorter than its scale clusters its τ and loses the cubic. A value
    /// that is not finite is not slid either: it would stay in the sums after it left the window.
    fn slide(&mut self, t: &[f64], y: &[f64], m: usize) -> bool {
        let (new, old) = (self.lo + m, self.lo);
        let tau_new = (t[new] - self.anchor) / self.scale;
        let span_ratio = (t[new] - t[old + 1]) / (2.0 * self.scale);
        if (new - self.anchor_lo - m) as f64 >= REANCHOR * (m - 1) as f64 / 2.0
            || tau_new.is_nan()
            || tau_new > 3.0
            || !(0.5..=2.0).contains(&span_ratio)
            || !(y[old].is_finite() && y[new].is_finite())
        {
            return false;
        }
        self.add(t[old], y[old], -1.0);
        self.add(t[new], y[new], 1.0);
        self.lo += 1;
        true
    }

    /// The window's least-squares cubic; `None` for a window without duration or a singular system.
    fn cubic(&self) -> Option<LocalCubic> {
        if self.scale.is_nan() || self.scale <= 0.0 {
            return None;
        }
        let mut gram = [[0.0; DEGREE + 1]; DEGREE + 1];
        for (a, row) in gram.iter_mut().enumerate() {
            for (b, g) in row.iter_mut().enumerate() {
                *g = self.tau_powers[a + b];
            }
        }
        Some(LocalCubic {
            centre: self.anchor,
            scale: self.scale,
            coefficients: solve4(gram, self.y_moments)?,
        })
    }
}

/// Gaussian elimination with partial pivoting; `None` for a singular system.
fn solve4(
    mut a: [[f64; DEGREE + 1]; DEGREE + 1],
    mut b: [f64; DEGREE + 1],
) -> Option<[f64; DEGREE + 1]> {
    let k = DEGREE + 1;
    for col in 0..k {
        let pivot = (col..k).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[pivot][col] == 0.0 || a[pivot][col].is_nan() {
            return None;
        }
        a.swap(col, pivot);
        b.swap(col, pivot);
        let pivot_row = a[col];
        for row in col + 1..k {
            let f = a[row][col] / pivot_row[col];
            for (x, p) in a[row][col..].iter_mut().zip(&pivot_row[col..]) {
                *x -= f * p;
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = [0.0; DEGREE + 1];
    for row in (0..k).rev() {
        let tail: f64 = (row + 1..k).map(|c| a[row][c] * x[c]).sum();
        x[row] = (b[row] - tail) / a[row][row];
    }
    Some(x)
}

/// Recorded accelerations when the recording has them, otherwise the smoothing differentiator's
/// estimate with the ship's default window. Returns whether they were estimated.
pub fn accelerations_or_estimate(rec: &Recording, ship: &Ship) -> (Accelerations, bool) {
    match &rec.accelerations {
        Some(a) => (a.clone(), false),
        None => (
            Differentiator::for_ship(&rec.t, ship).accelerations(rec),
            true,
        ),
    }
}

fn median_step(t: &[f64]) -> Option<f64> {
    let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    if steps.is_empty() {
        return None;
    }
    steps.sort_by(f64::total_cmp);
    Some(steps[steps.len() / 2])
}

/// A least-squares cubic in τ = (t − centre)/scale, the window centred and scaled to [−1, 1] so the
/// normal equations stay well conditioned at any sampling rate: a window's fit from its power sums
/// ([`SlidingMoments::cubic`]).
struct LocalCubic {
    centre: f64,
    scale: f64,
    coefficients: [f64; DEGREE + 1],
}

impl LocalCubic {
    fn fit(t: &[f64], y: &[f64]) -> Option<LocalCubic> {
        SlidingMoments::new(t, y, 0, t.len().min(y.len())).cubic()
    }

    fn slope_at(&self, t: f64) -> f64 {
        let tau = (t - self.centre) / self.scale;
        let c = &self.coefficients;
        (c[1] + tau * (2.0 * c[2] + tau * 3.0 * c[3])) / self.scale
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sliding power sums against a fresh least-squares cubic of every window, on a jittered
    /// clock over a long record (rounding carried from one re-anchoring to the next would show).
    #[test]
    fn sliding_moments_match_a_fit_of_each_window() {
        let mut t = vec![0.0];
        for i in 1..5000 {
            let jitter = 0.3 * ((i as f64 * 12.9898).sin() * 43758.5453).fract();
            t.push(t[i - 1] + 0.01 * (1.0 + jitter));
        }
        let y: Vec<f64> = t
            .iter()
            .map(|&t| 3.0 + (0.7 * t).sin() + 0.05 * (9.0 * t).cos())
            .collect();
        let d = Differentiator { half_width: 60 };
        let got = d.derivative(&t, &y);
        let m = 121;
        let mut worst = 0.0_f64;
        for i in 61..t.len() - 61 {
            let lo = i - 60;
            let fit = LocalCubic::fit(&t[lo..lo + m], &y[lo..lo + m]).unwrap();
            let expected = fit.slope_at(t[i]);
            worst = worst.max((got[i] - expected).abs() / expected.abs().max(1e-3));
        }
        assert!(worst < 1e-9, "largest relative difference {worst:e}");
    }
}
