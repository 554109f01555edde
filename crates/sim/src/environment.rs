//! The environment a recording carries as a known input: its recorded true wind and current
//! (`docs/data-format.md`, columns `wind_speed`, `wind_from`, `current_speed`, `current_from`) and the
//! ship's windage (`[windage]` of the data set).
//!
//! - [`Aerodynamics`] turns a windage table into the aerodynamic force on the ship for a relative wind.
//! - [`KnownEnvironment`] is one recording's wind and current as functions of time (linear between
//!   samples, held beyond the ends), with the force and the water-relative state they imply.
//! - [`WithEnvironment`] wraps any [`Dynamics`] so that a simulation or replay of that recording feels
//!   its wind and current at every RK4 stage ([`Dynamics::accelerations_at`]).
//!
//! Conventions: both flows are given by their speed and the earth-fixed direction they come FROM,
//! clockwise from north. The `*_at(t_s, …)` methods take *simulation* time: seconds from the
//! environment's origin, the recording time where a simulation or replay starts (the first sample,
//! or the one [`KnownEnvironment::replay_from`] names). The recording-level helpers
//! ([`KnownEnvironment::water_relative`], [`KnownEnvironment::wind_accelerations`]) take recording
//! times.

use shipid_io::{AddedMass, Recording, Ship, WindModel, Windage};
use thiserror::Error;

use crate::dynamics::{Dynamics, DynamicsError, Input, MassMatrix, State};

/// Why a recording's environment cannot be used as a known input.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum EnvironmentError {
    /// The recording has wind columns but no windage was given to turn them into forces.
    #[error(
        "the recording has a recorded wind (`wind_speed`, `wind_from`) but the data set has no [windage] table to turn it into forces (give frontal_area_m2 and lateral_area_m2, docs/data-format.md)"
    )]
    NoWindage,
    /// The wind-coefficient model cannot be used with the windage given.
    #[error("windage model `{model}`: {reason}")]
    Windage { model: &'static str, reason: String },
    /// A recorded series is not as long as the recording's time.
    #[error("recorded {what} has {got} samples for {want} times")]
    Length {
        what: &'static str,
        got: usize,
        want: usize,
    },
}

/// Aerodynamic force model of a ship above water: the wind-coefficient model of its windage table.
#[derive(Debug, Clone, PartialEq)]
pub struct Aerodynamics {
    windage: Windage,
    /// Reference length of the yaw moment [m] (length overall; L_pp when not given).
    length_m: f64,
    /// Isherwood's ship parameters, when that is the model.
    isherwood: Option<IsherwoodShip>,
}

/// Fossen's mid-range merchant-ship constants [c_x, c_y, c_n] (Fossen 2011, §8.1: c_x 0.50–0.90,
/// c_y 0.70–0.95, c_n 0.05–0.20).
pub const FOSSEN_COEFFICIENTS: [f64; 3] = [0.70, 0.825, 0.125];

