//! The page of a diagnosis (`shipid diagnose --json … --plots … --model-out …`).

use std::fmt::Write as _;

use serde_json::{Map, Value};

use crate::data::{figures_html, read_text, read_text_optional};
use crate::html::{badge, esc, facts, id_of, json_html, num, page, toml_block, warnings_box};
use crate::{DiagnosisFiles, ReportError, RunMeta};

/// Keys of the report that the page shows in their own place; any other key is listed as it is.
const KNOWN: [&str; 22] = [
    "model",
    "dataset",
    "warnings",
    "per_recording_wind",
    "windage",
    "recorded_environment",
    "against_recorded",
    "reveal",
    "verdict",
    "candidates",
    "located",
    "fit_before",
    "fit_after",
    "effects",
    "standard_errors",
    "per_recording",
    "regimes",
    "horizon_s",
    "noise_floor_position_rmse_over_l",
    "model_level_position_rmse_over_l",
    "outside_identification_range",
    "explanation",
];

/// The HTML page of a diagnosis: the report JSON is required (an object with a `verdict`), figures
/// and the augmented model are shown when given and present.
pub fn diagnosis_page(files: &DiagnosisFiles, meta: &RunMeta) -> Result<String, ReportError> {
    let path = &files.report;
    let text = read_text(path)?;
    let report: Value = serde_json::from_str(&text).map_err(|source| ReportError::Json {
        path: path.clone(),
        source,
    })?;
    let invalid = |message: &str| ReportError::Invalid {
        path: path.clone(),
        message: message.into(),
    };
    let r = report
        .as_object()
        .ok_or_else(|| invalid("the report is not a JSON object"))?;
    let verdict = r
        .get("verdict")
        .and_then(Value::as_str)
        .ok_or_else(|| invalid("no `verdict` string: not a diagnosis report"))?;
    let model = match &files.model {
        Some(p) => read_text_optional(p)?.map(|t| (p, t)),
        None => None,
    };
    let mut notes: Vec<String> = Vec::new();

    // The model and data set as the report names them, for a page rebuilt from the folder alone
    // (`shipid report DIR`), where the caller knows neither.
    let named = |key: &str| r.get(key).and_then(Value::as_str).map(str::to_string);
    let title = meta
        .name
        .clone()
        .or_else(|| named("model").map(|m| format!("diagnosis of {m}")))
        .unwrap_or_else(|| "Diagnosis".into());
    let mut header: Vec<(String, String)> = vec![(
        "tool version".into(),
        meta.tool_version
            .as_ref()
            .map_or("unknown".into(), |v| format!("shipid {v}")),
    )];
    if let Some(d) = meta
        .dataset
        .as_ref()
        .map(|d| d.display().to_string())
        .or_else(|| named("dataset"))
    {
        header.push(("data set".into(), d));
    }
    if let Some(f) = &meta.study_file {
        header.push(("study file".into(), f.display().to_string()));
    }
    header.extend(meta.details.iter().cloned());
    if let (false, Some(m)) = (
        meta.details.iter().any(|(k, _)| k == "model"),
        named("model"),
    ) {
        header.push(("model".into(), m));
    }
    header.push(("report".into(), path.display().to_string()));
    if let Some((p, _)) = &model {
        header.push(("augmented model".into(), p.display().to_string()));
    }

    let mut b = String::new();
    // A title that already says it is a diagnosis ("diagnosis of mmg:kvlcc2") stands alone.
    let says_it = title.to_lowercase().starts_with("diagnosis");
    let _ = if says_it {
        let mut c = title.chars();
        let t: String = c
            .next()
            .map_or(String::new(), |f| f.to_uppercase().chain(c).collect());
        write!(b, "<header class=\"top\"><h1>{}</h1>", esc(&t))
    } else {
        write!(
            b,
            "<header class=\"top\"><h1><span class=\"kind\">Diagnosis</span> {}</h1>",
            esc(&title)
        )
    };
    b.push_str(&facts(&header));
    b.push_str(
        "<nav class=\"toc\"><a href=\"#verdict\">Verdict</a><a href=\"#candidates\">Candidates</a>\
         <a href=\"#recordings\">Recordings</a><a href=\"#figures\">Figures</a>\
         <a href=\"#located\">Where</a><a href=\"#model\">Augmented model</a></nav></header>",
    );
    let warnings_at = b.len();

    // ---- verdict and evidence
    let f = |k: &str| r.get(k).and_then(Value::as_f64);
    let fit = |k: &str, q: &str| r.get(k).and_then(|v| v.get(q)).and_then(Value::as_f64);
    let _ = write!(
        b,
        "<section id=\"verdict\" class=\"verdict\"><div class=\"muted\">verdict</div><div class=\"word\">{}</div>",
        esc(verdict)
    );
    if let Some(e) = r.get("explanation").and_then(Value::as_str) {
        let _ = write!(b, "<p>{}</p>", esc(e));
    }
    let mut ev: Vec<(String, String)> = Vec::new();
    let effects: Vec<String> = r
        .get("effects")
        .and_then(Value::as_array)
        .map(|a| {
            a.iter()
                .map(|x| x.as_str().map_or_else(|| x.to_string(), str::to_string))
                .collect()
        })
        .unwrap_or_default();
    let own_winds = r
        .get("per_recording_wind")
        .and_then(Value::as_array)
        .filter(|a| !a.is_empty());
    ev.push((
        "effects found".into(),
        if let Some(w) = own_winds {
            format!(
                "a wind of its own on each of {} recordings (below): the runs' environment, not the model's, so the model is not augmented",
                w.len()
            )
        } else if effects.is_empty() {
            "none".into()
        } else {
            effects
                .iter()
                .map(|e| readable_effect(e))
                .collect::<Vec<_>>()
                .join("; ")
        },
    ));
    if let Some(se) = r.get("standard_errors").and_then(Value::as_object)
        && !se.is_empty()
    {
        let parts: Vec<String> = se
            .iter()
            .map(|(k, v)| format!("{k} ± {}", v.as_f64().map_or(v.to_string(), num)))
            .collect();
        ev.push(("standard errors".into(), parts.join(", ")));
    }
    let arrow = |a: Option<f64>, b: Option<f64>, unit: &str| -> Option<String> {
        let (a, b) = (a?, b?);
        let change = if a != 0.0 {
            format!(" ({:+.0}\u{a0}%)", 100.0 * (b - a) / a)
        } else {
            String::new()
        };
        Some(format!("{}{unit} → {}{unit}{change}", num(a), num(b)))
    };
    if let Some(s) = arrow(
        fit("fit_before", "position_rmse_over_l"),
        fit("fit_after", "position_rmse_over_l"),
        "\u{a0}L",
    ) {
        ev.push(("held-out position RMSE ÷ L, before → after".into(), s));
    }
    if let Some(s) = arrow(
        fit("fit_before", "heading_rmse_deg"),
        fit("fit_after", "heading_rmse_deg"),
        "°",
    ) {
        ev.push(("held-out heading RMSE, before → after".into(), s));
    }
    if let Some(x) = f("noise_floor_position_rmse_over_l") {
        ev.push((
            "noise floor (position RMSE ÷ L)".into(),
            format!("{} L", num(x)),
        ));
    }
    if let Some(x) = f("model_level_position_rmse_over_l") {
        ev.push((
            "model's own level (position RMSE ÷ L)".into(),
            format!("{} L", num(x)),
        ));
    }
    if let Some(x) = f("outside_identification_range") {
        ev.push((
            "recorded states outside the identification range".into(),
            format!("{} %", num(100.0 * x)),
        ));
    }
    if let Some(x) = f("horizon_s") {
        ev.push(("replay segment length".into(), format!("{} s", num(x))));
    }
    b.push_str(&facts(&ev));
    if own_winds.is_some() {
        rows_table(
            &mut b,
            r.get("per_recording_wind"),
            "A wind of its own on each recording (direction it comes from, earth-fixed, clockwise from north; held-out on the recording's time halves)",
            &[
                ("recording", "recording", false),
                ("speed_m_s", "speed [m/s]", true),
                ("speed_standard_error_m_s", "± [m/s]", true),
                ("from_deg", "from [deg]", true),
                ("from_standard_error_deg", "± [deg]", true),
                ("before_position_rmse_over_l", "before ÷ L", true),
                ("after_position_rmse_over_l", "after ÷ L", true),
            ],
        );
    }
    b.push_str("</section>");

    environment_section(&mut b, r);
    // The diagnosis's own warnings (a varying propeller rate, an assumed windage) head the page.
    if let Some(ws) = r.get("warnings").and_then(Value::as_array) {
        notes.extend(ws.iter().filter_map(Value::as_str).map(str::to_string));
    }

    // ---- candidates
    b.push_str("<section id=\"candidates\"><h2>Candidate effects</h2>");
    match r.get("candidates").and_then(Value::as_array) {
        Some(cands) if !cands.is_empty() => {
            b.push_str(
                "<div class=\"tablewrap\"><table class=\"candidates\"><caption class=\"vh\">Candidate \
                 effects, each fitted to the data set</caption><thead><tr>\
                 <th scope=\"col\">effect</th><th scope=\"col\" title=\"accepted\">accepted</th>\
                 <th scope=\"col\" title=\"score\">score</th><th scope=\"col\" title=\"explains\">explains [%]</th>\
                 <th scope=\"col\" title=\"held_out_position_rmse_over_l\">held-out position RMSE ÷ L</th>\
                 <th scope=\"col\" title=\"n_parameters\">parameters</th><th scope=\"col\">fitted values</th></tr></thead><tbody>",
            );
            for c in cands {
                let accepted = c.get("accepted").and_then(Value::as_bool);
                let _ = write!(
                    b,
                    "<tr class=\"{}\"><td><code>{}</code></td><td>{}</td>",
                    if accepted == Some(true) { "good" } else { "" },
                    esc(&candidate_title(c)),
                    match accepted {
                        Some(true) => badge("accepted"),
                        Some(false) => "<span class=\"muted\">no</span>".into(),
                        None => String::new(),
                    }
                );
                num_cell(&mut b, c.get("score").and_then(Value::as_f64));
                num_cell(
                    &mut b,
                    c.get("explains").and_then(Value::as_f64).map(|x| 100.0 * x),
                );
                num_cell(
                    &mut b,
                    c.get("held_out_position_rmse_over_l")
                        .and_then(Value::as_f64),
                );
                num_cell(&mut b, c.get("n_parameters").and_then(Value::as_f64));
                // One unbreakable piece per parameter: a narrow window wraps between them only.
                let params: Vec<String> = c
                    .get("parameters")
                    .and_then(Value::as_object)
                    .map(params_text)
                    .unwrap_or_default()
                    .iter()
                    .map(|p| format!("<code class=\"nw\">{}</code>", esc(p)))
                    .collect();
                let _ = write!(
                    b,
                    "<td class=\"params\"><div>{}</div></td></tr>",
                    params.join(", ")
                );
            }
            b.push_str("</tbody></table></div>");
        }
        _ => b.push_str("<p class=\"muted\">No candidates in the report.</p>"),
    }
    b.push_str("</section>");

    // ---- per recording (the diagnosis's summary table: one row per recording)
    b.push_str("<section id=\"recordings\"><h2>Per recording (held out)</h2>");
    match r.get("per_recording").and_then(Value::as_array) {
        Some(recs) if !recs.is_empty() => {
            let has_out = recs
                .iter()
                .any(|x| x.get("outside_identification_range").is_some());
            b.push_str(
                "<div class=\"tablewrap fit\"><table class=\"summary narrow\"><caption class=\"vh\">\
                 Per recording, held out: position RMSE before and after the effect</caption><thead><tr><th scope=\"col\">recording</th>\
                 <th scope=\"col\" title=\"before_position_rmse_over_l\">position RMSE ÷ L before</th>\
                 <th scope=\"col\" title=\"after_position_rmse_over_l\">position RMSE ÷ L after</th>\
                 <th scope=\"col\">change [%]</th>",
            );
            if has_out {
                b.push_str(
                    "<th scope=\"col\" title=\"outside_identification_range\">outside identification range [%]</th>",
                );
            }
            b.push_str("</tr></thead><tbody>");
            for x in recs {
                let name = str_field(x, "recording");
                let before = x.get("before_position_rmse_over_l").and_then(Value::as_f64);
                let after = x.get("after_position_rmse_over_l").and_then(Value::as_f64);
                let change = match (before, after) {
                    (Some(a), Some(b)) if a != 0.0 => Some(100.0 * (b - a) / a),
                    _ => None,
                };
                let class = match change {
                    Some(c) if c > 0.0 => "warn",
                    _ => "",
                };
                let _ = write!(
                    b,
                    "<tr id=\"{}\" data-case-id=\"{}\" class=\"{class}\"><td class=\"id\">{}</td>",
                    esc(&id_of("recording-", &name)),
                    esc(&name),
                    esc(&name)
                );
                num_cell(&mut b, before);
                num_cell(&mut b, after);
                num_cell(&mut b, change);
                if has_out {
                    num_cell(
                        &mut b,
                        x.get("outside_identification_range")
                            .and_then(Value::as_f64)
                            .map(|v| 100.0 * v),
                    );
                }
                b.push_str("</tr>");
            }
            b.push_str("</tbody></table></div>");
        }
        _ => b.push_str("<p class=\"muted\">No per-recording results in the report.</p>"),
    }
    b.push_str("</section>");

    // ---- figures
    b.push_str("<section id=\"figures\"><h2>Figures</h2>");
    match &files.figures {
        Some(d) if d.is_dir() => {
            let (html, n) = figures_html(d, "dfig", &mut notes, &|_| None)?;
            if n == 0 {
                b.push_str("<p class=\"muted\">No figures in the figures folder.</p>");
            }
            b.push_str(&html);
        }
        Some(d) => {
            notes.push(format!("figures folder {} does not exist", d.display()));
            b.push_str("<p class=\"muted\">No figures.</p>");
        }
        None => b.push_str(
            "<p class=\"muted\">No figures (<code>shipid diagnose --plots DIR</code> draws them).</p>",
        ),
    }
    b.push_str("</section>");

    // ---- where the mismatch is
    b.push_str("<section id=\"located\"><h2>Where the mismatch is</h2>");
    rows_table(
        &mut b,
        r.get("located"),
        "Located mismatch: recording, DOF and time window",
        &[
            ("recording", "recording", false),
            ("dof", "DOF", false),
            ("t_start", "t start [s]", true),
            ("t_end", "t end [s]", true),
            ("mean_residual_over_noise", "mean residual ÷ noise", true),
        ],
    );
    rows_table(
        &mut b,
        r.get("regimes"),
        "Residual by manoeuvre regime",
        &[
            ("regime", "regime", false),
            ("dof", "DOF", false),
            ("samples", "samples", true),
            ("mean_residual_over_noise", "mean residual ÷ noise", true),
        ],
    );
    b.push_str("</section>");

    // ---- augmented model, other keys, raw report
    b.push_str("<section id=\"model\"><h2>Augmented model</h2>");
    match &model {
        Some((p, t)) => {
            let _ = write!(
                b,
                "<details open><summary><code>{}</code></summary>{}</details>",
                esc(&p.display().to_string()),
                toml_block(t)
            );
        }
        None => b.push_str(
            "<p class=\"muted\">No augmented model file (none is written when no effect is found).</p>",
        ),
    }
    let other: Map<String, Value> = r
        .iter()
        .filter(|(k, _)| !KNOWN.contains(&k.as_str()))
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    if !other.is_empty() {
        let _ = write!(
            b,
            "<h3>Further fields of the report</h3>{}",
            json_html(&Value::Object(other))
        );
    }
    let _ = write!(
        b,
        "<details><summary>The report as written <code>{}</code></summary><pre class=\"code\">{}</pre></details>",
        esc(&path.display().to_string()),
        esc(&serde_json::to_string_pretty(&report).unwrap_or(text))
    );
    b.push_str("</section>");
    b.push_str("<footer>Written by shipid-report from the diagnosis files; the page has no script and loads nothing.</footer>");

    let mut warnings = meta.warnings.clone();
    warnings.extend(notes);
    let mut seen = std::collections::HashSet::new();
    warnings.retain(|w| seen.insert(w.clone()));
    b.insert_str(warnings_at, &warnings_box(&warnings));
    let page_title = if says_it {
        format!("{title}: {verdict} — shipid report")
    } else {
        format!("{title}: {verdict} — shipid diagnosis report")
    };
    Ok(page(&page_title, &b))
}

