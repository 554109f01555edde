//! Whether training windows excite the rudder: a window whose rudder barely moved carries no
//! information on it, whatever the conditioning of the design says. Shared by every model family's
//! fit. No I/O.

use shipid_model::TrainingWindow;

use crate::error::{PipelineError, failed};

/// The least spread [deg] of the recorded rudder over the training samples below which the data
/// cannot determine a rudder derivative. Exact constancy is caught by the design's rank, but a tank
/// recording holds its rudder at a small offset with sensor noise (0.0002 rad on the HSVA runs), and
/// column scaling made that noise look like a well-conditioned regressor: a reduced32 fit on the
/// first second of a run, before the rudder moved, said "status ok" and diverged in every replay.
/// Half a degree is below every manoeuvre's stroke (the smallest zig-zag moves it by 10°) and above
/// any sensor's noise or neutral drift.
pub const MIN_RUDDER_SPREAD_DEG: f64 = 0.5;

/// The spread [deg] of the finite values of `delta_rad` (0 for none).
pub fn rudder_spread_deg(delta_rad: &[f64]) -> f64 {
    let (lo, hi) = delta_rad
        .iter()
        .filter(|d| d.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &d| {
            (lo.min(d), hi.max(d))
        });
    if hi >= lo {
        (hi - lo).to_degrees()
    } else {
        0.0
    }
}

/// The rank-deficiency of training windows whose rudder `delta_rad` spans more than nothing but less
/// than [`MIN_RUDDER_SPREAD_DEG`] (exact constancy is left to the design's rank check, whose message
/// names the regressors); `what` is what the rudder's information was needed for.
pub fn rudder_unexcited(
    delta_rad: &[f64],
    windows: &[TrainingWindow],
    what: &str,
) -> Result<(), PipelineError> {
    let spread_deg = rudder_spread_deg(delta_rad);
    if spread_deg > 0.0 && spread_deg < MIN_RUDDER_SPREAD_DEG {
        return Err(rudder_unexcited_error(spread_deg, windows, what));
    }
    Ok(())
}

/// The error of training windows whose rudder spans only `spread_deg`.
pub fn rudder_unexcited_error(
    spread_deg: f64,
    windows: &[TrainingWindow],
    what: &str,
) -> PipelineError {
    failed(format!(
        "rank-deficient: the training window ({}) carries no information on the rudder: it spans {spread_deg:.2}° there, below the {MIN_RUDDER_SPREAD_DEG}° {what} (e.g. the window ends before the rudder first moves): widen the window or choose other recordings",
        windows
            .iter()
            .map(|w| format!("{} {}–{} s", w.recording, w.t_start_s, w.t_end_s))
            .collect::<Vec<_>>()
            .join("; ")
    ))
}
