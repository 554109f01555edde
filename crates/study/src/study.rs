//! Study files: a grid of identification cases in TOML, in three layers —
//! [`RawStudy`] (the file as written, unknown keys rejected) → [`CheckedStudy`] (checked against its
//! data set: recordings exist, overshoot counts exist, estimators and sets are known, no grid axis is
//! empty or repeats a value; each axis resolved) → [`Study`] with its [`Case`]s (the axes crossed, one
//! case per grid point, each with an id made from its values). [`load_study`] runs all three.
//!
//! ```toml
//! name = "truncation"
//! description = "Paper 000 Tab. 7/8"
//! dataset = "../data/kvlcc2-mmg/dataset.toml"   # relative to the study file
//! sets = ["reduced32"]
//! [training]
//! recordings = [["zz35_35_ps.csv"], ["zz35_35_ps.csv", "tc35_ps.csv"]]  # combinations
//! overshoots = { from = 1, to = 8 }             # or a list [1, 4], one count 4, or omit: whole records
//! [[estimator]]
//! name = "ridge"
//! lambda = [1e-6, 1e-4]                         # one case per value; or tune = true
//! refine = true                                 # then refine in the output-error sense (default false)
//! [[estimator]]
//! name = "sparse-gp"                            # paper 001's sparse GP: no set, no solver; one case
//! similarity = [0.9, 0.96]                      # per threshold d_gen (default 0.96)
//! [test]
//! recordings = "all"                            # or a list of files
//! [check]                                       # tolerances of `shipid check`, per summary column
//! mrae = { abs = 1e-6 }
//! ```
//!
//! Two top-level keys give every polynomial case's test metrics a band (docs/uncertainty.md):
//! `bootstrap = 200` block-bootstrap replicates of each case's fit, and `bands = 0.9` the nominal
//! level of the percentile band over their re-simulations. They go together; the sparse GP and the
//! mmg family have no replicates in a study yet, so a study that crosses them with bands is refused.
//! `calibrate = true` widens every band by the case's calibration from its training recordings
//! (`shipid_pipeline::calibration`; docs/uncertainty.md).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use shipid_io::{Dataset, InputError, Manoeuvre};
use shipid_model::CoefficientSet;
use shipid_sim::metrics::{missing_execute_reason, zigzag_events};

use shipid_pipeline::fit::{EstimatorSpec, WindowSpec};

pub use shipid_pipeline::fit::GP;
/// `Case::set` and `Case::solver` of a sparse-GP case, which has neither.
pub const NO_SET: &str = "none";
const NO_SOLVER: &str = "none";

pub use crate::raw_values::{OneOrMany, OvershootSpec, TestRecordings, TimeWindow};

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawTraining {
    /// Combinations of recordings (each a list of file names).
    pub recordings: Vec<Vec<String>>,
    #[serde(default)]
    pub overshoots: Option<OvershootSpec>,
    /// Time windows [start, end] in seconds, instead of overshoots.
    #[serde(default)]
    pub windows: Option<Vec<TimeWindow>>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawEstimator {
    pub name: String,
    #[serde(default)]
    pub lambda: Option<OneOrMany>,
    #[serde(default)]
    pub alpha: Option<OneOrMany>,
    #[serde(default)]
    pub c: Option<OneOrMany>,
    #[serde(default)]
    pub epsilon: Option<f64>,
    #[serde(default)]
    pub tune: bool,
    /// Refine the estimator's coefficients in the output-error sense (`shipid fit --refine`).
    #[serde(default)]
    pub refine: bool,
    /// "fast" (default) or "qp".
    #[serde(default)]
    pub solver: Option<String>,
    /// Similarity thresholds d_gen of `sparse-gp` (one case per value; default
    /// [`shipid_pipeline::fit_gp::DEFAULT_SIMILARITY`]).
    #[serde(default)]
    pub similarity: Option<OneOrMany>,
    /// The mmg family holds the propeller's wake at what the recorded thrust measures (`shipid fit
    /// --inflow-from-thrust`); a study whose sets are all `mmg` only.
    #[serde(default)]
    pub inflow_from_thrust: bool,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawTest {
    pub recordings: TestRecordings,
}

/// Tolerance of one summary column in `shipid check`: |fresh − reference| ≤ abs + rel·|reference|.
/// Written as a table only (`{ abs = 1e-6, rel = 1e-4 }`): serde's derive also took a list read by
/// position (`[1e-6, 1e-4, 99]`, extras dropped, `[]` the default), a form no document names.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Tolerance {
    pub abs: f64,
    pub rel: f64,
}

impl<'de> Deserialize<'de> for Tolerance {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::{self, MapAccess, Visitor};
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Tolerance;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a tolerance table such as { abs = 1e-6, rel = 1e-4 } (either may be left out: 0)")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Tolerance, A::Error> {
                let (mut abs, mut rel) = (None, None);
                while let Some(key) = map.next_key::<String>()? {
                    let slot = match key.as_str() {
                        "abs" => &mut abs,
                        "rel" => &mut rel,
                        _ => {
                            // Not serde's "unknown field `…`" form, which would be read as the
                            // key's name (`check.x`), not the tolerance it is in.
                            return Err(de::Error::custom(format!(
                                "{key:?} is not a key of a tolerance: it has `abs` and `rel` only"
                            )));
                        }
                    };
                    *slot = Some(map.next_value::<TolerancePart>()?.0);
                }
                Ok(Tolerance {
                    abs: abs.unwrap_or(0.0),
                    rel: rel.unwrap_or(0.0),
                })
            }
        }
        d.deserialize_any(V)
    }
}

/// One bound of a [`Tolerance`]: a number, integer or float.
struct TolerancePart(f64);

impl<'de> Deserialize<'de> for TolerancePart {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::{self, Visitor};
        struct V;
        impl Visitor<'_> for V {
            type Value = TolerancePart;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a number (e.g. 1e-6)")
            }
            fn visit_f64<E: de::Error>(self, x: f64) -> Result<TolerancePart, E> {
                Ok(TolerancePart(x))
            }
            fn visit_i64<E: de::Error>(self, x: i64) -> Result<TolerancePart, E> {
                Ok(TolerancePart(x as f64))
            }
            fn visit_u64<E: de::Error>(self, x: u64) -> Result<TolerancePart, E> {
                Ok(TolerancePart(x as f64))
            }
        }
        d.deserialize_any(V)
    }
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawStudy {
    pub name: String,
    #[serde(default)]
    pub description: String,
    pub dataset: String,
    /// Coefficient sets of the polynomial estimators (may be left out when every estimator is the GP).
    #[serde(default)]
    pub sets: Vec<String>,
    pub training: RawTraining,
    #[serde(rename = "estimator")]
    pub estimators: Vec<RawEstimator>,
    pub test: RawTest,
    #[serde(default)]
    pub check: BTreeMap<String, Tolerance>,
    /// Nominal level of every test metric's band (needs `bootstrap`).
    #[serde(default)]
    pub bands: Option<f64>,
    /// Block-bootstrap replicates per case for the bands (needs `bands`).
    #[serde(default)]
    pub bootstrap: Option<i64>,
    /// Widen each band by the calibration of `shipid_pipeline::calibration` (needs `bands`).
    #[serde(default)]
    pub calibrate: bool,
}

