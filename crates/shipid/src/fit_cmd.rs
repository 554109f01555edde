//! `shipid fit DATASET.toml --set S --estimator E [...] --out MODEL.toml [--json]`.

use std::path::Path;

use serde_json::{Value, json};
use shipid_estimators::Solver;
use shipid_io::Dataset;
use shipid_io::write::write_atomic;

use shipid_pipeline::bootstrap::bootstrap_fit;
use shipid_pipeline::fit::{EstimatorSpec, FitOutput, WindowSpec, fit_dataset, load_set};
use shipid_pipeline::fit_gp::{DEFAULT_SIMILARITY, fit_gp_dataset, model_text};
use shipid_pipeline::model_file::load_model;
use shipid_pipeline::range::StateExtent;
use shipid_pipeline::validate::{propeller_rate_variations, rates_between_runs_note};

use crate::{CliError, Outcome, failed};

/// Parsed flags of `shipid fit`.
pub struct FitArgs<'a> {
    pub dataset: &'a Path,
    pub set: &'a str,
    pub estimator: EstimatorSpec,
    pub recordings: Vec<String>,
    pub window: WindowSpec,
    pub solver: Solver,
    pub out: &'a Path,
    pub json: bool,
    /// After fitting, validate the model on every recording of the data set (trained on or not).
    pub validate: bool,
    /// Bootstrap replicates and their seed (`--bootstrap N --bootstrap-seed S`).
    pub bootstrap: Option<(usize, u64)>,
    /// `--calibrate [LEVEL] [--structures a,b]`: the level and the ensemble's other sets (empty: the
    /// fitted set alone).
    pub calibrate: Option<(f64, Vec<String>)>,
}

/// How many of the largest VIFs the report lists per DOF.
const TOP_VIFS: usize = 5;

/// The `--json` report: fit time, residual RMS per DOF, condition numbers, the largest VIFs, status.
pub fn report_json(out: &FitOutput, warnings: &[String]) -> Value {
    let mut dofs = serde_json::Map::new();
    for d in &out.dofs {
        let mut vifs: Vec<(&String, f64)> = d
            .names
            .iter()
            .zip(&d.vif)
            .filter_map(|(n, v)| v.map(|v| (n, v)))
            .collect();
        vifs.sort_by(|a, b| b.1.total_cmp(&a.1));
        // An infinite VIF (exactly collinear) is not a JSON number: those regressors are listed
        // apart.
        let collinear: Vec<&String> = vifs
            .iter()
            .filter(|(_, v)| !v.is_finite())
            .map(|(n, _)| *n)
            .collect();
        let largest: serde_json::Map<String, Value> = vifs
            .iter()
            .filter(|(_, v)| v.is_finite())
            .take(TOP_VIFS)
            .map(|(n, v)| ((*n).clone(), json!(v)))
            .collect();
        let mut entry = json!({
            "status": d.fit.status,
            "residual_rms": d.residual_rms,
            "target_rms": d.target_rms,
            "condition_number": d.condition_number,
            "scaled_condition_number": d.scaled_condition_number,
            "largest_vif": largest,
            "objective": d.fit.objective,
            "iterations": d.fit.iterations,
            "hyper_parameter": d.tuning.as_ref().map(|t| t.best),
            "epsilon": shipid_pipeline::fit::svr_epsilon(&d.fit.estimator),
        });
        if let Value::Object(o) = &mut entry {
            // Undefined (an estimator without the hyper-parameter) or infinite (a rank-deficient
            // design) values are left out: JSON would write both as null.
            o.retain(|_, v| !v.is_null());
            if !collinear.is_empty() {
                o.insert("collinear_regressors".into(), json!(collinear));
            }
            if explains_nothing(d) {
                o.insert("explains_nothing".into(), json!(true));
            }
            if let shipid_estimators::Status::RankDeficient { zero_columns } = &d.fit.status {
                let names: Vec<&String> = zero_columns
                    .iter()
                    .filter_map(|&j| d.names.get(j))
                    .collect();
                o.insert("regressors_without_information".into(), json!(names));
            }
        }
        dofs.insert(d.dof.to_string(), entry);
    }
    let mut report = json!({
        "fit_time_s": out.fit_time_s,
        "samples": out.training.len(),
        "set": out.model.set.name,
        "estimator": out.file.estimator,
        "dofs": dofs,
    });
    if !warnings.is_empty()
        && let Value::Object(o) = &mut report
    {
        o.insert("warnings".into(), json!(warnings));
    }
    report
}

