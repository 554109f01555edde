//! Printing shared by several commands (the binary's only shared output code).

use serde_json::{Map, Value, json};
use shipid_io::Dataset;
use shipid_pipeline::validate::{RangeSource, propeller_rate_variations, validate_dataset};
use shipid_sim::Dynamics;

use crate::Outcome;

/// Validates `model` on every recording of `ds` and prints the table (or the JSON with `as_json`);
/// `SomeFailed` when a simulation diverged.
pub fn validation(model: &dyn Dynamics, model_spec: &str, ds: &Dataset, as_json: bool) -> Outcome {
    let (rows, source) = validate_dataset(model, model_spec, ds);
    let dataset = &ds.path;
    let any_failed = rows.iter().any(|r| r.validation.diverged());
    let recs: Map<String, Value> = rows
        .iter()
        .map(|r| (r.file.clone(), serde_json::to_value(r).unwrap_or_default()))
        .collect();
    let mut value = json!({
        "model": model_spec,
        "dataset": dataset.display().to_string(),
        "method": "replay: recorded rudder from the recorded initial state (RMSEs); manoeuvre: the recording's standard manoeuvre re-simulated in closed loop (metrics)",
        "recordings": recs,
    });
    let warnings: Vec<String> = propeller_rate_variations(&ds.recordings)
        .iter()
        .map(ToString::to_string)
        .collect();
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    if !warnings.is_empty()
        && let Value::Object(o) = &mut value
    {
        o.insert("warnings".into(), json!(warnings));
    }
    if as_json {
        println!(
            "{}",
            serde_json::to_string_pretty(&value).unwrap_or_default()
        );
    } else {
        println!(
            "{:<16} {:>10} {:>9} {:>9} {:>9} {:>9} {:>8} {:>8}",
            "recording", "pos/L", "psi[deg]", "u[m/s]", "v[m/s]", "r[deg/s]", "MRAE", "outside"
        );
        for (file, v) in &recs {
            let f = |k: &str| {
                v["replay"][k]
                    .as_f64()
                    .map_or("-".into(), |x| format!("{x:.4}"))
            };
            let mrae = v["manoeuvre"]["mrae"]
                .as_f64()
                .map_or("-".into(), |x| format!("{:.1}%", 100.0 * x));
            let outside = v["outside_identification_range"]
                .as_f64()
                .map_or("-".into(), |x| format!("{:.0}%", 100.0 * x));
            let status = v["replay"]["status"].as_str().unwrap_or("?").to_string();
            println!(
                "{file:<16} {:>10} {:>9} {:>9} {:>9} {:>9} {:>8} {:>8} {}",
                f("position_rmse_over_l"),
                f("heading_rmse_deg"),
                f("u_rmse_m_s"),
                f("v_rmse_m_s"),
                f("r_rmse_deg_s"),
                mrae,
                outside,
                if status == "ok" {
                    String::new()
                } else {
                    status
                }
            );
        }
        if source == RangeSource::Leverage {
            println!(
                "outside: share of the recording's states outside the model's identification range (leverage above every training state's; there its forces are extrapolated)"
            );
        } else if source == RangeSource::Coverage {
            println!(
                "outside: share of the recording's states outside the sparse GP's identification range (no sparse point d_gen-similar, paper 001's test that every training state passes; there its mean reverts towards its constant)"
            );
        } else {
            // Said, not left as a bare "-": a user would otherwise read it as "nothing outside".
            println!(
                "outside: not available for this model (the mmg family and the reference carry no identification range; a polynomial's needs its training data, see the warnings above)"
            );
        }
    }
    if any_failed {
        Outcome::SomeFailed
    } else {
        Outcome::Ok
    }
}
