//! The MMG standard method (Yasukawa & Yoshimura 2015, J. Mar. Sci. Technol. 20:37–52) with the KVLCC2
//! model-scale parameters of their Tables 1–5 (summarised in `docs/conventions.md`, "The reference model").
//!
//! Hull forces act at midship and are non-dimensionalised with the instantaneous speed U:
//! X_H = ½ρ L d U² X'_H(v', r'), Y_H likewise, N_H = ½ρ L² d U² N'_H, with v' = v_m/U and r' = r L/U.
//! Propeller and rudder forces follow the MMG interaction model; the propeller turns at the
//! self-propulsion rate of the approach speed U0, found by a root finder when the model is built.

use shipid_io::{AddedMass, Ship};
use thiserror::Error;

use crate::dynamics::{Dynamics, DynamicsError, Input, LinearHullDerivatives, State};

/// Below this speed [m/s] the hull model (normalised with the instantaneous speed) is not evaluated.
const MIN_SPEED_M_S: f64 = 1e-6;

/// The 31 parameters of an `mmg` model file, in its order (hull derivatives, then propeller and rudder
/// interaction), by the names the file uses.
pub const MODEL_FILE_NAMES: [&str; 31] = [
    "r0",
    "x_vv",
    "x_vr",
    "x_rr",
    "x_vvvv",
    "y_v",
    "y_r",
    "y_vvv",
    "y_vvr",
    "y_vrr",
    "y_rrr",
    "n_v",
    "n_r",
    "n_vvv",
    "n_vvr",
    "n_vrr",
    "n_rrr",
    "t_p",
    "w_p0",
    "c1",
    "c2_pos",
    "c2_neg",
    "epsilon",
    "kappa",
    "gamma_r_neg",
    "gamma_r_pos",
    "l_r",
    "t_r",
    "a_h",
    "x_h",
    "f_alpha",
];

/// The values of [`MODEL_FILE_NAMES`] in `p`.
pub fn model_file_values(p: &MmgParameters) -> [f64; 31] {
    [
        p.r0,
        p.x_vv,
        p.x_vr,
        p.x_rr,
        p.x_vvvv,
        p.y_v,
        p.y_r,
        p.y_vvv,
        p.y_vvr,
        p.y_vrr,
        p.y_rrr,
        p.n_v,
        p.n_r,
        p.n_vvv,
        p.n_vvr,
        p.n_vrr,
        p.n_rrr,
        p.t_p,
        p.w_p0,
        p.c1,
        p.c2_pos,
        p.c2_neg,
        p.epsilon,
        p.kappa,
        p.gamma_r_neg,
        p.gamma_r_pos,
        p.l_r,
        p.t_r,
        p.a_h,
        p.x_h,
        p.f_alpha,
    ]
}

