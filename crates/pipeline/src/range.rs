//! The identification range of a model file (where its regression extrapolates, see
//! [`shipid_model::envelope`]): built from the training windows the file records, when its data set can
//! still be read unchanged, and applied to recordings by `diagnose` and `validate`. A sparse GP carries
//! its own (its sparse points and their similarity, [`gp_outside_fraction`]).

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use shipid_io::{Dataset, PrimeScale, Recording};
use shipid_model::design::primed_state;
use shipid_model::{
    AugmentedModelFile, CoefficientSet, IdentificationRange, ModelFile, RangeError, TrainingWindow,
};
use shipid_sim::metrics::relative_to_water;

use crate::model_file::{absolute_path, resolve_base, resolve_stored, training_hash};

/// A model's training data, read: the Abkowitz model file (`None` for another kind, such as a sparse
/// GP, whose training windows are read all the same), the data set restricted to the training
/// recordings, and the data set's absolute path.
pub type TrainingData = (Option<ModelFile>, Dataset, PathBuf);

/// What became of the training data a model names.
#[derive(Debug)]
pub enum TrainingSource {
    /// The model names none (the reference `mmg:…`, or a file without `[[training]]`).
    NotRecorded,
    /// Read, and unchanged since the fit; `unverified` when the file predates the fingerprints.
    Read {
        // Boxed: a data set is large beside the other variants.
        data: Box<TrainingData>,
        /// The model file whose windows these are (the base of an augmented file).
        model: PathBuf,
        unverified: bool,
    },
    /// Named, but not usable.
    Unavailable(Unavailable),
}

/// Why a model's training data cannot be used; each names the model file, the key and the data set.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Unavailable {
    /// The data set is not where the model file says (relative to the model file).
    #[error(
        "{model}: key `training[{index}].dataset`: `{stored}` is not a file (paths in a model file are relative to it: {resolved}); \
         older model files stored it relative to the working directory of `shipid fit`: write it relative to the model file"
    )]
    Missing {
        model: PathBuf,
        index: usize,
        stored: String,
        resolved: PathBuf,
    },
    /// The data set or a training recording has changed since the fit.
    #[error(
        "{model}: key `training[{index}].dataset_hash` = {stored}, but the data set {dataset} with recording `{recording}` now hashes to {found}: the training data changed since the fit"
    )]
    Changed {
        model: PathBuf,
        index: usize,
        dataset: PathBuf,
        recording: String,
        stored: String,
        found: String,
    },
    /// The data set is there but cannot be read (or the model file itself cannot).
    #[error("{model}: {reason}")]
    Unreadable { model: PathBuf, reason: String },
}

/// The training data a model names, following an augmented file to its base: resolved relative to the
/// file that names it, and checked against its fingerprints.
pub fn training_source(model_spec: &str) -> TrainingSource {
    if model_spec.starts_with("mmg:") {
        return TrainingSource::NotRecorded;
    }
    let mut path = PathBuf::from(model_spec);
    let mut chain = Vec::new();
    loop {
        let unreadable = |reason: String, model: &Path| {
            TrainingSource::Unavailable(Unavailable::Unreadable {
                model: model.to_path_buf(),
                reason,
            })
        };
        let text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) => return unreadable(e.to_string(), &path),
        };
        let table = match toml::from_str::<toml::Table>(&text) {
            Ok(t) => t,
            Err(e) => return unreadable(e.message().to_string(), &path),
        };
        if !table.contains_key("base") {
            return windows_source(&path, &text);
        }
        let base = toml::from_str::<AugmentedModelFile>(&text)
            .map_err(|e| e.message().to_string())
            .and_then(|f| resolve_base(&path, &f, &chain).map_err(|e| e.to_string()));
        match base {
            Ok(b) if b.starts_with("mmg:") => return TrainingSource::NotRecorded,
            Ok(b) => {
                chain.push(absolute_path(&path));
                path = PathBuf::from(b);
            }
            Err(reason) => return unreadable(reason, &path),
        }
    }
}

