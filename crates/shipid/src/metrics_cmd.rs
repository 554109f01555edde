//! `shipid metrics DATASET.toml [--json]`: IMO metrics of every recording of a data set.

use std::path::Path;

use serde_json::{Map, Value, json};
use shipid_io::Dataset;
use shipid_sim::{Metrics, metrics};

use crate::{CliError, Outcome};

/// Metrics of every recording, keyed by file name.
pub fn dataset_metrics(ds: &Dataset) -> Vec<(String, &'static str, Metrics)> {
    ds.recordings
        .iter()
        .map(|r| {
            (
                r.file.clone(),
                r.manoeuvre.kind(),
                metrics(&r.recording, &r.manoeuvre, &ds.ship),
            )
        })
        .collect()
}

/// `{"recordings": {"<file>": {"kind": ..., <metric keys>}}}` (the metric keys of docs/data-format.md).
pub fn metrics_json(rows: &[(String, &'static str, Metrics)]) -> Value {
    let mut recs = Map::new();
    for (file, kind, m) in rows {
        let mut o = Map::new();
        o.insert("kind".into(), json!(kind));
        // An undefined metric is absent, never `null`: JSON has no NaN or infinity, and serde_json
        // would write a non-finite value as null.
        for (key, value) in m.entries() {
            if let Some(v) = value.filter(|v| v.is_finite()) {
                o.insert(key.into(), json!(v));
            }
        }
        recs.insert(file.clone(), Value::Object(o));
    }
    json!({ "recordings": recs })
}

pub fn run(dataset: &Path, as_json: bool) -> Result<Outcome, CliError> {
    use shipid_pipeline::validate::{
        approach_notes, declared_manoeuvre_notes, require_recordings, undefined_metrics_reason,
    };
    let ds = Dataset::load(dataset)?;
    require_recordings(&ds)?;
    let rows = dataset_metrics(&ds);
    // The declarations validate questions are questioned here too: the metrics rest on them.
    let mut warnings = declared_manoeuvre_notes(&ds);
    warnings.extend(approach_notes(&ds));
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    // A "-" says nothing on its own: each recording with one says why.
    let undefined: Vec<(String, String)> = ds
        .recordings
        .iter()
        .zip(&rows)
        .filter_map(|(r, (_, _, m))| {
            undefined_metrics_reason(r, &ds.ship, m).map(|why| (r.file.clone(), why))
        })
        .collect();
    if as_json {
        let mut out = metrics_json(&rows);
        for (file, why) in &undefined {
            out["recordings"][file]["undefined"] = json!(why);
        }
        if !warnings.is_empty() {
            out["warnings"] = json!(warnings);
        }
        println!("{}", serde_json::to_string_pretty(&out).unwrap_or_default());
    } else {
        println!("{} ({})", ds.name, dataset.display());
        println!("{}", metrics_table(&rows));
        println!(
            "times t_a and t_check × U0/L, distances ÷ L (docs/conventions.md); - undefined{}",
            if undefined.is_empty() { "" } else { ":" }
        );
        for (_, why) in &undefined {
            println!("  {why}");
        }
    }
    Ok(Outcome::Ok)
}

/// A plain-text table: one row per recording, one column per metric.
pub fn metrics_table(rows: &[(String, &'static str, Metrics)]) -> String {
    let header = [
        "recording",
        "kind",
        "os1 [deg]",
        "os2 [deg]",
        "t_a·U0/L",
        "t_check·U0/L",
        "advance/L",
        "transfer/L",
        "tact. D/L",
        "steady D/L",
    ];
    let width = rows.iter().map(|r| r.0.len()).max().unwrap_or(9).max(9);
    let mut lines = vec![
        std::iter::once(format!("{:<width$}", header[0]))
            .chain(header[1..].iter().map(|h| format!("{h:>12}")))
            .collect::<Vec<_>>()
            .join(" "),
    ];
    for (file, kind, m) in rows {
        let mut cells = vec![format!("{file:<width$}"), format!("{kind:>12}")];
        for (_, v) in m.entries() {
            cells.push(
                v.filter(|x| x.is_finite())
                    .map_or_else(|| format!("{:>12}", "-"), |x| format!("{x:>12.3}")),
            );
        }
        lines.push(cells.join(" "));
    }
    lines.join("\n")
}
