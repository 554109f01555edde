//! The parameters of the identified MMG model, their physical bounds and their priors from the ship's
//! main particulars, each with its source. No I/O.

use shipid_io::{AddedMass, Ship};

use super::geometry::MmgGeometry;

/// Kinematic viscosity of fresh water at 15 °C [m²/s] (ITTC 2011 tables), for the friction line of
/// the resistance prior.
const NU_M2_S: f64 = 1.139e-6;
/// Form factor 1 + k of the resistance prior: a typical value of full-form single-screw ships.
const FORM_FACTOR: f64 = 1.25;

/// Upper bound of N'_vvv: the largest |N'_vvv| of the 20 ships of Yoshimura's captive-test database
/// (data/paper003/ships.toml, ship S15: N'_βββ = 0.335, N'_vvv = −N'_βββ).
pub const N_VVV_MAX: f64 = 0.335;

/// Whether a parameter enters the forces linearly given the others (the hull derivatives, solved by
/// the inner least-squares problem) or not (propeller and rudder interaction, the outer problem).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// Hull derivative: coefficient of the regressor `column` in the equation of `dof` (0 = X, 1 = Y,
    /// 2 = N).
    Hull { dof: usize, column: usize },
    /// Propeller or rudder parameter.
    Nonlinear,
}

/// One identified parameter: its name in the model file, bounds, prior and the prior's source.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamSpec {
    pub name: &'static str,
    pub role: Role,
    pub lower: f64,
    pub upper: f64,
    /// Prior centre: an empirical estimate from the main particulars.
    pub prior: f64,
    /// Prior standard deviation (the width of the neighbourhood the prior stands for).
    pub prior_sd: f64,
    pub source: String,
}

impl ParamSpec {
    /// Whether the parameter is known rather than identified (its bounds collapsed onto one value, as
    /// the recorded thrust holds the propeller's inflow: [`super::thrust::hold_inflow`]).
    pub fn is_held(&self) -> bool {
        self.lower == self.upper
    }
}

/// The 17 hull parameters in the order of the regressors of [`super::identify`]: X (R'_0 and four),
/// Y (six) and N (six).
pub const HULL_NAMES: [[&str; 6]; 3] = [
    ["r0", "x_vv", "x_vr", "x_rr", "x_vvvv", ""],
    ["y_v", "y_r", "y_vvv", "y_vvr", "y_vrr", "y_rrr"],
    ["n_v", "n_r", "n_vvv", "n_vvr", "n_vrr", "n_rrr"],
];

