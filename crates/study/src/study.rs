//! Study files: a grid of identification cases in TOML, in three layers —
//! [`RawStudy`] (the file as written, unknown keys rejected) → [`Study`] (checked against its data set:
//! recordings exist, overshoot counts exist, estimators and sets are known) → [`Case`]s (one per grid
//! point, each with an id made from its values).
//!
//! ```toml
//! name = "truncation"
//! description = "Paper 000 Tab. 7/8"
//! dataset = "../data/kvlcc2-mmg/dataset.toml"   # relative to the study file
//! sets = ["reduced32"]
//! [training]
//! recordings = [["zz35_35_ps.csv"], ["zz35_35_ps.csv", "tc35_ps.csv"]]  # combinations
//! overshoots = { from = 1, to = 8 }             # or a list [1, 4], or omit for whole records
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

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use shipid_io::{Dataset, InputError, Manoeuvre};
use shipid_model::CoefficientSet;
use shipid_sim::metrics::zigzag_events;

use shipid_pipeline::fit::{EstimatorSpec, WindowSpec};

pub use shipid_pipeline::fit::GP;
/// `Case::set` and `Case::solver` of a sparse-GP case, which has neither.
pub const NO_SET: &str = "none";
const NO_SOLVER: &str = "none";

#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum OneOrMany {
    One(f64),
    Many(Vec<f64>),
}

impl OneOrMany {
    fn values(&self) -> Vec<f64> {
        match self {
            OneOrMany::One(x) => vec![*x],
            OneOrMany::Many(v) => v.clone(),
        }
    }
}

#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum OvershootSpec {
    List(Vec<u32>),
    Range { from: u32, to: u32 },
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawTraining {
    /// Combinations of recordings (each a list of file names).
    pub recordings: Vec<Vec<String>>,
    #[serde(default)]
    pub overshoots: Option<OvershootSpec>,
    /// Time windows [start, end] in seconds, instead of overshoots.
    #[serde(default)]
    pub windows: Option<Vec<[f64; 2]>>,
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
}

#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum TestRecordings {
    /// "all"
    Word(String),
    List(Vec<String>),
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawTest {
    pub recordings: TestRecordings,
}

/// Tolerance of one summary column in `shipid check`: |fresh − reference| ≤ abs + rel·|reference|.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Tolerance {
    #[serde(default)]
    pub abs: f64,
    #[serde(default)]
    pub rel: f64,
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
    pub cases: Vec<Case>,
    pub tests: Vec<String>,
    pub check: BTreeMap<String, Tolerance>,
}