/// The recorded environment: the windage a wind is turned into forces with, the wind and current the
/// recordings carry as known inputs, a found flow against the recorded one, and the `--reveal` check.
/// Nothing when the report has none of these keys (written before they existed).
fn environment_section(b: &mut String, r: &Map<String, Value>) {
    let windage = r.get("windage").and_then(Value::as_object);
    let recorded = r.get("recorded_environment").and_then(Value::as_object);
    let against = r.get("against_recorded").and_then(Value::as_array);
    let reveal = r.get("reveal").and_then(Value::as_object);
    if windage.is_none() && recorded.is_none() && against.is_none() && reveal.is_none() {
        return;
    }
    let g = |v: &Value, k: &str| v.get(k).and_then(Value::as_f64);
    let flow_text = |v: &Value| {
        format!(
            "{} m/s from {}° (mean; {}–{} m/s)",
            g(v, "speed_mean_m_s").map_or("?".into(), num),
            g(v, "from_mean_deg").map_or("?".into(), num),
            g(v, "speed_min_m_s").map_or("?".into(), num),
            g(v, "speed_max_m_s").map_or("?".into(), num)
        )
    };
    b.push_str("<section id=\"environment\"><h2>Recorded environment</h2>");
    let mut rows: Vec<(String, String)> = Vec::new();
    if let Some(w) = windage {
        let assumed = w.get("source").and_then(Value::as_str) == Some("assumed");
        let description = w
            .get("description")
            .and_then(Value::as_str)
            .unwrap_or_default();
        // Whether it is assumed goes with the value: in the label it outgrew a phone's width.
        let value = if assumed && !description.contains("assumed") {
            format!("assumed (the data set gives no [windage]): {description}")
        } else {
            description.to_string()
        };
        rows.push(("windage".into(), value));
    }
    for (key, word) in [("wind", "recorded wind"), ("current", "recorded current")] {
        for x in recorded
            .and_then(|e| e.get(key))
            .and_then(Value::as_array)
            .into_iter()
            .flatten()
        {
            rows.push((
                format!("{word} (known input), {}", str_field(x, "recording")),
                flow_text(x),
            ));
        }
    }
    for a in against.into_iter().flatten() {
        let flow = str_field(a, "flow");
        let on = match a.get("recording").and_then(Value::as_str) {
            Some(rec) => format!(" on {rec}"),
            None => String::new(),
        };
        rows.push((
            format!("{flow} found{on}, not recorded"),
            format!(
                "{} m/s from {}°, against the recorded {}: {} % of its speed, {}° from its direction; felt together {} m/s from {}°",
                g(a, "found_speed_m_s").map_or("?".into(), num),
                g(a, "found_from_deg").map_or("?".into(), num),
                a.get("recorded").map_or("?".into(), flow_text),
                g(a, "speed_ratio").map_or("?".into(), |x| num(100.0 * x)),
                g(a, "direction_difference_deg").map_or("?".into(), num),
                g(a, "felt_speed_m_s").map_or("?".into(), num),
                g(a, "felt_from_deg").map_or("?".into(), num)
            ),
        ));
    }
    if let Some(c) = reveal {
        let right = c.get("verdict_right").and_then(Value::as_bool) == Some(true);
        let expected: Vec<&str> = c
            .get("expected")
            .and_then(Value::as_array)
            .map(|a| a.iter().filter_map(Value::as_str).collect())
            .unwrap_or_default();
        rows.push((
            "--reveal: verdict on the concealed channels".into(),
            format!(
                "{} ({}; expected {})",
                c.get("verdict").and_then(Value::as_str).unwrap_or("?"),
                if right { "right" } else { "wrong" },
                expected.join(" or ")
            ),
        ));
        // A concealed flow against the one found for it.
        let revealed = |f: &Value| {
            let recorded = f.get("recorded").map_or("?".into(), flow_text);
            match (g(f, "found_speed_m_s"), g(f, "found_from_deg")) {
                (Some(s), Some(d)) => format!(
                    "recorded {recorded}; found {} m/s from {}°: speed error {} m/s, direction error {}°",
                    num(s),
                    num(d),
                    g(f, "speed_error_m_s").map_or("?".into(), num),
                    g(f, "direction_error_deg").map_or("?".into(), num)
                ),
                _ => format!("recorded {recorded}; none found"),
            }
        };
        for key in ["wind", "current"] {
            if let Some(f) = c.get(key) {
                rows.push((format!("--reveal: concealed {key}"), revealed(f)));
            }
        }
        for w in c
            .get("wind_per_recording")
            .and_then(Value::as_array)
            .into_iter()
            .flatten()
        {
            rows.push((
                format!("--reveal: concealed wind of {}", str_field(w, "recording")),
                revealed(w),
            ));
        }
    }
    b.push_str(&facts(&rows));
    b.push_str("</section>");
}

