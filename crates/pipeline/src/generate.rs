//! `shipid generate`: the embedded default data set, made by the project's MMG reference simulator.
//!
//! Six manoeuvres of the KVLCC2 model (docs/conventions.md, "The MMG reference"): ZZ10/10, ZZ20/20 and ZZ35/35 to port first,
//! ZZ35/35 to starboard first, and 35° turning circles to both sides (or the zig-zags and turning
//! circles given by `--manoeuvre`, e.g. to test a diagnosis on manoeuvres its base model was not
//! identified from). Each starts from a steady approach
//! at U0 with the rudder at zero; the first execute is at [`T_EXECUTE_S`]. RK4 with dt = 0.05 s, written
//! at 10 Hz, midship, project signs.
//!
//! # Concealed effects (`--effect KIND:key=value,...`, repeatable)
//! Physical effects of `shipid_sim::effects` (current, wind, rudder lag, asymmetry, shallow water) are
//! applied in the simulation and mentioned nowhere in the written data set: the recordings are what a
//! test of a ship under that effect would record (over ground for a current). This is how the
//! discrepancy diagnosis is proven on data where the effect is concealed.
//!
//! # Recorded environment (`--recorded-wind KEY=VALUE,…`, `--recorded-current KEY=VALUE,…`)
//! A wind (and a current) the ship feels in the simulation *and* that is written as the recording's
//! `wind_speed`/`wind_from` (`current_speed`/`current_from`) channels, with the windage that turns it
//! into forces as the data set's `[windage]` ([`assumed_windage`] of the KVLCC2 model unless given):
//! the data of a trial that measured its environment. The MMG reference is simulated inside
//! [`WithEnvironment`] with the very series that is written (before the anemometer's noise), so a
//! replay of a recording with its own environment reproduces it. Each run draws its own mean wind
//! ([`RecordedWind`]: speed and direction vary between runs, seeded); an optional gust is a
//! first-order Gauss–Markov process on the speed ([`RecordedWind::gust_intensity`]).
//!
//! # Noise model (`--noise SEED`)
//! Independent zero-mean Gaussian white noise on every recorded channel, with standard deviations fixed
//! in Froude-invariant terms so that the same seed gives the same primed noise at any scale
//! ([`NoiseModel::TANK`]). Accelerations are not written for noisy data (a tank does not measure them;
//! they are estimated from the velocities like any recording's). Every recording draws from its own
//! stream, seeded from SEED and the file name, so the set is reproducible. Recorded wind and current
//! channels get the noise of their sensors ([`AnemometerNoise`]).

use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, Normal};
use shipid_io::dataset::{DatasetFile, Origin, entry_for};
use shipid_io::write::WindChannels;
use shipid_io::{FlowSeries, Manoeuvre, Recording, Ship, Side, Windage};
use shipid_sim::effects::{Effect, simulate_with_effects};
use shipid_sim::environment::{KnownEnvironment, WithEnvironment, assumed_windage};
use shipid_sim::{Dynamics, MmgModel, SimOptions, SimStatus, State, controller_for, kvlcc2_ship};

use crate::error::{PipelineError, failed};
use crate::spec::manoeuvre_stem;

/// Steady approach before the first rudder execute of the KVLCC2 model [s] (0.84 L/U0); other ships
/// take the same time in units of L/U0 ([`execute_time_s`]).
pub const T_EXECUTE_S: f64 = 5.0;

/// The first execute of a standard manoeuvre of `ship` [s]: [`T_EXECUTE_S`] at the KVLCC2 model's
/// L/U0, the same fraction of L/U0 for any other ship. A model not in equilibrium with the rudder
/// amidships (a polynomial set's constant terms, a sparse GP) drifts during the approach; a fixed
/// time in seconds let that drift, and with it the metrics, depend on the ship's absolute size (the
/// same model at full scale put the rudder over after 0.12 L/U0 instead of 0.84).
pub fn execute_time_s(ship: &Ship) -> f64 {
    let reference = kvlcc2_ship();
    // The ratio first: the KVLCC2 model's own L/U0 gives exactly T_EXECUTE_S.
    T_EXECUTE_S * ((ship.lpp / ship.u0) / (reference.lpp / reference.u0))
}
/// RK4 step [s] (model scale; reproduces the published KVLCC2 check values of the MMG reference).
pub const DT_S: f64 = 0.05;
/// Sampling interval of the written recordings [s] (10 Hz).
pub const SAMPLE_INTERVAL_S: f64 = 0.1;