/// The regression constants of Isherwood (1973), "Wind resistance of merchant ships", Trans. RINA 115,
/// 327–338, Tables 1–3, as tabulated in the MSS toolbox (Fossen, `GNC/isherwood72.m`, revision
/// 2008-11-20), per 10° of the relative wind angle from 0° (ahead) to 180° (astern). Rows:
/// [A0 … A6] of C_X, [B0 … B6] of C_Y, [C0 … C5, 0] of C_N, with the regressors
/// [1, 2A_L/L², 2A_F/B², L/B, S/L, C/L, M] for C_X, [1, 2A_L/L², 2A_F/B², L/B, S/L, C/L, A_SS/A_L] for
/// C_Y and [1, 2A_L/L², 2A_F/B², L/B, S/L, C/L] for C_N (L length overall, B beam, S perimeter, C the
/// lateral centroid's distance from the bow, M the mast groups).
#[rustfmt::skip]
#[allow(clippy::approx_constant)] // A1 = 3.14 at 150° is Isherwood's regression constant, not π.
pub const ISHERWOOD_TABLES: [[[f64; 7]; 3]; 19] = [
    [[2.152, -5.00, 0.243, -0.164, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]],
    [[1.714, -3.33, 0.145, -0.121, 0.0, 0.0, 0.0], [0.096, 0.22, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0596, 0.061, 0.0, 0.0, 0.0, -0.074, 0.0]],
    [[1.818, -3.97, 0.211, -0.143, 0.0, 0.0, 0.033], [0.176, 0.71, 0.0, 0.0, 0.0, 0.0, 0.0], [0.1106, 0.204, 0.0, 0.0, 0.0, -0.170, 0.0]],
    [[1.965, -4.81, 0.243, -0.154, 0.0, 0.0, 0.041], [0.225, 1.38, 0.0, 0.023, 0.0, -0.29, 0.0], [0.2258, 0.245, 0.0, 0.0, 0.0, -0.380, 0.0]],
    [[2.333, -5.99, 0.247, -0.190, 0.0, 0.0, 0.042], [0.329, 1.82, 0.0, 0.043, 0.0, -0.59, 0.0], [0.2017, 0.457, 0.0, 0.0067, 0.0, -0.472, 0.0]],
    [[1.726, -6.54, 0.189, -0.173, 0.348, 0.0, 0.048], [1.164, 1.26, 0.121, 0.0, -0.242, -0.95, 0.0], [0.1759, 0.573, 0.0, 0.0118, 0.0, -0.523, 0.0]],
    [[0.913, -4.68, 0.0, -0.104, 0.482, 0.0, 0.052], [1.163, 0.96, 0.101, 0.0, -0.177, -0.88, 0.0], [0.1925, 0.480, 0.0, 0.0115, 0.0, -0.546, 0.0]],
    [[0.457, -2.88, 0.0, -0.068, 0.346, 0.0, 0.043], [0.916, 0.53, 0.069, 0.0, 0.0, -0.65, 0.0], [0.2133, 0.315, 0.0, 0.0081, 0.0, -0.526, 0.0]],
    [[0.341, -0.91, 0.0, -0.031, 0.0, 0.0, 0.032], [0.844, 0.55, 0.082, 0.0, 0.0, -0.54, 0.0], [0.1827, 0.254, 0.0, 0.0053, 0.0, -0.443, 0.0]],
    [[0.355, 0.0, 0.0, 0.0, -0.247, 0.0, 0.018], [0.889, 0.0, 0.138, 0.0, 0.0, -0.66, 0.0], [0.2627, 0.0, 0.0, 0.0, 0.0, -0.508, 0.0]],
    [[0.601, 0.0, 0.0, 0.0, -0.372, 0.0, -0.020], [0.799, 0.0, 0.155, 0.0, 0.0, -0.55, 0.0], [0.2102, 0.0, -0.0195, 0.0, 0.0335, -0.492, 0.0]],
    [[0.651, 1.29, 0.0, 0.0, -0.582, 0.0, -0.031], [0.797, 0.0, 0.151, 0.0, 0.0, -0.55, 0.0], [0.1567, 0.0, -0.0258, 0.0, 0.0497, -0.457, 0.0]],
    [[0.564, 2.54, 0.0, 0.0, -0.748, 0.0, -0.024], [0.996, 0.0, 0.184, 0.0, -0.212, -0.66, 0.34], [0.0801, 0.0, -0.0311, 0.0, 0.0740, -0.396, 0.0]],
    [[-0.142, 3.58, 0.0, 0.047, -0.700, 0.0, -0.028], [1.014, 0.0, 0.191, 0.0, -0.280, -0.69, 0.44], [-0.0189, 0.0, -0.0488, 0.0101, 0.1128, -0.420, 0.0]],
    [[-0.677, 3.64, 0.0, 0.069, -0.529, 0.0, -0.032], [0.784, 0.0, 0.166, 0.0, -0.209, -0.53, 0.38], [0.0256, 0.0, -0.0422, 0.0100, 0.0889, -0.463, 0.0]],
    [[-0.723, 3.14, 0.0, 0.064, -0.475, 0.0, -0.032], [0.536, 0.0, 0.176, -0.029, -0.163, 0.0, 0.27], [0.0552, 0.0, -0.0381, 0.0109, 0.0689, -0.476, 0.0]],
    [[-2.148, 2.56, 0.0, 0.081, 0.0, 1.27, -0.027], [0.251, 0.0, 0.106, -0.022, 0.0, 0.0, 0.0], [0.0881, 0.0, -0.0306, 0.0091, 0.0366, -0.415, 0.0]],
    [[-2.707, 3.97, -0.175, 0.126, 0.0, 1.81, 0.0], [0.125, 0.0, 0.046, -0.012, 0.0, 0.0, 0.0], [0.0851, 0.0, -0.0122, 0.0025, 0.0, -0.220, 0.0]],
    [[-2.529, 3.76, -0.174, 0.128, 0.0, 1.55, 0.0], [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]],
];

/// The regressors of Isherwood's tables for one ship (see [`ISHERWOOD_TABLES`]).
#[derive(Debug, Clone, Copy, PartialEq)]
struct IsherwoodShip {
    /// [1, 2A_L/L², 2A_F/B², L/B, S/L, C/L] and the last regressor of C_X (M) and of C_Y (A_SS/A_L).
    common: [f64; 6],
    masts: f64,
    superstructure: f64,
}

impl IsherwoodShip {
    /// Isherwood's coefficients as he gives them, for a relative wind `gamma_deg` in [0°, 180°] off the
    /// bow: C_X (positive pushing the ship forward), the side force C_Y and yaw moment C_N (both
    /// positive to leeward and bow to leeward), interpolated linearly between the 10° rows.
    fn tabulated(&self, gamma_deg: f64) -> [f64; 3] {
        let x = (gamma_deg / 10.0).clamp(0.0, 18.0);
        let k = (x.floor() as usize).min(17);
        let w = x - k as f64;
        let row = |i: usize, which: usize, last: f64| {
            let t = &ISHERWOOD_TABLES[i][which];
            let mut v = last * t[6];
            for (j, r) in self.common.iter().enumerate() {
                v += t[j] * r;
            }
            v
        };
        let at =
            |which: usize, last: f64| (1.0 - w) * row(k, which, last) + w * row(k + 1, which, last);
        // Isherwood's C_X is a resistance (positive aft); MSS negates it (Blendermann's signs).
        [-at(0, self.masts), at(1, self.superstructure), at(2, 0.0)]
    }
}

