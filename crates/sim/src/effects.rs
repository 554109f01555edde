//! Physical effects that a manoeuvring model leaves out (the effects vocabulary of the diagnosis and
//! result files, `docs/data-format.md`), applied around any [`Dynamics`] without changing the simulation
//! loop:
//!
//! - [`WithEffects`] wraps a model and is itself a [`Dynamics`]: it converts the over-ground state to the
//!   water-relative one the hydrodynamics see (current), adds external forces (wind, asymmetry, shallow
//!   water) through the model's mass matrix, and adds the transport terms of the current.
//! - [`EffectRudder`] is a [`RudderFilter`]: the recorded rudder → the rudder acting on the hull (lag,
//!   delay, neutral offset).
//! - [`simulate_with_effects`] combines both with [`simulate_filtered`].
//!
//! Effects parse from strings such as `current:speed=0.05,from=120`, `rudder_lag:tau=1.5,delay=0.3`,
//! `wind:speed=5,from=90`, `asymmetry:offset=1.0`, `shallow_water:h_over_t=1.5` ([`Effect::from_str`]).

use std::collections::VecDeque;
use std::fmt;
use std::str::FromStr;

use shipid_io::{AddedMass, Ship, WindModel, Windage};
use thiserror::Error;

use crate::control::RudderController;
use crate::dynamics::{
    Dynamics, DynamicsError, Input, LinearHullDerivatives, MassMatrix, RudderFilter, State,
};
use crate::environment::{Aerodynamics, EnvironmentError};
use crate::sim::{SimError, SimOptions, SimOutput, simulate_filtered};

/// Density of air [kg/m³] (ISA sea level, 15 °C).
pub const AIR_DENSITY_KG_M3: f64 = 1.225;

/// Steady uniform current. Positions and velocities of the simulation are over ground; the hydrodynamic
/// model sees the velocities relative to the water. For a uniform, steady (irrotational) current the
/// rigid-body equations hold in the water-relative velocities (e.g. Fossen 2011, *Handbook of Marine
/// Craft Hydrodynamics and Motion Control*, §10.3), so the body-axis over-ground accelerations are the
/// model's plus the rotation of the current in body axes: u̇ += r v_c, v̇ −= r u_c.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Current {
    /// Current speed [m/s], ≥ 0.
    pub speed_m_s: f64,
    /// Direction the current comes from [deg], earth-fixed, clockwise from north (0 = from north,
    /// flowing south; 90 = from east).
    pub from_deg: f64,
}

impl Current {
    /// Current velocity [north, east] [m/s].
    pub fn velocity_earth(&self) -> [f64; 2] {
        let (s, c) = self.from_deg.to_radians().sin_cos();
        [-self.speed_m_s * c, -self.speed_m_s * s]
    }
}

/// Aerodynamic coefficients of [`Wind`] without a windage table: the simple model of Fossen (2011,
/// §8.1, "wind forces and moments"), the same constants as [`crate::environment::FOSSEN_COEFFICIENTS`].
pub const WIND_COEFFICIENTS: [f64; 3] = crate::environment::FOSSEN_COEFFICIENTS;

/// Freeboard ÷ draft of loaded KVLCC2: depth 30.0 m, design draft 20.8 m (SIMMAN 2008 KVLCC2 particulars).
/// Used for the default windage areas of the hull above water (no deckhouse).
pub const KVLCC2_FREEBOARD_OVER_DRAFT: f64 = (30.0 - 20.8) / 20.8;

/// Steady uniform wind with the forces of the ship's windage ([`Aerodynamics::force`]): X = ½ρ_a V² A_F
/// C_X, Y = ½ρ_a V² A_L C_Y, N = ½ρ_a V² A_L L C_N + x_L Y, V the wind speed relative to the ship's
/// over-ground velocity. Without a windage table: Fossen's coefficients ([`WIND_COEFFICIENTS`]) on the
/// areas [`Wind::areas_m2`], acting about midship; the yaw moment then turns the bow away from a wind
/// forward of the beam and towards one abaft it.
#[derive(Debug, Clone, PartialEq)]
pub struct Wind {
    /// True wind speed [m/s], ≥ 0 (model scale: full-scale speed ÷ √45.714 for KVLCC2).
    pub speed_m_s: f64,
    /// Direction the wind comes from [deg], earth-fixed, clockwise from north.
    pub from_deg: f64,
    /// Frontal windage area A_F [m²]; `None`: the windage's, else beam × freeboard with the freeboard
    /// of loaded KVLCC2 ([`KVLCC2_FREEBOARD_OVER_DRAFT`] × draft), 0.26 m² for the KVLCC2 model.
    pub frontal_area_m2: Option<f64>,
    /// Lateral windage area A_L [m²]; `None`: the windage's, else L × freeboard as above, 1.42 m² for
    /// the KVLCC2 model.
    pub lateral_area_m2: Option<f64>,
    /// The ship's windage (a data set's `[windage]`: areas, lateral centre, wind-coefficient model,
    /// air density); `None`: Fossen on the areas above. Not part of the effect's string form: whoever
    /// builds the effect for a data set sets it (the areas `af`, `al` still override its areas).
    pub windage: Option<Windage>,
}

impl Wind {
    /// Windage areas [A_F, A_L] [m²] for `ship`.
    pub fn areas_m2(&self, ship: &Ship) -> [f64; 2] {
        let freeboard = KVLCC2_FREEBOARD_OVER_DRAFT * ship.draft;
        let (af, al) = match &self.windage {
            Some(w) => (w.frontal_area_m2, w.lateral_area_m2),
            None => (ship.beam * freeboard, ship.lpp * freeboard),
        };
        [
            self.frontal_area_m2.unwrap_or(af),
            self.lateral_area_m2.unwrap_or(al),
        ]
    }

