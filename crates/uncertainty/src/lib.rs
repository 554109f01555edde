//! How far to trust a prediction. I/O-free building blocks shared by the model families:
//!
//! - [`block`]: the block length of a moving-block bootstrap, chosen from the autocorrelation of the
//!   fit residuals (manoeuvre residuals are strongly autocorrelated, so resampling single rows would
//!   understate the spread of the coefficients);
//! - [`resample`]: the rows of one bootstrap replicate, blocks drawn within each recording (a block never
//!   spans two recordings) from a seeded generator that does not change between releases;
//! - [`band`]: percentile bands of a predicted quantity over the replicates, counting the replicates
//!   whose prediction is not finite (a diverged simulation is evidence, not noise to drop silently);
//! - [`spread`]: standard errors and correlations of the replicated coefficients;
//! - [`coverage`]: the measured share of truths inside their nominal bands, with its binomial interval.

pub mod band;
pub mod block;
pub mod coverage;
pub mod resample;
pub mod spread;

pub use band::{Band, order_statistic_band, percentile_band};
pub use block::{BlockLength, block_length};
pub use coverage::Coverage;
pub use resample::{SplitMix64, replicate_rows};
pub use spread::{Spread, spread};

use thiserror::Error;

/// Why an uncertainty computation cannot give an answer.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum UncertaintyError {
    #[error("band level must lie strictly between 0 and 1, got {0}")]
    Level(f64),
    #[error("{finite} finite replicate values of {total}: a band needs at least {needed}")]
    TooFewReplicates {
        finite: usize,
        total: usize,
        needed: usize,
    },
    #[error("replicates have different lengths ({0} and {1})")]
    Ragged(usize, usize),
    #[error("no rows to resample")]
    NoRows,
    /// A calibrated band of a run that leaves the training range further than the calibration can
    /// speak for: its half-width would be the reach times a factor measured at reaches of 1–2.
    #[error(
        "no band: the run reaches {reach:.1} × beyond the training range (calibrated bands stop at \
         a reach of {cap}; docs/uncertainty.md)"
    )]
    BeyondRange { reach: f64, cap: f64 },
    /// The point prediction does not define the quantity: a band beside no value bounds nothing the
    /// user is shown.
    #[error("no band: the point prediction does not define it")]
    PointUndefined,
}