impl Aerodynamics {
    /// The force model of `windage` for `ship`, checked against what its wind model needs: Isherwood
    /// (1973) needs `length_overall_m` and `lateral_perimeter_m`; Fujiwara et al. (2005) is refused
    /// (see [`WindModel::Fujiwara2005`] in `docs/data-format.md`).
    pub fn new(windage: &Windage, ship: &Ship) -> Result<Aerodynamics, EnvironmentError> {
        let length_m = windage.length_overall_m.unwrap_or(ship.lpp);
        let missing = |key: &str, what: &str| EnvironmentError::Windage {
            model: windage.model.name(),
            reason: format!("needs the [windage] key `{key}` ({what})"),
        };
        let isherwood = match windage.model {
            WindModel::Fossen => None,
            WindModel::Isherwood1973 => {
                let loa = windage.length_overall_m.ok_or_else(|| {
                    missing("length_overall_m", "length overall [m], Isherwood's L")
                })?;
                let perimeter = windage.lateral_perimeter_m.ok_or_else(|| {
                    missing(
                        "lateral_perimeter_m",
                        "perimeter of the lateral projection above water [m], Isherwood's S",
                    )
                })?;
                // Isherwood's C counts from the bow; midship is taken at half the length overall.
                let c_from_bow = 0.5 * loa - windage.lateral_centre_x_m;
                Some(IsherwoodShip {
                    common: [
                        1.0,
                        2.0 * windage.lateral_area_m2 / (loa * loa),
                        2.0 * windage.frontal_area_m2 / (ship.beam * ship.beam),
                        loa / ship.beam,
                        perimeter / loa,
                        c_from_bow / loa,
                    ],
                    masts: f64::from(windage.mast_groups.unwrap_or(0)),
                    superstructure: windage.superstructure_lateral_area_m2.unwrap_or(0.0)
                        / windage.lateral_area_m2,
                })
            }
            WindModel::Fujiwara2005 => {
                return Err(EnvironmentError::Windage {
                    model: windage.model.name(),
                    reason: "not available in this build: its regression constants are not yet \
                             checked against a published source; use model = \"isherwood1973\" or \
                             \"fossen\""
                        .into(),
                });
            }
        };
        Ok(Aerodynamics {
            length_m,
            windage: windage.clone(),
            isherwood,
        })
    }

    /// The windage this model was built from.
    pub fn windage(&self) -> &Windage {
        &self.windage
    }

    /// Force coefficients [C_X, C_Y, C_N] for the relative wind coming from `gamma_rad` (0 from ahead,
    /// +90° from starboard), with X = q A_F C_X, Y = q A_L C_Y, N = q A_L L C_N about midship. For
    /// Fossen's model N is about the lateral centre ([`Aerodynamics::force`] adds its lever); Isherwood's
    /// regression holds the centroid's position already. Signs are the project's: a head wind gives
    /// C_X < 0, a wind from starboard C_Y < 0 (to port), one from the starboard bow C_N < 0.
    pub fn coefficients(&self, gamma_rad: f64) -> [f64; 3] {
        match &self.isherwood {
            Some(ish) => {
                // Isherwood tabulates 0–180°; a wind from port mirrors one from starboard.
                let g = gamma_rad.sin().atan2(gamma_rad.cos());
                let side = if g < 0.0 { -1.0 } else { 1.0 };
                let [cx, cy, cn] = ish.tabulated(g.abs().to_degrees());
                [cx, -side * cy, -side * cn]
            }
            None => {
                let [cx, cy, cn] = FOSSEN_COEFFICIENTS;
                [
                    -cx * gamma_rad.cos(),
                    -cy * gamma_rad.sin(),
                    -cn * (2.0 * gamma_rad).sin(),
                ]
            }
        }
    }

    /// Aerodynamic [X, Y, N] [N, N, N m] about midship for the air velocity relative to the ship in
    /// body axes `[u_a, v_a]` [m/s] (the velocity of the air past the ship: a head wind has u_a < 0).
    pub fn force(&self, relative_air_body: [f64; 2]) -> [f64; 3] {
        let [ua, va] = relative_air_body;
        let q = 0.5 * self.windage.air_density_kg_m3 * (ua * ua + va * va);
        if q == 0.0 {
            return [0.0; 3];
        }
        // The direction the relative wind comes from: opposite to the air's velocity past the ship.
        let gamma = (-va).atan2(-ua);
        let [cx, cy, cn] = self.coefficients(gamma);
        let y = q * self.windage.lateral_area_m2 * cy;
        let lever_m = if self.isherwood.is_some() {
            0.0
        } else {
            self.windage.lateral_centre_x_m
        };
        [
            q * self.windage.frontal_area_m2 * cx,
            y,
            q * self.windage.lateral_area_m2 * self.length_m * cn + lever_m * y,
        ]
    }
}

