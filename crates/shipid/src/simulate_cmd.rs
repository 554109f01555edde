//! `shipid simulate MODEL --manoeuvre SPEC [--dt S] [--duration S] [--json] [--out FILE.csv]`.

use std::path::Path;

use serde_json::{Map, Value, json};
use shipid_io::Manoeuvre;
use shipid_io::write::{recording_csv, write_atomic};
use shipid_sim::{Dynamics, MmgModel, SimOptions, SimOutput, SimStatus, State, controller_for, metrics};

use crate::generate::{DT_S, SAMPLE_INTERVAL_S, T_EXECUTE_S, standard_duration_s};
use crate::spec::parse_manoeuvre;
use crate::{CliError, Outcome, bad_input, failed};

/// A model named on the command line: `mmg:kvlcc2` (the reference).
pub fn load_model(spec: &str) -> Result<Box<dyn Dynamics + Send + Sync>, CliError> {
    match spec {
        "mmg:kvlcc2" => Ok(Box::new(MmgModel::kvlcc2())),
        other => Err(bad_input(format!(
            "unknown model `{other}`: expected `mmg:kvlcc2` or a model file"
        ))),
    }
}

/// Simulate a standard manoeuvre from a steady approach at U0.
pub fn simulate_manoeuvre(
    model: &dyn Dynamics,
    m: &Manoeuvre,
    dt_s: Option<f64>,
    duration_s: Option<f64>,
) -> Result<SimOutput, CliError> {
    let ship = *model.ship();
    let mut controller = controller_for(m, T_EXECUTE_S).map_err(|e| bad_input(e))?;
    let dt = dt_s.unwrap_or(DT_S);
    // Sample at 10 Hz when the step divides it, otherwise every step.
    let ratio = (SAMPLE_INTERVAL_S / dt).round();
    let sample = if ratio >= 1.0 && (ratio * dt - SAMPLE_INTERVAL_S).abs() < 1e-9 { ratio * dt } else { dt };
    let options = SimOptions::new(duration_s.unwrap_or_else(|| standard_duration_s(m, &ship))).with_step(dt, sample);
    shipid_sim::simulate(model, controller.as_mut(), State::approach(ship.u0), &options)
        .map_err(|e| bad_input(e))
}

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
        println!("{}", serde_json::to_string_pretty(&value).unwrap_or_default());
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
