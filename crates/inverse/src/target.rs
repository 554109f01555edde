//! The target ship (paper 003 Tab. 2 and Tab. 4) and the MMG model built from generated coefficients.
//!
//! The database coefficients (β form with the Munk terms folded in, [`crate::database`]) are turned
//! into the MMG standard method's v-form parameters of [`shipid_sim::MmgParameters`] with the target's
//! own added masses (β ≈ −v', so odd-in-β terms flip sign):
//! X'_vv = X'_ββ, X'_vr = −(X'_βr − m'_y) − m'_y, X'_rr = (X'_rr + x'_G m'_y) − x'_G m'_y, X'_vvvv = X'_ββββ,
//! Y'_v = −Y'_β, Y'_r = (Y'_r − m'_x) + m'_x, Y'_vvv = −Y'_βββ, Y'_vvr = Y'_ββr, Y'_vrr = −Y'_βrr,
//! Y'_rrr = Y'_rrr and the same for N (N'_r unchanged). The database polynomials use β [rad] where the
//! MMG model evaluates v' = −sin β; the difference is below 2 % at the 20° edge of the grid.

use serde::Deserialize;
use shipid_io::Ship;
use shipid_sim::{MmgModel, MmgParameters};

use crate::database::Coefficients;
use crate::error::{InverseError, readable};
use crate::indexes::MotionTarget;

/// Sea water density [kg/m³] for the full-scale targets of paper 003.
pub const RHO_SEA_KG_M3: f64 = 1025.0;
/// Kinematic viscosity of sea water at 15 °C [m²/s] (ITTC 2011 fresh/sea water tables: 1.1892e-6).
pub const NU_SEA_M2_S: f64 = 1.1892e-6;

/// Gravity [m/s²] for the Froude number.
pub const G_M_S2: f64 = 9.81;
/// Largest approach Froude number U0/√(gL) of a target. The database's ships and the MMG standard
/// method are displacement ships (KVLCC2 at 0.14, container ships up to about 0.3); above 0.5 a hull
/// rides its own bow wave or planes, which no hull-force polynomial of the database describes, and a
/// speed that high is far more often a wrong unit (knots or km/h given as m/s).
pub const MAX_FROUDE: f64 = 0.5;
/// A propeller diameter or rudder span at most this multiple of the draft: ships carry them below
/// the waterline (D_P/T ≈ 0.5 … 0.8, in ballast up to about 1.2); twice the draft is a wrong unit.
pub const MAX_APPENDAGE_OVER_DRAFT: f64 = 2.0;
/// A rudder area at most this fraction of L × T: ships have A_R/(L T) ≈ 1/70 … 1/30; a tenth is
/// three times the largest.
pub const MAX_RUDDER_AREA_RATIO: f64 = 0.1;

/// Largest added mass accepted, as a multiple of the ship's own mass (a data set's bound).
pub const MAX_ADDED_MASS_OVER_MASS: f64 = 100.0;

/// Added masses in the MMG primes: m'_x, m'_y ÷ ½ρL²d, J'_z ÷ ½ρL⁴d.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AddedMassPrimes {
    pub m_x: f64,
    pub m_y: f64,
    pub j_z: f64,
}

/// The particulars of a target ship (`[[target]]` in a targets file; all SI).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TargetShip {
    pub name: String,
    #[serde(default)]
    pub source: String,
    pub lpp_m: f64,
    pub beam_m: f64,
    pub draft_m: f64,
    pub propeller_diameter_m: f64,
    pub rudder_span_m: f64,
    pub rudder_area_m2: f64,
    pub cb: f64,
    /// Centre of gravity forward of midship [m].
    pub xg_m: f64,
    /// K_T = k0 + k1 J + k2 J².
    pub k_t: [f64; 3],
    /// Thrust deduction t_P [-].
    pub t_p: f64,
    /// Approach speed U0 [m/s] (paper: V_initial).
    pub u0_m_s: f64,
    /// Rudder rate [deg/s].
    pub rudder_rate_deg_s: f64,
    /// Added masses; when absent, Zhou et al. (1983) ([`zhou_added_mass`]).
    #[serde(default)]
    pub added_mass: Option<AddedMassPrimes>,
    /// Rudder lift gradient coefficient f_α [1/rad]; when absent, Fujii's formula ([`fujii_f_alpha`]).
    #[serde(default)]
    pub f_alpha: Option<f64>,
    /// The motions to invert (`[[target.motion]]`).
    #[serde(default)]
    pub motion: Vec<MotionTarget>,
}

