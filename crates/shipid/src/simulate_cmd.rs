//! `shipid simulate MODEL --manoeuvre SPEC [--dt S] [--duration S] [--json] [--out FILE.csv]`.

use std::path::Path;

use serde_json::{Map, Value, json};
use shipid_io::Manoeuvre;
use shipid_io::write::{recording_csv, write_atomic};
use shipid_model::{AugmentedModelFile, EffectEntry, ModelFile};
use shipid_sim::{
    AbkowitzDynamics, Dynamics, Effect, MmgModel, SimOptions, SimOutput, SimStatus, State,
    WithEffects, controller_for, metrics,
};

use crate::generate::{DT_S, SAMPLE_INTERVAL_S, T_EXECUTE_S, standard_duration_s};
use crate::spec::parse_manoeuvre;
use crate::{CliError, Outcome, bad_input, failed};

/// A model named on the command line: `mmg:kvlcc2` (the reference), a model file written by `shipid fit`,
/// or an augmented model file (`base = …` plus effects) written by `shipid diagnose`. Effects in the
/// file are applied around the model, so every simulation includes them.
pub fn load_model(spec: &str) -> Result<Box<dyn Dynamics + Send + Sync>, CliError> {
    let (base, effects) = load_model_parts(spec)?;
    if effects.is_empty() {
        return Ok(base);
    }
    let wrapped =
        WithEffects::new(base, &effects).map_err(|e| bad_input(format!("{spec}: effects: {e}")))?;
    Ok(Box::new(wrapped))
}

/// The model without its effects, and its effects (see [`load_model`]).
pub fn load_model_parts(
    spec: &str,
) -> Result<(Box<dyn Dynamics + Send + Sync>, Vec<Effect>), CliError> {
    load_parts(spec, 0)
}

fn parse_entries(path: &Path, entries: &[EffectEntry]) -> Result<Vec<Effect>, CliError> {
    entries
        .iter()
        .enumerate()
        .map(|(i, e)| {
            e.effect.parse::<Effect>().map_err(|err| {
                bad_input(format!(
                    "{}: key `effects[{i}].effect`: {err}",
                    path.display()
                ))
            })
        })
        .collect()
}

fn load_parts(
    spec: &str,
    depth: usize,
) -> Result<(Box<dyn Dynamics + Send + Sync>, Vec<Effect>), CliError> {
    if spec == "mmg:kvlcc2" {
        return Ok((Box::new(MmgModel::kvlcc2()), Vec::new()));
    }
    let path = Path::new(spec);
    if spec.starts_with("mmg:") || !path.is_file() {
        return Err(bad_input(format!(
            "unknown model `{spec}`: expected `mmg:kvlcc2` or a model file"
        )));
    }
    let text = std::fs::read_to_string(path).map_err(|e| shipid_io::InputError::read(path, &e))?;
    let is_augmented = toml::from_str::<toml::Table>(&text)
        .map(|t| t.contains_key("base"))
        .unwrap_or(false);
    if is_augmented {
        let file: AugmentedModelFile =
            toml::from_str(&text).map_err(|e| shipid_io::InputError::toml(path, &text, &e))?;
        if depth > 4 {
            return Err(bad_input(format!(
                "{}: key `base`: too many nested augmented model files",
                path.display()
            )));
        }
        let base_spec = if file.base.starts_with("mmg:") {
            file.base.clone()
        } else {
            path.parent()
                .unwrap_or(Path::new("."))
                .join(&file.base)
                .display()
                .to_string()
        };
        let (base, mut effects) = load_parts(&base_spec, depth + 1)?;
        for e in parse_entries(path, &file.effects)? {
            effects.retain(|x| x.kind() != e.kind());
            effects.push(e);
        }
        return Ok((base, effects));
    }
    if let Some(gp) = crate::fit_gp::load_gp_model(path, &text)? {
        return Ok((Box::new(gp), Vec::new()));
    }
    let file: ModelFile =
        toml::from_str(&text).map_err(|e| shipid_io::InputError::toml(path, &text, &e))?;
    let model = file
        .to_model()
        .map_err(|e| bad_input(format!("{}: {e}", path.display())))?;
    let effects = parse_entries(path, &file.effects)?;
    Ok((Box::new(AbkowitzDynamics(model)), effects))
}

/// Simulate a standard manoeuvre from a steady approach at U0.
pub fn simulate_manoeuvre(
    model: &dyn Dynamics,
    m: &Manoeuvre,
    dt_s: Option<f64>,
    duration_s: Option<f64>,
) -> Result<SimOutput, CliError> {
    let ship = *model.ship();
    let mut controller = controller_for(m, T_EXECUTE_S).map_err(bad_input)?;
    let dt = dt_s.unwrap_or(DT_S);
    // Sample at 10 Hz when the step divides it, otherwise every step.
    let ratio = (SAMPLE_INTERVAL_S / dt).round();
    let sample = if ratio >= 1.0 && (ratio * dt - SAMPLE_INTERVAL_S).abs() < 1e-9 {
        ratio * dt
    } else {
        dt
    };
    let options = SimOptions::new(duration_s.unwrap_or_else(|| standard_duration_s(m, &ship)))
        .with_step(dt, sample);
    shipid_sim::simulate(
        model,
        controller.as_mut(),
        model.over_ground(&State::approach(ship.u0)),
        &options,
    )
    .map_err(bad_input)
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

/// `--replay DATASET.toml`: every recording's rudder replayed from its initial state.
pub fn run_replay(model_spec: &str, dataset: &Path, as_json: bool) -> Result<Outcome, CliError> {
    let model = load_model(model_spec)?;
    let ds = shipid_io::Dataset::load(dataset)?;
    let mut recs = Map::new();
    let mut any_failed = false;
    for r in &ds.recordings {
        let sim = crate::validate::replay(model.as_ref(), &r.recording);
        let errors = crate::validate::replay_errors(&sim, &r.recording, model.ship());
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
