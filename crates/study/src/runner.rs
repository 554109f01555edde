//! `shipid run STUDY.toml`: run a study's cases in parallel and keep every case's outcome.
//!
//! Each case writes `cases/<id>/config.toml` (its resolved configuration and the tool version),
//! `model.toml` and `result.json`, atomically. A rerun reuses every case whose `result.json` exists for
//! the same configuration (resume); `--force` reruns all. A case that fails or diverges is a status in
//! its result, never a crash. Results are collected in the study's case order, so the output does not
//! depend on the number of threads (except the measured fit times).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use shipid_estimators::{Solver, Status};
use shipid_io::PrimeScale;
use shipid_io::write::write_atomic;
use shipid_model::IdentificationRange;
use shipid_sim::{AbkowitzDynamics, Dynamics, Metrics, SimStatus};

use crate::progress::Progress;
use crate::study::{Case, Study};
use shipid_pipeline::fit::{fit_dataset, load_set};
use shipid_pipeline::range::outside_fraction;
use shipid_pipeline::validate::validate_recording_with;

/// How a case's fit (or one DOF's) ended. Stored as kebab-case words in `result.json` and the tables.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CaseStatus {
    /// Solved to tolerance.
    Ok,
    /// Solved, but the design's condition number is above the estimators' threshold.
    IllConditioned,
    /// Solved, but some DOF's fit explains (almost) nothing of its target (all coefficients zero,
    /// or a residual within 0.1 % of the target: `shipid_estimators::explains_nothing`), e.g. an
    /// SVR whose ε-tube holds every sample. The model exists and is tested; it is not a model of
    /// the data.
    ExplainsNothing,
    /// The solver stopped short (reduced accuracy, iteration limit, failure).
    SolverFailed,
    /// The fit could not be made at all (`message` says why).
    FitFailed,
}

impl CaseStatus {
    /// The word used in files and tables.
    pub fn as_str(self) -> &'static str {
        match self {
            CaseStatus::Ok => "ok",
            CaseStatus::IllConditioned => "ill-conditioned",
            CaseStatus::ExplainsNothing => "explains-nothing",
            CaseStatus::SolverFailed => "solver-failed",
            CaseStatus::FitFailed => "fit-failed",
        }
    }

    /// Whether a model came out of the fit (possibly ill-conditioned, or explaining nothing).
    pub fn has_model(self) -> bool {
        matches!(
            self,
            CaseStatus::Ok | CaseStatus::IllConditioned | CaseStatus::ExplainsNothing
        )
    }
}

/// How a simulation of a test ended. Stored as kebab-case words.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TestStatus {
    Ok,
    Diverged,
    /// A recording without a standard manoeuvre ("free"): replayed only, no closed-loop run.
    ReplayOnly,
}