    /// The windage this wind acts on: [`Wind::windage`] (or Fossen's model at sea-level air density,
    /// centred at midship) with the areas of [`Wind::areas_m2`].
    pub fn windage_for(&self, ship: &Ship) -> Windage {
        let [af, al] = self.areas_m2(ship);
        let base = self.windage.clone().unwrap_or(Windage {
            frontal_area_m2: af,
            lateral_area_m2: al,
            lateral_centre_x_m: 0.0,
            model: WindModel::Fossen,
            air_density_kg_m3: AIR_DENSITY_KG_M3,
            length_overall_m: None,
            superstructure_lateral_area_m2: None,
            lateral_centre_height_m: None,
            height_m: None,
            lateral_perimeter_m: None,
            mast_groups: None,
            source: None,
        });
        Windage {
            frontal_area_m2: af,
            lateral_area_m2: al,
            ..base
        }
    }

    /// The force model of this wind on `ship` (refused when the windage lacks what its model needs).
    pub fn aerodynamics(&self, ship: &Ship) -> Result<Aerodynamics, EnvironmentError> {
        Aerodynamics::new(&self.windage_for(ship), ship)
    }

    /// Aerodynamic [X, Y, N] [N, N, N m] on a ship in over-ground state `s`, through `aero` (built once
    /// by [`Wind::aerodynamics`]).
    pub fn force_with(&self, aero: &Aerodynamics, s: &State) -> [f64; 3] {
        let (sf, cf) = self.from_deg.to_radians().sin_cos();
        let (wn, we) = (-self.speed_m_s * cf, -self.speed_m_s * sf);
        let (sp, cp) = s.psi.sin_cos();
        // Air velocity relative to the ship, body axes.
        aero.force([wn * cp + we * sp - s.u, -wn * sp + we * cp - s.v])
    }

    /// Aerodynamic [X, Y, N] [N, N, N m] on `ship` in over-ground state `s`.
    pub fn force(&self, ship: &Ship, s: &State) -> Result<[f64; 3], EnvironmentError> {
        Ok(self.force_with(&self.aerodynamics(ship)?, s))
    }
}

/// The rudder acting on the hull lags the recorded (or commanded-and-rate-limited) rudder: a pure delay
/// followed by a first-order lag, τ δ̇_a = δ(t − delay) − δ_a, integrated exactly for a rudder that is
/// piecewise linear between RK4 stages. Models a slow steering gear or a rudder sensor that leads the
/// blade.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RudderLag {
    /// Pure delay [s], ≥ 0.
    pub delay_s: f64,
    /// First-order time constant τ [s], ≥ 0.
    pub time_constant_s: f64,
}

/// Port–starboard bias: a rudder neutral offset (the blade is at `rudder_offset_deg` when the recorded
/// rudder is zero) and/or a constant side force and yaw moment, such as the single-screw propeller's
/// (the constant terms Y_0, N_0 of an asymmetric Abkowitz model).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Asymmetry {
    /// Rudder neutral offset [deg], added to the recorded rudder (positive to starboard).
    pub rudder_offset_deg: f64,
    /// Constant side force Y_0 [N], positive to starboard.
    pub y0_n: f64,
    /// Constant yaw moment N_0 [N m] about midship, positive to starboard.
    pub n0_nm: f64,
}

/// Finite water depth: larger sway and yaw hull damping and added masses than in deep water.
///
/// The hull, seen as a lifting surface of low aspect ratio k = 2d/L, has its effective aspect ratio
/// raised by the sea bed acting as a reflection plane. Kijima-type shallow-water corrections write this as
/// k_e/k = 1 / (d/2h + ((πd/2h) cot(πd/2h))^q), which is 1 in deep water and 2 when the keel touches the
/// bottom (form and exponents as given by Tang et al. 2020, Ocean Eng. 196:106679). This effect uses a
/// single factor f = k_e/k with q = 2.3 (their exponent for Y'_v): f = 1.04 at h/T = 3, 1.21 at 2,
/// 1.54 at 1.5, 1.98 at 1.2. It multiplies all four linear hull derivatives Y'_v, Y'_r, N'_v, N'_r (the
/// model's own, [`Dynamics::linear_hull_derivatives`], or else [`clarke_linear_derivatives`]) and the sway
/// added mass m_y and yaw added inertia J_z; the increments act as extra forces and inertia on top of the
/// wrapped model, whose nonlinear terms, added-mass Coriolis terms and surge stay as in deep water.
///
/// This is a deliberately simple stand-in, our reconstruction rather than a validated shallow-water
/// model: one factor grows damping and inertia together and keeps the model's balance between sway and
/// yaw, so that course stability rises as observed in shallow water (for MMG KVLCC2 at h/T = 1.5:
/// tactical diameter 3.12 L → 3.56 L, 20/20 overshoots 10.5°/15.6° → 8.1°/13.1°). Applying the source's
/// separate exponents per derivative (0.7 for Y'_r and N'_r, 1.7 for N'_v) to the MMG KVLCC2
/// derivatives made the ship less stable, against the observed trend, so they are not used.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShallowWater {
    /// Water depth ÷ draft h/T [-], > 1.
    pub depth_over_draft: f64,
    /// Growth factor of the yaw derivatives Y'_r, N'_r and of J_z when it differs from the sway factor
    /// f(h/T) (shallow-water corrections grow sway and yaw terms by different amounts, e.g. the
    /// exponents of Tang et al. 2020); `None`: the single factor for all. `shipid diagnose` fits both.
    pub yaw_factor: Option<f64>,
}

