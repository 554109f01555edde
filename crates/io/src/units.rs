//! Physical quantities of recording columns and the units each accepts (a header `name[unit]` overrides
//! the default SI unit; an unknown unit is an error).

/// The dimension of a column, which decides the units it may be written in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dimension {
    Time,
    Length,
    Angle,
    Velocity,
    AngularRate,
    Acceleration,
    AngularAcceleration,
    Frequency,
    Force,
}

impl Dimension {
    /// Factor that converts a value in `unit` to SI, or None for a unit this dimension does not know.
    pub fn to_si(self, unit: &str) -> Option<f64> {
        use std::f64::consts::PI;
        let deg = PI / 180.0;
        let f = match (self, unit) {
            (Dimension::Time, "s") => 1.0,
            (Dimension::Time, "ms") => 1e-3,
            (Dimension::Time, "min") => 60.0,
            (Dimension::Length, "m") => 1.0,
            (Dimension::Length, "cm") => 1e-2,
            (Dimension::Length, "mm") => 1e-3,
            (Dimension::Angle, "rad") => 1.0,
            (Dimension::Angle, "deg") => deg,
            (Dimension::Velocity, "m/s") => 1.0,
            (Dimension::Velocity, "cm/s") => 1e-2,
            (Dimension::Velocity, "mm/s") => 1e-3,
            (Dimension::Velocity, "kn") => 1852.0 / 3600.0,
            (Dimension::AngularRate, "rad/s") => 1.0,
            (Dimension::AngularRate, "deg/s") => deg,
            (Dimension::Acceleration, "m/s^2" | "m/s2" | "m/s²") => 1.0,
            (Dimension::AngularAcceleration, "rad/s^2" | "rad/s2" | "rad/s²") => 1.0,
            (Dimension::AngularAcceleration, "deg/s^2" | "deg/s2" | "deg/s²") => deg,
            (Dimension::Frequency, "1/s" | "rps" | "Hz") => 1.0,
            (Dimension::Frequency, "rpm") => 1.0 / 60.0,
            (Dimension::Force, "N") => 1.0,
            (Dimension::Force, "kN") => 1e3,
            _ => return None,
        };
        Some(f)
    }

    /// The units accepted, for error messages.
    pub fn known_units(self) -> &'static str {
        match self {
            Dimension::Time => "s, ms, min",
            Dimension::Length => "m, cm, mm",
            Dimension::Angle => "rad, deg",
            Dimension::Velocity => "m/s, cm/s, mm/s, kn",
            Dimension::AngularRate => "rad/s, deg/s",
            Dimension::Acceleration => "m/s^2",
            Dimension::AngularAcceleration => "rad/s^2, deg/s^2",
            Dimension::Frequency => "1/s, rps, Hz, rpm",
            Dimension::Force => "N, kN",
        }
    }
}

/// A quantity a recording column (or an imported column) can hold.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Quantity {
    T,
    X0,
    Y0,
    Psi,
    U,
    V,
    R,
    Delta,
    N,
    UDot,
    VDot,
    RDot,
    /// True wind speed [m/s] (optional column `wind_speed`).
    WindSpeed,
    /// Direction the true wind comes from [rad], earth-fixed, clockwise from north (`wind_from`).
    WindFrom,
    /// Relative (apparent) wind speed measured on board [m/s] (optional column
    /// `relative_wind_speed`; turned into the true wind on reading, [`crate::relative_wind`]).
    RelativeWindSpeed,
    /// Angle off the bow the relative wind comes from [rad]: 0 from dead ahead, positive from
    /// starboard (`relative_wind_angle`).
    RelativeWindAngle,
    /// Current speed [m/s] (optional column `current_speed`).
    CurrentSpeed,
    /// Direction the current comes from [rad], earth-fixed, clockwise from north (`current_from`;
    /// note: the direction it comes FROM, like the wind, not the oceanographic "sets towards").
    CurrentFrom,
    /// Propeller thrust [N] (optional column `thrust`).
    Thrust,
    /// Earth-fixed velocity north [m/s]; only in import mappings (converted to body u, v).
    X0Dot,
    /// Earth-fixed velocity east [m/s]; only in import mappings.
    Y0Dot,
}

