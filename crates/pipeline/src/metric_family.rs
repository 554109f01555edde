//! The families of manoeuvre metrics whose errors behave alike: the unit a calibration counts an
//! error in.

use serde::{Deserialize, Serialize};

/// Metrics whose errors behave alike: the same unit and the same part of the manoeuvre.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MetricFamily {
    /// Zig-zag overshoot angles [deg].
    Overshoot,
    /// Zig-zag times (t_a, t_check) [× U0/L].
    ZigzagTime,
    /// Turning-circle lengths (advance, transfer, tactical and steady diameter) [÷ L].
    TurningLength,
}

impl MetricFamily {
    /// The family of a metric key as `Metrics::entries` names it.
    pub fn of(metric: &str) -> Option<MetricFamily> {
        match metric {
            "overshoot_1" | "overshoot_2" => Some(MetricFamily::Overshoot),
            "t_a" | "t_check" => Some(MetricFamily::ZigzagTime),
            "advance" | "transfer" | "tactical_diameter" | "steady_diameter" => {
                Some(MetricFamily::TurningLength)
            }
            _ => None,
        }
    }

    pub const ALL: [MetricFamily; 3] = [
        MetricFamily::Overshoot,
        MetricFamily::ZigzagTime,
        MetricFamily::TurningLength,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            MetricFamily::Overshoot => "overshoot",
            MetricFamily::ZigzagTime => "zigzag-time",
            MetricFamily::TurningLength => "turning-length",
        }
    }
}

/// The physical lower limit of a metric as `shipid_sim::metrics` defines it, which no band may
/// pass: times are durations, the diameters and the advance are distances travelled into the turn,
/// and an overshoot is the heading's excursion *beyond* the check angle (a peak that stays inside it
/// is no overshoot). The transfer has none: a ship that kicks outwards before it turns has a
/// negative one.
pub fn physical_lower_limit(metric: &str) -> Option<f64> {
    match metric {
        "overshoot_1" | "overshoot_2" | "t_a" | "t_check" | "advance" | "tactical_diameter"
        | "steady_diameter" => Some(0.0),
        _ => None,
    }
}

/// The largest calibration factor a model file may hold. The factors measured (docs/uncertainty.md)
/// are 1–23: the HSVA mmg fit's 17–23 are the largest. A factor beyond 100 makes the band a hundred
/// times the replicates' spread, whose shape then says nothing; it is a damaged file, not a
/// calibration.
pub const MAX_CALIBRATION_FACTOR: f64 = 100.0;

/// The largest reach (√ of the run's mean leverage ratio over the training states' largest) at which
/// a calibrated band is still given. The factors are measured on the training recordings, at reaches
/// of 1–2, and the widening by the reach is a regression's variance growing with leverage; at a
/// reach of 10 the run's states have on average 100 times the leverage of the farthest training
/// state, where nothing checks that rule any longer and the band (centre ± factor · reach ·
/// half-width) is the reach itself, not a measurement. Such a band is dropped and the reason given.
pub const MAX_BAND_REACH: f64 = 10.0;

/// The first family (in the map's order) whose `[calibration]` factor is beyond
/// [`MAX_CALIBRATION_FACTOR`], with that factor.
pub fn factor_beyond_cap<'a>(
    factors: impl IntoIterator<Item = (&'a String, f64)>,
) -> Option<(&'a String, f64)> {
    factors
        .into_iter()
        .find(|(_, f)| *f > MAX_CALIBRATION_FACTOR)
}

/// The fault (key, message) of a loaded file's `[calibration]` factor beyond
/// [`MAX_CALIBRATION_FACTOR`]: the model crate's check holds them finite and at least 1.
pub fn factor_cap_fault<'a>(
    factors: impl IntoIterator<Item = (&'a String, f64)>,
) -> Option<(String, String)> {
    factor_beyond_cap(factors).map(|(family, f)| {
        (
            format!("calibration.factors.{family}.factor"),
            format!(
                "{} is beyond the largest factor a calibration may hold ({MAX_CALIBRATION_FACTOR}; \
                 measured factors are 1–23): a band that wide says nothing; refit with --calibrate",
                shipid_io::error::number(f)
            ),
        )
    })
}

/// A factor beyond [`MAX_CALIBRATION_FACTOR`] is refused, naming its key.
pub fn check_factor_cap(
    path: &std::path::Path,
    factors: &std::collections::BTreeMap<String, shipid_model::FactorRecord>,
) -> Result<(), crate::error::PipelineError> {
    match factor_cap_fault(factors.iter().map(|(k, f)| (k, f.factor))) {
        Some((key, msg)) => Err(shipid_io::InputError::key(path, &key, msg).into()),
        None => Ok(()),
    }
}