/// The windage assumed when a recording has a wind but its data set no `[windage]` table: the hull
/// above water of a loaded tanker (freeboard 0.44 × draft, as KVLCC2: depth 30.0 m, draft 20.8 m), no
/// superstructure, Fossen's coefficients. Every command that uses it says so.
pub fn assumed_windage(ship: &Ship) -> Windage {
    let freeboard_m = (30.0 - 20.8) / 20.8 * ship.draft;
    Windage {
        frontal_area_m2: ship.beam * freeboard_m,
        lateral_area_m2: ship.lpp * freeboard_m,
        lateral_centre_x_m: 0.0,
        model: WindModel::Fossen,
        air_density_kg_m3: shipid_io::DEFAULT_AIR_DENSITY_KG_M3,
        length_overall_m: None,
        superstructure_lateral_area_m2: None,
        lateral_centre_height_m: None,
        height_m: None,
        lateral_perimeter_m: None,
        mast_groups: None,
        source: Some(ASSUMED_WINDAGE_SOURCE.into()),
    }
}

/// How [`assumed_windage`] is named in model files and warnings.
pub const ASSUMED_WINDAGE_SOURCE: &str = "assumed: hull above water of a loaded tanker (freeboard 0.44 × draft, no superstructure), Fossen (2011) coefficients; the data set gives no [windage]";

/// A recording's wind and current as known inputs (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct KnownEnvironment {
    /// Recording times [s] of the samples.
    t_s: Vec<f64>,
    /// Recording time [s] at simulation time 0.
    origin_s: f64,
    /// Wind velocity [north, east] [m/s] per sample, with the force model.
    wind: Option<(Vec<[f64; 2]>, Aerodynamics)>,
    /// Current velocity [north, east] [m/s] per sample.
    current: Option<Vec<[f64; 2]>>,
}

