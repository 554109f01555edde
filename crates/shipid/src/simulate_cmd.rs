//! `shipid simulate MODEL --manoeuvre SPEC [--dt S] [--duration S] [--wind SPEED,FROM]
//! [--current SPEED,FROM] [--json] [--out FILE.csv]`, or `--replay DATASET.toml` (each recording in
//! its recorded wind and current).

use std::path::Path;

use serde_json::{Map, Value, json};
use shipid_io::Manoeuvre;
use shipid_io::write::{recording_csv, write_atomic};
use shipid_pipeline::bands::BandRun;
use shipid_pipeline::calibration::{ModelBands, RunBands};
use shipid_pipeline::model_file::load_model;
use shipid_pipeline::simulate::{
    MAX_STORED_SAMPLES, OwnRateApproach, SimRequest, constant_environment, own_rate_approach,
    parse_flow, sim_grid, simulate_on_grid_in, simulation_windage, straight_run_speed,
};
use shipid_pipeline::spec::parse_manoeuvre;
use shipid_sim::{Dynamics, RecordedRate, SimOutput, SimStatus, WithPropellerRate, metrics};

use crate::{CliError, Outcome, bad_input};

/// For `--bands` on a model file written by `shipid inverse` that has no `[bootstrap]` (no ensemble):
/// the advice that applies to it. `fit --bootstrap` cannot reproduce an inverse model (it has no
/// `[training]`); its band is the ensemble `inverse` writes when it refines. `None` for any other
/// file (or one that does not parse: the loader says what is wrong with it).
fn inverse_without_ensemble(model: &str) -> Option<String> {
    let text = std::fs::read_to_string(model).ok()?;
    let table: toml::Table = toml::from_str(&text).ok()?;
    let inverse = table
        .get("estimator")
        .and_then(|e| e.get("name"))
        .and_then(|n| n.as_str())
        == Some("inverse-network");
    (inverse && !table.contains_key("bootstrap")).then(|| {
        format!(
            "{model}: key `bootstrap`: missing: --bands needs the replicates of an ensemble, and this model \
             was written by `shipid inverse` without one (with --refine-evals 0 it is the network's \
             answer alone; with refinement, fewer than two members were kept). Rerun `shipid inverse` \
             on its targets file with refinement on (--refine-evals above 0; the default is 150): the \
             ensemble of networks and refinement restarts is written under [bootstrap] and gives the \
             band"
        )
    })
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

/// `--replay DATASET.toml`: every recording's rudder replayed from its initial state, in its recorded
/// wind and current, and each standard manoeuvre re-simulated with its own rudder law — as
/// `validate` does. The IMO metrics of the open-loop replay were given before 2026-12-02: with the
/// rudder no longer answering the heading they measure nothing (an overshoot of 110° where the
/// re-simulation predicts 2.8°).
pub fn run_replay(model_spec: &str, dataset: &Path, as_json: bool) -> Result<Outcome, CliError> {
    let model = load_model(model_spec)?;
    let ds = shipid_io::Dataset::load(dataset)?;
    // The same replay as validate's: the same warnings, and errors and metrics in the data set's L
    // and U0, so that both commands give one number under one key.
    let mut warnings = crate::validate_cmd::ship_warnings(
        model_spec,
        model.ship(),
        model.added_mass(),
        &ds,
        dataset,
    );
    warnings.extend(shipid_pipeline::validate::validation_warnings(
        model_spec,
        Some(model.as_ref()),
        &ds,
    ));
    if model.own_range().is_none() {
        warnings.extend(crate::print::training_range_warnings(
            model_spec,
            "`outside_identification_range`",
        ));
    }
    let (rows, _) = shipid_pipeline::validate::validate_dataset(model.as_ref(), model_spec, &ds);
    warnings.extend(rows.iter().filter(|r| !r.beyond_training.is_empty()).map(|r| {
        format!(
            "{}: the recording goes past the extremes of the states {model_spec} was identified on ({}): its predictions are extrapolations, whatever its `outside` share",
            r.file,
            r.beyond_training.join(", ")
        )
    }));
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    let any_failed = rows.iter().any(|r| r.validation.diverged());
    let recs: Map<String, Value> = rows
        .iter()
        .map(|r| (r.file.clone(), serde_json::to_value(r).unwrap_or_default()))
        .collect();
    let mut value = json!({
        "model": model_spec,
        "dataset": dataset.display().to_string(),
        "scaled_by": { "lpp_m": ds.ship.lpp, "u0_m_s": ds.ship.u0, "ship": "the data set's" },
        "recordings": recs,
    });
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
            "replay of {} on {} (lengths ÷ the data set's L = {} m)",
            model_spec,
            dataset.display(),
            ds.ship.lpp
        );
        for r in &rows {
            println!("{}", replay_line(r));
        }
        println!(
            "replay: the recorded rudder from the recorded initial state, RMS errors (position ÷ L); closed loop: the manoeuvre re-simulated with its rudder law, its IMO metrics (angles [deg], times ÷ L/U0, lengths ÷ L); outside: share of the recording's states outside the model's identification range"
        );
    }
    Ok(if any_failed {
        Outcome::SomeFailed
    } else {
        Outcome::Ok
    })
}

