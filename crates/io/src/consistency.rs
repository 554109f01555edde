//! Do a recording's channels describe one motion? The heading must change as the yaw rate
//! integrates, the track must follow the velocities turned by the heading, recorded accelerations
//! must integrate to the velocities' changes, and the rudder must reach about the angle the data set
//! declares. A unit left off a header (`psi` holding degrees), a mirrored axis or a sign flipped by a
//! logger reads as a valid file, and every number computed from it is silently wrong (a heading in
//! degrees gave first overshoots of 3110°; a sway velocity with the wrong sign fitted N_v with the
//! wrong sign and still replayed its own data well). Channels that disagree clearly are refused
//! with the likely cause; noise and small disagreements pass.
//!
//! Each comparison is made on increments over windows of a quarter ship length of travel, so that
//! sensor noise averages out and a gyro bias cannot accumulate.

use std::path::Path;

use crate::error::{InputError, number};
use crate::types::{Manoeuvre, Recording};

/// Window of the increments compared, in L/U0.
pub const WINDOW_L_OVER_U0: f64 = 0.25;

/// Scale factors within this band of 1 agree (a tank's carriage and a GNSS both drift a little).
const FACTOR_BAND: (f64, f64) = (0.8, 1.25);

/// A linear relation explains the increments when its residual is below this share of their energy.
const CLEAR_FIT: f64 = 0.3;

/// A track agrees with its velocities when their residual is below this share of its energy.
const TRACK_AGREES: f64 = 0.05;

/// Another reading of the channels is taken as the cause when it leaves less than this share of the
/// residual of the reading as given (and the given reading is above the noise).
const ALTERNATIVE_WINS: f64 = 0.25;

/// Residual share below which the given reading is within noise (no alternative is looked for).
const NOISE_SHARE: f64 = 1e-3;

/// Below this RMS heading increment per window [rad] (0.1°) the heading carries no test.
const HEADING_SIGNIFICANT_RAD: f64 = 0.1_f64 * std::f64::consts::PI / 180.0;

/// Refuse `rec` (read from `file`) when its channels clearly contradict each other or the declared
/// manoeuvre. The ship's length `lpp_m` and approach speed `u0_m_s` set the comparison window and
/// what counts as moving.
pub fn check_channels(
    file: &Path,
    rec: &Recording,
    manoeuvre: &Manoeuvre,
    lpp_m: f64,
    u0_m_s: f64,
) -> Result<(), InputError> {
    check_spikes(file, rec)?;
    check_rate_dropouts(file, rec)?;
    check_heading_lag(file, rec)?;
    let windows = windows(rec, WINDOW_L_OVER_U0 * lpp_m / u0_m_s);
    if windows.len() >= 4 {
        check_time_base(file, rec, &windows)?;
        check_heading(file, rec, &windows)?;
        // A track is tested when the ship moves at a quarter of U0 on average at least: at rest, the
        // position noise is all there is.
        check_track(file, rec, &windows, 0.25 * u0_m_s)?;
        check_accelerations(file, rec, &windows)?;
    }
    check_rudder_amplitude(file, rec, manoeuvre)
}

/// Sample index pairs (start, end) of consecutive windows of about `window_s`, at least 3 samples
/// apart.
fn windows(rec: &Recording, window_s: f64) -> Vec<(usize, usize)> {
    let n = rec.len();
    if n < 8 {
        return Vec::new();
    }
    let dt = (rec.t[n - 1] - rec.t[0]) / (n - 1) as f64;
    let step = ((window_s / dt).round() as usize).clamp(3, n / 4);
    (0..)
        .map(|k| (k * step, (k + 1) * step))
        .take_while(|&(_, b)| b < n)
        .collect()
}

/// Trapezoidal integral of `f` over samples a..=b.
fn integral(t: &[f64], f: impl Fn(usize) -> f64, a: usize, b: usize) -> f64 {
    (a..b)
        .map(|i| 0.5 * (f(i) + f(i + 1)) * (t[i + 1] - t[i]))
        .sum()
}

/// Least-squares factor k of `measured ≈ k · predicted` and the residual's share of the measured
/// energy; `None` when the prediction has no energy.
fn factor(measured: &[f64], predicted: &[f64]) -> (Option<f64>, f64) {
    let pp: f64 = predicted.iter().map(|p| p * p).sum();
    let mm: f64 = measured.iter().map(|m| m * m).sum();
    if pp <= 0.0 || mm <= 0.0 {
        return (None, 1.0);
    }
    let k = measured
        .iter()
        .zip(predicted)
        .map(|(m, p)| m * p)
        .sum::<f64>()
        / pp;
    let rr: f64 = measured
        .iter()
        .zip(predicted)
        .map(|(m, p)| (m - k * p).powi(2))
        .sum();
    (Some(k), rr / mm)
}

/// Where `measured − k · predicted` (`per` values per window) first gets close to its largest
/// (a quarter of it), as "t = a … b s": where a spike sits, or where a frozen or spliced part begins.
fn worst_window(
    rec: &Recording,
    windows: &[(usize, usize)],
    measured: &[f64],
    predicted: &[f64],
    k: f64,
    per: usize,
) -> String {
    let error: Vec<f64> = (0..windows.len())
        .map(|w| {
            (0..per)
                .map(|j| (measured[w * per + j] - k * predicted[w * per + j]).powi(2))
                .sum()
        })
        .collect();
    let largest = error.iter().copied().fold(0.0, f64::max);
    let first = error.iter().position(|&e| e >= 0.25 * largest).unwrap_or(0);
    let (a, b) = windows[first];
    format!(
        "first large between t = {} and {} s",
        number(rec.t[a]),
        number(rec.t[b])
    )
}