impl TestStatus {
    /// The word used in files and tables.
    pub fn as_str(self) -> &'static str {
        match self {
            TestStatus::Ok => "ok",
            TestStatus::Diverged => "diverged",
            TestStatus::ReplayOnly => "replay-only",
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DofSummary {
    pub dof: String,
    pub status: CaseStatus,
    pub residual_rms: f64,
    pub condition_number: Option<f64>,
    pub scaled_condition_number: Option<f64>,
    pub hyper_parameter: Option<f64>,
    /// The SVR's ε (given or tuned) [target units]; absent for the other estimators and in
    /// results written before 0.2.1.
    #[serde(default)]
    pub epsilon: Option<f64>,
    pub objective: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TermValue {
    pub dof: String,
    pub term: String,
    pub value: Option<f64>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TestRow {
    pub test: String,
    pub kind: String,
    /// Closed-loop manoeuvre: "ok" or "diverged" ("free" recordings have none: "replay-only").
    pub status: TestStatus,
    pub diverged_at_s: Option<f64>,
    pub replay_status: TestStatus,
    /// When the replay diverged [s]; absent when it ran to the end (and in results written before
    /// it existed).
    #[serde(default)]
    pub replay_diverged_at_s: Option<f64>,
    /// The replay's errors over the whole recording; absent when the replay diverged, whose errors
    /// up to the divergence would rank a model that failed among the best (see [`TestRow::rmse`]).
    pub position_rmse_over_l: Option<f64>,
    pub heading_rmse_deg: Option<f64>,
    pub u_rmse_m_s: Option<f64>,
    pub v_rmse_m_s: Option<f64>,
    pub r_rmse_deg_s: Option<f64>,
    pub recorded: Metrics,
    pub predicted: Option<Metrics>,
    pub relative_error: std::collections::BTreeMap<String, f64>,
    pub mrae: Option<f64>,
    /// Share of the test recording's states outside the model's identification range (leverage above
    /// every training state's); absent in results written before it existed.
    #[serde(default)]
    pub outside_identification_range: Option<f64>,
    /// Each metric's band over the case's bootstrap replicates and whether the recorded value lies
    /// inside (studies with `bands`; empty otherwise, and then left out of `result.json`, so studies
    /// without bands keep their files and references).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub bands: BTreeMap<String, MetricBandRow>,
}

impl TestRow {
    /// A replay error as the tables show it: none for a diverged replay, also in a `result.json`
    /// written before 0.2.2, which stored the errors up to the divergence.
    pub fn rmse(&self, value: Option<f64>) -> Option<f64> {
        value.filter(|_| self.replay_status != TestStatus::Diverged)
    }
}

/// One metric's band in a study ([`TestRow::bands`]): the band and whether the recorded value lies
/// inside, or why there is no band.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", tag = "outcome")]
pub enum MetricBandRow {
    /// Lower and upper bound (units of the metric as in the summary), and whether the recorded
    /// value lies inside (None: the recording does not define the metric).
    Band {
        lo: f64,
        hi: f64,
        inside: Option<bool>,
    },
    /// Too few replicate runs define the metric (diverged, or the manoeuvre never reached it).
    NoBand { reason: String },
}

/// What one case produced.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CaseResult {
    pub case_id: String,
    /// The worst status over the DOFs, or `fit-failed` (the fit could not be made: `message` says why).
    pub status: CaseStatus,
    pub message: Option<String>,
    pub fit_time_s: Option<f64>,
    pub samples: usize,
    pub dofs: Vec<DofSummary>,
    pub coefficients: Vec<TermValue>,
    pub vif: Vec<TermValue>,
    pub tests: Vec<TestRow>,
}

impl CaseResult {
    /// The row of a case whose fit could not be made (`message` says why).
    fn failed_fit(case: &Case, message: String) -> CaseResult {
        CaseResult {
            case_id: case.id.clone(),
            status: CaseStatus::FitFailed,
            message: Some(message),
            fit_time_s: None,
            samples: 0,
            dofs: vec![],
            coefficients: vec![],
            vif: vec![],
            tests: vec![],
        }
    }

    /// How the case counts in a run: a fit that produced no model could not be computed; a
    /// simulation that diverged is a result of the study, not a failure to compute it.
    pub fn outcome(&self) -> CaseOutcome {
        if !self.status.has_model() {
            CaseOutcome::FitFailed
        } else if self
            .tests
            .iter()
            .any(|t| t.status == TestStatus::Diverged || t.replay_status == TestStatus::Diverged)
        {
            CaseOutcome::Diverged
        } else {
            CaseOutcome::Ok
        }
    }
}

/// How a case counts in a run ([`CaseResult::outcome`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CaseOutcome {
    /// A model, and every prediction of it ran to the end.
    Ok,
    /// A model, and some prediction (closed loop or replay) diverged.
    Diverged,
    /// No model came out of the fit.
    FitFailed,
}

/// Cases per outcome, as `run.json` and the summary line give them.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct OutcomeCounts {
    pub every_prediction_ok: usize,
    pub some_prediction_diverged: usize,
    pub fit_failed: usize,
}

impl OutcomeCounts {
    /// Counts the outcomes of `results`.
    pub fn of(results: &[CaseResult]) -> OutcomeCounts {
        let mut c = OutcomeCounts::default();
        for r in results {
            c.add(r.outcome());
        }
        c
    }

