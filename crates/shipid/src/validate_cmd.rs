//! `shipid validate MODEL.toml DATASET.toml [--json]`.

use std::path::Path;

use serde_json::{Map, json};
use shipid_io::Dataset;

use crate::simulate_cmd::load_model;
use crate::validate::validate_recording;
use crate::{CliError, Outcome};

pub fn run(model_spec: &str, dataset: &Path, as_json: bool) -> Result<Outcome, CliError> {
    let model = load_model(model_spec)?;
    let ds = Dataset::load(dataset)?;
    let mut recs = Map::new();
    let mut any_failed = false;
    for r in &ds.recordings {
        let v = validate_recording(model.as_ref(), r, &ds.ship);
        any_failed |= v.diverged();
        recs.insert(r.file.clone(), serde_json::to_value(&v).unwrap_or_default());
    }
    let value = json!({
        "model": model_spec,
        "dataset": dataset.display().to_string(),
        "method": "replay: recorded rudder from the recorded initial state (RMSEs); manoeuvre: the recording's standard manoeuvre re-simulated in closed loop (metrics)",
        "recordings": recs,
    });
    if as_json {
        println!(
            "{}",
            serde_json::to_string_pretty(&value).unwrap_or_default()
        );
    } else {
        println!(
            "{:<16} {:>10} {:>9} {:>9} {:>9} {:>9} {:>8}",
            "recording", "pos/L", "psi[deg]", "u[m/s]", "v[m/s]", "r[deg/s]", "MRAE"
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
            let status = v["replay"]["status"].as_str().unwrap_or("?").to_string();
            println!(
                "{file:<16} {:>10} {:>9} {:>9} {:>9} {:>9} {:>8} {}",
                f("position_rmse_over_l"),
                f("heading_rmse_deg"),
                f("u_rmse_m_s"),
                f("v_rmse_m_s"),
                f("r_rmse_deg_s"),
                mrae,
                if status == "ok" {
                    String::new()
                } else {
                    status
                }
            );
        }
    }
    Ok(if any_failed {
        Outcome::SomeFailed
    } else {
        Outcome::Ok
    })
}