/// Read, check and expand a study file.
pub fn load_study(path: &Path) -> Result<Study, InputError> {
    let text = std::fs::read_to_string(path).map_err(|e| InputError::read(path, &e))?;
    let raw: RawStudy = toml::from_str(&text).map_err(|e| InputError::toml(path, &text, &e))?;
    let key = |k: &str, msg: String| InputError::key(path, k, msg);
    if raw.name.is_empty()
        || !raw
            .name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
    {
        return Err(key(
            "name",
            format!(
                "\"{}\" must be a non-empty word of letters, digits, - and _",
                raw.name
            ),
        ));
    }
    let dataset_path = path.parent().unwrap_or(Path::new(".")).join(&raw.dataset);
    if !dataset_path.is_file() {
        return Err(key(
            "dataset",
            format!("data set `{}` not found", dataset_path.display()),
        ));
    }
    let dataset = Dataset::load(&dataset_path)?;
    let polynomial = raw.estimators.iter().any(|e| e.name != GP);
    if raw.sets.is_empty() && polynomial {
        return Err(key("sets", "the grid is empty: no coefficient set".into()));
    }
    // A repeated grid value would give two cases one id (one directory, one row twice).
    if let Some((i, j)) = first_repeat(&raw.sets) {
        return Err(key(
            &format!("sets[{i}]"),
            format!("`{}` repeats sets[{j}]", raw.sets[i]),
        ));
    }
    for (i, s) in raw.sets.iter().enumerate() {
        let as_path = path.parent().unwrap_or(Path::new(".")).join(s);
        if CoefficientSet::builtin(s).is_none() && !as_path.is_file() {
            return Err(key(
                &format!("sets[{i}]"),
                format!(
                    "unknown coefficient set `{s}` (not one of {} and no such file)",
                    CoefficientSet::builtin_names().join(", ")
                ),
            ));
        }
    }
    if raw.training.recordings.is_empty() {
        return Err(key(
            "training.recordings",
            "the grid is empty: no training combination".into(),
        ));
    }
    if let Some((i, j)) = first_repeat(&raw.training.recordings) {
        return Err(key(
            &format!("training.recordings[{i}]"),
            format!("repeats training.recordings[{j}]"),
        ));
    }
    for (i, combo) in raw.training.recordings.iter().enumerate() {
        if combo.is_empty() {
            return Err(key(
                &format!("training.recordings[{i}]"),
                "empty combination".into(),
            ));
        }
        for (j, f) in combo.iter().enumerate() {
            if dataset.recording(f).is_none() {
                return Err(key(
                    &format!("training.recordings[{i}][{j}]"),
                    format!("recording `{f}` is not in {}", dataset_path.display()),
                ));
            }
        }
    }
    let windows: Vec<WindowSpec> = match (&raw.training.overshoots, &raw.training.windows) {
        (Some(_), Some(_)) => {
            return Err(key(
                "training.windows",
                "give overshoots or windows, not both".into(),
            ));
        }
        (Some(o), None) => {
            let list: Vec<u32> = match o {
                OvershootSpec::List(l) => l.clone(),
                OvershootSpec::Range { from, to } => (*from..=*to).collect(),
            };
            if list.is_empty() || list.contains(&0) {
                return Err(key(
                    "training.overshoots",
                    "needs overshoot counts of 1 or more".into(),
                ));
            }
            check_overshoots(path, &dataset, &raw.training.recordings, &list)?;
            list.into_iter().map(WindowSpec::Overshoots).collect()
        }
        (None, Some(w)) => {
            if w.is_empty() {
                return Err(key(
                    "training.windows",
                    "the grid is empty: no window".into(),
                ));
            }
            w.iter()
                .map(|[a, b]| {
                    if a.is_finite() && b.is_finite() && b > a {
                        Ok(WindowSpec::Time {
                            start_s: *a,
                            end_s: *b,
                        })
                    } else {
                        Err(key(
                            "training.windows",
                            format!("[{a}, {b}] is not a time window"),
                        ))
                    }
                })
                .collect::<Result<_, _>>()?
        }
        (None, None) => vec![WindowSpec::Whole],
    };
    if let Some((i, j)) = first_repeat(&windows) {
        let grid = if raw.training.windows.is_some() {
            "training.windows"
        } else {
            "training.overshoots"
        };
        return Err(key(
            grid,
            format!("value {} repeats value {} (counting from 1)", i + 1, j + 1),
        ));
    }
    if raw.estimators.is_empty() {
        return Err(key("estimator", "the grid is empty: no estimator".into()));
    }
    let mut estimators: Vec<(EstimatorSpec, String)> = Vec::new();
    // The [[estimator]] entry each of `estimators` came from.
    let mut origin: Vec<usize> = Vec::new();
    for (i, e) in raw.estimators.iter().enumerate() {
        let k = |f: &str| format!("estimator[{i}].{f}");
        if e.name == GP {
            // Keys of the polynomial estimators name what they would change; here nothing.
            for (given, flag) in [
                (e.lambda.is_some(), "lambda"),
                (e.alpha.is_some(), "alpha"),
                (e.c.is_some(), "c"),
                (e.epsilon.is_some(), "epsilon"),
                (e.tune, "tune"),
                (e.refine, "refine"),
                (e.solver.is_some(), "solver"),
            ] {
                if given {
                    return Err(key(
                        &k(flag),
                        format!(
                            "does not apply to {GP} (its one setting is `similarity`, the threshold d_gen)"
                        ),
                    ));
                }
            }
            let values = e
                .similarity
                .as_ref()
                .map(OneOrMany::values)
                .unwrap_or_else(|| vec![shipid_pipeline::fit_gp::DEFAULT_SIMILARITY]);
            if values.is_empty() {
                return Err(key(
                    &k("similarity"),
                    "the grid is empty: give similarity values or leave it out".into(),
                ));
            }
            for d in values {
                let spec = EstimatorSpec {
                    similarity: Some(d),
                    ..EstimatorSpec::named(GP)
                };
                spec.validate()
                    .map_err(|err| key(&k("similarity"), err.to_string()))?;
                estimators.push((spec, NO_SOLVER.into()));
                origin.push(i);
            }
            continue;
        }
        if e.similarity.is_some() {
            return Err(key(&k("similarity"), format!("applies to {GP} only")));
        }
        let solver = e.solver.clone().unwrap_or_else(|| "fast".into());
        if let Err(err) = solver.parse::<shipid_estimators::Solver>() {
            return Err(key(&k("solver"), err.to_string()));
        }
        let base = EstimatorSpec {
            epsilon: e.epsilon,
            tune: e.tune,
            refine: e.refine,
            ..EstimatorSpec::named(&e.name)
        };
        let grid = |v: &Option<OneOrMany>| v.as_ref().map(OneOrMany::values).unwrap_or_default();
        let expanded: Vec<EstimatorSpec> = match e.name.as_str() {
            "lsq" | "bounded-lsq" => vec![base.clone()],
            "ridge" if !e.tune => grid(&e.lambda)
                .into_iter()
                .map(|l| EstimatorSpec {
                    lambda: Some(l),
                    ..base.clone()
                })
                .collect(),
            "lasso" if !e.tune => grid(&e.alpha)
                .into_iter()
                .map(|a| EstimatorSpec {
                    alpha: Some(a),
                    ..base.clone()
                })
                .collect(),
            "svr" if !e.tune => grid(&e.c)
                .into_iter()
                .map(|c| EstimatorSpec {
                    c: Some(c),
                    ..base.clone()
                })
                .collect(),
            "ridge" | "lasso" | "svr" => vec![base.clone()],
            other => {
                return Err(key(
                    &k("name"),
                    format!(
                        "unknown estimator `{other}` (lsq, bounded-lsq, ridge, lasso, svr, {GP})"
                    ),
                ));
            }
        };
        if expanded.is_empty() {
            let flag = grid_key(&e.name);
            return Err(key(
                &k(flag),
                format!("the grid is empty: give {flag} values or tune = true"),
            ));
        }
        for spec in expanded {
            spec.validate()
                .map_err(|err| key(&k("name"), err.to_string()))?;
            estimators.push((spec, solver.clone()));
            origin.push(i);
        }
    }
    if let Some((a, b)) = first_repeat(&estimators) {
        let (i, earlier) = (origin[a], origin[b]);
        return Err(if i == earlier {
            key(
                &format!("estimator[{i}].{}", grid_key(&estimators[a].0.name)),
                "a value appears twice in the grid".into(),
            )
        } else {
            key(
                &format!("estimator[{i}]"),
                format!("repeats a case of estimator[{earlier}]"),
            )
        });
    }
    let tests = match &raw.test.recordings {
        TestRecordings::Word(w) if w == "all" => {
            dataset.recordings.iter().map(|r| r.file.clone()).collect()
        }
        TestRecordings::Word(w) => {
            return Err(key(
                "test.recordings",
                format!("\"{w}\": expected \"all\" or a list of files"),
            ));
        }
        TestRecordings::List(l) => {
            for (i, f) in l.iter().enumerate() {
                if dataset.recording(f).is_none() {
                    return Err(key(
                        &format!("test.recordings[{i}]"),
                        format!("recording `{f}` is not in {}", dataset_path.display()),
                    ));
                }
            }
            l.clone()
        }
    };
    let mut cases = Vec::new();
    for set in &raw.sets {
        for (est, solver) in estimators.iter().filter(|(e, _)| e.name != GP) {
            for combo in &raw.training.recordings {
                for w in &windows {
                    cases.push(case(set, est, solver, combo, *w));
                }
            }
        }
    }
    // The GP has no coefficient set: its cases come once, after the polynomial ones (whose order, and
    // so every existing study's, is unchanged).
    for (est, solver) in estimators.iter().filter(|(e, _)| e.name == GP) {
        for combo in &raw.training.recordings {
            for w in &windows {
                cases.push(case(NO_SET, est, solver, combo, *w));
            }
        }
    }
    Ok(Study {
        path: path.to_path_buf(),
        name: raw.name,
        description: raw.description,
        dataset_path,
        dataset,
        cases,
        tests,
        check: raw.check,
    })
}

fn check_overshoots(
    path: &Path,
    ds: &Dataset,
    combos: &[Vec<String>],
    wanted: &[u32],
) -> Result<(), InputError> {
    let max = wanted.iter().copied().max().unwrap_or(0);
    for combo in combos {
        for f in combo {
            let Some(r) = ds.recording(f) else { continue };
            if let Manoeuvre::ZigZag {
                rudder_deg,
                check_deg,
                side,
            } = r.manoeuvre
            {
                let have = zigzag_events(&r.recording, rudder_deg, check_deg, side, &ds.ship)
                    .map_or(0, |e| e.overshoots.len());
                if (have as u32) < max {
                    return Err(InputError::key(
                        path,
                        "training.overshoots",
                        format!("{max} overshoots requested but `{f}` has {have}"),
                    ));
                }
            }
        }
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

/// The first `(i, j)` with `j < i` and `items[i] == items[j]`.
fn first_repeat<T: PartialEq>(items: &[T]) -> Option<(usize, usize)> {
    items
        .iter()
        .enumerate()
        .find_map(|(i, a)| items[..i].iter().position(|b| b == a).map(|j| (i, j)))
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
    c.id = format!("{clean}-{:08x}", hash as u32);
    c
}