impl KnownEnvironment {
    /// The environment `rec` records, `None` when it records neither wind nor current. A recorded wind
    /// needs `windage` ([`EnvironmentError::NoWindage`] otherwise: the caller decides whether to assume
    /// [`assumed_windage`] and say so).
    pub fn of_recording(
        rec: &Recording,
        windage: Option<&Windage>,
        ship: &Ship,
    ) -> Result<Option<KnownEnvironment>, EnvironmentError> {
        if rec.wind.is_none() && rec.current.is_none() {
            return Ok(None);
        }
        let n = rec.len();
        let velocities = |what: &'static str, f: &shipid_io::FlowSeries| {
            if f.speed_m_s.len() != n || f.from_rad.len() != n {
                return Err(EnvironmentError::Length {
                    what,
                    got: f.speed_m_s.len().min(f.from_rad.len()),
                    want: n,
                });
            }
            Ok((0..n).map(|i| f.velocity_earth(i)).collect::<Vec<_>>())
        };
        let wind = match &rec.wind {
            Some(w) => {
                let windage = windage.ok_or(EnvironmentError::NoWindage)?;
                Some((velocities("wind", w)?, Aerodynamics::new(windage, ship)?))
            }
            None => None,
        };
        let current = rec
            .current
            .as_ref()
            .map(|c| velocities("current", c))
            .transpose()?;
        Ok(Some(KnownEnvironment {
            t_s: rec.t.clone(),
            origin_s: rec.t.first().copied().unwrap_or(0.0),
            wind,
            current,
        }))
    }

    /// The same environment for a simulation that starts at recording time `t_start_s` [s] (a replay
    /// of a segment or window that starts there).
    pub fn replay_from(&self, t_start_s: f64) -> KnownEnvironment {
        KnownEnvironment {
            origin_s: t_start_s,
            ..self.clone()
        }
    }

    /// The recording time [s] at simulation time 0.
    pub fn origin_s(&self) -> f64 {
        self.origin_s
    }

    /// Whether a wind is recorded.
    pub fn has_wind(&self) -> bool {
        self.wind.is_some()
    }

    /// Whether a current is recorded.
    pub fn has_current(&self) -> bool {
        self.current.is_some()
    }

    /// The force model of the recorded wind.
    pub fn aerodynamics(&self) -> Option<&Aerodynamics> {
        self.wind.as_ref().map(|(_, a)| a)
    }

    /// Index and weight of the sample interval that holds simulation time `t_s` (held at the ends).
    fn locate(&self, t_s: f64) -> (usize, f64) {
        let t_s = t_s + self.origin_s;
        let n = self.t_s.len();
        if n < 2 || t_s <= self.t_s[0] {
            return (0, 0.0);
        }
        if t_s >= self.t_s[n - 1] {
            return (n - 2, 1.0);
        }
        let k = self.t_s.partition_point(|&t| t <= t_s) - 1;
        let w = (t_s - self.t_s[k]) / (self.t_s[k + 1] - self.t_s[k]);
        (k, w)
    }

    fn interpolate(&self, series: &[[f64; 2]], t_s: f64) -> [f64; 2] {
        if series.len() < 2 {
            return series.first().copied().unwrap_or([0.0; 2]);
        }
        let (k, w) = self.locate(t_s);
        let (a, b) = (series[k], series[k + 1]);
        [a[0] + w * (b[0] - a[0]), a[1] + w * (b[1] - a[1])]
    }

    /// Wind velocity [north, east] [m/s] at `t_s` (velocities, not speed and direction, are
    /// interpolated, so a wind veering through north does not spin the long way round).
    pub fn wind_at(&self, t_s: f64) -> Option<[f64; 2]> {
        self.wind.as_ref().map(|(w, _)| self.interpolate(w, t_s))
    }

    /// Current velocity [north, east] [m/s] at `t_s` (zero when none is recorded).
    pub fn current_at(&self, t_s: f64) -> [f64; 2] {
        match &self.current {
            Some(c) => self.interpolate(c, t_s),
            None => [0.0; 2],
        }
    }

    /// The current at simulation times `t_s` as a recorded flow (speed and the direction it comes
    /// from): what a simulation in this environment carries in its recording, so that its metrics
    /// are taken relative to the water as the recording's are. `None` without a current.
    pub fn current_series(&self, t_s: &[f64]) -> Option<shipid_io::FlowSeries> {
        self.current.as_ref()?;
        Some(crate::flow::flow_series(t_s, |t| self.current_at(t)))
    }

    /// The wind at simulation times `t_s` as a recorded true wind (speed and the direction it comes
    /// from), so that a simulation written as a recording carries the wind it ran in. `None` without
    /// a wind.
    pub fn wind_series(&self, t_s: &[f64]) -> Option<shipid_io::FlowSeries> {
        self.wind.as_ref()?;
        Some(crate::flow::flow_series(t_s, |t| {
            self.wind_at(t).unwrap_or([0.0; 2])
        }))
    }

    /// Rate of change of the current velocity [north, east] [m/s²] at `t_s`: the slope of the
    /// interval that holds it (zero beyond the ends).
    pub fn current_rate_at(&self, t_s: f64) -> [f64; 2] {
        let Some(c) = &self.current else {
            return [0.0; 2];
        };
        let n = self.t_s.len();
        let t_rec = t_s + self.origin_s;
        if n < 2 || t_rec < self.t_s[0] || t_rec > self.t_s[n - 1] {
            return [0.0; 2];
        }
        let (k, _) = self.locate(t_s);
        let dt = self.t_s[k + 1] - self.t_s[k];
        [(c[k + 1][0] - c[k][0]) / dt, (c[k + 1][1] - c[k][1]) / dt]
    }

    /// Aerodynamic [X, Y, N] [N, N, N m] about midship at `t_s` on a ship in over-ground state `s`.
    pub fn wind_force(&self, t_s: f64, s: &State) -> [f64; 3] {
        let Some((_, aero)) = &self.wind else {
            return [0.0; 3];
        };
        let [wn, we] = self.interpolate(&self.wind.as_ref().expect("checked above").0, t_s);
        let (sp, cp) = s.psi.sin_cos();
        aero.force([wn * cp + we * sp - s.u, -wn * sp + we * cp - s.v])
    }

    /// Current velocity in body axes [u_c, v_c] [m/s] at `t_s` and heading `psi_rad`.
    pub fn current_body(&self, t_s: f64, psi_rad: f64) -> [f64; 2] {
        let [n, e] = self.current_at(t_s);
        let (s, c) = psi_rad.sin_cos();
        [n * c + e * s, -n * s + e * c]
    }

    /// The state relative to the water at `t_s` of the over-ground state `s`.
    pub fn through_water(&self, t_s: f64, s: &State) -> State {
        let [uc, vc] = self.current_body(t_s, s.psi);
        State {
            u: s.u - uc,
            v: s.v - vc,
            ..*s
        }
    }

    /// The over-ground state at `t_s` of a ship moving through the water with `through_water`.
    pub fn over_ground(&self, t_s: f64, through_water: &State) -> State {
        let [uc, vc] = self.current_body(t_s, through_water.psi);
        State {
            u: through_water.u + uc,
            v: through_water.v + vc,
            ..*through_water
        }
    }

    /// Body-axis over-ground accelerations minus water-relative ones at `t_s` in over-ground state
    /// `s`: the rotation of the current in body axes (r v_c, −r u_c) plus its own change in time. The
    /// current is taken as uniform; the pressure gradient that accelerates a changing current would also
    /// push the hull, which is left out (recorded currents change slowly against the ship's motions).
    pub fn current_transport(&self, t_s: f64, s: &State) -> [f64; 2] {
        if self.current.is_none() {
            return [0.0; 2];
        }
        let [uc, vc] = self.current_body(t_s, s.psi);
        let [dn, de] = self.current_rate_at(t_s);
        let (sp, cp) = s.psi.sin_cos();
        [s.r * vc + dn * cp + de * sp, -s.r * uc - dn * sp + de * cp]
    }
}

impl KnownEnvironment {
    /// `rec` (a recording, or a window of it, with recording times inside this environment's) with
    /// its velocities relative to the water: what the hydrodynamics of an identified model see.
    /// Positions, heading and yaw rate are kept; recorded accelerations, which are over ground, are
    /// dropped (differentiating the water-relative velocities gives the water-relative accelerations,
    /// current transport included).
    pub fn water_relative(&self, rec: &Recording) -> Recording {
        let mut out = rec.clone();
        if self.current.is_none() {
            return out;
        }
        for i in 0..rec.len() {
            let s = State::of_recording(rec, i);
            let w = self.through_water(rec.t[i] - self.origin_s, &s);
            out.u[i] = w.u;
            out.v[i] = w.v;
        }
        out.accelerations = None;
        out
    }

