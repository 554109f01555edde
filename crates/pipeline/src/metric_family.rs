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
