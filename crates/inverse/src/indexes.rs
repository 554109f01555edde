//! Motion indexes of paper 003 eq. 12 from simulated ±35° turning circles and ±20/20 zig-zags.
//!
//! Eq. 12 itself was lost in the text extraction; the nine indexes are read from the headers and values
//! of Tab. 3 and Tab. 5 ([`INDEX_KEYS`]):
//! 1. A_D,+35 / L,
//! 2. D_T,+35 / L,
//! 3. U_final / U_initial of the +35° turn,
//! 4. A_D,−35 / L,
//! 5. D_T,−35 / L (signed: negative, to port),
//! 6. ψ_peak / ψ_check at the first overshoot of the +20/20 zig-zag (Tab. 3 "32.3567/20"),
//! 7. the time of that peak from the first execute × U0/L,
//! 8. ψ_peak / ψ_check at the first overshoot of the −20/−20 zig-zag ("−40/−20" = 2),
//! 9. the time of the second overshoot peak of the −20/−20 zig-zag from the first execute × U0/L
//!    (Tab. 3 gives t2 U/L = 11.05 against t1 U/L = 4.06: a second overshoot, not the first of the
//!    port zig-zag).
//!
//! U_final is the speed when the heading has changed by [`FINAL_SPEED_HEADING_DEG`] = 540°: turning
//! circles are integrated in chunks and stopped there, which is where the cost of a database goes. For
//! KVLCC2 the speed then is within 0.4 % of that after 1080° (at 360° it is still 4 % higher; test
//! `speed_at_540_is_steady`).

use serde::Deserialize;
use shipid_io::{Manoeuvre, Recording, Side};
use shipid_sim::metrics::zigzag_events;
use shipid_sim::{
    DivergenceBounds, Dynamics, SimOptions, SimStatus, State, Turning, ZigZag, metrics, simulate,
};

use crate::error::InverseError;
use crate::physical::Unphysical;

/// Number of motion indexes.
pub const N_INDEXES: usize = 9;
/// The targets-file keys of the indexes, in order.
pub const INDEX_KEYS: [&str; N_INDEXES] = [
    "advance_p35",
    "tactical_diameter_p35",
    "speed_ratio_p35",
    "advance_m35",
    "tactical_diameter_m35",
    "heading_peak_p20",
    "t1_p20",
    "heading_peak_m20",
    "t2_m20",
];
/// Short labels for tables and figures.
pub const INDEX_LABELS: [&str; N_INDEXES] = [
    "AD+35/L",
    "DT+35/L",
    "Uf/Ui",
    "AD-35/L",
    "DT-35/L",
    "psi1/20 (+20)",
    "t1 U/L",
    "psi1/20 (-20)",
    "t2 U/L",
];
/// Heading change [deg] of a turn at which U_final is taken and the turn is stopped.
pub const FINAL_SPEED_HEADING_DEG: f64 = 540.0;
/// Index 3 (the speed ratio) is the only one not log-transformed (paper 003 §2.2).
pub const SPEED_RATIO: usize = 2;

/// Largest advance or tactical diameter of a 35° turn accepted, in ship lengths: ships turn within
/// 2 … 6 L (IMO's criteria: advance 4.5 L, tactical diameter 5 L); beyond 100 L the number is no
/// turning circle's.
pub const MAX_TURN_LENGTH_OVER_L: f64 = 100.0;
/// Largest ψ_peak/ψ_check of a 20/20 zig-zag accepted: 10 is an overshoot of 180°, past which the
/// ship turns in circles instead of zig-zagging.
pub const MAX_HEADING_PEAK_RATIO: f64 = 10.0;
/// Largest overshoot peak time accepted, × U0/L: ships peak within 3 … 15 ship lengths of
/// travel (Tab. 3: 4.06 and 11.05); 100 L is no zig-zag's.
pub const MAX_PEAK_TIME_U_OVER_L: f64 = 100.0;
const TURN_LENGTH: &str =
    "a 35° turn's advance and tactical diameter are a few ship lengths (2 … 6 L)";
const HEADING_PEAK: &str = "ψ_peak/ψ_check = 1 + overshoot/20°; beyond 10 the overshoot exceeds 180° \
                            and the ship turns in circles instead of zig-zagging";
const PEAK_TIME: &str = "a 20/20 zig-zag's overshoots peak within a few ship lengths of travel \
                         (3 … 15 U/L)";

/// The nine motion indexes in [`INDEX_KEYS`] order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionIndexes(pub [f64; N_INDEXES]);