    /// Per sample of `rec` (recording times), the accelerations [u̇, v̇, ṙ] the recorded wind gives the
    /// ship through `mass`: what an identification subtracts from the recorded accelerations before it
    /// fits the hydrodynamics. Zero without a recorded wind; `None` when the mass matrix is singular.
    pub fn wind_accelerations(&self, rec: &Recording, mass: &MassMatrix) -> Option<Vec<[f64; 3]>> {
        (0..rec.len())
            .map(|i| {
                let s = State::of_recording(rec, i);
                mass.solve(self.wind_force(rec.t[i] - self.origin_s, &s))
            })
            .collect()
    }
}

/// A model that feels a recording's wind and current (see the module docs). Its state is over
/// ground; time is the recording's, from its first sample.
#[derive(Debug, Clone)]
pub struct WithEnvironment<D> {
    inner: D,
    environment: KnownEnvironment,
    mass: MassMatrix,
}

impl<D: Dynamics> WithEnvironment<D> {
    /// `inner` in `environment`.
    pub fn new(inner: D, environment: KnownEnvironment) -> WithEnvironment<D> {
        let mass = MassMatrix::new(inner.ship(), inner.added_mass());
        WithEnvironment {
            inner,
            environment,
            mass,
        }
    }

    /// The wrapped model.
    pub fn inner(&self) -> &D {
        &self.inner
    }

    /// The environment.
    pub fn environment(&self) -> &KnownEnvironment {
        &self.environment
    }
}

impl<D: Dynamics> Dynamics for WithEnvironment<D> {
    /// The wrapped model's accelerations through the water at `input.t_s` (at the propeller rate
    /// the input names, a recorded one, else its own), plus the wind's force and the current's
    /// transport.
    fn accelerations_for(&self, s: &State, input: &Input) -> Result<[f64; 3], DynamicsError> {
        let env = &self.environment;
        let t_s = input.t_s;
        let water = env.through_water(t_s, s);
        let mut acc = self.inner.accelerations_for(&water, input)?;
        if env.has_wind() {
            let f = env.wind_force(t_s, s);
            let da = self
                .mass
                .solve(f)
                .ok_or_else(|| DynamicsError::OutOfDomain("singular mass matrix".into()))?;
            (0..3).for_each(|i| acc[i] += da[i]);
        }
        let [tu, tv] = env.current_transport(t_s, s);
        acc[0] += tu;
        acc[1] += tv;
        Ok(acc)
    }

    fn wrapped(&self) -> Option<&dyn Dynamics> {
        Some(&self.inner)
    }

    fn ship(&self) -> &Ship {
        self.inner.ship()
    }

    fn added_mass(&self) -> &AddedMass {
        self.inner.added_mass()
    }

    fn over_ground(&self, through_water: &State) -> State {
        self.inner
            .over_ground(&self.environment.over_ground(0.0, through_water))
    }

