//! Fixed-step RK4 integration of a [`Dynamics`] model under a [`RudderController`], with a rate-limited
//! rudder actuator, uniform sampling into a [`Recording`] and divergence detection.

use serde::{Deserialize, Serialize};
use shipid_io::{Accelerations, Recording};
use thiserror::Error;

use crate::control::{RudderCommand, RudderController};
use crate::dynamics::{Dynamics, State};
// Defined next to `Dynamics` (whose `model_rudder_filter` returns one); re-exported here for the
// paths `shipid_sim::sim::{RudderFilter, NoFilter}`.
pub use crate::dynamics::{NoFilter, RudderFilter};

/// Limits beyond which a simulated state counts as diverged. A state outside them is not physical for a
/// displacement ship driven by its own propeller at the approach speed U0.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DivergenceBounds {
    /// Largest speed √(u² + v²) through the water as a multiple of U0 [-]. Default 3: the propeller is set for U0 and the
    /// hull resistance grows with U², so a ship more than three times faster has left the physics.
    pub max_speed_over_u0: f64,
    /// Largest |v| through the water as a multiple of U0 [-]. Default 1.5: drifting sideways faster than the approach
    /// speed is not a manoeuvre.
    pub max_sway_over_u0: f64,
    /// Largest |r| L / U0 [-]. Default 5: about twenty times the yaw rate of a hard-over steady turn of
    /// KVLCC2 (r L/U0 ≈ 0.25).
    pub max_yaw_rate_prime: f64,
}

impl Default for DivergenceBounds {
    fn default() -> Self {
        DivergenceBounds {
            max_speed_over_u0: 3.0,
            max_sway_over_u0: 1.5,
            max_yaw_rate_prime: 5.0,
        }
    }
}

/// Integration and sampling settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SimOptions {
    /// RK4 step [s]. Default 0.05 s (model scale): the KVLCC2 zig-zag overshoots then agree with those
    /// at 0.0125 s to 0.001°, thanks to rudder switches placed inside the step.
    pub dt_s: f64,
    /// Simulated time [s]; rounded to a whole number of steps.
    pub duration_s: f64,
    /// Interval between recorded samples [s]; a whole multiple of `dt_s`.
    pub sample_interval_s: f64,
    /// Actual rudder angle at t = 0 [rad] (the actuator's initial position).
    pub initial_rudder_rad: f64,
    /// Divergence limits.
    pub bounds: DivergenceBounds,
}

impl SimOptions {
    /// Default model-scale settings for `duration_s`: dt = 0.05 s, a sample every step, rudder at zero.
    pub fn new(duration_s: f64) -> SimOptions {
        SimOptions {
            dt_s: 0.05,
            duration_s,
            sample_interval_s: 0.05,
            initial_rudder_rad: 0.0,
            bounds: DivergenceBounds::default(),
        }
    }

    /// Same settings with the RK4 step `dt_s`, recording every `sample_interval_s`.
    pub fn with_step(self, dt_s: f64, sample_interval_s: f64) -> SimOptions {
        SimOptions {
            dt_s,
            sample_interval_s,
            ..self
        }
    }