/// The factor of a [`factor`] fit when it explains the increments clearly and is not about 1: a unit
/// or sign between two channels.
fn clear_wrong_factor((k, residual): (Option<f64>, f64)) -> Option<f64> {
    k.filter(|k| residual < CLEAR_FIT && !(FACTOR_BAND.0..=FACTOR_BAND.1).contains(k))
}

/// The middle value of `values` (the upper of the two middle ones for an even count), `None` for
/// none: the level the load checks judge a channel against.
pub fn upper_median(values: &[f64]) -> Option<f64> {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    sorted.get(sorted.len() / 2).copied()
}

fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

/// What a scale factor `k` between two channels most likely is, for a message.
fn likely_factor(k: f64, what_scaled: &str, unit_hint: &str) -> String {
    let deg = 180.0 / std::f64::consts::PI;
    let near = |x: f64, target: f64| (x / target - 1.0).abs() < 0.1;
    if near(k, -1.0) {
        format!("opposite signs: {what_scaled} has the other sign convention")
    } else if near(k, deg) || near(k, -deg) {
        format!("a factor 180/π: {what_scaled} holds degrees read as radians ({unit_hint})")
    } else if near(k, 1.0 / deg) || near(k, -1.0 / deg) {
        format!(
            "a factor π/180: {what_scaled} holds radians read as degrees (check its header's unit)"
        )
    } else {
        format!("a factor {} (a wrong unit?)", number_short(k))
    }
}

fn number_short(x: f64) -> String {
    if x.abs() >= 0.01 && x.abs() < 1e4 {
        format!("{x:.3}")
    } else {
        format!("{x:.2e}")
    }
}

/// Per window: the heading's change and the yaw rate's integral.
fn heading_increments(rec: &Recording, windows: &[(usize, usize)]) -> (Vec<f64>, Vec<f64>) {
    windows
        .iter()
        .map(|&(a, b)| {
            (
                rec.psi[b] - rec.psi[a],
                integral(&rec.t, |i| rec.r[i], a, b),
            )
        })
        .unzip()
}

/// The time column against both rates: when the heading and the track change by one common factor
/// more or less than the yaw rate and the velocities integrate to, the clock is what is off (t in
/// ms under a bare `t` was blamed on `psi`, seconds declared `t[min]` on radians read as degrees).
fn check_time_base(
    file: &Path,
    rec: &Recording,
    windows: &[(usize, usize)],
) -> Result<(), InputError> {
    let (dpsi, int_r) = heading_increments(rec, windows);
    let earth = |i: usize| {
        let (s, c) = rec.psi[i].sin_cos();
        (rec.u[i] * c - rec.v[i] * s, rec.u[i] * s + rec.v[i] * c)
    };
    let (mut track, mut int_v) = (Vec::new(), Vec::new());
    for &(a, b) in windows {
        track.extend([rec.x0[b] - rec.x0[a], rec.y0[b] - rec.y0[a]]);
        int_v.extend([
            integral(&rec.t, |i| earth(i).0, a, b),
            integral(&rec.t, |i| earth(i).1, a, b),
        ]);
    }
    if rms(&dpsi).max(rms(&int_r)) < HEADING_SIGNIFICANT_RAD {
        return Ok(());
    }
    let (Some(k_psi), Some(k_track)) = (
        clear_wrong_factor(factor(&dpsi, &int_r)),
        clear_wrong_factor(factor(&track, &int_v)),
    ) else {
        return Ok(());
    };
    if !(k_psi > 0.0 && k_track > 0.0 && (k_psi / k_track - 1.0).abs() < 0.1) {
        return Ok(());
    }
    let k = (k_psi * k_track).sqrt();
    let near = |target: f64| (k / target - 1.0).abs() < 0.1;
    let hint = if near(1e-3) {
        "t in milliseconds under a bare `t`? write `t[ms]`".to_string()
    } else if near(1e3) {
        "seconds declared as `t[ms]`? check `t`'s unit".to_string()
    } else if near(1.0 / 60.0) {
        "seconds declared as `t[min]`? check `t`'s unit".to_string()
    } else if near(60.0) {
        "t in minutes under a bare `t`? write `t[min]`".to_string()
    } else {
        format!(
            "the recorded times span {} times what the rates imply: check `t`'s unit and sampling",
            number_short(1.0 / k)
        )
    };
    Err(InputError::file(
        file,
        format!(
            "column `t` is off: the heading and the track both change {} times as much as the yaw rate and the velocities integrate to over the recorded time ({hint})",
            number_short(k)
        ),
    ))
}