/// Parameters of the MMG model. Primed quantities are non-dimensional in the MMG system: forces
/// ÷ ½ρ L d U², yaw moment ÷ ½ρ L² d U², masses ÷ ½ρ L² d, moment of inertia ÷ ½ρ L⁴ d, lengths ÷ L.
///
/// Unless stated otherwise the KVLCC2 values ([`MmgParameters::kvlcc2`]) are those of Yasukawa &
/// Yoshimura (2015) Tables 2–5, model scale L = 7.00 m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MmgParameters {
    // --- Hull (Y&Y 2015 Table 4) ---
    /// R'_0, straight-ahead resistance coefficient [-].
    pub r0: f64,
    /// X'_vv [-].
    pub x_vv: f64,
    /// X'_vr [-].
    pub x_vr: f64,
    /// X'_rr [-].
    pub x_rr: f64,
    /// X'_vvvv [-].
    pub x_vvvv: f64,
    /// Y'_v [-].
    pub y_v: f64,
    /// Y'_r [-].
    pub y_r: f64,
    /// Y'_vvv [-].
    pub y_vvv: f64,
    /// Y'_vvr [-].
    pub y_vvr: f64,
    /// Y'_vrr [-].
    pub y_vrr: f64,
    /// Y'_rrr [-].
    pub y_rrr: f64,
    /// N'_v [-].
    pub n_v: f64,
    /// N'_r [-].
    pub n_r: f64,
    /// N'_vvv [-].
    pub n_vvv: f64,
    /// N'_vvr [-].
    pub n_vvr: f64,
    /// N'_vrr [-].
    pub n_vrr: f64,
    /// N'_rrr [-].
    pub n_rrr: f64,
    /// m'_x, surge added mass ÷ ½ρL²d [-] (Y&Y 2015 Table 2).
    pub m_x: f64,
    /// m'_y, sway added mass ÷ ½ρL²d [-] (Table 2).
    pub m_y: f64,
    /// J'_z, yaw added moment of inertia ÷ ½ρL⁴d [-] (Table 2).
    pub j_z: f64,

    // --- Propeller (Table 1 and 5) ---
    /// D_P, propeller diameter [m] (Table 1, model scale).
    pub propeller_diameter_m: f64,
    /// t_P, thrust deduction factor [-].
    pub t_p: f64,
    /// w_P0, wake fraction straight ahead [-].
    pub w_p0: f64,
    /// K_T(J) = k0 + k1 J + k2 J² open-water thrust coefficients [-] (Table 5).
    pub k_t: [f64; 3],
    /// x'_P, longitudinal propeller position ÷ L [-] (−0.48, not the −0.65/−0.69 of some codes).
    pub x_p: f64,
    /// C_1 of the wake change with β_P [-].
    pub c1: f64,
    /// C_2 for β_P > 0 [-].
    pub c2_pos: f64,
    /// C_2 for β_P ≤ 0 [-].
    pub c2_neg: f64,

    // --- Rudder (Table 1 and 5) ---
    /// H_R, rudder span [m] (Table 1, model scale).
    pub rudder_span_m: f64,
    /// A_R, rudder area [m²] (Table 1, model scale).
    pub rudder_area_m2: f64,
    /// t_R, steering resistance deduction factor [-].
    pub t_r: f64,
    /// a_H, rudder force increase factor (hull–rudder interaction) [-].
    pub a_h: f64,
    /// x'_H, position of the additional lateral force ÷ L [-].
    pub x_h: f64,
    /// x'_R, rudder position ÷ L [-].
    pub x_r: f64,
    /// ε, ratio of wake fractions at rudder and propeller [-].
    pub epsilon: f64,
    /// κ, propeller-slipstream constant of u_R [-].
    pub kappa: f64,
    /// l'_R, effective longitudinal rudder position for the flow straightening ÷ L [-].
    pub l_r: f64,
    /// γ_R for β_R < 0 [-].
    pub gamma_r_neg: f64,
    /// γ_R for β_R ≥ 0 [-].
    pub gamma_r_pos: f64,
    /// f_α, rudder lift gradient coefficient [1/rad].
    pub f_alpha: f64,
}

impl MmgParameters {
    /// KVLCC2 (Yasukawa & Yoshimura 2015, Tables 1–5).
    pub fn kvlcc2() -> MmgParameters {
        MmgParameters {
            r0: 0.022,
            x_vv: -0.040,
            x_vr: 0.002,
            x_rr: 0.011,
            x_vvvv: 0.771,
            y_v: -0.315,
            y_r: 0.083,
            y_vvv: -1.607,
            y_vvr: 0.379,
            y_vrr: -0.391,
            y_rrr: 0.008,
            n_v: -0.137,
            n_r: -0.049,
            n_vvv: -0.030,
            n_vvr: -0.294,
            n_vrr: 0.055,
            n_rrr: -0.013,
            m_x: 0.022,
            m_y: 0.223,
            j_z: 0.011,
            propeller_diameter_m: 0.216,
            t_p: 0.220,
            w_p0: 0.40,
            k_t: [0.2931, -0.2753, -0.1385],
            x_p: -0.48,
            c1: 2.0,
            c2_pos: 1.6,
            c2_neg: 1.1,
            rudder_span_m: 0.345,
            rudder_area_m2: 0.0539,
            t_r: 0.387,
            a_h: 0.312,
            x_h: -0.464,
            x_r: -0.5,
            epsilon: 1.09,
            kappa: 0.50,
            l_r: -0.710,
            gamma_r_neg: 0.395,
            gamma_r_pos: 0.640,
            f_alpha: 2.747,
        }
    }