/// Warnings about the training recordings (printed on stderr and kept in the JSON report): a
/// propeller rate that varies although the fitted model runs at one constant rate (not for a model
/// that `takes_rate`, the mmg family: its fit and replays take every sample's rate). With
/// `--validate` the validation warns about every recording instead.
fn training_warnings(
    ds: &Dataset,
    recordings: &[String],
    validate: bool,
    takes_rate: bool,
) -> Vec<String> {
    // What the fit does with a recorded wind or current is said whether or not it validates after.
    let mut warnings =
        shipid_pipeline::fit::fit_environment_notes(ds, recordings).unwrap_or_default();
    warnings.extend(
        shipid_pipeline::fit::acceleration_window_notes(ds, recordings).unwrap_or_default(),
    );
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    if takes_rate {
        return warnings;
    }
    let chosen = || {
        ds.recordings
            .iter()
            .filter(|r| recordings.is_empty() || recordings.contains(&r.file))
    };
    if let Some(w) = rates_between_runs_note(chosen()) {
        eprintln!("warning: {w}");
        warnings.push(w);
    }
    if validate {
        return warnings;
    }
    let rates: Vec<String> = propeller_rate_variations(chosen())
        .iter()
        .map(ToString::to_string)
        .collect();
    for w in &rates {
        eprintln!("warning: {w}");
    }
    warnings.extend(rates);
    warnings
}

/// `text` of an mmg or sparse-GP model file with the `[environment]` of its fit appended (their
/// formats have no such table; the loader reads it apart).
fn with_environment_table(
    text: String,
    ds: &Dataset,
    recordings: &[String],
) -> Result<String, CliError> {
    Ok(
        match shipid_pipeline::fit::fit_environment_record(ds, recordings)? {
            Some(record) => text + &shipid_pipeline::environment::environment_table_text(&record)?,
            None => text,
        },
    )
}