/// The heading's increments against the yaw rate's integral.
fn check_heading(
    file: &Path,
    rec: &Recording,
    windows: &[(usize, usize)],
) -> Result<(), InputError> {
    let (dpsi, int_r) = heading_increments(rec, windows);
    let (moves_psi, moves_r) = (rms(&dpsi), rms(&int_r));
    if moves_psi.max(moves_r) < HEADING_SIGNIFICANT_RAD {
        return Ok(());
    }
    let deg = 180.0 / std::f64::consts::PI;
    // One channel flat while the other turns the ship: a channel the logger did not fill.
    for (flat, moves, turning, other, how, channel) in [
        (
            "r",
            moves_r,
            "psi",
            moves_psi,
            "turns the ship by",
            "yaw rate",
        ),
        ("psi", moves_psi, "r", moves_r, "integrates to", "heading"),
    ] {
        if moves < 1e-2 * other && other > 5.0 * HEADING_SIGNIFICANT_RAD {
            return Err(InputError::file(
                file,
                format!(
                    "column `{flat}` does not move (RMS {:.3}° per window) while `{turning}` {how} {:.2}° RMS per window of {WINDOW_L_OVER_U0} L/U0: the {channel} channel is empty or wrong",
                    moves * deg,
                    other * deg
                ),
            ));
        }
    }
    if let Some(k) = clear_wrong_factor(factor(&dpsi, &int_r)) {
        return Err(InputError::file(
            file,
            format!(
                "columns `psi` and `r` disagree: the heading changes {} times as much as the yaw rate integrates to ({}); headings and yaw rates are positive to starboard, in rad and rad/s unless the header says `[deg]` / `[deg/s]` (docs/data-format.md)",
                number_short(k),
                likely_factor(
                    k,
                    "`psi` (or `r`)",
                    "write `psi[deg]`, or `r[rad/s]` if r is the one in radians"
                )
            ),
        ));
    }
    Ok(())
}

/// The track's increments against the velocities turned by the heading, with the readings a
/// mistaken axis or sign would give.
fn check_track(
    file: &Path,
    rec: &Recording,
    windows: &[(usize, usize)],
    moving_m_s: f64,
) -> Result<(), InputError> {
    // Earth velocity of midship from body velocities: x0 north, y0 east, ψ from north to starboard.
    let earth = |i: usize, v_sign: f64| {
        let (s, c) = rec.psi[i].sin_cos();
        let v = v_sign * rec.v[i];
        (rec.u[i] * c - v * s, rec.u[i] * s + v * c)
    };
    let predicted = |v_sign: f64| -> Vec<f64> {
        windows
            .iter()
            .flat_map(|&(a, b)| {
                [
                    integral(&rec.t, |i| earth(i, v_sign).0, a, b),
                    integral(&rec.t, |i| earth(i, v_sign).1, a, b),
                ]
            })
            .collect()
    };
    let track = |y_sign: f64, swapped: bool| -> Vec<f64> {
        windows
            .iter()
            .flat_map(|&(a, b)| {
                let (dx, dy) = (rec.x0[b] - rec.x0[a], y_sign * (rec.y0[b] - rec.y0[a]));
                if swapped { [dy, dx] } else { [dx, dy] }
            })
            .collect()
    };
    let as_given = predicted(1.0);
    let measured = track(1.0, false);
    // A ship at rest (or nearly) carries no test of its track.
    let travel = rms(&measured).max(rms(&as_given));
    let window_s = rec.t[windows[0].1] - rec.t[windows[0].0];
    if !travel.is_finite() || travel < moving_m_s * window_s {
        return Ok(());
    }
    let (k, residual) = factor(&measured, &as_given);
    let alternatives: [(&str, Vec<f64>, &Vec<f64>); 3] = [
        (
            "the track `y0` is mirrored (east negative), or `x0`/`y0` are not north/east",
            track(-1.0, false),
            &as_given,
        ),
        (
            "`x0` and `y0` are swapped (x0 is north, y0 east)",
            track(1.0, true),
            &as_given,
        ),
        (
            "`v` has the other sign (sway positive to starboard)",
            measured.clone(),
            &predicted(-1.0),
        ),
    ];
    if residual > NOISE_SHARE {
        for (cause, m, p) in &alternatives {
            let (k_alt, r_alt) = factor(m, p);
            if r_alt < ALTERNATIVE_WINS * residual
                && r_alt < TRACK_AGREES
                && k_alt.is_some_and(|k| (FACTOR_BAND.0..=FACTOR_BAND.1).contains(&k))
            {
                return Err(InputError::file(
                    file,
                    format!(
                        "the track (`x0`, `y0`) does not follow the velocities (`u`, `v`) turned by the heading `psi` ({:.1} % of its movement unexplained over windows of {WINDOW_L_OVER_U0} L/U0); it would ({:.2} %) if {cause} (docs/conventions.md)",
                        100.0 * residual,
                        100.0 * r_alt
                    ),
                ));
            }
        }
    }
    check_heading_offset(file, rec, &measured, &as_given, residual)?;
    match k {
        Some(k) if residual < CLEAR_FIT && !(FACTOR_BAND.0..=FACTOR_BAND.1).contains(&k) => {
            let cause = match k {
                k if (k / 1000.0 - 1.0).abs() < 0.1 => {
                    "positions in mm (or velocities in km/s)?".to_string()
                }
                k if (k / 0.5144 - 1.0).abs() < 0.05 => "velocities in knots?".to_string(),
                k if (k / 1.852 - 1.0).abs() < 0.05 => {
                    "positions in nautical miles ÷ … or velocities in km/h?".to_string()
                }
                k if (k / 3.6 - 1.0).abs() < 0.05 => "velocities in km/h?".to_string(),
                _ => "a wrong unit?".to_string(),
            };
            Err(InputError::file(
                file,
                format!(
                    "the track (`x0`, `y0`) moves {} times as far as the velocities (`u`, `v`) carry the ship ({cause}); positions are in m and velocities in m/s unless the header says otherwise (docs/data-format.md)",
                    number_short(k)
                ),
            ))
        }
        _ if residual > CLEAR_FIT => Err(InputError::file(
            file,
            format!(
                "the track (`x0`, `y0`) does not follow the velocities (`u`, `v`) turned by the heading `psi`: {:.0} % of its movement over windows of {WINDOW_L_OVER_U0} L/U0 is unexplained, {} (a spike, a spliced run, or a sign or axis convention?); the conventions are in docs/conventions.md",
                100.0 * residual,
                worst_window(rec, windows, &measured, &as_given, 1.0, 2)
            ),
        )),
        _ => Ok(()),
    }
}