    fn named(&self) -> [(&'static str, f64); 42] {
        [
            ("r0", self.r0),
            ("x_vv", self.x_vv),
            ("x_vr", self.x_vr),
            ("x_rr", self.x_rr),
            ("x_vvvv", self.x_vvvv),
            ("y_v", self.y_v),
            ("y_r", self.y_r),
            ("y_vvv", self.y_vvv),
            ("y_vvr", self.y_vvr),
            ("y_vrr", self.y_vrr),
            ("y_rrr", self.y_rrr),
            ("n_v", self.n_v),
            ("n_r", self.n_r),
            ("n_vvv", self.n_vvv),
            ("n_vvr", self.n_vvr),
            ("n_vrr", self.n_vrr),
            ("n_rrr", self.n_rrr),
            ("m_x", self.m_x),
            ("m_y", self.m_y),
            ("j_z", self.j_z),
            ("propeller_diameter_m", self.propeller_diameter_m),
            ("t_p", self.t_p),
            ("w_p0", self.w_p0),
            ("k_t[0]", self.k_t[0]),
            ("k_t[1]", self.k_t[1]),
            ("k_t[2]", self.k_t[2]),
            ("x_p", self.x_p),
            ("c1", self.c1),
            ("c2_pos", self.c2_pos),
            ("c2_neg", self.c2_neg),
            ("rudder_span_m", self.rudder_span_m),
            ("rudder_area_m2", self.rudder_area_m2),
            ("t_r", self.t_r),
            ("a_h", self.a_h),
            ("x_h", self.x_h),
            ("x_r", self.x_r),
            ("epsilon", self.epsilon),
            ("kappa", self.kappa),
            ("l_r", self.l_r),
            ("gamma_r_neg", self.gamma_r_neg),
            ("gamma_r_pos", self.gamma_r_pos),
            ("f_alpha", self.f_alpha),
        ]
    }

    fn validate(&self) -> Result<(), MmgError> {
        for (name, value) in self.named() {
            if !value.is_finite() {
                return Err(MmgError::InvalidParameter { name, value });
            }
        }
        for (name, value) in [
            ("propeller_diameter_m", self.propeller_diameter_m),
            ("rudder_span_m", self.rudder_span_m),
            ("rudder_area_m2", self.rudder_area_m2),
        ] {
            if value <= 0.0 {
                return Err(MmgError::InvalidParameter { name, value });
            }
        }
        let named = self.named();
        for &(name, domain, inside) in PHYSICAL_DOMAINS {
            let value = named
                .iter()
                .find(|(n, _)| *n == name)
                .map_or(f64::NAN, |p| p.1);
            if !inside(value) {
                return Err(MmgError::OutsideDomain {
                    name,
                    value,
                    domain,
                });
            }
        }
        Ok(())
    }
}

/// Where each resistance, propeller, rudder and interaction parameter means what the MMG equations
/// use it for, whatever the ship: outside, a force changes sign (1 − t_P ≤ 0 thrusts astern, ε ≤ 0
/// reverses the rudder's inflow, f_α ≤ 0 its lift), and a hand-edited model file with ε = −0.5
/// simulated a ship turning against its rudder. Wider than any fit's bounds (docs/mmg.md) and than
/// the inverse method's ships; the hull derivatives have no such domain beyond finiteness.
type Domain = (&'static str, &'static str, fn(f64) -> bool);
const PHYSICAL_DOMAINS: &[Domain] = &[
    ("r0", "R′₀ ≥ 0: a resistance", |v| v >= 0.0),
    (
        "w_p0",
        "w_P0 < 1: keeps the propeller's inflow 1 − w_P0 positive",
        |v| v < 1.0,
    ),
    ("t_p", "0 ≤ t_P < 1: a thrust deduction", |v| {
        (0.0..1.0).contains(&v)
    }),
    (
        "c1",
        "C₁ ≥ 0: the wake's decay with the propeller's drift",
        |v| v >= 0.0,
    ),
    ("c2_pos", "C₂ ≥ 0: keeps 1 − w_P positive", |v| {
        v >= 0.0
    }),
    ("c2_neg", "C₂ ≥ 0: keeps 1 − w_P positive", |v| {
        v >= 0.0
    }),
    (
        "t_r",
        "t_R < 1: the rudder's drag deduction keeps 1 − t_R > 0",
        |v| v < 1.0,
    ),
    (
        "a_h",
        "a_H > −1: the hull's share of the rudder force keeps 1 + a_H > 0",
        |v| v > -1.0,
    ),
    (
        "epsilon",
        "ε > 0: the ratio of the rudder's to the propeller's wake",
        |v| v > 0.0,
    ),
    (
        "kappa",
        "κ ≥ 0: the slipstream's share of the rudder inflow",
        |v| v >= 0.0,
    ),
    ("gamma_r_neg", "γ_R ≥ 0: flow straightening", |v| {
        v >= 0.0
    }),
    ("gamma_r_pos", "γ_R ≥ 0: flow straightening", |v| {
        v >= 0.0
    }),
    ("f_alpha", "f_α > 0: the rudder's lift slope", |v| v > 0.0),
];

/// The KVLCC2 model of the SIMMAN/MMG benchmark at scale 1:45.714 (particulars as in
/// `docs/conventions.md`, "The reference model"):
/// L 7.00 m, B 1.27 m, d 0.46 m, ∇ 3.27 m³, ρ 1000 kg/m³ (model basin), x_G 0.25 m, k_zz = 0.25 L,
/// U0 1.179 m/s (Froude number 0.142), rudder rate 15.8 °/s (2.34 °/s at full scale).
pub fn kvlcc2_ship() -> Ship {
    let lpp = 7.00;
    Ship {
        lpp,
        beam: 1.27,
        draft: 0.46,
        displacement: 3.27,
        rho: 1000.0,
        xg: 0.25,
        kzz: 0.25 * lpp,
        u0: 1.179,
        rudder_rate: 15.8,
    }
}

/// Added masses of KVLCC2 in SI about midship, from the MMG primes m'_x 0.022, m'_y 0.223 (÷½ρL²d) and
/// J'_z 0.011 (÷½ρL⁴d): X_u̇ ≈ −247.9 kg, Y_v̇ ≈ −2513 kg, N_ṙ ≈ −6074.5 kg m², Y_ṙ = N_v̇ = 0 (the MMG
/// model has no sway–yaw added-mass coupling).
pub fn kvlcc2_added_mass() -> AddedMass {
    mmg_added_mass(&kvlcc2_ship(), &MmgParameters::kvlcc2())
}

fn mmg_added_mass(ship: &Ship, p: &MmgParameters) -> AddedMass {
    let half_rho_l2_d = 0.5 * ship.rho * ship.lpp * ship.lpp * ship.draft;
    AddedMass {
        X_udot: -p.m_x * half_rho_l2_d,
        Y_vdot: -p.m_y * half_rho_l2_d,
        Y_rdot: 0.0,
        N_vdot: 0.0,
        N_rdot: -p.j_z * half_rho_l2_d * ship.lpp * ship.lpp,
    }
}

/// Why an MMG model could not be built.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum MmgError {
    /// A parameter or ship particular is non-finite or outside its physical range.
    #[error("invalid MMG parameter {name} = {value}")]
    InvalidParameter { name: &'static str, value: f64 },
    /// A parameter lies outside the range where it means what the equations use it for.
    #[error("MMG parameter {name} = {value} is outside its physical domain ({domain})")]
    OutsideDomain {
        name: &'static str,
        value: f64,
        domain: &'static str,
    },
    /// The propeller cannot balance the resistance at U0 for any rate in the searched range.
    #[error(
        "no self-propulsion point at U0 = {u0_m_s} m/s for propeller rates up to {max_rate_hz} 1/s"
    )]
    NoSelfPropulsionPoint { u0_m_s: f64, max_rate_hz: f64 },
}