impl ShallowWater {
    /// The growth factor f(h/T) of damping and added mass ([`ShallowWater`] documents it).
    pub fn factor(&self) -> f64 {
        let h_over_d = self.depth_over_draft;
        let x = std::f64::consts::FRAC_PI_2 / h_over_d;
        let x_cot_x = x / x.tan();
        1.0 / (0.5 / h_over_d + x_cot_x.powf(2.3))
    }
}

/// Deep-water linear hull derivatives of `ship` from Clarke, Gedling & Hine (1983, Trans. RINA 125,
/// "The application of manoeuvring criteria in hull design using linear theory"), converted from their
/// ½ρL²U normalisation to the MMG one (× L/d):
/// Y'_v = −π(d/L)²(1 + 0.40 C_B B/d), Y'_r = −π(d/L)²(−1/2 + 2.2 B/L − 0.080 B/d),
/// N'_v = −π(d/L)²(1/2 + 2.4 d/L), N'_r = −π(d/L)²(1/4 + 0.039 B/d − 0.56 B/L).
/// For KVLCC2 they give −0.389, 0.067, −0.136, −0.053 against the MMG −0.315, 0.083, −0.137, −0.049.
pub fn clarke_linear_derivatives(ship: &Ship) -> LinearHullDerivatives {
    let (l, b, d) = (ship.lpp, ship.beam, ship.draft);
    let cb = ship.displacement / (l * b * d);
    let scale = -std::f64::consts::PI * (d / l) * (d / l) * (l / d);
    LinearHullDerivatives {
        y_v: scale * (1.0 + 0.40 * cb * b / d),
        y_r: scale * (-0.5 + 2.2 * b / l - 0.080 * b / d),
        n_v: scale * (0.5 + 2.4 * d / l),
        n_r: scale * (0.25 + 0.039 * b / d - 0.56 * b / l),
    }
}

/// One physical effect (its vocabulary word, [`Effect::kind`], in brackets).
#[derive(Debug, Clone, PartialEq)]
pub enum Effect {
    /// `current`.
    Current(Current),
    /// `wind`.
    Wind(Wind),
    /// `rudder_lag`.
    RudderLag(RudderLag),
    /// `asymmetry`.
    Asymmetry(Asymmetry),
    /// `shallow_water`.
    ShallowWater(ShallowWater),
}

