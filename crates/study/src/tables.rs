//! The result tables of a study run: `summary` (one row per case × test), `coefficients` and
//! `diagnostics` (long tables, one row per case × DOF × term × quantity). Every row carries the columns
//! that tell its case apart (case id, set, estimator, hyper-parameters, training).

use std::path::Path;

use shipid_tables::{Pivot, Table, TableError};

use crate::error::StudyError;
use crate::runner::CaseResult;
use crate::study::{Case, Study};

/// Writes the three tables of a run into `out` (`<stem>.csv` and `<stem>.parquet` each).
pub fn write_tables(study: &Study, results: &[CaseResult], out: &Path) -> Result<(), StudyError> {
    for (stem, table) in [
        ("summary", summary_table(study, results)),
        ("coefficients", coefficients_table(study, results)),
        ("diagnostics", diagnostics_table(study, results)),
    ] {
        table.write(out, stem).map_err(|e| StudyError::Table {
            path: out.join(format!("{stem}.csv")),
            message: e.to_string(),
        })?;
    }
    Ok(())
}

/// `shipid table`'s pivot when none is given: the test's MRAE per window, with the columns that tell
/// the study's cases apart added to the rows.
pub const DEFAULT_PIVOT: &str = "window,test,mrae";

/// The summary's columns that tell cases apart, in the order a default pivot adds them to its rows
/// (each only if it splits cases that would otherwise share a cell); the case id is the last resort.
pub const CASE_COLUMNS: [&str; 13] = [
    "set",
    "estimator",
    "solver",
    "training",
    "window",
    "tuned",
    "hyper_X",
    "hyper_Y",
    "hyper_N",
    "epsilon_X",
    "epsilon_Y",
    "epsilon_N",
    "case",
];

/// A markdown pivot of a summary table. `None`: [`DEFAULT_PIVOT`] with the case columns it needs
/// added to its rows, so every case × test has its own cell. A given pivot is used as written and
/// refused when it would put two cases in one cell (the error names them).
///
/// A value `<metric>_band` (a study with bands) shows each cell as `[lo, hi]` and whether the
/// recorded value lies inside: one column made of `<metric>_lo`, `_hi` and `_inside`.
pub fn summary_pivot(summary: &Table, pivot: Option<&str>) -> Result<String, TableError> {
    let mut p: Pivot = pivot.unwrap_or(DEFAULT_PIVOT).parse()?;
    let with_band;
    let summary = match band_cells(summary, &p.value) {
        Some(column) => {
            let mut t = summary.clone();
            t.push_text(&p.value, column);
            with_band = t;
            &with_band
        }
        None => summary,
    };
    if pivot.is_none() {
        p.rows = separated_rows(summary, &p)?;
    }
    let percent = p.value.ends_with("mrae") || p.value.ends_with("rel_error");
    let mut md = summary.pivot_markdown(&p, "case", |x| {
        if percent {
            format!("{:.1} %", 100.0 * x)
        } else {
            format!("{x:.4}")
        }
    })?;
    // A case without test rows has a row of empty cells: say why, so they do not read as missing
    // values (a "–" is a diverged prediction).
    if let (Some(test), Some(case), Some(status)) = (
        summary.column("test"),
        summary.column("case"),
        summary.column("case_status"),
    ) {
        for i in (0..summary.rows()).filter(|&i| test.cell(i).is_empty()) {
            md.push_str(&format!(
                "\n{}: {}, no test results (cases/{}/result.json says why)\n",
                case.cell(i),
                status.cell(i),
                case.cell(i)
            ));
        }
    }
    Ok(md)
}

/// Refuses an output folder whose `summary.csv` is not this study's run: a case the study does not
/// have (another study, or an older version of this one, wrote it) or a case of the study missing.
/// `shipid table` and `shipid plot` check it before showing anything under the study's name.
pub fn check_output_of(study: &Study, out: &Path) -> Result<(), StudyError> {
    let path = out.join("summary.csv");
    let refuse = |message: String| StudyError::NotThisStudy {
        path: path.clone(),
        message,
    };
    if !path.is_file() {
        return Err(refuse(format!(
            "not found: run `shipid run {}` first",
            study.path.display()
        )));
    }
    let summary = Table::read_csv(&path).map_err(|e| refuse(e.to_string()))?;
    let Some(col) = summary.column("case") else {
        return Err(refuse(
            "no `case` column: not a summary written by shipid run".into(),
        ));
    };
    let shown: std::collections::BTreeSet<String> =
        (0..summary.rows()).map(|i| col.cell(i)).collect();
    let known: std::collections::BTreeSet<&str> =
        study.cases.iter().map(|c| c.id.as_str()).collect();
    let run_first = format!("run `shipid run {}` first", study.path.display());
    let foreign: Vec<&String> = shown
        .iter()
        .filter(|id| !known.contains(id.as_str()))
        .collect();
    if let Some(first) = foreign.first() {
        return Err(refuse(format!(
            "{} case(s) are not cases of {} (e.g. {first}): written by another study or an older \
             version of it; {run_first}",
            foreign.len(),
            study.path.display()
        )));
    }
    let missing: Vec<&&str> = known.iter().filter(|id| !shown.contains(**id)).collect();
    if let Some(first) = missing.first() {
        return Err(refuse(format!(
            "lacks {} of the {} cases of {} (e.g. {first}): {run_first}",
            missing.len(),
            known.len(),
            study.path.display()
        )));
    }
    Ok(())
}

