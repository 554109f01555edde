//! Standard manoeuvres simulated with a model from a steady approach at U0 (`shipid simulate`).

use shipid_io::Manoeuvre;
use shipid_sim::{Dynamics, SimOptions, SimOutput, State, controller_for};

use crate::error::{PipelineError, bad_input};
use crate::generate::{DT_S, SAMPLE_INTERVAL_S, T_EXECUTE_S, standard_duration_s};

/// Simulate a standard manoeuvre from a steady approach at U0.
pub fn simulate_manoeuvre(
    model: &dyn Dynamics,
    m: &Manoeuvre,
    dt_s: Option<f64>,
    duration_s: Option<f64>,
) -> Result<SimOutput, PipelineError> {
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
