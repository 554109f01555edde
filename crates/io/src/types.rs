//! The in-memory types every crate shares: a recording in the project's conventions, the ship, the
//! manoeuvre a recording (or a simulation) performs.

use serde::{Deserialize, Serialize};

/// One manoeuvre's time series in the project's conventions (`docs/conventions.md`):
/// SI units (s, m, rad, m/s, rad/s, rad/s²), body axes x forward / y starboard, earth axes x0 north /
/// y0 east, velocities and positions of the **midship** point, heading and yaw rate positive to
/// starboard, rudder angle positive when it turns the ship to starboard.
///
/// All vectors have the same length; `t` is strictly increasing.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Recording {
    /// Time [s].
    pub t: Vec<f64>,
    /// North position of midship [m].
    pub x0: Vec<f64>,
    /// East position of midship [m].
    pub y0: Vec<f64>,
    /// Heading [rad], unwrapped (continuous), positive to starboard.
    pub psi: Vec<f64>,
    /// Surge velocity of midship [m/s].
    pub u: Vec<f64>,
    /// Sway velocity of midship [m/s], positive to starboard.
    pub v: Vec<f64>,
    /// Yaw rate [rad/s], positive to starboard.
    pub r: Vec<f64>,
    /// Rudder angle [rad], positive turns the ship to starboard.
    pub delta: Vec<f64>,
    /// Propeller rate [1/s], when recorded.
    pub n: Option<Vec<f64>>,
    /// Propeller thrust [N], when recorded (a free-running model's dynamometer): the mmg family
    /// identifies the propeller's inflow from it (docs/mmg.md).
    pub thrust: Option<Vec<f64>>,
    /// Recorded accelerations of midship, when the source has them.
    pub accelerations: Option<Accelerations>,
    /// Recorded true wind, when the recording has `wind_speed` and `wind_from` columns.
    pub wind: Option<FlowSeries>,
    /// Recorded current, when the recording has `current_speed` and `current_from` columns.
    pub current: Option<FlowSeries>,
}

/// A recorded uniform flow (true wind, or current) per sample: its speed and the earth-fixed direction
/// it comes from, clockwise from north (0: from north, flowing south; 90°: from east). Both vectors are
/// as long as the recording.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FlowSeries {
    /// Speed [m/s], ≥ 0.
    pub speed_m_s: Vec<f64>,
    /// Direction it comes from [rad], earth-fixed, clockwise from north.
    pub from_rad: Vec<f64>,
}

impl FlowSeries {
    /// The flow's velocity [north, east] [m/s] at sample `i` (it moves away from where it comes from).
    pub fn velocity_earth(&self, i: usize) -> [f64; 2] {
        let (s, c) = self.from_rad[i].sin_cos();
        [-self.speed_m_s[i] * c, -self.speed_m_s[i] * s]
    }

    /// True when the recorded speed is zero throughout: a recorded calm, which is information (the
    /// environment was measured), unlike a missing column.
    pub fn is_calm(&self) -> bool {
        self.speed_m_s.iter().all(|&s| s == 0.0)
    }

    /// The samples `range` of the series.
    pub fn slice(&self, range: std::ops::Range<usize>) -> FlowSeries {
        FlowSeries {
            speed_m_s: self.speed_m_s[range.clone()].to_vec(),
            from_rad: self.from_rad[range].to_vec(),
        }
    }
}

/// Accelerations in body axes of the midship point.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Accelerations {
    /// Surge acceleration [m/s²].
    pub u_dot: Vec<f64>,
    /// Sway acceleration [m/s²].
    pub v_dot: Vec<f64>,
    /// Yaw acceleration [rad/s²].
    pub r_dot: Vec<f64>,
}

impl Recording {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Speed over the body's reference point [m/s].
    pub fn speed(&self, i: usize) -> f64 {
        self.u[i].hypot(self.v[i])
    }

    /// Keep the samples whose index is in `range` (used for training windows).
    pub fn slice(&self, range: std::ops::Range<usize>) -> Recording {
        let s = |x: &Vec<f64>| x[range.clone()].to_vec();
        Recording {
            t: s(&self.t),
            x0: s(&self.x0),
            y0: s(&self.y0),
            psi: s(&self.psi),
            u: s(&self.u),
            v: s(&self.v),
            r: s(&self.r),
            delta: s(&self.delta),
            n: self.n.as_ref().map(s),
            thrust: self.thrust.as_ref().map(s),
            accelerations: self.accelerations.as_ref().map(|a| Accelerations {
                u_dot: s(&a.u_dot),
                v_dot: s(&a.v_dot),
                r_dot: s(&a.r_dot),
            }),
            wind: self.wind.as_ref().map(|w| w.slice(range.clone())),
            current: self.current.as_ref().map(|c| c.slice(range.clone())),
        }
    }
}