/// One recording of `simulate --replay` as text.
fn replay_line(r: &shipid_pipeline::validate::ValidatedRecording) -> String {
    let e = &r.validation.replay;
    let replay = match &e.status {
        SimStatus::Ok => format!(
            "replay pos/L {:.4}, ψ {:.2}°, u {:.4} m/s, v {:.4} m/s, r {:.4}°/s",
            e.position_rmse_over_l, e.heading_rmse_deg, e.u_rmse_m_s, e.v_rmse_m_s, e.r_rmse_deg_s
        ),
        other => format!(
            "replay {}",
            serde_json::to_string(other).unwrap_or_default()
        ),
    };
    let closed = match &r.validation.manoeuvre {
        None => String::new(),
        Some(m) => match &m.predicted {
            Some(p) => {
                let values: Vec<String> = p
                    .entries()
                    .iter()
                    .filter_map(|(k, v)| v.map(|v| format!("{k} {v:.4}")))
                    .collect();
                let left = m
                    .left_manoeuvre
                    .as_ref()
                    .map(|why| format!(" (left the manoeuvre: {why})"))
                    .unwrap_or_default();
                format!("; closed loop {}{left}", values.join(", "))
            }
            None => format!(
                "; closed loop {}",
                serde_json::to_string(&m.status).unwrap_or_default()
            ),
        },
    };
    let outside = r
        .outside_identification_range
        .map(|o| format!("; outside {:.1} %", 100.0 * o))
        .unwrap_or_default();
    format!("{}: {replay}{closed}{outside}", r.file)
}

/// A JSON value of `simulate`'s report as text: numbers without their rounding noise, strings
/// without quotes, a table as `key value, …` (the approach at another propeller rate, a wind, a
/// current), where the text output printed the raw JSON.
fn plain(v: &Value) -> String {
    match v {
        Value::Number(n) => n.as_f64().map_or_else(|| n.to_string(), short_number),
        Value::String(s) => s.clone(),
        Value::Array(items) => format!(
            "[{}]",
            items.iter().map(plain).collect::<Vec<_>>().join(", ")
        ),
        Value::Object(o) => o
            .iter()
            .map(|(k, v)| format!("{k} {}", plain(v)))
            .collect::<Vec<_>>()
            .join(", "),
        other => other.to_string(),
    }
}

/// A number with at most 6 significant digits, trailing zeros dropped (214.10000000000002 reads
/// 214.1, 1e-7 stays 1e-7).
fn short_number(x: f64) -> String {
    if !x.is_finite() {
        return x.to_string();
    }
    if x != 0.0 && (x.abs() < 1e-4 || x.abs() >= 1e9) {
        let s = format!("{x:.5e}");
        let (mantissa, exponent) = s.split_once('e').unwrap_or((&s, "0"));
        let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
        return format!("{mantissa}e{exponent}");
    }
    let digits = (5 - x.abs().log10().floor() as i32).clamp(0, 12) as usize;
    let s = format!("{x:.digits$}");
    match s.contains('.') {
        true => s.trim_end_matches('0').trim_end_matches('.').to_string(),
        false => s,
    }
}

/// A time [s] as a person would write it: the sum of whole steps without its rounding noise
/// (1.2000000000000002 reads 1.2).
fn seconds(t: f64) -> String {
    let rounded = (t * 1e9).round() / 1e9;
    format!("{rounded}")
}

/// Flags of `shipid simulate --manoeuvre`.
pub struct SimulateArgs<'a> {
    pub model: &'a str,
    pub manoeuvre: &'a str,
    pub dt_s: Option<f64>,
    pub duration_s: Option<f64>,
    pub allow_large: bool,
    pub json: bool,
    pub out_csv: Option<&'a Path>,
    /// `--bands LEVEL`: bands over the model file's replicates, calibrated when it has a
    /// `[calibration]`.
    pub bands: Option<f64>,
    /// `--wind SPEED_M_S,FROM_DEG`: a constant true wind.
    pub wind: Option<&'a str>,
    /// `--current SPEED_M_S,FROM_DEG`: a constant current.
    pub current: Option<&'a str>,
    /// `--propeller-rate N`: the propeller at `N` [1/s] instead of the model's own rate.
    pub propeller_rate_hz: Option<f64>,
}