impl MotionIndexes {
    /// Network input: ln|q_i| for every index but the speed ratio (paper 003 §2.2), which stays as is.
    pub fn features(&self) -> [f64; N_INDEXES] {
        std::array::from_fn(|i| {
            if i == SPEED_RATIO {
                self.0[i]
            } else {
                self.0[i].abs().ln()
            }
        })
    }
}

/// A motion to invert (`[[target.motion]]` in a targets file).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotionTarget {
    pub name: String,
    pub advance_p35: f64,
    pub tactical_diameter_p35: f64,
    pub speed_ratio_p35: f64,
    pub advance_m35: f64,
    pub tactical_diameter_m35: f64,
    pub heading_peak_p20: f64,
    pub t1_p20: f64,
    pub heading_peak_m20: f64,
    pub t2_m20: f64,
}

impl MotionTarget {
    /// The indexes, checked: finite, non-zero (they are log-transformed), of the sign their definition
    /// gives (all positive but the port turn's tactical diameter), ψ_peak/ψ_check ratios ≥ 1, speed
    /// ratio in (0, 1].
    pub fn indexes(&self) -> Result<MotionIndexes, InverseError> {
        let q = MotionIndexes([
            self.advance_p35,
            self.tactical_diameter_p35,
            self.speed_ratio_p35,
            self.advance_m35,
            self.tactical_diameter_m35,
            self.heading_peak_p20,
            self.t1_p20,
            self.heading_peak_m20,
            self.t2_m20,
        ]);
        for (key, v) in INDEX_KEYS.iter().zip(q.0) {
            if !(v.is_finite() && v != 0.0) {
                return Err(InverseError::Index {
                    motion: self.name.clone(),
                    key,
                    value: v,
                    reason: "must be finite and non-zero".into(),
                });
            }
        }
        // The network sees ln|q|, so a wrong sign would be inverted as if it were right: refuse it.
        for (key, v, positive) in [
            ("advance_p35", self.advance_p35, true),
            ("tactical_diameter_p35", self.tactical_diameter_p35, true),
            ("advance_m35", self.advance_m35, true),
            ("tactical_diameter_m35", self.tactical_diameter_m35, false),
            ("heading_peak_p20", self.heading_peak_p20, true),
            ("t1_p20", self.t1_p20, true),
            ("heading_peak_m20", self.heading_peak_m20, true),
            ("t2_m20", self.t2_m20, true),
        ] {
            if (v > 0.0) != positive {
                return Err(InverseError::Index {
                    motion: self.name.clone(),
                    key,
                    value: v,
                    reason: if positive {
                        "must be positive (lengths, times and ψ_peak/ψ_check of the same sign)"
                    } else {
                        "must be negative (the port turn's tactical diameter is signed, negative to port)"
                    }
                    .into(),
                });
            }
        }
        // ψ_peak is the heading at the first overshoot, past the check heading ψ_check where the
        // rudder reverses: a zig-zag cannot peak before it reaches its check, so the ratio is ≥ 1
        // (1: no overshoot).
        for (key, v) in [
            ("heading_peak_p20", self.heading_peak_p20),
            ("heading_peak_m20", self.heading_peak_m20),
        ] {
            if v < 1.0 {
                return Err(InverseError::Index {
                    motion: self.name.clone(),
                    key,
                    value: v,
                    reason: "must be at least 1: ψ_peak/ψ_check, the first overshoot's heading \
                             over the check heading, which a zig-zag reaches before it peaks"
                        .into(),
                });
            }
        }
        if !(self.speed_ratio_p35 > 0.0 && self.speed_ratio_p35 <= 1.0) {
            return Err(InverseError::Index {
                motion: self.name.clone(),
                key: "speed_ratio_p35",
                value: self.speed_ratio_p35,
                reason: "must be in (0, 1]".into(),
            });
        }
        // Beyond what any ship's manoeuvre gives: a wrong unit or a typo, which the network (it sees
        // ln|q|) would invert all the same.
        for (key, v, limit, what) in [
            (
                "advance_p35",
                self.advance_p35,
                MAX_TURN_LENGTH_OVER_L,
                TURN_LENGTH,
            ),
            (
                "tactical_diameter_p35",
                self.tactical_diameter_p35,
                MAX_TURN_LENGTH_OVER_L,
                TURN_LENGTH,
            ),
            (
                "advance_m35",
                self.advance_m35,
                MAX_TURN_LENGTH_OVER_L,
                TURN_LENGTH,
            ),
            (
                "tactical_diameter_m35",
                self.tactical_diameter_m35,
                MAX_TURN_LENGTH_OVER_L,
                TURN_LENGTH,
            ),
            (
                "heading_peak_p20",
                self.heading_peak_p20,
                MAX_HEADING_PEAK_RATIO,
                HEADING_PEAK,
            ),
            (
                "heading_peak_m20",
                self.heading_peak_m20,
                MAX_HEADING_PEAK_RATIO,
                HEADING_PEAK,
            ),
            ("t1_p20", self.t1_p20, MAX_PEAK_TIME_U_OVER_L, PEAK_TIME),
            ("t2_m20", self.t2_m20, MAX_PEAK_TIME_U_OVER_L, PEAK_TIME),
        ] {
            if v.abs() > limit {
                return Err(InverseError::Index {
                    motion: self.name.clone(),
                    key,
                    value: v,
                    reason: format!(
                        "{}above {limit}: {what}; a wrong unit or a typo?",
                        if v < 0.0 { "in magnitude " } else { "" }
                    ),
                });
            }
        }
        // The second overshoot of a zig-zag comes after its first, and the ±20° zig-zags of one
        // ship are near mirror images (its hull forces are symmetric): t2 of the −20° zig-zag
        // before t1 of the +20° one is no ship's.
        if self.t2_m20 <= self.t1_p20 {
            return Err(InverseError::Index {
                motion: self.name.clone(),
                key: "t2_m20",
                value: self.t2_m20,
                reason: format!(
                    "must be later than t1_p20 = {}: t2 is the time of a zig-zag's second \
                     overshoot peak, which follows its first (t1, Tab. 3: 4.06 and 11.05 U/L)",
                    crate::error::readable(&self.t1_p20)
                ),
            });
        }
        Ok(q)
    }
}