    fn current_velocity_earth(&self, t_s: f64) -> Option<[f64; 2]> {
        let own = self
            .environment
            .has_current()
            .then(|| self.environment.current_at(t_s));
        crate::flow::add_currents(own, self.inner.current_velocity_earth(t_s))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ship() -> Ship {
        crate::mmg::kvlcc2_ship()
    }

    fn recording(wind: Option<(f64, f64)>, current: Option<(f64, f64)>) -> Recording {
        let n = 11;
        let flow = |(speed, from_deg): (f64, f64)| shipid_io::FlowSeries {
            speed_m_s: vec![speed; n],
            from_rad: vec![f64::to_radians(from_deg); n],
        };
        Recording {
            t: (0..n).map(|i| 5.0 + i as f64).collect(),
            psi: vec![0.0; n],
            wind: wind.map(flow),
            current: current.map(flow),
            ..Recording::default()
        }
    }

    /// A head wind pushes the ship back, a wind from starboard pushes it to port; both with the
    /// windage areas' dynamic pressure.
    #[test]
    fn a_head_wind_pushes_back_and_a_beam_wind_pushes_to_lee() {
        let s = ship();
        let w = assumed_windage(&s);
        let head = KnownEnvironment::of_recording(&recording(Some((3.0, 0.0)), None), Some(&w), &s)
            .unwrap()
            .unwrap();
        let still = State::approach(0.0);
        let f = head.wind_force(0.0, &still);
        let q = 0.5 * 1.225 * 9.0;
        assert!((f[0] + q * w.frontal_area_m2 * 0.70).abs() < 1e-12, "{f:?}");
        assert!(f[1].abs() < 1e-12 && f[2].abs() < 1e-12, "{f:?}");
        let beam =
            KnownEnvironment::of_recording(&recording(Some((3.0, 90.0)), None), Some(&w), &s)
                .unwrap()
                .unwrap();
        let f = beam.wind_force(0.0, &still);
        assert!((f[1] + q * w.lateral_area_m2 * 0.825).abs() < 1e-9, "{f:?}");
    }

    /// A ship with round Isherwood regressors: L_oa 60 m, B 10 m (L/B = 6), 2A_L/L² = 0.2,
    /// 2A_F/B² = 1, S/L = 2, C/L = 0.5, one mast group, A_SS/A_L = 0.2.
    fn isherwood_ship() -> (Windage, Ship) {
        let ship = Ship {
            beam: 10.0,
            lpp: 58.0,
            ..ship()
        };
        let w = Windage {
            frontal_area_m2: 50.0,
            lateral_area_m2: 360.0,
            model: WindModel::Isherwood1973,
            length_overall_m: Some(60.0),
            lateral_perimeter_m: Some(120.0),
            mast_groups: Some(1),
            superstructure_lateral_area_m2: Some(72.0),
            ..assumed_windage(&ship)
        };
        (w, ship)
    }

    fn check_coefficients(aero: &Aerodynamics, gamma_deg: f64, expected: [f64; 3]) {
        let c = aero.coefficients(gamma_deg.to_radians());
        for i in 0..3 {
            assert!(
                (c[i] - expected[i]).abs() < 1e-12,
                "γ = {gamma_deg}°: {c:?} against {expected:?}"
            );
        }
    }

    /// Head, beam and following wind against Isherwood's table rows 0°, 90° and 180° by hand, e.g.
    /// C_X(0°) = −(2.152 − 5.00·0.2 + 0.243·1 − 0.164·6) = −0.411; C_Y(90°) = 0.889 + 0.138·1 − 0.66·0.5
    /// = 0.697 to leeward; C_N(90°) = 0.2627 − 0.508·0.5 = 0.0087 bow to leeward.
    #[test]
    fn isherwood_matches_its_table_ahead_abeam_and_astern() {
        let (w, ship) = isherwood_ship();
        let aero = Aerodynamics::new(&w, &ship).unwrap();
        check_coefficients(&aero, 0.0, [-0.411, 0.0, 0.0]);
        check_coefficients(
            &aero,
            90.0,
            [-(0.355 - 0.247 * 2.0 + 0.018), -0.697, -0.0087],
        );
        check_coefficients(
            &aero,
            180.0,
            [
                -(-2.529 + 3.76 * 0.2 - 0.174 + 0.128 * 6.0 + 1.55 * 0.5),
                0.0,
                0.0,
            ],
        );
        // Halfway between the 30° and 40° rows: the mean of both.
        let mean = |a: [f64; 3], b: [f64; 3]| {
            [
                0.5 * (a[0] + b[0]),
                0.5 * (a[1] + b[1]),
                0.5 * (a[2] + b[2]),
            ]
        };
        let c30 = aero.coefficients(30f64.to_radians());
        let c40 = aero.coefficients(40f64.to_radians());
        check_coefficients(&aero, 35.0, mean(c30, c40));
    }

    /// Port mirrors starboard: C_X(−γ) = C_X(γ), C_Y(−γ) = −C_Y(γ), C_N(−γ) = −C_N(γ), for every model.
    #[test]
    fn wind_from_port_mirrors_wind_from_starboard() {
        let (w, ship) = isherwood_ship();
        for model in [WindModel::Fossen, WindModel::Isherwood1973] {
            let aero = Aerodynamics::new(&Windage { model, ..w.clone() }, &ship).unwrap();
            for deg in (5..=175).step_by(10) {
                let g = f64::from(deg).to_radians();
                let (a, b) = (aero.coefficients(g), aero.coefficients(-g));
                assert!(
                    (a[0] - b[0]).abs() < 1e-12
                        && (a[1] + b[1]).abs() < 1e-12
                        && (a[2] + b[2]).abs() < 1e-12,
                    "{model:?} at {deg}°: {a:?} {b:?}"
                );
            }
        }
    }

    /// Isherwood's wind pushes as physics says: a head wind back, a beam wind to leeward, a wind on
    /// the bow turns the bow to leeward and one on the quarter the stern.
    #[test]
    fn isherwood_forces_have_the_signs_of_fossens() {
        let (w, ship) = isherwood_ship();
        let ish = Aerodynamics::new(&w, &ship).unwrap();
        let fossen = Aerodynamics::new(
            &Windage {
                model: WindModel::Fossen,
                ..w
            },
            &ship,
        )
        .unwrap();
        for deg in [0.0, 30.0, 60.0, 150.0, -60.0] {
            let g: f64 = f64::to_radians(deg);
            let (a, b) = (ish.coefficients(g), fossen.coefficients(g));
            for i in 0..3 {
                assert!(a[i] * b[i] >= 0.0, "{deg}°: Isherwood {a:?}, Fossen {b:?}");
            }
        }
    }

    /// Fossen's model is the one of `effects::Wind`: −c_x cos γ, −c_y sin γ, −c_n sin 2γ.
    #[test]
    fn fossen_coefficients_are_unchanged() {
        let aero = Aerodynamics::new(&assumed_windage(&ship()), &ship()).unwrap();
        for deg in [0.0, 45.0, 90.0, 135.0, 180.0, -30.0] {
            let g: f64 = f64::to_radians(deg);
            check_coefficients(
                &aero,
                deg,
                [-0.70 * g.cos(), -0.825 * g.sin(), -0.125 * (2.0 * g).sin()],
            );
        }
    }

    /// Isherwood without the keys it needs is refused naming the key; Fujiwara is refused.
    #[test]
    fn a_model_without_its_keys_is_refused_naming_the_key() {
        let (w, ship) = isherwood_ship();
        for (windage, key) in [
            (
                Windage {
                    length_overall_m: None,
                    ..w.clone()
                },
                "`length_overall_m`",
            ),
            (
                Windage {
                    lateral_perimeter_m: None,
                    ..w.clone()
                },
                "`lateral_perimeter_m`",
            ),
        ] {
            let e = Aerodynamics::new(&windage, &ship).unwrap_err().to_string();
            assert!(e.contains(key) && e.contains("isherwood1973"), "{e}");
        }
        let e = Aerodynamics::new(
            &Windage {
                model: WindModel::Fujiwara2005,
                ..w
            },
            &ship,
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("fujiwara2005") && e.contains("not available"),
            "{e}"
        );
    }

    /// Regression guard: a recorded wind without windage is refused, not silently ignored.
    #[test]
    fn a_wind_without_windage_is_refused() {
        let e = KnownEnvironment::of_recording(&recording(Some((3.0, 0.0)), None), None, &ship());
        assert_eq!(e, Err(EnvironmentError::NoWindage));
    }

    /// A current from the north moves a ship heading north backwards over ground by its speed; times
    /// count from the recording's first sample.
    #[test]
    fn a_current_from_ahead_slows_the_ship_over_ground() {
        let env = KnownEnvironment::of_recording(&recording(None, Some((0.2, 0.0))), None, &ship())
            .unwrap()
            .unwrap();
        let water = State::approach(1.0);
        let ground = env.over_ground(3.0, &water);
        assert!((ground.u - 0.8).abs() < 1e-12 && ground.v.abs() < 1e-12);
        assert_eq!(env.through_water(3.0, &ground), water);
        assert_eq!(env.current_rate_at(3.0), [0.0, 0.0]);
    }

    /// A simulation in a recorded head wind that rises halfway loses speed against the calm run only
    /// after the rise: the wind is felt at the simulation time that matches the recording's.
    #[test]
    fn a_recorded_wind_is_felt_when_the_recording_has_it() {
        let model = crate::mmg::MmgModel::kvlcc2();
        let ship = *model.ship();
        let n = 201;
        let rec = Recording {
            t: (0..n).map(|i| 100.0 + i as f64 * 0.5).collect(),
            psi: vec![0.0; n],
            wind: Some(shipid_io::FlowSeries {
                speed_m_s: (0..n).map(|i| if i < 100 { 0.0 } else { 6.0 }).collect(),
                from_rad: vec![0.0; n],
            }),
            ..Recording::default()
        };
        let env = KnownEnvironment::of_recording(&rec, Some(&assumed_windage(&ship)), &ship)
            .unwrap()
            .unwrap();
        let windy = WithEnvironment::new(&model, env.clone());
        let run = |m: &dyn Dynamics| {
            let mut straight =
                crate::control::Replay::new(vec![0.0, 100.0], vec![0.0, 0.0]).unwrap();
            crate::sim::simulate(
                m,
                &mut straight,
                State::approach(ship.u0),
                &crate::sim::SimOptions::new(100.0).with_step(0.05, 0.5),
            )
            .unwrap()
            .recording
        };
        let (calm, wind) = (run(&model), run(&windy));
        // Before the rise only the ship's own motion through still air acts (0.15 N on a ship of
        // 3 t); after it the head wind's drag is some 40 times that.
        let before = calm.u[90] - wind.u[90];
        let after = calm.u[200] - wind.u[200];
        assert!(
            before > 0.0 && after > 10.0 * before,
            "before {before}, after {after}"
        );
        // Replayed from the rise, the wind acts from the start.
        let late = WithEnvironment::new(&model, env.replay_from(150.0));
        assert!(run(&late).u[20] < calm.u[20] - 1e-4);
    }

    /// Water-relative velocities remove the recorded current; without a current nothing changes.
    #[test]
    fn water_relative_velocities_remove_the_current() {
        let mut rec = recording(None, Some((0.2, 90.0)));
        rec.u = vec![1.0; rec.len()];
        rec.v = vec![0.0; rec.len()];
        rec.r = vec![0.0; rec.len()];
        rec.x0 = vec![0.0; rec.len()];
        rec.y0 = vec![0.0; rec.len()];
        let env = KnownEnvironment::of_recording(&rec, None, &ship())
            .unwrap()
            .unwrap();
        let water = env.water_relative(&rec);
        // From the east the current sets the ship to port: over ground v = −0.2 + v_water.
        assert!((water.v[4] - 0.2).abs() < 1e-12 && (water.u[4] - 1.0).abs() < 1e-12);
        let calm = recording(None, None);
        assert_eq!(
            KnownEnvironment::of_recording(&calm, None, &ship()),
            Ok(None)
        );
    }
}