/// What the bands of a study are made of: `replicates` block-bootstrap refits of each case, and the
/// nominal `level` of the percentile band over their re-simulations.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StudyBands {
    pub level: f64,
    pub replicates: usize,
    /// Seed of the replicate draws (`shipid fit --bootstrap-seed`'s default), so a rerun of the
    /// study gives the same bands.
    pub seed: u64,
    /// Widened by the case's own calibration: inflation per metric family from its training
    /// recordings' errors (in sample and left out in turn) and the reach outside its range.
    pub calibrate: bool,
}

/// One grid point.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Case {
    /// Readable and unique: values, then a hash of the whole resolved configuration.
    pub id: String,
    pub set: String,
    pub estimator: EstimatorSpec,
    pub solver: String,
    pub training: Vec<String>,
    pub window: WindowSpec,
}

/// A checked study.
pub struct Study {
    pub path: PathBuf,
    pub name: String,
    pub description: String,
    pub dataset_path: PathBuf,
    pub dataset: Dataset,
    /// A hash of the data set file and its recordings' bytes: a finished case is reused only for
    /// the same data, wherever the study is run from.
    pub data_fnv1a: String,
    /// How the case count comes about, for messages (`2 sets × 5 estimator settings × …`).
    pub grid: String,
    pub cases: Vec<Case>,
    pub tests: Vec<String>,
    pub check: BTreeMap<String, Tolerance>,
    /// Bands of the test metrics, when the study asks for them.
    pub bands: Option<StudyBands>,
    /// What the checks let through but a user should hear before the run (a time window that
    /// extends past a training recording, which its cases fit on less than the window says).
    pub warnings: Vec<String>,
}

/// Read, check and expand a study file.
pub fn load_study(path: &Path) -> Result<Study, InputError> {
    let raw = RawStudy::read(path)?;
    CheckedStudy::from_raw(path, raw)?.into_study()
}

/// Runs of more cases than this are refused unless the user insists (`shipid run --allow-large`):
/// at a tenth of a second to a second per case, 5 000 cases already take minutes to hours, and a
/// grid that large is more often a typo (a value list pasted twice as a range) than a plan.
pub const LARGE_RUN_CASES: usize = 5_000;

/// Studies with bands whose cases × replicates × tests exceed this are refused likewise: each
/// replicate is a refit and a re-simulation of every test, and at a few milliseconds each a million
/// take about as long as the largest grid [`LARGE_RUN_CASES`] lets through (the shipped
/// `studies/bands.toml` needs about ten thousand).
pub const LARGE_RUN_REPLICATE_SIMULATIONS: usize = 1_000_000;

/// What a study costs, counted from the lengths of its axes (before any case is built).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StudySize {
    pub cases: usize,
    /// Bootstrap replicate simulations of a study with bands: cases × replicates × tests (each
    /// replicate is also a refit); 0 without bands.
    pub replicate_simulations: usize,
    /// Its factors besides the cases, for the message: replicates per case (0 without bands) and
    /// test recordings.
    pub replicates: usize,
    pub tests: usize,
}

impl StudySize {
    /// Why a run of this size needs the user's consent (`shipid run --allow-large`), naming how
    /// the grid (`grid`, [`CheckedStudy::grid`]) makes it; `None` within [`LARGE_RUN_CASES`]
    /// cases and [`LARGE_RUN_REPLICATE_SIMULATIONS`] replicate simulations.
    pub fn too_large(&self, grid: &str) -> Option<String> {
        if self.cases > LARGE_RUN_CASES {
            Some(format!(
                "{} cases ({grid}), more than {LARGE_RUN_CASES}",
                self.cases
            ))
        } else if self.replicate_simulations > LARGE_RUN_REPLICATE_SIMULATIONS {
            Some(format!(
                "{} bootstrap replicate simulations ({} cases ({grid}) × {} replicates × {} \
                 tests), more than {LARGE_RUN_REPLICATE_SIMULATIONS}",
                self.replicate_simulations, self.cases, self.replicates, self.tests
            ))
        } else {
            None
        }
    }
}

/// [`load_study`] for a run: a study larger than [`StudySize::too_large`] allows is refused
/// (unless `allow_large`) after its checks and before its cases are built, so a short file that
/// expands to millions of cases is refused in moments instead of filling the memory first.
pub fn load_study_within(path: &Path, allow_large: bool) -> Result<Study, crate::StudyError> {
    let raw = RawStudy::read(path)?;
    let checked = CheckedStudy::from_raw(path, raw)?;
    if let Some(why) = checked
        .size()
        .too_large(&checked.grid())
        .filter(|_| !allow_large)
    {
        return Err(crate::StudyError::TooLarge {
            path: path.to_path_buf(),
            why,
        });
    }
    Ok(checked.into_study()?)
}

impl RawStudy {
    /// The file as written; a misspelt key is an error rather than a silently ignored one.
    pub fn read(path: &Path) -> Result<RawStudy, InputError> {
        let text = std::fs::read_to_string(path).map_err(|e| InputError::read(path, &e))?;
        toml::from_str(&text).map_err(|e| InputError::toml(path, &text, &e))
    }
}

/// A study whose keys all hold against its data set: each axis of the grid is resolved (estimator
/// entries expanded into one spec per hyper-parameter value) but the axes are not yet crossed.
pub struct CheckedStudy {
    pub path: PathBuf,
    pub name: String,
    pub description: String,
    pub dataset_path: PathBuf,
    pub dataset: Dataset,
    pub data_fnv1a: String,
    /// May be empty when every estimator is the GP.
    pub sets: Vec<String>,
    /// Combinations of recordings.
    pub training: Vec<Vec<String>>,
    pub windows: Vec<WindowSpec>,
    pub estimators: Vec<CheckedEstimator>,
    pub tests: Vec<String>,
    pub check: BTreeMap<String, Tolerance>,
    pub bands: Option<StudyBands>,
    /// See [`Study::warnings`].
    pub warnings: Vec<String>,
}

/// One point of the estimator axis.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckedEstimator {
    pub spec: EstimatorSpec,
    pub solver: String,
}

impl CheckedStudy {
    /// The checks run in a fixed order (name, data set, sets, training, estimators, tests), so a
    /// file with several faults always reports the same first one.
    pub fn from_raw(path: &Path, raw: RawStudy) -> Result<CheckedStudy, InputError> {
        check_name(path, &raw.name)?;
        let (dataset_path, dataset) = load_dataset(path, &raw.dataset)?;
        let polynomial = raw.estimators.iter().any(|e| e.name != GP);
        check_sets(path, &raw.sets, polynomial)?;
        let known = DatasetRecordings {
            dataset: &dataset,
            dataset_path: &dataset_path,
        };
        check_training(path, &raw.training.recordings, known)?;
        let windows = training_windows(path, &raw.training, &dataset)?;
        let warnings = window_extents(path, &windows, &raw.training.recordings, &dataset)?;
        let estimators = check_estimators(path, &raw.estimators)?;
        check_mmg_estimators(path, &raw.sets, &estimators)?;
        let tests = test_recordings(path, &raw.test.recordings, known)?;
        let bands = check_bands(path, &raw)?;
        check_tolerances(path, &raw.check)?;
        let data_fnv1a = data_fingerprint(path, &dataset_path, &dataset)?;
        Ok(CheckedStudy {
            path: path.to_path_buf(),
            name: raw.name,
            description: raw.description,
            dataset_path,
            dataset,
            data_fnv1a,
            sets: raw.sets,
            training: raw.training.recordings,
            windows,
            estimators,
            tests,
            check: raw.check,
            bands,
            warnings,
        })
    }

