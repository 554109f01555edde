//! Standard manoeuvres simulated with a model from a steady approach at U0, or at the straight-run
//! speed of another propeller rate (`shipid simulate`).

use shipid_io::{FlowSeries, Manoeuvre, Recording};
use shipid_sim::{
    Dynamics, KnownEnvironment, SimOptions, SimOutput, State, WithEnvironment, controller_for,
};

use crate::environment::{ChosenWindage, WindageSource};

use crate::error::{PipelineError, bad_input};
use crate::generate::{DT_S, SAMPLE_INTERVAL_S, execute_time_s, standard_duration_s};

/// RK4 steps a simulation may take unless the user insists (`--allow-large`): about ten seconds of
/// work, some 4000 times a standard manoeuvre of the KVLCC2 model at the default step.
pub const MAX_STEPS_UNLESS_ALLOWED: f64 = 1e7;
/// RK4 steps of one command over all its runs (the model, its band replicates, valley starts and
/// jackknife refits) unless the user insists: a minute or so of an mmg model, a few minutes of a
/// sparse GP — 2500 standard manoeuvres, so that a thousand replicates of one pass.
pub const MAX_TOTAL_STEPS_UNLESS_ALLOWED: f64 = 5e7;
/// Samples kept of a run's history at most: 96 bytes each (twelve channels), so under 100 MB. A longer
/// run stores every k-th step (the history is decimated, the integration is not).
pub const MAX_STORED_SAMPLES: f64 = 1e6;
/// Largest RK4 step as a fraction of L/U0: the yaw response of a ship takes about L/U0, and a step
/// beyond a tenth of it no longer resolves it (the default 0.05 s is 0.008 L/U0 for the KVLCC2 model).
pub const MAX_STEP_OVER_L_OVER_U0: f64 = 0.1;

/// The finest default step [L/U0]: [`DT_S`] on the default KVLCC2 model (L 7 m, U0 1.179 m/s) is
/// 0.00842 L/U0; ships of that size and larger keep [`DT_S`] exactly, smaller ones take this.
pub const DEFAULT_MAX_STEP_OVER_L_OVER_U0: f64 = 0.0085;

/// What `shipid simulate` asks for: the step and duration as given (defaults otherwise), and whether a
/// run above [`MAX_STEPS_UNLESS_ALLOWED`] may start.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SimRequest {
    pub dt_s: Option<f64>,
    pub duration_s: Option<f64>,
    pub allow_large: bool,
}

/// The grid a request resolves to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimGrid {
    pub dt_s: f64,
    /// Simulated time [s]: a whole number of steps, the asked duration rounded to the nearest.
    pub duration_s: f64,
    /// The duration asked for (or the manoeuvre's standard one) [s], before that rounding.
    pub requested_duration_s: f64,
    /// RK4 steps.
    pub steps: f64,
    /// Interval of the stored samples [s]: 0.1 s when the step divides it, else the step, times the
    /// decimation that keeps at most [`MAX_STORED_SAMPLES`].
    pub sample_interval_s: f64,
    /// Whether the history was thinned to bound memory.
    pub decimated: bool,
}

