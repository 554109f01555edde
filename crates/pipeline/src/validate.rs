//! Validation of a model against recordings it may not have seen (`shipid validate`, and the study
//! runner later):
//!
//! - **replay** (open loop): the recording's rudder history is replayed from its initial state; the
//!   trajectory, heading and velocities are compared sample by sample (RMSE);
//! - **manoeuvre** (closed loop): the recording's standard manoeuvre (zig-zag or turning circle) is
//!   re-simulated with its controller, first execute at the recorded time, and its IMO metrics compared
//!   with the recording's (relative errors, MRAE). Closed loop because a zig-zag's reversals respond to
//!   the model's own heading; replaying the recorded rudder would not test that.
//!
//! A recording with a recorded wind or current is replayed and re-simulated in it
//! ([`shipid_sim::WithEnvironment`]): the model is of the ship in calm water, the recording's own
//! environment is a known input ([`crate::environment`]).

use serde::Serialize;
use shipid_io::{DatasetRecording, Manoeuvre, Recording, Ship};
use shipid_sim::metrics::{
    DEFINITE_FRACTION, check_reaction_delay_s, first_execute, missing_execute_reason,
};
use shipid_sim::{
    Dynamics, KnownEnvironment, Metrics, Replay, SimOptions, SimOutput, SimStatus, State,
    controller_with_reaction_delay, metrics,
};

use crate::environment::{ChosenWindage, WindageSource, environment_with, with_recorded_inputs};
use crate::error::{PipelineError, bad_input};

/// A data set without recordings has nothing to validate or measure: refused as `fit` refuses it,
/// rather than answered with an empty table.
pub fn require_recordings(ds: &shipid_io::Dataset) -> Result<(), PipelineError> {
    if ds.recordings.is_empty() {
        return Err(bad_input(format!(
            "{} has no recordings (no [[recording]] table): nothing to compute",
            ds.path.display()
        )));
    }
    Ok(())
}

/// Below this share of the declared amplitude the recorded rudder is not the declared manoeuvre.
const AMPLITUDE_SHARE: f64 = 0.5;

/// Why metrics that `r`'s declared manoeuvre defines are undefined in `m` (its metrics), in words for
/// a table's "-": `"<file>: <metrics> undefined: <why>"`; `None` when all are defined or the recording
/// declares no standard manoeuvre.
pub fn undefined_metrics_reason(r: &DatasetRecording, ship: &Ship, m: &Metrics) -> Option<String> {
    let zigzag = match r.manoeuvre {
        Manoeuvre::ZigZag { .. } => true,
        Manoeuvre::Turning { .. } => false,
        Manoeuvre::Free => return None,
    };
    let missing: Vec<&str> = m
        .entries()
        .iter()
        .filter(|(key, v)| {
            v.is_none()
                && zigzag == matches!(*key, "overshoot_1" | "overshoot_2" | "t_a" | "t_check")
        })
        .map(|(key, _)| *key)
        .collect();
    if missing.is_empty() {
        return None;
    }
    Some(format!(
        "{}: {} undefined: {}",
        r.file,
        missing.join(", "),
        undefined_why(r, ship)
    ))
}

fn undefined_why(r: &DatasetRecording, ship: &Ship) -> String {
    let rec = &r.recording;
    let (rudder_deg, check_deg, side) = match r.manoeuvre {
        Manoeuvre::ZigZag {
            rudder_deg,
            check_deg,
            side,
        } => (rudder_deg, Some(check_deg), side),
        Manoeuvre::Turning { rudder_deg, side } => (rudder_deg, None, side),
        Manoeuvre::Free => return "a free recording defines no standard metrics".into(),
    };
    let n = rec.t.len();
    if n < 3 {
        return format!("the record has {n} samples, too few for any metric");
    }
    if let Some(why) = missing_execute_reason(rec, rudder_deg, side) {
        return why;
    }
    let side_name = if side.sign() > 0.0 {
        "starboard"
    } else {
        "port"
    };
    let Some(first) = first_execute(rec, rudder_deg, side, ship) else {
        return format!(
            "no first rudder execute to {side_name} is found (the record is unusable: non-finite values or times not increasing?)"
        );
    };
    let s = side.sign();
    let d0 = rec.delta[0];
    let reached_deg = rec
        .delta
        .iter()
        .map(|d| s * (d - d0))
        .fold(f64::NEG_INFINITY, f64::max)
        .to_degrees();
    if reached_deg < AMPLITUDE_SHARE * rudder_deg {
        return format!(
            "its rudder goes at most {reached_deg:.1}° to {side_name}, against the declared {rudder_deg}°: is the declared amplitude (or the rudder's unit) right?"
        );
    }
    let after = rec.t.partition_point(|t| *t < first.t_s);
    let turned_deg = rec.psi[after..]
        .iter()
        .map(|p| s * (p - first.psi_rad))
        .fold(0.0, f64::max)
        .to_degrees();
    let definite = DEFINITE_FRACTION * rudder_deg.to_radians();
    let reverses = rec.delta[after..].iter().any(|d| s * (d - d0) < -definite);
    let duration_s = rec.t[n - 1] - first.t_s;
    match check_deg {
        Some(check) if turned_deg < check => format!(
            "the heading turns at most {turned_deg:.1}° in the {duration_s:.0} s after the execute, never reaching the declared check angle {check}°"
        ),
        Some(_) if !reverses => format!(
            "its rudder never reverses in the {duration_s:.0} s after the execute: a turning circle declared as a zig-zag?"
        ),
        Some(_) => format!(
            "the record ends {duration_s:.0} s after the execute, before the overshoot completes"
        ),
        None if reverses => {
            "its rudder reverses after the execute: a zig-zag declared as a turning circle?".into()
        }
        None => format!(
            "the heading turns {turned_deg:.0}° in the {duration_s:.0} s after the execute (the advance and transfer need 90°, the tactical diameter 180°, the steady diameter a steady turn beyond): the record is too short"
        ),
    }
}