/// The training data of a model file with `[[training]]` windows (every kind written by `fit`).
fn windows_source(path: &Path, text: &str) -> TrainingSource {
    // Only the windows: every kind of model file written by `fit` records them alike.
    #[derive(serde::Deserialize)]
    struct Windows {
        #[serde(default)]
        training: Vec<TrainingWindow>,
    }
    let windows = match toml::from_str::<Windows>(text) {
        Ok(w) => w.training,
        Err(e) => {
            return TrainingSource::Unavailable(Unavailable::Unreadable {
                model: path.to_path_buf(),
                reason: e.message().to_string(),
            });
        }
    };
    let Some(first) = windows.first() else {
        return TrainingSource::NotRecorded;
    };
    let ds_path = resolve_stored(path, &first.dataset);
    let mut unverified = false;
    for (index, w) in windows.iter().enumerate() {
        let resolved = resolve_stored(path, &w.dataset);
        if !resolved.is_file() {
            return TrainingSource::Unavailable(Unavailable::Missing {
                model: path.to_path_buf(),
                index,
                stored: w.dataset.clone(),
                resolved,
            });
        }
        if absolute_path(&resolved) != absolute_path(&ds_path) {
            return TrainingSource::Unavailable(Unavailable::Unreadable {
                model: path.to_path_buf(),
                reason: format!(
                    "key `training[{index}].dataset`: the training windows name two data sets ({} and {})",
                    first.dataset, w.dataset
                ),
            });
        }
        let Some(stored) = &w.dataset_hash else {
            unverified = true;
            continue;
        };
        match training_hash(&resolved, &w.recording) {
            Ok(found) if &found == stored => {}
            Ok(found) => {
                return TrainingSource::Unavailable(Unavailable::Changed {
                    model: path.to_path_buf(),
                    index,
                    dataset: resolved,
                    recording: w.recording.clone(),
                    stored: stored.clone(),
                    found,
                });
            }
            Err(e) => {
                return TrainingSource::Unavailable(Unavailable::Unreadable {
                    model: path.to_path_buf(),
                    reason: format!("key `training[{index}].recording`: {e}"),
                });
            }
        }
    }
    let used: Vec<String> = windows.iter().map(|w| w.recording.clone()).collect();
    let ds = match Dataset::load_filtered(&ds_path, |f| used.iter().any(|u| u == f)) {
        Ok(ds) => ds,
        Err(e) => {
            return TrainingSource::Unavailable(Unavailable::Unreadable {
                model: path.to_path_buf(),
                reason: format!("key `training[0].dataset`: {e}"),
            });
        }
    };
    let file = toml::from_str::<ModelFile>(text).ok();
    // Named as the file system knows it: the same wherever the model was named from.
    TrainingSource::Read {
        data: Box::new((file, ds, absolute_path(&ds_path))),
        model: path.to_path_buf(),
        unverified,
    }
}

/// The model's training data when it can be used (see [`training_source`] for why it cannot).
pub fn training_data(model_spec: &str) -> Option<TrainingData> {
    match training_source(model_spec) {
        TrainingSource::Read { data, .. } => Some(*data),
        _ => None,
    }
}

/// Where an Abkowitz model was identified: its set's leverage over the states of its training windows.
pub fn identification_range((file, ds, _): &TrainingData) -> Option<IdentificationRange> {
    let file = file.as_ref()?;
    if file.kind != "abkowitz" {
        return None;
    }
    let set = CoefficientSet::from_file(file.set.clone()).ok()?;
    range_or_nowhere(&set, &window_states(ds, &file.training))
}

/// The range of `set` over `states`; a range outside which every state lies when the states span
/// none (a straight run: no rudder, drift or yaw), with the quantities that did not vary. `None`
/// only for a non-finite state, which no loaded recording has. `None` for states that span nothing
/// read as "no range known", and every caller then said nothing of a 35° turn predicted from a
/// straight run.
fn range_or_nowhere(set: &CoefficientSet, states: &[[f64; 4]]) -> Option<IdentificationRange> {
    match IdentificationRange::new(set, states) {
        Ok(range) => Some(range),
        Err(RangeError::NonFinite) => None,
        Err(e) => Some(IdentificationRange::nowhere(
            set,
            no_span_reason(states, &e),
        )),
    }
}