/// Standard deviations of the measurement noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseModel {
    /// Position noise ÷ L.
    pub position_over_l: f64,
    /// Heading noise [deg].
    pub heading_deg: f64,
    /// Surge and sway velocity noise ÷ U0.
    pub velocity_over_u0: f64,
    /// Yaw-rate noise × L/U0 (primed).
    pub yaw_rate_prime: f64,
    /// Rudder-angle noise [deg].
    pub rudder_deg: f64,
}

impl NoiseModel {
    /// Levels of a towing-tank free-running test (model scale KVLCC2: 7 mm, 0.1°, 2.4 mm/s, 0.05 °/s,
    /// 0.05°), of the order seen in the HSVA KVLCC2 channels.
    pub const TANK: NoiseModel = NoiseModel {
        position_over_l: 1e-3,
        heading_deg: 0.1,
        velocity_over_u0: 2e-3,
        yaw_rate_prime: 5e-3,
        rudder_deg: 0.05,
    };

    /// Add noise to a recording in place, from a stream seeded by `seed` and `stream`.
    pub fn apply(&self, rec: &mut Recording, ship: &Ship, seed: u64, stream: &str) {
        let mut rng = StdRng::seed_from_u64(seed ^ fnv1a(stream));
        let mut add = |x: &mut Vec<f64>, sigma: f64| {
            if let Ok(normal) = Normal::new(0.0, sigma) {
                x.iter_mut().for_each(|v| *v += normal.sample(&mut rng));
            }
        };
        add(&mut rec.x0, self.position_over_l * ship.lpp);
        add(&mut rec.y0, self.position_over_l * ship.lpp);
        add(&mut rec.psi, self.heading_deg.to_radians());
        add(&mut rec.u, self.velocity_over_u0 * ship.u0);
        add(&mut rec.v, self.velocity_over_u0 * ship.u0);
        add(&mut rec.r, self.yaw_rate_prime * ship.u0 / ship.lpp);
        add(&mut rec.delta, self.rudder_deg.to_radians());
        rec.accelerations = None;
    }
}

/// FNV-1a: a fixed, platform-independent hash to derive per-recording seeds.
pub fn fnv1a(s: &str) -> u64 {
    s.bytes().fold(0xcbf29ce484222325, |h, b| {
        (h ^ b as u64).wrapping_mul(0x100000001b3)
    })
}

/// The manoeuvres of the default data set.
pub fn default_manoeuvres() -> Vec<Manoeuvre> {
    let zz = |a: f64, side| Manoeuvre::ZigZag {
        rudder_deg: a,
        check_deg: a,
        side,
    };
    vec![
        zz(10.0, Side::Port),
        zz(20.0, Side::Port),
        zz(35.0, Side::Port),
        zz(35.0, Side::Starboard),
        Manoeuvre::Turning {
            rudder_deg: 35.0,
            side: Side::Port,
        },
        Manoeuvre::Turning {
            rudder_deg: 35.0,
            side: Side::Starboard,
        },
    ]
}

/// Simulated time for a standard manoeuvre of the KVLCC2 model [s], scaled by L/U0 for other ships:
/// zig-zags get at least nine rudder reversals (eight overshoots and more), turning circles about two
/// full turns so the steady diameter is defined.
pub fn standard_duration_s(m: &Manoeuvre, ship: &Ship) -> f64 {
    let l_over_u0 = ship.lpp / ship.u0;
    let units = match *m {
        Manoeuvre::ZigZag { rudder_deg, .. } if rudder_deg < 15.0 => 70.0,
        Manoeuvre::ZigZag { .. } => 80.0,
        Manoeuvre::Turning { .. } => 75.0,
        Manoeuvre::Free => 20.0,
    };
    execute_time_s(ship) + units * l_over_u0
}

/// What `generate` produces: the data set file and its recordings, same order.
pub struct Generated {
    pub dataset: DatasetFile,
    pub recordings: Vec<Recording>,
}