    fn add(&mut self, o: CaseOutcome) {
        match o {
            CaseOutcome::Ok => self.every_prediction_ok += 1,
            CaseOutcome::Diverged => self.some_prediction_diverged += 1,
            CaseOutcome::FitFailed => self.fit_failed += 1,
        }
    }
}

fn case_status(s: &Status) -> CaseStatus {
    match s {
        Status::Ok => CaseStatus::Ok,
        Status::IllConditioned { .. } => CaseStatus::IllConditioned,
        Status::ReducedAccuracy | Status::MaxIterations | Status::SolverFailed(_) => {
            CaseStatus::SolverFailed
        }
        // run_case turns it into a fit-failed row with the windows and regressors named.
        Status::RankDeficient { .. } => CaseStatus::FitFailed,
    }
}

/// The configuration stored beside a case's results. It names its inputs by content, not by path,
/// so a finished case is reused wherever the study is run from, and never for changed data.
#[derive(Debug, Serialize)]
struct StoredConfig<'a> {
    shipid_version: &'static str,
    study: &'a str,
    dataset: &'a str,
    data_fnv1a: &'a str,
    /// A set file's content hash (a shipped set is named by `case.set` alone).
    set_fnv1a: Option<String>,
    tests: &'a [String],
    case: &'a Case,
    /// Left out without bands, so the stored configurations of earlier runs still match.
    #[serde(skip_serializing_if = "Option::is_none")]
    bands: Option<crate::study::StudyBands>,
}

/// The text of a case's `config.toml`.
pub(crate) fn stored_config(study: &Study, case: &Case) -> std::io::Result<String> {
    let set_fnv1a = (shipid_model::CoefficientSet::builtin(&case.set).is_none()
        && case.set != crate::study::NO_SET)
        .then(|| std::fs::read(resolve_set(study, &case.set)).ok())
        .flatten()
        .map(|b| {
            format!(
                "{:016x}",
                shipid_pipeline::generate::fnv1a(&String::from_utf8_lossy(&b))
            )
        });
    toml::to_string(&StoredConfig {
        shipid_version: env!("CARGO_PKG_VERSION"),
        study: &study.name,
        dataset: &study.dataset.name,
        data_fnv1a: &study.data_fnv1a,
        set_fnv1a,
        tests: &study.tests,
        case,
        bands: study.bands,
    })
    .map_err(std::io::Error::other)
}

/// The stored result of a case finished with this configuration, if there is one.
fn finished_result(dir: &Path, config: &str) -> Option<CaseResult> {
    let same = std::fs::read_to_string(dir.join("config.toml")).is_ok_and(|c| c == config);
    if !same {
        return None;
    }
    let bytes = std::fs::read(dir.join("result.json")).ok()?;
    serde_json::from_slice::<CaseResult>(&bytes).ok()
}

/// How much of a study is left to do in an output folder.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RunPlan {
    pub cases: usize,
    /// Finished earlier with the same configuration (reused unless `force`).
    pub finished: usize,
}

impl RunPlan {
    /// The cases of `study` already finished in `out` (none with `force`).
    pub fn of(study: &Study, out: &Path, force: bool) -> RunPlan {
        let finished = if force {
            0
        } else {
            study
                .cases
                .iter()
                .filter(|c| {
                    stored_config(study, c).is_ok_and(|cfg| {
                        finished_result(&out.join("cases").join(&c.id), &cfg).is_some()
                    })
                })
                .count()
        };
        RunPlan {
            cases: study.cases.len(),
            finished,
        }
    }
}

