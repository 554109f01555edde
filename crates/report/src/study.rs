//! The page of a study output folder.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use serde_json::Value;

use crate::data::{Csv, figures_html, read_json_optional, read_text_optional, read_toml_optional};
use crate::html::{
    badge, cell, esc, facts, id_of, json_html, label, num, page, parse_num, status_class, th,
    toml_block, warnings_box,
};
use crate::{ReportError, RunMeta};

/// Test-level metrics whose median over a case's tests the summary table shows, when present.
const MEDIANS: [&str; 3] = ["position_rmse_over_l", "heading_rmse_deg", "mrae"];

struct Case {
    id: String,
    /// Indices of its rows in summary.csv.
    rows: Vec<usize>,
}

/// The HTML page of the study output folder `dir` (layout in the crate docs). `summary.csv` is
/// required; everything else is shown when present.
pub fn study_page(dir: &Path, meta: &RunMeta) -> Result<String, ReportError> {
    study_page_with_warnings(dir, meta).map(|(html, _)| html)
}

/// [`study_page`] and the warnings about the folder's provenance that the caller should print
/// (shown in the page too): results computed by another shipid version than the caller's
/// (`meta.tool_version`), as `run.json` or the cases' `config.toml` name it, and case files of
/// another run than `summary.csv`.
pub fn study_page_with_warnings(
    dir: &Path,
    meta: &RunMeta,
) -> Result<(String, Vec<String>), ReportError> {
    let summary = Csv::read(&dir.join("summary.csv"))?;
    let case_col = summary.case_col()?;
    let coefficients = Csv::read_optional(&dir.join("coefficients.csv"))?;
    let diagnostics = Csv::read_optional(&dir.join("diagnostics.csv"))?;
    let study = read_toml_optional(&dir.join("study.toml"))?;
    let run = read_json_optional(&dir.join("run.json"))?;
    let run_obj = run.as_ref().and_then(Value::as_object);
    let mut notes: Vec<String> = Vec::new();

    // Cases in the order of summary.csv. A case folder without a row is a leftover (an earlier run
    // into the folder with other grid values): shown as a case, it was counted among the run's.
    let mut cases: Vec<Case> = Vec::new();
    let mut index: BTreeMap<String, usize> = BTreeMap::new();
    for (i, r) in summary.rows.iter().enumerate() {
        let id = r.get(case_col).cloned().unwrap_or_default();
        let k = *index.entry(id.clone()).or_insert_with(|| {
            cases.push(Case {
                id,
                rows: Vec::new(),
            });
            cases.len() - 1
        });
        cases[k].rows.push(i);
    }
    let cases_dir = dir.join("cases");
    if let Ok(rd) = std::fs::read_dir(&cases_dir) {
        let mut extra: Vec<String> = rd
            .flatten()
            .filter(|e| e.path().is_dir())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|id| !index.contains_key(id))
            .collect();
        extra.sort();
        if let Some(first) = extra.first() {
            notes.push(format!(
                "{} folder(s) under cases/ have no row in summary.csv and are not cases of this run \
                 (left from an earlier run into this folder?), not shown: {first}{}",
                extra.len(),
                if extra.len() > 1 { ", …" } else { "" }
            ));
        }
    }

    // Per-case files.
    let mut configs = Vec::new();
    for c in &cases {
        let d = cases_dir.join(&c.id);
        let config = read_toml_optional(&d.join("config.toml"))?;
        let result = read_json_optional(&d.join("result.json"))?;
        let model = read_text_optional(&d.join("model.toml"))?;
        configs.push((config, result, model));
    }
    let first_config = configs.iter().find_map(|c| c.0.as_ref().map(|c| &c.1));

    // Columns: those before `test` describe the case, the others the test.
    let ncol = summary.headers.len();
    let case_cols: Vec<usize> = match summary.col("test") {
        Some(t) => (0..t).filter(|&j| j != case_col).collect(),
        None => (0..ncol)
            .filter(|&j| {
                j != case_col
                    && cases.iter().all(|c| {
                        c.rows
                            .windows(2)
                            .all(|w| summary.rows[w[0]][j] == summary.rows[w[1]][j])
                    })
            })
            .collect(),
    };
    let test_cols: Vec<usize> = (0..ncol)
        .filter(|j| *j != case_col && !case_cols.contains(j))
        .collect();
    let first_value = |c: &Case, j: usize| -> String {
        c.rows
            .first()
            .map(|&i| summary.rows[i][j].clone())
            .unwrap_or_default()
    };
    let with_rows: Vec<&Case> = cases.iter().filter(|c| !c.rows.is_empty()).collect();
    // Case columns with a value somewhere; those equal for every case go to one line above the table.
    let mut common: Vec<(String, String)> = Vec::new();
    let mut varying: Vec<usize> = Vec::new();
    for &j in &case_cols {
        let values: Vec<String> = with_rows.iter().map(|c| first_value(c, j)).collect();
        if values.iter().all(|v| v.trim().is_empty()) {
            continue;
        }
        let status_col = summary.headers[j] == "case_status";
        if with_rows.len() > 1 && !status_col && values.windows(2).all(|w| w[0] == w[1]) {
            common.push((summary.headers[j].clone(), values[0].clone()));
        } else {
            varying.push(j);
        }
    }
    let status_col = summary.col("case_status");
    let test_status_col = summary.col("status").filter(|j| test_cols.contains(j));
    let replay_status_col = summary
        .col("replay_status")
        .filter(|j| test_cols.contains(j));
    let test_name_col = summary.col("test");
    // A test's status as the run counts it: a replay that diverged is a diverged prediction even
    // when the closed-loop manoeuvre ran to its end (`shipid run`'s line and run.json say so).
    let test_status = |i: usize, j: usize| -> String {
        let replay = replay_status_col.map(|r| summary.rows[i][r].as_str());
        if replay == Some("diverged") {
            "diverged".to_string()
        } else {
            summary.rows[i][j].clone()
        }
    };
    // Case files of another run than the summary: a rerun (of a changed study) stopped before its
    // tables left the summary of the old run beside the new cases' files. Contents are compared,
    // not file times (a fresh clone has its files' times in checkout order).
    let mrae_col = summary.col("mrae");
    // Returned to the caller too (`shipid report` prints them), as the version warnings are.
    let mut stale: Vec<String> = Vec::new();
    for (c, (config, result, _)) in cases.iter().zip(&configs) {
        if c.rows.is_empty() {
            continue;
        }
        let shown: Vec<(String, Option<f64>)> = c
            .rows
            .iter()
            .map(|&i| {
                let test = test_name_col.map_or(String::new(), |t| summary.rows[i][t].clone());
                let mrae = mrae_col.and_then(|m| parse_num(summary.rows[i][m].trim()));
                (test, mrae)
            })
            .collect();
        let tested = shown.iter().any(|(t, _)| !t.is_empty());
        let mut shown_tests: Vec<&str> = shown.iter().map(|(t, _)| t.as_str()).collect();
        shown_tests.sort_unstable();
        let other_tests = tested
            && config
                .as_ref()
                .and_then(|(_, t)| t.get("tests"))
                .and_then(|v| v.as_array())
                .is_some_and(|a| {
                    let mut stored: Vec<&str> = a.iter().filter_map(|x| x.as_str()).collect();
                    stored.sort_unstable();
                    stored != shown_tests
                });
        let other_results = result
            .as_ref()
            .and_then(|r| r.get("tests"))
            .and_then(Value::as_array)
            .is_some_and(|tests| {
                let stored: Vec<(String, Option<f64>)> = tests
                    .iter()
                    .map(|t| {
                        let name = t.get("test").and_then(Value::as_str).unwrap_or_default();
                        (name.to_string(), t.get("mrae").and_then(Value::as_f64))
                    })
                    .collect();
                let same = |(ta, ma): &(String, Option<f64>), (tb, mb): &(String, Option<f64>)| {
                    ta == tb
                        && match (ma, mb) {
                            (Some(x), Some(y)) => (x - y).abs() <= 1e-12 * x.abs().max(y.abs()),
                            (None, None) => true,
                            _ => false,
                        }
                };
                // A case without tests has one summary row with no test.
                let stored_rows = if stored.is_empty() { 1 } else { stored.len() };
                !(stored_rows == shown.len()
                    && (stored.is_empty() || stored.iter().zip(&shown).all(|(a, b)| same(a, b))))
            });
        if other_tests || other_results {
            stale.push(format!(
                "case {}: cases/{}/{} is of another run than summary.csv (a rerun stopped before \
                 its tables?): the summary and the case's details below disagree; rerun the study",
                c.id,
                c.id,
                if other_tests {
                    "config.toml (other tests)"
                } else {
                    "result.json"
                }
            ));
        }
    }

    // ---- header
    let str_of = |keys: &[&str]| -> Option<String> {
        let o = run_obj?;
        keys.iter().find_map(|k| match o.get(*k)? {
            Value::String(s) => Some(s.clone()),
            Value::Null => None,
            v => Some(v.to_string()),
        })
    };
    let study_str = |key: &str| -> Option<String> {
        study
            .as_ref()
            .and_then(|(_, t)| t.get(key))
            .and_then(|v| v.as_str())
            .map(str::to_string)
    };
    let config_str = |key: &str| -> Option<String> {
        first_config
            .and_then(|t| t.get(key))
            .and_then(|v| v.as_str())
            .map(str::to_string)
    };
    let name = meta
        .name
        .clone()
        .or_else(|| str_of(&["study_name", "name"]))
        .or_else(|| study_str("name"))
        .or_else(|| config_str("study"))
        .unwrap_or_else(|| {
            dir.file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_else(|| "study".into())
        });
    let mut used_keys: Vec<&str> = vec!["study_name", "name", "warnings"];
    let mut header: Vec<(String, String)> = Vec::new();
    // The version that computed the results, not the one writing this page: `shipid report` of an
    // old folder must not vouch for results with its own version.
    let run_version = str_of(&["tool_version", "shipid_version", "version"]);
    let version = run_version
        .clone()
        .or_else(|| config_str("shipid_version"))
        .or_else(|| meta.tool_version.clone());
    used_keys.extend(["tool_version", "shipid_version", "version"]);
    header.push((
        "tool version".into(),
        version
            .as_ref()
            .map_or("unknown".into(), |v| format!("shipid {v}")),
    ));
    let mut version_warnings = Vec::new();
    if let Some(mine) = &meta.tool_version {
        if let Some(v) = run_version.as_ref().filter(|v| *v != mine) {
            version_warnings.push(format!(
                "run.json: the run was made by shipid {v}, this page by shipid {mine}: rerun the \
                 study to have its results from this version"
            ));
        }
        let mut others: BTreeMap<String, Vec<&str>> = BTreeMap::new();
        for (c, (config, _, _)) in cases.iter().zip(&configs) {
            if let Some(v) = config
                .as_ref()
                .and_then(|(_, t)| t.get("shipid_version"))
                .and_then(|v| v.as_str())
                .filter(|v| v != mine)
            {
                others.entry(v.to_string()).or_default().push(&c.id);
            }
        }
        for (v, ids) in others {
            version_warnings.push(format!(
                "{} case(s) were computed by shipid {v}, not {mine} (their config.toml says so; \
                 e.g. {}): rerun the study (--force) to recompute them",
                ids.len(),
                ids[0]
            ));
        }
        if version.as_ref().is_some_and(|v| v != mine) {
            header.push(("page written by".into(), format!("shipid {mine}")));
        }
    }
    if let Some(f) = meta
        .study_file
        .as_ref()
        .map(|p| p.display().to_string())
        .or_else(|| {
            str_of(&["study_file", "study"]).map(|s| {
                // Older runs stored it as typed: relative to a working directory the page cannot know.
                if std::path::Path::new(&s).is_relative() {
                    format!("{s} (relative to the folder `shipid run` was started in)")
                } else {
                    s
                }
            })
        })
    {
        header.push(("study file".into(), f));
    }
    used_keys.extend(["study_file", "study"]);
    let dataset = meta
        .dataset
        .as_ref()
        .map(|p| p.display().to_string())
        .or_else(|| str_of(&["dataset", "data_set"]))
        .or_else(|| study_str("dataset"))
        .or_else(|| config_str("dataset"));
    used_keys.extend(["dataset", "data_set"]);
    header.push((
        "data set".into(),
        dataset.unwrap_or_else(|| "unknown".into()),
    ));
    for (k, utc) in [("started", "started_utc"), ("finished", "finished_utc")] {
        if let Some(v) = str_of(&[utc, k]) {
            header.push((k.into(), v));
        }
        used_keys.extend([k, utc]);
    }
    header.push(("output folder".into(), dir.display().to_string()));
    header.extend(meta.details.iter().cloned());

    // ---- warnings
    let mut warnings: Vec<String> = version_warnings.clone();
    warnings.extend(stale.iter().cloned());
    warnings.extend(meta.warnings.iter().cloned());
    if let Some(Value::Array(ws)) = run_obj.and_then(|o| o.get("warnings")) {
        for w in ws {
            warnings.push(match w {
                Value::String(s) => s.clone(),
                v => v.to_string(),
            });
        }
    }
    warnings.extend(notes);
    let mut seen = std::collections::HashSet::new();
    warnings.retain(|w| seen.insert(w.clone()));

    let mut b = String::new();
    let _ = write!(
        b,
        "<header class=\"top\"><h1><span class=\"kind\">Study</span> {}</h1>",
        esc(&name)
    );
    if let Some(d) = study_str("description") {
        let _ = write!(b, "<p class=\"sub\">{}</p>", esc(&d));
    }
    b.push_str(&facts(&header));
    b.push_str(
        "<nav class=\"toc\"><a href=\"#status\">Status</a><a href=\"#summary\">Summary</a>\
         <a href=\"#figures\">Figures</a><a href=\"#cases\">Cases</a>\
         <a href=\"#configuration\">Run configuration</a></nav></header>",
    );
    b.push_str(&warnings_box(&warnings));

    // ---- status counts
    let mut case_counts: BTreeMap<String, usize> = BTreeMap::new();
    let mut test_counts: BTreeMap<String, usize> = BTreeMap::new();
    // Cases with some diverged prediction, as run.json's `some_prediction_diverged` counts them (a
    // case's status is its fit's).
    let mut with_diverged = 0usize;
    for c in &cases {
        let st = match (status_col, c.rows.is_empty()) {
            (Some(j), false) => first_value(c, j),
            _ => "no row".into(),
        };
        *case_counts.entry(st.clone()).or_default() += 1;
        if let Some(j) = test_status_col {
            let mut diverged = false;
            for &i in &c.rows {
                let has_test = test_name_col.is_none_or(|t| !summary.rows[i][t].is_empty());
                if has_test {
                    let st = test_status(i, j);
                    diverged |= st == "diverged";
                    *test_counts.entry(st).or_default() += 1;
                }
            }
            if diverged {
                with_diverged += 1;
                // "cases ok" are those whose every prediction is ok, as run.json counts them: a
                // case whose fit is ok and one of whose predictions diverged is counted once, in
                // the tile of cases with a diverged prediction.
                if st == "ok"
                    && let Some(n) = case_counts.get_mut("ok")
                {
                    *n -= 1;
                }
            }
        }
    }
    case_counts.retain(|_, n| *n > 0);
    b.push_str("<section id=\"status\"><h2>Status</h2><div class=\"counts\">");
    count_box(&mut b, "cases", cases.len(), "");
    for (k, v) in &case_counts {
        count_box(&mut b, &format!("cases {k}"), *v, status_class(k));
    }
    if with_diverged > 0 {
        count_box(
            &mut b,
            if with_diverged == 1 {
                "case with a diverged prediction"
            } else {
                "cases with a diverged prediction"
            },
            with_diverged,
            "bad",
        );
    }
    if !test_counts.is_empty() {
        count_box(&mut b, "tests", test_counts.values().sum(), "");
        for (k, v) in &test_counts {
            count_box(&mut b, &format!("tests {k}"), *v, status_class(k));
        }
    }
    b.push_str("</div>");
    if let Some(o) = run_obj {
        let rest: serde_json::Map<String, Value> = o
            .iter()
            .filter(|(k, _)| !used_keys.contains(&k.as_str()))
            .map(|(k, v)| (k.clone(), v.clone()))
            .collect();
        if !rest.is_empty() {
            let _ = write!(
                b,
                "<h3>Run record <code>run.json</code></h3>{}",
                json_html(&Value::Object(rest))
            );
        }
    }
    b.push_str("</section>");

    // ---- summary table
    b.push_str("<section id=\"summary\"><h2>Summary</h2>");
    if !common.is_empty() {
        b.push_str("<p class=\"common\">All cases: ");
        let parts: Vec<String> = common
            .iter()
            .map(|(k, v)| {
                let v = parse_num(v.trim()).map_or_else(|| v.clone(), num);
                format!("{} <code>{}</code>", esc(&label(k)), esc(&v))
            })
            .collect();
        b.push_str(&parts.join(" · "));
        b.push_str("</p>");
    }
    let medians: Vec<usize> = MEDIANS
        .iter()
        .filter_map(|m| summary.col(m))
        .filter(|j| test_cols.contains(j))
        .collect();
    // Case id, its status, its tests and their medians first (what a reader scans for), then the
    // columns that tell the cases apart.
    let descriptive: Vec<usize> = varying
        .iter()
        .copied()
        .filter(|&j| Some(j) != status_col)
        .collect();
    b.push_str(
        "<div class=\"tablewrap\"><table class=\"summary\"><caption class=\"vh\">Summary: one row per case, \
         with its fit status, its tests' statuses and the medians over its tests</caption><thead><tr>\
         <th scope=\"col\" class=\"id\" title=\"case\">case</th>",
    );
    if status_col.is_some() {
        b.push_str("<th scope=\"col\" title=\"case_status\">status</th>");
    }
    if test_status_col.is_some() {
        b.push_str("<th scope=\"col\">tests</th>");
    }
    for &j in &medians {
        let _ = write!(
            b,
            "<th scope=\"col\" title=\"median over the case's tests of {}\">median {}</th>",
            esc(&summary.headers[j]),
            esc(&label(&summary.headers[j]))
        );
    }
    for &j in &descriptive {
        b.push_str(&th(&summary.headers[j]));
    }
    b.push_str("</tr></thead><tbody>");
    let shared = shared_prefix(&cases.iter().map(|c| c.id.as_str()).collect::<Vec<_>>());
    for c in &cases {
        let mut worst = "good";
        if let Some(j) = status_col {
            worst = worse(worst, status_class(&first_value(c, j)));
        }
        let mut tcount: BTreeMap<String, usize> = BTreeMap::new();
        if let Some(j) = test_status_col {
            for &i in &c.rows {
                if test_name_col.is_none_or(|t| !summary.rows[i][t].is_empty()) {
                    let st = test_status(i, j);
                    worst = worse(worst, status_class(&st));
                    *tcount.entry(st).or_default() += 1;
                }
            }
        }
        if c.rows.is_empty() {
            worst = "bad";
        }
        let _ = write!(
            b,
            "<tr id=\"{}\" data-case-id=\"{}\" class=\"{worst}\"><td class=\"id\"><a href=\"#{}\" title=\"{}\">{}</a></td>",
            esc(&id_of("case-", &c.id)),
            esc(&c.id),
            esc(&id_of("details-", &c.id)),
            esc(&c.id),
            id_cell_text(&c.id, shared)
        );
        if let Some(j) = status_col {
            let v = if c.rows.is_empty() {
                "no row".to_string()
            } else {
                first_value(c, j)
            };
            let _ = write!(b, "<td class=\"nw\">{}</td>", fit_badge(&v, &tcount));
        }
        if test_status_col.is_some() {
            let parts: Vec<String> = tcount
                .iter()
                .map(|(k, v)| format!("{v}&nbsp;{}", badge(k)))
                .collect();
            let _ = write!(b, "<td class=\"nw\">{}</td>", parts.join(" "));
        }
        for &j in &medians {
            let mut xs: Vec<f64> = c
                .rows
                .iter()
                .filter_map(|&i| parse_num(summary.rows[i][j].trim()))
                .filter(|x| x.is_finite())
                .collect();
            // Tests that have no value (a diverged prediction or replay) are left out of the
            // median: the cell says over how many, so one surviving test does not pass for all.
            let tests = c
                .rows
                .iter()
                .filter(|&&i| test_name_col.is_none_or(|t| !summary.rows[i][t].is_empty()))
                .count();
            match median(&mut xs) {
                Some(m) => {
                    let of = if xs.len() < tests {
                        format!(
                            " <span class=\"muted\">({} of {tests} tests)</span>",
                            xs.len()
                        )
                    } else {
                        String::new()
                    };
                    let _ = write!(
                        b,
                        "<td class=\"n\" title=\"{} of {} tests\">{}{of}</td>",
                        m,
                        xs.len(),
                        esc(&num(m))
                    );
                }
                None => b.push_str("<td class=\"empty\"></td>"),
            }
        }
        for &j in &descriptive {
            b.push_str(&cell(&first_value(c, j)));
        }
        b.push_str("</tr>");
    }
    b.push_str("</tbody></table></div>");
    b.push_str("</section>");

    // ---- figures
    b.push_str("<section id=\"figures\"><h2>Figures</h2>");
    let fig_dir = dir.join("figures");
    let mut fig_notes = Vec::new();
    if fig_dir.is_dir() {
        // A force figure names its case: one of a case this run does not have is a leftover of an
        // earlier run into the folder (`shipid run` and `plot` remove them; an older version did not).
        let current: Vec<String> = cases
            .iter()
            .filter(|c| !c.rows.is_empty())
            .map(|c| format!("forces_{}_", figure_slug(&c.id)))
            .collect();
        let keep = |name: &str| {
            (name.starts_with("forces_") && !current.iter().any(|p| name.starts_with(p.as_str())))
                .then(|| "a figure of a case that is not in summary.csv".to_string())
        };
        let (html, n) = figures_html(&fig_dir, "fig", &mut fig_notes, &keep)?;
        if n == 0 {
            b.push_str("<p class=\"muted\">No figures in <code>figures/</code>.</p>");
        }
        b.push_str(&html);
    } else {
        b.push_str(
            "<p class=\"muted\">No <code>figures/</code> folder (<code>shipid plot</code> draws them).</p>",
        );
    }
    if !fig_notes.is_empty() {
        b.push_str(&warnings_box(&fig_notes).replace("id=\"warnings\" ", ""));
    }
    b.push_str("</section>");

    // ---- per case
    b.push_str("<section id=\"cases\"><h2>Cases</h2>");
    for (c, (config, result, model)) in cases.iter().zip(&configs) {
        case_details(
            &mut b,
            c,
            &summary,
            &test_cols,
            coefficients.as_ref(),
            diagnostics.as_ref(),
            config.as_ref().map(|c| c.0.as_str()),
            result.as_ref(),
            model.as_deref(),
            status_col.map(|j| first_value(c, j)),
        )?;
    }
    b.push_str("</section>");

    // ---- configuration
    b.push_str("<section id=\"configuration\"><h2>Run configuration</h2>");
    match &study {
        Some((text, _)) => {
            b.push_str("<p class=\"muted\">The resolved study, <code>study.toml</code>:</p>");
            b.push_str(&toml_block(text));
        }
        None => b.push_str(
            "<p class=\"muted\">The folder has no <code>study.toml</code>; each case's resolved \
             configuration is in its details above.</p>",
        ),
    }
    if let Some(r) = &run {
        let pretty = serde_json::to_string_pretty(r).unwrap_or_default();
        let _ = write!(
            b,
            "<details><summary><code>run.json</code></summary><pre class=\"code\">{}</pre></details>",
            esc(&pretty)
        );
    }
    b.push_str("</section>");
    b.push_str("<footer>Written by shipid-report from the files of the output folder; the page has no script and loads nothing.</footer>");
    let mut printed = version_warnings;
    printed.extend(stale);
    Ok((page(&format!("{name} — shipid study report"), &b), printed))
}