    /// The size of the run, from the axes' lengths (saturating: a product past `usize` is simply
    /// too large).
    pub fn size(&self) -> StudySize {
        let gp = self.estimators.iter().filter(|e| e.spec.name == GP).count();
        let polynomial = self.estimators.len() - gp;
        let per_setting = self.training.len().saturating_mul(self.windows.len());
        let polynomial_cases = self
            .sets
            .len()
            .saturating_mul(polynomial)
            .saturating_mul(per_setting);
        let cases = polynomial_cases.saturating_add(gp.saturating_mul(per_setting));
        // Only polynomial cases get replicates (bands refuse the others).
        let replicate_simulations = self.bands.map_or(0, |b| {
            polynomial_cases
                .saturating_mul(b.replicates)
                .saturating_mul(self.tests.len())
        });
        StudySize {
            cases,
            replicate_simulations,
            replicates: self.bands.map_or(0, |b| b.replicates),
            tests: self.tests.len(),
        }
    }

    /// Sets × polynomial estimators × training × windows, then the GP's cases, which have no set. The
    /// GP comes last so that adding it left the order (and so the tables) of every existing study as
    /// it was.
    pub fn cases(&self) -> Vec<Case> {
        let (gp, polynomial): (Vec<_>, Vec<_>) =
            self.estimators.iter().partition(|e| e.spec.name == GP);
        let mut cases = Vec::new();
        for set in &self.sets {
            for e in &polynomial {
                self.push_cases(&mut cases, set, e);
            }
        }
        for e in &gp {
            self.push_cases(&mut cases, NO_SET, e);
        }
        cases
    }

    fn push_cases(&self, cases: &mut Vec<Case>, set: &str, e: &CheckedEstimator) {
        for combo in &self.training {
            for w in &self.windows {
                cases.push(case(set, &e.spec, &e.solver, combo, *w));
            }
        }
    }

    /// How the case count comes about: the polynomial axes crossed, plus the GP's settings.
    pub fn grid(&self) -> String {
        let gp = self.estimators.iter().filter(|e| e.spec.name == GP).count();
        let polynomial = self.estimators.len() - gp;
        let per_training = format!(
            "{} training combination(s) × {} window(s)",
            self.training.len(),
            self.windows.len()
        );
        let mut parts = Vec::new();
        if polynomial > 0 {
            parts.push(format!(
                "{} set(s) × {polynomial} estimator setting(s) × {per_training}",
                self.sets.len()
            ));
        }
        if gp > 0 {
            parts.push(format!("{gp} sparse-GP setting(s) × {per_training}"));
        }
        parts.join(" + ")
    }

    /// The study with its cases; two cases with one id (two configurations whose readable parts
    /// read alike and whose 32-bit hashes collide) are refused, as they would share a folder.
    pub fn into_study(self) -> Result<Study, InputError> {
        let cases = self.cases();
        check_unique_ids(&self.path, &cases)?;
        let grid = self.grid();
        Ok(Study {
            path: self.path,
            name: self.name,
            description: self.description,
            dataset_path: self.dataset_path,
            dataset: self.dataset,
            data_fnv1a: self.data_fnv1a,
            grid,
            cases,
            tests: self.tests,
            check: self.check,
            bands: self.bands,
            warnings: self.warnings,
        })
    }
}

/// Refuses two cases with one id, naming both and the axis they differ on.
fn check_unique_ids(path: &Path, cases: &[Case]) -> Result<(), InputError> {
    let mut seen: std::collections::HashMap<&str, &Case> = std::collections::HashMap::new();
    for c in cases {
        let Some(earlier) = seen.insert(&c.id, c) else {
            continue;
        };
        let key = if earlier.set != c.set {
            "sets"
        } else if earlier.training != c.training {
            "training.recordings"
        } else if earlier.window != c.window {
            "training.windows"
        } else {
            "estimator"
        };
        return Err(InputError::key(
            path,
            key,
            format!(
                "two cases would share the id (and folder) `{}`: {} and {}; rename one of them",
                c.id,
                describe(earlier),
                describe(c)
            ),
        ));
    }
    Ok(())
}

/// A case as its configuration reads, for messages.
fn describe(c: &Case) -> String {
    let e = &c.estimator;
    let mut est = e.name.clone();
    for (name, v) in [
        ("λ", e.lambda),
        ("α", e.alpha),
        ("C", e.c),
        ("ε", e.epsilon),
        ("d_gen", e.similarity),
    ] {
        if let Some(v) = v {
            est.push_str(&format!(" {name}={v:e}"));
        }
    }
    if e.tune {
        est.push_str(" tuned");
    }
    if e.refine {
        est.push_str(" refined");
    }
    format!(
        "(set `{}`, {est}, solver {}, training [{}], window {})",
        c.set,
        c.solver,
        c.training.join(", "),
        c.window.label()
    )
}

/// `bands` and `bootstrap` go together: a level without replicates has nothing to take percentiles
/// of, and replicates without a level would cost their refits for no column. Only the polynomial
/// cases have replicates in a study: a GP or mmg case among them would leave its rows without bands
/// while the table promises them, so such a study is refused.
fn check_bands(path: &Path, raw: &RawStudy) -> Result<Option<StudyBands>, InputError> {
    let (sets, estimators) = (&raw.sets, &raw.estimators);
    let max = shipid_pipeline::bootstrap::MAX_REPLICATES;
    let (level, replicates) = match (raw.bands, raw.bootstrap) {
        (None, None) if raw.calibrate => {
            return Err(InputError::key(
                path,
                "calibrate",
                "widens bands, and there are none: give bands = 0.9 and bootstrap = 200 too",
            ));
        }
        (None, None) => return Ok(None),
        (Some(_), None) => {
            return Err(InputError::key(
                path,
                "bootstrap",
                "missing: bands need replicates to take percentiles of (e.g. bootstrap = 200)",
            ));
        }
        (None, Some(_)) => {
            return Err(InputError::key(
                path,
                "bands",
                "missing: bootstrap replicates are only used for bands (e.g. bands = 0.9)",
            ));
        }
        (Some(l), Some(n)) => (l, n),
    };
    if !(level > 0.0 && level < 1.0) {
        return Err(InputError::key(
            path,
            "bands",
            format!("{level} is not a level strictly between 0 and 1 (e.g. 0.9 for a 90 % band)"),
        ));
    }
    let replicates = usize::try_from(replicates)
        .ok()
        .filter(|n| (2..=max).contains(n))
        .ok_or_else(|| {
            InputError::key(
                path,
                "bootstrap",
                format!("{replicates} replicates: give between 2 and {max}"),
            )
        })?;
    if let Some(i) = estimators.iter().position(|e| e.name == GP) {
        return Err(InputError::key(
            path,
            "bands",
            format!(
                "estimator[{i}] is {GP}, whose cases have no bootstrap replicates in a study: put \
                 them in a study without bands"
            ),
        ));
    }
    if let Some(i) = sets
        .iter()
        .position(|s| s == shipid_pipeline::mmg::SET_NAME)
    {
        return Err(InputError::key(
            path,
            "bands",
            format!(
                "sets[{i}] is `mmg`, whose cases have no bootstrap replicates in a study: put them \
                 in a study without bands"
            ),
        ));
    }
    Ok(Some(StudyBands {
        level,
        replicates,
        seed: 1,
        calibrate: raw.calibrate,
    }))
}