/// Root mean square of `x` (0 for no samples).
pub fn rms(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

/// RK4 step for re-simulation, as a fraction of L/U0 (0.05 s for the KVLCC2 model, whose check values
/// it reproduces to 0.05°).
pub const DT_OVER_L_OVER_U0: f64 = 0.05 / (7.0 / 1.179);

/// Open-loop replay errors. The RMSEs are over the samples the replay reached; serialised, a
/// diverged replay's are `null`: over the few samples before a divergence they are near zero and
/// would read as a perfect fit.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayErrors {
    pub status: SimStatus,
    pub position_rmse_over_l: f64,
    pub heading_rmse_deg: f64,
    pub u_rmse_m_s: f64,
    pub v_rmse_m_s: f64,
    pub r_rmse_deg_s: f64,
}

impl ReplayErrors {
    /// The RMSEs a reader may compare: `None` when the replay diverged.
    pub fn comparable(&self) -> Option<[f64; 5]> {
        matches!(self.status, SimStatus::Ok).then_some([
            self.position_rmse_over_l,
            self.heading_rmse_deg,
            self.u_rmse_m_s,
            self.v_rmse_m_s,
            self.r_rmse_deg_s,
        ])
    }
}

impl Serialize for ReplayErrors {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        #[derive(Serialize)]
        struct Shown<'a> {
            #[serde(flatten)]
            status: &'a SimStatus,
            position_rmse_over_l: Option<f64>,
            heading_rmse_deg: Option<f64>,
            u_rmse_m_s: Option<f64>,
            v_rmse_m_s: Option<f64>,
            r_rmse_deg_s: Option<f64>,
        }
        let rmse = self.comparable();
        let at = |i: usize| rmse.map(|r| r[i]);
        Shown {
            status: &self.status,
            position_rmse_over_l: at(0),
            heading_rmse_deg: at(1),
            u_rmse_m_s: at(2),
            v_rmse_m_s: at(3),
            r_rmse_deg_s: at(4),
        }
        .serialize(serializer)
    }
}

/// Closed-loop metrics comparison.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MetricComparison {
    #[serde(flatten)]
    pub status: SimStatus,
    pub recorded: Metrics,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub predicted: Option<Metrics>,
    /// (predicted − recorded)/recorded per metric both define.
    pub relative_error: std::collections::BTreeMap<String, f64>,
    /// Mean of |relative error| over those metrics.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mrae: Option<f64>,
    /// A zig-zag's reaction delay at its checks [s], measured on the recording, with which the
    /// re-simulation reversed the rudder.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reaction_delay_s: Option<f64>,
    /// How the re-simulation left the declared manoeuvre (turned against its rudder, a zig-zag's
    /// heading running off course), when it did: its metrics then describe no such manoeuvre.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub left_manoeuvre: Option<String>,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RecordingValidation {
    pub kind: &'static str,
    pub replay: ReplayErrors,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub manoeuvre: Option<MetricComparison>,
}

impl RecordingValidation {
    /// Whether either simulation diverged.
    pub fn diverged(&self) -> bool {
        matches!(self.replay.status, SimStatus::Diverged { .. })
            || self
                .manoeuvre
                .as_ref()
                .is_some_and(|m| matches!(m.status, SimStatus::Diverged { .. }))
    }
}

fn initial_state(rec: &Recording) -> State {
    State::of_recording(rec, 0)
}

fn options(ship: &Ship, duration_s: f64) -> SimOptions {
    let dt = DT_OVER_L_OVER_U0 * ship.lpp / ship.u0;
    SimOptions::new(duration_s).with_step(dt, dt)
}

/// Linear interpolation held at the ends: the simulation crate's one.
pub use shipid_sim::metrics::interp;

/// Replay the recorded rudder from the recorded initial state. Times are shifted so the record starts at 0.
/// In calm water: [`replay_in`] replays a recording in its recorded environment.
pub fn replay(model: &dyn Dynamics, rec: &Recording) -> SimOutput {
    replay_in(model, rec, None)
}