/// `--propeller-rate`: the model at that constant rate and its straight-run speed there, checked
/// before any simulation (a model without a rate input, a rate that is not a positive number, a rate
/// at which the model runs straight at no speed between 2 % and three times U0 are bad input).
fn at_propeller_rate<'m>(
    model: &'m dyn Dynamics,
    model_spec: &str,
    n_hz: f64,
) -> Result<(WithPropellerRate<&'m dyn Dynamics>, f64), CliError> {
    if !(n_hz.is_finite() && n_hz > 0.0) {
        return Err(bad_input(format!(
            "--propeller-rate must be a positive number of revolutions per second, got {n_hz}"
        )));
    }
    if !model.takes_propeller_rate() {
        return Err(bad_input(format!(
            "--propeller-rate: {model_spec} has no propeller-rate input (a polynomial set or a sparse GP holds the rate its training runs had; fit --set mmg for a model that takes it)"
        )));
    }
    let driven = WithPropellerRate::new(model, RecordedRate::constant(n_hz));
    let u = straight_run_speed(&driven).ok_or_else(|| {
        bad_input(format!(
            "--propeller-rate {n_hz}: {model_spec} runs straight at no speed between 2 % and 3 times U0 = {} m/s at that rate",
            model.ship().u0
        ))
    })?;
    Ok((driven, u))
}

