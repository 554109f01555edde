//! `shipid simulate MODEL --manoeuvre SPEC [--dt S] [--duration S] [--json] [--out FILE.csv]`.

use std::path::Path;

use serde_json::{Map, Value, json};
use shipid_io::Manoeuvre;
use shipid_io::write::{recording_csv, write_atomic};
use shipid_pipeline::model_file::load_model;
use shipid_pipeline::simulate::simulate_manoeuvre;
use shipid_pipeline::spec::parse_manoeuvre;
use shipid_sim::{Dynamics, SimOutput, SimStatus, metrics};

use crate::{CliError, Outcome, bad_input, failed};

/// The JSON of a simulated manoeuvre: `"status"` and the metric keys, or the divergence instead.
pub fn outcome_json(out: &SimOutput, m: &Manoeuvre, model: &dyn Dynamics) -> Value {
    let mut o = Map::new();
    match &out.status {
        SimStatus::Ok => {
            o.insert("status".into(), json!("ok"));
            for (key, value) in metrics(&out.recording, m, model.ship()).entries() {
                if let Some(v) = value {
                    o.insert(key.into(), json!(v));
                }
            }
        }
        SimStatus::Diverged { t_s, reason } => {
            o.insert("status".into(), json!("diverged"));
            o.insert("t_s".into(), json!(t_s));
            o.insert("reason".into(), json!(reason));
        }
    }
    Value::Object(o)
}

/// `--replay DATASET.toml`: every recording's rudder replayed from its initial state.
pub fn run_replay(model_spec: &str, dataset: &Path, as_json: bool) -> Result<Outcome, CliError> {
    let model = load_model(model_spec)?;
    let ds = shipid_io::Dataset::load(dataset)?;
    let mut recs = Map::new();
    let mut any_failed = false;
    for r in &ds.recordings {
        let sim = shipid_pipeline::validate::replay(model.as_ref(), &r.recording);
        let errors = shipid_pipeline::validate::replay_errors(&sim, &r.recording, model.ship());
        let mut o = match serde_json::to_value(&sim.status) {
            Ok(Value::Object(o)) => o,
            _ => Map::new(),
        };
        if matches!(sim.status, SimStatus::Ok) {
            for (key, value) in metrics(&sim.recording, &r.manoeuvre, model.ship()).entries() {
                if let Some(v) = value {
                    o.insert(key.into(), json!(v));
                }
            }
        } else {
            any_failed = true;
        }
        o.insert(
            "errors".into(),
            serde_json::to_value(&errors).unwrap_or_default(),
        );
        recs.insert(r.file.clone(), Value::Object(o));
    }
    let value = json!({ "model": model_spec, "dataset": dataset.display().to_string(), "recordings": recs });
    if as_json {
        println!(
            "{}",
            serde_json::to_string_pretty(&value).unwrap_or_default()
        );
    } else {
        for (file, v) in &recs {
            println!("{file}: {v}");
        }
    }
    Ok(if any_failed {
        Outcome::SomeFailed
    } else {
        Outcome::Ok
    })
}

pub fn run(
    model_spec: &str,
    manoeuvre: &str,
    dt_s: Option<f64>,
    duration_s: Option<f64>,
    as_json: bool,
    out_csv: Option<&Path>,
) -> Result<Outcome, CliError> {
    let m = parse_manoeuvre(manoeuvre).map_err(bad_input)?;
    let model = load_model(model_spec)?;
    let out = simulate_manoeuvre(model.as_ref(), &m, dt_s, duration_s)?;
    if let Some(path) = out_csv {
        let comments = vec![format!(
            "shipid {} simulate {model_spec} --manoeuvre {manoeuvre}; midship, SI, rudder positive to starboard",
            env!("CARGO_PKG_VERSION")
        )];
        write_atomic(path, recording_csv(&out.recording, &comments).as_bytes()).map_err(failed)?;
    }
    let value = outcome_json(&out, &m, model.as_ref());
    if as_json {
        println!(
            "{}",
            serde_json::to_string_pretty(&value).unwrap_or_default()
        );
    } else if let Value::Object(o) = &value {
        for (k, v) in o {
            println!("{k:>18}: {v}");
        }
    }
    Ok(match out.status {
        SimStatus::Ok => Outcome::Ok,
        SimStatus::Diverged { .. } => Outcome::SomeFailed,
    })
}
