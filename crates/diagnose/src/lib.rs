//! Discrepancy diagnosis (`shipid diagnose`): compare a model with recordings it did not see, locate the
//! mismatch, name the physical effect that was left out, fit it and show the fit improve.
//!
//! No I/O here: [`diagnose`] takes a model and a loaded data set and returns a [`Report`] in the layout
//! of docs/data-format.md ("Diagnosis report (JSON)").
//!
//! How it decides (the numbers are [`DiagnoseOptions`]):
//! 1. **Compare.** Every recording is replayed in the model in *segments* of `horizon` (10 L/U0 by
//!    default) restarted from the recorded state (a 1.1 s centred mean, to keep the velocity noise out of
//!    the start), with the recorded rudder. Long open-loop replays of a zig-zag drift by whole ship
//!    lengths even for a good identified model (a small yaw-rate bias integrates into heading), which
//!    would hide every effect; segments keep the model's own error small and an effect's signature
//!    (a drift, a lag, a bias) intact. The equation-error residual — recorded (or differentiated)
//!    accelerations minus the model's at the recorded state and rudder — says *where* and in *which DOF*.
//!    A recording's recorded wind and current are part of the base: replays and residuals feel them
//!    at the recording's time ([`shipid_sim::WithEnvironment`], the wind through the data set's
//!    `[windage]`, else an assumed one), so what the diagnosis may find is a wind or current the
//!    recordings do not carry; a found one is reported against the recorded one, and `--reveal`
//!    ([`conceal`], [`reveal`]) conceals the recorded channels to check the verdict against them.
//! 2. **Name.** Every effect of the library ([`Family`]) is fitted to half of the recordings in the
//!    equation-error sense (cheap, no integration; Levenberg–Marquardt on a handful of physical
//!    parameters, base model fixed) and judged by the segment-replay position error on the other half;
//!    then the halves swap, so each recording is held out once. A single recording is judged on the
//!    two halves of its time instead; so is a wind of its own on each recording
//!    ([`Family::WindPerRecording`], tried when a real mismatch needs explaining), which must beat one
//!    wind for all (and the winner, if another) judged on the same halves clearly.
//! 3. **Verdict.** A candidate is accepted when the held-out position RMSE of a typical recording (the
//!    geometric mean of after/before over recordings) is at least `min_gain` lower than the model's,
//!    at least 10 % lower in both halves, and the median recording improves by more than twice the
//!    noise floor of the recordings.
//!    Among accepted candidates, one with fewer parameters wins unless another is clearly better
//!    (`parsimony` per parameter). If the winner leaves more than half of the mismatch, pairs with it are
//!    tried. Nothing accepted: `none` when the mismatch is within what the model shows on its own
//!    training data (or within the noise), otherwise `unexplained`.
//! 4. **Model it.** The winner is refitted on all recordings; standard errors from the Gauss–Newton
//!    covariance with the residual autocorrelation accounted for by thinning the samples to one per
//!    smoothing window.
//!
//! The phases are modules, each using only those before it: `input` (what is given), `error`,
//! `verdict` (the vocabulary), `environment` (the recorded wind and current in the report, the
//! `--reveal` check), `compare`, `locate`, `families`, `judge`, `report` (which runs them), and on top
//! [`bench`](mod@bench), the concealed-effect benchmark, and [`known_wind`], the benchmark with a
//! recorded wind as known input; their public items are re-exported here.

mod augment;
pub mod bench;
mod compare;
mod environment;
mod error;
mod families;
mod input;
mod judge;
pub mod known_wind;
mod locate;
mod report;
mod verdict;

pub use augment::{AugmentedModel, augmented_model};
pub use compare::{
    POSITION_ERROR_CAP_OVER_L, Prepared, REPLAY_RESOLUTION_OVER_L, ReplayScore, ResidualSeries,
    SegmentTrack, environments, model_level, normalised_residuals, prepare, segment_tracks,
};
pub use environment::{
    AgainstRecorded, Concealed, FlowSummary, RecordedEnvironment, RecordedFlow, RecordingWind,
    RevealCheck, RevealedFlow, RevealedRecordingWind, WindageUse, angle_difference_deg, conceal,
    reveal,
};
pub use error::DiagnoseError;
pub use families::{Family, depth_for_factor};
pub use input::{BaseRange, DiagnoseInput, DiagnoseOptions, MIN_HORIZON_L_OVER_U0};
pub use locate::{Located, Regime};
pub use report::{Candidate, Fit, RecordingFit, Report, StandardErrorBasis, diagnose};
pub use verdict::Verdict;