/// A quantity whose training values spread by no more than this (primed, or rad for δ) did not
/// vary: far below any manoeuvre's, and above the rounding of a recorded constant.
const CONSTANT_SPREAD: f64 = 1e-6;

/// Why `states` span no range, in words: the quantities that stay constant, else what the range's
/// construction found (`err`); a warning puts it after "the training states do not span the state
/// space".
pub fn no_span_reason(states: &[[f64; 4]], err: &RangeError) -> String {
    if states.is_empty() {
        return "the training windows hold no states".into();
    }
    let names = ["Δu′ (speed)", "v′ (drift)", "r′ (yaw rate)", "δ (rudder)"];
    let constant: Vec<String> = (0..4)
        .filter_map(|k| {
            let (lo, hi) = states
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), s| {
                    (lo.min(s[k]), hi.max(s[k]))
                });
            (hi - lo <= CONSTANT_SPREAD).then(|| {
                let value = if k == 3 {
                    format!("{:.1}°", lo.to_degrees())
                } else {
                    format!("{lo:.3}")
                };
                format!("{} = {value} throughout", names[k])
            })
        })
        .collect();
    let what = if constant.is_empty() {
        err.to_string()
    } else {
        constant.join(", ")
    };
    format!("{what}, over {} training states", states.len())
}

/// How many of the samples `idx` of `rec` lie outside `range`, and how many there are.
pub fn outside_count(
    range: &IdentificationRange,
    rec: &Recording,
    scale: &PrimeScale,
    idx: impl Iterator<Item = usize>,
) -> (usize, usize) {
    let rec = relative_to_water(rec);
    let rec = rec.as_ref();
    let (mut outside, mut total) = (0usize, 0usize);
    for i in idx {
        let [du, v, r, d] = primed_state(rec, scale, i);
        total += 1;
        if range.leverage_ratio(du, v, r, d) > 1.0 {
            outside += 1;
        }
    }
    (outside, total)
}

/// `outside / total` of an [`outside_count`] (0 without samples).
pub fn share((outside, total): (usize, usize)) -> f64 {
    outside as f64 / total.max(1) as f64
}

/// Fraction of the samples `idx` of `rec` whose state lies outside `range`.
pub fn outside_fraction(
    range: &IdentificationRange,
    rec: &Recording,
    scale: &PrimeScale,
    idx: impl Iterator<Item = usize>,
) -> f64 {
    share(outside_count(range, rec, scale, idx))
}

/// Fraction of the samples of `rec` outside the identification range a model carries (a sparse GP's:
/// no sparse point is d_gen-similar to the state).
pub fn gp_outside_fraction(gp: &dyn shipid_sim::OwnRange, rec: &Recording) -> f64 {
    let rec = relative_to_water(rec);
    let outside = (0..rec.len())
        .filter(|&i| !gp.covers(rec.u[i], rec.v[i], rec.r[i], rec.delta[i]))
        .count();
    share((outside, rec.len()))
}

/// How a model's identification range is formed, for the explanation of "outside".
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum RangeSource {
    /// A polynomial's leverage over the states of its training windows (their data could be read).
    Leverage,
    /// A family without a regression of its own (mmg): the leverage of [`STATE_RANGE_SET`]'s
    /// monomials over the states of its training windows, the ellipsoid those states fill.
    StateEllipsoid,
    /// A sparse GP's coverage by its sparse points.
    Coverage,
    /// Training states that span no range (a straight run: a quantity that never varied): every
    /// state lies outside ([`IdentificationRange::nowhere`]).
    Degenerate,
    /// Not known (the model's training data cannot be read, or the reference model).
    Unknown,
}