impl Generated {
    /// The generated data as a loaded data set in memory, named `name`, whose recordings are the
    /// `manoeuvres` it was generated from (same order). Harnesses use it without writing files; the
    /// propeller and rudder tables are left out (nothing in memory reads them).
    pub fn in_memory(self, manoeuvres: &[Manoeuvre], name: &str) -> shipid_io::Dataset {
        let recordings = self
            .dataset
            .recordings
            .iter()
            .zip(manoeuvres)
            .zip(self.recordings)
            .map(|((e, &manoeuvre), recording)| shipid_io::DatasetRecording {
                file: e.file.clone(),
                manoeuvre,
                recording,
            })
            .collect();
        shipid_io::Dataset {
            path: std::path::PathBuf::from(name),
            name: self.dataset.name,
            ship: self.dataset.ship,
            added_mass: self.dataset.added_mass,
            propeller: None,
            rudder: None,
            windage: self.dataset.windage,
            recordings,
        }
    }
}

/// Parse `--effect` arguments (`current:speed=0.05,from=120`, …). A concealed wind or current is
/// held to the bounds of a recorded one ([`MAX_RECORDED_WIND_M_S`], [`MAX_RECORDED_CURRENT_M_S`]):
/// beyond them the reference "diverges" and the user's typo reads as the model's failure.
pub fn parse_effects(args: &[String]) -> Result<Vec<Effect>, PipelineError> {
    args.iter()
        .map(|a| {
            let effect = a
                .parse::<Effect>()
                .map_err(|e| crate::error::bad_input(format!("--effect `{a}`: {e}")))?;
            let (kind, speed, max) = match &effect {
                Effect::Current(c) => ("current", c.speed_m_s, MAX_RECORDED_CURRENT_M_S),
                Effect::Wind(w) => ("wind", w.speed_m_s, MAX_RECORDED_WIND_M_S),
                _ => return Ok(effect),
            };
            if speed > max {
                return Err(crate::error::bad_input(format!(
                    "--effect `{a}`: {kind}:speed = {speed} m/s is beyond the {max} m/s a recorded {kind} may have"
                )));
            }
            Ok(effect)
        })
        .collect()
}

/// Simulate the default manoeuvres with the MMG reference.
pub fn generate(noise_seed: Option<u64>) -> Result<Generated, PipelineError> {
    generate_with(noise_seed, &[])
}

/// Simulate the default manoeuvres with the MMG reference under concealed `effects`.
pub fn generate_with(
    noise_seed: Option<u64>,
    effects: &[Effect],
) -> Result<Generated, PipelineError> {
    generate_manoeuvres(noise_seed, effects, &default_manoeuvres())
}

/// Simulate `manoeuvres` (each at most once: the file is named after it) with the MMG reference
/// under concealed `effects`.
pub fn generate_manoeuvres(
    noise_seed: Option<u64>,
    effects: &[Effect],
    manoeuvres: &[Manoeuvre],
) -> Result<Generated, PipelineError> {
    generate_recorded(noise_seed, effects, manoeuvres, None)
}

/// Simulate `manoeuvres` with the MMG reference under concealed `effects` and, when given, in the
/// `recorded` environment, which every recording then carries as channels (module docs).
pub fn generate_recorded(
    noise_seed: Option<u64>,
    effects: &[Effect],
    manoeuvres: &[Manoeuvre],
    recorded: Option<&RecordedEnvironment>,
) -> Result<Generated, PipelineError> {
    let name = "KVLCC2 model, deep water: MMG reference simulation";
    generate_by(
        &MmgModel::kvlcc2(),
        name,
        noise_seed,
        effects,
        manoeuvres,
        recorded,
    )
}

/// Simulate `manoeuvres` with `model` (an MMG ship other than the reference: harnesses that measure
/// a method over a population of ships) in calm water, the data set named `name`.
pub fn generate_model(
    model: &MmgModel,
    name: &str,
    noise_seed: Option<u64>,
    manoeuvres: &[Manoeuvre],
) -> Result<Generated, PipelineError> {
    generate_by(model, name, noise_seed, &[], manoeuvres, None)
}

