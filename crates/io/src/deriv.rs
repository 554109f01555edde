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
//! is 1.78 s: 19 samples at 10 Hz, 37 at 20 Hz.

use faer::Mat;
use faer::prelude::*;

use crate::types::{Accelerations, Recording, Ship};

/// Window duration as a fraction of L/U0. Zig-zag periods are 5–8 L/U0; over 0.3 L/U0 a cubic follows
/// them with a bias below 0.1 % while averaging sensor noise over ~20 samples at 10 Hz. Rudder executes
/// (about 2 s at model scale) are smeared over the same window.
pub const WINDOW_FRACTION_OF_L_OVER_U0: f64 = 0.3;

/// Polynomial degree of the local fit.
pub const DEGREE: usize = 3;

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
    pub fn derivative(&self, t: &[f64], y: &[f64]) -> Vec<f64> {
        let n = t.len().min(y.len());
        let m = (2 * self.half_width + 1).min(n);
        if m < DEGREE + 1 {
            return vec![f64::NAN; n];
        }
        (0..n)
            .map(|i| {
                let lo = i.saturating_sub(self.half_width).min(n - m);
                local_slope(&t[lo..lo + m], &y[lo..lo + m], t[i])
            })
            .collect()
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

/// Slope at `t0` of the least-squares cubic through (t, y). Time is centred and scaled to [-1, 1] so the
/// normal equations stay well conditioned at any sampling rate.
fn local_slope(t: &[f64], y: &[f64], t0: f64) -> f64 {
    let scale = (t[t.len() - 1] - t[0]) / 2.0;
    if scale <= 0.0 {
        return f64::NAN;
    }
    let k = DEGREE + 1;
    let mut gram = Mat::<f64>::zeros(k, k);
    let mut rhs = Mat::<f64>::zeros(k, 1);
    for (&tj, &yj) in t.iter().zip(y) {
        let tau = (tj - t0) / scale;
        let mut pow = [1.0; DEGREE + 1];
        for p in 1..k {
            pow[p] = pow[p - 1] * tau;
        }
        for a in 0..k {
            rhs[(a, 0)] += pow[a] * yj;
            for b in 0..k {
                gram[(a, b)] += pow[a] * pow[b];
            }
        }
    }
    let c = gram.partial_piv_lu().solve(&rhs);
    c[(1, 0)] / scale
}