/// [`replay`] with the model in `env`, the recorded environment of `rec` (`None`: calm).
pub fn replay_in(
    model: &dyn Dynamics,
    rec: &Recording,
    env: Option<KnownEnvironment>,
) -> SimOutput {
    let Some(&t0) = rec.t.first() else {
        return failed_output("cannot replay: the recording is empty".into());
    };
    let model = with_recorded_inputs(model, rec, t0, env);
    let model = model.as_ref();
    let t_rel: Vec<f64> = rec.t.iter().map(|t| t - t0).collect();
    let duration = *t_rel.last().unwrap_or(&0.0);
    let mut ctrl = match Replay::new(t_rel, rec.delta.clone()) {
        Ok(c) => c,
        Err(e) => return failed_output(format!("cannot replay: {e}")),
    };
    let mut opts = options(model.ship(), duration);
    opts.initial_rudder_rad = rec.delta[0];
    shipid_sim::simulate(model, &mut ctrl, initial_state(rec), &opts)
        .unwrap_or_else(|e| failed_output(format!("cannot simulate: {e}")))
}

fn failed_output(reason: String) -> SimOutput {
    SimOutput {
        recording: Recording::default(),
        status: SimStatus::Diverged { t_s: 0.0, reason },
    }
}

/// RMSEs of a replay against the recording, over the samples the simulation reached.
pub fn replay_errors(sim: &SimOutput, rec: &Recording, ship: &Ship) -> ReplayErrors {
    let t0 = rec.t[0];
    let s = &sim.recording;
    let end = s.t.last().copied().unwrap_or(-1.0);
    let (mut dp, mut dpsi, mut du, mut dv, mut dr) = (vec![], vec![], vec![], vec![], vec![]);
    for i in 0..rec.len() {
        let t = rec.t[i] - t0;
        if t > end + 1e-9 || s.is_empty() {
            break;
        }
        let at = |y: &[f64]| interp(&s.t, y, t);
        dp.push((at(&s.x0) - rec.x0[i]).hypot(at(&s.y0) - rec.y0[i]));
        dpsi.push(at(&s.psi) - rec.psi[i]);
        du.push(at(&s.u) - rec.u[i]);
        dv.push(at(&s.v) - rec.v[i]);
        dr.push(at(&s.r) - rec.r[i]);
    }
    ReplayErrors {
        status: sim.status.clone(),
        position_rmse_over_l: rms(&dp) / ship.lpp,
        heading_rmse_deg: rms(&dpsi).to_degrees(),
        u_rmse_m_s: rms(&du),
        v_rmse_m_s: rms(&dv),
        r_rmse_deg_s: rms(&dr).to_degrees(),
    }
}

/// The recording's standard manoeuvre re-simulated in closed loop from its initial state: controller
/// from the manoeuvre, first execute where the recorded rudder started to move (the metric's execute is
/// interpolated on the rudder signal), times from 0 at the record's start. `None` for a free recording.
/// A simulation that cannot start is a divergence at 0 s with no samples.
pub fn closed_loop(model: &dyn Dynamics, r: &DatasetRecording, ship: &Ship) -> Option<SimOutput> {
    closed_loop_in(model, r, ship, None)
}

/// [`closed_loop`] with the model in `env`, the recorded environment of `r` (`None`: calm).
pub fn closed_loop_in(
    model: &dyn Dynamics,
    r: &DatasetRecording,
    ship: &Ship,
    env: Option<KnownEnvironment>,
) -> Option<SimOutput> {
    let rec = &r.recording;
    let t0 = rec.t.first().copied().unwrap_or(0.0);
    let current = env
        .as_ref()
        .filter(|e| e.has_current())
        .map(|e| e.replay_from(t0));
    let model = with_recorded_inputs(model, rec, t0, env);
    let model = model.as_ref();
    let (rudder, side) = match r.manoeuvre {
        Manoeuvre::ZigZag {
            rudder_deg, side, ..
        }
        | Manoeuvre::Turning { rudder_deg, side } => (rudder_deg, side),
        Manoeuvre::Free => return None,
    };
    if rec.is_empty() {
        return None;
    }
    let t_exec = first_execute(rec, rudder, side, ship).map_or(0.0, |f| (f.t_s - t0).max(0.0));
    let delay_s = recorded_reaction_delay_s(r, ship).unwrap_or(0.0);
    let mut out = match controller_with_reaction_delay(&r.manoeuvre, t_exec, delay_s) {
        Ok(mut c) => shipid_sim::simulate(
            model,
            c.as_mut(),
            initial_state(rec),
            &options(ship, rec.t[rec.len() - 1] - t0),
        )
        .unwrap_or_else(|e| failed_output(format!("cannot simulate: {e}"))),
        Err(e) => failed_output(format!("no controller: {e}")),
    };
    // The re-simulation's metrics are taken relative to the water, as the recording's are: the
    // current the simulation recorded (a model that carries one, with the environment it runs in),
    // else the recording's.
    if out.recording.current.is_none() {
        out.recording.current = current.and_then(|e| e.current_series(&out.recording.t));
    }
    Some(out)
}

/// A recorded zig-zag's reaction delay at its checks ([`check_reaction_delay_s`]), with which
/// [`closed_loop_in`] reverses the rudder; `None` for other manoeuvres.
pub fn recorded_reaction_delay_s(r: &DatasetRecording, ship: &Ship) -> Option<f64> {
    match r.manoeuvre {
        Manoeuvre::ZigZag {
            rudder_deg,
            check_deg,
            side,
        } => check_reaction_delay_s(&r.recording, rudder_deg, check_deg, side, ship),
        _ => None,
    }
}