/// Checks `request` against the ship and the manoeuvre before any work: positive finite step and
/// duration, a step shorter than the run and than [`MAX_STEP_OVER_L_OVER_U0`] L/U0, and no more than
/// [`MAX_STEPS_UNLESS_ALLOWED`] steps unless allowed. Messages name the flags.
pub fn sim_grid(
    model: &dyn Dynamics,
    m: &Manoeuvre,
    request: &SimRequest,
) -> Result<SimGrid, PipelineError> {
    let ship = *model.ship();
    // The default step is in seconds, and a Froude copy of the default ship at 2 cm length took
    // the same 0.05 s for a yaw response 19 times faster (advance +6.5 %, t_a +10.5 %): a ship
    // smaller than the default one steps as finely in L/U0 as the default one does.
    let dt = request
        .dt_s
        .unwrap_or_else(|| DT_S.min(DEFAULT_MAX_STEP_OVER_L_OVER_U0 * ship.lpp / ship.u0));
    if !(dt.is_finite() && dt > 0.0) {
        return Err(bad_input(format!(
            "--dt must be a positive number of seconds, got {}",
            shipid_io::error::number(dt)
        )));
    }
    let max_dt = MAX_STEP_OVER_L_OVER_U0 * ship.lpp / ship.u0;
    // Only a step the user chose: the default suits every model-scale ship.
    if request.dt_s.is_some() && dt > max_dt {
        return Err(bad_input(format!(
            "--dt {} s is more than {MAX_STEP_OVER_L_OVER_U0} L/U0 = {max_dt:.3} s for this ship (L = {} m, U0 = {} m/s): RK4 would step over its yaw response",
            shipid_io::error::number(dt),
            ship.lpp,
            ship.u0
        )));
    }
    let duration = request
        .duration_s
        .unwrap_or_else(|| standard_duration_s(m, &ship));
    if !(duration.is_finite() && duration > 0.0) {
        return Err(bad_input(format!(
            "--duration must be a positive number of seconds, got {}",
            shipid_io::error::number(duration)
        )));
    }
    if dt >= duration {
        return Err(bad_input(format!(
            "--dt {} s is not shorter than the simulated time {} s: the run would have no step to measure",
            shipid_io::error::number(dt),
            shipid_io::error::number(duration)
        )));
    }
    let steps = (duration / dt).round();
    if steps > MAX_STEPS_UNLESS_ALLOWED && !request.allow_large {
        // A duration nobody gave is the manoeuvre's standard one: named so, not as a flag's value
        // with sixteen digits.
        let duration_said = match request.duration_s {
            Some(d) => format!("--duration {} s", shipid_io::error::number(d)),
            None => format!("the manoeuvre's standard duration {duration:.1} s"),
        };
        return Err(bad_input(format!(
            "{duration_said} at --dt {} s is {steps:.3e} RK4 steps (more than {MAX_STEPS_UNLESS_ALLOWED:.0e}; a standard manoeuvre takes about {:.0}): give --allow-large to run it anyway (its stored history is then thinned to at most {MAX_STORED_SAMPLES:.0e} samples)",
            shipid_io::error::number(dt),
            (standard_duration_s(m, &ship) / DT_S).round()
        )));
    }
    // Sample at 10 Hz when the step divides it, otherwise every step.
    let ratio = (SAMPLE_INTERVAL_S / dt).round();
    let base = if ratio >= 1.0 && (ratio * dt - SAMPLE_INTERVAL_S).abs() < 1e-9 {
        ratio * dt
    } else {
        dt
    };
    let thin = (duration / base / MAX_STORED_SAMPLES).ceil().max(1.0);
    Ok(SimGrid {
        dt_s: dt,
        // The integrator takes whole steps: the time it simulates, not the time asked, is what the
        // messages and the output quote.
        duration_s: steps * dt,
        requested_duration_s: duration,
        steps,
        sample_interval_s: thin * base,
        decimated: thin > 1.0,
    })
}

/// Simulate a standard manoeuvre from a steady approach at U0 (default step and duration, no large
/// runs).
pub fn simulate_manoeuvre(
    model: &dyn Dynamics,
    m: &Manoeuvre,
    dt_s: Option<f64>,
    duration_s: Option<f64>,
) -> Result<SimOutput, PipelineError> {
    let request = SimRequest {
        dt_s,
        duration_s,
        allow_large: false,
    };
    let grid = sim_grid(model, m, &request)?;
    simulate_on_grid(model, m, &grid)
}

/// Simulate a standard manoeuvre from a steady approach at U0 on a checked grid ([`sim_grid`]).
pub fn simulate_on_grid(
    model: &dyn Dynamics,
    m: &Manoeuvre,
    grid: &SimGrid,
) -> Result<SimOutput, PipelineError> {
    simulate_on_grid_from(model, m, grid, model.ship().u0)
}

/// [`simulate_on_grid`] from a straight approach at `approach_m_s` [m/s] instead of U0 (a propeller
/// rate other than the model's own: [`straight_run_speed`]).
pub fn simulate_on_grid_from(
    model: &dyn Dynamics,
    m: &Manoeuvre,
    grid: &SimGrid,
    approach_m_s: f64,
) -> Result<SimOutput, PipelineError> {
    let mut controller = controller_for(m, execute_time_s(model.ship())).map_err(bad_input)?;
    let options = SimOptions::new(grid.duration_s).with_step(grid.dt_s, grid.sample_interval_s);
    shipid_sim::simulate(
        model,
        controller.as_mut(),
        model.over_ground(&State::approach(approach_m_s)),
        &options,
    )
    .map_err(bad_input)
}