pub fn run(a: &SimulateArgs<'_>) -> Result<Outcome, CliError> {
    let m = parse_manoeuvre(a.manoeuvre).map_err(|e| bad_input(format!("--manoeuvre: {e}")))?;
    if let Some(level) = a.bands
        && !(level > 0.0 && level < 1.0)
    {
        return Err(bad_input(format!(
            "--bands must be a level strictly between 0 and 1 (e.g. 0.9), got {level}"
        )));
    }
    let wind = a.wind.map(|w| parse_flow("--wind", w)).transpose()?;
    let current = a.current.map(|c| parse_flow("--current", c)).transpose()?;
    if a.bands.is_some() && (wind.is_some() || current.is_some()) {
        return Err(bad_input(
            "--bands does not apply with --wind or --current: the bootstrap replicates run in calm water",
        ));
    }
    if a.bands.is_some() && a.propeller_rate_hz.is_some() {
        return Err(bad_input(
            "--bands does not apply with --propeller-rate: the bootstrap replicates run at the model's own rate",
        ));
    }
    let loaded = load_model(a.model)?;
    let rate = a
        .propeller_rate_hz
        .map(|n| at_propeller_rate(loaded.as_ref(), a.model, n))
        .transpose()?;
    if let (Some((_, u)), Some(n)) = (&rate, a.propeller_rate_hz) {
        eprintln!(
            "note: --propeller-rate {n} 1/s (the model's own: {}): approach at {u:.4} m/s, the model's straight-run speed at that rate (U0 = {} m/s)",
            loaded
                .propeller_rate_hz()
                .map_or("none".into(), |own| format!("{own:.4} 1/s")),
            loaded.ship().u0
        );
    }
    let u0 = loaded.ship().u0;
    let approach_m_s = match &rate {
        Some((_, u)) => *u,
        None => match own_rate_approach(loaded.as_ref()) {
            OwnRateApproach::AtU0 => u0,
            OwnRateApproach::StraightRun { speed_m_s, rate_hz } => {
                eprintln!(
                    "note: {} runs straight at {speed_m_s:.4} m/s ({:.2} U0) at its own propeller rate {rate_hz:.4} 1/s, not at U0 = {u0:.3} m/s: the manoeuvre starts from that steady approach (--propeller-rate N for another rate)",
                    a.model,
                    speed_m_s / u0
                );
                speed_m_s
            }
            OwnRateApproach::NoStraightRun { rate_hz } => {
                eprintln!(
                    "warning: {} runs straight at no speed between 2 % and 3 times U0 at its own propeller rate {rate_hz:.4} 1/s: the manoeuvre starts at U0 = {u0:.3} m/s and its approach is not steady",
                    a.model
                );
                u0
            }
        },
    };
    let model: &dyn Dynamics = match &rate {
        Some((driven, _)) => driven,
        None => loaded.as_ref(),
    };
    // t_a and t_check are divided by L/U0 with the ship's U0 (docs/conventions.md), not by the
    // approach speed: at 0.08 U0 a zig-zag's t_a read 20.7 "L/U0" without saying which U0.
    // A turning circle has no times to qualify.
    if (approach_m_s / u0 - 1.0).abs() > 0.05 && matches!(m, Manoeuvre::ZigZag { .. }) {
        eprintln!(
            "note: times (t_a, t_check) are in L/U0 with U0 = {u0:.4} m/s, the ship's, not the approach speed {approach_m_s:.4} m/s: multiply by {:.4} for L/U_approach",
            approach_m_s / u0
        );
    }
    let mut warnings = Vec::new();
    let windage = simulation_windage(a.model, model.ship());
    if wind.is_some() {
        let w = format!("--wind: the wind's force uses {}", windage.describe());
        if windage.is_assumed() {
            warnings.push(format!(
                "{}: the model file records no windage and its data set gives no [windage]; {w}",
                a.model
            ));
        } else {
            eprintln!("note: {w}");
        }
    }
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    // Before the simulation: a model without replicates (or with a damaged calibration or valley) is
    // refused at once.
    if a.bands.is_some()
        && let Some(advice) = inverse_without_ensemble(a.model)
    {
        return Err(bad_input(advice));
    }
    let replicates = a
        .bands
        .map(|level| ModelBands::of(a.model, level))
        .transpose()?;
    let shipid_pipeline::bands::BesideModels { valley, jackknife } =
        shipid_pipeline::bands::beside_of(a.model)?;
    // A slower approach (another propeller rate) takes longer to the same heading changes: the
    // default duration scales with L over the approach speed, not over U0.
    let duration_s = a.duration_s.or_else(|| {
        (approach_m_s > 0.0 && approach_m_s < u0).then(|| {
            let mut ship = *model.ship();
            ship.u0 = approach_m_s;
            shipid_pipeline::generate::standard_duration_s(&m, &ship)
        })
    });
    let request = SimRequest {
        dt_s: a.dt_s,
        duration_s,
        allow_large: a.allow_large,
    };
    let grid = sim_grid(model, &m, &request)?;
    // The replicates, the valley's starts and the jackknife's refits each run the manoeuvre again:
    // the step limit is on the whole command (201 GP draws of 1e7 steps passed as one run of 1e7).
    let extra_runs = replicates.as_ref().map_or(0, ModelBands::runs)
        + valley.as_ref().map_or(0, |v| v.members.len())
        + jackknife.as_ref().map_or(0, |j| j.members.len());
    let total_steps = grid.steps * (1 + extra_runs) as f64;
    if extra_runs > 0
        && total_steps > shipid_pipeline::simulate::MAX_TOTAL_STEPS_UNLESS_ALLOWED
        && !a.allow_large
    {
        return Err(crate::bad_input(format!(
            "{:.3e} RK4 steps per run × {} runs (the model and {extra_runs} {}) is {total_steps:.3e} steps, more than {:.0e}: give --allow-large to run it anyway, or a shorter --duration",
            grid.steps,
            1 + extra_runs,
            match (
                replicates.is_some(),
                valley.is_some() || jackknife.is_some()
            ) {
                (true, true) => "band replicates, valley starts and jackknife refits",
                (true, false) => "band replicates",
                (false, _) => "valley starts and jackknife refits",
            },
            shipid_pipeline::simulate::MAX_TOTAL_STEPS_UNLESS_ALLOWED
        )));
    }
    if grid.decimated {
        eprintln!(
            "note: {:.3e} RK4 steps of {} s; the stored history keeps one sample every {} s (at most {:.0e} samples) to bound memory",
            grid.steps, grid.dt_s, grid.sample_interval_s, MAX_STORED_SAMPLES
        );
    }
    let duration_note = a
        .duration_s
        .filter(|_| (grid.duration_s - grid.requested_duration_s).abs() > 1e-9 * grid.duration_s)
        .map(|asked| {
            format!(
                "--duration {asked} s is not a whole number of --dt {} s steps: the run simulates {:.0} step(s), {} s",
                grid.dt_s,
                grid.duration_s / grid.dt_s,
                seconds(grid.duration_s)
            )
        });
    if let Some(n) = &duration_note {
        eprintln!("note: {n}");
    }
    let env = constant_environment(wind, current, &windage, model.ship(), grid.duration_s)?;
    let out = simulate_on_grid_in(model, &m, &grid, env.clone(), approach_m_s)?;
    let envelope = shipid_pipeline::range::model_envelope(a.model, model);
    let reach = envelope
        .as_ref()
        .and_then(|e| e.reach(model, &out.recording));
    // Silence would read as "inside": without its training data a model's extrapolation cannot be
    // told, and the user is told why, as `validate` tells it.
    let mut range_unavailable = if envelope.is_none() && model.own_range().is_none() {
        crate::print::training_range_warnings(a.model, "`outside` and the extrapolation warning")
    } else {
        Vec::new()
    };
    range_unavailable.extend(crate::print::training_ship_warnings(
        a.model,
        model.ship(),
        envelope.as_ref().and_then(|e| e.training_dataset.as_ref()),
    ));
    for w in &range_unavailable {
        eprintln!("warning: {w}");
    }
    warnings.extend(range_unavailable.iter().cloned());
    if let Some(w) = reach
        .as_ref()
        .and_then(|r| r.warning(a.model, !matches!(out.status, SimStatus::Ok)))
    {
        eprintln!("warning: {w}");
        warnings.push(w);
    }
    let mut value = outcome_json(&out, &m, model);
    if let Value::Object(o) = &mut value {
        if let Some(n) = &duration_note {
            o.insert(
                "simulated_s".into(),
                json!((grid.duration_s * 1e9).round() / 1e9),
            );
            o.insert("duration_note".into(), json!(n));
        }
        if let Some(w) = wind {
            o.insert(
                "wind".into(),
                json!({ "speed_m_s": w.speed_m_s, "from_deg": w.from_deg, "windage": windage.describe(), "windage_assumed": windage.is_assumed() }),
            );
        }
        if let Some(c) = current {
            o.insert(
                "current".into(),
                json!({ "speed_m_s": c.speed_m_s, "from_deg": c.from_deg }),
            );
        }
        if let (Some(n), Some((_, u))) = (a.propeller_rate_hz, &rate) {
            o.insert(
                "propeller_rate".into(),
                json!({ "n_hz": n, "model_own_n_hz": loaded.propeller_rate_hz(), "approach_m_s": u }),
            );
        }
        if let Some(r) = &reach {
            o.insert(
                "identification_range".into(),
                serde_json::to_value(r).unwrap_or_default(),
            );
        } else if !range_unavailable.is_empty() {
            o.insert(
                "identification_range".into(),
                json!({ "unavailable": range_unavailable.join("; ") }),
            );
        }
        if !warnings.is_empty() {
            o.insert("warnings".into(), json!(warnings));
        }
    }
    // Each valley member and jackknife refit runs as the point model does: the same grid and
    // environment, at the asked propeller rate from its own straight-run speed there.
    let run_member = |member: &dyn Dynamics| match a.propeller_rate_hz {
        Some(n) => at_propeller_rate(member, a.model, n)
            .ok()
            .and_then(|(d, u)| simulate_on_grid_in(&d, &m, &grid, env.clone(), u).ok()),
        None => simulate_on_grid_in(member, &m, &grid, env.clone(), approach_m_s).ok(),
    };
    if let (Some(v), SimStatus::Ok) = (&valley, &out.status) {
        let point = metrics(&out.recording, &m, model.ship());
        let run = shipid_pipeline::bands::valley_run(v, &point, &m, model.ship(), run_member);
        add_valley(&mut value, v, &run);
    }
    if let (Some(j), SimStatus::Ok) = (&jackknife, &out.status) {
        let point = metrics(&out.recording, &m, model.ship());
        let run = shipid_pipeline::bands::jackknife_run(j, &point, &m, model.ship(), run_member);
        add_jackknife(&mut value, j, &run);
    }
    if let (Some(level), Some(replicates)) = (a.bands, &replicates) {
        let bands = replicates.bands(
            model,
            &m,
            model.ship(),
            level,
            BandRun::Grid(&grid, approach_m_s),
        )?;
        add_bands(&mut value, &bands, replicates, a.json);
    }
    let left = matches!(out.status, SimStatus::Ok)
        .then(|| shipid_sim::metrics::lost_manoeuvre(&out.recording, &m, model.ship()))
        .flatten();
    if let Some(why) = &left {
        let w = format!("the run left the manoeuvre: {why}");
        eprintln!("warning: {w}");
        if let Value::Object(o) = &mut value {
            o.insert("left_manoeuvre".into(), json!(why));
            match o.get_mut("warnings") {
                Some(Value::Array(a)) => a.push(json!(w)),
                _ => {
                    o.insert("warnings".into(), json!([w]));
                }
            }
        }
    }
    if matches!(out.status, SimStatus::Ok) && left.is_none() {
        let undefined: Vec<&str> = metrics(&out.recording, &m, model.ship())
            .entries()
            .iter()
            .filter(|(key, v)| v.is_none() && applies(key, &m))
            .map(|(key, _)| *key)
            .collect();
        if !undefined.is_empty() {
            let why = if grid.decimated {
                format!(
                    "the run ends before the manoeuvre reaches them, or its history, thinned to a sample every {} s, is too coarse for them",
                    grid.sample_interval_s
                )
            } else {
                "the run ends before the manoeuvre reaches them; a longer --duration defines them"
                    .into()
            };
            eprintln!(
                "warning: {} undefined after {} s of simulated time (left out of the output): {why}",
                undefined.join(", "),
                seconds(grid.duration_s)
            );
        }
    }
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&value).unwrap_or_default()
        );
    } else if let Value::Object(o) = &value {
        for (k, v) in o {
            if k == "bands"
                || k == "valley"
                || k == "jackknife"
                || k.ends_with("_band")
                || k.ends_with("_valley")
                || k.ends_with("_jackknife")
                || k == "identification_range"
                // On stderr already, each as its own line.
                || k == "warnings"
            {
                continue;
            }
            let range = |suffix: &str| {
                o.get(&format!("{k}_{suffix}"))
                    .and_then(Value::as_array)
                    .map_or(String::new(), |r| {
                        let f = |x: Option<&Value>| {
                            x.and_then(Value::as_f64)
                                .map_or("–".into(), |x| format!("{x:.4}"))
                        };
                        format!("  {suffix} [{}, {}]", f(r.first()), f(r.get(1)))
                    })
            };
            let (band, valley) = (range("band"), range("valley"));
            let se = o
                .get("jackknife")
                .and_then(|j| j["standard_errors"][k].as_f64());
            let jackknife = match se {
                Some(se) => format!("{} ± {se:.4}", range("jackknife")),
                None => range("jackknife"),
            };
            // A metric with its unit and the digits its band has; other entries as they are.
            let shown = match (shipid_sim::metrics::metric_unit(k), v.as_f64()) {
                (Some(unit), Some(x)) => format!("{x:.4} {unit}"),
                _ => plain(v),
            };
            println!("{k:>18}: {shown}{band}{valley}{jackknife}");
        }
        if let Some(r) = &reach {
            // 0.04 % printed as "0.0 %" read as none outside.
            let share = match 100.0 * r.outside {
                p if p > 0.0 && p < 0.05 => "< 0.1".to_string(),
                p => format!("{p:.1}"),
            };
            println!(
                "{:>18}: {share} % of the run ({})",
                "outside",
                r.source.describe()
            );
        }
        if let (Some(about), Some(v)) = (o.get("valley"), &valley) {
            println!(
                "{:>18}: {} of the {} refinements from the other prior weights end within {:.0} % of this model's cost{}: {}",
                "valley",
                v.members.len(),
                v.starts,
                100.0 * v.cost_tolerance,
                about["diverged"]
                    .as_u64()
                    .filter(|d| *d > 0)
                    .map_or(String::new(), |d| format!(" ({d} of their runs diverged)")),
                about["what"].as_str().unwrap_or_default()
            );
        }
        if let Some(about) = o.get("jackknife") {
            println!(
                "{:>18}: {} refits{}: {}",
                "jackknife",
                about["refits"],
                about["diverged"]
                    .as_u64()
                    .filter(|d| *d > 0)
                    .map_or(String::new(), |d| format!(" ({d} of their runs diverged)")),
                about["what"].as_str().unwrap_or_default()
            );
        }
        if let Some(about) = o.get("bands") {
            println!(
                "{:>18}: {} % over {} {} ({} diverged): {}{}",
                "bands",
                short_number(about["level"].as_f64().unwrap_or(f64::NAN) * 100.0),
                about["replicates"],
                replicates.as_ref().map_or("", |r| r.noun()),
                about["diverged"],
                about["what"].as_str().unwrap_or_default(),
                about["reach"]
                    .as_f64()
                    .map_or(String::new(), |r| format!("; reach of this run {r:.2}"))
            );
        }
    }
    // Written after the metrics are shown: a write that fails then loses no more than the file.
    if let Some(path) = a.out_csv {
        // Every option that shapes the run, the step and time as simulated, so that the file's own
        // record reproduces it.
        let mut options = format!(
            " --dt {} --duration {}",
            seconds(grid.dt_s),
            seconds(grid.duration_s)
        );
        for (flag, given) in [("--wind", a.wind), ("--current", a.current)] {
            if let Some(text) = given {
                options.push_str(&format!(" {flag} {}", text.replace(' ', "")));
            }
        }
        if let Some(n) = a.propeller_rate_hz {
            options.push_str(&format!(" --propeller-rate {n}"));
        }
        if a.allow_large {
            options.push_str(" --allow-large");
        }
        // The model named relative to the file written, not as typed: the bytes must not depend on
        // the working directory.
        let model_name = if a.model.starts_with("mmg:") {
            a.model.to_string()
        } else {
            shipid_pipeline::model_file::stored_path(path, Path::new(a.model))
        };
        let comments = vec![format!(
            "shipid {} simulate {model_name} --manoeuvre {}{options}; midship, SI, rudder positive to starboard",
            env!("CARGO_PKG_VERSION"),
            a.manoeuvre
        )];
        write_atomic(path, recording_csv(&out.recording, &comments).as_bytes())
            .map_err(|e| crate::not_saved(path, e, "the simulated time series"))?;
    }
    // A run that left its manoeuvre is finite but no answer to the question asked, like a diverged
    // one: exit 1, with the time series still written for a look at what happened.
    Ok(match (&out.status, &left) {
        (SimStatus::Ok, None) => Outcome::Ok,
        _ => Outcome::SomeFailed,
    })
}