/// Re-simulate the recording's standard manoeuvre in closed loop and compare its metrics.
pub fn compare_manoeuvre(
    model: &dyn Dynamics,
    r: &DatasetRecording,
    ship: &Ship,
) -> Option<MetricComparison> {
    compare_manoeuvre_in(model, r, ship, None)
}

/// [`compare_manoeuvre`] with the model in `env`, the recorded environment of `r` (`None`: calm).
pub fn compare_manoeuvre_in(
    model: &dyn Dynamics,
    r: &DatasetRecording,
    ship: &Ship,
    env: Option<KnownEnvironment>,
) -> Option<MetricComparison> {
    let sim = closed_loop_in(model, r, ship, env)?;
    let recorded = metrics(&r.recording, &r.manoeuvre, ship);
    let predicted =
        matches!(sim.status, SimStatus::Ok).then(|| metrics(&sim.recording, &r.manoeuvre, ship));
    let mut relative_error = std::collections::BTreeMap::new();
    if let Some(p) = &predicted {
        for ((key, a), (_, b)) in recorded.entries().iter().zip(p.entries().iter()) {
            // A subnormal recorded value would give an infinite error, which JSON writes as null.
            if let (Some(a), Some(b)) = (a, b)
                && a.abs() > 0.0
                && ((b - a) / a).is_finite()
            {
                relative_error.insert(key.to_string(), (b - a) / a);
            }
        }
    }
    let mrae = (!relative_error.is_empty()).then(|| {
        relative_error.values().map(|e| e.abs()).sum::<f64>() / relative_error.len() as f64
    });
    Some(MetricComparison {
        status: sim.status,
        recorded,
        predicted,
        relative_error,
        mrae,
        reaction_delay_s: recorded_reaction_delay_s(r, ship),
        left_manoeuvre: shipid_sim::metrics::lost_manoeuvre(&sim.recording, &r.manoeuvre, ship),
    })
}

/// Both comparisons for one recording, in its recorded environment with an assumed windage when it
/// records a wind (callers that know the data set use [`validate_recording_with`]).
pub fn validate_recording(
    model: &dyn Dynamics,
    r: &DatasetRecording,
    ship: &Ship,
) -> RecordingValidation {
    validate_recording_with(model, r, ship, &ChosenWindage::first_of(&[], ship))
}

/// Both comparisons for one recording in its recorded wind and current, the wind's force with
/// `windage`. A recorded environment that cannot be used (series of the wrong length) makes both
/// simulations fail at their start with the reason.
pub fn validate_recording_with(
    model: &dyn Dynamics,
    r: &DatasetRecording,
    ship: &Ship,
    windage: &ChosenWindage,
) -> RecordingValidation {
    let env = match environment_with(&r.recording, windage, ship, &r.file) {
        Ok(env) => env,
        Err(e) => {
            let failed = failed_output(format!("cannot use the recorded environment: {e}"));
            return RecordingValidation {
                kind: r.manoeuvre.kind(),
                replay: replay_errors(&failed, &r.recording, ship),
                manoeuvre: None,
            };
        }
    };
    let sim = replay_in(model, &r.recording, env.clone());
    RecordingValidation {
        kind: r.manoeuvre.kind(),
        replay: replay_errors(&sim, &r.recording, ship),
        manoeuvre: compare_manoeuvre_in(model, r, ship, env),
    }
}

/// The recorded wind and current of `r` as a validation applies them with `windage` (its
/// [`validation_windage`]); `None` for a calm recording or one whose environment cannot be used
/// (its validation says why).
pub fn validation_environment(
    windage: &ChosenWindage,
    ds: &shipid_io::Dataset,
    r: &DatasetRecording,
) -> Option<KnownEnvironment> {
    environment_with(&r.recording, windage, &ds.ship, &r.file)
        .ok()
        .flatten()
}

/// The windage a validation of `model_spec` on `ds` gives a recorded wind: the data set's, else the
/// one the model file was identified with, else assumed.
pub fn validation_windage(model_spec: &str, ds: &shipid_io::Dataset) -> ChosenWindage {
    let record = crate::environment::model_environment(model_spec);
    let from_model = record.as_ref().and_then(|r| r.windage.as_ref());
    ChosenWindage::first_of(
        &[
            (ds.windage.as_ref(), WindageSource::Dataset),
            (from_model, WindageSource::ModelFile),
        ],
        &ds.ship,
    )
}

