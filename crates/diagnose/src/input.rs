//! What the diagnosis is given besides the data: the model, what is known about it, and the tunables.

use shipid_model::IdentificationRange;
use shipid_sim::{Dynamics, Effect};

/// Tunables of the diagnosis, with their reasons.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiagnoseOptions {
    /// Length of a replay segment ÷ (L/U0). 10 L/U0 is about one zig-zag period of KVLCC2: long enough
    /// for a current to drift the track by a visible amount, short enough that a model's own heading
    /// drift stays small.
    pub horizon_l_over_u0: f64,
    /// Smallest held-out relative reduction of the position RMSE for an effect to be accepted.
    pub min_gain: f64,
    /// Relative held-out error a candidate pays per parameter when candidates are ranked.
    pub parsimony: f64,
    /// A mismatch is real (and `unexplained` if nothing explains it) when the held-out position RMSE
    /// exceeds this multiple of the model's own level (on its training data, when known) plus the noise.
    pub real_mismatch_factor: f64,
    /// Largest number of equation-error samples per recording used in a fit.
    pub max_samples_per_recording: usize,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            horizon_l_over_u0: 10.0,
            min_gain: 0.3,
            parsimony: 0.03,
            real_mismatch_factor: 2.0,
            max_samples_per_recording: 400,
        }
    }
}

impl DiagnoseOptions {
    /// These options with the replay horizon fitted to the recordings of `ds`: when every recording
    /// is shorter than the horizon, a segment would be a whole recording while the noise floor and the
    /// model's own level were those of full-length segments (a 6-s recording judged against the drift
    /// of 59-s segments hides a strong current), so the horizon is shortened to the longest recording
    /// and a note says so. A single recording is judged on its two time halves, so the horizon is
    /// also shortened to the longer half ([`halves_horizon`]). `Err` when even the longest recording
    /// is below [`MIN_HORIZON_L_OVER_U0`].
    pub fn fitted_to(
        self,
        ds: &shipid_io::Dataset,
    ) -> Result<(DiagnoseOptions, Option<String>), crate::DiagnoseError> {
        let l_over_u0_s = ds.ship.lpp / ds.ship.u0;
        let longest_s = ds
            .recordings
            .iter()
            .filter(|r| r.recording.len() >= shipid_io::table::MIN_SAMPLES)
            .map(|r| r.recording.t.last().unwrap_or(&0.0) - r.recording.t.first().unwrap_or(&0.0))
            .fold(0.0, f64::max);
        let longest = longest_s / l_over_u0_s;
        if !(longest.is_finite() && longest > 0.0) || self.horizon_l_over_u0 <= longest {
            return Ok(self.fitted_to_halves(ds, None));
        }
        if longest < MIN_HORIZON_L_OVER_U0 {
            return Err(crate::DiagnoseError::TooShort {
                longest_s,
                needed_s: MIN_HORIZON_L_OVER_U0 * l_over_u0_s,
            });
        }
        let note = format!(
            "{}: every recording is shorter than the replay horizon {:.1} L/U0 ({:.0} s; the longest lasts {longest_s:.1} s): the horizon is shortened to {longest:.2} L/U0 ({longest_s:.1} s), so that the noise floor and the model's own level are those of segments as long as the recordings",
            ds.path.display(),
            self.horizon_l_over_u0,
            self.horizon_l_over_u0 * l_over_u0_s,
        );
        Ok(DiagnoseOptions {
            horizon_l_over_u0: longest,
            ..self
        }
        .fitted_to_halves(ds, Some(note)))
    }

    /// These options with the horizon shortened to a single recording's longer time half when it
    /// outlasts that half, and the note that says so (else `note`, the earlier one).
    fn fitted_to_halves(
        self,
        ds: &shipid_io::Dataset,
        note: Option<String>,
    ) -> (DiagnoseOptions, Option<String>) {
        match halves_horizon(ds, self.horizon_l_over_u0) {
            Some((half, why)) => (
                DiagnoseOptions {
                    horizon_l_over_u0: half,
                    ..self
                },
                Some(why),
            ),
            None => (self, note),
        }
    }
}

/// Shortest recording [samples] cut into time halves: each half keeps the samples a replay segment
/// and the differentiator need twice over.
pub(crate) const MIN_SAMPLES_FOR_HALVES: usize = 4 * shipid_io::table::MIN_SAMPLES;

/// A single recording is judged on its two time halves, so no segment outlasts the longer half: a
/// horizon beyond it would be reported as segments that never ran. The horizon shortened to that
/// half (÷ L/U0) and the note that says so, or `None` when the horizon fits.
fn halves_horizon(ds: &shipid_io::Dataset, horizon_l_over_u0: f64) -> Option<(f64, String)> {
    let [one] = ds.recordings.as_slice() else {
        return None;
    };
    let (t, n) = (&one.recording.t, one.recording.len());
    if n < MIN_SAMPLES_FOR_HALVES {
        return None;
    }
    let l_over_u0_s = ds.ship.lpp / ds.ship.u0;
    let half_s = (t[n / 2 - 1] - t[0]).max(t[n - 1] - t[n / 2]);
    let half = half_s / l_over_u0_s;
    (half.is_finite() && horizon_l_over_u0 > half).then(|| {
        (
            half,
            format!(
                "{}: the one recording is judged on its two time halves, each shorter than the replay horizon {horizon_l_over_u0:.1} L/U0 ({:.0} s): the horizon is shortened to {half:.2} L/U0 ({half_s:.1} s), the longest segment a half holds",
                one.file,
                horizon_l_over_u0 * l_over_u0_s,
            ),
        )
    })
}

/// Shortest replay horizon ÷ (L/U0) a diagnosis works with (the command's smallest `--horizon`).
pub const MIN_HORIZON_L_OVER_U0: f64 = 0.5;

/// Everything the diagnosis needs besides the data.
pub struct DiagnoseInput<'a> {
    /// The model without its own effects.
    pub base: &'a (dyn Dynamics + Send + Sync),
    /// The model's own effects (kept; a candidate of the same kind replaces it).
    pub base_effects: &'a [Effect],
    /// The model's level on its training recordings (position RMSE ÷ L of segment replays), if known.
    pub model_level_over_l: Option<f64>,
    /// Where the base model was identified (an Abkowitz model with readable training data, or a
    /// sparse GP), if known.
    pub identification_range: Option<BaseRange<'a>>,
}

/// Where a base model was identified, tested one recorded state at a time.
#[derive(Clone, Copy)]
pub enum BaseRange<'a> {
    /// A polynomial's leverage envelope: outside where the leverage exceeds every training state's.
    Leverage(&'a IdentificationRange),
    /// A sparse GP's coverage: outside where no sparse point is d_gen-similar
    /// (the range the model carries, [`shipid_sim::OwnRange`]).
    Coverage(&'a dyn shipid_sim::OwnRange),
}

impl<'a> BaseRange<'a> {
    /// The leverage range where there is one, else the GP's coverage.
    pub fn of(
        leverage: Option<&'a IdentificationRange>,
        gp: Option<&'a dyn shipid_sim::OwnRange>,
    ) -> Option<BaseRange<'a>> {
        leverage
            .map(BaseRange::Leverage)
            .or(gp.map(BaseRange::Coverage))
    }

    /// What "outside" means, for the report's explanation.
    pub fn criterion(self) -> &'static str {
        match self {
            BaseRange::Leverage(_) => "leverage above its training maximum",
            BaseRange::Coverage(own) => own.criterion(),
        }
    }
}