/// Run one case: fit, then validate on every test recording.
pub fn run_case(study: &Study, case: &Case) -> (CaseResult, Option<String>) {
    let failed = |msg: String| CaseResult::failed_fit(case, msg);
    if case.estimator.name == crate::study::GP {
        return run_gp_case(study, case);
    }
    if case.set == shipid_pipeline::mmg::SET_NAME {
        return run_mmg_case(study, case);
    }
    let set = match load_set(&resolve_set(study, &case.set)) {
        Ok(s) => s,
        Err(e) => return (failed(e.to_string()), None),
    };
    // Validated when the study was read, so this cannot fail; if it did, the case fails, not the run.
    let solver: Solver = match case.solver.parse() {
        Ok(s) => s,
        Err(e) => return (failed(e.to_string()), None),
    };
    let out = match fit_dataset(
        &study.dataset,
        set,
        &case.estimator,
        &case.training,
        case.window,
        solver,
    ) {
        Ok(o) => o,
        Err(e) => return (failed(e.to_string()), None),
    };
    if let Some(none) = out.no_information() {
        return (failed(none.to_string()), None);
    }
    let dof_status = |d: &shipid_pipeline::fit::DofReport| {
        let s = case_status(&d.fit.status);
        let nothing =
            shipid_estimators::explains_nothing(&d.fit.coefficients, d.residual_rms, d.target_rms);
        if nothing && s.has_model() {
            CaseStatus::ExplainsNothing.max(s)
        } else {
            s
        }
    };
    let worst = out
        .dofs
        .iter()
        .map(dof_status)
        .max()
        .unwrap_or(CaseStatus::Ok);
    let model = AbkowitzDynamics(out.model.clone());
    let range = IdentificationRange::from_samples(&out.model.set, &out.training).ok();
    let scale = PrimeScale::of(&study.dataset.ship);
    let outside = |rec: &shipid_io::Recording| {
        range
            .as_ref()
            .map(|g| outside_fraction(g, rec, &scale, 0..rec.len()))
    };
    let mut tests = test_rows(study, &model, &outside);
    let band_failure = study
        .bands
        .as_ref()
        .and_then(|b| add_bands(study, b, &out, case, solver, &mut tests).err());
    let mut coefficients = Vec::new();
    let mut vif = Vec::new();
    for d in &out.dofs {
        for (j, name) in d.names.iter().enumerate() {
            let term = name
                .split_once('_')
                .map_or(name.as_str(), |(_, t)| t)
                .to_string();
            coefficients.push(TermValue {
                dof: d.dof.to_string(),
                term: term.clone(),
                // The model's (after `refine`, the refined ones), not the estimator's.
                value: out.model.coefficients[d.dof.index()].get(j).copied(),
            });
            vif.push(TermValue {
                dof: d.dof.to_string(),
                term,
                value: d.vif.get(j).copied().flatten(),
            });
        }
    }
    let model_text = toml::to_string(&out.file).ok();
    let result = CaseResult {
        case_id: case.id.clone(),
        status: worst,
        message: band_failure,
        fit_time_s: Some(out.fit_time_s),
        samples: out.training.len(),
        dofs: out
            .dofs
            .iter()
            .map(|d| DofSummary {
                dof: d.dof.to_string(),
                status: dof_status(d),
                residual_rms: d.residual_rms,
                condition_number: d.condition_number,
                scaled_condition_number: d.scaled_condition_number,
                hyper_parameter: d.tuning.as_ref().map(|t| t.best),
                epsilon: shipid_pipeline::fit::svr_epsilon(&d.fit.estimator),
                objective: d.fit.objective,
            })
            .collect(),
        coefficients,
        vif,
        tests,
    };
    (result, model_text)
}