/// The 14 propeller and rudder parameters identified by the outer problem, in their order there.
pub const NONLINEAR_NAMES: [&str; 14] = [
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

/// Block coefficient C_b = ∇ / (L B d).
pub fn block_coefficient(ship: &Ship) -> f64 {
    ship.displacement / (ship.lpp * ship.beam * ship.draft)
}

/// m'_x from the added mass X_u̇ (MMG prime: ÷ ½ρL²d).
pub fn prime_mx(ship: &Ship, added: &AddedMass) -> f64 {
    -added.X_udot / (0.5 * ship.rho * ship.lpp * ship.lpp * ship.draft)
}

/// Every parameter of the model with its bounds and prior, hull derivatives first.
/// A regression's value for this ship held within `[lo, hi]` (where it holds, or the sign a bound
/// requires), and what the prior's source must add when it was held: the prior a user reads in the
/// model file is the one the fit used.
fn held_within(value: f64, lo: f64, hi: f64) -> (f64, String) {
    let held = value.clamp(lo, hi);
    let note = if held == value {
        String::new()
    } else {
        format!(
            "; it gives {value:.3} for this ship, outside {lo} … {hi} (the ships it was fitted on, or the sign the bound requires): held at {held}"
        )
    };
    (held, note)
}

/// The value a held prior's regression gave for this ship, read back from the note [`held_within`]
/// added to its source (the words the model file shows); `None` for a prior that is the regression's.
pub fn regression_outside(source: &str) -> Option<f64> {
    let (_, rest) = source.split_once("; it gives ")?;
    rest.split_whitespace().next()?.parse().ok()
}

pub fn priors(ship: &Ship, geometry: &MmgGeometry, added: &AddedMass) -> Vec<ParamSpec> {
    let l = ship.lpp;
    let cb = block_coefficient(ship);
    let k = 2.0 * ship.draft / l;
    let cbbl = cb * ship.beam / l;
    let pi = std::f64::consts::PI;
    const INF: f64 = f64::INFINITY;
    let kijima = "Kijima et al. 1990 (J. SNAJ 168) regression in k = 2d/L, C_b B/L";
    let lb = l / ship.beam;
    // The primary paper was not available here: the formulas are those of the cubic-form MMG hull
    // regression as transcribed in public MMG codes, which do not state its scatter. The sd is
    // therefore never narrower than the spread of published single-screw ships' derivatives that the
    // weak prior of the term stands for, nor than the regression value itself: the regression moves
    // the centre, it is not trusted to narrow the spread.
    let ym = "Yoshimura & Masumoto 2012 (medium high-speed merchant ships and fishing vessels) cubic-form \
              regression, as transcribed in public MMG codes; sd = max(|value|, the population spread of the weak prior) (scatter not stated there)";
    let ym_sd = |value: f64, population_sd: f64| value.abs().max(population_sd);
    // Yoshimura & Masumoto give Y'_vvr (−0.75) and Y'_rrr (−0.051) as bare constants: a mean over
    // their database of medium high-speed ships, which carries nothing of this ship's particulars.
    let bare_constant = "Yoshimura & Masumoto 2012 give a bare constant here (no dependence on the main \
                         particulars): weakly informative prior at 0, sd = the magnitude of published \
                         single-screw ships' derivatives";
    let weak = "no empirical estimate: weakly informative prior at 0, sd = the magnitude of published \
                single-screw ships' derivatives";
    // Sign bounds of the cubic damping terms Y'_vvv, N'_vvr, N'_rrr (≤ 0), as Y'_v and N'_r have
    // theirs. The cross-flow drag of the hull (Hooft 1994, Ocean Eng. 21:329–342),
    // −C_D ∫ (v' + ξr')|v' + ξr'| dξ and its moment, projected on the cubic form over |v'| ≤ 0.4,
    // |r'| ≤ 1 gives Y'_vvv −1.22 C_D, Y'_vrr −0.26 C_D, N'_vvr −0.27 C_D, N'_rrr −0.010 C_D, whatever
    // C_D > 0; all 20 ships of Yoshimura's captive-test database (data/paper003/ships.toml) and the
    // regression's centres have these signs. Y'_vrr has its sign there too but stays unbounded: on the
    // HSVA zig-zags the bound moved no prediction (docs/mmg.md), and an inverse-method ship just past
    // it (+0.065) would be refused for nothing. N'_vvv is 0 in the cross-flow model and 4 of those 20
    // ships have it positive (up to 0.093): only its magnitude is bounded, N_VVV_MAX. Zig-zags hardly
    // excite these terms: unbounded, they take whatever value helps the equation error and carry it
    // into a steady turn (docs/mmg.md, "What carries the turn"). Y'_vvr, Y'_rrr, N'_vrr come from the
    // hull's fore-and-aft asymmetry (zero in the cross-flow model) and take both signs there: no bound.
    // A regression that gives a value past the parameter's bound for this ship is held on the bound,
    // and its source says so.
    let hull =
        |dof: usize, column: usize, bounds: (f64, f64), prior: f64, sd: f64, source: &str| {
            let (prior, note) = held_within(prior, bounds.0, bounds.1);
            ParamSpec {
                name: HULL_NAMES[dof][column],
                role: Role::Hull { dof, column },
                lower: bounds.0,
                upper: bounds.1,
                prior,
                prior_sd: sd,
                source: format!("{source}{note}"),
            }
        };
    // ITTC-1957 friction line × form factor on Mumford's wetted surface S = 1.7 L d + ∇/d, as R'_0 =
    // (1 + k) C_F S / (L d).
    let reynolds = ship.u0 * l / NU_M2_S;
    let c_f = 0.075 / (reynolds.log10() - 2.0).powi(2);
    let wetted_m2 = 1.7 * l * ship.draft + ship.displacement / ship.draft;
    let r0 = FORM_FACTOR * c_f * wetted_m2 / (l * ship.draft);
    let (taylor_w, taylor_note) = held_within(0.5 * cb - 0.05, 0.0, 0.7);
    let (epsilon, epsilon_note) = held_within(-156.2 * cbbl * cbbl + 41.6 * cbbl - 1.76, 0.6, 1.9);
    let (t_r, t_r_note) = held_within(0.45 - 0.28 * cb, 0.0, 0.7);
    let span_aspect = geometry.rudder_span_m.powi(2) / geometry.rudder_area_m2;
    let mut out = vec![
        hull(
            0,
            0,
            (0.0, 0.2),
            r0,
            0.5 * r0,
            &format!(
                "ITTC-1957 friction line at Re = U0 L/ν ({reynolds:.3e}), form factor {FORM_FACTOR}, \
                 Mumford wetted surface; sd 50 %"
            ),
        ),
        hull(
            0,
            1,
            (-INF, INF),
            1.15 * cbbl - 0.18,
            ym_sd(1.15 * cbbl - 0.18, 0.1),
            &format!("{ym}: X'_vv = 1.15 C_b B/L − 0.18"),
        ),
        hull(0, 2, (-INF, INF), 0.0, 0.2, weak),
        hull(0, 3, (-INF, INF), 0.0, 0.05, weak),
        hull(
            0,
            4,
            (-INF, INF),
            -6.68 * cbbl + 1.1,
            ym_sd(-6.68 * cbbl + 1.1, 1.0),
            &format!("{ym}: X'_vvvv = −6.68 C_b B/L + 1.1"),
        ),
        hull(
            1,
            0,
            (-INF, 0.0),
            -(0.5 * pi * k + 1.4 * cbbl),
            0.1,
            &format!("{kijima}: Y'_v = −(πk/2 + 1.4 C_b B/L)"),
        ),
        hull(
            1,
            1,
            (-INF, INF),
            prime_mx(ship, added) + 0.25 * pi * k,
            0.05,
            &format!("{kijima}: Y'_r − m'_x = πk/4"),
        ),
        hull(
            1,
            2,
            (-INF, 0.0),
            -0.185 * lb + 0.48,
            ym_sd(-0.185 * lb + 0.48, 2.0),
            &format!("{ym}: Y'_vvv = −0.185 L/B + 0.48"),
        ),
        hull(1, 3, (-INF, INF), 0.0, 0.5, bare_constant),
        hull(
            1,
            4,
            (-INF, INF),
            -(0.26 * (1.0 - cb) * lb + 0.11),
            ym_sd(0.26 * (1.0 - cb) * lb + 0.11, 0.5),
            &format!("{ym}: Y'_vrr = −(0.26 (1 − C_b) L/B + 0.11)"),
        ),
        hull(1, 5, (-INF, INF), 0.0, 0.1, bare_constant),
        hull(2, 0, (-INF, INF), -k, 0.05, &format!("{kijima}: N'_v = −k")),
        hull(
            2,
            1,
            (-INF, 0.0),
            -0.54 * k + k * k,
            0.02,
            &format!("{kijima}: N'_r = −0.54k + k²"),
        ),
        hull(
            2,
            2,
            (-INF, N_VVV_MAX),
            0.69 * cb - 0.66,
            ym_sd(0.69 * cb - 0.66, 0.2),
            &format!("{ym}: N'_vvv = −(−0.69 C_b + 0.66)"),
        ),
        hull(
            2,
            3,
            (-INF, 0.0),
            1.55 * cbbl - 0.76,
            ym_sd(1.55 * cbbl - 0.76, 0.3),
            &format!("{ym}: N'_vvr = 1.55 C_b B/L − 0.76"),
        ),
        hull(
            2,
            4,
            (-INF, INF),
            -0.075 * (1.0 - cb) * lb - 0.098,
            ym_sd(0.075 * (1.0 - cb) * lb + 0.098, 0.1),
            &format!("{ym}: N'_vrr = −0.075 (1 − C_b) L/B − 0.098"),
        ),
        hull(
            2,
            5,
            (-INF, 0.0),
            0.25 * cbbl - 0.056,
            ym_sd(0.25 * cbbl - 0.056, 0.05),
            &format!("{ym}: N'_rrr = 0.25 C_b B/L − 0.056"),
        ),
    ];
    let nl = |name: &'static str, bounds: (f64, f64), prior: f64, sd: f64, source: String| {
        let (prior, note) = held_within(prior, bounds.0, bounds.1);
        ParamSpec {
            name,
            role: Role::Nonlinear,
            lower: bounds.0,
            upper: bounds.1,
            prior,
            prior_sd: sd,
            source: format!("{source}{note}"),
        }
    };
    out.extend([
        nl(
            "t_p",
            (0.0, 0.5),
            0.6 * taylor_w,
            0.1,
            format!("Schoenherr t_P = k w_P0 with k = 0.6 (single screw) on Taylor's w_P0{taylor_note}"),
        ),
        nl(
            "w_p0",
            (0.0, 0.8),
            taylor_w,
            0.1,
            format!("Taylor (single screw): w_P0 = 0.5 C_b − 0.05{taylor_note}"),
        ),
        nl(
            "c1",
            (0.0, 10.0),
            3.0,
            2.0,
            "no empirical estimate: weakly informative 3 ± 2".into(),
        ),
        nl(
            "c2_pos",
            (0.5, 3.0),
            1.3,
            0.4,
            "no empirical estimate: 1.3 ± 0.4 on both sides (no asymmetry assumed)".into(),
        ),
        nl(
            "c2_neg",
            (0.5, 3.0),
            1.3,
            0.4,
            "no empirical estimate: 1.3 ± 0.4 on both sides (no asymmetry assumed)".into(),
        ),
        nl(
            "epsilon",
            (0.5, 2.0),
            epsilon,
            0.2,
            format!("{kijima}: ε = −156.2 (C_b B/L)² + 41.6 C_b B/L − 1.76{epsilon_note}"),
        ),
        nl(
            "kappa",
            (0.0, 1.0),
            0.5,
            0.2,
            "usual MMG value κ = 0.5 (Yasukawa & Yoshimura 2015 use it for KVLCC2)".into(),
        ),
        nl(
            "gamma_r_neg",
            (0.05, 1.5),
            0.5,
            0.25,
            "no empirical estimate: 0.5 ± 0.25 on both sides".into(),
        ),
        nl(
            "gamma_r_pos",
            (0.05, 1.5),
            0.5,
            0.25,
            "no empirical estimate: 0.5 ± 0.25 on both sides".into(),
        ),
        nl(
            "l_r",
            (-1.5, -0.3),
            2.0 * geometry.rudder_x_m / l,
            0.3,
            "no empirical estimate: about twice x'_R, ± 0.3".into(),
        ),
        nl(
            "t_r",
            (0.0, 0.8),
            t_r,
            0.15,
            format!("{kijima}: 1 − t_R = 0.28 C_b + 0.55{t_r_note}"),
        ),
        nl(
            "a_h",
            (0.0, 1.0),
            0.3,
            0.2,
            "no empirical estimate: 0.3 ± 0.2".into(),
        ),
        nl(
            "x_h",
            (-0.8, -0.2),
            -(0.4 + 0.1 * cb),
            0.1,
            format!("{kijima}: x'_H = −(0.4 + 0.1 C_b)"),
        ),
        nl(
            "f_alpha",
            (1.0, 6.5),
            6.13 * span_aspect / (span_aspect + 2.25),
            0.5,
            format!(
                "Fujii's formula f_α = 6.13 Λ/(Λ + 2.25) with the rudder aspect ratio Λ = H_R²/A_R = {span_aspect:.3}"
            ),
        ),
    ]);
    out
}
