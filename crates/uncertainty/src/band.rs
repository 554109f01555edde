//! Percentile bands over bootstrap replicates, and order-statistic bands over small ensembles.

use serde::Serialize;

use crate::UncertaintyError;

/// Fewer finite replicate values than this give no band: the tails of a 90 % band rest on the 5 %
/// outermost values, which need a few values each to mean anything.
pub const MIN_FINITE_REPLICATES: usize = 20;

/// A central percentile band of a predicted quantity.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Band {
    /// Lower bound (the (1 − level)/2 quantile), in the quantity's unit.
    pub lo: f64,
    /// Upper bound (the (1 + level)/2 quantile).
    pub hi: f64,
    /// Nominal level, e.g. 0.9.
    pub level: f64,
    /// Replicates whose value was finite (used for the band).
    pub finite: usize,
    /// Replicates whose prediction was not finite or undefined (a diverged simulation, a metric the
    /// run did not reach).
    pub undefined: usize,
}

impl Band {
    pub fn contains(&self, value: f64) -> bool {
        value >= self.lo && value <= self.hi
    }

    /// Share of replicates with an undefined value: a band over the defined ones only says how far to
    /// trust the prediction *given* that it is defined.
    pub fn undefined_share(&self) -> f64 {
        self.undefined as f64 / (self.finite + self.undefined).max(1) as f64
    }
}

/// Quantile `q` of sorted values (linear interpolation between order statistics, Hyndman & Fan type 7).
/// Values may end in +∞ (a diverged prediction counted as an infinite error): the quantile is then
/// +∞ once it reaches them, never the NaN that ∞ − ∞ would give.
pub fn quantile(sorted: &[f64], q: f64) -> f64 {
    let h = (sorted.len() - 1) as f64 * q;
    let lo = h.floor() as usize;
    let hi = h.ceil() as usize;
    let w = h - lo as f64;
    if sorted[lo].is_infinite() || (w > 0.0 && sorted[hi].is_infinite()) {
        return if w > 0.0 { sorted[hi] } else { sorted[lo] };
    }
    sorted[lo] + w * (sorted[hi] - sorted[lo])
}

/// The finite values of `values`, sorted, and how many were undefined (None or not finite); refused
/// for a `level` outside (0, 1) or fewer than [`MIN_FINITE_REPLICATES`] finite values.
fn finite_sorted(
    values: impl IntoIterator<Item = Option<f64>>,
    level: f64,
) -> Result<(Vec<f64>, usize), UncertaintyError> {
    if !(level > 0.0 && level < 1.0) {
        return Err(UncertaintyError::Level(level));
    }
    let mut finite = Vec::new();
    let mut undefined = 0;
    for v in values {
        match v {
            Some(x) if x.is_finite() => finite.push(x),
            _ => undefined += 1,
        }
    }
    if finite.len() < MIN_FINITE_REPLICATES {
        return Err(UncertaintyError::TooFewReplicates {
            finite: finite.len(),
            total: finite.len() + undefined,
            needed: MIN_FINITE_REPLICATES,
        });
    }
    finite.sort_by(f64::total_cmp);
    Ok((finite, undefined))
}

/// The central `level` band of `values` (None entries and non-finite values count as undefined).
pub fn percentile_band(
    values: impl IntoIterator<Item = Option<f64>>,
    level: f64,
) -> Result<Band, UncertaintyError> {
    let (finite, undefined) = finite_sorted(values, level)?;
    let tail = (1.0 - level) / 2.0;
    Ok(Band {
        lo: quantile(&finite, tail),
        hi: quantile(&finite, 1.0 - tail),
        level,
        finite: finite.len(),
        undefined,
    })
}

/// The `level` band of `values` as a prediction interval for one more value drawn like them: the k-th
/// smallest and k-th largest values, k = max(1, ⌊(n + 1)(1 − level)/2⌋), which hold a new draw with
/// probability (n + 1 − 2k)/(n + 1) ≥ `level` whenever n is large enough for k ≥ 1 to satisfy it.
/// For an ensemble of equally plausible answers (a few tens of members) this is its range, and so it
/// holds every member, the delivered one included; the interpolated percentiles of
/// [`percentile_band`] would cut the outermost members of so few. Same refusals as
/// [`percentile_band`].
pub fn order_statistic_band(
    values: impl IntoIterator<Item = Option<f64>>,
    level: f64,
) -> Result<Band, UncertaintyError> {
    let (finite, undefined) = finite_sorted(values, level)?;
    let n = finite.len();
    // 1e-9: (1 − 0.9)/2 · 40 is 1.999… in floating point, and 40 values do give k = 2.
    let k =
        ((((n + 1) as f64) * (1.0 - level) / 2.0 + 1e-9).floor() as usize).clamp(1, n.div_ceil(2));
    Ok(Band {
        lo: finite[k - 1],
        hi: finite[n - k],
        level,
        finite: n,
        undefined,
    })
}