/// Force components of the MMG model at one state [N, N, N m], about midship.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MmgForces {
    /// Hull force and moment [X_H, Y_H, N_H].
    pub hull: [f64; 3],
    /// Propeller surge force X_P = (1 − t_P) T.
    pub propeller_x: f64,
    /// Rudder forces [X_R, Y_R, N_R].
    pub rudder: [f64; 3],
    /// Rudder normal force F_N [N].
    pub rudder_normal: f64,
    /// Propeller advance ratio J [-].
    pub advance_ratio: f64,
}

impl MmgForces {
    /// Total [X, Y, N].
    pub fn total(&self) -> [f64; 3] {
        [
            self.hull[0] + self.propeller_x + self.rudder[0],
            self.hull[1] + self.rudder[1],
            self.hull[2] + self.rudder[2],
        ]
    }
}

/// The MMG model of one ship with its propeller at the self-propulsion rate of U0.
#[derive(Debug, Clone, PartialEq)]
pub struct MmgModel {
    ship: Ship,
    params: MmgParameters,
    added_mass: AddedMass,
    propeller_rate_hz: f64,
    // Dimensional constants derived once from `ship` and `params`.
    mass_kg: f64,
    mx_kg: f64,
    my_kg: f64,
    half_rho_l_d: f64,
    /// Inverse of the sway–yaw block [[m+m_y, x_G m], [x_G m, I_zG + x_G² m + J_z]].
    inv_sway_yaw: [[f64; 2]; 2],
}

