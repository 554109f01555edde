//! The wind an anemometer on board measures (relative, apparent wind) and the true wind it implies.
//!
//! The relative wind is the air's velocity past the moving ship, given as its speed and the angle off
//! the bow it comes from (0: from dead ahead, +90°: from starboard, −90°: from port). The true wind
//! (over ground, `docs/data-format.md`) is that velocity plus the ship's own velocity over ground.
//!
//! The ship's velocity is taken at the recording's reference point: the anemometer's lever arm × r is
//! neglected. At model scale (mast a few tenths of a metre from midship, r of a few degrees per second)
//! that is a few mm/s against winds of metres per second; a user with a large lever arm and fast turns
//! should convert with it beforehand.

/// A wind as speed and the direction it comes from. For the true wind the direction is earth-fixed,
/// clockwise from north; for the relative wind it is the angle off the bow, positive to starboard.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wind {
    /// Speed [m/s], ≥ 0.
    pub speed_m_s: f64,
    /// Direction it comes from [rad].
    pub from_rad: f64,
}

/// The ship's motion that turns one wind into the other: heading (clockwise from north) and the body
/// velocities over ground at the reference point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShipMotion {
    pub psi_rad: f64,
    pub u_m_s: f64,
    pub v_m_s: f64,
}

/// The true wind of the relative wind `relative` measured on a ship in `motion`; `None` when a value
/// is not finite (the caller names the cell). Its direction lies in [0, 2π); a calm true wind has the
/// direction 0.
pub fn true_wind(relative: Wind, motion: ShipMotion) -> Option<Wind> {
    // The air past the ship moves away from where it comes from, in body axes.
    let (s_g, c_g) = relative.from_rad.sin_cos();
    let air_body = [
        -relative.speed_m_s * c_g + motion.u_m_s,
        -relative.speed_m_s * s_g + motion.v_m_s,
    ];
    let (s, c) = motion.psi_rad.sin_cos();
    let north = air_body[0] * c - air_body[1] * s;
    let east = air_body[0] * s + air_body[1] * c;
    from_velocity(north, east, std::f64::consts::TAU)
}

/// The relative wind a ship in `motion` feels in the true wind `true_wind` (the inverse of
/// [`true_wind`]; what `shipid generate --wind-channels relative` writes); `None` when a value is not
/// finite. Its angle lies in (−π, π].
pub fn relative_wind(true_wind: Wind, motion: ShipMotion) -> Option<Wind> {
    let (s_f, c_f) = true_wind.from_rad.sin_cos();
    let (north, east) = (-true_wind.speed_m_s * c_f, -true_wind.speed_m_s * s_f);
    let (s, c) = motion.psi_rad.sin_cos();
    let air_body_x = north * c + east * s - motion.u_m_s;
    let air_body_y = -north * s + east * c - motion.v_m_s;
    from_velocity(air_body_x, air_body_y, 0.0).map(|w| Wind {
        from_rad: if w.from_rad == -std::f64::consts::PI {
            std::f64::consts::PI
        } else {
            w.from_rad
        },
        ..w
    })
}

/// Speed and from-direction of an air velocity `[a, b]` (north/east, or forward/starboard), the
/// direction wrapped to [0, 2π) when `wrap` is 2π, else left in atan2's (−π, π].
fn from_velocity(a: f64, b: f64, wrap: f64) -> Option<Wind> {
    let speed_m_s = a.hypot(b);
    if !speed_m_s.is_finite() {
        return None;
    }
    if speed_m_s == 0.0 {
        return Some(Wind {
            speed_m_s,
            from_rad: 0.0,
        });
    }
    let from = (-b).atan2(-a);
    let from_rad = if wrap > 0.0 {
        from.rem_euclid(wrap)
    } else {
        from
    };
    from_rad.is_finite().then_some(Wind {
        speed_m_s,
        from_rad,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const DEG: f64 = std::f64::consts::PI / 180.0;

    fn motion(psi_deg: f64, u_m_s: f64, v_m_s: f64) -> ShipMotion {
        ShipMotion {
            psi_rad: psi_deg * DEG,
            u_m_s,
            v_m_s,
        }
    }

    /// The true wind of `relative` (speed [m/s], angle [deg]) on a ship in `m` is `expected` (speed
    /// [m/s], from [deg]) to 1e-12.
    fn check(relative: (f64, f64), m: ShipMotion, expected: (f64, f64)) {
        let got = true_wind(
            Wind {
                speed_m_s: relative.0,
                from_rad: relative.1 * DEG,
            },
            m,
        )
        .expect("finite");
        let from_err = ((got.from_rad - expected.1 * DEG + std::f64::consts::PI)
            .rem_euclid(std::f64::consts::TAU)
            - std::f64::consts::PI)
            .abs();
        assert!(
            (got.speed_m_s - expected.0).abs() < 1e-12 && (expected.0 == 0.0 || from_err < 1e-12),
            "relative {relative:?} on {m:?}: got {} m/s from {} deg, expected {expected:?}",
            got.speed_m_s,
            got.from_rad / DEG
        );
    }

    /// Heading north at 1 m/s, 1 m/s from dead ahead: all of it is the ship's own motion, the true
    /// wind is calm.
    #[test]
    fn head_wind_of_the_ships_own_speed_is_calm() {
        check((1.0, 0.0), motion(0.0, 1.0, 0.0), (0.0, 0.0));
    }

    /// Heading east (90°) at 2 m/s, 2 m/s from 90° (starboard, i.e. from the south): the air past the
    /// ship moves north at 2 m/s, plus the ship's 2 m/s east, so the true air moves north-east at
    /// 2√2 = 2.828 m/s and comes from the south-west, 225°.
    #[test]
    fn beam_wind_from_starboard_while_heading_east() {
        check(
            (2.0, 90.0),
            motion(90.0, 2.0, 0.0),
            (2.0 * 2f64.sqrt(), 225.0),
        );
    }

    /// A ship at rest feels the true wind, turned by its heading: heading 30°, 5 m/s from 10° off the
    /// starboard bow is 5 m/s from 40°; heading north, from port (−90° or 270°) is from the west.
    #[test]
    fn a_ship_at_rest_only_turns_the_angle_by_its_heading() {
        check((5.0, 10.0), motion(30.0, 0.0, 0.0), (5.0, 40.0));
        check((3.0, -90.0), motion(0.0, 0.0, 0.0), (3.0, 270.0));
        check((3.0, 270.0), motion(0.0, 0.0, 0.0), (3.0, 270.0));
    }

    /// Sway counts as well: heading north drifting to starboard (east) at 1 m/s with no surge, a
    /// relative wind of 1 m/s from starboard is the ship's own drift: calm.
    #[test]
    fn the_ships_own_sway_is_removed() {
        check((1.0, 90.0), motion(0.0, 0.0, 1.0), (0.0, 0.0));
    }

    /// Non-finite values give `None`, never a panic or a NaN wind.
    #[test]
    fn non_finite_values_give_none() {
        let w = Wind {
            speed_m_s: 1.0,
            from_rad: f64::NAN,
        };
        assert_eq!(true_wind(w, motion(0.0, 1.0, 0.0)), None);
        let w = Wind {
            speed_m_s: f64::INFINITY,
            from_rad: 0.0,
        };
        assert_eq!(true_wind(w, motion(0.0, 1.0, 0.0)), None);
        assert_eq!(relative_wind(w, motion(0.0, 1.0, 0.0)), None);
    }
}
