//! Measured coverage of nominal bands.

use serde::Serialize;

/// How many truths fell inside their bands.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Coverage {
    /// Nominal level of the bands, e.g. 0.9.
    pub nominal: f64,
    /// Truths inside their band.
    pub inside: usize,
    /// Truths with a band.
    pub total: usize,
}

impl Coverage {
    pub fn new(nominal: f64) -> Self {
        Coverage {
            nominal,
            inside: 0,
            total: 0,
        }
    }

    pub fn add(&mut self, inside: bool) {
        self.total += 1;
        self.inside += usize::from(inside);
    }

    /// Measured share inside (None without cases).
    pub fn measured(&self) -> Option<f64> {
        (self.total > 0).then(|| self.inside as f64 / self.total as f64)
    }

    /// 95 % Wilson score interval of the measured share: with 40 cases a measured 90 % is only known
    /// to about ±9 %, which decides whether a miss of the nominal level means anything.
    pub fn wilson_95(&self) -> Option<(f64, f64)> {
        let n = self.total as f64;
        let p = self.measured()?;
        let z = 1.959_963_984_540_054_f64;
        let denom = 1.0 + z * z / n;
        let centre = (p + z * z / (2.0 * n)) / denom;
        let half = z * ((p * (1.0 - p) / n) + z * z / (4.0 * n * n)).sqrt() / denom;
        Some(((centre - half).max(0.0), (centre + half).min(1.0)))
    }
}