/// The bands into the output: `<metric>_band: [lo, hi]` for every metric with a band, and a `bands`
/// object saying what they are (`kind`: calibrated, bootstrap or posterior-draws, and `what` in
/// words; level, replicates, diverged runs, a calibrated band's `reach` and `factors`, metrics
/// without a band and why, and with `--json` the track band).
fn add_bands(value: &mut Value, run: &RunBands, source: &ModelBands, with_track: bool) {
    let Value::Object(o) = value else { return };
    let bands = &run.bands;
    let mut without = Map::new();
    for b in &bands.metrics {
        match &b.band {
            Ok(band) => {
                o.insert(format!("{}_band", b.metric), json!([band.lo, band.hi]));
            }
            Err(e) if b.point.is_some() => {
                without.insert(b.metric.into(), json!(e.to_string()));
            }
            Err(_) => {}
        }
    }
    let mut about = Map::new();
    about.insert("level".into(), json!(bands.level));
    about.insert("replicates".into(), json!(bands.replicates));
    about.insert("diverged".into(), json!(bands.diverged));
    if let Some(w) = source.diverged_by_structure(&bands.diverged_members) {
        about.insert("diverged_by_structure".into(), json!(w));
    }
    about.insert("kind".into(), json!(source.kind()));
    about.insert("what".into(), json!(source.what()));
    if let Some(note) = source.beyond_resolution(bands.level) {
        eprintln!("warning: --bands {}: {note}", bands.level);
        about.insert("resolution".into(), json!(note));
    }
    if let Some(reach) = run.reach {
        about.insert("reach".into(), json!(reach));
        about.insert("factors".into(), json!(source.factors()));
        if let Some(o) = source.out_of_kind() {
            about.insert("out_of_kind".into(), json!(o));
        }
    }
    // The text output shows bands beside their metrics; one left out (past the reach cap, or not
    // computable) must say why there, not only in --json.
    if !with_track {
        for (metric, why) in &without {
            eprintln!("note: {metric}: {}", why.as_str().unwrap_or_default());
        }
    }
    if !without.is_empty() {
        about.insert("without_band".into(), Value::Object(without));
    }
    if with_track && let Some(track) = &bands.track {
        about.insert(
            "track".into(),
            serde_json::to_value(track).unwrap_or_default(),
        );
    }
    o.insert("bands".into(), Value::Object(about));
    if bands.diverged > 0 {
        // An ensemble's structures that diverge are the ones most wrong here: the band then holds
        // less of the model-form spread than its description says, and the user must know which.
        let which = source
            .diverged_by_structure(&bands.diverged_members)
            .map_or(String::new(), |w| {
                format!(
                    "; by structure: {w} (a structure whose replicates diverged adds nothing to the band's model-form spread here)"
                )
            });
        eprintln!(
            "warning: {} of {} {} diverged in this manoeuvre (their metrics are undefined; the band is over the others){which}",
            bands.diverged,
            bands.replicates,
            source.noun()
        );
    }
}