/// A case's status badge: its fit's word, and when some of its tests diverged, how many, in the
/// colour of a failure. A green "ok" on a case whose predictions mostly diverged read as a good case.
fn fit_badge<K: AsRef<str>>(status: &str, tests: &BTreeMap<K, usize>) -> String {
    let diverged: usize = tests
        .iter()
        .filter(|(k, _)| k.as_ref() == "diverged")
        .map(|(_, n)| n)
        .sum();
    if diverged == 0 {
        return badge(status);
    }
    let all: usize = tests.values().sum();
    format!(
        "<span class=\"badge {}\" title=\"{}\">{}</span>",
        worse(status_class(status), "bad"),
        esc(&format!(
            "the fit is {status}; {diverged} of its {all} tests' predictions diverged"
        )),
        esc(&format!("fit {status} · {diverged} of {all} diverged"))
    )
}

/// Length of the prefix every case id shares, up to and with its last `_` (0 for one case): the
/// ids of a study differ in their tails, and a narrow window shows them without it.
fn shared_prefix(ids: &[&str]) -> usize {
    let Some((first, rest)) = ids.split_first() else {
        return 0;
    };
    if rest.is_empty() {
        return 0;
    }
    let mut n = first.len();
    for id in rest {
        n = n.min(
            first
                .bytes()
                .zip(id.bytes())
                .take_while(|(a, b)| a == b)
                .count(),
        );
    }
    first[..n].rfind('_').map_or(0, |i| i + 1)
}

