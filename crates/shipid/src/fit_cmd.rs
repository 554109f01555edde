//! `shipid fit DATASET.toml --set S --estimator E [...] --out MODEL.toml [--json]`.

use std::path::Path;

use serde_json::{Value, json};
use shipid_estimators::Solver;
use shipid_io::Dataset;
use shipid_io::write::write_atomic;

use crate::fit::{EstimatorSpec, FitOutput, WindowSpec, fit_dataset, load_set};
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
}

/// How many of the largest VIFs the report lists per DOF.
const TOP_VIFS: usize = 5;

/// The `--json` report: fit time, residual RMS per DOF, condition numbers, the largest VIFs, status.
pub fn report_json(out: &FitOutput) -> Value {
    let mut dofs = serde_json::Map::new();
    for d in &out.dofs {
        let mut vifs: Vec<(&String, f64)> = d
            .names
            .iter()
            .zip(&d.vif)
            .filter_map(|(n, v)| v.map(|v| (n, v)))
            .collect();
        vifs.sort_by(|a, b| b.1.total_cmp(&a.1));
        let largest: serde_json::Map<String, Value> = vifs
            .iter()
            .take(TOP_VIFS)
            .map(|(n, v)| ((*n).clone(), json!(v)))
            .collect();
        dofs.insert(
            d.dof.to_string(),
            json!({
                "status": d.fit.status,
                "residual_rms": d.residual_rms,
                "target_rms": d.target_rms,
                "condition_number": d.condition_number,
                "scaled_condition_number": d.scaled_condition_number,
                "largest_vif": largest,
                "objective": d.fit.objective,
                "iterations": d.fit.iterations,
                "hyper_parameter": d.tuning.as_ref().map(|t| t.best),
                "epsilon": crate::fit::svr_epsilon(&d.fit.estimator),
            }),
        );
    }
    json!({
        "fit_time_s": out.fit_time_s,
        "samples": out.training.len(),
        "set": out.model.set.name,
        "estimator": out.file.estimator,
        "dofs": dofs,
    })
}

pub fn run(a: FitArgs<'_>) -> Result<Outcome, CliError> {
    a.estimator.validate()?;
    let set = load_set(a.set)?;
    let ds = Dataset::load(a.dataset)?;
    let out = fit_dataset(&ds, set, &a.estimator, &a.recordings, a.window, a.solver)?;
    let text = toml::to_string(&out.file).map_err(failed)?;
    let header = format!(
        "# Abkowitz model identified by shipid {}.\n# Coefficients: prime system I (DOMAIN.md §1) with U0 = {} m/s, L = {} m; midship; rudder positive to starboard.\n",
        env!("CARGO_PKG_VERSION"),
        ds.ship.u0,
        ds.ship.lpp
    );
    write_atomic(a.out, format!("{header}{text}").as_bytes()).map_err(failed)?;
    let all_solved = out.dofs.iter().all(|d| d.fit.status.is_solved());
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&report_json(&out)).unwrap_or_default()
        );
    } else {
        println!(
            "fitted {} with {} on {} samples in {:.2} ms → {}",
            out.model.set.name,
            out.file.estimator.name,
            out.training.len(),
            out.fit_time_s * 1e3,
            a.out.display()
        );
        for d in &out.dofs {
            println!(
                "  {}: status {:?}, residual RMS {:.3e} (target RMS {:.3e}), condition number {:.3e}",
                d.dof,
                d.fit.status,
                d.residual_rms,
                d.target_rms,
                d.condition_number.unwrap_or(f64::NAN)
            );
        }
    }
    let mut outcome = if all_solved {
        Outcome::Ok
    } else {
        Outcome::SomeFailed
    };
    if a.validate {
        let spec = a.out.to_string_lossy();
        if crate::validate_cmd::run(&spec, a.dataset, a.json)? == Outcome::SomeFailed {
            outcome = Outcome::SomeFailed;
        }
    }
    Ok(outcome)
}