fn generate_by(
    model: &MmgModel,
    name: &str,
    noise_seed: Option<u64>,
    effects: &[Effect],
    manoeuvres: &[Manoeuvre],
    recorded: Option<&RecordedEnvironment>,
) -> Result<Generated, PipelineError> {
    if let Some(env) = recorded {
        for e in effects {
            let clash = match e {
                Effect::Wind(_) => env.wind.is_some(),
                Effect::Current(_) => env.current.is_some(),
                _ => false,
            };
            if clash {
                return Err(crate::error::bad_input(format!(
                    "--effect {} with --recorded-{}: a {} is either concealed or recorded, not both",
                    e.kind(),
                    e.kind(),
                    e.kind()
                )));
            }
        }
    }
    let ship = *model.ship();
    let mut entries = Vec::new();
    let mut recordings = Vec::new();
    for (k, m) in manoeuvres.iter().enumerate() {
        let file = format!("{}.csv", manoeuvre_stem(m));
        if manoeuvres[..k]
            .iter()
            .any(|o| manoeuvre_stem(o) == manoeuvre_stem(m))
        {
            return Err(crate::error::bad_input(format!(
                "--manoeuvre: {file} is asked for twice"
            )));
        }
        let m = *m;
        let mut controller = controller_for(&m, execute_time_s(&ship)).map_err(failed)?;
        let options =
            SimOptions::new(standard_duration_s(&m, &ship)).with_step(DT_S, SAMPLE_INTERVAL_S);
        let flows = match recorded {
            Some(env) => Some(env.flows(&file, standard_duration_s(&m, &ship), &ship)?),
            None => None,
        };
        let out = match &flows {
            None => simulate_plain(model, effects, controller.as_mut(), &options)?,
            Some((_, environment)) => simulate_plain(
                &WithEnvironment::new(model, environment.clone()),
                effects,
                controller.as_mut(),
                &options,
            )?,
        };
        if let SimStatus::Diverged { t_s, reason } = out.status {
            return Err(failed(format!(
                "the MMG reference diverged in {file} at {t_s} s: {reason}"
            )));
        }
        let mut rec = out.recording;
        // A simulation records the current its model carries, a concealed one included; only what
        // was asked to be recorded may reach the files (a concealed current written as columns is a
        // known input to every fit and diagnosis, concealed no more).
        match flows {
            Some((template, _)) => {
                // The output is sampled on the template's grid from its start: the same samples.
                rec.wind = template.wind.map(|w| w.slice(0..rec.len()));
                rec.current = template.current.map(|c| c.slice(0..rec.len()));
            }
            None => {
                rec.wind = None;
                rec.current = None;
            }
        }
        if let Some(seed) = noise_seed {
            NoiseModel::TANK.apply(&mut rec, &ship, seed, &file);
            AnemometerNoise::TANK.apply(&mut rec, &ship, seed, &file);
        }
        entries.push(entry_for(&file, &m));
        recordings.push(rec);
    }
    let reference = model.parameters();
    let dataset = DatasetFile {
        name: name.into(),
        origin: Origin::Midship,
        reference_point: None,
        rudder_sign: 1,
        ship,
        added_mass: Some(*model.added_mass()),
        // The reference's propeller and rudder (Y&Y 2015 Tables 1 and 5): what an `mmg` fit needs.
        propeller: Some(shipid_io::PropellerTable {
            diameter_m: reference.propeller_diameter_m,
            x_m: reference.x_p * ship.lpp,
            k_t: Some(reference.k_t.to_vec()),
            open_water: None,
            rate_rps: None,
        }),
        rudder: Some(shipid_io::RudderData {
            area_m2: reference.rudder_area_m2,
            span_m: reference.rudder_span_m,
            x_m: reference.x_r * ship.lpp,
        }),
        windage: recorded
            .filter(|env| env.wind.is_some())
            .map(|env| env.windage.clone()),
        recordings: entries,
    };
    Ok(Generated {
        dataset,
        recordings,
    })
}

/// The comment lines written at the top of every generated file.
pub fn provenance(noise_seed: Option<u64>) -> Vec<String> {
    let mut c = vec![
        format!("Generated by shipid {} (`shipid generate`).", env!("CARGO_PKG_VERSION")),
        "Model: MMG standard method for KVLCC2, Yasukawa & Yoshimura (2015), J. Mar. Sci. Technol. 20:37-52;"
            .into(),
        format!(
            "parameters in crates/sim/src/mmg.rs. RK4 dt = {DT_S} s, sampled every {SAMPLE_INTERVAL_S} s; midship; SI units;"
        ),
        "rudder positive to starboard. Ship particulars and added masses: dataset.toml.".into(),
    ];
    match noise_seed {
        Some(seed) => c.push(format!(
            "Measurement noise: Gaussian, seed {seed}, sigma: position 1e-3 L, heading 0.1 deg, u and v 2e-3 U0, r 5e-3 U0/L, rudder 0.05 deg."
        )),
        None => c.push("No measurement noise; accelerations are the model's.".into()),
    }
    c
}

