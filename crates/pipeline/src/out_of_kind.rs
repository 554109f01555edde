//! The out-of-kind term of a calibrated band: how far a prediction of a manoeuvre kind the training
//! recordings never showed lands from the truth.
//!
//! A calibration from the training recordings (`crate::calibration`) measures the errors of the
//! kinds of manoeuvre it was given. A turning circle predicted from zig-zags alone is not among
//! them: its states lie inside the zig-zags' range, so the reach does not widen it, and no training
//! recording shows a turn's error (docs/uncertainty.md measured such bands holding the truth in 4
//! of 40 runs). Nothing in the user's data can measure that error, so it is measured on other
//! ships: `cargo xtask out-of-kind` fits each family, with the defaults of `shipid fit`, to noisy
//! zig-zags (or turning circles) of the 20 ships of paper 003's hydrodynamic database on the KVLCC2
//! model and predicts the other kind. [`OUT_OF_KIND`] holds the quantiles of the relative errors,
//! |predicted − true| / |true|, per family, training kind and metric family
//! (`bench/out-of-kind.md`). At a band's level the quantile (interpolated between the table's
//! levels) is a relative half-width added in quadrature to the calibrated one.
//!
//! The population is ships the MMG structure describes exactly. For the mmg family its term
//! therefore measures what the estimation leaves (noise, priors), not a structure that is wrong for
//! the ship: on real recordings it is a lower bound. No I/O.

use std::collections::BTreeMap;

use shipid_io::Manoeuvre;
use shipid_model::OutOfKindRecord;

use crate::metric_family::MetricFamily;

/// A model family, as its out-of-kind term tells them apart.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelFamily {
    /// Polynomial (Abkowitz) sets.
    Polynomial,
    /// The MMG grey-box family.
    Mmg,
    /// Paper 001's sparse GP.
    SparseGp,
}

/// What the training recordings held, as the population study tells training sets apart.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrainedKinds {
    /// Zig-zags of one rudder angle (one or both sides), no turning circle.
    ZigzagsOneAngle,
    /// Zig-zags of several rudder angles, no turning circle.
    ZigzagsSeveralAngles,
    /// Turning circles, no zig-zag.
    TurningOnly,
    /// Zig-zags and turning circles: every predicted metric's kind was trained on.
    Both,
    /// Free manoeuvres only: which kinds they show is not known, so no term is claimed.
    Unknown,
}

impl TrainedKinds {
    /// What `training` (the training recordings' manoeuvres) held.
    pub fn of(training: &[Manoeuvre]) -> TrainedKinds {
        let mut angles: Vec<f64> = Vec::new();
        let mut turning = false;
        for m in training {
            match *m {
                Manoeuvre::ZigZag { rudder_deg, .. } => {
                    let a = rudder_deg.abs();
                    if !angles.iter().any(|&b| (a - b).abs() < 0.5) {
                        angles.push(a);
                    }
                }
                Manoeuvre::Turning { .. } => turning = true,
                Manoeuvre::Free => {}
            }
        }
        match (angles.len(), turning) {
            (0, false) => TrainedKinds::Unknown,
            (0, true) => TrainedKinds::TurningOnly,
            (_, true) => TrainedKinds::Both,
            (1, false) => TrainedKinds::ZigzagsOneAngle,
            (_, false) => TrainedKinds::ZigzagsSeveralAngles,
        }
    }

    /// The manoeuvre kinds held, as the model file names them.
    fn names(self, training: &[Manoeuvre]) -> Vec<String> {
        let mut kinds: Vec<String> = Vec::new();
        for m in training {
            let k = match m {
                Manoeuvre::ZigZag { .. } => "zigzag",
                Manoeuvre::Turning { .. } => "turning",
                Manoeuvre::Free => "free",
            };
            if !kinds.iter().any(|x| x == k) {
                kinds.push(k.to_string());
            }
        }
        kinds
    }
}

/// The levels of [`OUT_OF_KIND`]'s quantiles.
pub const OUT_OF_KIND_LEVELS: [f64; 5] = [0.5, 0.68, 0.8, 0.9, 0.95];

/// Where [`OUT_OF_KIND`] comes from, as a model file's `[calibration.out_of_kind]` states it.
pub const OUT_OF_KIND_SOURCE: &str = "population study `cargo xtask out-of-kind --seeds 3` \
(bench/out-of-kind.md, 2026-11-24): relative errors of the other kind's metrics predicted by the \
family's default fit from noisy training runs of the 20 ships of paper 003's hydrodynamic database \
on the KVLCC2 model, quantile at the band's level";

/// What the mmg family's term does not hold, said wherever the term is (its source in the model file,
/// the fit's note, the band's description).
pub const MMG_STRUCTURE_CAVEAT: &str = "the population's ships follow the MMG structure exactly, so on a real ship's recordings the term is a lower bound (docs/mmg.md: hull-force shapes the HSVA zig-zags cannot tell apart spread the 35° turn by ±10 % tactical and ±20 % steady diameter)";

use MetricFamily::{Overshoot, TurningLength, ZigzagTime};
use ModelFamily::{Mmg, Polynomial, SparseGp};
use TrainedKinds::{TurningOnly, ZigzagsOneAngle, ZigzagsSeveralAngles};

const INF: f64 = f64::INFINITY;

