//! The identification range of a model file (where its regression extrapolates, see
//! [`shipid_model::envelope`]): built from the training windows the file records, when its data set can
//! still be read, and applied to recordings by `diagnose` and `validate`. A sparse GP carries its own
//! (its sparse points and their similarity, [`gp_outside_fraction`]).

use std::path::{Path, PathBuf};

use shipid_io::{Dataset, PrimeScale, Recording};
use shipid_model::design::primed_state;
use shipid_model::{CoefficientSet, IdentificationRange, ModelFile, TrainingWindow};

/// The model file's training data, when it names a data set that can still be read (paths as written by
/// `shipid fit`, tried as given and relative to the model file): the Abkowitz model file (`None` for
/// another kind, such as a sparse GP, whose training windows are read all the same), the data set
/// restricted to the training recordings, and the data set's path.
pub fn training_data(model_spec: &str) -> Option<(Option<ModelFile>, Dataset, PathBuf)> {
    // Only the windows: every kind of model file written by `fit` records them alike.
    #[derive(serde::Deserialize)]
    struct Windows {
        #[serde(default)]
        training: Vec<TrainingWindow>,
    }
    let path = Path::new(model_spec);
    let text = std::fs::read_to_string(path).ok()?;
    let windows = toml::from_str::<Windows>(&text).ok()?.training;
    let first = windows.first()?;
    // As given (relative to the working directory of `fit`), then relative to the model file's folder
    // and each folder above it (a model in results/ names data/… of the project root).
    let mut candidates = vec![PathBuf::from(&first.dataset)];
    let dir = std::path::absolute(path).ok()?;
    candidates.extend(dir.ancestors().skip(1).map(|a| a.join(&first.dataset)));
    let ds_path = candidates.into_iter().find(|p| p.is_file())?;
    let used: Vec<String> = windows.iter().map(|w| w.recording.clone()).collect();
    let ds = Dataset::load_filtered(&ds_path, |f| used.iter().any(|u| u == f)).ok()?;
    let file = toml::from_str::<ModelFile>(&text).ok();
    Some((file, ds, ds_path))
}

/// Where an Abkowitz model was identified: its set's leverage over the states of its training windows.
pub fn identification_range(
    (file, ds, _): &(Option<ModelFile>, Dataset, PathBuf),
) -> Option<IdentificationRange> {
    let file = file.as_ref()?;
    if file.kind != "abkowitz" {
        return None;
    }
    let set = CoefficientSet::from_file(file.set.clone()).ok()?;
    let scale = PrimeScale::of(&ds.ship);
    let mut states = Vec::new();
    for w in &file.training {
        let r = ds.recordings.iter().find(|r| r.file == w.recording)?;
        let rec = &r.recording;
        states.extend(
            (0..rec.len())
                .filter(|&i| rec.t[i] >= w.t_start_s && rec.t[i] <= w.t_end_s)
                .map(|i| primed_state(rec, &scale, i)),
        );
    }
    IdentificationRange::new(&set, &states).ok()
}

/// How many of the samples `idx` of `rec` lie outside `range`, and how many there are.
pub fn outside_count(
    range: &IdentificationRange,
    rec: &Recording,
    scale: &PrimeScale,
    idx: impl Iterator<Item = usize>,
) -> (usize, usize) {
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
    let outside = (0..rec.len())
        .filter(|&i| !gp.covers(rec.u[i], rec.v[i], rec.r[i], rec.delta[i]))
        .count();
    share((outside, rec.len()))
}