/// An effect in the effect syntax (`name:key=value,…`) with its numbers at four significant digits.
fn readable_effect(e: &str) -> String {
    let Some((name, params)) = e.split_once(':') else {
        return e.to_string();
    };
    let params: Vec<String> = params
        .split(',')
        .map(|kv| match kv.split_once('=') {
            Some((k, v)) => match crate::html::parse_num(v.trim()) {
                Some(x) => format!("{k}={}", num(x)),
                None => kv.to_string(),
            },
            None => kv.to_string(),
        })
        .collect();
    format!("{name}: {}", params.join(", "))
}

/// A candidate's word with its form (`variant`) and the other members of a pair (`combined_with`):
/// `asymmetry [rudder_offset] + current`. Reports written before these fields show `effect` alone.
fn candidate_title(c: &Value) -> String {
    let one = |v: &Value| {
        let effect = str_field(v, "effect");
        match v.get("variant").and_then(Value::as_str) {
            Some(form) => format!("{effect} [{form}]"),
            None => effect,
        }
    };
    std::iter::once(one(c))
        .chain(
            c.get("combined_with")
                .and_then(Value::as_array)
                .into_iter()
                .flatten()
                .map(one),
        )
        .collect::<Vec<_>>()
        .join(" + ")
}

fn str_field(v: &Value, k: &str) -> String {
    match v.get(k) {
        Some(Value::String(s)) => s.clone(),
        Some(Value::Null) | None => String::new(),
        Some(x) => x.to_string(),
    }
}