impl RangeSource {
    /// The range in a few words.
    pub fn short(self) -> &'static str {
        match self {
            RangeSource::Leverage => "its regression's leverage",
            RangeSource::StateEllipsoid => "the ellipsoid of its training states",
            RangeSource::Coverage => "its sparse points' coverage",
            RangeSource::Degenerate => "training states that span no range",
            RangeSource::Unknown => "unknown",
        }
    }

    /// What "outside" means under this range, in words.
    pub fn describe(self) -> &'static str {
        match self {
            RangeSource::Leverage => {
                "leverage of the model's own regression above every training state's: there its forces are extrapolated"
            }
            RangeSource::StateEllipsoid => {
                "outside the ellipsoid the training states fill (leverage of a cubic polynomial in Δu′, v′, r′, δ): the parameters were identified on other states"
            }
            RangeSource::Coverage => {
                "no sparse point d_gen-similar (paper 001's test that every training state passes): there the GP's mean reverts towards its constant"
            }
            RangeSource::Degenerate => {
                "every state: the training states do not span the state space (a quantity among Δu′, v′, r′, δ never varied), so the model was identified on no neighbourhood of any state"
            }
            RangeSource::Unknown => "not available",
        }
    }
}

/// The coefficient set whose leverage gives the range of a family without a regression of its own
/// (mmg, and the reach of a sparse GP's calibration): a third-order polynomial in Δu′, v′, r′, δ, the
/// states' own ellipsoid. The same for every such family, so that their reaches compare.
pub const STATE_RANGE_SET: &str = "reduced32";

/// The [`STATE_RANGE_SET`] range over primed states: for states that span no ellipsoid (too few,
/// or a quantity that never varies) one outside which every state lies
/// ([`IdentificationRange::degenerate`] says why); `None` only for a non-finite state.
pub fn state_range_of(states: &[[f64; 4]]) -> Option<IdentificationRange> {
    let set = CoefficientSet::builtin(STATE_RANGE_SET)?;
    range_or_nowhere(&set, states)
}

/// Each window of `windows` whose recording `ds` has, with the indices of its samples.
pub fn window_samples<'a>(
    ds: &'a Dataset,
    windows: &'a [TrainingWindow],
) -> impl Iterator<Item = (Cow<'a, Recording>, Vec<usize>)> + 'a {
    windows.iter().filter_map(|w| {
        // Through the water, as the fit saw them (a recorded current taken out).
        let rec = relative_to_water(&ds.recording(&w.recording)?.recording);
        let idx = (0..rec.len())
            .filter(|&i| rec.t[i] >= w.t_start_s && rec.t[i] <= w.t_end_s)
            .collect();
        Some((rec, idx))
    })
}

/// The primed states of `windows` in `ds` (a window whose recording `ds` lacks adds none).
pub fn window_states(ds: &Dataset, windows: &[TrainingWindow]) -> Vec<[f64; 4]> {
    let scale = PrimeScale::of(&ds.ship);
    window_samples(ds, windows)
        .flat_map(|(rec, idx)| {
            idx.into_iter()
                .map(|i| primed_state(&rec, &scale, i))
                .collect::<Vec<_>>()
        })
        .collect()
}

/// Below this speed (÷ U0) a sample's drift angle and non-dimensional yaw rate are the noise of a
/// velocity near zero (a run that starts from rest), and the mmg family's non-dimensionalisation
/// is meaningless: its fit skips such samples, and a training extent does not take its drift and
/// r′ from them.
pub const SLOW_SPEED_OVER_U0: f64 = 0.05;

/// Width (× L/U0) of the moving average a state extent takes its velocities through: the window of
/// the acceleration estimate (docs/data-format.md), over which measurement noise averages out and a
/// manoeuvre's peaks stay (a simulated ZZ35/35's peak r′ moves by 0.1 %).
pub const EXTENT_SMOOTHING_L_OVER_U0: f64 = 0.3;

/// Centred moving average of `y(t)` over `t ± half_s` (uneven sampling allowed; the ends average
/// what they have).
fn moving_average(t: &[f64], y: &[f64], half_s: f64) -> Vec<f64> {
    let n = t.len().min(y.len());
    let (mut lo, mut hi, mut sum) = (0usize, 0usize, 0.0);
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        while hi < n && t[hi] <= t[i] + half_s {
            sum += y[hi];
            hi += 1;
        }
        while t[lo] < t[i] - half_s {
            sum -= y[lo];
            lo += 1;
        }
        out.push(sum / (hi - lo) as f64);
    }
    out
}