/// Most a `[check]` tolerance's `rel` may be: at 1 a value passes anywhere between zero and twice
/// the reference, so a larger one no longer checks anything.
pub const MAX_RELATIVE_TOLERANCE: f64 = 1.0;

/// Most a `[check]` tolerance's `abs` may be. Its unit is the column's, so no one bound fits all;
/// the tables' largest magnitudes are times and distances of a few thousand (seconds, metres), and
/// an `abs` of a million already passes any of their values: above it, a tolerance is a typo
/// (`1e300`), not a tolerance.
pub const MAX_ABSOLUTE_TOLERANCE: f64 = 1e6;

/// `[check]`'s tolerances are finite and not negative: an infinite (or 1e309) `abs` or `rel` lets
/// every value pass, a negative one fails equal values, and NaN fails every comparison.
/// `fit_time_s` is the fit's wall time, which `shipid check` never compares: a tolerance for it
/// would read as if it were. Whether a key names a column of the tables is known only with them
/// (`tables::check_tolerance_columns`).
fn check_tolerances(path: &Path, check: &BTreeMap<String, Tolerance>) -> Result<(), InputError> {
    for (column, t) in check {
        if column == "fit_time_s" {
            return Err(InputError::key(
                path,
                format!("check.{column}"),
                "the fit's wall time varies between runs and is never compared: remove this tolerance",
            ));
        }
        for (name, v) in [("abs", t.abs), ("rel", t.rel)] {
            let most = if name == "rel" {
                MAX_RELATIVE_TOLERANCE
            } else {
                MAX_ABSOLUTE_TOLERANCE
            };
            let why = if v.is_nan() {
                Some("is not a number (it would fail every comparison)".to_string())
            } else if v.is_infinite() {
                Some("must be finite (an infinite tolerance passes every value)".to_string())
            } else if v < 0.0 {
                Some("must not be negative (it would fail equal values)".to_string())
            } else if v > most {
                Some(format!(
                    "must be at most {} (a larger one passes any value of the tables)",
                    shipid_io::error::number(most)
                ))
            } else {
                None
            };
            if let Some(why) = why {
                return Err(InputError::key(
                    path,
                    format!("check.{column}.{name}"),
                    format!("{} {why}", shipid_io::error::number(v)),
                ));
            }
        }
    }
    Ok(())
}

/// Most characters of a study's name: it names the default results folder, and a file name holds
/// at most 255 bytes (with room left for the check's scratch folder, which adds some 40).
pub const MAX_NAME_CHARS: usize = 100;

/// The name becomes the default results directory (`results/NAME`): one plain word.
fn check_name(path: &Path, name: &str) -> Result<(), InputError> {
    if name.chars().count() > MAX_NAME_CHARS {
        return Err(InputError::key(
            path,
            "name",
            format!(
                "{} characters: a study's name names its results folder, give at most {MAX_NAME_CHARS}",
                name.chars().count()
            ),
        ));
    }
    if !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
    {
        return Ok(());
    }
    Err(InputError::key(
        path,
        "name",
        format!("\"{name}\" must be a non-empty word of letters, digits, - and _"),
    ))
}

/// Relative to the study file, so a study and its data move together.
fn load_dataset(path: &Path, dataset: &str) -> Result<(PathBuf, Dataset), InputError> {
    let dataset_path = beside(path, dataset);
    if !dataset_path.is_file() {
        return Err(InputError::key(
            path,
            "dataset",
            format!("data set `{}` not found", dataset_path.display()),
        ));
    }
    let dataset = Dataset::load(&dataset_path)?;
    Ok((dataset_path, dataset))
}

/// FNV-1a of the data set file and of every recording file it names, in order.
fn data_fingerprint(
    path: &Path,
    dataset_path: &Path,
    dataset: &Dataset,
) -> Result<String, InputError> {
    let dir = dataset_path.parent().unwrap_or(Path::new("."));
    let mut text = String::new();
    let files = std::iter::once(dataset_path.to_path_buf())
        .chain(dataset.recordings.iter().map(|r| dir.join(&r.file)));
    for f in files {
        let bytes = std::fs::read(&f)
            .map_err(|e| InputError::key(path, "dataset", format!("{}: {e}", f.display())))?;
        let h = shipid_pipeline::generate::fnv1a(&String::from_utf8_lossy(&bytes));
        text.push_str(&format!("{h:016x}"));
    }
    Ok(format!("{:016x}", shipid_pipeline::generate::fnv1a(&text)))
}

fn beside(path: &Path, file: &str) -> PathBuf {
    path.parent().unwrap_or(Path::new(".")).join(file)
}

/// A GP-only study needs no set; any polynomial estimator does.
fn check_sets(path: &Path, sets: &[String], polynomial: bool) -> Result<(), InputError> {
    if sets.is_empty() && polynomial {
        return Err(InputError::key(
            path,
            "sets",
            "the grid is empty: no coefficient set",
        ));
    }
    // A repeated grid value would give two cases one id (one directory, one row twice).
    if let Some((i, j)) = first_repeat(sets) {
        return Err(InputError::key(
            path,
            format!("sets[{i}]"),
            format!("`{}` repeats sets[{j}]", sets[i]),
        ));
    }
    // Each file once, however it is spelt (`myset.toml`, `./myset.toml`, `sub/../myset.toml`, a
    // link): the same set twice is one fit run twice under two ids.
    let mut files: BTreeMap<PathBuf, usize> = BTreeMap::new();
    for (i, s) in sets.iter().enumerate() {
        if CoefficientSet::builtin(s).is_some() || s == shipid_pipeline::mmg::SET_NAME {
            continue;
        }
        let file = beside(path, s);
        if let Ok(real) = std::fs::canonicalize(&file)
            && let Some(j) = files.insert(real, i)
        {
            return Err(InputError::key(
                path,
                format!("sets[{i}]"),
                format!("`{s}` is the same file as sets[{j}] (`{}`)", sets[j]),
            ));
        }
        if !file.is_file() {
            return Err(InputError::key(
                path,
                format!("sets[{i}]"),
                format!(
                    "unknown coefficient set `{s}` (not one of {} and no such file)",
                    CoefficientSet::builtin_names().join(", ")
                ),
            ));
        }
        // Read now: a broken set file is the study's input error, not a failed fit in every case.
        if let Err(e) = shipid_pipeline::fit::load_set(&file.display().to_string()) {
            return Err(InputError::key(path, format!("sets[{i}]"), e.to_string()));
        }
    }
    Ok(())
}

