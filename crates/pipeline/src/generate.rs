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
//! # Noise model (`--noise SEED`)
//! Independent zero-mean Gaussian white noise on every recorded channel, with standard deviations fixed
//! in Froude-invariant terms so that the same seed gives the same primed noise at any scale
//! ([`NoiseModel::TANK`]). Accelerations are not written for noisy data (a tank does not measure them;
//! they are estimated from the velocities like any recording's). Every recording draws from its own
//! stream, seeded from SEED and the file name, so the set is reproducible.

use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, Normal};
use shipid_io::dataset::{DatasetFile, Origin, entry_for};
use shipid_io::{Manoeuvre, Recording, Ship, Side};
use shipid_sim::effects::{Effect, simulate_with_effects};
use shipid_sim::{
    MmgModel, SimOptions, SimStatus, State, controller_for, kvlcc2_added_mass, kvlcc2_ship,
};

use crate::error::{PipelineError, failed};
use crate::spec::manoeuvre_stem;

/// Steady approach before the first rudder execute [s].
pub const T_EXECUTE_S: f64 = 5.0;
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
    T_EXECUTE_S + units * l_over_u0
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

/// Parse `--effect` arguments (`current:speed=0.05,from=120`, …).
pub fn parse_effects(args: &[String]) -> Result<Vec<Effect>, PipelineError> {
    args.iter()
        .map(|a| {
            a.parse::<Effect>()
                .map_err(|e| crate::error::bad_input(format!("--effect `{a}`: {e}")))
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
    let model = MmgModel::kvlcc2();
    let ship = kvlcc2_ship();
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
        let mut controller = controller_for(&m, T_EXECUTE_S).map_err(failed)?;
        let options =
            SimOptions::new(standard_duration_s(&m, &ship)).with_step(DT_S, SAMPLE_INTERVAL_S);
        let out = if effects.is_empty() {
            shipid_sim::simulate(
                &model,
                controller.as_mut(),
                State::approach(ship.u0),
                &options,
            )
            .map_err(failed)?
        } else {
            simulate_with_effects(
                &model,
                effects,
                controller.as_mut(),
                State::approach(ship.u0),
                &options,
            )
            .map_err(|e| crate::error::bad_input(format!("--effect: {e}")))?
        };
        if let SimStatus::Diverged { t_s, reason } = out.status {
            return Err(failed(format!(
                "the MMG reference diverged in {file} at {t_s} s: {reason}"
            )));
        }
        let mut rec = out.recording;
        if let Some(seed) = noise_seed {
            NoiseModel::TANK.apply(&mut rec, &ship, seed, &file);
        }
        entries.push(entry_for(&file, &m));
        recordings.push(rec);
    }
    let reference = shipid_sim::MmgParameters::kvlcc2();
    let dataset = DatasetFile {
        name: "KVLCC2 model, deep water: MMG reference simulation".into(),
        origin: Origin::Midship,
        rudder_sign: 1,
        ship,
        added_mass: Some(kvlcc2_added_mass()),
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
        windage: None,
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