/// The summary's case cell: the full id, and for a narrow window the id without the prefix all
/// cases share (the stylesheet shows one of the two; the link's title holds the full id).
fn id_cell_text(id: &str, shared: usize) -> String {
    match id.get(shared..).filter(|_| shared > 0) {
        Some(tail) => format!(
            "<span class=\"full\">{}</span><span class=\"tail\">…{}</span>",
            esc(id),
            esc(tail)
        ),
        None => esc(id),
    }
}

fn count_box(b: &mut String, what: &str, n: usize, class: &str) {
    let _ = write!(
        b,
        "<div class=\"count {class}\"><span class=\"v\">{n}</span>{}</div>",
        esc(what)
    );
}

fn worse(a: &'static str, b: &'static str) -> &'static str {
    let rank = |s: &str| match s {
        "bad" => 2,
        "warn" => 1,
        _ => 0,
    };
    if rank(b) > rank(a) { b } else { a }
}

/// A case id as `shipid-figures` writes it into a figure's file name.
fn figure_slug(id: &str) -> String {
    let s: String = id
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    s.trim_end_matches("_csv").to_string()
}

fn median(xs: &mut [f64]) -> Option<f64> {
    if xs.is_empty() {
        return None;
    }
    xs.sort_by(f64::total_cmp);
    let n = xs.len();
    Some(if n % 2 == 1 {
        xs[n / 2]
    } else {
        0.5 * (xs[n / 2 - 1] + xs[n / 2])
    })
}

