//! `shipid validate MODEL.toml DATASET.toml [--json]`.

use std::path::Path;

use serde_json::{Map, json};
use shipid_io::{Dataset, PrimeScale};

use crate::range::{gp_outside_fraction, identification_range, outside_fraction, training_data};
use crate::simulate_cmd::load_model;
use crate::validate::validate_recording;
use crate::{CliError, Outcome};

pub fn run(model_spec: &str, dataset: &Path, as_json: bool) -> Result<Outcome, CliError> {
    let model = load_model(model_spec)?;
    let ds = Dataset::load(dataset)?;
    // Where the model was identified: a recording mostly outside that range tests the model's
    // extrapolation, not its fit. A sparse GP carries its range (its sparse points' coverage); a
    // polynomial's needs the training data its file names, when they can still be read.
    let gp = model.sparse_gp();
    let range = if gp.is_some() {
        None
    } else {
        training_data(model_spec)
            .as_ref()
            .and_then(identification_range)
    };
    let scale = PrimeScale::of(&ds.ship);
    let mut recs = Map::new();
    let mut any_failed = false;
    for r in &ds.recordings {
        let v = validate_recording(model.as_ref(), r, &ds.ship);
        any_failed |= v.diverged();
        let mut value = serde_json::to_value(&v).unwrap_or_default();
        let outside = match (&range, &gp) {
            (Some(range), _) => Some(outside_fraction(
                range,
                &r.recording,
                &scale,
                0..r.recording.len(),
            )),
            (None, Some(gp)) => Some(gp_outside_fraction(gp, &r.recording)),
            (None, None) => None,
        };
        if let (Some(f), Some(obj)) = (outside, value.as_object_mut()) {
            obj.insert("outside_identification_range".into(), json!(f));
        }
        recs.insert(r.file.clone(), value);
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
        if range.is_some() {
            println!(
                "outside: share of the recording's states outside the model's identification range (leverage above every training state's; there its forces are extrapolated)"
            );
        } else if gp.is_some() {
            println!(
                "outside: share of the recording's states outside the sparse GP's identification range (no sparse point d_gen-similar, paper 001's test that every training state passes; there its mean reverts towards its constant)"
            );
        }
    }
    Ok(if any_failed {
        Outcome::SomeFailed
    } else {
        Outcome::Ok
    })
}