/// One model run beside the point model, as `--json` lists it: its metrics (none when its run
/// diverged), what names it, and its `status`.
fn member_json<const N: usize>(
    metrics: Option<&shipid_sim::Metrics>,
    names: [(&str, Value); N],
) -> Value {
    let mut member = match metrics.map(serde_json::to_value) {
        Some(Ok(Value::Object(k))) => k,
        _ => Map::new(),
    };
    for (key, value) in names {
        member.insert(key.into(), value);
    }
    let status = if metrics.is_some() { "ok" } else { "diverged" };
    member.insert("status".into(), json!(status));
    Value::Object(member)
}

/// The jackknife into the output: `<metric>_jackknife: [lo, hi]`, the range of the metric over the
/// refits whose runs define it, and a `jackknife` object (each refit's metrics, diverged runs, each
/// metric's jackknife standard error, what it means).
fn add_jackknife(
    value: &mut Value,
    jackknife: &shipid_pipeline::bands::Jackknife,
    run: &shipid_pipeline::bands::JackknifeRun,
) {
    let Value::Object(o) = value else { return };
    for (key, lo, hi) in &run.ranges {
        o.insert(format!("{key}_jackknife"), json!([lo, hi]));
    }
    let members: Vec<Value> = run
        .members
        .iter()
        .map(|(left_out, metrics)| member_json(metrics.as_ref(), [("left_out", json!(left_out))]))
        .collect();
    let standard_errors: Map<String, Value> = run
        .standard_errors
        .iter()
        .map(|(key, se)| (key.to_string(), json!(se)))
        .collect();
    o.insert(
        "jackknife".into(),
        json!({
            "refits": jackknife.members.len(),
            "diverged": run.diverged(),
            "standard_errors": standard_errors,
            "members": members,
            "what": jackknife.what(),
        }),
    );
    if run.diverged() > 0 {
        eprintln!(
            "warning: {} of the jackknife's {} refits diverged in this manoeuvre (its ranges are over the others)",
            run.diverged(),
            jackknife.members.len()
        );
    }
}