/// The grid crosses every set with every estimator: with `mmg` among the sets, an estimator the
/// mmg family has not (it takes bounded-lsq or ridge, whose λ is its prior weight) would fail in every
/// one of its cases, so it is refused here, naming the estimator.
fn check_mmg_estimators(
    path: &Path,
    sets: &[String],
    estimators: &[CheckedEstimator],
) -> Result<(), InputError> {
    let mmg = shipid_pipeline::mmg::SET_NAME;
    if let Some(i) = estimators.iter().position(|e| e.spec.inflow_from_thrust)
        && let Some(other) = sets.iter().find(|s| *s != mmg)
    {
        return Err(InputError::key(
            path,
            format!("estimator[{i}].inflow_from_thrust"),
            format!(
                "applies to the mmg set only (the grid crosses it with `{other}`, which has no propeller model; put the mmg cases in a study of their own)"
            ),
        ));
    }
    if !sets.iter().any(|s| s == mmg) {
        return Ok(());
    }
    for (i, e) in estimators.iter().enumerate() {
        if e.spec.name == GP {
            continue;
        }
        if let Err(err) = shipid_pipeline::mmg::MmgEstimator::parse(&e.spec.name) {
            return Err(InputError::key(
                path,
                format!("estimator[{i}].name"),
                format!(
                    "{err} (the grid crosses it with sets = [\"mmg\"]; put the mmg cases in a study of their own)"
                ),
            ));
        }
    }
    Ok(())
}

/// The data set a study's recordings are looked up in, and its path for the messages.
#[derive(Clone, Copy)]
struct DatasetRecordings<'a> {
    dataset: &'a Dataset,
    dataset_path: &'a Path,
}

impl DatasetRecordings<'_> {
    fn check(&self, path: &Path, key: String, file: &str) -> Result<(), InputError> {
        if self.dataset.recording(file).is_some() {
            return Ok(());
        }
        Err(InputError::key(
            path,
            key,
            format!(
                "recording `{file}` is not in {}",
                self.dataset_path.display()
            ),
        ))
    }
}

fn check_training(
    path: &Path,
    combos: &[Vec<String>],
    known: DatasetRecordings,
) -> Result<(), InputError> {
    if combos.is_empty() {
        return Err(InputError::key(
            path,
            "training.recordings",
            "the grid is empty: no training combination",
        ));
    }
    // A combination is a set of recordings: the same ones in another order are the same training
    // data under another id.
    let sorted: Vec<Vec<&String>> = combos
        .iter()
        .map(|c| {
            let mut c: Vec<&String> = c.iter().collect();
            c.sort();
            c
        })
        .collect();
    if let Some((i, j)) = first_repeat(&sorted) {
        let order = if combos[i] == combos[j] {
            ""
        } else {
            " in another order (the order of a combination does not matter)"
        };
        return Err(InputError::key(
            path,
            format!("training.recordings[{i}]"),
            format!("repeats training.recordings[{j}]{order}"),
        ));
    }
    for (i, combo) in combos.iter().enumerate() {
        if combo.is_empty() {
            return Err(InputError::key(
                path,
                format!("training.recordings[{i}]"),
                "empty combination",
            ));
        }
        // The same recording twice would weigh its samples double without a word.
        if let Some((j, k)) = first_repeat(combo) {
            return Err(InputError::key(
                path,
                format!("training.recordings[{i}][{j}]"),
                format!("`{}` repeats training.recordings[{i}][{k}]", combo[j]),
            ));
        }
        for (j, f) in combo.iter().enumerate() {
            // The tables write a combination as its names joined by `+`: `["a+b.csv"]` and
            // `["a", "b.csv"]` would read alike.
            if f.contains('+') {
                return Err(InputError::key(
                    path,
                    format!("training.recordings[{i}][{j}]"),
                    format!(
                        "`{f}` holds a `+`, which the tables put between the recordings of a combination \
                         (a recording named `a+b.csv` would read as `a` and `b.csv` trained together): \
                         rename the file"
                    ),
                ));
            }
            known.check(path, format!("training.recordings[{i}][{j}]"), f)?;
        }
    }
    Ok(())
}

/// The window axis: overshoot counts, time windows or (neither given) whole recordings.
fn training_windows(
    path: &Path,
    training: &RawTraining,
    dataset: &Dataset,
) -> Result<Vec<WindowSpec>, InputError> {
    let windows = match (&training.overshoots, &training.windows) {
        (Some(_), Some(_)) => {
            return Err(InputError::key(
                path,
                "training.windows",
                "give overshoots or windows, not both",
            ));
        }
        (Some(o), None) => overshoot_windows(path, o, dataset, &training.recordings)?,
        (None, Some(w)) => time_windows(path, w)?,
        (None, None) => vec![WindowSpec::Whole],
    };
    if let Some((i, j)) = first_repeat(&windows) {
        let grid = if training.windows.is_some() {
            "training.windows"
        } else {
            "training.overshoots"
        };
        return Err(InputError::key(
            path,
            grid,
            format!(
                "value {} repeats value {} (counting from 1): {} twice",
                i + 1,
                j + 1,
                windows[i].label()
            ),
        ));
    }
    Ok(windows)
}

fn overshoot_windows(
    path: &Path,
    spec: &OvershootSpec,
    dataset: &Dataset,
    combos: &[Vec<String>],
) -> Result<Vec<WindowSpec>, InputError> {
    let (least, most) = match spec {
        OvershootSpec::List(l) => (
            l.iter().copied().min().unwrap_or(0),
            l.iter().copied().max().unwrap_or(0),
        ),
        OvershootSpec::Range { from, to } if from > to => {
            return Err(InputError::key(
                path,
                "training.overshoots",
                format!("from = {from} is past to = {to}: the grid is empty"),
            ));
        }
        OvershootSpec::Range { from, to } => (*from, *to),
    };
    if least == 0 {
        return Err(InputError::key(
            path,
            "training.overshoots",
            "needs overshoot counts of 1 or more",
        ));
    }
    // Checked before the range is expanded: `to = 4000000000` must be refused, not allocated.
    check_overshoots(path, dataset, combos, most)?;
    let list: Vec<u32> = match spec {
        OvershootSpec::List(l) => l.clone(),
        OvershootSpec::Range { from, to } => (*from..=*to).collect(),
    };
    Ok(list.into_iter().map(WindowSpec::Overshoots).collect())
}

