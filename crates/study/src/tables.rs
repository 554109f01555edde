//! The result tables of a study run: `summary` (one row per case × test), `coefficients` and
//! `diagnostics` (long tables, one row per case × DOF × term × quantity). Every row carries the columns
//! that tell its case apart (case id, set, estimator, hyper-parameters, training).

use std::collections::BTreeSet;
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
            percent_cell(x)
        } else {
            significant(x)
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
/// have (another study, or an older version of this one, wrote it), a case of the study missing,
/// other tests than the study's, or `cases/` holding other results than the summary
/// ([`check_cases_are_of_the_summary`]). `shipid table` and `shipid plot` check it before showing
/// anything under the study's name.
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
    let shown: BTreeSet<String> = (0..summary.rows()).map(|i| col.cell(i)).collect();
    let known: BTreeSet<&str> = study.cases.iter().map(|c| c.id.as_str()).collect();
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
    // Case ids do not hold the test list: a study whose `[test]` changed since the run has the
    // same cases and other tests.
    if let Some(test) = summary.column("test") {
        let stored: BTreeSet<String> = (0..summary.rows())
            .map(|i| test.cell(i))
            .filter(|t| !t.is_empty())
            .collect();
        let wanted: BTreeSet<String> = study.tests.iter().cloned().collect();
        // A run whose every fit failed has no test rows at all: nothing to compare.
        if !stored.is_empty() && stored != wanted {
            let list = |v: Vec<&String>| {
                v.iter()
                    .take(3)
                    .map(|t| format!("`{t}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            let extra: Vec<&String> = stored.difference(&wanted).collect();
            let lacking: Vec<&String> = wanted.difference(&stored).collect();
            let mut parts = Vec::new();
            if !extra.is_empty() {
                parts.push(format!(
                    "tests {} that the study does not test",
                    list(extra)
                ));
            }
            if !lacking.is_empty() {
                parts.push(format!("no rows of the study's tests {}", list(lacking)));
            }
            return Err(refuse(format!(
                "holds {} (the `[test]` list of {} changed since the run): {run_first}",
                parts.join(" and "),
                study.path.display()
            )));
        }
    }
    check_cases_are_of_the_summary(study, out, &summary, &path, &run_first)
}

/// Refuses a folder whose `cases/` no longer holds what `summary.csv` was made from: a case's
/// stored configuration that is not this study's (an interrupted run of a changed study rewrote
/// it), or a `result.json` whose tests or MRAEs are not the summary's rows of its case (a rerun
/// stopped before its tables). The shipid version a case names is left out of the comparison: the
/// report warns of that one. Contents are compared, not times: a fresh clone of a results folder
/// has its files' times in checkout order.
fn check_cases_are_of_the_summary(
    study: &Study,
    out: &Path,
    summary: &Table,
    summary_path: &Path,
    run_first: &str,
) -> Result<(), StudyError> {
    let refuse = |message: String| StudyError::NotThisStudy {
        path: summary_path.to_path_buf(),
        message,
    };
    let without_version = |text: &str| {
        toml::from_str::<toml::Table>(text).ok().map(|mut t| {
            t.remove("shipid_version");
            t
        })
    };
    let rows = summary_rows_by_case(summary);
    for case in &study.cases {
        let dir = out.join("cases").join(&case.id);
        let config = dir.join("config.toml");
        if let (Ok(stored), Ok(resolved)) = (
            std::fs::read_to_string(&config),
            crate::runner::stored_config(study, case),
        ) && without_version(&stored) != without_version(&resolved)
        {
            return Err(refuse(format!(
                "{} is of another configuration than {} (a run of a changed study, interrupted \
                 before its tables?): the summary is not this study's results; {run_first}",
                config.display(),
                study.path.display()
            )));
        }
        let result = dir.join("result.json");
        let Some(stored) = std::fs::read(&result)
            .ok()
            .and_then(|b| serde_json::from_slice::<CaseResult>(&b).ok())
        else {
            continue;
        };
        let from_result: Vec<(String, Option<f64>)> = if stored.tests.is_empty() {
            vec![(String::new(), None)]
        } else {
            stored
                .tests
                .iter()
                .map(|t| (t.test.clone(), t.mrae))
                .collect()
        };
        let shown = rows.get(case.id.as_str()).cloned().unwrap_or_default();
        if !same_rows(&from_result, &shown) {
            return Err(refuse(format!(
                "{} holds other results than the summary's rows of its case (a rerun stopped \
                 before its tables?); {run_first}",
                result.display()
            )));
        }
    }
    Ok(())
}

/// Each case's (test, mrae) rows of a summary, in order.
fn summary_rows_by_case(
    summary: &Table,
) -> std::collections::BTreeMap<String, Vec<(String, Option<f64>)>> {
    let mut by_case: std::collections::BTreeMap<String, Vec<(String, Option<f64>)>> =
        Default::default();
    let (Some(case), Some(test)) = (summary.column("case"), summary.column("test")) else {
        return by_case;
    };
    let mrae = summary.column("mrae");
    for i in 0..summary.rows() {
        let m = mrae.and_then(|c| c.cell(i).parse::<f64>().ok());
        by_case
            .entry(case.cell(i))
            .or_default()
            .push((test.cell(i), m));
    }
    by_case
}

/// The same tests with the same MRAEs (to the last bits a CSV round trip may change).
fn same_rows(a: &[(String, Option<f64>)], b: &[(String, Option<f64>)]) -> bool {
    a.len() == b.len()
        && a.iter().zip(b).all(|((ta, ma), (tb, mb))| {
            ta == tb
                && match (ma, mb) {
                    (Some(x), Some(y)) => (x - y).abs() <= 1e-12 * x.abs().max(y.abs()),
                    (None, None) => true,
                    _ => false,
                }
        })
}

/// `[check]`'s tolerances name columns of the compared tables (summary and coefficients): a
/// misspelt key (`mrea`, `MRAE`) would leave its column at the default tolerance without a word.
/// Text columns (`case`, `test`) are compared exactly, so a tolerance for one is refused too.
pub fn check_tolerance_columns(study: &Study) -> Result<(), StudyError> {
    let summary = summary_table(study, &[]);
    let coefficients = coefficients_table(study, &[]);
    let numeric: BTreeSet<&str> = summary
        .columns
        .iter()
        .chain(&coefficients.columns)
        .filter(|(n, c)| matches!(c, shipid_tables::Column::Num(_)) && n != "fit_time_s")
        .map(|(n, _)| n.as_str())
        .collect();
    for column in study.check.keys() {
        if !numeric.contains(column.as_str()) {
            let near: Vec<&&str> = numeric
                .iter()
                .filter(|n| n.eq_ignore_ascii_case(column) || strsim_close(n, column))
                .collect();
            let hint = near
                .first()
                .map(|n| format!(" (did you mean `{n}`?)"))
                .unwrap_or_default();
            return Err(StudyError::Input(shipid_io::InputError::key(
                &study.path,
                format!("check.{column}"),
                format!(
                    "no numeric column `{column}` in the summary or coefficients table{hint}; \
                     tolerances apply to {}",
                    numeric.iter().copied().collect::<Vec<_>>().join(", ")
                ),
            )));
        }
    }
    Ok(())
}

/// Two names one letter apart or with two letters swapped (`mrea` for `mrae`).
fn strsim_close(a: &str, b: &str) -> bool {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    if a.len() != b.len() {
        return false;
    }
    let differ: Vec<usize> = (0..a.len()).filter(|&i| a[i] != b[i]).collect();
    match differ.as_slice() {
        [_] => true,
        [i, j] => *j == i + 1 && a[*i] == b[*j] && a[*j] == b[*i],
        _ => false,
    }
}

/// A table cell of `x` to four significant digits: four fixed decimals showed λ = 1e-8 and 1e-6
/// both as 0.0000 and a fit time of 9.7e-5 s as 0.0001. Scientific below 1e-3 and from 1e6 on,
/// where fixed decimals would need many zeros.
pub fn significant(x: f64) -> String {
    let a = x.abs();
    if x == 0.0 {
        "0".into()
    } else if !x.is_finite() {
        format!("{x}")
    } else if !(1e-3..1e6).contains(&a) {
        format!("{x:.3e}")
    } else {
        // Rounding to four digits may carry into a fifth (9999.5 → 10000): then one decimal fewer.
        let magnitude = a.log10().floor() as i32;
        let decimals = (3 - magnitude).max(0) as usize;
        let text = format!("{x:.decimals$}");
        let digits = text.chars().filter(char::is_ascii_digit).count();
        let leading_zeros = text
            .trim_start_matches('-')
            .chars()
            .take_while(|&c| c == '0' || c == '.')
            .filter(|&c| c == '0')
            .count();
        if digits - leading_zeros > 4 && decimals > 0 {
            format!("{x:.prec$}", prec = decimals - 1)
        } else {
            text
        }
    }
}

/// A relative error or MRAE as a percentage to one decimal; one that small rounds to 0.0 %, so a
/// non-zero value under 0.05 % is given to four significant digits instead.
fn percent_cell(x: f64) -> String {
    let p = 100.0 * x;
    if p != 0.0 && p.abs() < 0.05 {
        format!("{} %", significant(p))
    } else {
        format!("{p:.1} %")
    }
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
                    format!("[{}, {}]{side}", significant(l), significant(h))
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression: `shipid table` printed every value with four fixed decimals, so λ = 1e-8 and
    /// 1e-6 both read 0.0000 and a fit time of 9.7e-5 s read 0.0001.
    #[test]
    fn small_values_keep_four_significant_digits_in_a_table() {
        for (x, cell) in [
            (1e-8, "1.000e-8"),
            (1e-6, "1.000e-6"),
            (9.7e-5, "9.700e-5"),
            (-2.5e-4, "-2.500e-4"),
            (0.0, "0"),
            (0.001, "0.001000"),
            (0.12345, "0.1235"),
            (2.5, "2.500"),
            (11.25, "11.25"),
            (-11.25, "-11.25"),
            (123.456, "123.5"),
            (9999.6, "10000"),
            (99.996, "100.0"),
            (123456.0, "123456"),
            (1e6, "1.000e6"),
            (f64::NAN, "NaN"),
        ] {
            assert_eq!(significant(x), cell, "{x}");
        }
        assert_eq!(percent_cell(0.109), "10.9 %");
        assert_eq!(percent_cell(1e-8), "1.000e-6 %");
        assert_eq!(percent_cell(0.0), "0.0 %");
    }
}