impl Quantity {
    /// Columns of a recording file (`docs/data-format.md`), in the order the project writes them.
    pub const RECORDING: [Quantity; 19] = [
        Quantity::T,
        Quantity::X0,
        Quantity::Y0,
        Quantity::Psi,
        Quantity::U,
        Quantity::V,
        Quantity::R,
        Quantity::Delta,
        Quantity::N,
        Quantity::UDot,
        Quantity::VDot,
        Quantity::RDot,
        Quantity::WindSpeed,
        Quantity::WindFrom,
        Quantity::RelativeWindSpeed,
        Quantity::RelativeWindAngle,
        Quantity::CurrentSpeed,
        Quantity::CurrentFrom,
        Quantity::Thrust,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Quantity::T => "t",
            Quantity::X0 => "x0",
            Quantity::Y0 => "y0",
            Quantity::Psi => "psi",
            Quantity::U => "u",
            Quantity::V => "v",
            Quantity::R => "r",
            Quantity::Delta => "delta",
            Quantity::N => "n",
            Quantity::UDot => "u_dot",
            Quantity::VDot => "v_dot",
            Quantity::RDot => "r_dot",
            Quantity::WindSpeed => "wind_speed",
            Quantity::WindFrom => "wind_from",
            Quantity::RelativeWindSpeed => "relative_wind_speed",
            Quantity::RelativeWindAngle => "relative_wind_angle",
            Quantity::CurrentSpeed => "current_speed",
            Quantity::CurrentFrom => "current_from",
            Quantity::Thrust => "thrust",
            Quantity::X0Dot => "x0_dot",
            Quantity::Y0Dot => "y0_dot",
        }
    }

    pub fn from_name(name: &str) -> Option<Quantity> {
        [Quantity::X0Dot, Quantity::Y0Dot]
            .into_iter()
            .chain(Quantity::RECORDING)
            .find(|q| q.name() == name)
    }

    pub fn dimension(self) -> Dimension {
        match self {
            Quantity::T => Dimension::Time,
            Quantity::X0 | Quantity::Y0 => Dimension::Length,
            Quantity::Psi
            | Quantity::Delta
            | Quantity::WindFrom
            | Quantity::RelativeWindAngle
            | Quantity::CurrentFrom => Dimension::Angle,
            Quantity::U
            | Quantity::V
            | Quantity::X0Dot
            | Quantity::Y0Dot
            | Quantity::WindSpeed
            | Quantity::RelativeWindSpeed
            | Quantity::CurrentSpeed => Dimension::Velocity,
            Quantity::R => Dimension::AngularRate,
            Quantity::N => Dimension::Frequency,
            Quantity::Thrust => Dimension::Force,
            Quantity::UDot | Quantity::VDot => Dimension::Acceleration,
            Quantity::RDot => Dimension::AngularAcceleration,
        }
    }

    /// The SI unit the project writes.
    pub fn si_unit(self) -> &'static str {
        match self.dimension() {
            Dimension::Time => "s",
            Dimension::Length => "m",
            Dimension::Angle => "rad",
            Dimension::Velocity => "m/s",
            Dimension::AngularRate => "rad/s",
            Dimension::Acceleration => "m/s^2",
            Dimension::AngularAcceleration => "rad/s^2",
            Dimension::Frequency => "1/s",
            Dimension::Force => "N",
        }
    }

    /// The largest magnitude a value of this quantity may have in SI, after unit conversion
    /// (`docs/data-format.md`). Far beyond anything a ship (model or full scale) records, yet small
    /// enough that squares and cubes of prime-scaled values stay finite: a value beyond it is a wrong
    /// unit, a corrupt file or a sentinel, never data.
    pub fn bound_si(self) -> f64 {
        match self {
            Quantity::T => 1e8,
            Quantity::X0 | Quantity::Y0 => 1e8,
            Quantity::Psi => 1e5,
            Quantity::U | Quantity::V | Quantity::X0Dot | Quantity::Y0Dot => 1e3,
            Quantity::R => 1e2,
            Quantity::Delta => std::f64::consts::PI,
            Quantity::N => 1e4,
            Quantity::UDot | Quantity::VDot => 1e4,
            Quantity::RDot => 1e4,
            // Beyond any storm at full scale (the strongest gusts measured are near 110 m/s).
            Quantity::WindSpeed | Quantity::RelativeWindSpeed => 200.0,
            // Beyond any ocean current (the fastest tidal races run near 8 m/s).
            Quantity::CurrentSpeed => 50.0,
            // A direction is one turn at most either way: a logger writes 0–360° or ±180°, and a
            // column of degrees read as radians (241.7 "rad") would otherwise pass as some angle.
            Quantity::WindFrom | Quantity::RelativeWindAngle | Quantity::CurrentFrom => {
                std::f64::consts::TAU * (1.0 + 1e-9)
            }
            // Ten times the largest marine propeller's thrust (some 5 MN on a 20 m, 100 MW one).
            Quantity::Thrust => 5e7,
        }
    }

    /// The bound as a message writes it.
    pub fn bound_text(self) -> String {
        match self {
            Quantity::Delta => "π rad (180°)".into(),
            Quantity::WindFrom | Quantity::RelativeWindAngle | Quantity::CurrentFrom => {
                "2π rad (360°)".into()
            }
            q if q.bound_si() < 1e4 => format!("{} {}", q.bound_si(), q.si_unit()),
            q => format!("{:e} {}", q.bound_si(), q.si_unit()),
        }
    }

    /// Required in every recording.
    pub fn required(self) -> bool {
        matches!(
            self,
            Quantity::T
                | Quantity::X0
                | Quantity::Y0
                | Quantity::Psi
                | Quantity::U
                | Quantity::V
                | Quantity::R
                | Quantity::Delta
        )
    }
}

/// A number with 9 significant digits in its shortest form: exact enough for every channel (relative
/// 1e-9) and keeps committed data small.
pub fn fmt_sig(x: f64) -> String {
    if x == 0.0 {
        return "0".into();
    }
    let rounded: f64 = format!("{x:.8e}").parse().unwrap_or(x);
    // Plain notation reads best in the usual range; far outside it the exponent form is shorter.
    if (1e-4..1e9).contains(&rounded.abs()) {
        format!("{rounded}")
    } else {
        format!("{rounded:e}")
    }
}