/// One simulation of the reference (or of it in a recorded environment) under concealed `effects`.
fn simulate_plain<D: shipid_sim::Dynamics>(
    model: &D,
    effects: &[Effect],
    controller: &mut dyn shipid_sim::RudderController,
    options: &SimOptions,
) -> Result<shipid_sim::sim::SimOutput, PipelineError> {
    let ship = *model.ship();
    if effects.is_empty() {
        shipid_sim::simulate(model, controller, State::approach(ship.u0), options).map_err(failed)
    } else {
        simulate_with_effects(
            model,
            effects,
            controller,
            State::approach(ship.u0),
            options,
        )
        .map_err(|e| crate::error::bad_input(format!("--effect: {e}")))
    }
}

/// Standard deviations of the recorded environment's sensors (anemometer, current meter), applied with
/// `--noise`: speed in Froude-invariant terms as [`NoiseModel`], direction in degrees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AnemometerNoise {
    /// Wind speed noise ÷ U0.
    pub wind_speed_over_u0: f64,
    /// Wind direction noise [deg].
    pub wind_from_deg: f64,
    /// Current speed noise ÷ U0.
    pub current_speed_over_u0: f64,
    /// Current direction noise [deg].
    pub current_from_deg: f64,
}

impl AnemometerNoise {
    /// A cup or ultrasonic anemometer's few per cent of a model-scale wind of U0–3 U0 and a vane's
    /// 2°; a current meter's 1 mm/s at model scale and 5° (a weak current's direction is poorly
    /// measured).
    pub const TANK: AnemometerNoise = AnemometerNoise {
        wind_speed_over_u0: 0.02,
        wind_from_deg: 2.0,
        current_speed_over_u0: 1e-3,
        current_from_deg: 5.0,
    };

    /// Add the sensors' noise to the recorded channels of `rec` in place (speeds kept ≥ 0 by
    /// reflection: a sensor reads no negative speed), from a stream of `seed` and `stream`.
    pub fn apply(&self, rec: &mut Recording, ship: &Ship, seed: u64, stream: &str) {
        let mut rng = StdRng::seed_from_u64(seed ^ fnv1a(stream) ^ fnv1a("anemometer"));
        for (flow, speed_sigma, from_sigma_deg) in [
            (
                &mut rec.wind,
                self.wind_speed_over_u0 * ship.u0,
                self.wind_from_deg,
            ),
            (
                &mut rec.current,
                self.current_speed_over_u0 * ship.u0,
                self.current_from_deg,
            ),
        ] {
            let Some(f) = flow else { continue };
            if let (Ok(ns), Ok(nd)) = (
                Normal::new(0.0, speed_sigma),
                Normal::new(0.0, from_sigma_deg.to_radians()),
            ) {
                for (s, d) in f.speed_m_s.iter_mut().zip(f.from_rad.iter_mut()) {
                    *s = (*s + ns.sample(&mut rng)).abs();
                    *d = (*d + nd.sample(&mut rng)).rem_euclid(std::f64::consts::TAU);
                }
            }
        }
    }
}

/// A recorded wind whose mean varies between runs (`--recorded-wind`). Each run (stream: its file
/// name) draws its mean speed uniformly in `mean ± spread` and its direction uniformly in
/// `from ± from_spread` (any direction when `from` is not given), seeded by `seed`.
///
/// The gust, when `gust_intensity` > 0, is a first-order Gauss–Markov process g on the speed,
/// V(t) = V̄ (1 + I g(t)), with unit variance and correlation time T (`gust_time`):
/// g_{k+1} = a g_k + √(1 − a²) ξ_k, a = exp(−Δt/T), exact at the sampling interval. Chosen over a
/// Davenport or Harris spectrum because its spectrum is their low-frequency part with the same integral
/// time scale, which is all a ship with manoeuvring time constants of L/U0 responds to, and because
/// it is exact sample by sample from a seed without synthesising a spectrum.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RecordedWind {
    /// Mean of the runs' mean speeds [m/s] (> 0).
    pub mean_m_s: f64,
    /// Half-width of the runs' mean speeds [m/s] (0 ≤ spread < mean: no run is calm).
    pub spread_m_s: f64,
    /// Mean direction the wind comes from [deg]; `None`: any direction.
    pub from_deg: Option<f64>,
    /// Half-width of the runs' directions around `from_deg` [deg], 0–180.
    pub from_spread_deg: f64,
    /// Seed of the runs' draws and gusts.
    pub seed: u64,
    /// Turbulence intensity I = σ_V / V̄ of the gust [-], 0–0.5.
    pub gust_intensity: f64,
    /// Correlation time T of the gust [s], > 0.
    pub gust_time_s: f64,
}