/// What a validation of `model_spec` (loaded as `model`; `None` for a study's several models) on `ds`
/// warns about (stderr and the JSON's `warnings`): a recording whose propeller rate varies though the
/// model runs at one rate, or, for a model that takes the rate, the recordings it replays at a rate
/// other than its own; a recorded wind or current the validation applies (and with which windage; an
/// assumed one named as such), and a model identified in a recorded environment applied to recordings
/// without one.
pub fn validation_warnings(
    model_spec: &str,
    model: Option<&dyn Dynamics>,
    ds: &shipid_io::Dataset,
) -> Vec<String> {
    let mut warnings: Vec<String> = match model {
        Some(m) if m.takes_propeller_rate() => {
            recorded_rate_notes(m.propeller_rate_hz(), &ds.recordings)
        }
        _ => propeller_rate_variations(&ds.recordings)
            .iter()
            .map(ToString::to_string)
            .collect(),
    };
    // A study (`None`) fits its polynomial and GP cases on recordings that may have run at
    // different rates.
    if model.is_none() {
        warnings.extend(rates_between_runs_note(&ds.recordings));
    }
    // A model without a rate input, against the rate it was trained at (a study, `None`, trains on
    // the data set it tests on).
    if model.is_some_and(|m| !m.takes_propeller_rate()) {
        warnings.extend(training_rate_mismatches(model_spec, &ds.recordings));
    }
    let windage = validation_windage(model_spec, ds);
    let any_wind = ds.recordings.iter().any(|r| r.recording.wind.is_some());
    if any_wind && windage.is_assumed() {
        warnings.push(format!(
            "{}: recordings carry a recorded wind but neither the data set nor the model gives a windage; the validation applies the wind with an assumed windage ({})",
            ds.path.display(),
            shipid_sim::environment::ASSUMED_WINDAGE_SOURCE
        ));
    }
    warnings.extend(crate::environment::environment_notes(
        ds,
        &ds.recordings,
        &windage,
        "the validation",
    ));
    warnings.extend(declared_manoeuvre_notes(ds));
    warnings.extend(approach_notes(ds));
    warnings
}

/// A reaction delay at a zig-zag's checks longer than this (× L/U0) is more than a helmsman's or an
/// autopilot's reaction (the HSVA tests: 0.05 L/U0): more likely the declared check angle is not the
/// one the test used.
const LATE_REVERSAL_L_OVER_U0: f64 = 0.25;

/// The zig-zags of `ds` whose rudder reverses implausibly long after the declared check angle.
pub fn late_reversal_notes(ds: &shipid_io::Dataset) -> Vec<String> {
    let scale = ds.ship.lpp / ds.ship.u0;
    ds.recordings
        .iter()
        .filter_map(|r| {
            let delay = recorded_reaction_delay_s(r, &ds.ship)?;
            (delay > LATE_REVERSAL_L_OVER_U0 * scale).then(|| {
                format!(
                    "{}: the rudder reverses {delay:.2} s ({:.2} L/U0) after the heading reaches the declared check angle: is the check angle in the data set right? The re-simulation reverses with that delay",
                    r.file,
                    delay / scale
                )
            })
        })
        .collect()
}

/// A rudder held further than this from the declared angle [deg] (or [`HELD_RUDDER_SHARE`] of it,
/// whichever is larger) is not the manoeuvre declared: a helmsman's or a logger's rounding stays well
/// inside, a 20° turn declared as a 35° one does not.
const HELD_RUDDER_TOLERANCE_DEG: f64 = 2.0;
/// See [`HELD_RUDDER_TOLERANCE_DEG`].
const HELD_RUDDER_SHARE: f64 = 0.1;
/// A zig-zag whose rudder reverses before the heading has turned the declared check angle less this
/// [deg] (or [`EARLY_REVERSAL_SHARE`] of the check angle, whichever is larger) was run with a smaller
/// check angle: the overshoots measured beyond the declared one are too small by the difference.
const EARLY_REVERSAL_TOLERANCE_DEG: f64 = 0.5;
/// See [`EARLY_REVERSAL_TOLERANCE_DEG`].
const EARLY_REVERSAL_SHARE: f64 = 0.2;

/// Everything the records of `ds` show about their declared manoeuvre that does not fit it: a rudder
/// reversing implausibly late or clearly early at the checks, a rudder held at another angle than the
/// declared one. The metrics of such a record, and a re-simulation of the declared manoeuvre, compare
/// the model with a test that was not run; `metrics` and `validate` print these beside their numbers.
pub fn declared_manoeuvre_notes(ds: &shipid_io::Dataset) -> Vec<String> {
    let mut notes = late_reversal_notes(ds);
    for r in &ds.recordings {
        let (rudder_deg, side, check) = match r.manoeuvre {
            Manoeuvre::ZigZag {
                rudder_deg,
                check_deg,
                side,
            } => (rudder_deg, side, Some(check_deg)),
            Manoeuvre::Turning { rudder_deg, side } => (rudder_deg, side, None),
            Manoeuvre::Free => continue,
        };
        let rec = &r.recording;
        if let Some(held) = shipid_sim::metrics::held_rudder_deg(rec, rudder_deg, side, &ds.ship)
            && (held - rudder_deg).abs()
                > HELD_RUDDER_TOLERANCE_DEG.max(HELD_RUDDER_SHARE * rudder_deg)
        {
            notes.push(format!(
                "{}: the rudder is held at {held:.1}° while the data set declares a {} with {rudder_deg}° rudder: is the declared rudder angle right? Its re-simulation puts the rudder to the declared angle, and the comparison then blames the model for the difference",
                r.file,
                r.manoeuvre.kind()
            ));
        }
        let Some(check) = check else { continue };
        let Some(turned) =
            shipid_sim::metrics::heading_at_reversals_deg(rec, rudder_deg, side, &ds.ship)
        else {
            continue;
        };
        if turned.is_empty() {
            continue;
        }
        let typical = shipid_sim::metrics::median(&turned);
        if typical < check - EARLY_REVERSAL_TOLERANCE_DEG.max(EARLY_REVERSAL_SHARE * check) {
            notes.push(format!(
                "{}: the rudder reverses when the heading has turned {typical:.1}° (median of {} reversals), short of the declared check angle {check}°: is the check angle in the data set right? Overshoots are measured beyond the declared angle, so they come out too small by the difference",
                r.file,
                turned.len()
            ));
        }
    }
    notes
}