/// A heading this far off the track's direction is named (a compass's mounting, magnetic against
/// true north); below it, a GNSS track and a gyro agree within what trials record.
const HEADING_OFFSET_NAMED_RAD: f64 = 1.0_f64 * std::f64::consts::PI / 180.0;

/// The heading must turn through this much for a rotation of the whole track to be told from a
/// current: a current across a straight run or a zig-zag looks like a turned track, but the
/// rotation it mimics changes sign once the ship has turned a quarter circle.
const HEADING_SPAN_FOR_OFFSET_RAD: f64 = std::f64::consts::FRAC_PI_2;

/// A constant offset of the recorded heading: the velocities turned by `psi` then carry the ship
/// along a track turned by that angle from the recorded one. The scale test above reads the
/// rotation θ as a factor cos θ (inside its band up to 37°) and a residual sin² θ (under its
/// threshold up to 33°), so a 10° or 30° offset passed and every model was blamed for it.
fn check_heading_offset(
    file: &Path,
    rec: &Recording,
    measured: &[f64],
    as_given: &[f64],
    residual: f64,
) -> Result<(), InputError> {
    let (lo, hi) = rec
        .psi
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        });
    if residual <= NOISE_SHARE
        || hi - lo < HEADING_SPAN_FOR_OFFSET_RAD
        || hi.is_nan()
        || lo.is_nan()
    {
        return Ok(());
    }
    // measured ≈ c · predicted with c complex (x north, y east: a turn to starboard is +θ).
    let (mut re, mut im, mut pp, mut mm) = (0.0, 0.0, 0.0, 0.0);
    for (m, p) in measured.chunks_exact(2).zip(as_given.chunks_exact(2)) {
        re += m[0] * p[0] + m[1] * p[1];
        im += m[1] * p[0] - m[0] * p[1];
        pp += p[0] * p[0] + p[1] * p[1];
        mm += m[0] * m[0] + m[1] * m[1];
    }
    if pp <= 0.0 || mm <= 0.0 {
        return Ok(());
    }
    let theta = im.atan2(re);
    let (cr, ci) = (re / pp, im / pp);
    let rotated: f64 = measured
        .chunks_exact(2)
        .zip(as_given.chunks_exact(2))
        .map(|(m, p)| {
            (m[0] - (cr * p[0] - ci * p[1])).powi(2) + (m[1] - (ci * p[0] + cr * p[1])).powi(2)
        })
        .sum::<f64>()
        / mm;
    let k = (cr * cr + ci * ci).sqrt();
    if theta.abs() >= HEADING_OFFSET_NAMED_RAD
        && rotated < ALTERNATIVE_WINS * residual
        && rotated < TRACK_AGREES
        && (FACTOR_BAND.0..=FACTOR_BAND.1).contains(&k)
    {
        // The track runs θ to starboard of where the heading points: the heading reads θ too little.
        return Err(InputError::file(
            file,
            format!(
                "the track (`x0`, `y0`) runs {:.1}° to {} of the direction the velocities (`u`, `v`) turned by the heading `psi` give, throughout the run ({:.1} % of its movement unexplained as given, {:.2} % with the heading turned by that angle): the heading is offset from the track's north (a compass's mounting, magnetic against true north?); correct `psi` by {:+.1}° or give the track in the heading's frame (docs/conventions.md)",
                theta.abs().to_degrees(),
                if theta > 0.0 { "starboard" } else { "port" },
                100.0 * residual,
                100.0 * rotated,
                theta.to_degrees()
            ),
        ));
    }
    Ok(())
}

/// Recorded accelerations against the changes of the velocities they belong to.
fn check_accelerations(
    file: &Path,
    rec: &Recording,
    windows: &[(usize, usize)],
) -> Result<(), InputError> {
    let Some(acc) = &rec.accelerations else {
        return Ok(());
    };
    let channels: [(&str, &str, &[f64], &[f64]); 3] = [
        ("u_dot", "u", &acc.u_dot, &rec.u),
        ("v_dot", "v", &acc.v_dot, &rec.v),
        ("r_dot", "r", &acc.r_dot, &rec.r),
    ];
    for (name, of, dot, x) in channels {
        if dot.len() != x.len() {
            continue;
        }
        let change: Vec<f64> = windows.iter().map(|&(a, b)| x[b] - x[a]).collect();
        let int: Vec<f64> = windows
            .iter()
            .map(|&(a, b)| integral(&rec.t, |i| dot[i], a, b))
            .collect();
        let (moves, integrates) = (rms(&change), rms(&int));
        // The velocity must change clearly (its own noise is not a test); u changes least of the three.
        let typical = rms(x).max(f64::MIN_POSITIVE);
        if moves < 0.02 * typical || moves <= 0.0 {
            continue;
        }
        if integrates < 1e-2 * moves {
            return Err(InputError::file(
                file,
                format!(
                    "column `{name}` is (nearly) zero while `{of}` changes: a recorded acceleration that does not integrate to its velocity's change; leave the acceleration columns out and shipid estimates them (docs/data-format.md)"
                ),
            ));
        }
        if let Some(k) = clear_wrong_factor(factor(&change, &int)) {
            return Err(InputError::file(
                file,
                format!(
                    "columns `{name}` and `{of}` disagree: `{of}` changes {} times as much as `{name}` integrates to ({})",
                    number_short(k),
                    likely_factor(k, &format!("`{name}`"), &format!("write `{name}[deg/s2]`"))
                ),
            ));
        }
    }
    Ok(())
}