/// A constant true wind or current for `shipid simulate --wind/--current`: its speed and the
/// earth-fixed direction it comes from, clockwise from north.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConstantFlow {
    pub speed_m_s: f64,
    pub from_deg: f64,
}

/// `SPEED_M_S,FROM_DEG` as given to `flag` (`--wind` or `--current`): two finite numbers, the speed not
/// negative.
pub fn parse_flow(flag: &str, text: &str) -> Result<ConstantFlow, PipelineError> {
    let expected = |why: &str| {
        bad_input(format!(
            "{flag} {text}: {why}; expected SPEED_M_S,FROM_DEG (speed in m/s, then the direction it comes from in degrees clockwise from north, e.g. {flag} 10,45)"
        ))
    };
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let [speed, from] = parts[..] else {
        return Err(expected(&format!(
            "{} value(s) where two are needed",
            parts.len()
        )));
    };
    let number = |what: &str, s: &str| -> Result<f64, PipelineError> {
        match s.parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(x),
            _ => Err(expected(&format!(
                "the {what} `{s}` is not a finite number"
            ))),
        }
    };
    let flow = ConstantFlow {
        speed_m_s: number("speed", speed)?,
        from_deg: number("direction", from)?,
    };
    if flow.speed_m_s < 0.0 {
        return Err(expected(&format!(
            "the speed {} m/s is negative (give the direction it comes from instead)",
            flow.speed_m_s
        )));
    }
    // As a model file's effects are held: 1e300° has no direction left in floating point, and 720°
    // was echoed as given.
    if flow.from_deg.abs() > shipid_sim::effects::MAX_FROM_DEG {
        return Err(expected(&format!(
            "the direction {}° is beyond ±{}° (a full turn)",
            shipid_io::error::number(flow.from_deg),
            shipid_sim::effects::MAX_FROM_DEG
        )));
    }
    // The bounds of a recorded wind or current: beyond them the run ends as a "diverged" model, and
    // the user's typo reads as the model's failure.
    let max = if flag == "--wind" {
        crate::generate::MAX_RECORDED_WIND_M_S
    } else {
        crate::generate::MAX_RECORDED_CURRENT_M_S
    };
    if flow.speed_m_s > max {
        return Err(bad_input(format!(
            "{flag} {text}: the speed {} m/s is beyond the {max} m/s a recorded {} may have",
            flow.speed_m_s,
            flag.trim_start_matches("--")
        )));
    }
    Ok(flow)
}

/// The windage a simulation of `model_spec` in a given wind uses: the model file's (the one it was
/// identified with), else its training data set's `[windage]`, else assumed.
pub fn simulation_windage(model_spec: &str, ship: &shipid_io::Ship) -> ChosenWindage {
    let record = crate::environment::model_environment(model_spec);
    let training = crate::range::training_data(model_spec);
    ChosenWindage::first_of(
        &[
            (
                record.as_ref().and_then(|r| r.windage.as_ref()),
                WindageSource::ModelFile,
            ),
            (
                training.as_ref().and_then(|(_, ds, _)| ds.windage.as_ref()),
                WindageSource::Dataset,
            ),
        ],
        ship,
    )
}

/// A constant wind and current as a known environment for a simulation of `duration_s` (`None`
/// when neither is given); the wind's force with `windage`.
pub fn constant_environment(
    wind: Option<ConstantFlow>,
    current: Option<ConstantFlow>,
    windage: &ChosenWindage,
    ship: &shipid_io::Ship,
    duration_s: f64,
) -> Result<Option<KnownEnvironment>, PipelineError> {
    if wind.is_none() && current.is_none() {
        return Ok(None);
    }
    let series = |f: ConstantFlow| FlowSeries {
        speed_m_s: vec![f.speed_m_s; 2],
        from_rad: vec![f.from_deg.to_radians(); 2],
    };
    let rec = Recording {
        t: vec![0.0, duration_s.max(1.0)],
        wind: wind.map(series),
        current: current.map(series),
        ..Recording::default()
    };
    crate::environment::environment_with(&rec, windage, ship, "--wind/--current")
}