/// An approach speed at the first execute further than this from U0 (÷ U0) is not the steady approach
/// at U0 that IMO metrics assume (a test started from rest, or at another propeller rate).
const APPROACH_SPEED_TOLERANCE: f64 = 0.05;
/// A speed change over the L/U0 before the first execute larger than this (÷ U0) is not steady.
const APPROACH_CHANGE_TOLERANCE: f64 = 0.02;

/// The zig-zags and turning circles of `ds` whose metrics do not start from a steady approach at the
/// data set's U0: their advance, tactical diameter or overshoots are the record's own, not the
/// ship's standard ones (a validation compares them with a re-simulation from the same start, which
/// stays consistent).
pub fn approach_notes(ds: &shipid_io::Dataset) -> Vec<String> {
    ds.recordings
        .iter()
        .filter_map(|r| {
            let a = shipid_sim::metrics::approach(&r.recording, &r.manoeuvre, &ds.ship)?;
            let off = (a.speed_ratio - 1.0).abs() > APPROACH_SPEED_TOLERANCE;
            // A change the speed's noise could make is none (three standard errors).
            let changing = a.change_ratio.abs()
                > APPROACH_CHANGE_TOLERANCE.max(3.0 * a.change_standard_error);
            (off || changing).then(|| {
                let how = match (off, changing) {
                    (true, true) => format!(
                        "at {:.2} U0 while the ship still {} ({:+.1} % of U0 over the L/U0 before)",
                        a.speed_ratio,
                        if a.change_ratio > 0.0 { "accelerates" } else { "slows" },
                        100.0 * a.change_ratio
                    ),
                    (true, false) => format!("at {:.2} U0", a.speed_ratio),
                    _ => format!(
                        "while the speed still changes ({:+.1} % of U0 over the L/U0 before)",
                        100.0 * a.change_ratio
                    ),
                };
                format!(
                    "{}: its rudder is put over {how}, not after a steady approach at the data set's U0 = {:.3} m/s: its {} metrics are this record's own, not the ship's standard ones",
                    r.file,
                    ds.ship.u0,
                    r.manoeuvre.kind()
                )
            })
        })
        .collect()
}

pub use crate::range::RangeSource;

/// One recording's validation and the share of its states outside the model's identification range.
#[derive(Debug, Clone, Serialize)]
pub struct ValidatedRecording {
    /// The recording's file name (the key it is listed under, not one of its values).
    #[serde(skip)]
    pub file: String,
    #[serde(flatten)]
    pub validation: RecordingValidation,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outside_identification_range: Option<f64>,
    /// What the recording reaches past the training states' extremes, in words, when it goes clearly
    /// past one ([`crate::range::RunReach::clearly_beyond`]): its predictions are extrapolations,
    /// however small its share outside the leverage ellipsoid (a 45° turn was 1 % outside a model
    /// trained to 35°, and nothing said so).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub beyond_training: Vec<String>,
}

/// Every recording of `ds` validated with the model loaded from `model_spec` (whose file names the
/// training data for the identification range), in the data set's order.
pub fn validate_dataset(
    model: &dyn Dynamics,
    model_spec: &str,
    ds: &shipid_io::Dataset,
) -> (Vec<ValidatedRecording>, RangeSource) {
    // A recording mostly outside the identification range tests the model's extrapolation, not its
    // fit. A sparse GP carries its range; a polynomial's and an mmg model's need the training data
    // their file names.
    let envelope = crate::range::model_envelope(model_spec, model);
    let windage = validation_windage(model_spec, ds);
    let rows = ds
        .recordings
        .iter()
        .map(|r| {
            // The reach holds the outside share: computed once (its leverage per sample is the
            // costly part); the share alone where the recording has no extent to reach with.
            let reach = envelope.as_ref().and_then(|e| e.reach(model, &r.recording));
            ValidatedRecording {
                file: r.file.clone(),
                validation: validate_recording_with(model, r, &ds.ship, &windage),
                outside_identification_range: reach.as_ref().map(|reach| reach.outside).or_else(
                    || {
                        envelope
                            .as_ref()
                            .and_then(|e| e.outside_share(model, &r.recording))
                    },
                ),
                beyond_training: reach
                    .filter(|reach| reach.clearly_beyond())
                    .map(|reach| reach.beyond())
                    .unwrap_or_default(),
            }
        })
        .collect();
    let source = envelope.map_or(RangeSource::Unknown, |e| e.source);
    (rows, source)
}

