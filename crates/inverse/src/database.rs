//! The hydrodynamic database of paper 003 Tab. 1 (`data/paper003/ships.toml`) and the map from a ship's
//! coefficients to its hull-force behaviour vector h (paper 003 eqs. 3, 6, 7).
//!
//! Conventions of the database (Yoshimura's MMG database form): drift β [rad] positive when v' < 0, i.e.
//! β ≈ −v/U, r' = r L/U positive to starboard. The hull polynomials carry the Munk added-mass terms, so the
//! "hull force" here is X'* = X'_H + R'_0 + m'_y v'_G r', Y'* = Y'_H − m'_x u' r', N'* = N'_H, with
//!
//! ```text
//! X'* = X'_ββ β² + (X'_βr − m'_y) β r' + (X'_rr + x'_G m'_y) r'² + X'_ββββ β⁴
//! Y'* = Y'_β β + (Y'_r − m'_x) r' + Y'_βββ β³ + Y'_ββr β² r' + Y'_βrr β r'² + Y'_rrr r'³
//! N'* = N'_β β + N'_r r' + N'_βββ β³ + N'_ββr β² r' + N'_βrr β r'² + N'_rrr r'³
//! ```
//! (forces ÷ ½ρLdU², moment ÷ ½ρL²dU²). Everything is linear in the 24 coefficients
//! ([`Coefficients`]), which is what lets a mode of h be mapped back to coefficients exactly.

use serde::Deserialize;

use crate::error::{InverseError, readable};

/// Number of hull derivatives (4 in X, 6 in Y, 6 in N).
pub const N_HULL: usize = 16;
/// Number of interaction coefficients (1 − t_R, a_H, x'_H, ε, κ, γ_R+, γ_R−, l'_R).
pub const N_INTERACTION: usize = 8;
/// All coefficients of one ship.
pub const N_COEF: usize = N_HULL + N_INTERACTION;
/// How often the interaction coefficients are repeated in h (paper 003 §2.2: "10 times").
pub const INTERACTION_REPEAT: usize = 10;

/// Names of the 24 coefficients in [`Coefficients`] order (the ships.toml keys).
pub const COEF_NAMES: [&str; N_COEF] = [
    "x_bb",
    "x_br_minus_my",
    "x_rr_plus_xg_my",
    "x_bbbb",
    "y_b",
    "y_r_minus_mx",
    "y_bbb",
    "y_bbr",
    "y_brr",
    "y_rrr",
    "n_b",
    "n_r",
    "n_bbb",
    "n_bbr",
    "n_brr",
    "n_rrr",
    "one_minus_t_r",
    "a_h",
    "x_h",
    "epsilon",
    "kappa",
    "gamma_r_pos",
    "gamma_r_neg",
    "l_r",
];

/// One ship of paper 003 Tab. 1, as stored in `ships.toml` (see its header for units and ambiguities).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DatabaseShip {
    pub id: String,
    pub l_over_b: f64,
    pub b_over_d: f64,
    pub cb: f64,
    pub xg_over_l_percent: f64,
    pub dp_over_d: f64,
    pub ar_over_ld_percent: f64,
    pub dp_over_h: f64,
    pub x_bb: f64,
    pub x_br_minus_my: f64,
    pub x_rr_plus_xg_my: f64,
    pub x_bbbb: f64,
    pub y_b: f64,
    pub y_r_minus_mx: f64,
    pub y_bbb: f64,
    pub y_bbr: f64,
    pub y_brr: f64,
    pub y_rrr: f64,
    pub n_b: f64,
    pub n_r: f64,
    pub n_bbb: f64,
    pub n_bbr: f64,
    pub n_brr: f64,
    pub n_rrr: f64,
    pub one_minus_t_r: f64,
    pub a_h: f64,
    pub x_h: f64,
    pub epsilon: f64,
    pub kappa: f64,
    pub gamma_r_pos: f64,
    pub gamma_r_neg: f64,
    pub l_r: f64,
}

/// The file layout of `ships.toml`: `[[ship]]` tables.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShipsFile {
    pub ship: Vec<DatabaseShip>,
}

/// The 24 database coefficients of one ship in [`COEF_NAMES`] order (database conventions, see the
/// module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coefficients(pub [f64; N_COEF]);