/// Validate a model on every test recording of the study: one row each. `outside`: the share of a
/// recording's states outside the model's identification range, where it has one.
fn test_rows(
    study: &Study,
    model: &dyn Dynamics,
    outside: &dyn Fn(&shipid_io::Recording) -> Option<f64>,
) -> Vec<TestRow> {
    study
        .tests
        .iter()
        .filter_map(|f| study.dataset.recording(f))
        .map(|r| {
            // In the recording's recorded wind and current, with the data set's windage.
            let windage = shipid_pipeline::environment::ChosenWindage::of_dataset(&study.dataset);
            let v = validate_recording_with(model, r, &study.dataset.ship, &windage);
            let (status, diverged_at_s, recorded, predicted, relative_error, mrae) =
                match v.manoeuvre {
                    Some(m) => {
                        let (st, at) = match m.status {
                            SimStatus::Ok => (TestStatus::Ok, None),
                            SimStatus::Diverged { t_s, .. } => (TestStatus::Diverged, Some(t_s)),
                        };
                        (st, at, m.recorded, m.predicted, m.relative_error, m.mrae)
                    }
                    None => (
                        TestStatus::ReplayOnly,
                        None,
                        Metrics::default(),
                        None,
                        Default::default(),
                        None,
                    ),
                };
            let (replay_status, replay_diverged_at_s) = match v.replay.status {
                SimStatus::Ok => (TestStatus::Ok, None),
                SimStatus::Diverged { t_s, .. } => (TestStatus::Diverged, Some(t_s)),
            };
            // Errors up to a divergence cover only the part the model managed: left out, as a
            // diverged prediction's MRAE is.
            let whole = |x: f64| (replay_status == TestStatus::Ok).then_some(x);
            TestRow {
                test: r.file.clone(),
                kind: v.kind.into(),
                status,
                diverged_at_s,
                replay_status,
                replay_diverged_at_s,
                position_rmse_over_l: whole(v.replay.position_rmse_over_l),
                heading_rmse_deg: whole(v.replay.heading_rmse_deg),
                u_rmse_m_s: whole(v.replay.u_rmse_m_s),
                v_rmse_m_s: whole(v.replay.v_rmse_m_s),
                r_rmse_deg_s: whole(v.replay.r_rmse_deg_s),
                recorded,
                predicted,
                relative_error,
                mrae,
                outside_identification_range: outside(&r.recording),
                bands: BTreeMap::new(),
            }
        })
        .collect()
}

/// The bands of every test of a polynomial case (studies with `bands`): the fit's block-bootstrap
/// replicates, each re-simulated through the test's manoeuvre as the point prediction is (from the
/// recording's initial state), and with `calibrate` widened by the case's calibration from its own
/// training recordings (`shipid_pipeline::calibration::calibrate_ensemble`). A bootstrap that cannot be made leaves the
/// rows without bands and says why in the case's message; the point results stand.
fn add_bands(
    study: &Study,
    bands: &crate::study::StudyBands,
    out: &shipid_pipeline::fit::FitOutput,
    case: &Case,
    solver: Solver,
    tests: &mut [TestRow],
) -> Result<(), String> {
    use shipid_pipeline::bands::BandRun;
    use shipid_pipeline::calibration::{
        Ensemble, EnsembleSpec, calibrate_ensemble, ensemble_bands,
    };
    let boot = shipid_pipeline::bootstrap::bootstrap_fit(
        &study.dataset,
        out,
        &case.estimator,
        solver,
        bands.replicates,
        bands.seed,
    )
    .map_err(|e| format!("no bands: {e}"))?;
    let ensemble = Ensemble {
        point: out.model.clone(),
        range: IdentificationRange::from_samples(&out.model.set, &out.training).ok(),
        replicates: boot.models(&out.model),
        block_rows: vec![boot.block.rows],
    };
    let calibration = if bands.calibrate {
        let sets = [out.model.set.clone()];
        let how = EnsembleSpec {
            sets: &sets,
            estimator: &case.estimator,
            window: case.window,
            solver,
            replicates: bands.replicates,
            seed: bands.seed,
        };
        Some(
            calibrate_ensemble(&ensemble, &study.dataset, &how, &case.training, bands.level)
                .map_err(|e| format!("no calibrated bands: {e}"))?,
        )
    } else {
        None
    };
    for row in tests.iter_mut() {
        let Some(r) = study.dataset.recording(&row.test) else {
            continue;
        };
        if row.status == TestStatus::ReplayOnly {
            continue;
        }
        // As the test's own validation: in the recording's wind and current.
        let env = shipid_pipeline::environment::recording_environment(&study.dataset, &r.recording)
            .ok()
            .and_then(|(env, _)| env);
        let (b, reach) = ensemble_bands(
            &ensemble,
            &r.manoeuvre,
            &study.dataset.ship,
            bands.level,
            BandRun::Recording(r, env.as_ref()),
        )
        .map_err(|e| format!("no bands for {}: {e}", row.test))?;
        let recorded = row.recorded.entries();
        for (m, (_, value)) in b.metrics.iter().zip(recorded) {
            // A metric of another manoeuvre (an overshoot of a turning circle) has no row.
            if value.is_none() && m.point.is_none() {
                continue;
            }
            let entry = match &m.band {
                Ok(band) => {
                    let band = match &calibration {
                        Some(c) => c.widen(band, m.metric, reach),
                        None => *band,
                    };
                    MetricBandRow::Band {
                        lo: band.lo,
                        hi: band.hi,
                        inside: value.map(|v| band.contains(v)),
                    }
                }
                Err(e) => MetricBandRow::NoBand {
                    reason: e.to_string(),
                },
            };
            row.bands.insert(m.metric.to_string(), entry);
        }
    }
    Ok(())
}