/// Integration settings in units of L/U0, so that they carry over between scales.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimSettings {
    /// RK4 step × U0/L. Default 0.05 (KVLCC2 full scale: 2.0 s; the ship turns through 0.4° per step at
    /// the steady 35° turn rate). The indexes then agree with those at a quarter of the step to 0.1 % for
    /// KVLCC2 and to 0.5 % for generated ships (tests `step_is_converged`,
    /// `step_is_converged_for_generated_ships`): the rudder executes and zig-zag reversals are placed
    /// inside the step by the sim crate, so no event waits for the grid, and the indexes are
    /// interpolated between samples.
    pub dt_prime: f64,
    /// Length of a zig-zag × U0/L (the −20/−20 second overshoot of KVLCC2 comes at about 11).
    pub zigzag_duration_prime: f64,
    /// Turning circles are integrated in chunks of this length × U0/L until
    /// [`FINAL_SPEED_HEADING_DEG`] of heading change.
    pub turn_chunk_prime: f64,
    /// A turn that has not reached [`FINAL_SPEED_HEADING_DEG`] after this time × U0/L counts as failed.
    pub turn_max_prime: f64,
}

impl Default for SimSettings {
    fn default() -> Self {
        SimSettings {
            dt_prime: 0.05,
            zigzag_duration_prime: 20.0,
            turn_chunk_prime: 5.0,
            turn_max_prime: 120.0,
        }
    }
}

/// The four simulated manoeuvres (midship tracks, SI, in the conventions of
/// `docs/conventions.md`). The +35° turn runs to
/// [`FINAL_SPEED_HEADING_DEG`], the −35° turn to [`PORT_TURN_STOP_DEG`] (rounded up to a chunk).
#[derive(Debug, Clone, PartialEq)]
pub struct Manoeuvres {
    pub turn_p35: Recording,
    pub turn_m35: Recording,
    pub zigzag_p20: Recording,
    pub zigzag_m20: Recording,
}

/// Why a sample has no indexes. A status, not an error: the database drops and counts such samples.
#[derive(Debug, Clone, PartialEq)]
pub enum IndexFailure {
    /// The MMG model cannot be built (no self-propulsion point, invalid generated parameter).
    NoModel,
    /// A simulation diverged or could not start.
    Diverged {
        manoeuvre: &'static str,
        reason: String,
    },
    /// An index is not reached within the simulated time.
    Missing {
        manoeuvre: &'static str,
        what: &'static str,
    },
    /// The ship fails a physical check (rejected before simulating).
    Unphysical(Unphysical),
}