/// A recorded current, the same in every run (`--recorded-current`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RecordedCurrent {
    /// Speed [m/s], ≥ 0.
    pub speed_m_s: f64,
    /// Direction it comes from [deg], earth-fixed, clockwise from north.
    pub from_deg: f64,
}

/// What `generate` writes as recorded channels, and the windage of the data set.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedEnvironment {
    pub wind: Option<RecordedWind>,
    pub current: Option<RecordedCurrent>,
    /// The windage the ship feels the wind through, written as the data set's `[windage]`.
    pub windage: Windage,
}

/// The fastest wind [m/s] `--recorded-wind` accepts: above hurricane force (33 m/s) at full scale, and
/// some 25 U0 of the KVLCC2 model, beyond any trial.
pub const MAX_RECORDED_WIND_M_S: f64 = 40.0;

/// The fastest current [m/s] `--recorded-current` accepts: a current of half the KVLCC2 model's speed
/// is already beyond any tank or trial, and this is four times U0.
pub const MAX_RECORDED_CURRENT_M_S: f64 = 5.0;

/// `key=value,…` of `option` into (key, value) pairs, each key once and from `known`.
fn key_values(
    option: &str,
    spec: &str,
    known: &[&str],
) -> Result<Vec<(String, f64)>, PipelineError> {
    let mut out: Vec<(String, f64)> = Vec::new();
    for item in spec.split(',').map(str::trim).filter(|i| !i.is_empty()) {
        let Some((k, v)) = item.split_once('=') else {
            return Err(crate::error::bad_input(format!(
                "{option}: expected key=value, got `{item}` (keys: {})",
                known.join(", ")
            )));
        };
        let k = k.trim();
        if !known.contains(&k) {
            return Err(crate::error::bad_input(format!(
                "{option}: unknown key `{k}` (keys: {})",
                known.join(", ")
            )));
        }
        let v: f64 = v.trim().parse().map_err(|_| {
            crate::error::bad_input(format!(
                "{option}: `{k}` must be a number, not `{}`",
                v.trim()
            ))
        })?;
        if !v.is_finite() {
            return Err(crate::error::bad_input(format!(
                "{option}: `{k}` must be finite, not {v}"
            )));
        }
        if out.iter().any(|(o, _)| o == k) {
            return Err(crate::error::bad_input(format!(
                "{option}: `{k}` given twice"
            )));
        }
        out.push((k.to_string(), v));
    }
    Ok(out)
}

fn out_of_range(option: &str, key: &str, v: f64, why: &str) -> PipelineError {
    crate::error::bad_input(format!("{option}: `{key}` = {v} {why}"))
}

impl std::str::FromStr for RecordedWind {
    type Err = PipelineError;