/// A sparse-GP case (paper 001): fit, then validate on every test recording. Its `dofs` are the three
/// GP outputs (u_dot [m/s²], v_dot [m/s²], r_dot [rad/s²]: accelerations in SI, not prime forces), with
/// the residual RMS over all training samples and, as the objective, the negative log marginal
/// likelihood the training minimised; it has no coefficients or VIFs, and its identification range is
/// its sparse points' coverage ([`shipid_pipeline::range::gp_outside_fraction`]).
fn run_gp_case(study: &Study, case: &Case) -> (CaseResult, Option<String>) {
    let threshold = case
        .estimator
        .similarity
        .unwrap_or(shipid_pipeline::fit_gp::DEFAULT_SIMILARITY);
    let (file, model, report) = match shipid_pipeline::fit_gp::fit_gp_dataset(
        &study.dataset,
        &case.training,
        case.window,
        threshold,
    ) {
        Ok(x) => x,
        Err(e) => return (CaseResult::failed_fit(case, e.to_string()), None),
    };
    let tests = test_rows(study, &model, &|rec| {
        Some(shipid_pipeline::range::gp_outside_fraction(&model, rec))
    });
    let result = CaseResult {
        case_id: case.id.clone(),
        status: CaseStatus::Ok,
        message: Some(format!(
            "sparse GP: kept {} of {} training samples (d_gen {threshold})",
            report.kept, report.candidates
        )),
        fit_time_s: Some(report.sparsify_time_s + report.train_time_s),
        samples: report.candidates,
        dofs: report
            .outputs
            .iter()
            .map(|o| DofSummary {
                dof: o.name.clone(),
                status: CaseStatus::Ok,
                residual_rms: o.rms_residual_all_samples,
                condition_number: None,
                scaled_condition_number: None,
                hyper_parameter: None,
                epsilon: None,
                objective: -o.log_marginal_likelihood,
            })
            .collect(),
        coefficients: vec![],
        vif: vec![],
        tests,
    };
    (result, shipid_pipeline::fit_gp::model_text(&file).ok())
}

/// An `mmg` case (docs/mmg.md): the MMG family's fit, then validation on every test recording. Its
/// `dofs` are the equation error's X, Y, N (prime forces): `objective` is each one's term of the data
/// part of J ((residual RMS ÷ force RMS)²), `hyper_parameter` the prior weight λ; its identification
/// range is the ellipsoid of its training states ([`shipid_pipeline::range::state_range_of`]).
fn run_mmg_case(study: &Study, case: &Case) -> (CaseResult, Option<String>) {
    use shipid_pipeline::mmg::file::Identifiability;
    use shipid_pipeline::mmg::{MmgFitOptions, fit_mmg_model_file, write_mmg_model_file};
    let fitted = MmgFitOptions::from_spec(&case.estimator, &case.training, case.window)
        .and_then(|o| fit_mmg_model_file(&study.dataset, &o, case.estimator.refine));
    let (fit, file) = match fitted {
        Ok(x) => x,
        Err(e) => return (CaseResult::failed_fit(case, e.to_string()), None),
    };
    // No regression of its own: the ellipsoid its training states fill (as `validate` gives it).
    let range = shipid_pipeline::range::state_range_of(&shipid_pipeline::range::window_states(
        &study.dataset,
        &fit.windows,
    ));
    let scale = PrimeScale::of(&study.dataset.ship);
    let tests = test_rows(study, &fit.model, &|rec| {
        range
            .as_ref()
            .map(|g| outside_fraction(g, rec, &scale, 0..rec.len()))
    });
    // On a bound, prior-held, moved by correlated parameters, or disputed by the recordings.
    let undetermined: Vec<&str> = file
        .parameters
        .iter()
        .filter(|p| p.identifiability() != Identifiability::DeterminedByData)
        .map(|p| p.name.as_str())
        .collect();
    let result = CaseResult {
        case_id: case.id.clone(),
        status: CaseStatus::Ok,
        message: Some(format!(
            "mmg: not determined by the data: {}",
            undetermined.join(", ")
        )),
        fit_time_s: Some(fit.fit_time_s),
        samples: fit.samples,
        dofs: ["X", "Y", "N"]
            .iter()
            .zip(fit.estimate.residual_rms.iter().zip(fit.estimate.force_rms))
            .map(|(dof, (&rms, scale))| DofSummary {
                dof: dof.to_string(),
                status: CaseStatus::Ok,
                residual_rms: rms,
                condition_number: None,
                scaled_condition_number: None,
                hyper_parameter: Some(fit.lambda),
                epsilon: None,
                objective: (rms / scale).powi(2),
            })
            .collect(),
        coefficients: vec![],
        vif: vec![],
        tests,
    };
    (result, write_mmg_model_file(&file).ok())
}