impl IndexFailure {
    /// The failure without its numbers, for counting failures by kind.
    pub fn kind(&self) -> String {
        match self {
            IndexFailure::NoModel => "no MMG model".into(),
            IndexFailure::Diverged { manoeuvre, .. } => format!("{manoeuvre} diverged"),
            IndexFailure::Missing { manoeuvre, what } => format!("{manoeuvre}: {what} not reached"),
            IndexFailure::Unphysical(u) => u.kind(),
        }
    }
}

impl std::fmt::Display for IndexFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            IndexFailure::NoModel => write!(f, "no MMG model (no self-propulsion point)"),
            IndexFailure::Diverged { manoeuvre, reason } => {
                write!(f, "{manoeuvre} diverged: {reason}")
            }
            IndexFailure::Missing { manoeuvre, what } => {
                write!(f, "{manoeuvre}: {what} not reached")
            }
            IndexFailure::Unphysical(u) => write!(f, "unphysical: {u}"),
        }
    }
}

fn options(dt_s: f64, duration_s: f64, initial_rudder_rad: f64) -> SimOptions {
    SimOptions {
        dt_s,
        duration_s,
        sample_interval_s: dt_s,
        initial_rudder_rad,
        bounds: DivergenceBounds::default(),
    }
}

fn append(into: &mut Recording, rec: &Recording, t_offset_s: f64, skip_first: bool) {
    let from = usize::from(skip_first);
    into.t.extend(rec.t[from..].iter().map(|t| t + t_offset_s));
    into.x0.extend_from_slice(&rec.x0[from..]);
    into.y0.extend_from_slice(&rec.y0[from..]);
    into.psi.extend_from_slice(&rec.psi[from..]);
    into.u.extend_from_slice(&rec.u[from..]);
    into.v.extend_from_slice(&rec.v[from..]);
    into.r.extend_from_slice(&rec.r[from..]);
    into.delta.extend_from_slice(&rec.delta[from..]);
}

/// Heading change [deg] at which the −35° turn stops: it only needs the tactical diameter at 180°.
pub const PORT_TURN_STOP_DEG: f64 = 190.0;

fn turning(
    model: &dyn Dynamics,
    side: Side,
    stop_deg: f64,
    s: &SimSettings,
    name: &'static str,
) -> Result<Recording, IndexFailure> {
    let ship = model.ship();
    let tl = ship.lpp / ship.u0;
    let dt = s.dt_prime * tl;
    let diverged = |reason: String| IndexFailure::Diverged {
        manoeuvre: name,
        reason,
    };
    let mut all = Recording::default();
    let mut state = State::approach(ship.u0);
    let mut delta0 = 0.0;
    let mut t0 = 0.0;
    loop {
        let first = all.t.is_empty();
        // The first chunk executes the rudder one step after the start, so that the record shows the
        // approach; later chunks continue with the rudder already hard over.
        let mut ctl = Turning::new(35.0, side, if first { dt } else { 0.0 })
            .map_err(|e| diverged(e.to_string()))?;
        let out = simulate(
            model,
            &mut ctl,
            state,
            &options(dt, s.turn_chunk_prime * tl, delta0),
        )
        .map_err(|e| diverged(e.to_string()))?;
        if let SimStatus::Diverged { reason, .. } = out.status {
            return Err(diverged(reason));
        }
        let rec = &out.recording;
        append(&mut all, rec, t0, !first);
        let last = rec.len() - 1;
        let turned = side.sign() * (all.psi[all.psi.len() - 1] - all.psi[0]);
        if turned >= stop_deg.to_radians() {
            return Ok(all);
        }
        t0 = all.t[all.t.len() - 1];
        if t0 >= s.turn_max_prime * tl {
            return Err(IndexFailure::Missing {
                manoeuvre: name,
                what: "final heading change",
            });
        }
        state = State::of_recording(rec, last);
        delta0 = rec.delta[last];
    }
}

fn zigzag(
    model: &dyn Dynamics,
    side: Side,
    s: &SimSettings,
    name: &'static str,
) -> Result<Recording, IndexFailure> {
    let ship = model.ship();
    let tl = ship.lpp / ship.u0;
    let dt = s.dt_prime * tl;
    let diverged = |reason: String| IndexFailure::Diverged {
        manoeuvre: name,
        reason,
    };
    let mut ctl = ZigZag::new(20.0, 20.0, side, dt).map_err(|e| diverged(e.to_string()))?;
    let out = simulate(
        model,
        &mut ctl,
        State::approach(ship.u0),
        &options(dt, s.zigzag_duration_prime * tl, 0.0),
    )
    .map_err(|e| diverged(e.to_string()))?;
    if let SimStatus::Diverged { reason, .. } = out.status {
        return Err(diverged(reason));
    }
    Ok(out.recording)
}

