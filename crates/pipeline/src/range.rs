//! The identification range of a model file (where its regression extrapolates, see
//! [`shipid_model::envelope`]): built from the training windows the file records, when its data set can
//! still be read unchanged, and applied to recordings by `diagnose` and `validate`. A sparse GP carries
//! its own (its sparse points and their similarity, [`gp_outside_fraction`]).

use std::path::{Path, PathBuf};

use shipid_io::{Dataset, PrimeScale, Recording};
use shipid_model::design::primed_state;
use shipid_model::{
    AugmentedModelFile, CoefficientSet, IdentificationRange, ModelFile, TrainingWindow,
};

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
