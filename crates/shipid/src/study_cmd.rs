//! `shipid run`, `shipid table` and `shipid check`: studies end to end.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use shipid_tables::{Table, Tolerance, compare};

use crate::runner::{CaseResult, default_out, run_study};
use crate::study::{Case, Study, load_study};
use crate::{CliError, Outcome, bad_input, failed};

const METRIC_KEYS: [&str; 8] = [
    "overshoot_1",
    "overshoot_2",
    "t_a",
    "t_check",
    "advance",
    "transfer",
    "tactical_diameter",
    "steady_diameter",
];

fn case_columns(t: &mut Table, rows: &[(&Case, &CaseResult)]) {
    let text = |f: &dyn Fn(&Case, &CaseResult) -> String| {
        rows.iter().map(|(c, r)| f(c, r)).collect::<Vec<_>>()
    };
    t.push_text("case", text(&|c, _| c.id.clone()));
    t.push_text("set", text(&|c, _| c.set.clone()));
    // A refined fit is another estimator for every reader of the tables ("lsq-oe", as in its case id).
    t.push_text(
        "estimator",
        text(&|c, _| {
            let e = &c.estimator;
            format!("{}{}", e.name, if e.refine { "-oe" } else { "" })
        }),
    );
    t.push_text("solver", text(&|c, _| c.solver.clone()));
    t.push_text("training", text(&|c, _| c.training.join("+")));
    t.push_text("window", text(&|c, _| c.window.label()));
    let num = |f: &dyn Fn(&Case, &CaseResult) -> Option<f64>| {
        rows.iter().map(|(c, r)| f(c, r)).collect::<Vec<_>>()
    };
    t.push_num(
        "overshoots",
        num(&|c, _| match c.window {
            crate::fit::WindowSpec::Overshoots(n) => Some(n as f64),
            _ => None,
        }),
    );
    t.push_text("tuned", text(&|c, _| c.estimator.tune.to_string()));
    // One column per DOF: the value of its fit, else what the case gave (a failed case has no fits).
    let per_dof = |t: &mut Table,
                   prefix: &str,
                   fitted: &dyn Fn(&crate::runner::DofSummary) -> Option<f64>,
                   given: &dyn Fn(&Case) -> Option<f64>| {
        for (key, dof) in [("X", 0usize), ("Y", 1), ("N", 2)] {
            t.push_num(
                &format!("{prefix}_{key}"),
                num(&|c, r| r.dofs.get(dof).and_then(fitted).or_else(|| given(c))),
            );
        }
    };
    per_dof(t, "hyper", &|d| d.hyper_parameter, &|c| {
        let e = &c.estimator;
        e.lambda.or(e.alpha).or(e.c).or(e.similarity)
    });
    // The SVR's second hyper-parameter (hyper_* holds its C): tuned per DOF unless given.
    per_dof(t, "epsilon", &|d| d.epsilon, &|c| c.estimator.epsilon);
    t.push_text("case_status", text(&|_, r| r.status.clone()));
    t.push_num("fit_time_s", num(&|_, r| r.fit_time_s));
}

/// One row per case × test.
pub fn summary_table(study: &Study, results: &[CaseResult]) -> Table {
    let mut rows: Vec<(&Case, &CaseResult, Option<&crate::runner::TestRow>)> = Vec::new();
    for (c, r) in study.cases.iter().zip(results) {
        if r.tests.is_empty() {
            rows.push((c, r, None));
        }
        for t in &r.tests {
            rows.push((c, r, Some(t)));
        }
    }
    let mut t = Table::default();
    let pairs: Vec<(&Case, &CaseResult)> = rows.iter().map(|(c, r, _)| (*c, *r)).collect();
    case_columns(&mut t, &pairs);
    let text = |f: &dyn Fn(&crate::runner::TestRow) -> String| {
        rows.iter()
            .map(|(_, _, x)| x.map(f).unwrap_or_default())
            .collect()
    };
    let num = |f: &dyn Fn(&crate::runner::TestRow) -> Option<f64>| {
        rows.iter().map(|(_, _, x)| x.and_then(f)).collect()
    };
    t.push_text("test", text(&|x| x.test.clone()));
    t.push_text("kind", text(&|x| x.kind.clone()));
    t.push_text("status", text(&|x| x.status.clone()));
    t.push_num("diverged_at_s", num(&|x| x.diverged_at_s));
    t.push_text("replay_status", text(&|x| x.replay_status.clone()));
    t.push_num(
        "position_rmse_over_l",
        num(&|x| Some(x.position_rmse_over_l)),
    );
    t.push_num("heading_rmse_deg", num(&|x| Some(x.heading_rmse_deg)));
    t.push_num("u_rmse_m_s", num(&|x| Some(x.u_rmse_m_s)));
    t.push_num("v_rmse_m_s", num(&|x| Some(x.v_rmse_m_s)));
    t.push_num("r_rmse_deg_s", num(&|x| Some(x.r_rmse_deg_s)));
    t.push_num(
        "outside_identification_range",
        num(&|x| x.outside_identification_range),
    );
    for (i, key) in METRIC_KEYS.iter().enumerate() {
        t.push_num(
            &format!("{key}_recorded"),
            num(&|x| x.recorded.entries()[i].1),
        );
        t.push_num(
            &format!("{key}_predicted"),
            num(&|x| x.predicted.and_then(|p| p.entries()[i].1)),
        );
        t.push_num(
            &format!("{key}_rel_error"),
            num(&|x| x.relative_error.get(*key).copied()),
        );
    }
    t.push_num("mrae", num(&|x| x.mrae));
    t
}