/// A targets file: `[[target]]` tables.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TargetsFile {
    pub target: Vec<TargetShip>,
}

/// Added masses from the empirical formulas of Zhou, Yan & Feng (1983) (paper 003 ref. [24]), in MMG
/// primes. They give m'_x 0.0231, m'_y 0.224, J'_z 0.0112 for KVLCC2 (published 0.022, 0.223, 0.011).
pub fn zhou_added_mass(lpp_m: f64, beam_m: f64, draft_m: f64, cb: f64) -> AddedMassPrimes {
    let lb = lpp_m / beam_m;
    let db = draft_m / beam_m;
    let m_prime = 2.0 * cb * beam_m / lpp_m; // m ÷ ½ρL²d
    let mx_over_m = (0.398 + 11.97 * cb * (1.0 + 3.73 * db) - 2.89 * cb * lb * (1.0 + 1.13 * db)
        + 0.175 * cb * lb * lb * (1.0 + 0.541 * db)
        - 1.107 * lb * db)
        / 100.0;
    let my_over_m = 0.882 - 0.54 * cb * (1.0 - 1.6 * db) - 0.156 * (1.0 - 0.673 * cb) * lb
        + 0.826 * db * lb * (1.0 - 0.678 * db)
        - 0.638 * cb * db * lb * (1.0 - 0.669 * db);
    let kz_over_l =
        (33.0 - 76.85 * cb * (1.0 - 0.784 * cb) + 3.43 * lb * (1.0 - 0.63 * cb)) / 100.0;
    AddedMassPrimes {
        m_x: mx_over_m * m_prime,
        m_y: my_over_m * m_prime,
        j_z: kz_over_l * kz_over_l * m_prime,
    }
}

/// Fujii's rudder lift gradient f_α = 6.13 Λ / (Λ + 2.25) with the aspect ratio Λ = H_R² / A_R.
pub fn fujii_f_alpha(rudder_span_m: f64, rudder_area_m2: f64) -> f64 {
    let aspect = rudder_span_m * rudder_span_m / rudder_area_m2;
    6.13 * aspect / (aspect + 2.25)
}

/// Schoenherr's flat-plate friction line 0.242/√C_F = log10(Re C_F), solved by fixed-point iteration.
pub fn schoenherr_cf(reynolds: f64) -> f64 {
    let mut cf = 0.075 / (reynolds.log10() - 2.0).powi(2); // ITTC-57 as the start
    for _ in 0..50 {
        let next = (0.242 / (reynolds * cf).log10()).powi(2);
        if (next - cf).abs() < 1e-14 {
            return next;
        }
        cf = next;
    }
    cf
}

/// Straight-run resistance R'_0 = R_0 / (½ρ L d U0²) from Schoenherr friction, the form factor of
/// Watanabe (1 + k, k = −0.095 + 25.6 C_B / ((L/B)² √(B/d))) and Denny–Mumford's wetted surface
/// S = 1.7 L d + ∇/d. No correlation allowance. KVLCC2 full scale gives 0.0073 (the model-scale
/// value of Yasukawa & Yoshimura is 0.022: friction falls with the Reynolds number).
pub fn resistance_prime(lpp_m: f64, beam_m: f64, draft_m: f64, cb: f64, u0_m_s: f64) -> f64 {
    let re = u0_m_s * lpp_m / NU_SEA_M2_S;
    let cf = schoenherr_cf(re);
    let k = -0.095 + 25.6 * cb / ((lpp_m / beam_m).powi(2) * (beam_m / draft_m).sqrt());
    let volume = cb * lpp_m * beam_m * draft_m;
    let wetted = 1.7 * lpp_m * draft_m + volume / draft_m;
    (1.0 + k) * cf * wetted / (lpp_m * draft_m)
}