fn time_windows(path: &Path, windows: &[TimeWindow]) -> Result<Vec<WindowSpec>, InputError> {
    // As `shipid fit --window`: the largest time a recording's `t` may hold. A window beyond it
    // is no recording's, and its times would print as hundreds of digits in ids and tables.
    let max_time_s = shipid_io::units::Quantity::T.bound_si();
    if windows.is_empty() {
        return Err(InputError::key(
            path,
            "training.windows",
            "the grid is empty: no window",
        ));
    }
    windows
        .iter()
        .enumerate()
        .map(|(k, TimeWindow([a, b]))| {
            // Recordings start at 0 s: a negative start would be labelled with a time no sample has.
            let why = if !(a.is_finite() && b.is_finite()) {
                Some("give finite seconds".to_string())
            } else if *a < 0.0 {
                Some("it starts before 0 s, where recordings start".to_string())
            } else if a.abs() > max_time_s || b.abs() > max_time_s {
                Some(format!(
                    "times beyond {max_time_s:e} s, the largest a recording's `t` may hold, are no recording's"
                ))
            } else if b <= a {
                Some("it does not end after it starts".to_string())
            } else {
                None
            };
            match why {
                None => Ok(WindowSpec::Time {
                    start_s: *a,
                    end_s: *b,
                }),
                Some(why) => Err(InputError::key(
                    path,
                    "training.windows",
                    format!(
                        "[{}, {}] is not a time window: {why} (window {}, counting from 1)",
                        shipid_io::error::number(*a),
                        shipid_io::error::number(*b),
                        k + 1
                    ),
                )),
            }
        })
        .collect()
}

/// Each time window against each training recording it cuts: one that leaves a recording too few
/// samples to fit is the study's input error (not a `fit-failed` case at run time); one that
/// extends past a recording is fitted on the part recorded, which the returned warnings say, as
/// the window's label in the tables gives the requested times.
fn window_extents(
    path: &Path,
    windows: &[WindowSpec],
    combos: &[Vec<String>],
    dataset: &Dataset,
) -> Result<Vec<String>, InputError> {
    let mut files: Vec<&String> = combos.iter().flatten().collect();
    files.sort();
    files.dedup();
    let mut warnings = Vec::new();
    for (k, w) in windows.iter().enumerate() {
        let WindowSpec::Time { start_s, end_s } = *w else {
            continue;
        };
        for f in &files {
            let Some(r) = dataset.recording(f) else {
                continue;
            };
            let range = shipid_pipeline::fit::window_range(r, dataset, *w).map_err(|e| {
                InputError::key(
                    path,
                    "training.windows",
                    format!(
                        "[{start_s}, {end_s}] (window {}, counting from 1): {e}",
                        k + 1
                    ),
                )
            })?;
            let t = &r.recording.t;
            let (Some(&first), Some(&last)) = (t.first(), t.last()) else {
                continue;
            };
            // Half a sample interval of slack: a window written as the record's length is not past it.
            let dt = if t.len() > 1 {
                (last - first) / (t.len() - 1) as f64
            } else {
                0.0
            };
            if start_s < first - 0.5 * dt || end_s > last + 0.5 * dt {
                let (a, b) = (t[range.start], t[range.end - 1]);
                warnings.push(format!(
                    "{}: training.windows[{k}] = [{start_s}, {end_s}] s extends past `{f}` (recorded {first}–{last} s): \
                     its cases fit `{f}` on {a}–{b} s, though the tables label them {}",
                    path.display(),
                    w.label()
                ));
            }
        }
    }
    Ok(warnings)
}

/// The estimator axis: every entry expanded over its hyper-parameter values, in the file's order.
fn check_estimators(
    path: &Path,
    entries: &[RawEstimator],
) -> Result<Vec<CheckedEstimator>, InputError> {
    if entries.is_empty() {
        return Err(InputError::key(
            path,
            "estimator",
            "the grid is empty: no estimator",
        ));
    }
    let mut estimators = Vec::new();
    // The [[estimator]] entry each of `estimators` came from, to name it when a case repeats.
    let mut origin = Vec::new();
    for (i, e) in entries.iter().enumerate() {
        let expanded = if e.name == GP {
            gp_estimators(path, i, e)?
        } else {
            polynomial_estimators(path, i, e)?
        };
        origin.extend(std::iter::repeat_n(i, expanded.len()));
        estimators.extend(expanded);
    }
    check_estimator_repeats(path, &estimators, &origin)?;
    Ok(estimators)
}

fn entry_key(i: usize, field: &str) -> String {
    format!("estimator[{i}].{field}")
}

fn gp_estimators(
    path: &Path,
    i: usize,
    e: &RawEstimator,
) -> Result<Vec<CheckedEstimator>, InputError> {
    reject_polynomial_keys(path, i, e)?;
    let values = e
        .similarity
        .as_ref()
        .map(OneOrMany::values)
        .unwrap_or_else(|| vec![shipid_pipeline::fit_gp::DEFAULT_SIMILARITY]);
    if values.is_empty() {
        return Err(InputError::key(
            path,
            entry_key(i, "similarity"),
            "the grid is empty: give similarity values or leave it out",
        ));
    }
    values
        .into_iter()
        .map(|d| {
            let spec = EstimatorSpec {
                similarity: Some(d),
                ..EstimatorSpec::named(GP)
            };
            spec.validate().map_err(|err| {
                InputError::key(
                    path,
                    entry_key(i, "similarity"),
                    flags_as_keys(&err.to_string()),
                )
            })?;
            Ok(CheckedEstimator {
                spec,
                solver: NO_SOLVER.into(),
            })
        })
        .collect()
}

/// Keys of the polynomial estimators name what they would change; for the GP nothing, so one given
/// is a mistake rather than a no-op.
fn reject_polynomial_keys(path: &Path, i: usize, e: &RawEstimator) -> Result<(), InputError> {
    for (given, flag) in [
        (e.lambda.is_some(), "lambda"),
        (e.alpha.is_some(), "alpha"),
        (e.c.is_some(), "c"),
        (e.epsilon.is_some(), "epsilon"),
        (e.tune, "tune"),
        (e.refine, "refine"),
        (e.solver.is_some(), "solver"),
        (e.inflow_from_thrust, "inflow_from_thrust"),
    ] {
        if given {
            return Err(InputError::key(
                path,
                entry_key(i, flag),
                format!(
                    "does not apply to {GP} (its one setting is `similarity`, the threshold d_gen)"
                ),
            ));
        }
    }
    Ok(())
}

