//! Parsing the short manoeuvre and model specifications of the command line.

use shipid_io::{Manoeuvre, Side};

/// `zigzag:20/20:port`, `zigzag:10/10:starboard`, `turning:35:starboard` (side also `ps`/`sb`).
pub fn parse_manoeuvre(text: &str) -> Result<Manoeuvre, String> {
    // Every field trimmed and the words taken in any case, the kind as the side: `ZIGZAG:20/20: port`
    // was refused for its kind and its space while `zigzag: 20 / 20:PORT` was read.
    let lowered: Vec<String> = text
        .split(':')
        .map(|p| p.trim().to_ascii_lowercase())
        .collect();
    let parts: Vec<&str> = lowered.iter().map(String::as_str).collect();
    let side = |s: &str| match s {
        "port" | "ps" | "p" => Ok(Side::Port),
        "starboard" | "sb" | "s" => Ok(Side::Starboard),
        other => Err(format!(
            "manoeuvre `{text}`: unknown side `{other}` (port or starboard)"
        )),
    };
    let angle = |s: &str, what: &str| -> Result<f64, String> {
        match s.trim().parse::<f64>() {
            Ok(x) if x.is_finite() && x > 0.0 && x <= 90.0 => Ok(x),
            _ => Err(format!(
                "manoeuvre `{text}`: {what} `{s}` is not an angle in degrees between 0 and 90"
            )),
        }
    };
    match parts.as_slice() {
        ["zigzag", angles, s] => {
            let (rudder, check) = angles.split_once('/').ok_or_else(|| {
                format!(
                    "manoeuvre `{text}`: zig-zag angles must be written rudder/check, e.g. 20/20"
                )
            })?;
            Ok(Manoeuvre::ZigZag {
                rudder_deg: angle(rudder, "rudder angle")?,
                check_deg: angle(check, "check angle")?,
                side: side(s)?,
            })
        }
        ["turning", rudder, s] => Ok(Manoeuvre::Turning {
            rudder_deg: angle(rudder, "rudder angle")?,
            side: side(s)?,
        }),
        _ => Err(format!(
            "manoeuvre `{text}` not understood: expected zigzag:RUDDER/CHECK:SIDE or turning:RUDDER:SIDE"
        )),
    }
}

/// Short file-name stem of a manoeuvre: `zz20_20_ps`, `tc35_sb`.
pub fn manoeuvre_stem(m: &Manoeuvre) -> String {
    let side = |s: Side| match s {
        Side::Port => "ps",
        Side::Starboard => "sb",
    };
    match *m {
        Manoeuvre::ZigZag {
            rudder_deg,
            check_deg,
            side: s,
        } => format!("zz{}_{}_{}", rudder_deg, check_deg, side(s)),
        Manoeuvre::Turning {
            rudder_deg,
            side: s,
        } => format!("tc{}_{}", rudder_deg, side(s)),
        Manoeuvre::Free => "free".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(text: &str, expected: Result<Manoeuvre, &str>) {
        assert_eq!(
            parse_manoeuvre(text),
            expected.map_err(String::from),
            "{text}"
        );
    }

    #[test]
    fn manoeuvre_fields_are_trimmed_and_read_in_any_case_alike() {
        let zz = Ok(Manoeuvre::ZigZag {
            rudder_deg: 20.0,
            check_deg: 20.0,
            side: Side::Port,
        });
        for text in [
            "zigzag:20/20:port",
            "ZIGZAG:20/20:port",
            "zigzag:20/20:PORT",
            "zigzag:20/20: port",
            "zigzag:20/20:port ",
            " zigzag : 20 / 20 : Port",
        ] {
            check(text, zz);
        }
    }

    #[test]
    fn manoeuvre_specs() {
        check(
            "zigzag:20/20:port",
            Ok(Manoeuvre::ZigZag {
                rudder_deg: 20.0,
                check_deg: 20.0,
                side: Side::Port,
            }),
        );
        check(
            "turning:35:sb",
            Ok(Manoeuvre::Turning {
                rudder_deg: 35.0,
                side: Side::Starboard,
            }),
        );
        check(
            "zigzag:20:port",
            Err(
                "manoeuvre `zigzag:20:port`: zig-zag angles must be written rudder/check, e.g. 20/20",
            ),
        );
        check(
            "turning:35:left",
            Err("manoeuvre `turning:35:left`: unknown side `left` (port or starboard)"),
        );
        check(
            "turning:-5:port",
            Err(
                "manoeuvre `turning:-5:port`: rudder angle `-5` is not an angle in degrees between 0 and 90",
            ),
        );
        check(
            "spiral",
            Err(
                "manoeuvre `spiral` not understood: expected zigzag:RUDDER/CHECK:SIDE or turning:RUDDER:SIDE",
            ),
        );
    }

    #[test]
    fn stems() {
        assert_eq!(
            manoeuvre_stem(&parse_manoeuvre("zigzag:35/35:port").unwrap()),
            "zz35_35_ps"
        );
        assert_eq!(
            manoeuvre_stem(&parse_manoeuvre("turning:35:starboard").unwrap()),
            "tc35_sb"
        );
    }
}