    /// `mean=3,spread=1.5,from=120,from_spread=45,seed=7,gust=0.15,gust_time=2` (`mean` required;
    /// defaults: spread 0, any direction, seed 0, no gust, gust time 2 s).
    fn from_str(spec: &str) -> Result<RecordedWind, PipelineError> {
        const O: &str = "--recorded-wind";
        let kv = key_values(
            O,
            spec,
            &[
                "mean",
                "spread",
                "from",
                "from_spread",
                "seed",
                "gust",
                "gust_time",
            ],
        )?;
        let get = |k: &str| kv.iter().find(|(o, _)| o == k).map(|(_, v)| *v);
        let mean = get("mean").ok_or_else(|| {
            crate::error::bad_input(format!(
                "{O}: `mean` (the mean wind speed [m/s]) is required"
            ))
        })?;
        let spread = get("spread").unwrap_or(0.0);
        if !(mean > 0.0 && mean <= MAX_RECORDED_WIND_M_S) {
            return Err(out_of_range(
                O,
                "mean",
                mean,
                &format!("must lie in (0, {MAX_RECORDED_WIND_M_S}] m/s"),
            ));
        }
        if !(spread >= 0.0 && spread < mean && mean + spread <= MAX_RECORDED_WIND_M_S) {
            return Err(out_of_range(
                O,
                "spread",
                spread,
                &format!(
                    "must lie in [0, mean) so that no run is calm, with mean + spread ≤ {MAX_RECORDED_WIND_M_S} m/s"
                ),
            ));
        }
        let from_spread =
            get("from_spread").unwrap_or(if get("from").is_some() { 0.0 } else { 180.0 });
        if !(0.0..=180.0).contains(&from_spread) {
            return Err(out_of_range(
                O,
                "from_spread",
                from_spread,
                "must lie in [0, 180] deg",
            ));
        }
        let seed = get("seed").unwrap_or(0.0);
        if !(seed >= 0.0 && seed.fract() == 0.0 && seed < 2f64.powi(53)) {
            return Err(out_of_range(O, "seed", seed, "must be a whole number ≥ 0"));
        }
        let gust = get("gust").unwrap_or(0.0);
        if !(0.0..=0.5).contains(&gust) {
            return Err(out_of_range(
                O,
                "gust",
                gust,
                "(turbulence intensity σ_V / V̄) must lie in [0, 0.5]",
            ));
        }
        let gust_time = get("gust_time").unwrap_or(2.0);
        if !(gust_time > 0.0 && gust_time <= 3600.0) {
            return Err(out_of_range(
                O,
                "gust_time",
                gust_time,
                "must lie in (0, 3600] s",
            ));
        }
        Ok(RecordedWind {
            mean_m_s: mean,
            spread_m_s: spread,
            from_deg: get("from"),
            from_spread_deg: from_spread,
            seed: seed as u64,
            gust_intensity: gust,
            gust_time_s: gust_time,
        })
    }
}

impl std::str::FromStr for RecordedCurrent {
    type Err = PipelineError;

    /// `speed=0.02,from=120` (both required).
    fn from_str(spec: &str) -> Result<RecordedCurrent, PipelineError> {
        const O: &str = "--recorded-current";
        let kv = key_values(O, spec, &["speed", "from"])?;
        let get = |k: &str| {
            kv.iter()
                .find(|(o, _)| o == k)
                .map(|(_, v)| *v)
                .ok_or_else(|| {
                    crate::error::bad_input(format!(
                        "{O}: `{k}` is required (speed [m/s], from [deg])"
                    ))
                })
        };
        let (speed, from) = (get("speed")?, get("from")?);
        if !(0.0..=MAX_RECORDED_CURRENT_M_S).contains(&speed) {
            return Err(out_of_range(
                O,
                "speed",
                speed,
                &format!("must lie in [0, {MAX_RECORDED_CURRENT_M_S}] m/s"),
            ));
        }
        Ok(RecordedCurrent {
            speed_m_s: speed,
            from_deg: from,
        })
    }
}

impl RecordedWind {
    /// The mean speed [m/s] and direction it comes from [deg] of the run `stream`.
    pub fn run(&self, stream: &str) -> (f64, f64) {
        let mut rng = StdRng::seed_from_u64(self.seed ^ fnv1a(stream));
        let u = |rng: &mut StdRng| rand::Rng::random::<f64>(rng);
        let speed = self.mean_m_s + self.spread_m_s * (2.0 * u(&mut rng) - 1.0);
        let from = match self.from_deg {
            Some(f) => f + self.from_spread_deg * (2.0 * u(&mut rng) - 1.0),
            None => 360.0 * u(&mut rng),
        };
        (speed, from.rem_euclid(360.0))
    }

    /// The run `stream`'s wind at the times `t_s` (equally spaced): its mean with the gust.
    pub fn series(&self, t_s: &[f64], stream: &str) -> FlowSeries {
        let (mean, from_deg) = self.run(stream);
        let mut speed = vec![mean; t_s.len()];
        if self.gust_intensity > 0.0 && t_s.len() > 1 {
            let mut rng = StdRng::seed_from_u64(self.seed ^ fnv1a(stream) ^ fnv1a("gust"));
            let a = (-(t_s[1] - t_s[0]) / self.gust_time_s).exp();
            let b = (1.0 - a * a).sqrt();
            let normal = Normal::new(0.0, 1.0).expect("unit normal");
            let mut g: f64 = normal.sample(&mut rng);
            for s in speed.iter_mut() {
                *s = (mean * (1.0 + self.gust_intensity * g)).max(0.0);
                g = a * g + b * normal.sample(&mut rng);
            }
        }
        FlowSeries {
            speed_m_s: speed,
            from_rad: vec![from_deg.to_radians(); t_s.len()],
        }
    }
}