/// Columns of the manoeuvre metrics (recorded, predicted, relative error, and a study's bands:
/// lower and upper bound, record inside), shown apart.
fn is_metric(name: &str) -> bool {
    BAND_SUFFIXES
        .iter()
        .chain(&POINT_SUFFIXES)
        .any(|suf| name.ends_with(suf))
}

const POINT_SUFFIXES: [&str; 3] = ["_recorded", "_predicted", "_rel_error"];
/// Written only by studies with `bands`.
const BAND_SUFFIXES: [&str; 3] = ["_lo", "_hi", "_inside"];

/// The manoeuvre metrics of a case's tests, one row per test and metric with a value: recorded,
/// predicted, relative error (columns `<metric>_recorded`, `_predicted`, `_rel_error`), and in a
/// study with bands the band `[lo, hi]` and whether the record lies inside (`_lo`, `_hi`, `_inside`).
fn metric_table(b: &mut String, csv: &Csv, rows: &[usize], metric_cols: &[usize]) {
    let mut metrics: Vec<&str> = Vec::new();
    let mut banded = false;
    for &j in metric_cols {
        let h = csv.headers[j].as_str();
        let m = POINT_SUFFIXES
            .iter()
            .chain(&BAND_SUFFIXES)
            .find_map(|suf| h.strip_suffix(suf))
            .unwrap_or(h);
        banded |= BAND_SUFFIXES.iter().any(|suf| h.ends_with(suf));
        if !metrics.contains(&m) {
            metrics.push(m);
        }
    }
    let test = csv.col("test");
    let value = |i: usize, m: &str, suf: &str| {
        csv.col(&format!("{m}{suf}"))
            .map_or("", |j| csv.rows[i][j].as_str())
    };
    let mut body = String::new();
    for &i in rows {
        for m in &metrics {
            let v: Vec<&str> = POINT_SUFFIXES.iter().map(|suf| value(i, m, suf)).collect();
            if v.iter().all(|x| x.trim().is_empty()) {
                continue;
            }
            let _ = write!(
                body,
                "<tr><td>{}</td><td>{}</td>",
                esc(test.map_or("", |t| csv.rows[i][t].as_str())),
                esc(&label(m))
            );
            for x in v {
                body.push_str(&cell(x));
            }
            if banded {
                let bound = |suf| value(i, m, suf).parse::<f64>().ok();
                match (bound("_lo"), bound("_hi")) {
                    (Some(lo), Some(hi)) => {
                        let _ = write!(body, "<td class=\"n\">[{lo:.4}, {hi:.4}]</td>");
                    }
                    _ => body.push_str("<td></td>"),
                }
                let _ = write!(body, "<td>{}</td>", esc(value(i, m, "_inside")));
            }
            body.push_str("</tr>");
        }
    }
    if body.is_empty() {
        return;
    }
    b.push_str(
        "<h3>Manoeuvre metrics</h3><div class=\"tablewrap fit\"><table class=\"metrics narrow\"><thead><tr>\
         <th scope=\"col\">test</th><th scope=\"col\">metric</th><th scope=\"col\">recorded</th><th scope=\"col\">predicted</th><th scope=\"col\">rel. error</th>",
    );
    if banded {
        b.push_str("<th scope=\"col\">band</th><th scope=\"col\">recorded inside</th>");
    }
    b.push_str("</tr></thead><tbody>");
    b.push_str(&body);
    b.push_str("</tbody></table></div>");
}