/// A fit's status in words: `ok`, `ill-conditioned`, `rank-deficient (no information on …)`, …
fn status_words(d: &shipid_pipeline::fit::DofReport) -> String {
    use shipid_estimators::Status;
    match &d.fit.status {
        Status::Ok => "ok".into(),
        Status::IllConditioned { condition_number } => {
            format!("ill-conditioned (effective condition number {condition_number:.3e})")
        }
        Status::RankDeficient { zero_columns } => format!(
            "rank-deficient (no information on {})",
            zero_columns
                .iter()
                .filter_map(|&j| d.names.get(j).map(String::as_str))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        Status::ReducedAccuracy => "reduced accuracy".into(),
        Status::MaxIterations => "iteration limit reached".into(),
        Status::SolverFailed(how) => format!("solver failed ({how})"),
    }
}

/// A DOF whose fit explains (almost) nothing of its target: every coefficient zero, or the
/// residual as large as the target (a regularisation that ignores the data, say).
fn explains_nothing(d: &shipid_pipeline::fit::DofReport) -> bool {
    shipid_estimators::explains_nothing(&d.fit.coefficients, d.residual_rms, d.target_rms)
}

/// The fit's summary: with `as_json` the JSON report, returned for [`emit_json`] to print (alone, or
/// beside the validation's); else one line per DOF on stdout. `out` is the model file written, if
/// any.
fn print_summary(
    out: &FitOutput,
    written: Option<&Path>,
    as_json: bool,
    warnings: &[String],
    extent: Option<&StateExtent>,
) -> Option<Value> {
    if as_json {
        let mut report = report_json(out, warnings);
        if let (Value::Object(o), Some(e)) = (&mut report, extent) {
            o.insert("training_extent".into(), json!(e));
        }
        return Some(report);
    }
    println!(
        "fitted {} with {} on {} samples in {:.2} ms → {}",
        out.model.set.name,
        out.file.estimator.name,
        out.training.len(),
        out.fit_time_s * 1e3,
        written.map_or("no model file".into(), |p| p.display().to_string())
    );
    for d in &out.dofs {
        println!(
            "  {}: status {}, residual RMS {:.3e} (target RMS {:.3e}), condition number {:.3e}",
            d.dof,
            status_words(d),
            d.residual_rms,
            d.target_rms,
            d.condition_number.unwrap_or(f64::NAN)
        );
        if explains_nothing(d) {
            let why = match shipid_pipeline::fit::svr_epsilon(&d.fit.estimator) {
                Some(eps) if eps >= d.target_rms => format!(
                    "the SVR's ε {eps:.3e} is as wide as the target's RMS: every sample lies in its insensitive tube; give a smaller --epsilon or use --tune"
                ),
                _ => "the estimator's settings ignore the data; lower the regularisation or use --tune".into(),
            };
            eprintln!(
                "warning: {}: the fit explains nothing of the target (residual RMS {:.3e} against the target's {:.3e}{}): {why}",
                d.dof,
                d.residual_rms,
                d.target_rms,
                if d.fit.coefficients.iter().all(|c| *c == 0.0) {
                    ", every coefficient 0"
                } else {
                    ""
                }
            );
        }
    }
    None
}

/// `fit --json` on stdout: the fit's report alone, or with `--validate` ONE document
/// `{"fit": …, "validation": …}` whose `validation` is what `shipid validate MODEL DATASET --json`
/// prints (the same library call, so the two never drift apart). The model is read back from the
/// file written, as `validate` would read it. The outcome is the validation's (a diverged
/// re-simulation: some failed).
fn emit_json(fit: Value, validate: Option<(&Path, &Dataset)>) -> Result<Outcome, CliError> {
    let Some((model_path, ds)) = validate else {
        println!("{}", serde_json::to_string_pretty(&fit).unwrap_or_default());
        return Ok(Outcome::Ok);
    };
    let spec = model_path.to_string_lossy();
    let model = load_model(&spec)?;
    let (validation, outcome) = crate::print::validation_value(model.as_ref(), &spec, ds);
    println!(
        "{}",
        serde_json::to_string_pretty(&json!({ "fit": fit, "validation": validation }))
            .unwrap_or_default()
    );
    Ok(outcome)
}

pub fn run(a: FitArgs<'_>) -> Result<Outcome, CliError> {
    if let Some((level, _)) = &a.calibrate {
        check_calibrate(&a, *level)?;
    }
    if a.set == shipid_pipeline::mmg::SET_NAME {
        return run_mmg(a);
    }
    a.estimator.validate()?;
    let set = load_set(a.set)?;
    let ds = Dataset::load(a.dataset)?;
    warn_window_clipped(&ds, &a.recordings, a.window);
    let out = fit_dataset(&ds, set, &a.estimator, &a.recordings, a.window, a.solver)?;
    let warnings = training_warnings(&ds, &a.recordings, a.validate, false);
    if let Some(none) = out.no_information() {
        // No model file: a model whose coefficients the data never saw would validate as if it
        // were one.
        if let Some(report) = print_summary(&out, None, a.json, &warnings, None) {
            emit_json(report, None)?;
        }
        return Err(crate::failed_msg(none));
    }
    // The data set's path relative to the model file, so the model reads it from anywhere.
    let mut file = out.file.clone();
    if let Some((n, seed)) = a.bootstrap {
        let bar = working(format!("bootstrap: {n} replicates re-identified"));
        let boot = bootstrap_fit(&ds, &out, &a.estimator, a.solver, n, seed);
        bar.finish_and_clear();
        let boot = boot?;
        report_bootstrap(
            boot.replicates.len(),
            boot.rejected,
            (boot.block.rows, boot.block.decorrelation_lag),
            n,
        )?;
        file.bootstrap = Some(boot.record(&out.model));
        if let Some((level, others)) = &a.calibrate {
            let bar = calibrating(*level, "");
            let record = calibrate(&a, &ds, &out, (n, seed), *level, others);
            bar.finish_and_clear();
            let record = record?;
            file.calibration = within_factor_cap(&record.factors).then_some(record);
        }
    }
    shipid_pipeline::model_file::anchor_training(&mut file.training, a.out);
    let text = toml::to_string(&file).map_err(failed)?;
    let header = format!(
        "# Abkowitz model identified by shipid {}.\n# Coefficients: prime system I (docs/conventions.md) with U0 = {} m/s, L = {} m; midship; rudder positive to starboard.\n",
        env!("CARGO_PKG_VERSION"),
        ds.ship.u0,
        ds.ship.lpp
    );
    write_atomic(a.out, format!("{header}{text}").as_bytes())
        .map_err(|e| crate::not_saved(a.out, e, "the fitted model"))?;
    let all_solved = out.dofs.iter().all(|d| d.fit.status.is_solved());
    let extent = StateExtent::of_windows(&ds, &out.file.training);
    let report = print_summary(&out, Some(a.out), a.json, &warnings, extent.as_ref());
    if !a.json {
        print_training_extent(extent.as_ref());
    }
    let mut outcome = if all_solved {
        Outcome::Ok
    } else {
        Outcome::SomeFailed
    };
    if let Some(report) = report {
        if emit_json(report, a.validate.then_some((a.out, &ds)))? == Outcome::SomeFailed {
            outcome = Outcome::SomeFailed;
        }
    } else if a.validate {
        let spec = a.out.to_string_lossy();
        let model = load_model(&spec)?;
        if crate::print::validation(model.as_ref(), &spec, &ds, a.json) == Outcome::SomeFailed {
            outcome = Outcome::SomeFailed;
        }
    }
    Ok(outcome)
}

/// `--calibrate` is refused before any work where it cannot apply: a level outside (0, 1), no
/// `--bootstrap` (the replicates it widens), `--structures` of the mmg family (one structure, its
/// own), a refined polynomial fit (the ensemble is fitted in the equation-error sense, so its
/// replicates would not be centred on the refined model; an mmg fit's replicates are shifted onto
/// it and every refit is refined too), an unknown or repeated structure, and fewer replicates per
/// structure than a band needs.
fn check_calibrate(a: &FitArgs<'_>, level: f64) -> Result<(), CliError> {
    check_level(level)?;
    let Some((n, _)) = a.bootstrap else {
        return Err(crate::bad_input(
            "--calibrate widens the bands of bootstrap replicates: give --bootstrap N (e.g. 200) too",
        ));
    };
    let others = a.calibrate.iter().flat_map(|(_, others)| others);
    if a.set == shipid_pipeline::mmg::SET_NAME {
        if others.clone().next().is_some() {
            return Err(crate::bad_input(
                "--structures names polynomial sets of an ensemble; the mmg family is calibrated on its own bootstrap replicates: drop --structures",
            ));
        }
        return Ok(());
    }
    if a.estimator.refine {
        return Err(crate::bad_input(
            "--calibrate does not apply with --refine: the ensemble is fitted in the equation-error sense and would not be centred on the refined model",
        ));
    }
    let fitted = load_set(a.set)?.name;
    let mut names = vec![fitted.clone()];
    for name in others {
        let set = load_set(name).map_err(|e| crate::bad_input(format!("--structures: {e}")))?;
        // The list is the user's: a repeated name would be merged without a word.
        if set.name == fitted {
            return Err(crate::bad_input(format!(
                "--structures names {name}, the fitted --set {}, which is always the ensemble's first structure: drop it from --structures",
                a.set
            )));
        }
        if names.contains(&set.name) {
            return Err(crate::bad_input(format!(
                "--structures names {name} twice: give each structure once"
            )));
        }
        names.push(set.name);
    }
    // Each structure is bootstrapped with its share of the N replicates; fewer than a band needs
    // would leave every calibrated band empty.
    let per = shipid_pipeline::bands::MIN_FINITE_REPLICATES;
    if n / names.len() < per {
        return Err(crate::bad_input(format!(
            "--bootstrap {n} is too few for {} structures ({}): each gets {} replicates and a band needs at least {per}: give --bootstrap {} or more",
            names.len(),
            names.join(", "),
            n / names.len(),
            per * names.len()
        )));
    }
    Ok(())
}

fn check_level(level: f64) -> Result<(), CliError> {
    if !(level > 0.0 && level < 1.0) {
        return Err(crate::bad_input(format!(
            "--calibrate must be a level strictly between 0 and 1 (e.g. 0.9), got {level}"
        )));
    }
    Ok(())
}

/// The training recordings a calibration re-simulates and leaves out in turn: those named, or every
/// recording of the data set.
fn calibration_recordings(ds: &Dataset, named: &[String]) -> Vec<String> {
    if named.is_empty() {
        ds.recordings.iter().map(|r| r.file.clone()).collect()
    } else {
        named.to_vec()
    }
}

/// The calibration's line on stderr.
fn report_calibration(
    level: f64,
    what: &str,
    folds: usize,
    factors: &std::collections::BTreeMap<String, shipid_model::FactorRecord>,
    out_of_kind: Option<&shipid_model::OutOfKindRecord>,
) {
    let factors: Vec<String> = factors
        .iter()
        .map(|(fam, f)| format!("{fam} {:.2} ({}, {} errors)", f.factor, f.outcome, f.errors))
        .collect();
    eprintln!(
        "calibration at {level}: {what}, {folds} held-out folds; factors {}; in the model file's [calibration]",
        factors.join(", ")
    );
    // Said at fit time: the band of the other kind rests on other ships, not on these data.
    if let Some(o) = out_of_kind {
        eprintln!(
            "note: trained on {} only: the other kind's bands take an out-of-kind term measured \
             on a population of ships, not on these data: {}{}{} (docs/uncertainty.md)",
            o.trained_on.join(" and "),
            shipid_pipeline::out_of_kind::terms_in_words(o),
            shipid_pipeline::out_of_kind::level_note(level),
            shipid_pipeline::out_of_kind::caveat(o)
        );
    }
}

/// The model file's `[calibration]`: the ensemble of the fitted set and `others` (same windows,
/// estimator, solver, `n` replicates pooled, the bootstrap's seed) and its factors at `level` from
/// the training recordings (all of the data set's when none were named).
fn calibrate(
    a: &FitArgs<'_>,
    ds: &Dataset,
    out: &FitOutput,
    (n, seed): (usize, u64),
    level: f64,
    others: &[String],
) -> Result<shipid_model::CalibrationRecord, CliError> {
    use shipid_pipeline::calibration::{
        EnsembleSpec, calibrate_ensemble, calibration_record, fit_ensemble_stored,
    };
    let mut sets = vec![out.model.set.clone()];
    for name in others {
        let set = load_set(name).map_err(|e| crate::bad_input(format!("--structures: {e}")))?;
        if !sets.iter().any(|s| s.name == set.name) {
            sets.push(set);
        }
    }
    let recordings = calibration_recordings(ds, &a.recordings);
    let how = EnsembleSpec {
        sets: &sets,
        estimator: &a.estimator,
        window: a.window,
        solver: a.solver,
        replicates: n,
        seed,
    };
    let (ensemble, structures) = fit_ensemble_stored(ds, &how, &recordings)?;
    let c = calibrate_ensemble(&ensemble, ds, &how, &recordings, level)?;
    let record = calibration_record(&c, &how, structures);
    let what = format!(
        "ensemble of {} ({} replicates each)",
        sets.iter()
            .map(|s| s.name.as_str())
            .collect::<Vec<_>>()
            .join(" + "),
        (n / sets.len()).max(2)
    );
    report_calibration(
        level,
        &what,
        c.folds,
        &record.factors,
        record.out_of_kind.as_ref(),
    );
    Ok(record)
}

/// The bootstrap's line on stderr; a failure when too few replicates are left for a band.
fn report_bootstrap(
    kept: usize,
    rejected: usize,
    (block_rows, decorrelation_lag): (usize, Option<usize>),
    asked: usize,
) -> Result<(), CliError> {
    eprintln!(
        "bootstrap: {kept} replicates kept ({rejected} rejected), blocks of {} rows ({}); standard errors and correlations in the model file's [bootstrap]",
        block_rows,
        decorrelation_lag.map_or("residuals correlated up to the cap".into(), |l| format!(
            "residuals decorrelate after {l} rows"
        ))
    );
    if kept < shipid_pipeline::bands::MIN_FINITE_REPLICATES {
        return Err(crate::failed_msg(format!(
            "only {kept} of {asked} bootstrap replicates could be refitted: too few for a band"
        )));
    }
    Ok(())
}

/// `shipid fit DATASET --set mmg --estimator bounded-lsq|ridge [--lambda λ | --tune] [--refine]`: the
/// MMG family (docs/mmg.md); its model file gives every parameter with its prior and standard error.
fn run_mmg(a: FitArgs<'_>) -> Result<Outcome, CliError> {
    use shipid_pipeline::calibration::{MmgFamily, calibrate_fit, factor_calibration_record};
    use shipid_pipeline::mmg::{MmgFitOptions, fit_mmg_model_file, write_mmg_model_file};
    let opts = MmgFitOptions::from_spec(&a.estimator, &a.recordings, a.window)?;
    let ds = Dataset::load(a.dataset)?;
    warn_window_clipped(&ds, &a.recordings, a.window);
    let mut warnings = training_warnings(&ds, &a.recordings, a.validate, true);
    // A `rate_rps` the recorded `n` overrides matters only to the mmg fit, which takes the rate.
    for note in shipid_io::dataset::load_notes(&ds) {
        eprintln!("warning: {note}");
        warnings.push(note);
    }
    let training: Vec<&shipid_io::DatasetRecording> = ds
        .recordings
        .iter()
        .filter(|r| a.recordings.is_empty() || a.recordings.contains(&r.file))
        .collect();
    for r in &training {
        let astern = r
            .recording
            .n
            .as_ref()
            .map_or(0, |n| n.iter().filter(|x| **x < 0.0).count());
        if astern > 0 {
            let w = format!(
                "{}: {astern} samples with the propeller astern (n < 0) are left out of the fit: the MMG propeller model is for ahead",
                r.file
            );
            eprintln!("warning: {w}");
            warnings.push(w);
        }
    }
    if let Some(source) = ds.propeller.as_ref().and_then(|p| p.k_t_default.as_ref()) {
        let w = format!(
            "{}: [propeller] {source}; the thrust, and with it the rudder inflow, assumes that curve",
            a.dataset.display()
        );
        eprintln!("warning: {w}");
        warnings.push(w);
    }
    let slow = a.estimator.tune && a.estimator.refine;
    if slow {
        // The one slow combination (tens of seconds): say what it is doing before it starts (a line
        // for logs), and on a terminal that it is still at it.
        eprintln!(
            "cross-validating the prior weight over {} candidates, every fold's fit refined (output error), then refining from every candidate (the valley){}…",
            shipid_pipeline::mmg::CV_GRID.len(),
            if a.calibrate.is_some() {
                ", and again in every refit of the calibration (minutes)"
            } else {
                ""
            }
        );
    }
    let bar = slow.then(|| working("cross-validating and refining the mmg fit".into()));
    let fitted = fit_mmg_model_file(&ds, &opts, a.estimator.refine);
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    let (fit, mut file) = fitted?;
    if let Some(note) = shipid_pipeline::validate::training_rates_note(
        fit.propeller_rate_hz,
        training.iter().copied(),
    ) {
        eprintln!("note: {note}");
        warnings.push(note);
    }
    if let Some((n, seed)) = a.bootstrap {
        let family = MmgFamily {
            opts: opts.clone(),
            geometry: fit.geometry,
            refine: a.estimator.refine,
            replicates: n,
            seed,
        };
        let recordings = calibration_recordings(&ds, &a.recordings);
        // The spinner shows on a terminal only; a log gets how long to expect (10 000 replicates of
        // the default fit ran 19 minutes without a line).
        let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
        // The fit's own solve (and refinement), not the command's wall time, which also holds the
        // jackknife's refits and the file: a replicate starts from the fit and takes less.
        let one_fit_s = fit.fit_time_s;
        eprintln!(
            "bootstrap: re-identifying {n} mmg replicates, at most about {:.0} s ({one_fit_s:.2} s per fit on {cores} core(s))…",
            n as f64 * one_fit_s / cores as f64
        );
        let bar = working(format!("bootstrap: {n} mmg replicates re-identified"));
        let bands = family.bands_of(&ds, &fit, &recordings);
        bar.finish_and_clear();
        let (fitted, boot) = bands?;
        report_bootstrap(
            boot.replicates.len(),
            boot.rejected,
            (boot.block.rows, boot.block.decorrelation_lag),
            n,
        )?;
        file.bootstrap = Some(boot.record());
        if let Some((level, _)) = &a.calibrate {
            let bar = calibrating(*level, "");
            let c = calibrate_fit(fitted.source(), &family, &ds, &recordings, *level);
            bar.finish_and_clear();
            let c = c?;
            let record = factor_calibration_record(&c, n, seed);
            let what = format!(
                "mmg block-bootstrap replicates ({n} per refit{})",
                if a.estimator.refine {
                    ", every refit refined"
                } else {
                    ""
                }
            );
            report_calibration(
                *level,
                &what,
                c.folds,
                &record.factors,
                record.out_of_kind.as_ref(),
            );
            file.calibration = within_factor_cap(&record.factors).then_some(record);
        }
    }
    shipid_pipeline::model_file::anchor_training(&mut file.training, a.out);
    let text = with_environment_table(write_mmg_model_file(&file)?, &ds, &a.recordings)?;
    write_atomic(a.out, text.as_bytes())
        .map_err(|e| crate::not_saved(a.out, e, "the fitted model"))?;
    if a.json {
        let report = json!({
            "fit_time_s": fit.fit_time_s,
            "samples": fit.samples,
            "samples_available": fit.samples_available,
            "training_extent": StateExtent::of_windows(&ds, &fit.windows),
            "set": "mmg",
            "estimator": file.estimator,
            "parameters": file.parameters,
            "identifiability": file
                .parameters
                .iter()
                .map(|p| (p.name.clone(), p.identifiability().label()))
                .collect::<std::collections::BTreeMap<_, _>>(),
            "valley": file.valley,
            "on_bound": file
                .parameters
                .iter()
                .filter_map(|p| p.bound_reached().map(|b| json!({ "name": p.name, "bound": b })))
                .collect::<Vec<_>>(),
            "warnings": warnings,
        });
        return emit_json(report, a.validate.then_some((a.out, &ds)));
    } else {
        println!(
            "fitted mmg with {} on {} samples{} in {:.2} ms → {}",
            file.estimator.name,
            fit.samples,
            thinned_from(fit.samples, fit.samples_available),
            fit.fit_time_s * 1e3,
            a.out.display()
        );
        file.summary().iter().for_each(|l| println!("{l}"));
        print_training_extent(StateExtent::of_windows(&ds, &fit.windows).as_ref());
    }
    if a.validate {
        let spec = a.out.to_string_lossy();
        let model = load_model(&spec)?;
        // As `validate` of the written file: its valley and jackknife ranges beside the table.
        let shipid_pipeline::bands::BesideModels { valley, jackknife } =
            shipid_pipeline::bands::beside_of(&spec)?;
        return Ok(crate::print::validation_with_bands(
            model.as_ref(),
            &spec,
            &ds,
            a.json,
            None,
            valley.as_ref(),
            jackknife.as_ref(),
        ));
    }
    Ok(Outcome::Ok)
}

/// `shipid fit DATASET --estimator sparse-gp [--similarity D] [--calibrate [LEVEL]] --out MODEL.toml
/// [--json] [--validate]`.
#[allow(clippy::too_many_arguments)]
pub fn run_gp(
    dataset: &std::path::Path,
    recordings: &[String],
    window: WindowSpec,
    similarity: Option<f64>,
    calibrate: Option<(f64, Vec<String>)>,
    out: &std::path::Path,
    json: bool,
    validate: bool,
) -> Result<Outcome, CliError> {
    if let Some((level, others)) = &calibrate {
        check_level(*level)?;
        if !others.is_empty() {
            return Err(crate::bad_input(
                "--structures names polynomial sets of an ensemble; the sparse GP is calibrated on its own posterior draws: drop --structures",
            ));
        }
    }
    let ds = Dataset::load(dataset)?;
    warn_window_clipped(&ds, recordings, window);
    let threshold = similarity.unwrap_or(DEFAULT_SIMILARITY);
    let (mut file, model, mut report) = fit_gp_dataset(&ds, recordings, window, threshold)?;
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    if let Some((level, _)) = calibrate {
        use shipid_pipeline::bands::{GP_DRAW_SEED, GP_DRAWS};
        use shipid_pipeline::calibration::{GpFamily, calibrate_fit, factor_calibration_record};
        let family = GpFamily {
            window,
            similarity: threshold,
            draws: GP_DRAWS,
            seed: GP_DRAW_SEED,
        };
        let chosen = calibration_recordings(&ds, recordings);
        let bar = calibrating(level, " over posterior draws");
        let c = family
            .bands_of(&ds, model, &chosen)
            .and_then(|fitted| calibrate_fit(fitted.source(), &family, &ds, &chosen, level));
        bar.finish_and_clear();
        let c = c?;
        let record = factor_calibration_record(&c, GP_DRAWS, GP_DRAW_SEED);
        report_calibration(
            level,
            &format!("sparse-GP posterior draws ({GP_DRAWS} per refit)"),
            c.folds,
            &record.factors,
            record.out_of_kind.as_ref(),
        );
        file.calibration = within_factor_cap(&record.factors).then_some(record);
    }
    report
        .warnings
        .extend(training_warnings(&ds, recordings, validate, false));
    shipid_pipeline::model_file::anchor_training(&mut file.training, out);
    let text = with_environment_table(model_text(&file).map_err(failed)?, &ds, recordings)?;
    write_atomic(out, text.as_bytes()).map_err(|e| crate::not_saved(out, e, "the fitted model"))?;
    let extent = StateExtent::of_windows(&ds, &file.training);
    if json {
        let mut value = serde_json::to_value(&report).unwrap_or_default();
        if let (Value::Object(o), Some(e)) = (&mut value, &extent) {
            o.insert("training_extent".into(), json!(e));
        }
        return emit_json(value, validate.then_some((out, &ds)));
    } else {
        println!(
            "sparse GP: kept {} of {} samples (d_gen {threshold}) in {:.1} ms; trained 3 GPs in {:.3} s → {}",
            report.kept,
            report.candidates,
            report.sparsify_time_s * 1e3,
            report.train_time_s,
            out.display()
        );
        for o in &report.outputs {
            println!(
                "  {}: log marginal likelihood {:.1}, {} iterations, {:.3} s, RMS residual over all training samples {:.3e} (target RMS {:.3e})",
                o.name,
                o.log_marginal_likelihood,
                o.iterations,
                o.train_time_s,
                o.rms_residual_all_samples,
                o.target_rms
            );
        }
        print_training_extent(extent.as_ref());
    }
    if validate {
        let spec = out.to_string_lossy();
        let model = load_model(&spec)?;
        return Ok(crate::print::validation(model.as_ref(), &spec, &ds, json));
    }
    Ok(Outcome::Ok)
}

/// A `--window` reaching beyond a training recording is fitted on the part inside it: said, with
/// the span actually used, so a typo (`0:10000`, `-50:100`) is not taken for the window asked. A
/// window missing a recording altogether is the fit's to refuse.
fn warn_window_clipped(ds: &Dataset, recordings: &[String], window: WindowSpec) {
    let WindowSpec::Time { start_s, end_s } = window else {
        return;
    };
    for r in ds
        .recordings
        .iter()
        .filter(|r| recordings.is_empty() || recordings.contains(&r.file))
    {
        let (Some(&a), Some(&b)) = (r.recording.t.first(), r.recording.t.last()) else {
            continue;
        };
        if (start_s < a || end_s > b) && start_s < b && end_s > a {
            eprintln!(
                "warning: --window {start_s}:{end_s} s reaches beyond {} ({a}–{b} s): fitted on {}–{} s",
                r.file,
                start_s.max(a),
                end_s.min(b)
            );
        }
    }
}

/// The extent of the states the model was identified on, below a fit's summary: what a manoeuvre must
/// stay within not to be an extrapolation (`simulate` says how far one goes beyond).
fn print_training_extent(extent: Option<&StateExtent>) {
    if let Some(e) = extent {
        println!(
            "  identified on: drift ≤ {:.1}°, r′ ≤ {:.2}, rudder ≤ {:.1}°, speed ≥ {:.2} U0 (beyond these, or in combinations the training did not visit, a prediction extrapolates: simulate says how much)",
            e.max_drift_deg, e.max_yaw_rate_prime, e.max_rudder_deg, e.min_speed_over_u0
        );
    }
}

/// A spinner on stderr saying what runs and for how long (indicatif draws it only on a terminal):
/// bootstraps and calibrations take from a second to a minute with no other output meanwhile.
fn working(what: String) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new_spinner();
    bar.set_style(
        indicatif::ProgressStyle::with_template("{spinner} {msg}  elapsed {elapsed}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
    );
    bar.set_message(what);
    bar.enable_steady_tick(std::time::Duration::from_millis(200));
    bar
}

/// The spinner of a calibration at `level` (`over`: over what the replicates are, or empty).
fn calibrating(level: f64, over: &str) -> indicatif::ProgressBar {
    working(format!(
        "calibration at {level}: training recordings re-simulated{over}, each refit without it"
    ))
}

/// How the equation-error samples were thinned, for the fit's summary line: every k-th of the
/// training windows' usable samples once they are more than the fit keeps (docs/mmg.md), which a
/// long record with a short transient feels (its transient keeps few samples).
fn thinned_from(kept: usize, available: usize) -> String {
    if available > kept {
        format!(
            " (one in {} of the {available} usable samples: the fit keeps at most {})",
            available.div_ceil(kept.max(1)),
            shipid_pipeline::mmg::MAX_SAMPLES
        )
    } else {
        String::new()
    }
}

/// Whether a calibration's factors are within what a model file may hold: one beyond the cap would
/// make the file unreadable (the loader refuses it as damaged), so the calibration is left out with a
/// warning and the rest of the fit, its replicates included, is kept.
fn within_factor_cap(
    factors: &std::collections::BTreeMap<String, shipid_model::FactorRecord>,
) -> bool {
    match shipid_pipeline::metric_family::factor_beyond_cap(
        factors.iter().map(|(family, f)| (family, f.factor)),
    ) {
        None => true,
        Some((family, factor)) => {
            eprintln!(
                "warning: the calibration is left out of the model file: its {family} factor {} is beyond the {} a band may be widened by (measured factors are 1–23): such a band says nothing; the model keeps its replicates, and --bands gives their raw band",
                shipid_io::error::number(factor),
                shipid_pipeline::metric_family::MAX_CALIBRATION_FACTOR
            );
            false
        }
    }
}