fn num_cell(b: &mut String, x: Option<f64>) {
    match x {
        Some(x) => {
            let _ = write!(b, "<td class=\"n\" title=\"{x}\">{}</td>", esc(&num(x)));
        }
        None => b.push_str("<td class=\"empty\"></td>"),
    }
}

fn params_text(p: &Map<String, Value>) -> Vec<String> {
    p.iter()
        .map(|(k, v)| format!("{k} = {}", v.as_f64().map_or_else(|| v.to_string(), num)))
        .collect()
}

/// A table of an array of objects with the given (key, header, numeric) columns.
fn rows_table(b: &mut String, v: Option<&Value>, title: &str, cols: &[(&str, &str, bool)]) {
    let Some(rows) = v.and_then(Value::as_array).filter(|a| !a.is_empty()) else {
        return;
    };
    // A long list is folded: the verdict, recordings and figures come first for a reader.
    let folded = rows.len() > 12;
    let _ = if folded {
        write!(
            b,
            "<details><summary>{} ({} rows)</summary><div class=\"tablewrap fit\"><table class=\"narrow\"><caption class=\"vh\">{}</caption><thead><tr>",
            esc(title),
            rows.len(),
            esc(title)
        )
    } else {
        write!(
            b,
            "<h3>{}</h3><div class=\"tablewrap fit\"><table class=\"narrow\"><caption class=\"vh\">{}</caption><thead><tr>",
            esc(title),
            esc(title)
        )
    };
    for (k, h, _) in cols {
        let _ = write!(b, "<th scope=\"col\" title=\"{}\">{}</th>", esc(k), esc(h));
    }
    b.push_str("</tr></thead><tbody>");
    for r in rows {
        b.push_str("<tr>");
        for (k, _, numeric) in cols {
            if *numeric {
                num_cell(b, r.get(*k).and_then(Value::as_f64));
            } else {
                let _ = write!(b, "<td>{}</td>", esc(&str_field(r, k)));
            }
        }
        b.push_str("</tr>");
    }
    b.push_str("</tbody></table></div>");
    if folded {
        b.push_str("</details>");
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn effects_are_shown_with_readable_numbers() {
        assert_eq!(
            super::readable_effect("asymmetry:offset=0.8662200838312236,y0=0,n0=0"),
            "asymmetry: offset=0.8662, y0=0, n0=0"
        );
        assert_eq!(super::readable_effect("odd"), "odd");
    }
}