/// A table of the given columns of some rows, leaving out columns empty in all of them.
fn sub_table(b: &mut String, csv: &Csv, rows: &[usize], cols: &[usize], class: &str) {
    let cols: Vec<usize> = cols
        .iter()
        .copied()
        .filter(|&j| rows.iter().any(|&i| !csv.rows[i][j].trim().is_empty()))
        .collect();
    if cols.is_empty() || rows.is_empty() {
        return;
    }
    let _ = write!(
        b,
        "<div class=\"tablewrap\"><table class=\"{class}\"><thead><tr>"
    );
    for &j in &cols {
        b.push_str(&th(&csv.headers[j]));
    }
    b.push_str("</tr></thead><tbody>");
    for &i in rows {
        b.push_str("<tr>");
        for &j in &cols {
            let v = &csv.rows[i][j];
            if csv.headers[j].ends_with("status") {
                let _ = write!(b, "<td>{}</td>", badge(v));
            } else {
                b.push_str(&cell(v));
            }
        }
        b.push_str("</tr>");
    }
    b.push_str("</tbody></table></div>");
}

#[allow(clippy::too_many_arguments)]
fn case_details(
    b: &mut String,
    c: &Case,
    summary: &Csv,
    test_cols: &[usize],
    coefficients: Option<&Csv>,
    diagnostics: Option<&Csv>,
    config: Option<&str>,
    result: Option<&Value>,
    model: Option<&str>,
    status: Option<String>,
) -> Result<(), ReportError> {
    let status = status
        .or_else(|| {
            result
                .and_then(|r| r.get("status"))
                .and_then(Value::as_str)
                .map(str::to_string)
        })
        .unwrap_or_default();
    let mut tcount: BTreeMap<&str, usize> = BTreeMap::new();
    if let (Some(t), Some(j)) = (summary.col("test"), summary.col("status")) {
        let replay = summary.col("replay_status");
        for &i in &c.rows {
            if !summary.rows[i][t].is_empty() {
                // As the summary row counts it: a diverged replay is a diverged prediction.
                let st = match replay {
                    Some(r) if summary.rows[i][r] == "diverged" => "diverged",
                    _ => summary.rows[i][j].as_str(),
                };
                *tcount.entry(st).or_default() += 1;
            }
        }
    }
    let tests: Vec<String> = tcount
        .iter()
        .map(|(k, v)| format!("{v} {}", esc(k)))
        .collect();
    let _ = write!(
        b,
        "<details id=\"{}\" data-case-id=\"{}\"><summary><code>{}</code> {} <span class=\"muted tests\">{}</span></summary>",
        esc(&id_of("details-", &c.id)),
        esc(&c.id),
        esc(&c.id),
        if status.is_empty() {
            badge(&status)
        } else {
            fit_badge(&status, &tcount)
        },
        if tests.is_empty() {
            String::new()
        } else {
            format!("tests: {}", tests.join(", "))
        }
    );
    if let Some(r) = result.and_then(Value::as_object) {
        let mut f: Vec<(String, String)> = Vec::new();
        if let Some(m) = r.get("message").and_then(Value::as_str) {
            f.push(("message".into(), m.to_string()));
        }
        if let Some(n) = r.get("samples").and_then(Value::as_f64) {
            f.push(("training samples".into(), num(n)));
        }
        if let Some(t) = r.get("fit_time_s").and_then(Value::as_f64) {
            f.push(("fit time [s]".into(), num(t)));
        }
        if !f.is_empty() {
            b.push_str(&facts(&f));
        }
    }
    // Tests: replay columns, then manoeuvre metrics.
    let (metric, replay): (Vec<usize>, Vec<usize>) = test_cols
        .iter()
        .partition(|&&j| is_metric(&summary.headers[j]));
    let rows: Vec<usize> = c
        .rows
        .iter()
        .copied()
        .filter(|&i| {
            summary
                .col("test")
                .is_none_or(|t| !summary.rows[i][t].is_empty())
        })
        .collect();
    if !rows.is_empty() {
        b.push_str("<h3>Tests</h3>");
        sub_table(b, summary, &rows, &replay, "tests");
        if !metric.is_empty() {
            metric_table(b, summary, &rows, &metric);
        }
    }
    // Coefficients with their VIF beside the per-DOF diagnostics.
    b.push_str("<div class=\"side\">");
    if let Some(t) = coefficients {
        coefficient_table(b, c, t, diagnostics)?;
    }
    if let Some(d) = diagnostics {
        dof_table(b, c, d)?;
    }
    b.push_str("</div>");
    for (file, text) in [("config.toml", config), ("model.toml", model)] {
        if let Some(text) = text {
            let _ = write!(
                b,
                "<details><summary><code>cases/{}/{file}</code></summary>{}</details>",
                esc(&c.id),
                toml_block(text)
            );
        }
    }
    b.push_str("</details>");
    Ok(())
}