/// The rudder of a zig-zag or turn must reach about the declared angle: a factor 180/π either way is
/// a unit left off the header or the data set's angle given in radians.
fn check_rudder_amplitude(
    file: &Path,
    rec: &Recording,
    manoeuvre: &Manoeuvre,
) -> Result<(), InputError> {
    let declared_deg = match *manoeuvre {
        Manoeuvre::ZigZag { rudder_deg, .. } | Manoeuvre::Turning { rudder_deg, .. } => rudder_deg,
        Manoeuvre::Free => return Ok(()),
    };
    let (at, recorded_deg) = rec
        .delta
        .iter()
        .enumerate()
        .fold((0, 0.0_f64), |(at, m), (i, d)| {
            if d.abs() > m { (i, d.abs()) } else { (at, m) }
        });
    let recorded_deg = recorded_deg.to_degrees();
    if recorded_deg < 0.1 {
        return Ok(()); // a rudder that never moves: the metrics say there is no execute
    }
    let ratio = recorded_deg / declared_deg;
    if (0.1..=2.5).contains(&ratio) {
        return Ok(());
    }
    let deg = 180.0 / std::f64::consts::PI;
    let cause = if (ratio / deg - 1.0).abs() < 0.15 {
        "the data set's `rudder` in radians, or the column `delta` holding degrees without `[deg]` in its header?"
    } else if (ratio * deg - 1.0).abs() < 0.15 {
        "the column `delta[deg]` holding radians?"
    } else {
        "a wrong unit, or the wrong recording?"
    };
    Err(InputError::file(
        file,
        format!(
            "the rudder reaches {}° (at t = {} s) while the data set declares a {} with {}° rudder ({cause})",
            number_short(recorded_deg),
            number(rec.t[at]),
            manoeuvre.kind(),
            number(declared_deg)
        ),
    ))
}

/// A single sample this many times the channel's whole spread (1st to 99th percentile) away from the
/// mean of its neighbours is no motion: a missing-value marker (-999) or a corrupt sample.
const SPIKE_SPREADS: f64 = 5.0;

/// Isolated samples far beyond the channel's spread in the continuous channels (the rudder may step).
fn check_spikes(file: &Path, rec: &Recording) -> Result<(), InputError> {
    let n = rec.len();
    if n < 50 {
        return Ok(());
    }
    let channels: [(&str, &[f64], &str); 6] = [
        ("x0", &rec.x0, "m"),
        ("y0", &rec.y0, "m"),
        ("psi", &rec.psi, "rad"),
        ("u", &rec.u, "m/s"),
        ("v", &rec.v, "m/s"),
        ("r", &rec.r, "rad/s"),
    ];
    let rate = rec.n.as_deref().map(|n| ("n", n, "1/s"));
    for (name, x, unit) in channels.into_iter().chain(rate) {
        let mut sorted = x.to_vec();
        sorted.sort_by(f64::total_cmp);
        let spread =
            sorted[(0.99 * (n - 1) as f64) as usize] - sorted[(0.01 * (n - 1) as f64) as usize];
        if spread <= 0.0 {
            continue;
        }
        // The largest departure is the spike itself (its neighbours depart by half as much).
        let (i, off) = (1..n - 1)
            .map(|i| (i, x[i] - 0.5 * (x[i - 1] + x[i + 1])))
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
            .unwrap_or((0, 0.0));
        if off.abs() > SPIKE_SPREADS * spread {
            return Err(InputError::file(
                file,
                format!(
                    "column `{name}`: the sample at t = {} s is {} {unit}, {:.0} times the channel's spread away from its neighbours: a missing-value marker (-999?) or a corrupt sample; fill or cut it",
                    number(rec.t[i]),
                    number_short(x[i]),
                    off.abs() / spread
                ),
            ));
        }
    }
    Ok(())
}

/// Longest run of samples, as a share of the recording, that [`check_rate_dropouts`] takes for a
/// dropout rather than a change of the propeller's rate.
const DROPOUT_SHARE: f64 = 0.05;