fn polynomial_estimators(
    path: &Path,
    i: usize,
    e: &RawEstimator,
) -> Result<Vec<CheckedEstimator>, InputError> {
    if e.similarity.is_some() {
        return Err(InputError::key(
            path,
            entry_key(i, "similarity"),
            format!("applies to {GP} only"),
        ));
    }
    reject_foreign_keys(path, i, e)?;
    let solver = e.solver.clone().unwrap_or_else(|| "fast".into());
    if let Err(err) = solver.parse::<shipid_estimators::Solver>() {
        return Err(InputError::key(
            path,
            entry_key(i, "solver"),
            err.to_string(),
        ));
    }
    let expanded = hyper_grid(path, i, e)?;
    if expanded.is_empty() {
        let flag = grid_key(&e.name);
        return Err(InputError::key(
            path,
            entry_key(i, flag),
            format!("the grid is empty: give {flag} values or tune = true"),
        ));
    }
    expanded
        .into_iter()
        .map(|spec| {
            spec.validate().map_err(|err| {
                let msg = flags_as_keys(&err.to_string());
                // Name the key that holds the bad value (a λ of NaN is `lambda`'s fault, not `name`'s).
                let key = match e.name.as_str() {
                    "ridge" | "lasso" | "svr" if msg.contains("epsilon") => "epsilon",
                    "ridge" | "lasso" | "svr" => grid_key(&e.name),
                    _ => "name",
                };
                InputError::key(path, entry_key(i, key), msg)
            })?;
            check_hyper_bounds(path, i, &spec)?;
            Ok(CheckedEstimator {
                spec,
                solver: solver.clone(),
            })
        })
        .collect()
}

/// The pipeline's checks of an estimator speak of `shipid fit`'s flags (`--lambda must be …`); in a
/// study the same settings are keys of an `[[estimator]]` entry, which the message names instead.
fn flags_as_keys(message: &str) -> String {
    let mut out = message
        .replace("--tune", "tune = true")
        .replace("--estimator lsq", "name = \"lsq\"")
        .replace("--estimator sparse-gp", "name = \"sparse-gp\"");
    for flag in ["similarity", "epsilon", "lambda", "alpha", "c"] {
        let dashed = format!("--{flag}");
        let mut rest = out.as_str();
        let mut done = String::new();
        while let Some(at) = rest.find(&dashed) {
            done.push_str(&rest[..at]);
            let after = &rest[at + dashed.len()..];
            // `--c 1e9 is beyond` is `c = 1e9 is beyond`; `--c must be` is `c must be`.
            let value_follows = after
                .strip_prefix(' ')
                .and_then(|a| a.chars().next())
                .is_some_and(|ch| ch.is_ascii_digit() || "-+.".contains(ch));
            if after.starts_with(|ch: char| ch.is_ascii_alphanumeric() || ch == '-') {
                done.push_str(&dashed); // another flag with this prefix
            } else if value_follows {
                done.push_str(flag);
                done.push_str(" =");
            } else {
                done.push_str(flag);
            }
            rest = after;
        }
        done.push_str(rest);
        out = done;
    }
    out
}

/// A value beyond what the estimators take ([`shipid_estimators::MAX_HYPER_PARAMETER`]) would
/// fail every case it makes at run time: the estimators' own check, here, names the key instead.
fn check_hyper_bounds(path: &Path, i: usize, spec: &EstimatorSpec) -> Result<(), InputError> {
    use shipid_estimators::{Estimator, Params, Solver};
    let probes = [
        (
            spec.lambda.map(|lambda| Estimator::Ridge { lambda }),
            "lambda",
        ),
        (spec.alpha.map(|alpha| Estimator::Lasso { alpha }), "alpha"),
        (spec.c.map(|c| Estimator::Svr { c, epsilon: 0.0 }), "c"),
        (
            spec.epsilon
                .map(|epsilon| Estimator::Svr { c: 1.0, epsilon }),
            "epsilon",
        ),
    ];
    for (estimator, key) in probes {
        if let Some(e) = estimator
            && let Err(err) = Params::new(e, Solver::Fast).check()
        {
            return Err(InputError::key(path, entry_key(i, key), err.to_string()));
        }
    }
    Ok(())
}

/// A key that the estimator would ignore (a λ grid on LSQ, values beside `tune = true`) is a mistake
/// the user should hear about, not a grid that silently collapses to one case.
fn reject_foreign_keys(path: &Path, i: usize, e: &RawEstimator) -> Result<(), InputError> {
    let applies: &[&str] = match e.name.as_str() {
        "lsq" | "bounded-lsq" => &[],
        "ridge" => &["lambda", "tune"],
        "lasso" => &["alpha", "tune"],
        "svr" => &["c", "epsilon", "tune"],
        _ => return Ok(()),
    };
    for (given, key) in [
        (e.lambda.is_some(), "lambda"),
        (e.alpha.is_some(), "alpha"),
        (e.c.is_some(), "c"),
        (e.epsilon.is_some(), "epsilon"),
        (e.tune, "tune"),
    ] {
        if given && !applies.contains(&key) {
            return Err(InputError::key(
                path,
                entry_key(i, key),
                format!("does not apply to {}", e.name),
            ));
        }
    }
    let grid = grid_key(&e.name);
    let grid_given = match e.name.as_str() {
        "ridge" => e.lambda.is_some(),
        "lasso" => e.alpha.is_some(),
        "svr" => e.c.is_some(),
        _ => false,
    };
    if e.tune && grid_given {
        return Err(InputError::key(
            path,
            entry_key(i, grid),
            format!(
                "give {grid} values or tune = true, not both (the cross-validation chooses {grid})"
            ),
        ));
    }
    Ok(())
}

/// One spec per value of the estimator's grid key; a tuned estimator picks its own value, so it is
/// one spec whatever the file lists.
fn hyper_grid(path: &Path, i: usize, e: &RawEstimator) -> Result<Vec<EstimatorSpec>, InputError> {
    let base = EstimatorSpec {
        epsilon: e.epsilon,
        tune: e.tune,
        refine: e.refine,
        inflow_from_thrust: e.inflow_from_thrust,
        ..EstimatorSpec::named(&e.name)
    };
    let grid = |v: &Option<OneOrMany>| v.as_ref().map(OneOrMany::values).unwrap_or_default();
    let with = |set: fn(&mut EstimatorSpec, f64), values: Vec<f64>| -> Vec<EstimatorSpec> {
        values
            .into_iter()
            .map(|x| {
                let mut spec = base.clone();
                set(&mut spec, x);
                spec
            })
            .collect()
    };
    Ok(match e.name.as_str() {
        "lsq" | "bounded-lsq" => vec![base.clone()],
        "ridge" | "lasso" | "svr" if e.tune => vec![base.clone()],
        "ridge" => with(|s, x| s.lambda = Some(x), grid(&e.lambda)),
        "lasso" => with(|s, x| s.alpha = Some(x), grid(&e.alpha)),
        "svr" => with(|s, x| s.c = Some(x), grid(&e.c)),
        other => {
            return Err(InputError::key(
                path,
                entry_key(i, "name"),
                format!("unknown estimator `{other}` (lsq, bounded-lsq, ridge, lasso, svr, {GP})"),
            ));
        }
    })
}

/// Two equal points would give two cases one id.
fn check_estimator_repeats(
    path: &Path,
    estimators: &[CheckedEstimator],
    origin: &[usize],
) -> Result<(), InputError> {
    let Some((a, b)) = first_repeat(estimators) else {
        return Ok(());
    };
    let (i, earlier) = (origin[a], origin[b]);
    Err(if i == earlier {
        let spec = &estimators[a].spec;
        let value = [spec.lambda, spec.alpha, spec.c, spec.similarity]
            .into_iter()
            .flatten()
            .next()
            .map(|v| format!(" ({})", shipid_io::error::number(v)))
            .unwrap_or_default();
        InputError::key(
            path,
            entry_key(i, grid_key(&spec.name)),
            format!("a value appears twice in the grid{value}"),
        )
    } else {
        InputError::key(
            path,
            format!("estimator[{i}]"),
            format!("repeats a case of estimator[{earlier}]"),
        )
    })
}