impl MmgModel {
    /// KVLCC2 model scale with the parameters of Yasukawa & Yoshimura (2015).
    pub fn kvlcc2() -> MmgModel {
        MmgModel::new(kvlcc2_ship(), MmgParameters::kvlcc2())
            .expect("the published KVLCC2 parameters are valid and have a self-propulsion point")
    }

    /// Build the model and solve for the self-propulsion propeller rate at `ship.u0`.
    pub fn new(ship: Ship, params: MmgParameters) -> Result<MmgModel, MmgError> {
        let mut model = MmgModel::unsolved(ship, params)?;
        model.propeller_rate_hz = model.solve_self_propulsion()?;
        Ok(model)
    }

    /// Build the model with the propeller turning at `n_hz` [1/s] (a recorded rate, or an identified
    /// model's training rate) instead of the self-propulsion rate of U0.
    pub fn at_rate(ship: Ship, params: MmgParameters, n_hz: f64) -> Result<MmgModel, MmgError> {
        if !(n_hz.is_finite() && n_hz >= 0.0) {
            return Err(MmgError::InvalidParameter {
                name: "propeller_rate_hz",
                value: n_hz,
            });
        }
        let mut model = MmgModel::unsolved(ship, params)?;
        model.propeller_rate_hz = n_hz;
        Ok(model)
    }