/// A run past a training extreme by more than this fraction (drift, r′, lowest speed) is an
/// extrapolation whatever share of it lies outside the identification range.
pub const EXTREME_MARGIN: f64 = 0.05;

/// The extent of a set of states, as a user reads it first: the largest drift angle, non-dimensional
/// yaw rate (both from samples faster than [`SLOW_SPEED_OVER_U0`]) and rudder angle, and the lowest
/// and highest speed.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct StateExtent {
    /// Largest |β| = |atan2(−v, u)| [deg].
    pub max_drift_deg: f64,
    /// Largest |r′| = |r| L / U.
    pub max_yaw_rate_prime: f64,
    /// Largest |δ| [deg].
    pub max_rudder_deg: f64,
    /// Lowest U / U0.
    pub min_speed_over_u0: f64,
    /// Highest U / U0: a run at a higher propeller rate than the training's goes faster than any
    /// training state, which drift and r′ (ratios to the speed) do not show.
    pub max_speed_over_u0: f64,
}

impl StateExtent {
    /// The extent of the samples `idx` of `rec` (`None` without samples): a simulated run's, whose
    /// states are exact up to where it diverged.
    pub fn of(
        rec: &Recording,
        ship: &shipid_io::Ship,
        idx: impl Iterator<Item = usize>,
    ) -> Option<StateExtent> {
        Self::of_states(rec, ship, idx, false)
    }

    /// The extent of the samples `idx` of a *recording* (training data), its velocities averaged
    /// over [`EXTENT_SMOOTHING_L_OVER_U0`] first so that measurement noise does not widen it.
    pub fn of_recorded(
        rec: &Recording,
        ship: &shipid_io::Ship,
        idx: impl Iterator<Item = usize>,
    ) -> Option<StateExtent> {
        Self::of_states(rec, ship, idx, true)
    }

    fn of_states(
        rec: &Recording,
        ship: &shipid_io::Ship,
        idx: impl Iterator<Item = usize>,
        smooth: bool,
    ) -> Option<StateExtent> {
        let mut e = StateExtent {
            max_drift_deg: 0.0,
            max_yaw_rate_prime: 0.0,
            max_rudder_deg: 0.0,
            min_speed_over_u0: f64::INFINITY,
            max_speed_over_u0: 0.0,
        };
        let rec = relative_to_water(rec);
        // A recording's extremes are the motion's, not its measurement noise's: velocities averaged
        // over EXTENT_SMOOTHING_L_OVER_U0 (2 % of U0 of noise on v put 5° of drift into the extent
        // of a recorded zig-zag, and hid the extrapolation of a turn).
        let half_s = 0.5 * EXTENT_SMOOTHING_L_OVER_U0 * ship.lpp / ship.u0;
        let smoothed = |y: &[f64]| {
            if smooth {
                moving_average(&rec.t, y, half_s)
            } else {
                y.to_vec()
            }
        };
        let (u, v, r) = (smoothed(&rec.u), smoothed(&rec.v), smoothed(&rec.r));
        let mut any = false;
        for i in idx {
            let speed = u[i].hypot(v[i]);
            if !speed.is_finite() {
                continue;
            }
            any = true;
            if speed > SLOW_SPEED_OVER_U0 * ship.u0 {
                e.max_drift_deg = e.max_drift_deg.max((-v[i]).atan2(u[i]).to_degrees().abs());
                e.max_yaw_rate_prime = e.max_yaw_rate_prime.max((r[i] * ship.lpp / speed).abs());
            }
            e.max_rudder_deg = e.max_rudder_deg.max(rec.delta[i].to_degrees().abs());
            e.min_speed_over_u0 = e.min_speed_over_u0.min(speed / ship.u0);
            e.max_speed_over_u0 = e.max_speed_over_u0.max(speed / ship.u0);
        }
        any.then_some(e)
    }