/// A set named in a study: shipped name, or a path relative to the study file.
pub fn resolve_set(study: &Study, set: &str) -> String {
    if shipid_model::CoefficientSet::builtin(set).is_some() {
        return set.to_string();
    }
    study
        .path
        .parent()
        .unwrap_or(Path::new("."))
        .join(set)
        .display()
        .to_string()
}

/// A run killed while writing a case leaves its temporary files; the lock is ours, so they are
/// nobody's now.
fn remove_temporaries(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        if e.file_name().to_string_lossy().ends_with(".tmp") {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

/// Where a study's results go by default: `results/<name>/`.
pub fn default_out(study: &Study) -> PathBuf {
    PathBuf::from("results").join(&study.name)
}

/// Run (or resume) every case; results in case order. `progress`: a bar on a terminal, plain
/// progress lines on stderr otherwise (a log, a pipe, CI).
pub fn run_study(
    study: &Study,
    out: &Path,
    jobs: usize,
    force: bool,
    progress: bool,
) -> std::io::Result<Vec<CaseResult>> {
    // faer would otherwise spread each small factorisation over all threads while rayon already runs
    // one case per thread.
    faer::set_global_parallelism(faer::Par::Seq);
    // A thread beyond the cases would have nothing to do but cost its stack.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs.clamp(1, study.cases.len().max(1)))
        .build()
        .map_err(std::io::Error::other)?;
    let meter = Progress::new(study.cases.len(), progress);
    let results: Vec<std::io::Result<CaseResult>> = pool.install(|| {
        study
            .cases
            .par_iter()
            .map(|case| {
                let dir = out.join("cases").join(&case.id);
                // An error names the file: "File name too long" alone leaves the user guessing.
                let named = |path: &Path| {
                    let path = path.display().to_string();
                    move |e: std::io::Error| std::io::Error::new(e.kind(), format!("{path}: {e}"))
                };
                let config = stored_config(study, case)?;
                let reused = if force {
                    None
                } else {
                    finished_result(&dir, &config)
                };
                let computed = reused.is_none();
                let result = match reused {
                    Some(r) => r,
                    None => {
                        remove_temporaries(&dir);
                        let (r, model) = run_case(study, case);
                        let path = dir.join("config.toml");
                        write_atomic(&path, config.as_bytes()).map_err(named(&path))?;
                        if let Some(m) = model {
                            let path = dir.join("model.toml");
                            write_atomic(&path, m.as_bytes()).map_err(named(&path))?;
                        }
                        // Written last: its presence marks the case as finished.
                        let path = dir.join("result.json");
                        write_atomic(
                            &path,
                            serde_json::to_string_pretty(&r)
                                .map_err(std::io::Error::other)?
                                .as_bytes(),
                        )
                        .map_err(named(&path))?;
                        r
                    }
                };
                let outcome = result.outcome();
                meter.case_done(
                    computed,
                    outcome == CaseOutcome::FitFailed,
                    outcome == CaseOutcome::Diverged,
                );
                Ok(result)
            })
            .collect()
    });
    meter.finish();
    results.into_iter().collect()
}