    /// The checked model with its propeller at rest; the constructors set the rate.
    fn unsolved(ship: Ship, params: MmgParameters) -> Result<MmgModel, MmgError> {
        for (name, value) in [
            ("lpp", ship.lpp),
            ("draft", ship.draft),
            ("displacement", ship.displacement),
            ("rho", ship.rho),
            ("kzz", ship.kzz),
            ("u0", ship.u0),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(MmgError::InvalidParameter { name, value });
            }
        }
        if !ship.xg.is_finite() {
            return Err(MmgError::InvalidParameter {
                name: "xg",
                value: ship.xg,
            });
        }
        params.validate()?;
        let added_mass = mmg_added_mass(&ship, &params);
        let mass_kg = ship.mass_kg();
        let mx_kg = -added_mass.X_udot;
        let my_kg = -added_mass.Y_vdot;
        let jz = -added_mass.N_rdot;
        let a = mass_kg + my_kg;
        let b = ship.xg * mass_kg;
        let d = mass_kg * ship.kzz * ship.kzz + ship.xg * ship.xg * mass_kg + jz;
        let det = a * d - b * b;
        if !(det > 0.0 && mass_kg + mx_kg > 0.0) {
            return Err(MmgError::InvalidParameter {
                name: "m_y",
                value: params.m_y,
            });
        }
        Ok(MmgModel {
            ship,
            params,
            added_mass,
            propeller_rate_hz: 0.0,
            mass_kg,
            mx_kg,
            my_kg,
            half_rho_l_d: 0.5 * ship.rho * ship.lpp * ship.draft,
            inv_sway_yaw: [[d / det, -b / det], [-b / det, a / det]],
        })
    }

    /// The parameters.
    pub fn parameters(&self) -> &MmgParameters {
        &self.params
    }

    /// Propeller rate n_P [1/s]: the self-propulsion point at U0 (X = 0 straight ahead, δ = 0).
    pub fn propeller_rate(&self) -> f64 {
        self.propeller_rate_hz
    }

    /// Surge force straight ahead at U0 with propeller rate `n_hz` [N].
    fn straight_surge_force(&self, n_hz: f64) -> f64 {
        let s = State::approach(self.ship.u0);
        let mut m = self.clone();
        m.propeller_rate_hz = n_hz;
        m.forces(&s, 0.0).map(|f| f.total()[0]).unwrap_or(f64::NAN)
    }

    /// Bisection on X(n) = 0. X rises monotonically with n wherever the thrust is positive, and is
    /// negative (resistance, negative thrust at huge J) for small n, so one sign change brackets the root.
    fn solve_self_propulsion(&self) -> Result<f64, MmgError> {
        const MAX_RATE_HZ: f64 = 1.0e4;
        let no_point = MmgError::NoSelfPropulsionPoint {
            u0_m_s: self.ship.u0,
            max_rate_hz: MAX_RATE_HZ,
        };
        let mut lo = 1.0e-3;
        let mut hi = 1.0;
        let at_lo = self.straight_surge_force(lo);
        if at_lo.is_nan() || at_lo >= 0.0 {
            return Err(no_point);
        }
        while self.straight_surge_force(hi) < 0.0 {
            lo = hi;
            hi *= 2.0;
            if hi > MAX_RATE_HZ {
                return Err(no_point);
            }
        }
        // The loop above also ends on NaN.
        if self.straight_surge_force(hi).is_nan() {
            return Err(no_point);
        }
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if self.straight_surge_force(mid) < 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
            if hi - lo <= 1e-13 * hi {
                break;
            }
        }
        Ok(0.5 * (lo + hi))
    }

    /// Hull, propeller and rudder forces at `state` with rudder angle `delta_rad` (Y&Y 2015 §2–3).
    pub fn forces(&self, state: &State, delta_rad: f64) -> Result<MmgForces, DynamicsError> {
        self.forces_at_rate(state, delta_rad, self.propeller_rate_hz)
    }

    /// [`MmgModel::forces`] with the propeller turning at `n_hz` [1/s] (a recorded rate) instead of the
    /// model's own rate: the identification evaluates each sample at its recorded rate.
    pub fn forces_at_rate(
        &self,
        state: &State,
        delta_rad: f64,
        n_hz: f64,
    ) -> Result<MmgForces, DynamicsError> {
        // The quadratic thrust form below at n < 0 gives a forward thrust (an astern ship that
        // keeps its speed better than one with the propeller stopped): no force is better than that.
        if n_hz < 0.0 {
            return Err(DynamicsError::PropellerAstern { n_hz });
        }
        let p = &self.params;
        let ship = &self.ship;
        let (u, v, r) = (state.u, state.v, state.r);
        let speed = (u * u + v * v).sqrt();
        if speed.is_nan() || speed < MIN_SPEED_M_S {
            return Err(DynamicsError::SpeedTooLow {
                speed_m_s: speed,
                limit_m_s: MIN_SPEED_M_S,
            });
        }
        let l = ship.lpp;
        let vp = v / speed;
        let rp = r * l / speed;
        let beta = (-v).atan2(u);

        let q = self.half_rho_l_d * speed * speed;
        let x_h = q
            * (-p.r0
                + p.x_vv * vp * vp
                + p.x_vr * vp * rp
                + p.x_rr * rp * rp
                + p.x_vvvv * vp * vp * vp * vp);
        let y_h = q
            * (p.y_v * vp
                + p.y_r * rp
                + p.y_vvv * vp * vp * vp
                + p.y_vvr * vp * vp * rp
                + p.y_vrr * vp * rp * rp
                + p.y_rrr * rp * rp * rp);
        let n_h = q
            * l
            * (p.n_v * vp
                + p.n_r * rp
                + p.n_vvv * vp * vp * vp
                + p.n_vvr * vp * vp * rp
                + p.n_vrr * vp * rp * rp
                + p.n_rrr * rp * rp * rp);

        // Propeller: (1 − w_P) = (1 − w_P0)[1 + {1 − exp(−C1|β_P|)}(C2 − 1)], β_P = β − x'_P r'.
        let one_minus_wp = one_minus_wake(p.w_p0, p.c1, [p.c2_pos, p.c2_neg], beta - p.x_p * rp);
        let n = n_hz;
        let dp = p.propeller_diameter_m;
        let u_p = u * one_minus_wp;
        let nd = n * dp;
        let j = if nd != 0.0 { u_p / nd } else { f64::INFINITY };
        let k_t = if nd != 0.0 {
            p.k_t[0] + p.k_t[1] * j + p.k_t[2] * j * j
        } else {
            0.0
        };
        // T = ρ n² D⁴ K_T written as ρ D² (k0 (nD)² + k1 (nD) u_P + k2 u_P²) stays finite as n → 0.
        let thrust =
            ship.rho * dp * dp * (p.k_t[0] * nd * nd + p.k_t[1] * nd * u_p + p.k_t[2] * u_p * u_p);
        let x_p = (1.0 - p.t_p) * thrust;

        // Rudder inflow. u_P{1 + κ(√(1 + 8K_T/(πJ²)) − 1)} = u_P + κ(√(u_P² + 8 K_T (nD)²/π) − u_P)
        // for u_P ≥ 0, which avoids dividing by J².
        let eta = dp / p.rudder_span_m;
        let slip = (u_p * u_p + 8.0 * k_t * nd * nd / std::f64::consts::PI)
            .max(0.0)
            .sqrt();
        let accelerated = u_p + p.kappa * (slip - u_p);
        let u_r = p.epsilon * (eta * accelerated * accelerated + (1.0 - eta) * u_p * u_p).sqrt();
        let beta_r = beta - p.l_r * rp;
        let gamma_r = if beta_r < 0.0 {
            p.gamma_r_neg
        } else {
            p.gamma_r_pos
        };
        let v_r = speed * gamma_r * beta_r;
        // F_N = ½ρ A_R U_R² f_α sin α_R with α_R = δ − atan(v_R/u_R), and
        // U_R² sin α_R = U_R (u_R sin δ − v_R cos δ): no atan and sin needed.
        let (sd, cd) = delta_rad.sin_cos();
        let u_rudder = (u_r * u_r + v_r * v_r).sqrt();
        let f_n = 0.5 * ship.rho * p.rudder_area_m2 * p.f_alpha * u_rudder * (u_r * sd - v_r * cd);
        let x_r_dim = p.x_r * l;
        let x_h_dim = p.x_h * l;
        let rudder = [
            -(1.0 - p.t_r) * f_n * sd,
            -(1.0 + p.a_h) * f_n * cd,
            -(x_r_dim + p.a_h * x_h_dim) * f_n * cd,
        ];
        Ok(MmgForces {
            hull: [x_h, y_h, n_h],
            propeller_x: x_p,
            rudder,
            rudder_normal: f_n,
            advance_ratio: j,
        })
    }
}