    /// The extent of `windows` in `ds`.
    pub fn of_windows(ds: &Dataset, windows: &[TrainingWindow]) -> Option<StateExtent> {
        window_samples(ds, windows)
            .filter_map(|(rec, idx)| StateExtent::of_recorded(&rec, &ds.ship, idx.into_iter()))
            .reduce(|a, b| StateExtent {
                max_drift_deg: a.max_drift_deg.max(b.max_drift_deg),
                max_yaw_rate_prime: a.max_yaw_rate_prime.max(b.max_yaw_rate_prime),
                max_rudder_deg: a.max_rudder_deg.max(b.max_rudder_deg),
                min_speed_over_u0: a.min_speed_over_u0.min(b.min_speed_over_u0),
                max_speed_over_u0: a.max_speed_over_u0.max(b.max_speed_over_u0),
            })
    }
}

/// Where a model was identified: the range its kind calls for and the extent of its training states.
pub struct Envelope {
    pub source: RangeSource,
    /// The leverage range (polynomial, mmg); `None` for a sparse GP, which carries its own.
    range: Option<IdentificationRange>,
    /// The training states' extent (`None` when the training data cannot be read).
    pub training: Option<StateExtent>,
    /// The ship of the training data set and its path, when it was read: a model file's own
    /// `[ship]` is compared with it without reading the data set again.
    pub training_dataset: Option<(shipid_io::Ship, PathBuf)>,
}

/// The training windows a model file records (following nothing: `path` is the file that holds them).
fn recorded_windows(path: &Path) -> Option<Vec<TrainingWindow>> {
    #[derive(serde::Deserialize)]
    struct Windows {
        #[serde(default)]
        training: Vec<TrainingWindow>,
    }
    let text = std::fs::read_to_string(path).ok()?;
    toml::from_str::<Windows>(&text).ok().map(|w| w.training)
}

/// The training data a model names with its training windows, whatever its kind (`None` when it
/// names none, or they cannot be read unchanged: [`training_source`]).
pub fn training_windows(model_spec: &str) -> Option<(Box<TrainingData>, Vec<TrainingWindow>)> {
    match training_source(model_spec) {
        TrainingSource::Read {
            data, model: path, ..
        } => recorded_windows(&path).map(|windows| (data, windows)),
        _ => None,
    }
}

/// The envelope of the model loaded from `model_spec`: `None` when it has no range (the reference
/// model; a polynomial or mmg file whose training data cannot be read or changed since the fit). A
/// sparse GP carries its range; the extent of its training states needs its data all the same.
pub fn model_envelope(model_spec: &str, model: &dyn shipid_sim::Dynamics) -> Option<Envelope> {
    let read = training_windows(model_spec);
    let training = read
        .as_ref()
        .and_then(|(data, windows)| StateExtent::of_windows(&data.1, windows));
    let training_dataset = read.as_ref().map(|(data, _)| (data.1.ship, data.2.clone()));
    if model.own_range().is_some() {
        return Some(Envelope {
            source: RangeSource::Coverage,
            range: None,
            training,
            training_dataset,
        });
    }
    let (data, windows) = read?;
    let (source, range) = match data.0 {
        Some(_) => (RangeSource::Leverage, identification_range(&data)?),
        None => (
            RangeSource::StateEllipsoid,
            state_range_of(&window_states(&data.1, &windows))?,
        ),
    };
    let source = if range.degenerate().is_some() {
        RangeSource::Degenerate
    } else {
        source
    };
    Some(Envelope {
        source,
        range: Some(range),
        training,
        training_dataset,
    })
}