/// Main particulars of the ship a data set describes (the `[ship]` table of a data-set file, `docs/data-format.md`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ship {
    /// Length between perpendiculars [m].
    pub lpp: f64,
    /// Beam [m].
    pub beam: f64,
    /// Draft [m].
    pub draft: f64,
    /// Displacement volume [m³].
    pub displacement: f64,
    /// Water density [kg/m³].
    pub rho: f64,
    /// Centre of gravity forward of midship [m].
    pub xg: f64,
    /// Yaw radius of gyration about the centre of gravity [m].
    pub kzz: f64,
    /// Approach speed U0 [m/s]; the speed of the prime system.
    pub u0: f64,
    /// Rudder rate [deg/s].
    pub rudder_rate: f64,
}

impl Ship {
    /// Mass [kg].
    pub fn mass_kg(&self) -> f64 {
        self.rho * self.displacement
    }

    /// Yaw moment of inertia about midship, I_zG + m x_G² [kg m²].
    pub fn iz_midship_kg_m2(&self) -> f64 {
        self.mass_kg() * (self.kzz * self.kzz + self.xg * self.xg)
    }

    /// Rudder rate [rad/s].
    pub fn rudder_rate_rad_s(&self) -> f64 {
        self.rudder_rate.to_radians()
    }
}

/// Known added-mass derivatives in SI about the data set's origin (the data set's `[added_mass]` table), as
/// derivatives (negative numbers). After loading they refer to midship.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
#[allow(non_snake_case)]
pub struct AddedMass {
    /// X_u̇ [kg].
    pub X_udot: f64,
    /// Y_v̇ [kg].
    pub Y_vdot: f64,
    /// Y_ṙ [kg m].
    pub Y_rdot: f64,
    /// N_v̇ [kg m].
    pub N_vdot: f64,
    /// N_ṙ [kg m²].
    pub N_rdot: f64,
}

/// The ship's propeller (the data set's optional `[propeller]` table, `docs/data-format.md`), as the mmg
/// model family needs it. Positions are of the propeller plane, forward of midship.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PropellerData {
    /// Propeller diameter D_P [m].
    pub diameter_m: f64,
    /// Position forward of midship [m] (aft is negative).
    pub x_m: f64,
    /// Open-water thrust coefficient K_T(J) = k_t[0] + k_t[1] J + k_t[2] J²: as given, or the
    /// least-squares quadratic through the open-water points.
    pub k_t: [f64; 3],
    /// The open-water points the quadratic was fitted to, when the data set gives a table.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub open_water: Option<OpenWaterCurve>,
    /// Where `k_t` comes from when the data set gives no curve: the documented default
    /// ([`DEFAULT_K_T_SOURCE`]); absent when the data set gives `k_t` or `open_water`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k_t_default: Option<String>,
    /// Constant propeller rate n [1/s] for recordings without an `n` column.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate_rps: Option<f64>,
}

/// The wind-coefficient model that turns a data set's windage areas into aerodynamic force
/// coefficients (`docs/data-format.md`, `[windage]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum WindModel {
    /// Fossen (2011, *Handbook of Marine Craft Hydrodynamics and Motion Control*, §8.1): C_X = −c_x cos γ,
    /// C_Y = c_y sin γ, C_N = c_n sin 2γ with mid-range merchant-ship constants; needs only the areas.
    #[default]
    Fossen,
    /// Isherwood (1973), "Wind resistance of merchant ships", RINA Trans. 115: regression on the
    /// areas, lengths and lateral centre.
    Isherwood1973,
    /// Fujiwara, Ueno & Ikeda (2005), "Cruising performance of a large passenger ship in heavy sea",
    /// ISOPE: regression on the areas, heights and lateral centre.
    Fujiwara2005,
}

impl WindModel {
    /// The name as written in a data set.
    pub fn name(self) -> &'static str {
        match self {
            WindModel::Fossen => "fossen",
            WindModel::Isherwood1973 => "isherwood1973",
            WindModel::Fujiwara2005 => "fujiwara2005",
        }
    }
}

/// Density of air [kg/m³] at sea level, 15 °C (ISA), the default of `[windage] air_density_kg_m3`.
pub const DEFAULT_AIR_DENSITY_KG_M3: f64 = 1.225;

fn default_air_density() -> f64 {
    DEFAULT_AIR_DENSITY_KG_M3
}