/// A propeller rate that leaves its level by more than half of it within one sample and returns
/// within one sample, a few samples later, is a logger's dropout or a corrupt value: no propeller
/// stops (or doubles its rate) and recovers between two samples. The spread test of
/// [`check_spikes`] cannot see it in the usual constant `n`, whose spread is 0 (one `n` = 9999, or
/// 5 s of `n` = 0, fitted with exit 0 and put the model's own rate 18 % off).
fn check_rate_dropouts(file: &Path, rec: &Recording) -> Result<(), InputError> {
    let Some(n) = rec.n.as_deref() else {
        return Ok(());
    };
    let len = n.len();
    if len < 50 || n.len() != rec.t.len() {
        return Ok(());
    }
    let Some(level) = upper_median(n) else {
        return Ok(());
    };
    if !(level.is_finite() && level != 0.0) {
        return Ok(());
    }
    let jump = 0.5 * level.abs();
    let far = |i: usize| (n[i] - level).abs() > jump;
    let longest = ((DROPOUT_SHARE * len as f64) as usize).max(1);
    let mut i = 0;
    while i < len {
        if !far(i) {
            i += 1;
            continue;
        }
        let a = i;
        while i < len && far(i) {
            i += 1;
        }
        let b = i - 1;
        let abrupt =
            a > 0 && i < len && (n[a] - n[a - 1]).abs() > jump && (n[i] - n[b]).abs() > jump;
        if abrupt && b - a < longest {
            let (lo, hi) = n[a..=b]
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
                    (lo.min(x), hi.max(x))
                });
            let values = if lo == hi {
                number_short(lo)
            } else {
                format!("{} … {}", number_short(lo), number_short(hi))
            };
            let what = if a == b {
                format!("the sample at t = {} s is {values} 1/s", number(rec.t[a]))
            } else {
                format!(
                    "the {} samples from t = {} to {} s are {values} 1/s",
                    b - a + 1,
                    number(rec.t[a]),
                    number(rec.t[b])
                )
            };
            return Err(InputError::file(
                file,
                format!(
                    "column `n`: {what}, against the channel's level (median) of {} 1/s, and the rate jumps there and back within one sample: a logger's dropout or a corrupt value (a propeller does not stop or race and recover between two samples); fill the gap or cut the recording",
                    number_short(level)
                ),
            ));
        }
    }
    Ok(())
}

/// A heading that lags the yaw rate by more than this [s] (and two samples) is refused: the turn
/// would be measured from a heading that arrives late (a 1 s gyro latency moved t_a by 10 %).
const HEADING_LAG_S: f64 = 0.4;

/// Shifts each way that [`check_heading_lag`] tries at most (a high-rate recording is thinned to them).
const MAX_LAG_SHIFTS: usize = 200;