/// How far a run of a model goes beyond where the model was identified.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RunReach {
    pub source: RangeSource,
    /// Share of the run's samples outside the identification range.
    pub outside: f64,
    /// The run's extent.
    pub run: StateExtent,
    /// The training states' extent (`None` when the training data cannot be read).
    pub training: Option<StateExtent>,
    /// Why the training states span no range ([`RangeSource::Degenerate`]: every state is outside).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub degenerate: Option<String>,
}

/// Relative excess over a training extreme below which [`RunReach::beyond`] does not name the
/// quantity: within the rounding of its printed value and the smoothing of the training extent.
pub const NAMED_MARGIN: f64 = 0.01;
/// Absolute excess (degrees, r′, U/U0) below which a quantity whose training extreme is 0 is not
/// named: the noise of a straight run.
const NAMED_FLOOR: f64 = 1e-3;

/// Rudder angle [deg] past the largest of the training runs beyond which a run uses a rudder the
/// model never saw: a recorder's resolution and a helmsman's overshoot of the commanded angle stay
/// below it.
pub const RUDDER_MARGIN_DEG: f64 = 0.5;

/// Share of a simulated run outside the model's identification range above which `simulate` warns
/// that the run is an extrapolation (a run inside it still grazes the edge of the training states).
pub const EXTRAPOLATION_WARNING_SHARE: f64 = 0.05;

impl RunReach {
    /// The warning for a run that lies outside the range in more than
    /// [`EXTRAPOLATION_WARNING_SHARE`] of its samples (`None` otherwise); `diverged`: the run ended
    /// in a divergence, and has no metrics to qualify.
    pub fn warning(&self, model_spec: &str, diverged: bool) -> Option<String> {
        // The leverage of a cubic in four states can reach far in some directions: a run may go past
        // every training extreme with few of its states outside the ellipsoid (a 35° turn to one side
        // 1 % outside, the other side 88 %). Past the extremes is an extrapolation either way.
        if self.outside <= EXTRAPOLATION_WARNING_SHARE && !self.clearly_beyond() {
            return None;
        }
        let beyond = self.beyond();
        let ending = if diverged {
            "it diverged out there"
        } else {
            "its metrics are an extrapolation"
        };
        if let Some(why) = &self.degenerate {
            return Some(format!(
                "{model_spec}: the training states do not span the state space ({why}): the model was identified on no neighbourhood of any state, and every state of this run is an extrapolation{}: {ending}",
                if beyond.is_empty() {
                    String::new()
                } else {
                    format!(" ({})", beyond.join(", "))
                }
            ));
        }
        if self.outside <= EXTRAPOLATION_WARNING_SHARE {
            return Some(format!(
                "{model_spec}: this run goes past the extremes of the states the model was identified on ({}), though only {:.0} % of it lies outside {}, which reaches far along the training states: {ending}",
                beyond.join(", "),
                100.0 * self.outside,
                self.source.short(),
            ));
        }
        Some(format!(
            "{model_spec}: {:.0} % of this run lies outside where the model was identified ({}; {}): {}",
            100.0 * self.outside,
            self.source.short(),
            match (beyond.is_empty(), self.training.is_some()) {
                (false, _) => beyond.join(", "),
                (true, true) => "each quantity within its training extent, in combinations the training did not visit".into(),
                (true, false) => "the training data cannot be read for their extent".into(),
            },
            ending
        ))
    }

    /// Whether the run goes past a training extreme by more than [`EXTREME_MARGIN`] (drift, r′, or
    /// speed below the lowest or above the highest), or its rudder past the largest trained by more
    /// than [`RUDDER_MARGIN_DEG`]: what a simulation a little beyond the recorded peaks does not. A
    /// rudder angle no training run used is an input the model never saw (a 37° turn of a model
    /// trained to 35° went unwarned: its states stayed within 2 % of the training extremes).
    pub fn clearly_beyond(&self) -> bool {
        let (run, Some(tr)) = (&self.run, &self.training) else {
            return false;
        };
        run.max_rudder_deg > tr.max_rudder_deg + RUDDER_MARGIN_DEG
            || run.max_drift_deg > (1.0 + EXTREME_MARGIN) * tr.max_drift_deg
            || run.max_yaw_rate_prime > (1.0 + EXTREME_MARGIN) * tr.max_yaw_rate_prime
            || run.min_speed_over_u0 < (1.0 - EXTREME_MARGIN) * tr.min_speed_over_u0
            || run.max_speed_over_u0 > (1.0 + EXTREME_MARGIN) * tr.max_speed_over_u0
    }