/// The ship above water as the wind sees it (`[windage]` of a data set, `docs/data-format.md`), at the
/// scale of the recordings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Windage {
    /// Frontal projected area above water A_F [m²].
    pub frontal_area_m2: f64,
    /// Lateral projected area above water A_L [m²].
    pub lateral_area_m2: f64,
    /// Longitudinal position of the lateral area's centroid [m], positive forward of midship.
    #[serde(default)]
    pub lateral_centre_x_m: f64,
    /// The wind-coefficient model.
    #[serde(default)]
    pub model: WindModel,
    /// Air density ρ_a [kg/m³].
    #[serde(default = "default_air_density")]
    pub air_density_kg_m3: f64,
    /// Length overall [m] (Isherwood 1973); default: the length between perpendiculars.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub length_overall_m: Option<f64>,
    /// Lateral projected area of the superstructure above the deck [m²] (Isherwood 1973 A_SS,
    /// Fujiwara 2005 A_OD); default 0 (a bare hull above water).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub superstructure_lateral_area_m2: Option<f64>,
    /// Height of the lateral area's centroid above the waterline [m] (Fujiwara 2005 H_C).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lateral_centre_height_m: Option<f64>,
    /// Height of the highest point of the ship above the waterline [m] (Fujiwara 2005 H_BR).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub height_m: Option<f64>,
    /// Perimeter of the lateral projection above water [m], waterline and slender bodies (masts,
    /// ventilators) excluded (Isherwood 1973 S; required by `isherwood1973`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lateral_perimeter_m: Option<f64>,
    /// Number of distinct groups of masts or king posts seen in the lateral projection, king posts close
    /// against the bridge front not counted (Isherwood 1973 M); default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mast_groups: Option<u32>,
    /// Where these values come from (drawings, an estimate, …): model files repeat it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
}

/// K_T(J) coefficients used when a `[propeller]` table gives neither `k_t` nor `open_water`: the KVLCC2
/// model propeller of Yasukawa & Yoshimura (2015), Table 5, a four-bladed fixed-pitch propeller of
/// P/D 0.72 typical of full-form merchant ships. A ship with another propeller should give its own
/// curve; every command that uses the default says so.
pub const DEFAULT_K_T: [f64; 3] = [0.2931, -0.2753, -0.1385];

/// The source of [`DEFAULT_K_T`] as model files and warnings state it.
pub const DEFAULT_K_T_SOURCE: &str = "default open-water curve: KVLCC2 model propeller, Yasukawa & Yoshimura (2015) Table 5 (the data set gives no k_t or open_water)";

impl PropellerData {
    /// K_T at advance ratio J from the quadratic (outside the open-water range it is an extrapolation:
    /// see [`OpenWaterCurve::j_min`] / [`OpenWaterCurve::j_max`]).
    pub fn k_t_at(&self, j: f64) -> f64 {
        let [k0, k1, k2] = self.k_t;
        k0 + j * (k1 + j * k2)
    }
}

/// Open-water test points (advance ratio J, thrust coefficient K_T) read from a CSV file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OpenWaterCurve {
    /// The CSV file as named in the data set (relative to the data set file).
    pub file: String,
    /// Advance ratios J [-], strictly increasing.
    pub j: Vec<f64>,
    /// Thrust coefficients K_T [-] at `j`.
    pub k_t: Vec<f64>,
    /// Smallest J of the points: the quadratic is fitted, not extrapolated, from here …
    pub j_min: f64,
    /// … to here.
    pub j_max: f64,
    /// Root-mean-square residual of the quadratic at the points [-].
    pub rms_residual: f64,
}

/// The ship's rudder (the data set's optional `[rudder]` table, `docs/data-format.md`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RudderData {
    /// Rudder area A_R [m²].
    pub area_m2: f64,
    /// Rudder span H_R [m].
    pub span_m: f64,
    /// Rudder stock position forward of midship [m] (aft is negative).
    pub x_m: f64,
}

/// Side of the first rudder execute.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Hash)]
#[serde(rename_all = "lowercase")]
pub enum Side {
    Port,
    Starboard,
}

impl Side {
    /// Sign of the first rudder execute in the project's convention (starboard = +1).
    pub fn sign(self) -> f64 {
        match self {
            Side::Port => -1.0,
            Side::Starboard => 1.0,
        }
    }

    pub fn as_str(self) -> &'static str {
        match self {
            Side::Port => "port",
            Side::Starboard => "starboard",
        }
    }
}

/// What a recording (or a simulation) does with the rudder.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Manoeuvre {
    /// Zig-zag δ/ψ: rudder to ±`rudder_deg`, reversed at ±`check_deg` heading deviation.
    ZigZag {
        rudder_deg: f64,
        check_deg: f64,
        side: Side,
    },
    /// Turning circle: rudder to `rudder_deg` towards `side` and held.
    Turning { rudder_deg: f64, side: Side },
    /// Any other rudder history (no standard metrics).
    Free,
}

impl Manoeuvre {
    /// The `kind` word of a data-set file: `zigzag`, `turning` or `free`.
    pub fn kind(&self) -> &'static str {
        match self {
            Manoeuvre::ZigZag { .. } => "zigzag",
            Manoeuvre::Turning { .. } => "turning",
            Manoeuvre::Free => "free",
        }
    }
}