/// The valley into the output: `<metric>_valley: [lo, hi]`, the range of the metric over this model
/// and the valley's members whose runs define it, and a `valley` object (the members, their cost
/// ratios and metrics, diverged runs, what it means).
fn add_valley(
    value: &mut Value,
    valley: &shipid_pipeline::bands::Valley,
    run: &shipid_pipeline::bands::ValleyRun,
) {
    let Value::Object(o) = value else { return };
    if !valley.members.is_empty() {
        for (key, lo, hi) in &run.ranges {
            o.insert(format!("{key}_valley"), json!([lo, hi]));
        }
    }
    let members: Vec<Value> = run
        .members
        .iter()
        .map(|m| {
            member_json(
                m.metrics.as_ref(),
                [
                    ("prior_weight", json!(m.prior_weight)),
                    ("cost_ratio", json!(m.cost_ratio)),
                ],
            )
        })
        .collect();
    o.insert(
        "valley".into(),
        json!({
            "starts": valley.starts,
            "in_valley": valley.members.len(),
            "cost_tolerance": valley.cost_tolerance,
            "diverged": run.diverged(),
            "members": members,
            "what": valley.what(),
        }),
    );
    if run.diverged() > 0 {
        eprintln!(
            "warning: {} of the valley's {} refinements diverged in this manoeuvre (the valley ranges are over the others)",
            run.diverged(),
            valley.members.len()
        );
    }
}