impl DatabaseShip {
    /// The ship's coefficients.
    pub fn coefficients(&self) -> Coefficients {
        Coefficients([
            self.x_bb,
            self.x_br_minus_my,
            self.x_rr_plus_xg_my,
            self.x_bbbb,
            self.y_b,
            self.y_r_minus_mx,
            self.y_bbb,
            self.y_bbr,
            self.y_brr,
            self.y_rrr,
            self.n_b,
            self.n_r,
            self.n_bbb,
            self.n_bbr,
            self.n_brr,
            self.n_rrr,
            self.one_minus_t_r,
            self.a_h,
            self.x_h,
            self.epsilon,
            self.kappa,
            self.gamma_r_pos,
            self.gamma_r_neg,
            self.l_r,
        ])
    }
}

/// The (β, r') sampling grid of paper 003 §3: β = −20, −15, …, 20° and r' = −0.8, −0.6, …, 0.8.
pub fn grid() -> Vec<(f64, f64)> {
    let mut g = Vec::with_capacity(81);
    for i in 0..9 {
        let beta = (-20.0 + 5.0 * i as f64).to_radians();
        for j in 0..9 {
            let r = -0.8 + 0.2 * j as f64;
            g.push((beta, r));
        }
    }
    g
}

/// Length of the behaviour vector h: 3 × 81 forces + 10 × 8 interaction coefficients = 323.
pub fn behaviour_len() -> usize {
    3 * 81 + INTERACTION_REPEAT * N_INTERACTION
}

/// Hull forces [X'*, Y'*, N'*] of `c` at drift `beta_rad` and yaw rate `r_prime` (module docs).
pub fn hull_forces(c: &Coefficients, beta_rad: f64, r_prime: f64) -> [f64; 3] {
    let k = &c.0;
    let (b, r) = (beta_rad, r_prime);
    let x = k[0] * b * b + k[1] * b * r + k[2] * r * r + k[3] * b.powi(4);
    let odd = |o: usize| {
        k[o] * b
            + k[o + 1] * r
            + k[o + 2] * b.powi(3)
            + k[o + 3] * b * b * r
            + k[o + 4] * b * r * r
            + k[o + 5] * r.powi(3)
    };
    [x, odd(4), odd(10)]
}

/// Behaviour vector h of paper 003 eq. 7: X'* on the grid, then Y'*, then N'*, then the interaction
/// coefficients repeated [`INTERACTION_REPEAT`] times.
pub fn behaviour(c: &Coefficients) -> Vec<f64> {
    let g = grid();
    let mut h = Vec::with_capacity(behaviour_len());
    for dof in 0..3 {
        for &(b, r) in &g {
            h.push(hull_forces(c, b, r)[dof]);
        }
    }
    for _ in 0..INTERACTION_REPEAT {
        h.extend_from_slice(&c.0[N_HULL..]);
    }
    h
}

/// Largest magnitude of a database coefficient. The coefficients are nondimensional (hull
/// derivatives ÷ ½ρLdU² or ½ρL²dU², interaction coefficients and lengths over L): the 20 ships of
/// paper 003 Tab. 1 lie within ±2.7. Beyond ±100 a value is a typo or a wrong unit, and its square
/// in the SVD would swamp (or overflow) every other ship's variation.
pub const MAX_COEFFICIENT_MAGNITUDE: f64 = 100.0;

/// Two ships whose 24 coefficients agree to this relative tolerance are copies: they differ by
/// rounding at most.
pub const DUPLICATE_RELATIVE_TOLERANCE: f64 = 1e-9;

/// Whether two coefficient sets agree within [`DUPLICATE_RELATIVE_TOLERANCE`].
fn same_coefficients(a: &Coefficients, b: &Coefficients) -> bool {
    a.0.iter()
        .zip(b.0)
        .all(|(x, y)| (x - y).abs() <= DUPLICATE_RELATIVE_TOLERANCE * x.abs().max(y.abs()))
}

/// Ids listed in a message: all of them up to this many, then a count.
const LISTED_IDS: usize = 40;

fn list_ids(ids: &[&str]) -> String {
    if ids.len() <= LISTED_IDS {
        ids.join(", ")
    } else {
        format!(
            "{} and {} more",
            ids[..LISTED_IDS].join(", "),
            ids.len() - LISTED_IDS
        )
    }
}