    /// The quantities of the run beyond the training states' extent by more than [`NAMED_MARGIN`],
    /// in words (empty when none is).
    pub fn beyond(&self) -> Vec<String> {
        let run = &self.run;
        let mut out = Vec::new();
        let Some(tr) = &self.training else {
            return out;
        };
        // A run at 2.5 U0 was said to reach "drift up to 19.2° (training ≤ 19.2°)": past by a
        // rounding, and not what put it outside. Only a real excess is named.
        let above = |run: f64, training: f64| run > training * (1.0 + NAMED_MARGIN) + NAMED_FLOOR;
        let below = |run: f64, training: f64| run < training * (1.0 - NAMED_MARGIN) - NAMED_FLOOR;
        if above(run.max_speed_over_u0, tr.max_speed_over_u0) {
            out.push(format!(
                "speed up to {:.2} U0 (training ≤ {:.2} U0)",
                run.max_speed_over_u0, tr.max_speed_over_u0
            ));
        }
        if above(run.max_drift_deg, tr.max_drift_deg) {
            out.push(format!(
                "drift up to {:.1}° (training ≤ {:.1}°)",
                run.max_drift_deg, tr.max_drift_deg
            ));
        }
        if above(run.max_yaw_rate_prime, tr.max_yaw_rate_prime) {
            out.push(format!(
                "r′ up to {:.2} (training ≤ {:.2})",
                run.max_yaw_rate_prime, tr.max_yaw_rate_prime
            ));
        }
        if run.max_rudder_deg > tr.max_rudder_deg + RUDDER_MARGIN_DEG {
            out.push(format!(
                "rudder up to {:.1}° (training ≤ {:.1}°)",
                run.max_rudder_deg, tr.max_rudder_deg
            ));
        }
        if below(run.min_speed_over_u0, tr.min_speed_over_u0) {
            out.push(format!(
                "speed down to {:.2} U0 (training ≥ {:.2} U0)",
                run.min_speed_over_u0, tr.min_speed_over_u0
            ));
        }
        out
    }
}

impl Envelope {
    /// Why the training states span no range ([`RangeSource::Degenerate`]), in words.
    pub fn degenerate(&self) -> Option<&str> {
        self.range.as_ref().and_then(|r| r.degenerate())
    }

    /// The leverage range (a polynomial's own, or the ellipsoid of an mmg model's training states);
    /// `None` for a sparse GP, whose coverage the model carries.
    pub fn leverage(&self) -> Option<&IdentificationRange> {
        self.range.as_ref()
    }

    /// Share of the samples of `rec` outside the identification range (`None` when the model, which
    /// should carry it, does not).
    pub fn outside_share(&self, model: &dyn shipid_sim::Dynamics, rec: &Recording) -> Option<f64> {
        match (&self.range, model.own_range()) {
            (Some(range), _) => Some(outside_fraction(
                range,
                rec,
                &PrimeScale::of(model.ship()),
                0..rec.len(),
            )),
            (None, Some(gp)) => Some(gp_outside_fraction(gp, rec)),
            (None, None) => None,
        }
    }

    /// The reach of `run` (a simulation of `model`) beyond this envelope.
    pub fn reach(&self, model: &dyn shipid_sim::Dynamics, run: &Recording) -> Option<RunReach> {
        Some(RunReach {
            source: self.source,
            outside: self.outside_share(model, run)?,
            run: StateExtent::of(run, model.ship(), 0..run.len())?,
            training: self.training,
            degenerate: self.degenerate().map(str::to_string),
        })
    }
}