fn test_recordings(
    path: &Path,
    recordings: &TestRecordings,
    known: DatasetRecordings,
) -> Result<Vec<String>, InputError> {
    match recordings {
        TestRecordings::Word(w) if w == "all" => Ok(known
            .dataset
            .recordings
            .iter()
            .map(|r| r.file.clone())
            .collect()),
        TestRecordings::Word(w) => Err(InputError::key(
            path,
            "test.recordings",
            format!("\"{w}\": expected \"all\" or a list of files"),
        )),
        TestRecordings::List(l) => {
            if l.is_empty() {
                return Err(InputError::key(
                    path,
                    "test.recordings",
                    "no test recording: give a list of files or \"all\"",
                ));
            }
            if let Some((i, j)) = first_repeat(l) {
                return Err(InputError::key(
                    path,
                    format!("test.recordings[{i}]"),
                    format!("`{}` repeats test.recordings[{j}]", l[i]),
                ));
            }
            for (i, f) in l.iter().enumerate() {
                known.check(path, format!("test.recordings[{i}]"), f)?;
            }
            Ok(l.clone())
        }
    }
}

fn check_overshoots(
    path: &Path,
    ds: &Dataset,
    combos: &[Vec<String>],
    max: u32,
) -> Result<(), InputError> {
    let mut zigzags = 0;
    for combo in combos {
        for f in combo {
            let Some(r) = ds.recording(f) else { continue };
            if let Manoeuvre::ZigZag {
                rudder_deg,
                check_deg,
                side,
            } = r.manoeuvre
            {
                zigzags += 1;
                let have = zigzag_events(&r.recording, rudder_deg, check_deg, side, &ds.ship)
                    .map_or(0, |e| e.overshoots.len());
                if (have as u32) < max {
                    let why = missing_execute_reason(&r.recording, rudder_deg, side)
                        .map_or(String::new(), |w| format!(": {w}"));
                    return Err(InputError::key(
                        path,
                        "training.overshoots",
                        format!("{max} overshoots requested but `{f}` has {have}{why}"),
                    ));
                }
            }
        }
    }
    // Overshoot counts cut zig-zags only: without one, every count would give the same fit.
    if zigzags == 0 {
        return Err(InputError::key(
            path,
            "training.overshoots",
            "no training recording is a zig-zag, and overshoot counts cut zig-zags only: leave overshoots out",
        ));
    }
    Ok(())
}

/// The key of an estimator's value grid (one case per value).
fn grid_key(estimator: &str) -> &'static str {
    match estimator {
        "ridge" => "lambda",
        "lasso" => "alpha",
        GP => "similarity",
        _ => "c",
    }
}

/// The first `(i, j)` with `j < i` and `items[i]` the same grid value as `items[j]` (the same
/// written form, as in case ids). Linear, so a huge grid is checked before it is refused for its size.
fn first_repeat<T: std::fmt::Debug>(items: &[T]) -> Option<(usize, usize)> {
    let mut seen = std::collections::HashMap::new();
    items
        .iter()
        .enumerate()
        .find_map(|(i, a)| seen.insert(format!("{a:?}"), i).map(|j| (i, j)))
}

fn case(set: &str, est: &EstimatorSpec, solver: &str, combo: &[String], w: WindowSpec) -> Case {
    let hyper = |name: &str, v: Option<f64>| v.map(|x| format!("-{name}{x:e}")).unwrap_or_default();
    let est_part = format!(
        "{}{}{}{}{}{}{}{}",
        est.name,
        hyper("l", est.lambda),
        hyper("a", est.alpha),
        hyper("c", est.c),
        hyper("e", est.epsilon),
        hyper("d", est.similarity),
        if est.tune { "-cv" } else { "" },
        if est.refine { "-oe" } else { "" }
    );
    let train: Vec<String> = combo
        .iter()
        .map(|f| f.trim_end_matches(".csv").to_string())
        .collect();
    let window = match w {
        WindowSpec::Whole => "whole".to_string(),
        WindowSpec::Overshoots(n) => format!("os{n}"),
        WindowSpec::Time { start_s, end_s } => format!("t{start_s}-{end_s}"),
    };
    let readable = if set == NO_SET {
        format!("{est_part}_{}_{window}", train.join("+"))
    } else {
        format!("{set}_{est_part}_{solver}_{}_{window}", train.join("+"))
    };
    let mut c = Case {
        id: String::new(),
        set: set.into(),
        estimator: est.clone(),
        solver: solver.into(),
        training: combo.to_vec(),
        window: w,
    };
    let hash = shipid_pipeline::generate::fnv1a(&serde_json::to_string(&c).unwrap_or_default());
    let clean: String = readable
        .chars()
        .map(|ch| {
            if ch.is_ascii_alphanumeric() || "-_+.".contains(ch) {
                ch
            } else {
                '_'
            }
        })
        .collect();
    // A folder named with a leading dot is hidden from listings (and `..` would climb out of
    // `cases/`): a set file named `.x.toml` or `../x.toml` must not give one.
    let visible = clean.trim_start_matches('.');
    let dots = clean.len() - visible.len();
    // A file name holds at most 255 bytes, and a figure's name holds the id and a test name: long
    // recording names (two of 121 characters trained together) cut the readable part. The hash
    // covers the whole configuration, so cut ids stay distinct (`check_unique_ids` holds it).
    let mut readable = format!("{}{visible}", "_".repeat(dots));
    readable.truncate(MAX_READABLE_ID); // ASCII after cleaning: any byte is a boundary
    c.id = format!("{readable}-{:08x}", hash as u32);
    c
}

/// Most bytes of a case id before its hash (`-` and 8 hex digits follow).
pub const MAX_READABLE_ID: usize = 100;

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression: a study's `lambda = -1` said "--lambda must be a non-negative number", a flag
    /// the study file has not.
    #[test]
    fn estimator_messages_name_study_keys_not_cli_flags() {
        for (flag_words, key_words) in [
            (
                "--lambda must be a non-negative number, not -1",
                "lambda must be a non-negative number, not -1",
            ),
            (
                "--c 1e12 is beyond 1e10: for no regularisation use --estimator lsq, or --tune",
                "c = 1e12 is beyond 1e10: for no regularisation use name = \"lsq\", or tune = true",
            ),
            (
                "give --alpha or --tune, not both (--tune chooses alpha by cross-validation)",
                "give alpha or tune = true, not both (tune = true chooses alpha by cross-validation)",
            ),
            (
                "--similarity applies to --estimator sparse-gp only",
                "similarity applies to name = \"sparse-gp\" only",
            ),
            ("--c must be > 0, got 0", "c must be > 0, got 0"),
        ] {
            assert_eq!(flags_as_keys(flag_words), key_words);
        }
    }
}