/// Simulates the +35°, −35° turns and the +20/20, −20/−20 zig-zags of `model` from a straight approach
/// at U0.
pub fn simulate_manoeuvres(
    model: &dyn Dynamics,
    s: &SimSettings,
) -> Result<Manoeuvres, IndexFailure> {
    Ok(Manoeuvres {
        turn_p35: turning(
            model,
            Side::Starboard,
            FINAL_SPEED_HEADING_DEG,
            s,
            "turn +35",
        )?,
        turn_m35: turning(model, Side::Port, PORT_TURN_STOP_DEG, s, "turn -35")?,
        zigzag_p20: zigzag(model, Side::Starboard, s, "zig-zag +20/20")?,
        zigzag_m20: zigzag(model, Side::Port, s, "zig-zag -20/-20")?,
    })
}

/// Speed [m/s] where the heading change of a turn to `side` reaches `deg`.
pub fn speed_at_heading_change(rec: &Recording, side: Side, deg: f64) -> Option<f64> {
    let level = deg.to_radians();
    let dev: Vec<f64> = rec
        .psi
        .iter()
        .map(|p| side.sign() * (p - rec.psi[0]))
        .collect();
    let i = (1..dev.len()).find(|&i| dev[i - 1] < level && dev[i] >= level)?;
    let w = (level - dev[i - 1]) / (dev[i] - dev[i - 1]);
    let sp = |k: usize| rec.u[k].hypot(rec.v[k]);
    Some(sp(i - 1) + w * (sp(i) - sp(i - 1)))
}

/// The nine indexes of simulated manoeuvres of a ship with length `ship.lpp` and speed `ship.u0`.
pub fn indexes_of(m: &Manoeuvres, ship: &shipid_io::Ship) -> Result<MotionIndexes, IndexFailure> {
    let scale = ship.u0 / ship.lpp;
    let turn = |rec: &Recording, side: Side, name: &'static str| {
        let mt = metrics(
            rec,
            &Manoeuvre::Turning {
                rudder_deg: 35.0,
                side,
            },
            ship,
        );
        let missing = |what| IndexFailure::Missing {
            manoeuvre: name,
            what,
        };
        Ok::<_, IndexFailure>((
            mt.advance.ok_or(missing("advance"))?,
            side.sign() * mt.tactical_diameter.ok_or(missing("tactical diameter"))?,
        ))
    };
    let (ad_p, dt_p) = turn(&m.turn_p35, Side::Starboard, "turn +35")?;
    let (ad_m, dt_m) = turn(&m.turn_m35, Side::Port, "turn -35")?;
    let u_final = speed_at_heading_change(&m.turn_p35, Side::Starboard, FINAL_SPEED_HEADING_DEG)
        .ok_or(IndexFailure::Missing {
            manoeuvre: "turn +35",
            what: "540° heading change",
        })?;
    let zz = |rec: &Recording, side: Side, k: usize, name: &'static str| {
        let missing = |what| IndexFailure::Missing {
            manoeuvre: name,
            what,
        };
        let ev = zigzag_events(rec, 20.0, 20.0, side, ship).ok_or(missing("first execute"))?;
        let first = ev.overshoots.first().ok_or(missing("first overshoot"))?;
        let k_th = ev.overshoots.get(k).ok_or(missing("overshoot peak"))?;
        Ok::<_, IndexFailure>((
            (20.0 + first.angle_deg) / 20.0,
            (k_th.t_s - ev.first.t_s) * scale,
        ))
    };
    let (peak_p, t1) = zz(&m.zigzag_p20, Side::Starboard, 0, "zig-zag +20/20")?;
    let (peak_m, t2) = zz(&m.zigzag_m20, Side::Port, 1, "zig-zag -20/-20")?;
    Ok(MotionIndexes([
        ad_p,
        dt_p,
        u_final / ship.u0,
        ad_m,
        dt_m,
        peak_p,
        t1,
        peak_m,
        t2,
    ]))
}

/// Simulates the four manoeuvres and returns the indexes.
pub fn motion_indexes(
    model: &dyn Dynamics,
    s: &SimSettings,
) -> Result<MotionIndexes, IndexFailure> {
    let m = simulate_manoeuvres(model, s)?;
    indexes_of(&m, model.ship())
}