/// Column indices of a long table (case, dof, term, quantity, value), an error naming the file when
/// one is missing.
fn long_cols(t: &Csv) -> Result<[usize; 5], ReportError> {
    let case = t.case_col()?;
    let mut out = [case, 0, 0, 0, 0];
    for (k, name) in ["dof", "term", "quantity", "value"].iter().enumerate() {
        out[k + 1] = t.col(name).ok_or_else(|| ReportError::Invalid {
            path: t.path.clone(),
            message: format!("no column `{name}`"),
        })?;
    }
    Ok(out)
}

fn coefficient_table(
    b: &mut String,
    c: &Case,
    t: &Csv,
    diagnostics: Option<&Csv>,
) -> Result<(), ReportError> {
    let [case, dof, term, quantity, value] = long_cols(t)?;
    let mut vif: BTreeMap<(String, String), String> = BTreeMap::new();
    if let Some(d) = diagnostics {
        let [dc, dd, dt, dq, dv] = long_cols(d)?;
        for r in d.rows.iter().filter(|r| r[dc] == c.id && r[dq] == "vif") {
            vif.insert((r[dd].clone(), r[dt].clone()), r[dv].clone());
        }
    }
    let rows: Vec<&Vec<String>> = t.rows.iter().filter(|r| r[case] == c.id).collect();
    if rows.is_empty() {
        return Ok(());
    }
    let quantities: Vec<&str> = {
        let mut q: Vec<&str> = rows.iter().map(|r| r[quantity].as_str()).collect();
        q.sort_unstable();
        q.dedup();
        q
    };
    let show_quantity = quantities.len() > 1 || quantities.first() != Some(&"coefficient");
    b.push_str("<div><h3>Coefficients</h3><div class=\"tablewrap fit\"><table class=\"coefficients narrow\"><thead><tr>");
    b.push_str(&th("dof"));
    b.push_str(&th("term"));
    if show_quantity {
        b.push_str(&th("quantity"));
    }
    b.push_str(&th("value"));
    if !vif.is_empty() {
        b.push_str(&th("vif"));
    }
    b.push_str("</tr></thead><tbody>");
    for r in rows {
        let _ = write!(
            b,
            "<tr><td>{}</td><td><code>{}</code></td>",
            esc(&r[dof]),
            esc(&r[term])
        );
        if show_quantity {
            let _ = write!(b, "<td>{}</td>", esc(&r[quantity]));
        }
        b.push_str(&cell(&r[value]));
        if !vif.is_empty() {
            b.push_str(&cell(
                vif.get(&(r[dof].clone(), r[term].clone()))
                    .map_or("", String::as_str),
            ));
        }
        b.push_str("</tr>");
    }
    b.push_str("</tbody></table></div></div>");
    Ok(())
}