/// The lag of the heading's rate behind the yaw rate, by the best correlation over shifts of up to
/// 2 s; refused when the channels clearly agree better shifted.
fn check_heading_lag(file: &Path, rec: &Recording) -> Result<(), InputError> {
    let n = rec.len();
    if n < 100 {
        return Ok(());
    }
    let dt = (rec.t[n - 1] - rec.t[0]) / (n - 1) as f64;
    let max_shift = ((2.0 / dt).round() as usize).clamp(1, n / 10);
    // Rates over ±0.5 s: a compass's noise differentiated sample by sample would hide any lag.
    let h = ((0.5 / dt).round() as usize).clamp(1, n / 20);
    // Both series are smooth over ±0.5 s, so a high-rate recording is compared on every stride-th
    // sample: at most MAX_LAG_SHIFTS shifts each way (20 Hz keeps every sample; 10 kHz every 100th,
    // 0.01 s apart, far finer than the lag refused), and not n × 40 000 products.
    let stride = max_shift.div_ceil(MAX_LAG_SHIFTS).max(1);
    let max_shift = max_shift / stride;
    let mut r_prefix = Vec::with_capacity(n + 1);
    r_prefix.push(0.0);
    for (i, &x) in rec.r.iter().enumerate() {
        r_prefix.push(r_prefix[i] + x);
    }
    let centres: Vec<usize> = (h..n - h).step_by(stride).collect();
    let rate: Vec<f64> = centres
        .iter()
        .map(|&i| (rec.psi[i + h] - rec.psi[i - h]) / (rec.t[i + h] - rec.t[i - h]))
        .collect();
    let r: Vec<f64> = centres
        .iter()
        .map(|&i| (r_prefix[i + h + 1] - r_prefix[i - h]) / (2 * h + 1) as f64)
        .collect();
    // Correlation of the heading's rate at i + k with the yaw rate at i (k > 0: the heading lags).
    let correlation = |k: isize| -> f64 {
        let m = rate.len() as isize;
        let range = (0.max(-k))..(m.min(m - k));
        let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
        for i in range {
            let (a, b) = (rate[(i + k) as usize], r[i as usize]);
            ab += a * b;
            aa += a * a;
            bb += b * b;
        }
        if aa > 0.0 && bb > 0.0 {
            ab / (aa * bb).sqrt()
        } else {
            0.0
        }
    };
    let at_zero = correlation(0);
    let (best_k, best) = (-(max_shift as isize)..=max_shift as isize)
        .map(|k| (k, correlation(k)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or((0, at_zero));
    let lag_s = best_k as f64 * stride as f64 * dt;
    // Smooth manoeuvres correlate highly at any small shift; what tells a lag is the unexplained
    // share 1 − ρ² falling to a quarter or less when shifted.
    let unexplained = |rho: f64| 1.0 - rho * rho;
    if lag_s.abs() >= HEADING_LAG_S
        && best_k.unsigned_abs() * stride >= 2
        && best > 0.9
        && unexplained(best) < 0.25 * unexplained(at_zero)
    {
        let (late, early) = if lag_s > 0.0 {
            ("psi", "r")
        } else {
            ("r", "psi")
        };
        return Err(InputError::file(
            file,
            format!(
                "column `{late}` lags `{early}` by {:.2} s (the heading's rate matches the yaw rate with correlation {best:.3} shifted, {at_zero:.3} as recorded): a sensor latency; shift one of them so that the channels share one clock",
                lag_s.abs()
            ),
        ));
    }
    Ok(())
}

/// Advance ratios J = u/(nD) of a working propeller lie between about 0.1 (heavily loaded, a tug
/// pulling) and 1.2 (lightly loaded); below this, or above [`ADVANCE_RATIO_MAX`], the rate is in
/// another unit than the header says (a rate in rev/min read as rev/s gives J near 0.01).
const ADVANCE_RATIO_MIN: f64 = 0.04;
/// See [`ADVANCE_RATIO_MIN`]: rev/s written under `n[rpm]` gives J sixty times too large, and a
/// diameter ten times too small ten times (J 4.6 passed at a limit of 5, and the fitted model ran
/// straight at 4 % of U0). No propeller thrusts ahead at J 2: even lightly loaded ones stop at ~1.5.
const ADVANCE_RATIO_MAX: f64 = 2.0;

/// The propeller rate of `rec` against its diameter: the median advance ratio u/(nD) over the samples
/// where the propeller turns ahead and the ship moves at a quarter of U0 at least must be a working
/// propeller's. `None` when no such sample exists.
fn median_advance_ratio(rec: &Recording, n: &[f64], diameter_m: f64, u0_m_s: f64) -> Option<f64> {
    let j: Vec<f64> = rec
        .u
        .iter()
        .zip(n)
        .filter(|(u, n)| **n > 0.0 && **u > 0.25 * u0_m_s)
        .map(|(u, n)| u / (n * diameter_m))
        .filter(|j| j.is_finite())
        .collect();
    upper_median(&j)
}

/// What an advance ratio outside a working propeller's range most likely means.
fn advance_ratio_cause(j: f64) -> Option<&'static str> {
    if j < ADVANCE_RATIO_MIN {
        Some(if (ADVANCE_RATIO_MIN..=1.5).contains(&(60.0 * j)) {
            "the rate looks like revolutions per minute: a rate in rev/min needs the header `n[rpm]`"
        } else {
            "the rate is far too high for this propeller: a wrong unit, or the wrong diameter?"
        })
    } else if j > ADVANCE_RATIO_MAX {
        Some(if (0.1..=ADVANCE_RATIO_MAX).contains(&(j / 60.0)) {
            "the rate looks like revolutions per second under an rpm header (`n[rpm]`)"
        } else {
            "the rate is too low or the diameter too small for a working propeller: check propeller.diameter_m (a diameter in another unit, or a tenth of it?) and the unit of the `n` channel"
        })
    } else {
        None
    }
}

/// Refuse a recorded propeller rate `n` whose advance ratio with the data set's propeller diameter
/// is no working propeller's: it is almost always a unit (rev/min under a bare `n`), and the MMG
/// fit would otherwise run on J ≈ 0.005 and put half its parameters on their bounds with exit 0.
pub fn check_advance_ratio(
    file: &Path,
    rec: &Recording,
    diameter_m: f64,
    u0_m_s: f64,
) -> Result<(), InputError> {
    let Some(n) = &rec.n else {
        return Ok(());
    };
    let Some(j) = median_advance_ratio(rec, n, diameter_m, u0_m_s) else {
        return Ok(());
    };
    match advance_ratio_cause(j) {
        None => Ok(()),
        Some(cause) => Err(InputError::file(
            file,
            format!(
                "the propeller rate `n` gives a median advance ratio J = u/(nD) of {} with the data set's propeller.diameter_m = {} m, where a working propeller runs at about 0.1–1.2: {cause}",
                number_short(j),
                number(diameter_m)
            ),
        )),
    }
}

/// The same test for the data set's constant `propeller.rate_rps` at the approach speed U0 (`None`
/// when it is plausible, else the message).
pub fn rate_rps_problem(rate_rps: f64, diameter_m: f64, u0_m_s: f64) -> Option<String> {
    let j = u0_m_s / (rate_rps * diameter_m);
    let cause = if (ADVANCE_RATIO_MIN..=ADVANCE_RATIO_MAX).contains(&j) {
        return None;
    } else if j < ADVANCE_RATIO_MIN && (ADVANCE_RATIO_MIN..=1.5).contains(&(60.0 * j)) {
        "it looks like revolutions per minute; rate_rps is in revolutions per second"
    } else {
        "a wrong unit, or the wrong diameter?"
    };
    Some(format!(
        "{} 1/s gives an advance ratio J = U0/(nD) of {} at U0 = {} m/s with propeller.diameter_m = {} m, where a working propeller runs at about 0.1–1.2: {cause}",
        number(rate_rps),
        number_short(j),
        number(u0_m_s),
        number(diameter_m),
    ))
}

/// Below this share of K_T(0), a recorded thrust's median K_T = T/(ρ n² D⁴) is no working
/// propeller's: the thrust is in another unit (kN under a bare header gives a thousandth).
const THRUST_K_T_LOW: f64 = 0.01;
/// Above this multiple of K_T(0) the recorded thrust is more than the propeller gives at bollard
/// pull: a unit, the wrong diameter or the wrong curve (2 × the thrust passed and was then dropped
/// by the inflow inversion without a word). A propeller moving ahead stays below K_T(0); the margin
/// is for a curve measured on another propeller or at another scale (the HSVA runs reach 0.88 × on
/// the median, 0.99 × in the tightest turn).
const THRUST_K_T_HIGH: f64 = 1.25;
/// Wake fraction no hull exceeds: the propeller runs at J_P = (1 − w_P) J ≥ this share of the
/// ship's advance ratio J = u/(nD).
const LEAST_INFLOW_SHARE: f64 = 0.5;

/// The propeller of a data set against a recording that drives it (its `n`, or the data set's
/// constant `propeller.rate_rps`) at samples where it turns ahead and the ship moves at a quarter
/// of U0 at least:
///
/// - the open-water curve must give thrust at the recording's median advance ratio, even with a
///   wake fraction of [`LEAST_INFLOW_SHARE`] (a diameter ten times too small runs at J ≈ 4.6, where
///   K_T is strongly negative);
/// - a recorded `thrust` must be a thrust of this propeller: positive in most samples, and its
///   median K_T = T/(ρ n² D⁴) between [`THRUST_K_T_LOW`] and [`THRUST_K_T_HIGH`] times K_T(0).
///   The mmg fit inverts K_T for the inflow; outside these it either put every wake parameter on its
///   bounds (thrust in kN) or dropped the channel silently (negative, doubled).
pub fn check_propeller_loading(
    file: &Path,
    rec: &Recording,
    propeller: &crate::types::PropellerData,
    rho: f64,
    u0_m_s: f64,
) -> Result<(), InputError> {
    let d = propeller.diameter_m;
    let rate_at = |i: usize| match &rec.n {
        Some(n) => n.get(i).copied(),
        None => propeller.rate_rps,
    };
    let working: Vec<(usize, f64)> = (0..rec.len())
        .filter_map(|i| rate_at(i).map(|n| (i, n)))
        .filter(|&(i, n)| n.is_finite() && n > 0.0 && rec.u[i] > 0.25 * u0_m_s)
        .collect();
    if working.is_empty() {
        return Ok(());
    }
    let rate_word = if rec.n.is_some() {
        "the `n` channel"
    } else {
        "propeller.rate_rps"
    };
    let j: Vec<f64> = working
        .iter()
        .map(|&(i, n)| rec.u[i] / (n * d))
        .filter(|j| j.is_finite())
        .collect();
    if let Some(j_median) = upper_median(&j) {
        let j_p = LEAST_INFLOW_SHARE * j_median;
        if propeller.k_t_at(j_p) <= 0.0 {
            return Err(InputError::file(
                file,
                format!(
                    "the propeller gives no thrust at this recording's advance ratio: the median J = u/(nD) is {} with propeller.diameter_m = {} m and {rate_word}, and the open-water curve's K_T is {} ≤ 0 already at J = {} (a wake fraction of {}); check propeller.diameter_m (a tenth of it?), the unit of {rate_word}, or the curve",
                    number_short(j_median),
                    number(d),
                    number_short(propeller.k_t_at(j_p)),
                    number_short(j_p),
                    1.0 - LEAST_INFLOW_SHARE
                ),
            ));
        }
    }
    let Some(thrust) = &rec.thrust else {
        return Ok(());
    };
    let k_t: Vec<f64> = working
        .iter()
        .filter_map(|&(i, n)| thrust.get(i).map(|t| t / (rho * n * n * d.powi(4))))
        .filter(|k| k.is_finite())
        .collect();
    if k_t.len() < 10 {
        return Ok(());
    }
    let k0 = propeller.k_t[0];
    let count = k_t.len();
    let not_ahead = k_t.iter().filter(|&&k| k <= 0.0).count();
    if 2 * not_ahead > count {
        let cause = if k_t.iter().all(|&k| k == 0.0) {
            "an empty channel? Leave the column out when the thrust was not measured"
        } else {
            "the other sign? Thrust is positive when it pushes the ship ahead"
        };
        return Err(InputError::file(
            file,
            format!(
                "column `thrust` is ≤ 0 in {not_ahead} of the {count} samples where the propeller turns ahead and the ship moves ({cause})"
            ),
        ));
    }
    let median = upper_median(&k_t).unwrap_or(f64::NAN);
    let share = median / k0;
    let beyond = |above: bool| {
        k_t.iter()
            .filter(|&&k| {
                if above {
                    k > k0
                } else {
                    k < THRUST_K_T_LOW * k0
                }
            })
            .count()
    };
    let cause = if share < THRUST_K_T_LOW {
        let kilo = 1000.0 * share;
        let hint = if (THRUST_K_T_LOW..=THRUST_K_T_HIGH).contains(&kilo) {
            "the thrust in kN under a bare header? Write `thrust[kN]`"
        } else {
            "the thrust in another unit (write it in the header, e.g. `thrust[kN]`), or the wrong diameter or curve?"
        };
        format!(
            "{} × the curve's K_T(0) = {}, below it in {} of {count} samples; {hint}",
            number_short(share),
            number_short(k0),
            beyond(false)
        )
    } else if share > THRUST_K_T_HIGH {
        format!(
            "{} × the open-water curve's K_T(0) = {}, above it in {} of {count} samples, more than the propeller gives at bollard pull; the thrust in another unit, or the wrong propeller.diameter_m or curve?",
            number_short(share),
            number_short(k0),
            beyond(true)
        )
    } else {
        return Ok(());
    };
    Err(InputError::file(
        file,
        format!(
            "column `thrust` gives a median K_T = T/(ρ n² D⁴) of {} with propeller.diameter_m = {} m and {rate_word}: {cause}",
            number_short(median),
            number(d)
        ),
    ))
}