/// Long format: case, DOF, term, value.
pub fn coefficients_table(study: &Study, results: &[CaseResult]) -> Table {
    long_table(study, results, |r| {
        r.coefficients
            .iter()
            .map(|c| (c.dof.clone(), c.term.clone(), "coefficient".into(), c.value))
            .collect()
    })
}

/// Long format: VIF per term, condition numbers and residual RMS per DOF.
pub fn diagnostics_table(study: &Study, results: &[CaseResult]) -> Table {
    long_table(study, results, |r| {
        let mut v: Vec<(String, String, String, Option<f64>)> = r
            .vif
            .iter()
            .map(|c| (c.dof.clone(), c.term.clone(), "vif".into(), c.value))
            .collect();
        for d in &r.dofs {
            v.push((
                d.dof.clone(),
                String::new(),
                "condition_number".into(),
                d.condition_number,
            ));
            v.push((
                d.dof.clone(),
                String::new(),
                "scaled_condition_number".into(),
                d.scaled_condition_number,
            ));
            v.push((
                d.dof.clone(),
                String::new(),
                "residual_rms".into(),
                Some(d.residual_rms),
            ));
        }
        v
    })
}

type LongRow = (String, String, String, Option<f64>);

fn long_table(
    study: &Study,
    results: &[CaseResult],
    rows_of: impl Fn(&CaseResult) -> Vec<LongRow>,
) -> Table {
    let mut pairs = Vec::new();
    let mut long = Vec::new();
    for (c, r) in study.cases.iter().zip(results) {
        for row in rows_of(r) {
            pairs.push((c, r));
            long.push(row);
        }
    }
    let mut t = Table::default();
    case_columns(&mut t, &pairs);
    t.push_text("dof", long.iter().map(|r| r.0.clone()).collect());
    t.push_text("term", long.iter().map(|r| r.1.clone()).collect());
    t.push_text("quantity", long.iter().map(|r| r.2.clone()).collect());
    t.push_num("value", long.iter().map(|r| r.3).collect());
    t
}

/// Run a study and write its tables; returns the results.
pub fn run_and_write(
    study: &Study,
    out: &Path,
    jobs: usize,
    force: bool,
    progress: bool,
) -> Result<Vec<CaseResult>, CliError> {
    let results = run_study(study, out, jobs, force, progress).map_err(failed)?;
    summary_table(study, &results)
        .write(out, "summary")
        .map_err(failed)?;
    coefficients_table(study, &results)
        .write(out, "coefficients")
        .map_err(failed)?;
    diagnostics_table(study, &results)
        .write(out, "diagnostics")
        .map_err(failed)?;
    // Figures are a convenience: one that cannot be drawn is a warning, never a failed run.
    for w in crate::plot::write_figures(study, out).warnings {
        eprintln!("warning: {w}");
    }
    Ok(results)
}

pub fn run(
    study_path: &Path,
    out: Option<&Path>,
    jobs: usize,
    force: bool,
) -> Result<Outcome, CliError> {
    let study = load_study(study_path)?;
    let out = out
        .map(PathBuf::from)
        .unwrap_or_else(|| default_out(&study));
    let started = std::time::Instant::now();
    let results = run_and_write(&study, &out, jobs, force, true)?;
    let n_failed = results.iter().filter(|r| r.failed()).count();
    eprintln!(
        "{}: {} cases ({} with a failed fit or a diverged test) in {:.1} s with {jobs} job(s); tables in {}",
        study.name,
        results.len(),
        n_failed,
        started.elapsed().as_secs_f64(),
        out.display()
    );
    Ok(if n_failed > 0 {
        Outcome::SomeFailed
    } else {
        Outcome::Ok
    })
}