    /// Number of steps and the sampling stride in steps.
    fn grid(&self) -> Result<(usize, usize), SimError> {
        let bad =
            |field: &'static str, value: f64, reason: &'static str| SimError::InvalidOptions {
                field,
                value,
                reason,
            };
        if !(self.dt_s.is_finite() && self.dt_s > 0.0) {
            return Err(bad("dt_s", self.dt_s, "must be finite and positive"));
        }
        if !(self.duration_s.is_finite() && self.duration_s >= 0.0) {
            return Err(bad(
                "duration_s",
                self.duration_s,
                "must be finite and non-negative",
            ));
        }
        let steps = (self.duration_s / self.dt_s).round();
        if steps > 1e9 {
            return Err(bad("duration_s", self.duration_s, "more than 1e9 steps"));
        }
        if !(self.sample_interval_s.is_finite() && self.sample_interval_s > 0.0) {
            return Err(bad(
                "sample_interval_s",
                self.sample_interval_s,
                "must be finite and positive",
            ));
        }
        let stride = (self.sample_interval_s / self.dt_s).round();
        if stride < 1.0
            || (stride * self.dt_s - self.sample_interval_s).abs() > 1e-9 * self.sample_interval_s
        {
            return Err(bad(
                "sample_interval_s",
                self.sample_interval_s,
                "must be a whole multiple of dt_s",
            ));
        }
        if !self.initial_rudder_rad.is_finite() {
            return Err(bad(
                "initial_rudder_rad",
                self.initial_rudder_rad,
                "must be finite",
            ));
        }
        let b = &self.bounds;
        for (field, value) in [
            ("bounds.max_speed_over_u0", b.max_speed_over_u0),
            ("bounds.max_sway_over_u0", b.max_sway_over_u0),
            ("bounds.max_yaw_rate_prime", b.max_yaw_rate_prime),
        ] {
            if value.is_nan() || value <= 0.0 {
                return Err(bad(field, value, "must be positive"));
            }
        }
        Ok((steps as usize, stride as usize))
    }
}

/// How a simulation ended. Serialises as `{"status": "ok"}` or
/// `{"status": "diverged", "t_s": …, "reason": "…"}` (as in result files, `docs/data-format.md`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "status", rename_all = "lowercase")]
pub enum SimStatus {
    /// Ran for the whole duration.
    Ok,
    /// Stopped at `t_s` [s]: the state left the [`DivergenceBounds`], became non-finite, or the model
    /// could not be evaluated (`reason` says which).
    Diverged { t_s: f64, reason: String },
}

/// A simulated manoeuvre.
#[derive(Debug, Clone, PartialEq)]
pub struct SimOutput {
    /// Samples every `sample_interval_s` of midship in the project's conventions (`docs/conventions.md`),
    /// heading unwrapped, with the
    /// model's accelerations and (when the model has one) the propeller rate. `delta` is the rudder as a
    /// log would record it: the actuator output or the replayed history, before any
    /// [`RudderFilter`]. After a divergence it holds the samples before it.
    pub recording: Recording,
    /// How the run ended.
    pub status: SimStatus,
}

/// Invalid simulation input.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SimError {
    /// A [`SimOptions`] field is out of range.
    #[error("invalid simulation option {field} = {value}: {reason}")]
    InvalidOptions {
        field: &'static str,
        value: f64,
        reason: &'static str,
    },
    /// The initial state has a non-finite component.
    #[error("initial state is not finite: {0:?}")]
    InvalidInitialState(State),
    /// The model's ship cannot scale the divergence bounds or drive the actuator.
    #[error("ship particular {field} = {value} must be finite and positive")]
    InvalidShip { field: &'static str, value: f64 },
}

/// Simulate `model` from `initial` under `controller` (see [`simulate_filtered`]), through the model's own
/// rudder filter when it has one ([`Dynamics::model_rudder_filter`]).
pub fn simulate(
    model: &dyn Dynamics,
    controller: &mut dyn RudderController,
    initial: State,
    options: &SimOptions,
) -> Result<SimOutput, SimError> {
    match model.model_rudder_filter() {
        Some(mut filter) => simulate_filtered(model, controller, filter.as_mut(), initial, options),
        None => simulate_filtered(model, controller, &mut NoFilter, initial, options),
    }
}

/// Moves `from` towards `to` by at most `max_step`.
fn actuate(from: f64, to: f64, max_step: f64) -> f64 {
    let d = to - from;
    if d.abs() <= max_step {
        to
    } else {
        from + max_step.copysign(d)
    }
}