/// Whether a metric key belongs to the manoeuvre (zig-zag keys to zig-zags, turning keys to turns).
fn applies(key: &str, m: &Manoeuvre) -> bool {
    let zigzag_key = matches!(key, "overshoot_1" | "overshoot_2" | "t_a" | "t_check");
    match m {
        Manoeuvre::ZigZag { .. } => zigzag_key,
        Manoeuvre::Turning { .. } => !zigzag_key,
        Manoeuvre::Free => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(x: f64, expected: &str) {
        assert_eq!(short_number(x), expected, "{x:?}");
    }

    /// Regression: the text output printed `t_s: 214.10000000000002`, a band level of 1e-9 as
    /// "0.00000010000000000000001 %" and a displacement of 312698.88000000006 m³.
    #[test]
    fn numbers_are_printed_without_their_rounding_noise() {
        check(214.10000000000002, "214.1");
        check(1e-7, "1e-7");
        check(1.2345678e-7, "1.23457e-7");
        check(312698.88000000006, "312699");
        check(90.0, "90");
        check(0.0, "0");
        check(-0.0123456789, "-0.0123457");
        check(2.5e12, "2.5e12");
    }

    #[test]
    fn a_table_in_the_report_reads_as_keys_and_values() {
        let v = json!({"approach_m_s": 1.0170000000000001, "rate_hz": 10.229});
        assert_eq!(plain(&v), "approach_m_s 1.017, rate_hz 10.229");
        assert_eq!(plain(&json!("text")), "text");
    }
}