impl RecordedEnvironment {
    /// The environment of the run `file` lasting `duration_s`: a template recording on the output
    /// grid carrying its series (noise-free), and the known environment built from it.
    fn flows(
        &self,
        file: &str,
        duration_s: f64,
        ship: &Ship,
    ) -> Result<(Recording, KnownEnvironment), PipelineError> {
        // One sample past the end: the simulation's last output sample is inside the template.
        let n = (duration_s / SAMPLE_INTERVAL_S).ceil() as usize + 2;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * SAMPLE_INTERVAL_S).collect();
        let template = Recording {
            wind: self.wind.map(|w| w.series(&t, file)),
            current: self.current.map(|c| FlowSeries {
                speed_m_s: vec![c.speed_m_s; n],
                from_rad: vec![c.from_deg.to_radians().rem_euclid(std::f64::consts::TAU); n],
            }),
            t,
            ..Recording::default()
        };
        let env = KnownEnvironment::of_recording(&template, Some(&self.windage), ship)
            .map_err(|e| crate::error::bad_input(format!("[windage]: {e}")))?
            .ok_or_else(|| failed("a recorded environment without wind or current"))?;
        Ok((template, env))
    }
}

/// The windage `generate` writes by default: [`assumed_windage`] of the KVLCC2 model, with its source.
pub fn default_windage() -> Windage {
    Windage {
        source: Some(
            "shipid generate: the windage the simulated KVLCC2 model felt its wind through — hull above water of the loaded tanker (freeboard 0.44 × draft, no superstructure), Fossen (2011) coefficients"
                .into(),
        ),
        ..assumed_windage(&kvlcc2_ship())
    }
}

/// The comment line that says how the wind channels were written (`--wind-channels`): nothing for
/// the true wind, which [`recorded_provenance`] describes; a bad-input error for relative channels
/// without a recorded wind (nothing would be written as asked).
pub fn wind_channels_provenance(
    recorded: Option<&RecordedEnvironment>,
    channels: WindChannels,
) -> Result<Option<String>, PipelineError> {
    let has_wind = recorded.is_some_and(|env| env.wind.is_some());
    match channels {
        WindChannels::True => Ok(None),
        WindChannels::Relative if !has_wind => Err(crate::error::bad_input(
            "--wind-channels relative needs --recorded-wind: without a recorded wind there are no wind channels to write",
        )),
        WindChannels::Relative => Ok(Some(
            "The wind is written as measured on board: relative_wind_speed [m/s] and relative_wind_angle [rad] (off the bow it comes from, positive from starboard), computed from the recorded true wind with each sample's psi, u, v; reading them back gives the true wind above (docs/data-format.md).".into(),
        )),
    }
}

/// The comment lines that describe a recorded environment (after [`provenance`]).
pub fn recorded_provenance(env: &RecordedEnvironment) -> Vec<String> {
    let mut c = Vec::new();
    if let Some(w) = env.wind {
        c.push(format!(
            "Recorded wind (wind_speed [m/s], wind_from [rad], from where it comes, clockwise from north): per-run mean speed {} ± {} m/s, direction {}, seed {}{}; the ship felt the noise-free series through [windage] of dataset.toml.",
            w.mean_m_s,
            w.spread_m_s,
            match w.from_deg {
                Some(f) => format!("{f} ± {} deg", w.from_spread_deg),
                None => "any".into(),
            },
            w.seed,
            if w.gust_intensity > 0.0 {
                format!(
                    ", gust: first-order Gauss-Markov, intensity {}, correlation time {} s",
                    w.gust_intensity, w.gust_time_s
                )
            } else {
                String::new()
            }
        ));
    }
    if let Some(cur) = env.current {
        c.push(format!(
            "Recorded current (current_speed [m/s], current_from [rad], from where it comes): {} m/s from {} deg.",
            cur.speed_m_s, cur.from_deg
        ));
    }
    c.push(
        "With --noise: anemometer noise 0.02 U0 and 2 deg, current meter 1e-3 U0 and 5 deg.".into(),
    );
    c
}