/// Actual rudder `tau` seconds into a step that starts at `delta0` under `cmd`, moving at `rate`.
fn actuator(delta0: f64, cmd: &RudderCommand, rate: f64, tau: f64) -> f64 {
    match cmd.switch {
        Some((ts, angle)) if tau > ts => {
            let at_switch = actuate(delta0, cmd.angle_rad, rate * ts.max(0.0));
            actuate(at_switch, angle, rate * (tau - ts.max(0.0)))
        }
        _ => actuate(delta0, cmd.angle_rad, rate * tau),
    }
}

struct Samples {
    rec: Recording,
    n: Option<f64>,
}

impl Samples {
    fn push(&mut self, t: f64, s: &State, delta: f64, acc: [f64; 3]) {
        let r = &mut self.rec;
        r.t.push(t);
        r.x0.push(s.x0);
        r.y0.push(s.y0);
        r.psi.push(s.psi);
        r.u.push(s.u);
        r.v.push(s.v);
        r.r.push(s.r);
        r.delta.push(delta);
        if let (Some(n), Some(ns)) = (self.n, r.n.as_mut()) {
            ns.push(n);
        }
        if let Some(a) = r.accelerations.as_mut() {
            a.u_dot.push(acc[0]);
            a.v_dot.push(acc[1]);
            a.r_dot.push(acc[2]);
        }
    }
}

fn derivative(model: &dyn Dynamics, t_s: f64, s: &State, delta: f64) -> Result<[f64; 6], String> {
    let a = model
        .accelerations_at(t_s, s, delta)
        .map_err(|e| e.to_string())?;
    if !a.iter().all(|x| x.is_finite()) {
        return Err(format!("model returned non-finite accelerations {a:?}"));
    }
    let k = s.kinematics();
    Ok([a[0], a[1], a[2], k[0], k[1], k[2]])
}

fn axpy(s: &[f64; 6], h: f64, k: &[f64; 6]) -> State {
    State::from_array(std::array::from_fn(|i| s[i] + h * k[i]))
}

/// The state relative to water moving at `current` [north, east] m/s of the over-ground state `s`.
fn through_water(s: &State, [n, e]: [f64; 2]) -> State {
    let (sin, cos) = s.psi.sin_cos();
    State {
        u: s.u - (n * cos + e * sin),
        v: s.v - (-n * sin + e * cos),
        ..*s
    }
}

fn check_bounds(s: &State, b: &DivergenceBounds, u0: f64, lpp: f64) -> Option<String> {
    if !s.is_finite() {
        return Some(format!("non-finite state {s:?}"));
    }
    let speed = s.speed();
    if speed > b.max_speed_over_u0 * u0 {
        return Some(format!(
            "speed {speed:.4} m/s above {} U0",
            b.max_speed_over_u0
        ));
    }
    if s.v.abs() > b.max_sway_over_u0 * u0 {
        return Some(format!(
            "|v| = {:.4} m/s above {} U0",
            s.v.abs(),
            b.max_sway_over_u0
        ));
    }
    let r_prime = s.r.abs() * lpp / u0;
    if r_prime > b.max_yaw_rate_prime {
        return Some(format!(
            "|r| L/U0 = {r_prime:.3} above {}",
            b.max_yaw_rate_prime
        ));
    }
    None
}