/// `shipid table STUDY.toml [--pivot ROWS,COLS,VALUE]`: a markdown comparison table from `summary.csv`.
pub fn table(study_path: &Path, out: Option<&Path>, pivot: &str) -> Result<Outcome, CliError> {
    let study = load_study(study_path)?;
    let dir = out
        .map(PathBuf::from)
        .unwrap_or_else(|| default_out(&study));
    let path = dir.join("summary.csv");
    if !path.is_file() {
        return Err(bad_input(format!(
            "{} not found: run `shipid run {}` first",
            path.display(),
            study_path.display()
        )));
    }
    let parts: Vec<&str> = pivot.split(',').map(str::trim).collect();
    let [rows, cols, value] = parts.as_slice() else {
        return Err(bad_input(format!(
            "--pivot `{pivot}`: expected ROWS,COLS,VALUE, e.g. window,test,mrae"
        )));
    };
    let t = Table::read_csv(&path).map_err(failed)?;
    let percent = value.ends_with("mrae") || value.ends_with("rel_error");
    let md = t
        .pivot_markdown(rows, cols, value, |x| {
            if percent {
                format!("{:.1} %", 100.0 * x)
            } else {
                format!("{x:.4}")
            }
        })
        .map_err(|e| bad_input(format!("--pivot: {e} in {}", path.display())))?;
    println!("{md}");
    Ok(Outcome::Ok)
}

/// Tolerances of `shipid check`: timings are ignored, everything else is compared to 1e-8 absolute plus
/// 1e-5 relative unless the study's `[check]` table says otherwise.
pub const DEFAULT_TOLERANCE: Tolerance = Tolerance {
    abs: 1e-8,
    rel: 1e-5,
};

pub fn check(
    study_path: &Path,
    reference: &Path,
    bless: bool,
    jobs: usize,
) -> Result<Outcome, CliError> {
    let study = load_study(study_path)?;
    let fresh_dir = tempfile_dir(&study)?;
    let results = run_and_write(&study, &fresh_dir, jobs, true, false)?;
    let mut per_column: BTreeMap<String, Option<Tolerance>> =
        BTreeMap::from([("fit_time_s".to_string(), None)]);
    for (k, t) in &study.check {
        per_column.insert(
            k.clone(),
            Some(Tolerance {
                abs: t.abs,
                rel: t.rel,
            }),
        );
    }
    if bless {
        std::fs::create_dir_all(reference).map_err(failed)?;
        for stem in ["summary", "coefficients", "diagnostics"] {
            for ext in ["csv", "parquet"] {
                let name = format!("{stem}.{ext}");
                std::fs::copy(fresh_dir.join(&name), reference.join(&name)).map_err(failed)?;
            }
        }
        eprintln!(
            "blessed {} as the reference of {} ({} cases)",
            reference.display(),
            study.name,
            results.len()
        );
        let _ = std::fs::remove_dir_all(&fresh_dir);
        return Ok(Outcome::Ok);
    }
    let mut all = Vec::new();
    for stem in ["summary", "coefficients"] {
        let reference_path = reference.join(format!("{stem}.csv"));
        if !reference_path.is_file() {
            return Err(bad_input(format!(
                "{} not found (create it with --bless)",
                reference_path.display()
            )));
        }
        let r = Table::read_csv(&reference_path).map_err(failed)?;
        let f = Table::read_csv(&fresh_dir.join(format!("{stem}.csv"))).map_err(failed)?;
        all.extend(
            compare(&f, &r, &per_column, DEFAULT_TOLERANCE)
                .into_iter()
                .map(|d| format!("{stem}: {d}")),
        );
    }
    let _ = std::fs::remove_dir_all(&fresh_dir);
    if all.is_empty() {
        eprintln!(
            "{}: {} cases match the reference {}",
            study.name,
            results.len(),
            reference.display()
        );
        Ok(Outcome::Ok)
    } else {
        for d in all.iter().take(50) {
            println!("{d}");
        }
        if all.len() > 50 {
            println!("… and {} more differences", all.len() - 50);
        }
        eprintln!(
            "{}: {} differences from the reference {}",
            study.name,
            all.len(),
            reference.display()
        );
        Ok(Outcome::SomeFailed)
    }
}

fn tempfile_dir(study: &Study) -> Result<PathBuf, CliError> {
    let dir = std::env::temp_dir().join(format!(
        "shipid-check-{}-{}",
        study.name,
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).map_err(failed)?;
    Ok(dir)
}