impl TargetShip {
    /// Checks the particulars: positive lengths and speeds, 0 < C_B ≤ 1, t_P in [0, 1), each within
    /// the physical ranges of a data set's `[ship]` ([`shipid_io::dataset::SHIP_RANGES`]), the hull's
    /// proportions as `shipid_io::dataset::check_ship` checks them, a displacement ship's Froude number
    /// ([`MAX_FROUDE`]) and a propeller and rudder that fit the hull.
    pub fn validate(&self) -> Result<(), InverseError> {
        let bad = |key: &'static str, value: f64, reason: String| InverseError::Target {
            target: self.name.clone(),
            key,
            value,
            reason,
        };
        for (key, v) in [
            ("lpp_m", self.lpp_m),
            ("beam_m", self.beam_m),
            ("draft_m", self.draft_m),
            ("propeller_diameter_m", self.propeller_diameter_m),
            ("rudder_span_m", self.rudder_span_m),
            ("rudder_area_m2", self.rudder_area_m2),
            ("u0_m_s", self.u0_m_s),
            ("rudder_rate_deg_s", self.rudder_rate_deg_s),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(key, v, "must be finite and positive".into()));
            }
        }
        if !(self.cb > 0.0 && self.cb <= 1.0) {
            return Err(bad("cb", self.cb, "must be in (0, 1]".into()));
        }
        // The ranges of a data set's [ship] (one table of them for every command), by the targets
        // file's keys.
        for (key, v) in [
            ("lpp_m", self.lpp_m),
            ("beam_m", self.beam_m),
            ("draft_m", self.draft_m),
            ("u0_m_s", self.u0_m_s),
            ("rudder_rate_deg_s", self.rudder_rate_deg_s),
        ] {
            let ship_key = key.split('_').next().unwrap_or(key);
            let ship_key = if key == "rudder_rate_deg_s" {
                "rudder_rate"
            } else {
                ship_key
            };
            if let Some((_, lo, hi, unit)) = shipid_io::dataset::SHIP_RANGES
                .iter()
                .find(|(k, ..)| *k == ship_key)
                && !(*lo..=*hi).contains(&v)
            {
                return Err(bad(
                    key,
                    v,
                    format!(
                        "outside the physical range {lo} … {hi} {unit} of a ship (a wrong unit?)"
                    ),
                ));
            }
        }
        let froude = self.u0_m_s / (G_M_S2 * self.lpp_m).sqrt();
        if froude > MAX_FROUDE {
            return Err(bad(
                "u0_m_s",
                self.u0_m_s,
                format!(
                    "gives a Froude number U0/√(gL) of {froude:.3} for lpp_m = {} m, above {MAX_FROUDE}: \
                     no displacement ship (the 20 ships of the database and the MMG model's hull \
                     forces are of displacement ships at Fn ≈ 0.1 … 0.3); a wrong unit (knots, km/h)?",
                    self.lpp_m
                ),
            ));
        }
        if !(self.xg_m.is_finite() && self.xg_m.abs() < 0.5 * self.lpp_m) {
            return Err(bad(
                "xg_m",
                self.xg_m,
                "must be finite and within the ship".into(),
            ));
        }
        // The hull's proportions as a data set's [ship] is checked (L/B, B/T, ∇/(LBT), k_zz/L), the
        // message's key mapped to the targets file's.
        if let Err(e) = shipid_io::dataset::check_ship(std::path::Path::new(""), &self.ship()) {
            let (key, value) = match &e.location {
                shipid_io::error::Location::Key(k) if k == "ship.draft" => {
                    ("draft_m", self.draft_m)
                }
                shipid_io::error::Location::Key(k) if k == "ship.displacement" => ("cb", self.cb),
                shipid_io::error::Location::Key(k) if k == "ship.xg" => ("xg_m", self.xg_m),
                shipid_io::error::Location::Key(k) if k == "ship.u0" => ("u0_m_s", self.u0_m_s),
                shipid_io::error::Location::Key(k) if k == "ship.rudder_rate" => {
                    ("rudder_rate_deg_s", self.rudder_rate_deg_s)
                }
                shipid_io::error::Location::Key(k) if k == "ship.beam" => ("beam_m", self.beam_m),
                _ => ("lpp_m", self.lpp_m),
            };
            return Err(bad(key, value, e.message));
        }
        // A propeller or rudder larger than the hull is a wrong unit: the MMG forces scale with
        // D_P² and A_R, and no ship of the database carries one.
        for (key, v, limit, what) in [
            (
                "propeller_diameter_m",
                self.propeller_diameter_m,
                MAX_APPENDAGE_OVER_DRAFT * self.draft_m,
                "draft_m",
            ),
            (
                "rudder_span_m",
                self.rudder_span_m,
                MAX_APPENDAGE_OVER_DRAFT * self.draft_m,
                "draft_m",
            ),
            (
                "rudder_area_m2",
                self.rudder_area_m2,
                MAX_RUDDER_AREA_RATIO * self.lpp_m * self.draft_m,
                "lpp_m × draft_m",
            ),
        ] {
            if v > limit {
                return Err(bad(
                    key,
                    v,
                    format!(
                        "larger than {limit} ({} × {what}): no ship's appendage; a wrong unit?",
                        if key == "rudder_area_m2" {
                            MAX_RUDDER_AREA_RATIO
                        } else {
                            MAX_APPENDAGE_OVER_DRAFT
                        }
                    ),
                ));
            }
        }
        if !(self.t_p.is_finite() && (0.0..1.0).contains(&self.t_p)) {
            return Err(bad("t_p", self.t_p, "must be in [0, 1)".into()));
        }
        for (i, v) in self.k_t.iter().enumerate() {
            if !v.is_finite() {
                return Err(bad(
                    ["k_t[0]", "k_t[1]", "k_t[2]"][i],
                    *v,
                    "must be finite".into(),
                ));
            }
        }
        // As a data set's `propeller.k_t`: a propeller pushes ahead at J = 0 (bollard pull). With
        // K_T ≤ 0 there no rate balances the resistance, and every simulated ship has no MMG model.
        if self.k_t[0] <= 0.0 {
            return Err(bad(
                "k_t[0]",
                self.k_t[0],
                "K_T at J = 0 (the first coefficient of k_t = [k0, k1, k2], K_T = k0 + k1 J + \
                 k2 J²) must be positive: a propeller pushes ahead at the bollard (a data set's \
                 propeller.k_t requires k0 > 0)"
                    .into(),
            ));
        }
        if let Some(f) = self.f_alpha
            && !(f.is_finite() && f > 0.0)
        {
            return Err(bad("f_alpha", f, "must be finite and positive".into()));
        }
        if let Some(a) = self.added_mass {
            // The ship's own mass and moment of inertia in the same primes (m ÷ ½ρL²d, and
            // m L² ÷ ½ρL⁴d, the scale a data set's N_rdot is bounded by): an added mass beyond
            // [`MAX_ADDED_MASS_OVER_MASS`] times it is a wrong unit (kg for the prime), as a data
            // set's `added_mass` is checked.
            let m_prime = 2.0 * self.cb * self.beam_m / self.lpp_m;
            for (key, v) in [
                ("added_mass.m_x", a.m_x),
                ("added_mass.m_y", a.m_y),
                ("added_mass.j_z", a.j_z),
            ] {
                if !(v.is_finite() && v >= 0.0) {
                    return Err(bad(key, v, "must be finite and non-negative".into()));
                }
                let limit = MAX_ADDED_MASS_OVER_MASS * m_prime;
                if v > limit {
                    return Err(bad(
                        key,
                        v,
                        format!(
                            "more than {MAX_ADDED_MASS_OVER_MASS} × the ship's own mass in the same \
                             primes (m' = 2 C_B B/L = {m_prime:.4}, so at most {limit:.2}); real \
                             hulls have 0.02 … 1 times: a wrong unit (kg instead of the prime \
                             ÷ ½ρL²d)?"
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Whether the target can be simulated at all with database coefficients `c` (its mean ship):
    /// a self-propulsion point at U0 depends on the straight-run resistance, k_t, t_p and the fixed
    /// wake only, not on the hull derivatives, so a target without one gives no usable ship however
    /// the modes are drawn. Refused before any simulation, with the keys that decide it.
    pub fn check_straight_run(&self, c: &Coefficients) -> Result<(), InverseError> {
        let bad = |key: &'static str, value: f64, reason: String| InverseError::Target {
            target: self.name.clone(),
            key,
            value,
            reason,
        };
        match MmgModel::new(self.ship(), self.mmg_parameters(c)) {
            Ok(_) => Ok(()),
            Err(shipid_sim::MmgError::NoSelfPropulsionPoint { .. }) => Err(bad(
                "u0_m_s",
                self.u0_m_s,
                format!(
                    "no self-propulsion point: the propeller (k_t = [{}], t_p = {}, \
                     propeller_diameter_m = {}) cannot balance the straight-run resistance at this \
                     speed for any rate, so no ship of this target can be simulated; check k_t and t_p",
                    self.k_t.iter().map(readable).collect::<Vec<_>>().join(", "),
                    readable(&self.t_p),
                    readable(&self.propeller_diameter_m)
                ),
            )),
            Err(shipid_sim::MmgError::OutsideDomain {
                name,
                value,
                domain,
            }) => {
                // t_p and f_alpha are the target's own; the others come from the database's ships.
                let key = match name {
                    "t_p" => "t_p",
                    "f_alpha" => "f_alpha",
                    _ => "lpp_m",
                };
                Err(bad(
                    key,
                    value,
                    format!(
                        "gives the MMG parameter {name} = {}, outside its physical domain ({domain}), so no ship of this target can be simulated",
                        readable(&value)
                    ),
                ))
            }
            Err(shipid_sim::MmgError::InvalidParameter { name, value }) => {
                let key = match name {
                    "m_y" | "m_x" | "j_z" => "added_mass",
                    "propeller_diameter_m" => "propeller_diameter_m",
                    "rudder_span_m" => "rudder_span_m",
                    "rudder_area_m2" => "rudder_area_m2",
                    "xg" => "xg_m",
                    "u0" => "u0_m_s",
                    _ => "lpp_m",
                };
                Err(bad(
                    key,
                    value,
                    format!(
                        "gives the MMG parameter {name} = {}, which no MMG model accepts, so no \
                         ship of this target can be simulated",
                        readable(&value)
                    ),
                ))
            }
        }
    }

    /// The ship in the sim crate's form: ∇ = C_B L B d, ρ of sea water, k_zz = 0.25 L (paper 003 §3.2).
    pub fn ship(&self) -> Ship {
        Ship {
            lpp: self.lpp_m,
            beam: self.beam_m,
            draft: self.draft_m,
            displacement: self.cb * self.lpp_m * self.beam_m * self.draft_m,
            rho: RHO_SEA_KG_M3,
            xg: self.xg_m,
            kzz: 0.25 * self.lpp_m,
            u0: self.u0_m_s,
            rudder_rate: self.rudder_rate_deg_s,
        }
    }

    /// Added masses: the given ones or Zhou et al.'s.
    pub fn added_mass_primes(&self) -> AddedMassPrimes {
        self.added_mass
            .unwrap_or_else(|| zhou_added_mass(self.lpp_m, self.beam_m, self.draft_m, self.cb))
    }

    /// MMG parameters for database coefficients `c` (conversion in the module docs). Propeller wake
    /// (w_P0 0.40, C_1 2.0, C_2 1.6/1.1, x'_P −0.48) and x'_R −0.5 are KVLCC2's (Yasukawa & Yoshimura
    /// 2015): paper 003 gives no values for them.
    pub fn mmg_parameters(&self, c: &Coefficients) -> MmgParameters {
        let k = &c.0;
        let am = self.added_mass_primes();
        let xg = self.xg_m / self.lpp_m;
        let base = MmgParameters::kvlcc2();
        MmgParameters {
            r0: resistance_prime(self.lpp_m, self.beam_m, self.draft_m, self.cb, self.u0_m_s),
            x_vv: k[0],
            x_vr: -(k[1] + am.m_y),
            x_rr: k[2] - xg * am.m_y,
            x_vvvv: k[3],
            y_v: -k[4],
            y_r: k[5] + am.m_x,
            y_vvv: -k[6],
            y_vvr: k[7],
            y_vrr: -k[8],
            y_rrr: k[9],
            n_v: -k[10],
            n_r: k[11],
            n_vvv: -k[12],
            n_vvr: k[13],
            n_vrr: -k[14],
            n_rrr: k[15],
            m_x: am.m_x,
            m_y: am.m_y,
            j_z: am.j_z,
            propeller_diameter_m: self.propeller_diameter_m,
            t_p: self.t_p,
            k_t: self.k_t,
            rudder_span_m: self.rudder_span_m,
            rudder_area_m2: self.rudder_area_m2,
            t_r: 1.0 - k[16],
            a_h: k[17],
            x_h: k[18],
            epsilon: k[19],
            kappa: k[20],
            gamma_r_pos: k[21],
            gamma_r_neg: k[22],
            l_r: k[23],
            f_alpha: self
                .f_alpha
                .unwrap_or_else(|| fujii_f_alpha(self.rudder_span_m, self.rudder_area_m2)),
            ..base
        }
    }

    /// The MMG model of the target with coefficients `c`; `None` when it has no self-propulsion point or
    /// invalid parameters (a generated sample to drop).
    pub fn model(&self, c: &Coefficients) -> Option<MmgModel> {
        MmgModel::new(self.ship(), self.mmg_parameters(c)).ok()
    }
}