/// Relative spread of the propeller rate above which a recording is warned about: every model runs at
/// one constant rate (the MMG reference and a fitted MMG model at theirs; the polynomial sets and the
/// sparse GP have no `n` input), so where a recording's rate departs from it by more than a few per
/// cent its forces are not the model's.
pub const PROPELLER_RATE_SPREAD_WARNING: f64 = 0.05;

/// A recording whose propeller rate varies although the model ignores it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PropellerRateVariation {
    pub recording: String,
    /// 2nd and 98th percentiles of n [1/s] (robust to single spikes).
    pub n_low_hz: f64,
    pub n_high_hz: f64,
    /// (high − low) / median.
    pub relative_spread: f64,
}

impl std::fmt::Display for PropellerRateVariation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: the propeller rate n varies by {:.0} % ({:.3}–{:.3} 1/s) but a model without a propeller-rate input (polynomial sets, sparse GP; an mmg model takes the recorded n) runs at one constant rate: where n departs from it, the model's forces are not the recording's",
            self.recording,
            100.0 * self.relative_spread,
            self.n_low_hz,
            self.n_high_hz
        )
    }
}

/// Relative difference between a recording's propeller rate and a model's own above which a
/// validation of a model that takes the rate says that it replays at the recorded one.
pub const PROPELLER_RATE_DIFFERENCE_NOTE: f64 = 0.01;

/// For a model that takes the propeller rate (holding `model_rate_hz`): one note naming the recordings
/// it replays at a recorded rate that is not its own (median differing by more than
/// [`PROPELLER_RATE_DIFFERENCE_NOTE`], or spreading by more than [`PROPELLER_RATE_SPREAD_WARNING`]).
pub fn recorded_rate_notes<'a>(
    model_rate_hz: Option<f64>,
    recordings: impl IntoIterator<Item = &'a DatasetRecording>,
) -> Vec<String> {
    let Some(own) = model_rate_hz else {
        return Vec::new();
    };
    let recordings: Vec<&DatasetRecording> = recordings.into_iter().collect();
    let mut notes: Vec<String> = recordings
        .iter()
        .filter_map(|r| {
            let astern = r.recording.n.as_ref()?.iter().filter(|x| **x < 0.0).count();
            (astern > 0).then(|| {
                format!(
                    "{}: the propeller turns astern (n < 0) in {astern} samples; the MMG propeller model is for ahead (no astern quadrant), so its replay stops at the first of them with that reason (a stopped replay has no RMSEs)",
                    r.file
                )
            })
        })
        .collect();
    let differing: Vec<String> = recordings
        .iter()
        .filter_map(|r| {
            let (low, median, high) = rate_percentiles(r)?;
            let spreads = high - low > PROPELLER_RATE_SPREAD_WARNING * median.abs();
            let differs = (median - own).abs() > PROPELLER_RATE_DIFFERENCE_NOTE * own.abs();
            match (spreads, differs) {
                (true, _) => Some(format!("{} ({low:.3}–{high:.3} 1/s)", r.file)),
                (false, true) => Some(format!("{} ({median:.3} 1/s)", r.file)),
                (false, false) => None,
            }
        })
        .collect();
    if !differing.is_empty() {
        notes.insert(
            0,
            format!(
                "the model takes the propeller rate: it replays {} at the recorded rate n, not at its own {own:.3} 1/s",
                differing.join(", ")
            ),
        );
    }
    notes
}

/// For a model without a propeller-rate input (`model_spec`, a polynomial or sparse-GP file whose
/// training data can be read): one warning per recording of `recordings` whose median rate differs
/// from the median rate of the model's training windows by more than
/// [`PROPELLER_RATE_DIFFERENCE_NOTE`]: the model's forces are those of the rate it was identified at.
pub fn training_rate_mismatches<'a>(
    model_spec: &str,
    recordings: impl IntoIterator<Item = &'a DatasetRecording>,
) -> Vec<String> {
    let Some((data, windows)) = crate::range::training_windows(model_spec) else {
        return Vec::new();
    };
    // The median rate of each training window: a model trained on runs at several rates has seen each.
    let trained = distinct_rates(
        crate::range::window_samples(&data.1, &windows)
            .filter_map(|(rec, idx)| {
                let n = rec.n.as_deref()?;
                let mut w: Vec<f64> = idx
                    .into_iter()
                    .filter_map(|i| n.get(i).copied())
                    .filter(|x| x.is_finite())
                    .collect();
                if w.is_empty() {
                    return None;
                }
                w.sort_by(f64::total_cmp);
                Some(shipid_uncertainty::band::quantile(&w, 0.5))
            })
            .collect(),
    );
    if trained.is_empty() {
        return Vec::new();
    }
    let at = match trained.as_slice() {
        [one] => format!("{one:.3} 1/s"),
        several => format!("runs at {} 1/s", rates_text(several)),
    };
    recordings
        .into_iter()
        .filter_map(|r| {
            let (_, median, _) = rate_percentiles(r)?;
            let seen = trained
                .iter()
                .any(|t| (median - t).abs() <= PROPELLER_RATE_DIFFERENCE_NOTE * t.abs());
            (!seen).then(|| {
                format!(
                    "{}: recorded at a propeller rate of {median:.3} 1/s, but the model was identified at {at} and has no propeller-rate input (polynomial sets, sparse GP): its forces are those of the rates it was identified at (an mmg model takes the recorded rate)",
                    r.file
                )
            })
        })
        .collect()
}