/// The cells of a `<metric>_band` value, when the summary has that metric's band columns and no
/// column of that name: `[lo, hi] inside`, `[lo, hi] outside`, `[lo, hi]` without a recorded value,
/// or empty without a band.
fn band_cells(summary: &Table, value: &str) -> Option<Vec<String>> {
    let metric = value.strip_suffix("_band")?;
    if summary.column(value).is_some() {
        return None;
    }
    let lo = summary.column(&format!("{metric}_lo"))?;
    let hi = summary.column(&format!("{metric}_hi"))?;
    let inside = summary.column(&format!("{metric}_inside"))?;
    let number = |c: &shipid_tables::Column, i: usize| c.cell(i).parse::<f64>().ok();
    Some(
        (0..summary.rows())
            .map(|i| match (number(lo, i), number(hi, i)) {
                (Some(l), Some(h)) => {
                    let side = match inside.cell(i).as_str() {
                        "yes" => " inside",
                        "no" => " outside",
                        _ => "",
                    };
                    format!("[{l:.4}, {h:.4}]{side}")
                }
                _ => String::new(),
            })
            .collect(),
    )
}

/// `pivot`'s rows with the case columns added that tell its cases apart: the set and the estimator
/// whenever the study varies them (a reader needs them to know what a row is), then each further
/// column only if it splits cases that would still share a cell.
pub fn separated_rows(summary: &Table, pivot: &Pivot) -> Result<Vec<String>, TableError> {
    let varies = |name: &str| {
        summary
            .column(name)
            .is_some_and(|c| (1..c.len()).any(|i| c.cell(i) != c.cell(0)))
    };
    let mut rows: Vec<String> = ["set", "estimator"]
        .into_iter()
        .filter(|n| varies(n) && !pivot.rows.iter().chain(&pivot.cols).any(|r| r == n))
        .map(String::from)
        .collect();
    rows.extend(pivot.rows.iter().cloned());
    let added = summary.separating_columns(&rows, &pivot.cols, "case", &CASE_COLUMNS)?;
    let given = rows.split_off(rows.len() - pivot.rows.len());
    Ok(rows.into_iter().chain(added).chain(given).collect())
}

pub const METRIC_KEYS: [&str; 8] = [
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
            shipid_pipeline::fit::WindowSpec::Overshoots(n) => Some(n as f64),
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
    t.push_text("case_status", text(&|_, r| r.status.as_str().to_string()));
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
    t.push_text("status", text(&|x| x.status.as_str().to_string()));
    t.push_num("diverged_at_s", num(&|x| x.diverged_at_s));
    t.push_text(
        "replay_status",
        text(&|x| x.replay_status.as_str().to_string()),
    );
    t.push_num("replay_diverged_at_s", num(&|x| x.replay_diverged_at_s));
    t.push_num(
        "position_rmse_over_l",
        num(&|x| x.rmse(x.position_rmse_over_l)),
    );
    t.push_num("heading_rmse_deg", num(&|x| x.rmse(x.heading_rmse_deg)));
    t.push_num("u_rmse_m_s", num(&|x| x.rmse(x.u_rmse_m_s)));
    t.push_num("v_rmse_m_s", num(&|x| x.rmse(x.v_rmse_m_s)));
    t.push_num("r_rmse_deg_s", num(&|x| x.rmse(x.r_rmse_deg_s)));
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
    if study.bands.is_some() {
        band_columns(&mut t, &rows);
    }
    t
}

/// `<metric>_lo`, `<metric>_hi` and `<metric>_inside` ("yes", "no"; empty where the metric has no
/// band or no recorded value) for every metric, after the point columns. Only studies with bands get
/// them, so the summaries (and `shipid check` references) of the others keep their columns.
fn band_columns(t: &mut Table, rows: &[(&Case, &CaseResult, Option<&crate::runner::TestRow>)]) {
    use crate::runner::MetricBandRow;
    for key in METRIC_KEYS {
        let band = |i: usize| match rows[i].2.and_then(|x| x.bands.get(key)) {
            Some(MetricBandRow::Band { lo, hi, inside }) => Some((*lo, *hi, *inside)),
            _ => None,
        };
        let n = rows.len();
        t.push_num(
            &format!("{key}_lo"),
            (0..n).map(|i| band(i).map(|b| b.0)).collect(),
        );
        t.push_num(
            &format!("{key}_hi"),
            (0..n).map(|i| band(i).map(|b| b.1)).collect(),
        );
        t.push_text(
            &format!("{key}_inside"),
            (0..n)
                .map(|i| match band(i).and_then(|b| b.2) {
                    Some(true) => "yes".into(),
                    Some(false) => "no".into(),
                    None => String::new(),
                })
                .collect(),
        );
    }
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