/// [`simulate_on_grid_from`] in a known environment (`None`: calm water and air). The approach is
/// straight at `approach_m_s` through the water.
pub fn simulate_on_grid_in(
    model: &dyn Dynamics,
    m: &Manoeuvre,
    grid: &SimGrid,
    env: Option<KnownEnvironment>,
    approach_m_s: f64,
) -> Result<SimOutput, PipelineError> {
    match env {
        Some(env) => {
            let flows = env.clone();
            let mut out =
                simulate_on_grid_from(&WithEnvironment::new(model, env), m, grid, approach_m_s)?;
            // Its metrics are taken relative to the water, as a recording's in a current are; the
            // wind goes with it so that the run written as a recording reads back in the same air.
            // The simulation records the current of a model that carries one (its own effect
            // and this environment's together); the environment's alone otherwise.
            if out.recording.current.is_none() {
                out.recording.current = flows.current_series(&out.recording.t);
            }
            out.recording.wind = flows.wind_series(&out.recording.t);
            Ok(out)
        }
        None => simulate_on_grid_from(model, m, grid, approach_m_s),
    }
}

/// The speed [m/s] at which `model` runs straight with the rudder amidships (its surge acceleration
/// vanishes), searched from 2 % to three times U0; `None` when it does not vanish there or the model
/// cannot be evaluated. With the propeller at a rate other than the model's own
/// ([`shipid_sim::WithPropellerRate`]), the approach speed of a manoeuvre at that rate.
pub fn straight_run_speed(model: &dyn Dynamics) -> Option<f64> {
    let u0 = model.ship().u0;
    let surge = |u: f64| {
        // Straight through the water at u: a model that carries a current reads its state over
        // ground, and without the conversion the speed found was U0 plus the current along the
        // course (a 0.1 m/s current from ahead: 0.92 U0, blamed on the propeller rate).
        model
            .accelerations(&model.over_ground(&State::approach(u)), 0.0)
            .ok()
            .map(|a| a[0])
            .filter(|a| a.is_finite())
    };
    // Scan for the first sign change from accelerating to decelerating, then bisect it.
    let grid: Vec<f64> = (1..=150).map(|k| 0.02 * u0 * f64::from(k)).collect();
    let (mut lo, mut hi) = grid.windows(2).find_map(|w| {
        let (a, b) = (surge(w[0])?, surge(w[1])?);
        (a > 0.0 && b <= 0.0).then_some((w[0], w[1]))
    })?;
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if surge(mid)? > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(0.5 * (lo + hi))
}

/// A model that takes the propeller rate and runs straight at its own rate further than this from
/// U0 (÷ U0) does not start a standard manoeuvre steady at U0: the rate its recordings ran at drove
/// it at another speed (the HSVA fit: 0.5 % off).
pub const OWN_RATE_APPROACH_TOLERANCE: f64 = 0.01;

/// Where a standard manoeuvre of a model at its own propeller rate starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OwnRateApproach {
    /// At U0: the model runs straight there (within [`OWN_RATE_APPROACH_TOLERANCE`]), or it takes no
    /// propeller rate (a polynomial or a GP holds the speed its training approached at).
    AtU0,
    /// At the model's straight-run speed at its own rate, more than the tolerance away from U0.
    StraightRun {
        /// The straight-run speed [m/s].
        speed_m_s: f64,
        /// The model's own propeller rate [1/s].
        rate_hz: f64,
    },
    /// The model runs straight at no speed between 2 % and three times U0 at its own rate: the
    /// manoeuvre starts at U0 and is not steady.
    NoStraightRun {
        /// The model's own propeller rate [1/s].
        rate_hz: f64,
    },
}

/// The approach of a standard manoeuvre of `model` at its own propeller rate.
pub fn own_rate_approach(model: &dyn Dynamics) -> OwnRateApproach {
    let Some(rate_hz) = model
        .propeller_rate_hz()
        .filter(|_| model.takes_propeller_rate())
    else {
        return OwnRateApproach::AtU0;
    };
    let u0 = model.ship().u0;
    match straight_run_speed(model) {
        None => OwnRateApproach::NoStraightRun { rate_hz },
        Some(u) if (u / u0 - 1.0).abs() > OWN_RATE_APPROACH_TOLERANCE => {
            OwnRateApproach::StraightRun {
                speed_m_s: u,
                rate_hz,
            }
        }
        Some(_) => OwnRateApproach::AtU0,
    }
}