/// Per-DOF quantities of diagnostics.csv (rows without a term): one row per DOF.
fn dof_table(b: &mut String, c: &Case, d: &Csv) -> Result<(), ReportError> {
    let [case, dof, term, quantity, value] = long_cols(d)?;
    let mut dofs: Vec<String> = Vec::new();
    let mut qs: Vec<String> = Vec::new();
    let mut v: BTreeMap<(String, String), String> = BTreeMap::new();
    for r in d
        .rows
        .iter()
        .filter(|r| r[case] == c.id && r[term].trim().is_empty())
    {
        if !dofs.contains(&r[dof]) {
            dofs.push(r[dof].clone());
        }
        if !qs.contains(&r[quantity]) {
            qs.push(r[quantity].clone());
        }
        v.insert((r[dof].clone(), r[quantity].clone()), r[value].clone());
    }
    if dofs.is_empty() {
        return Ok(());
    }
    b.push_str("<div><h3>Fit diagnostics per DOF</h3><div class=\"tablewrap fit\"><table class=\"dofs narrow\"><thead><tr>");
    b.push_str(&th("dof"));
    for q in &qs {
        b.push_str(&th(q));
    }
    b.push_str("</tr></thead><tbody>");
    for x in &dofs {
        let _ = write!(b, "<tr><td>{}</td>", esc(x));
        for q in &qs {
            b.push_str(&cell(
                v.get(&(x.clone(), q.clone())).map_or("", String::as_str),
            ));
        }
        b.push_str("</tr>");
    }
    b.push_str("</tbody></table></div></div>");
    Ok(())
}