/// The distinct propeller rates [1/s] of `rates` (ascending): rates within
/// [`PROPELLER_RATE_DIFFERENCE_NOTE`] of the previous distinct one are the same rate.
fn distinct_rates(mut rates: Vec<f64>) -> Vec<f64> {
    rates.retain(|x| x.is_finite());
    rates.sort_by(f64::total_cmp);
    let mut out: Vec<f64> = Vec::new();
    for x in rates {
        if out
            .last()
            .is_none_or(|&y| (x - y).abs() > PROPELLER_RATE_DIFFERENCE_NOTE * y.abs())
        {
            out.push(x);
        }
    }
    out
}

fn rates_text(rates: &[f64]) -> String {
    rates
        .iter()
        .map(|x| format!("{x:.3}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// For a fit (or a study's fits) of a model without a propeller-rate input on `recordings`: a note
/// when they ran at different constant rates (medians more than [`PROPELLER_RATE_DIFFERENCE_NOTE`]
/// apart), whose forces such a model mixes as if they were at one rate.
pub fn rates_between_runs_note<'a>(
    recordings: impl IntoIterator<Item = &'a DatasetRecording>,
) -> Option<String> {
    runs_at_different_rates(recordings).map(|runs| {
        format!(
            "the recordings ran at different propeller rates ({runs} 1/s): a model without a propeller-rate input (polynomial sets, sparse GP) fits their forces as if at one rate; an mmg model takes each sample's rate"
        )
    })
}

/// For an mmg fit at its own rate `own_rate_hz` (the median of its training samples) on `recordings`:
/// a note when they ran at different constant rates. Each sample is fitted at its own rate, but a
/// standard manoeuvre runs at the model's one rate, which then is none of the recordings' in
/// particular.
pub fn training_rates_note<'a>(
    own_rate_hz: f64,
    recordings: impl IntoIterator<Item = &'a DatasetRecording>,
) -> Option<String> {
    runs_at_different_rates(recordings).map(|runs| {
        format!(
            "the training recordings ran at different propeller rates ({runs} 1/s): each sample is fitted at its recorded rate, but `simulate --manoeuvre` and the bands of a standard manoeuvre run at the model's own rate, the median of all its samples, {own_rate_hz:.3} 1/s (`simulate --propeller-rate N` for another)"
        )
    })
}

/// "file median, …" of `recordings` when their median rates are more than
/// [`PROPELLER_RATE_DIFFERENCE_NOTE`] apart (recordings without `n` are not judged).
fn runs_at_different_rates<'a>(
    recordings: impl IntoIterator<Item = &'a DatasetRecording>,
) -> Option<String> {
    let medians: Vec<(String, f64)> = recordings
        .into_iter()
        .filter_map(|r| Some((r.file.clone(), rate_percentiles(r)?.1)))
        .collect();
    let distinct = distinct_rates(medians.iter().map(|m| m.1).collect());
    (distinct.len() > 1).then(|| {
        medians
            .iter()
            .map(|(f, n)| format!("{f} {n:.3}"))
            .collect::<Vec<_>>()
            .join(", ")
    })
}

/// 2nd, 50th and 98th percentiles of the recorded propeller rate [1/s] of `r` (robust to single
/// spikes); `None` without an `n` column of at least three finite values.
fn rate_percentiles(r: &DatasetRecording) -> Option<(f64, f64, f64)> {
    let mut n: Vec<f64> = r
        .recording
        .n
        .as_ref()?
        .iter()
        .copied()
        .filter(|x| x.is_finite())
        .collect();
    if n.len() < 3 {
        return None;
    }
    n.sort_by(f64::total_cmp);
    let at = |q: f64| n[((n.len() - 1) as f64 * q).round() as usize];
    Some((at(0.02), at(0.5), at(0.98)))
}

/// The recordings of `recordings` whose recorded propeller rate spreads by more than
/// [`PROPELLER_RATE_SPREAD_WARNING`] of its median (recordings without `n` are not judged).
pub fn propeller_rate_variations<'a>(
    recordings: impl IntoIterator<Item = &'a DatasetRecording>,
) -> Vec<PropellerRateVariation> {
    recordings
        .into_iter()
        .filter_map(|r| {
            let (low, median, high) = rate_percentiles(r)?;
            let spread = (high - low) / median.abs();
            (median != 0.0 && spread > PROPELLER_RATE_SPREAD_WARNING).then(|| {
                PropellerRateVariation {
                    recording: r.file.clone(),
                    n_low_hz: low,
                    n_high_hz: high,
                    relative_spread: spread,
                }
            })
        })
        .collect()
}