/// An effect with invalid parameters, or an invalid combination.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum EffectError {
    /// A parameter is out of its physical range.
    #[error("{effect}: invalid {key} = {}: {reason}", shipid_io::error::number(*value))]
    InvalidParameter {
        effect: &'static str,
        key: &'static str,
        value: f64,
        reason: &'static str,
    },
    /// The same kind of effect was given twice.
    #[error("effect {0} given more than once")]
    Duplicate(&'static str),
    /// The wind's windage cannot be used with its wind-coefficient model.
    #[error("wind: {0}")]
    Windage(#[from] EnvironmentError),
    /// The simulation input is invalid.
    #[error(transparent)]
    Sim(#[from] SimError),
}

/// Why an effect string could not be parsed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum EffectParseError {
    /// The name before the colon is not an effect.
    #[error("unknown effect {0:?}; known: current, wind, rudder_lag, asymmetry, shallow_water")]
    UnknownEffect(String),
    /// A key is not a parameter of the effect.
    #[error("{effect}: unknown key {key:?}; known: {known}")]
    UnknownKey {
        effect: &'static str,
        key: String,
        known: &'static str,
    },
    /// A required key is absent.
    #[error("{effect}: missing key {key:?}")]
    MissingKey {
        effect: &'static str,
        key: &'static str,
    },
    /// A key appears twice.
    #[error("{effect}: key {key:?} given twice")]
    DuplicateKey { effect: &'static str, key: String },
    /// A value is not a number.
    #[error("{effect}: value of {key:?} is not a number: {value:?}")]
    NotANumber {
        effect: &'static str,
        key: String,
        value: String,
    },
    /// An item is not `key=value`.
    #[error("{effect}: expected key=value, got {item:?}")]
    Syntax { effect: &'static str, item: String },
    /// The values parse but are out of range.
    #[error(transparent)]
    Invalid(#[from] EffectError),
}

/// The largest |direction| [deg] an effect's `from_deg` may have. A direction past a full turn is
/// no direction anyone writes: `from_deg=1e300` came from a damaged number, and its sine and cosine
/// are rounding noise, so it is refused rather than wrapped into some angle.
pub const MAX_FROM_DEG: f64 = 360.0;

const FROM_DEG_REASON: &str =
    "must be a direction within ±360° [deg], clockwise from north, where the flow comes from";

fn check(
    effect: &'static str,
    key: &'static str,
    value: f64,
    ok: bool,
    reason: &'static str,
) -> Result<(), EffectError> {
    if ok && value.is_finite() {
        Ok(())
    } else {
        Err(EffectError::InvalidParameter {
            effect,
            key,
            value,
            reason,
        })
    }
}

impl Effect {
    /// The vocabulary word: `current`, `wind`, `rudder_lag`, `asymmetry` or `shallow_water`.
    pub fn kind(&self) -> &'static str {
        match self {
            Effect::Current(_) => "current",
            Effect::Wind(_) => "wind",
            Effect::RudderLag(_) => "rudder_lag",
            Effect::Asymmetry(_) => "asymmetry",
            Effect::ShallowWater(_) => "shallow_water",
        }
    }

    /// Parameters as `(key, value)` with the keys [`Effect::from_str`] reads (for reports; the direction
    /// key is `from_deg` as in the diagnosis file, `from` is accepted when parsing).
    pub fn parameters(&self) -> Vec<(&'static str, f64)> {
        match self {
            Effect::Current(c) => vec![("speed", c.speed_m_s), ("from_deg", c.from_deg)],
            Effect::Wind(w) => {
                let mut p = vec![("speed", w.speed_m_s), ("from_deg", w.from_deg)];
                p.extend(w.frontal_area_m2.map(|a| ("af", a)));
                p.extend(w.lateral_area_m2.map(|a| ("al", a)));
                p
            }
            Effect::RudderLag(l) => vec![("tau", l.time_constant_s), ("delay", l.delay_s)],
            Effect::Asymmetry(a) => vec![
                ("offset", a.rudder_offset_deg),
                ("y0", a.y0_n),
                ("n0", a.n0_nm),
            ],
            Effect::ShallowWater(s) => {
                let mut p = vec![("h_over_t", s.depth_over_draft)];
                p.extend(s.yaw_factor.map(|f| ("f_yaw", f)));
                p
            }
        }
    }

    /// The unit of parameter `key` of [`Effect::parameters`] ("" for a ratio).
    pub fn parameter_unit(key: &str) -> &'static str {
        match key {
            "speed" => "m/s",
            "from_deg" | "offset" => "deg",
            "af" | "al" => "m²",
            "tau" | "delay" => "s",
            "y0" => "N",
            "n0" => "N m",
            _ => "",
        }
    }

    /// Checks the parameters' ranges.
    pub fn validate(&self) -> Result<(), EffectError> {
        let e = self.kind();
        match self {
            Effect::Current(c) => {
                check(
                    e,
                    "speed",
                    c.speed_m_s,
                    c.speed_m_s >= 0.0,
                    "must be a non-negative speed [m/s]",
                )?;
                check(
                    e,
                    "from_deg",
                    c.from_deg,
                    c.from_deg.abs() <= MAX_FROM_DEG,
                    FROM_DEG_REASON,
                )
            }
            Effect::Wind(w) => {
                check(
                    e,
                    "speed",
                    w.speed_m_s,
                    w.speed_m_s >= 0.0,
                    "must be a non-negative speed [m/s]",
                )?;
                check(
                    e,
                    "from_deg",
                    w.from_deg,
                    w.from_deg.abs() <= MAX_FROM_DEG,
                    FROM_DEG_REASON,
                )?;
                for (key, a) in [("af", w.frontal_area_m2), ("al", w.lateral_area_m2)] {
                    if let Some(a) = a {
                        check(e, key, a, a >= 0.0, "must be a non-negative area [m²]")?;
                    }
                }
                Ok(())
            }
            Effect::RudderLag(l) => {
                check(
                    e,
                    "delay",
                    l.delay_s,
                    l.delay_s >= 0.0,
                    "must be a non-negative time [s]",
                )?;
                check(
                    e,
                    "tau",
                    l.time_constant_s,
                    l.time_constant_s >= 0.0,
                    "must be a non-negative time [s]",
                )
            }
            Effect::Asymmetry(a) => {
                check(
                    e,
                    "offset",
                    a.rudder_offset_deg,
                    a.rudder_offset_deg.abs() <= 45.0,
                    "must be within ±45° [deg]",
                )?;
                check(e, "y0", a.y0_n, true, "must be finite [N]")?;
                check(e, "n0", a.n0_nm, true, "must be finite [N m]")
            }
            Effect::ShallowWater(s) => {
                check(
                    e,
                    "h_over_t",
                    s.depth_over_draft,
                    s.depth_over_draft > 1.0,
                    "depth must exceed the draft (h/T > 1)",
                )?;
                match s.yaw_factor {
                    Some(f) => check(
                        e,
                        "f_yaw",
                        f,
                        (0.5..=5.0).contains(&f),
                        "must be a growth factor between 0.5 and 5",
                    ),
                    None => Ok(()),
                }
            }
        }
    }
}

/// Keys of each effect: (canonical key, aliases, required).
fn keys(effect: &'static str) -> &'static [(&'static str, &'static [&'static str], bool)] {
    match effect {
        "current" => &[
            ("speed", &["speed_m_s"], true),
            ("from_deg", &["from"], true),
        ],
        "wind" => &[
            ("speed", &["speed_m_s"], true),
            ("from_deg", &["from"], true),
            ("af", &["frontal_area_m2"], false),
            ("al", &["lateral_area_m2"], false),
        ],
        "rudder_lag" => &[
            ("tau", &["time_constant_s"], false),
            ("delay", &["delay_s"], false),
        ],
        "asymmetry" => &[
            ("offset", &["rudder_offset_deg"], false),
            ("y0", &["y0_n"], false),
            ("n0", &["n0_nm"], false),
        ],
        "shallow_water" => &[
            ("h_over_t", &["depth_over_draft"], true),
            ("f_yaw", &["yaw_factor"], false),
        ],
        _ => &[],
    }
}

fn known_keys(effect: &'static str) -> &'static str {
    match effect {
        "current" => "speed, from (or from_deg)",
        "wind" => "speed, from (or from_deg), af, al",
        "rudder_lag" => "tau, delay",
        "asymmetry" => "offset, y0, n0",
        _ => "h_over_t, f_yaw",
    }
}

impl FromStr for Effect {
    type Err = EffectParseError;

    /// `name[:key=value[,key=value…]]` with the keys of [`Effect::parameters`] (long aliases such as
    /// `from_deg` or `time_constant_s` are accepted). Optional keys default to 0 (`rudder_lag`,
    /// `asymmetry`) or to the documented default (`wind` areas).
    fn from_str(s: &str) -> Result<Effect, EffectParseError> {
        let (name, rest) = s.trim().split_once(':').unwrap_or((s.trim(), ""));
        let effect: &'static str = match name.trim() {
            "current" => "current",
            "wind" => "wind",
            "rudder_lag" => "rudder_lag",
            "asymmetry" => "asymmetry",
            "shallow_water" => "shallow_water",
            other => return Err(EffectParseError::UnknownEffect(other.to_string())),
        };
        let table = keys(effect);
        let mut values: Vec<Option<f64>> = vec![None; table.len()];
        for item in rest.split(',').map(str::trim).filter(|i| !i.is_empty()) {
            let Some((key, value)) = item.split_once('=') else {
                return Err(EffectParseError::Syntax {
                    effect,
                    item: item.to_string(),
                });
            };
            let key = key.trim();
            let Some(slot) = table
                .iter()
                .position(|(k, aliases, _)| *k == key || aliases.contains(&key))
            else {
                return Err(EffectParseError::UnknownKey {
                    effect,
                    key: key.to_string(),
                    known: known_keys(effect),
                });
            };
            let v: f64 = value
                .trim()
                .parse()
                .map_err(|_| EffectParseError::NotANumber {
                    effect,
                    key: key.to_string(),
                    value: value.trim().to_string(),
                })?;
            if values[slot].replace(v).is_some() {
                return Err(EffectParseError::DuplicateKey {
                    effect,
                    key: key.to_string(),
                });
            }
        }
        for (i, (key, _, required)) in table.iter().enumerate() {
            if *required && values[i].is_none() {
                return Err(EffectParseError::MissingKey { effect, key });
            }
        }
        let get = |i: usize| values[i].unwrap_or(0.0);
        let parsed = match effect {
            "current" => Effect::Current(Current {
                speed_m_s: get(0),
                from_deg: get(1),
            }),
            "wind" => Effect::Wind(Wind {
                speed_m_s: get(0),
                from_deg: get(1),
                frontal_area_m2: values[2],
                lateral_area_m2: values[3],
                windage: None,
            }),
            "rudder_lag" => Effect::RudderLag(RudderLag {
                time_constant_s: get(0),
                delay_s: get(1),
            }),
            "asymmetry" => Effect::Asymmetry(Asymmetry {
                rudder_offset_deg: get(0),
                y0_n: get(1),
                n0_nm: get(2),
            }),
            _ => Effect::ShallowWater(ShallowWater {
                depth_over_draft: get(0),
                yaw_factor: values[1],
            }),
        };
        parsed.validate()?;
        Ok(parsed)
    }
}

impl fmt::Display for Effect {
    /// The canonical string form, which [`Effect::from_str`] reads back.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:", self.kind())?;
        for (i, (k, v)) in self.parameters().into_iter().enumerate() {
            if i > 0 {
                write!(f, ",")?;
            }
            write!(f, "{k}={v}")?;
        }
        Ok(())
    }
}

/// A model with effects around it (see the module docs). Its state is over ground.
#[derive(Debug, Clone)]
pub struct WithEffects<D> {
    inner: D,
    current: Option<[f64; 2]>,
    wind: Option<(Wind, Aerodynamics)>,
    constant_force: [f64; 3],
    /// Shallow-water growth factors [sway (Y'_v, N'_v, m_y), yaw (Y'_r, N'_r, J_z)] and the deep-water
    /// linear derivatives they scale.
    shallow: Option<([f64; 2], LinearHullDerivatives)>,
    mass: MassMatrix,
    mass_effective: MassMatrix,
    added_mass: AddedMass,
    rudder_offset_rad: f64,
    lag: Option<RudderLag>,
}

impl<D: Dynamics> WithEffects<D> {
    /// Wraps `inner` with `effects` (at most one of each kind).
    pub fn new(inner: D, effects: &[Effect]) -> Result<WithEffects<D>, EffectError> {
        for (i, e) in effects.iter().enumerate() {
            e.validate()?;
            if effects[..i].iter().any(|p| p.kind() == e.kind()) {
                return Err(EffectError::Duplicate(e.kind()));
            }
        }
        let ship = *inner.ship();
        let mass = MassMatrix::new(&ship, inner.added_mass());
        let mut w = WithEffects {
            current: None,
            wind: None,
            constant_force: [0.0; 3],
            shallow: None,
            mass,
            mass_effective: mass,
            added_mass: *inner.added_mass(),
            rudder_offset_rad: 0.0,
            lag: None,
            inner,
        };
        for e in effects {
            match e {
                Effect::Current(c) => w.current = Some(c.velocity_earth()),
                Effect::Wind(wind) => w.wind = Some((wind.clone(), wind.aerodynamics(&ship)?)),
                Effect::RudderLag(l) => w.lag = Some(*l),
                Effect::Asymmetry(a) => {
                    w.rudder_offset_rad = a.rudder_offset_deg.to_radians();
                    w.constant_force = [0.0, a.y0_n, a.n0_nm];
                }
                Effect::ShallowWater(s) => {
                    let f = s.factor();
                    let f_yaw = s.yaw_factor.unwrap_or(f);
                    let lin = w
                        .inner
                        .linear_hull_derivatives()
                        .unwrap_or_else(|| clarke_linear_derivatives(&ship));
                    w.added_mass.Y_vdot *= f;
                    w.added_mass.N_rdot *= f_yaw;
                    w.mass_effective = MassMatrix::new(&ship, &w.added_mass);
                    w.shallow = Some(([f, f_yaw], lin));
                }
            }
        }
        Ok(w)
    }

    /// The wrapped model.
    pub fn inner(&self) -> &D {
        &self.inner
    }

    /// Current velocity in body axes [u_c, v_c] [m/s] at heading `psi_rad`.
    fn current_body(&self, psi_rad: f64) -> [f64; 2] {
        match self.current {
            Some([n, e]) => {
                let (s, c) = psi_rad.sin_cos();
                [n * c + e * s, -n * s + e * c]
            }
            None => [0.0, 0.0],
        }
    }

    /// The over-ground state of a ship moving through the water with `through_water` (adds the current).
    pub fn over_ground(&self, through_water: &State) -> State {
        let [uc, vc] = self.current_body(through_water.psi);
        State {
            u: through_water.u + uc,
            v: through_water.v + vc,
            ..*through_water
        }
    }

    /// The state relative to the water of the over-ground state `s` (removes the current).
    pub fn through_water(&self, s: &State) -> State {
        let [uc, vc] = self.current_body(s.psi);
        State {
            u: s.u - uc,
            v: s.v - vc,
            ..*s
        }
    }

    /// A fresh rudder filter for the rudder effects (lag, delay, neutral offset).
    pub fn rudder_filter(&self) -> EffectRudder {
        EffectRudder::new(self.lag, self.rudder_offset_rad)
    }
}

impl<D: Dynamics> Dynamics for WithEffects<D> {
    /// The wrapped model's accelerations through the water (at the propeller rate the input names,
    /// a recorded one, else its own) with the effects' forces, added mass and current.
    fn accelerations_for(&self, s: &State, input: &Input) -> Result<[f64; 3], DynamicsError> {
        let water = self.through_water(s);
        let mut acc = self.inner.accelerations_for(&water, input)?;
        let ship = self.inner.ship();
        let mut force = self.constant_force;
        if let Some((wind, aero)) = &self.wind {
            let fw = wind.force_with(aero, s);
            (0..3).for_each(|i| force[i] += fw[i]);
        }
        if let Some(([f_v, f_r], lin)) = &self.shallow {
            // Linear MMG hull terms ½ρLdU² Y'_v v/U = ½ρLd U Y'_v v etc., with the water-relative speed.
            let speed = water.speed();
            let q = 0.5 * ship.rho * ship.lpp * ship.draft * speed;
            let (qv, qr) = (q * (f_v - 1.0), q * (f_r - 1.0));
            let r_l = water.r * ship.lpp;
            force[1] += qv * lin.y_v * water.v + qr * lin.y_r * r_l;
            force[2] += ship.lpp * (qv * lin.n_v * water.v + qr * lin.n_r * r_l);
        }
        if force != [0.0; 3] || self.shallow.is_some() {
            // (M + ΔM) a' = M a + ΔF: the model's own forces are M a.
            let ma = self.mass.times(acc);
            let rhs = [ma[0] + force[0], ma[1] + force[1], ma[2] + force[2]];
            acc = self
                .mass_effective
                .solve(rhs)
                .ok_or_else(|| DynamicsError::OutOfDomain("singular mass matrix".into()))?;
        }
        if self.current.is_some() {
            let [uc, vc] = self.current_body(s.psi);
            acc[0] += s.r * vc;
            acc[1] -= s.r * uc;
        }
        Ok(acc)
    }

    fn wrapped(&self) -> Option<&dyn Dynamics> {
        Some(&self.inner)
    }

    fn ship(&self) -> &Ship {
        self.inner.ship()
    }

    fn added_mass(&self) -> &AddedMass {
        &self.added_mass
    }

    fn model_rudder_filter(&self) -> Option<Box<dyn RudderFilter>> {
        (self.lag.is_some() || self.rudder_offset_rad != 0.0)
            .then(|| Box::new(self.rudder_filter()) as Box<dyn RudderFilter>)
    }

    fn over_ground(&self, through_water: &State) -> State {
        self.inner
            .over_ground(&WithEffects::over_ground(self, through_water))
    }

    fn current_velocity_earth(&self, t_s: f64) -> Option<[f64; 2]> {
        crate::flow::add_currents(self.current, self.inner.current_velocity_earth(t_s))
    }

    fn linear_hull_derivatives(&self) -> Option<LinearHullDerivatives> {
        let lin = self.inner.linear_hull_derivatives();
        match &self.shallow {
            Some(([f_v, f_r], deep)) => Some(LinearHullDerivatives {
                y_v: f_v * deep.y_v,
                y_r: f_r * deep.y_r,
                n_v: f_v * deep.n_v,
                n_r: f_r * deep.n_r,
            }),
            None => lin,
        }
    }
}

/// [`RudderFilter`] of the rudder effects: delay, then first-order lag, then neutral offset.
#[derive(Debug, Clone)]
pub struct EffectRudder {
    lag: Option<RudderLag>,
    offset_rad: f64,
    /// Recorded rudder history (time, angle) still needed for the delay.
    history: VecDeque<(f64, f64)>,
    /// Lag output at the current time.
    output: Option<f64>,
    /// `(h, τ, e^(−h/τ))` of the last step: a replay steps at a constant dt (up to the rounding of
    /// the recorded times), and the exponential was 40 % of a diagnosis's time when evaluated twice
    /// per step.
    decay: Option<(f64, f64, f64)>,
}

impl EffectRudder {
    /// A filter with an optional lag and a neutral offset [rad].
    pub fn new(lag: Option<RudderLag>, offset_rad: f64) -> EffectRudder {
        EffectRudder {
            lag,
            offset_rad,
            history: VecDeque::new(),
            output: None,
            decay: None,
        }
    }

    /// `e^(−h/τ)`, from the cache when `τ` is that of the last call and `h` equal to 1e-12 relative
    /// (steps from differences of recorded times differ in their last bits; the decay's relative
    /// change is then below 1e-12 · h/τ).
    fn decay(&mut self, h: f64, tau: f64) -> f64 {
        match self.decay {
            Some((h0, tau0, e)) if tau0 == tau && (h0 - h).abs() <= 1e-12 * h => e,
            _ => {
                let e = (-h / tau).exp();
                self.decay = Some((h, tau, e));
                e
            }
        }
    }

    fn delayed(&self, t: f64) -> f64 {
        let h = &self.history;
        let i = h.partition_point(|&(ti, _)| ti <= t);
        if i == 0 {
            h.front().map_or(0.0, |p| p.1)
        } else if i == h.len() {
            h[i - 1].1
        } else {
            let ((t0, d0), (t1, d1)) = (h[i - 1], h[i]);
            d0 + (t - t0) / (t1 - t0) * (d1 - d0)
        }
    }

    fn record(&mut self, t: f64, delta: f64) {
        match self.history.back_mut() {
            Some(last) if last.0 >= t => last.1 = delta,
            _ => self.history.push_back((t, delta)),
        }
    }
}

/// First-order lag output after `h` seconds from `y0`, input linear from `a` to `b` (exact solution of
/// τ ẏ = x − y); `decay` = e^(−h/τ).
fn lag_linear(y0: f64, a: f64, b: f64, h: f64, tau: f64, decay: f64) -> f64 {
    if tau <= 0.0 {
        return b;
    }
    if h <= 0.0 {
        return y0;
    }
    let g = (b - a) / h;
    b - g * tau + (y0 - a + g * tau) * decay
}

impl RudderFilter for EffectRudder {
    fn step(&mut self, t_s: f64, dt_s: f64, recorded_rad: [f64; 3]) -> [f64; 3] {
        let Some(lag) = self.lag else {
            return recorded_rad.map(|d| d + self.offset_rad);
        };
        let half = 0.5 * dt_s;
        self.record(t_s, recorded_rad[0]);
        if dt_s > 0.0 {
            self.record(t_s + half, recorded_rad[1]);
            self.record(t_s + dt_s, recorded_rad[2]);
        }
        let x = [t_s, t_s + half, t_s + dt_s].map(|t| self.delayed(t - lag.delay_s));
        let tau = lag.time_constant_s;
        // Unused by lag_linear where τ or h is 0 (it returns early there).
        let decay = self.decay(half, tau);
        let y0 = *self.output.get_or_insert(x[0]);
        let y1 = lag_linear(y0, x[0], x[1], half, tau, decay);
        let y2 = lag_linear(y1, x[1], x[2], half, tau, decay);
        self.output = Some(y2);
        // Keep one sample at or before the oldest time the next step will look up.
        let oldest = t_s + dt_s - lag.delay_s;
        while self.history.len() > 2 && self.history[1].0 <= oldest {
            self.history.pop_front();
        }
        [y0, y1, y2].map(|d| d + self.offset_rad)
    }
}

/// Simulate `model` with `effects` under `controller` (see [`simulate_filtered`]). `initial_through_water`
/// is the ship's motion relative to the water (e.g. the steady approach at U0); the simulated state and
/// the recording are over ground, and the recorded rudder is the one before the rudder effects.
pub fn simulate_with_effects(
    model: &dyn Dynamics,
    effects: &[Effect],
    controller: &mut dyn RudderController,
    initial_through_water: State,
    options: &SimOptions,
) -> Result<SimOutput, EffectError> {
    let wrapped = WithEffects::new(model, effects)?;
    let mut filter = wrapped.rudder_filter();
    let initial = wrapped.over_ground(&initial_through_water);
    Ok(simulate_filtered(
        &wrapped,
        controller,
        &mut filter,
        initial,
        options,
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_documented_examples() {
        assert_eq!(
            "current:speed=0.05,from=120".parse::<Effect>().unwrap(),
            Effect::Current(Current {
                speed_m_s: 0.05,
                from_deg: 120.0
            })
        );
        assert_eq!(
            "rudder_lag:tau=1.5,delay=0.3".parse::<Effect>().unwrap(),
            Effect::RudderLag(RudderLag {
                delay_s: 0.3,
                time_constant_s: 1.5
            })
        );
        assert!(
            matches!("wind:speed=5,from=90".parse::<Effect>().unwrap(), Effect::Wind(w) if w.speed_m_s == 5.0 && w.frontal_area_m2.is_none())
        );
        assert_eq!(
            "asymmetry:offset=1.0".parse::<Effect>().unwrap(),
            Effect::Asymmetry(Asymmetry {
                rudder_offset_deg: 1.0,
                y0_n: 0.0,
                n0_nm: 0.0
            })
        );
        assert_eq!(
            "shallow_water:h_over_t=1.5".parse::<Effect>().unwrap(),
            Effect::ShallowWater(ShallowWater {
                depth_over_draft: 1.5,
                yaw_factor: None,
            })
        );
    }

    /// Regression: `current:speed=0.5,from_deg=1e300` in a model file's `[[effects]]` was read, its
    /// direction rounding noise; a direction past a full turn is refused, ±360° itself still read.
    #[test]
    fn a_direction_beyond_a_full_turn_is_refused() {
        for text in [
            "current:speed=0.5,from_deg=1e300",
            "wind:speed=10,from=720",
            "wind:speed=10,from=-360.5",
        ] {
            let e = text.parse::<Effect>().unwrap_err();
            assert!(
                e.to_string().contains("from_deg") && e.to_string().contains("360"),
                "{text}: {e}"
            );
        }
        for text in ["current:speed=0.5,from=360", "wind:speed=10,from=-360"] {
            assert!(text.parse::<Effect>().is_ok(), "{text}");
        }
    }

    #[test]
    fn parse_errors_name_the_bad_key() {
        let e = "current:speed=0.05,form=120".parse::<Effect>().unwrap_err();
        assert!(
            matches!(&e, EffectParseError::UnknownKey { key, .. } if key == "form"),
            "{e}"
        );
        assert!(e.to_string().contains("form"));
        let e = "current:speed=0.05".parse::<Effect>().unwrap_err();
        assert!(
            matches!(
                e,
                EffectParseError::MissingKey {
                    key: "from_deg",
                    ..
                }
            ),
            "{e}"
        );
        let e = "wind:speed=fast,from=90".parse::<Effect>().unwrap_err();
        assert!(
            e.to_string().contains("speed") && e.to_string().contains("fast"),
            "{e}"
        );
        let e = "shallow_water:h_over_t=0.8".parse::<Effect>().unwrap_err();
        assert!(e.to_string().contains("h_over_t"), "{e}");
        let e = "rudder_lag:tau=1,tau=2".parse::<Effect>().unwrap_err();
        assert!(matches!(e, EffectParseError::DuplicateKey { .. }), "{e}");
        assert!(matches!(
            "tide:speed=1".parse::<Effect>(),
            Err(EffectParseError::UnknownEffect(_))
        ));
        assert!(matches!(
            "current:speed".parse::<Effect>(),
            Err(EffectParseError::Syntax { .. })
        ));
    }

    #[test]
    fn display_round_trips() {
        for s in [
            "current:speed=0.05,from_deg=120",
            "wind:speed=5,from_deg=90,af=0.3,al=1.5",
            "rudder_lag:tau=1.5,delay=0.3",
            "asymmetry:offset=-1,y0=2.5,n0=-3",
            "shallow_water:h_over_t=1.5",
        ] {
            let e: Effect = s.parse().unwrap();
            assert_eq!(e.to_string(), s);
            assert_eq!(e.to_string().parse::<Effect>().unwrap(), e);
        }
    }

    #[test]
    fn lag_of_a_ramp_trails_by_delay_plus_time_constant() {
        let (tau, delay, slope, dt) = (1.5, 0.3, 0.02, 0.05);
        let mut f = EffectRudder::new(
            Some(RudderLag {
                delay_s: delay,
                time_constant_s: tau,
            }),
            0.0,
        );
        let mut last = [0.0; 3];
        for k in 0..600 {
            let t = k as f64 * dt;
            let rec = [t, t + 0.5 * dt, t + dt].map(|t| slope * t);
            last = f.step(t, dt, rec);
        }
        let t_end = 600.0 * dt;
        // After 20 time constants the transient is e^-20 ≈ 2e-9 of the initial gap.
        let expected = slope * (t_end - delay - tau);
        assert!(
            (last[2] - expected).abs() < 1e-9,
            "{} vs {expected}",
            last[2]
        );
    }

    #[test]
    fn shallow_water_factor_is_one_in_deep_water_and_grows_towards_two() {
        let f = |h: f64| {
            ShallowWater {
                depth_over_draft: h,
                yaw_factor: None,
            }
            .factor()
        };
        assert!((f(1e4) - 1.0).abs() < 1e-4, "{}", f(1e4));
        let depths = [10.0, 5.0, 3.0, 2.0, 1.5, 1.3, 1.2];
        assert!(depths.windows(2).all(|w| f(w[1]) > f(w[0])));
        assert!(
            (f(1.5) - 1.544).abs() < 1e-3 && (f(1.2) - 1.975).abs() < 2e-3,
            "{} {}",
            f(1.5),
            f(1.2)
        );
    }

    #[test]
    fn clarke_derivatives_are_close_to_the_mmg_ones_for_kvlcc2() {
        let c = clarke_linear_derivatives(&crate::mmg::kvlcc2_ship());
        let p = crate::mmg::MmgParameters::kvlcc2();
        for (clarke, mmg) in [
            (c.y_v, p.y_v),
            (c.y_r, p.y_r),
            (c.n_v, p.n_v),
            (c.n_r, p.n_r),
        ] {
            assert!(
                clarke * mmg > 0.0 && (clarke / mmg - 1.0).abs() < 0.25,
                "{c:?}"
            );
        }
    }

    #[test]
    fn wind_forces_have_the_expected_signs() {
        let ship = crate::mmg::kvlcc2_ship();
        let at_rest = State::default();
        let wind = |from_deg: f64| Wind {
            speed_m_s: 5.0,
            from_deg,
            frontal_area_m2: None,
            lateral_area_m2: None,
            windage: None,
        };
        let head = wind(0.0).force(&ship, &at_rest).unwrap();
        assert!(
            head[0] < 0.0
                && head[1].abs() < 1e-9 * head[0].abs()
                && head[2].abs() < 1e-9 * head[0].abs()
        );
        let from_stbd = wind(90.0).force(&ship, &at_rest).unwrap();
        assert!(from_stbd[1] < 0.0 && from_stbd[0].abs() < 1e-9 * from_stbd[1].abs());
        let from_port = wind(270.0).force(&ship, &at_rest).unwrap();
        assert!((from_port[1] + from_stbd[1]).abs() < 1e-9 * from_stbd[1].abs());
        // Wind from the starboard bow pushes the bow to port.
        assert!(wind(45.0).force(&ship, &at_rest).unwrap()[2] < 0.0);
        // Beam wind on the KVLCC2 model at 5 m/s: ½ · 1.225 · 25 · 1.42 · 0.825 ≈ 18 N.
        assert!(
            (from_stbd[1] + 0.5 * 1.225 * 25.0 * 7.0 * 0.46 * KVLCC2_FREEBOARD_OVER_DRAFT * 0.825)
                .abs()
                < 1e-9
        );
    }
}