/// Checks a database: at least two ships, unique ids, all values finite, every coefficient within
/// ±[`MAX_COEFFICIENT_MAGNITUDE`] and the interaction coefficients within their physical ranges, and
/// no ship a copy of another under another id (same 24 coefficients: a copy adds no variation, weighs
/// its ship twice in the SVD, and a database of copies has no variation but rounding noise).
pub fn validate(ships: &[DatabaseShip]) -> Result<(), InverseError> {
    if ships.len() < 2 {
        return Err(InverseError::Database(format!(
            "{} ships; the SVD of variations needs at least 2",
            ships.len()
        )));
    }
    for (i, s) in ships.iter().enumerate() {
        if ships[..i].iter().any(|o| o.id == s.id) {
            return Err(InverseError::Database(format!(
                "duplicate ship id {}",
                s.id
            )));
        }
        for (name, v) in [
            ("l_over_b", s.l_over_b),
            ("b_over_d", s.b_over_d),
            ("cb", s.cb),
            ("xg_over_l_percent", s.xg_over_l_percent),
            ("dp_over_d", s.dp_over_d),
            ("ar_over_ld_percent", s.ar_over_ld_percent),
            ("dp_over_h", s.dp_over_h),
        ] {
            if !v.is_finite() {
                return Err(InverseError::Database(format!(
                    "ship {}: {name} = {} is not finite",
                    s.id,
                    readable(&v)
                )));
            }
        }
        for (name, v) in COEF_NAMES.iter().zip(s.coefficients().0) {
            if !v.is_finite() {
                return Err(InverseError::Database(format!(
                    "ship {}: {name} = {} is not finite",
                    s.id,
                    readable(&v)
                )));
            }
            if v.abs() > MAX_COEFFICIENT_MAGNITUDE {
                return Err(InverseError::Database(format!(
                    "ship {}: {name} = {} is beyond ±{MAX_COEFFICIENT_MAGNITUDE}: the database's \
                     coefficients are nondimensional (the 20 ships of paper 003 lie within ±2.7); \
                     a typo or a wrong unit?",
                    s.id,
                    readable(&v)
                )));
            }
        }
        // The interaction coefficients have physical ranges; outside them the MMG model of a
        // generated ship runs, but describes no ship (a thrust-increasing rudder, a negative wake).
        for (name, v, ok, range) in [
            (
                "one_minus_t_r",
                s.one_minus_t_r,
                s.one_minus_t_r > 0.0 && s.one_minus_t_r <= 1.0,
                "(0, 1]: t_R in [0, 1)",
            ),
            ("a_h", s.a_h, s.a_h >= 0.0, "≥ 0"),
            ("epsilon", s.epsilon, s.epsilon > 0.0, "> 0"),
            ("kappa", s.kappa, s.kappa > 0.0, "> 0"),
            ("gamma_r_pos", s.gamma_r_pos, s.gamma_r_pos > 0.0, "> 0"),
            ("gamma_r_neg", s.gamma_r_neg, s.gamma_r_neg > 0.0, "> 0"),
        ] {
            if !ok {
                return Err(InverseError::Database(format!(
                    "ship {}: {name} = {} must be in {range}",
                    s.id,
                    readable(&v)
                )));
            }
        }
    }
    // Copies under other ids, grouped by the first ship they copy.
    let coefs: Vec<Coefficients> = ships.iter().map(|s| s.coefficients()).collect();
    let mut copy_of: Vec<Option<usize>> = vec![None; ships.len()];
    let mut groups: Vec<(usize, Vec<usize>)> = Vec::new();
    for i in 0..ships.len() {
        if copy_of[i].is_some() {
            continue;
        }
        let copies: Vec<usize> = (i + 1..ships.len())
            .filter(|&j| copy_of[j].is_none() && same_coefficients(&coefs[i], &coefs[j]))
            .collect();
        for &j in &copies {
            copy_of[j] = Some(i);
        }
        if !copies.is_empty() {
            groups.push((i, copies));
        }
    }
    if !groups.is_empty() {
        let copies: usize = groups.iter().map(|(_, c)| c.len()).sum();
        let distinct = ships.len() - copies;
        let text = groups
            .iter()
            .map(|(i, c)| {
                let ids: Vec<&str> = c.iter().map(|&j| ships[j].id.as_str()).collect();
                format!(
                    "{} {} {} the same 24 coefficients as ship {}",
                    if c.len() > 1 { "ships" } else { "ship" },
                    list_ids(&ids),
                    if c.len() > 1 { "have" } else { "has" },
                    ships[*i].id
                )
            })
            .collect::<Vec<_>>()
            .join("; ");
        return Err(InverseError::Database(format!(
            "{copies} of the {} ships are copies of another under another id ({text}): a copy adds \
             no variation and weighs its ship twice in the SVD{}; remove the copies",
            ships.len(),
            if distinct < 2 {
                format!(
                    ", and with {distinct} distinct ship the variation modes would be rounding noise"
                )
            } else {
                String::new()
            }
        )));
    }
    Ok(())
}

/// The database of paper 003 Tab. 1 (`data/paper003/ships.toml`), built into the library so that
/// `shipid inverse` works from any directory without the repository.
pub const PAPER003_SHIPS_TOML: &str = include_str!("../../../data/paper003/ships.toml");