/// Simulate `model` from `initial` (over-ground state at t = 0) under `controller`, with `filter`
/// between the recorded and the effective rudder.
///
/// Each RK4 step of `options.dt_s` asks the controller once for its command (which may switch inside
/// the step); the actuator moves the rudder towards it at the ship's rudder rate, evaluated exactly at
/// the stage times (a replay prescribes the rudder there instead). Divergence ends the run with [`SimStatus::Diverged`], never a panic: a
/// model error or non-finite accelerations at time t, or a state outside `options.bounds` (or
/// non-finite) after the step ending at t. Invalid options, ship or initial state are a [`SimError`].
pub fn simulate_filtered(
    model: &dyn Dynamics,
    controller: &mut dyn RudderController,
    filter: &mut dyn RudderFilter,
    initial: State,
    options: &SimOptions,
) -> Result<SimOutput, SimError> {
    let (steps, stride) = options.grid()?;
    let ship = *model.ship();
    for (field, value) in [
        ("u0", ship.u0),
        ("lpp", ship.lpp),
        ("rudder_rate", ship.rudder_rate),
    ] {
        if !(value.is_finite() && value > 0.0) {
            return Err(SimError::InvalidShip { field, value });
        }
    }
    if !initial.is_finite() {
        return Err(SimError::InvalidInitialState(initial));
    }
    let dt = options.dt_s;
    let rate = ship.rudder_rate_rad_s();
    let n_prop = model.propeller_rate_hz();
    let capacity = steps / stride + 1;
    let mut out = Samples {
        rec: Recording {
            n: n_prop.map(|_| Vec::with_capacity(capacity)),
            accelerations: Some(Accelerations::default()),
            ..Recording::default()
        },
        n: n_prop,
    };

    let mut state = initial;
    let mut delta = options.initial_rudder_rad;
    let mut status = SimStatus::Ok;
    let diverged = |t_s: f64, reason: String| SimStatus::Diverged { t_s, reason };
    for k in 0..=steps {
        let t = k as f64 * dt;
        let last = k == steps;
        let h = if last { 0.0 } else { dt };
        let cmd = controller.command(t, h, &state);
        let recorded = [0.0, 0.5 * h, h].map(|tau| {
            controller
                .prescribed(t + tau)
                .unwrap_or_else(|| actuator(delta, &cmd, rate, tau))
        });
        if !recorded.iter().all(|d| d.is_finite()) {
            status = diverged(t, format!("non-finite rudder angle {recorded:?}"));
            break;
        }
        let effective = filter.step(t, h, recorded);
        if !effective.iter().all(|d| d.is_finite()) {
            status = diverged(
                t,
                format!("non-finite effective rudder angle {effective:?}"),
            );
            break;
        }
        let y = state.to_array();
        let k1 = match derivative(model, t, &state, effective[0]) {
            Ok(k1) => k1,
            Err(reason) => {
                status = diverged(t, reason);
                break;
            }
        };
        if k % stride == 0 {
            out.push(t, &state, recorded[0], [k1[0], k1[1], k1[2]]);
        }
        if last {
            break;
        }
        let stages = (|| {
            let k2 = derivative(model, t + 0.5 * dt, &axpy(&y, 0.5 * dt, &k1), effective[1])?;
            let k3 = derivative(model, t + 0.5 * dt, &axpy(&y, 0.5 * dt, &k2), effective[1])?;
            let k4 = derivative(model, t + dt, &axpy(&y, dt, &k3), effective[2])?;
            Ok::<_, String>((k2, k3, k4))
        })();
        let (k2, k3, k4) = match stages {
            Ok(ks) => ks,
            Err(reason) => {
                status = diverged(t, reason);
                break;
            }
        };
        state = State::from_array(std::array::from_fn(|i| {
            y[i] + dt / 6.0 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i])
        }));
        delta = recorded[2];
        // The limits are of the hydrodynamics, which see the velocities through the water: a
        // current only carries the ship along (a 2.4 m/s current is not a model going 3 U0).
        let t_end = (k + 1) as f64 * dt;
        let judged = match model.current_velocity_earth(t_end) {
            Some(current) => through_water(&state, current),
            None => state,
        };
        if let Some(reason) = check_bounds(&judged, &options.bounds, ship.u0, ship.lpp) {
            status = diverged((k + 1) as f64 * dt, reason);
            break;
        }
    }
    // A model that carries the ship in a current records it, as a recording in a current does, so
    // that the run's metrics are taken relative to the water (`metrics::relative_to_water`).
    let mut recording = out.rec;
    if model.current_velocity_earth(0.0).is_some() {
        recording.current = Some(crate::flow::flow_series(&recording.t, |t| {
            model.current_velocity_earth(t).unwrap_or([0.0; 2])
        }));
    }
    Ok(SimOutput { recording, status })
}