/// Relative-error quantiles at [`OUT_OF_KIND_LEVELS`] per family, training kinds and predicted
/// metric family ([`OUT_OF_KIND_SOURCE`]). Infinite: at that level the population's predictions
/// diverged or defined no metric, so the band is unbounded.
#[rustfmt::skip]
pub const OUT_OF_KIND: [(ModelFamily, TrainedKinds, MetricFamily, [f64; 5]); 12] = [
    (Polynomial, ZigzagsOneAngle, TurningLength, [0.065, 0.126, 0.196, 0.354, 0.592]),
    (Polynomial, ZigzagsSeveralAngles, TurningLength, [0.041, 0.066, 0.103, 0.225, 0.315]),
    (Polynomial, TurningOnly, Overshoot, [0.684, 0.773, 0.832, 0.900, 2.705]),
    (Polynomial, TurningOnly, ZigzagTime, [0.439, 0.573, 0.705, 2.551, 6.057]),
    (Mmg, ZigzagsOneAngle, TurningLength, [0.020, 0.036, 0.056, 0.083, 0.137]),
    (Mmg, ZigzagsSeveralAngles, TurningLength, [0.007, 0.010, 0.015, 0.023, 0.031]),
    (Mmg, TurningOnly, Overshoot, [0.651, 0.780, 0.869, 0.940, 37.236]),
    (Mmg, TurningOnly, ZigzagTime, [0.256, 0.506, 0.648, 0.757, 2.848]),
    (SparseGp, ZigzagsOneAngle, TurningLength, [0.092, 0.162, 0.257, 0.380, 0.572]),
    (SparseGp, ZigzagsSeveralAngles, TurningLength, [0.033, 0.053, 0.079, 0.111, 0.151]),
    (SparseGp, TurningOnly, Overshoot, [INF; 5]),
    (SparseGp, TurningOnly, ZigzagTime, [0.395, 0.907, INF, INF, INF]),
];

/// The quantile at `level` of one row: linear between the table's levels, the first below them,
/// the last above them (there a lower bound of the term).
fn at_level(q: &[f64; 5], level: f64) -> f64 {
    let l = &OUT_OF_KIND_LEVELS;
    if level <= l[0] {
        return q[0];
    }
    for i in 1..l.len() {
        if level <= l[i] {
            if q[i].is_infinite() {
                return f64::INFINITY;
            }
            let w = (level - l[i - 1]) / (l[i] - l[i - 1]);
            return q[i - 1] + w * (q[i] - q[i - 1]);
        }
    }
    q[l.len() - 1]
}

/// The out-of-kind term of `family` trained on `training` at `level`: None when the training held
/// both kinds (nothing to add) or only free manoeuvres (nothing known).
pub fn out_of_kind(
    family: ModelFamily,
    training: &[Manoeuvre],
    level: f64,
) -> Option<OutOfKindRecord> {
    let trained = TrainedKinds::of(training);
    let relative: BTreeMap<String, f64> = OUT_OF_KIND
        .iter()
        .filter(|(f, t, _, _)| *f == family && *t == trained)
        .map(|(_, _, m, q)| (m.as_str().to_string(), at_level(q, level)))
        .collect();
    (!relative.is_empty()).then(|| OutOfKindRecord {
        trained_on: trained.names(training),
        source: format!(
            "{OUT_OF_KIND_SOURCE}{}{}",
            level_note(level),
            if family == Mmg {
                format!("; {MMG_STRUCTURE_CAVEAT}")
            } else {
                String::new()
            }
        ),
        relative,
    })
}

/// "; " and [`MMG_STRUCTURE_CAVEAT`] when the record's source carries it (an mmg model's), else "".
pub fn caveat(o: &OutOfKindRecord) -> String {
    if o.source.contains(MMG_STRUCTURE_CAVEAT) {
        format!("; {MMG_STRUCTURE_CAVEAT}")
    } else {
        String::new()
    }
}

/// "" inside the levels of [`OUT_OF_KIND`]; beyond them, what the term at `level` then is.
pub fn level_note(level: f64) -> String {
    let (first, last) = (
        OUT_OF_KIND_LEVELS[0],
        OUT_OF_KIND_LEVELS[OUT_OF_KIND_LEVELS.len() - 1],
    );
    if level > last {
        format!(
            "; at the level {level}, above the study's largest ({last}), the term is its {last} \
             quantile: a lower bound"
        )
    } else if level < first {
        format!(
            "; at the level {level}, below the study's smallest ({first}), the term is its \
             {first} quantile: an upper bound"
        )
    } else {
        String::new()
    }
}

/// `(lo, hi)` with the relative half-width `relative` × |centre| added in quadrature to its own
/// half-width (unbounded for an infinite term).
pub fn add_out_of_kind((lo, hi): (f64, f64), relative: f64) -> (f64, f64) {
    let (centre, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
    if relative.is_infinite() {
        return (f64::NEG_INFINITY, f64::INFINITY);
    }
    let extra = relative * centre.abs();
    let h = half.hypot(extra);
    (centre - h, centre + h)
}

/// The record's terms in words: "turning-length ±35.4 %", "overshoot unbounded", ….
pub fn terms_in_words(o: &OutOfKindRecord) -> String {
    o.relative
        .iter()
        .map(|(family, r)| {
            if r.is_finite() {
                format!("{family} ±{:.1} %", 100.0 * r)
            } else {
                format!("{family} unbounded")
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}