/// 1 − w_P of the MMG wake model, (1 − w_P0)[1 + {1 − exp(−C₁|β_P|)}(C₂ − 1)], at the propeller's
/// drift angle β_P = β − x′_P r′ [rad], C₂ = `c2[0]` for β_P > 0 and `c2[1]` otherwise.
pub fn one_minus_wake(w_p0: f64, c1: f64, c2: [f64; 2], beta_p_rad: f64) -> f64 {
    let c2 = if beta_p_rad > 0.0 { c2[0] } else { c2[1] };
    (1.0 - w_p0) * (1.0 + (1.0 - (-c1 * beta_p_rad.abs()).exp()) * (c2 - 1.0))
}

impl MmgModel {
    /// The accelerations under the total forces `[X, Y, N]`, Y&Y 2015 eq. (4) about midship:
    /// (m + m_x)u̇ − (m + m_y)v r − x_G m r² = X;
    /// (m + m_y)v̇ + (m + m_x)u r + x_G m ṙ = Y;
    /// (I_zG + x_G² m + J_z)ṙ + x_G m(v̇ + u r) = N.
    fn accelerations_of(&self, [x, y, n]: [f64; 3], state: &State) -> [f64; 3] {
        let m = self.mass_kg;
        let xg = self.ship.xg;
        let (u, v, r) = (state.u, state.v, state.r);
        let u_dot = (x + (m + self.my_kg) * v * r + xg * m * r * r) / (m + self.mx_kg);
        let rhs_y = y - (m + self.mx_kg) * u * r;
        let rhs_n = n - xg * m * u * r;
        let inv = &self.inv_sway_yaw;
        let v_dot = inv[0][0] * rhs_y + inv[0][1] * rhs_n;
        let r_dot = inv[1][0] * rhs_y + inv[1][1] * rhs_n;
        [u_dot, v_dot, r_dot]
    }
}

impl Dynamics for MmgModel {
    fn accelerations_for(&self, state: &State, input: &Input) -> Result<[f64; 3], DynamicsError> {
        let n_hz = input.propeller_rate_hz.unwrap_or(self.propeller_rate_hz);
        let forces = self.forces_at_rate(state, input.delta_rad, n_hz)?.total();
        Ok(self.accelerations_of(forces, state))
    }

    fn takes_propeller_rate(&self) -> bool {
        true
    }

    fn ship(&self) -> &Ship {
        &self.ship
    }

    fn added_mass(&self) -> &AddedMass {
        &self.added_mass
    }

    fn propeller_rate_hz(&self) -> Option<f64> {
        Some(self.propeller_rate_hz)
    }

    fn linear_hull_derivatives(&self) -> Option<LinearHullDerivatives> {
        Some(LinearHullDerivatives {
            y_v: self.params.y_v,
            y_r: self.params.y_r,
            n_v: self.params.n_v,
            n_r: self.params.n_r,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn added_mass_matches_data_md() {
        let a = kvlcc2_added_mass();
        assert!((a.X_udot + 247.94).abs() < 0.05, "{}", a.X_udot);
        assert!((a.Y_vdot + 2513.2).abs() < 0.5, "{}", a.Y_vdot);
        assert!((a.N_rdot + 6074.5).abs() < 0.1, "{}", a.N_rdot);
    }

    #[test]
    fn invalid_parameter_is_named() {
        let mut p = MmgParameters::kvlcc2();
        p.f_alpha = f64::NAN;
        let err = MmgModel::new(kvlcc2_ship(), p).unwrap_err();
        assert!(matches!(
            err,
            MmgError::InvalidParameter {
                name: "f_alpha",
                ..
            }
        ));
        let mut ship = kvlcc2_ship();
        ship.u0 = 0.0;
        assert!(MmgModel::new(ship, MmgParameters::kvlcc2()).is_err());
    }

    #[test]
    fn no_self_propulsion_point_is_an_error() {
        let mut p = MmgParameters::kvlcc2();
        // A propeller without thrust at any rate cannot balance the resistance.
        p.k_t = [0.0, 0.0, 0.0];
        assert!(matches!(
            MmgModel::new(kvlcc2_ship(), p),
            Err(MmgError::NoSelfPropulsionPoint { .. })
        ));
    }

    #[test]
    fn speed_zero_is_an_error_not_a_panic() {
        let m = MmgModel::kvlcc2();
        assert!(m.accelerations(&State::default(), 0.1).is_err());
    }

    #[test]
    fn positive_rudder_turns_to_starboard() {
        let m = MmgModel::kvlcc2();
        let a = m
            .accelerations(&State::approach(1.179), 10f64.to_radians())
            .unwrap();
        assert!(a[2] > 0.0, "r_dot {}", a[2]);
        // The rudder lift pushes the stern to port: sway acceleration to port at first.
        assert!(a[1] < 0.0, "v_dot {}", a[1]);
    }
}
