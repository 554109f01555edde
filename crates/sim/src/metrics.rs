//! IMO manoeuvring metrics (MSC.137(76); keys and definitions in `docs/conventions.md`) of a recording, measured or simulated,
//! by one code path.
//!
//! Definitions, chosen to work on noisy tank data as well as on simulations:
//! - **First execute**: the rudder put over is the first departure from the first sample by more than a
//!   quarter of the rudder amplitude ([`DEFINITE_FRACTION`]); the stroke that led there is the run of
//!   samples moving monotonically towards it, and the rudder's initial value δ₀ is the median of the
//!   samples before that stroke (the first sample when the record starts with it). The first execute
//!   is where the stroke first departs from δ₀ by more than [`execute_threshold_deg`] (0.5°, or 10 % of
//!   the rudder amplitude if that is smaller), with the crossing time interpolated linearly and moved
//!   back by threshold / rudder rate, i.e. to the moment a rudder moving at the ship's rudder rate
//!   would have left δ₀. A rudder signal that is quantised or jitters at neutral by more than the
//!   threshold (a step of a real rudder encoder is about 0.5°) thus does not fake an execute. If the
//!   rudder is first put over towards the side opposite to the declared one, the record does not
//!   perform the declared manoeuvre and every metric is undefined. The heading ψ₀ and the midship
//!   position at the first execute (interpolated) are the original course and the origin.
//! - **Zig-zag**: with the heading deviation ψ − ψ₀ counted positive towards the first execute side,
//!   execute k+1 (k ≥ 1) is where the deviation first crosses the check angle with alternating sign
//!   (+, −, +, …), interpolated linearly. Overshoot k is the extreme deviation beyond the check angle
//!   between execute k+1 and execute k+2 (or the end of the record). It is defined only for a real peak:
//!   the heading must turn back afterwards (execute k+2 exists, or a later sample of the record is
//!   smaller). The peak is the plateau of samples within 1.5 heading resolutions of the extreme one
//!   (the heading's smallest step near the peak, at least the last of 6 significant digits), refined by
//!   the least-squares parabola through it and the sample either side: a single extreme sample gets
//!   the usual three-point parabola, and a flat-topped peak is not taken at the first or last sample
//!   of a tie that a change below the data's resolution makes or breaks.
//!   t_a = execute 2 − execute 1 and t_check = first overshoot peak − execute 2, both × U0/L.
//! - **Turning circle**: along-course and lateral (positive towards the turn) distances of midship from
//!   the first-execute position. Advance and transfer are taken where the heading change first reaches
//!   90°, the tactical diameter (lateral distance) where it first reaches 180°, all interpolated
//!   linearly between samples. The steady diameter is the diameter of a least-squares (Kåsa) circle
//!   fitted to the track over the last 360° of heading change; it needs at least 540° of heading change
//!   in the record, so that the fitted turn starts after the 180° point. All ÷ L.
//! - **A recorded current**: a record that carries one is measured relative to the water
//!   ([`relative_to_water`]: its drift taken out of the track, its velocities through the water), as
//!   trials correct their turning circles; a simulation in a recorded current carries it too, so the
//!   two compare alike.

use std::borrow::Cow;

use serde::{Deserialize, Serialize};
use shipid_io::{Manoeuvre, Recording, Ship, Side};

/// Manoeuvre metrics with the keys of every JSON output and table column; `None` (absent in JSON) where
/// undefined.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Metrics {
    /// First zig-zag overshoot [deg].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub overshoot_1: Option<f64>,
    /// Second zig-zag overshoot [deg].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub overshoot_2: Option<f64>,
    /// Time from first to second execute × U0/L [-].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub t_a: Option<f64>,
    /// Time from second execute to the first overshoot peak × U0/L [-].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub t_check: Option<f64>,
    /// Advance at 90° heading change ÷ L [-].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub advance: Option<f64>,
    /// Transfer at 90° heading change ÷ L [-].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transfer: Option<f64>,
    /// Lateral distance at 180° heading change ÷ L [-].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tactical_diameter: Option<f64>,
    /// Diameter of the steady turning circle ÷ L [-].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub steady_diameter: Option<f64>,
}

impl Metrics {
    /// `(key, value)` for all eight metrics, in the documented order (overshoots, t_a, t_check, then the
    /// turning-circle metrics).
    pub fn entries(&self) -> [(&'static str, Option<f64>); 8] {
        [
            ("overshoot_1", self.overshoot_1),
            ("overshoot_2", self.overshoot_2),
            ("t_a", self.t_a),
            ("t_check", self.t_check),
            ("advance", self.advance),
            ("transfer", self.transfer),
            ("tactical_diameter", self.tactical_diameter),
            ("steady_diameter", self.steady_diameter),
        ]
    }
}

/// The unit a metric of [`Metrics::entries`] is given in, as printed beside it: overshoots in degrees,
/// times in L/U0 (t·U0/L), lengths in ship lengths.
pub fn metric_unit(key: &str) -> Option<&'static str> {
    match key {
        "overshoot_1" | "overshoot_2" => Some("°"),
        "t_a" | "t_check" => Some("L/U0"),
        "advance" | "transfer" | "tactical_diameter" | "steady_diameter" => Some("L"),
        _ => None,
    }
}

/// Rudder departure [deg] from its initial value that marks the first execute for a rudder amplitude of
/// `rudder_deg`: 0.5°, or 10 % of the amplitude if smaller. Well above the noise of tank rudder signals
/// (HSVA: a few hundredths of a degree) and reached within 0.04 s at a rudder rate of 15.8 °/s.
pub fn execute_threshold_deg(rudder_deg: f64) -> f64 {
    0.5f64.min(0.1 * rudder_deg.abs())
}

/// Time, heading and midship position at the first rudder execute.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FirstExecute {
    /// Time [s].
    pub t_s: f64,
    /// Heading ψ₀ [rad]: the original course.
    pub psi_rad: f64,
    /// North position of midship [m].
    pub x0_m: f64,
    /// East position of midship [m].
    pub y0_m: f64,
    /// The rudder's neutral on the approach [rad]: the median before the stroke, from which the
    /// execute is measured.
    pub rudder_rad: f64,
}

/// An overshoot peak of a zig-zag.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Overshoot {
    /// Time of the peak [s].
    pub t_s: f64,
    /// Heading beyond the check angle at the peak [deg], positive.
    pub angle_deg: f64,
}

/// Rudder executes and overshoot peaks of a zig-zag record.
#[derive(Debug, Clone, PartialEq)]
pub struct ZigZagEvents {
    /// The first execute.
    pub first: FirstExecute,
    /// Times of execute 1, 2, 3, … [s] (execute 1 = `first.t_s`).
    pub executes_s: Vec<f64>,
    /// Overshoot 1, 2, … up to the first undefined one.
    pub overshoots: Vec<Overshoot>,
}

/// The metrics of `manoeuvre` in `rec` for `ship` (its L and U0 scale them). Metrics that the record does
/// not reach, a [`Manoeuvre::Free`], and unusable records (fewer than three samples, unequal column
/// lengths, non-finite values, time not increasing) give `None`.
pub fn metrics(rec: &Recording, manoeuvre: &Manoeuvre, ship: &Ship) -> Metrics {
    if !(usable(rec) && ship.lpp > 0.0 && ship.u0 > 0.0) {
        return Metrics::default();
    }
    let rec = relative_to_water(rec);
    let rec = rec.as_ref();
    let m = match *manoeuvre {
        Manoeuvre::ZigZag {
            rudder_deg,
            check_deg,
            side,
        } => zigzag_metrics(rec, rudder_deg, check_deg, side, ship),
        Manoeuvre::Turning { rudder_deg, side } => turning_metrics(rec, rudder_deg, side, ship),
        Manoeuvre::Free => Metrics::default(),
    };
    m.finite_only()
}

impl Metrics {
    /// Every non-finite value undefined: finite samples can still overflow in a difference (a heading
    /// of 1e308 rad), and JSON would write such a value as `null` instead of leaving the key out.
    fn finite_only(self) -> Metrics {
        let keep = |v: Option<f64>| v.filter(|x| x.is_finite());
        Metrics {
            overshoot_1: keep(self.overshoot_1),
            overshoot_2: keep(self.overshoot_2),
            t_a: keep(self.t_a),
            t_check: keep(self.t_check),
            advance: keep(self.advance),
            transfer: keep(self.transfer),
            tactical_diameter: keep(self.tactical_diameter),
            steady_diameter: keep(self.steady_diameter),
        }
    }
}

fn usable(rec: &Recording) -> bool {
    let n = rec.t.len();
    let cols = [&rec.x0, &rec.y0, &rec.psi, &rec.delta];
    n >= 3
        && cols
            .iter()
            .all(|c| c.len() == n && c.iter().all(|x| x.is_finite()))
        && rec.t.iter().all(|x| x.is_finite())
        && rec.t.windows(2).all(|w| w[1] > w[0])
}

/// Linear interpolation of `y(t)` at `tq` (held at the ends; `t` increasing, not empty): the one
/// every sampled series is read with (a recorded rudder, a recorded propeller rate, a simulation
/// against its recording).
pub fn interp(t: &[f64], y: &[f64], tq: f64) -> f64 {
    let i = t.partition_point(|&x| x <= tq);
    if i == 0 {
        y[0]
    } else if i == t.len() {
        y[t.len() - 1]
    } else {
        let w = (tq - t[i - 1]) / (t[i] - t[i - 1]);
        y[i - 1] + w * (y[i] - y[i - 1])
    }
}

/// Fraction of the rudder amplitude beyond which a departure is the rudder put over rather than the
/// jitter or quantisation of a rudder signal at rest (module docs, "First execute").
pub const DEFINITE_FRACTION: f64 = 0.25;

/// The stroke that first carries the rudder more than `definite` [rad] towards `towards` (±1) from
/// `reference`, searched from sample `from` up to (not including) `until`: the index of the first
/// sample past that, and the index where the monotone run of samples leading there starts. `None`
/// when the rudder does not get there, or first gets as far towards the other side.
fn stroke(
    delta: &[f64],
    from: usize,
    until: usize,
    reference: f64,
    towards: f64,
    definite: f64,
) -> Option<(usize, usize)> {
    let k = (from..until).find(|&i| (delta[i] - reference).abs() > definite)?;
    if towards * (delta[k] - reference) <= 0.0 {
        return None;
    }
    let mut m = k;
    while m > 0 && towards * delta[m - 1] <= towards * delta[m] {
        m -= 1;
    }
    Some((k, m))
}

/// The first execute towards `side` (see the module docs), or `None` when the rudder is never put over,
/// or is first put over towards the other side.
pub fn first_execute(
    rec: &Recording,
    rudder_deg: f64,
    side: Side,
    ship: &Ship,
) -> Option<FirstExecute> {
    if !(usable(rec) && rudder_deg.is_finite() && rudder_deg > 0.0) {
        return None;
    }
    let thr = execute_threshold_deg(rudder_deg).to_radians();
    let s = side.sign();
    let definite = DEFINITE_FRACTION * rudder_deg.to_radians();
    let (k, m) = stroke(&rec.delta, 0, rec.delta.len(), rec.delta[0], s, definite)?;
    let d0 = median(&rec.delta[..=m]);
    // The stroke passes the threshold at the latest at k (a quarter of the amplitude is above it).
    let i = (m..=k).find(|&i| s * (rec.delta[i] - d0) > thr)?;
    let crossing = if i == m {
        // The stroke starts beyond the threshold (a jump within one sample interval).
        rec.t[i]
    } else {
        let (a0, a1) = (s * (rec.delta[i - 1] - d0), s * (rec.delta[i] - d0));
        rec.t[i - 1] + (thr - a0) / (a1 - a0) * (rec.t[i] - rec.t[i - 1])
    };
    let rate = ship.rudder_rate_rad_s();
    let back = if rate.is_finite() && rate > 0.0 {
        thr / rate
    } else {
        0.0
    };
    let t_s = (crossing - back).max(rec.t[0]);
    Some(FirstExecute {
        t_s,
        psi_rad: interp(&rec.t, &rec.psi, t_s),
        x0_m: interp(&rec.t, &rec.x0, t_s),
        y0_m: interp(&rec.t, &rec.y0, t_s),
        rudder_rad: d0,
    })
}

/// `rec` relative to the water when it carries a recorded current: positions with the current's
/// drift since the first sample taken out (the track through the water, to which trials correct
/// their turning circles) and velocities through the water; `rec` itself otherwise. A uniform
/// current only carries the ship along, so a manoeuvre's metrics through the water are those of
/// calm water.
pub fn relative_to_water(rec: &Recording) -> Cow<'_, Recording> {
    let n = rec.t.len();
    let Some(current) = rec.current.as_ref().filter(|c| {
        c.speed_m_s.len() == n
            && c.from_rad.len() == n
            && [&rec.x0, &rec.y0, &rec.psi, &rec.u, &rec.v]
                .iter()
                .all(|col| col.len() == n)
    }) else {
        return Cow::Borrowed(rec);
    };
    let mut out = rec.clone();
    let (mut drift_n, mut drift_e) = (0.0, 0.0);
    for i in 0..n {
        let [cn, ce] = current.velocity_earth(i);
        if i > 0 {
            // Trapezoidal drift over the sample interval.
            let [pn, pe] = current.velocity_earth(i - 1);
            let dt = rec.t[i] - rec.t[i - 1];
            drift_n += 0.5 * (pn + cn) * dt;
            drift_e += 0.5 * (pe + ce) * dt;
        }
        out.x0[i] -= drift_n;
        out.y0[i] -= drift_e;
        let (s, c) = rec.psi[i].sin_cos();
        out.u[i] -= cn * c + ce * s;
        out.v[i] -= -cn * s + ce * c;
    }
    out.current = None;
    out.accelerations = None;
    Cow::Owned(out)
}

/// The approach a manoeuvre's metrics start from (IMO metrics assume a steady straight approach at
/// the ship's U0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Approach {
    /// Speed of midship at the first execute ÷ U0 [-] (a straight line fitted to the speed over the
    /// L/U0 before it, taken at the execute).
    pub speed_ratio: f64,
    /// Change of that line over the L/U0 before the first execute ÷ U0 [-] (positive: accelerating).
    pub change_ratio: f64,
    /// Standard error of that change from the scatter of the speed about the line ÷ U0 [-]: a
    /// change within a few of these is the recording's noise, not an acceleration.
    pub change_standard_error: f64,
}

/// The approach of `rec` for `manoeuvre` (a zig-zag or a turning circle whose first execute the
/// record shows); `None` otherwise.
pub fn approach(rec: &Recording, manoeuvre: &Manoeuvre, ship: &Ship) -> Option<Approach> {
    let (rudder_deg, side) = match *manoeuvre {
        Manoeuvre::ZigZag {
            rudder_deg, side, ..
        }
        | Manoeuvre::Turning { rudder_deg, side } => (rudder_deg, side),
        Manoeuvre::Free => return None,
    };
    if !(ship.u0 > 0.0 && ship.lpp > 0.0)
        || rec.u.len() != rec.t.len()
        || rec.v.len() != rec.t.len()
    {
        return None;
    }
    let first = first_execute(rec, rudder_deg, side, ship)?;
    let rec = relative_to_water(rec);
    // A straight line fitted to the speed over the L/U0 before the execute: its value there and its
    // change over that time, which the noise of single samples does not move (2 % of U0 on every
    // sample of a steady approach).
    let t_from = first.t_s - ship.lpp / ship.u0;
    let window: Vec<(f64, f64)> = (0..rec.t.len())
        .filter(|&i| rec.t[i] >= t_from && rec.t[i] <= first.t_s)
        .map(|i| (rec.t[i] - first.t_s, rec.u[i].hypot(rec.v[i])))
        .collect();
    let (at, slope, slope_se) = match window.len() {
        0 => (
            interp(&rec.t, &rec.u, first.t_s).hypot(interp(&rec.t, &rec.v, first.t_s)),
            0.0,
            0.0,
        ),
        1 | 2 => (window[window.len() - 1].1, 0.0, 0.0),
        n => {
            let n = n as f64;
            let (mt, ms) = window
                .iter()
                .fold((0.0, 0.0), |(a, b), (t, s)| (a + t / n, b + s / n));
            let (sts, stt) = window.iter().fold((0.0, 0.0), |(a, b), (t, s)| {
                (a + (t - mt) * (s - ms), b + (t - mt) * (t - mt))
            });
            let slope = if stt > 0.0 { sts / stt } else { 0.0 };
            // The line at the execute (t = 0 in the window's time), and the standard error of its
            // slope from the scatter about it.
            let at = ms - slope * mt;
            let scatter = window
                .iter()
                .map(|(t, s)| (s - (at + slope * t)).powi(2))
                .sum::<f64>()
                / (n - 2.0).max(1.0);
            let se = if stt > 0.0 {
                (scatter / stt).sqrt()
            } else {
                0.0
            };
            (at, slope, se)
        }
    };
    let span = first.t_s - t_from.max(rec.t[0]);
    let a = Approach {
        speed_ratio: at / ship.u0,
        change_ratio: slope * span / ship.u0,
        change_standard_error: slope_se * span / ship.u0,
    };
    (a.speed_ratio.is_finite() && a.change_ratio.is_finite()).then_some(a)
}

/// Why `rec` has no first execute towards `side` for a rudder of `rudder_deg` ([`first_execute`]
/// gives `None`), in words for an error message; `None` when it has one or is not usable at all.
pub fn missing_execute_reason(rec: &Recording, rudder_deg: f64, side: Side) -> Option<String> {
    if !(usable(rec) && rudder_deg.is_finite() && rudder_deg > 0.0) {
        return None;
    }
    let definite = DEFINITE_FRACTION * rudder_deg.to_radians();
    let d_start = rec.delta[0];
    let side_name = |s: f64| if s > 0.0 { "starboard" } else { "port" };
    match rec.delta.iter().find(|d| (*d - d_start).abs() > definite) {
        None => Some(format!(
            "its rudder never moves more than {:.1}° (a quarter of the declared {rudder_deg}°) from its first value",
            definite.to_degrees()
        )),
        Some(d) if (d - d_start) * side.sign() <= 0.0 => Some(format!(
            "its rudder is first put over to {}, while the data set declares {}",
            side_name(-side.sign()),
            side_name(side.sign())
        )),
        Some(_) => None,
    }
}

/// Median of a non-empty slice.
pub fn median(x: &[f64]) -> f64 {
    let mut v = x.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// First index `i ≥ from` where `sign · f` goes from below `level` at `i − 1` to at least `level` at
/// `i`, with the interpolated crossing fraction between the two samples.
fn crossing(f: &[f64], sign: f64, level: f64, from: usize) -> Option<(usize, f64)> {
    (from.max(1)..f.len())
        .find(|&i| sign * f[i - 1] < level && sign * f[i] >= level)
        .map(|i| (i, (level - sign * f[i - 1]) / (sign * (f[i] - f[i - 1]))))
}

/// Vertex of the parabola through three points when it is a maximum inside their span, else the middle
/// point.
fn parabola_peak(t: [f64; 3], y: [f64; 3]) -> (f64, f64) {
    let (h0, h2) = (t[0] - t[1], t[2] - t[1]);
    let (d0, d2) = (y[0] - y[1], y[2] - y[1]);
    let a = (d0 / h0 - d2 / h2) / (h0 - h2);
    let b = d0 / h0 - a * h0;
    if a < 0.0 {
        let s = -b / (2.0 * a);
        if s >= h0 && s <= h2 {
            return (t[1] + s, y[1] - b * b / (4.0 * a));
        }
    }
    (t[1], y[1])
}

/// Significant digits of a heading written as text that the overshoot peak's resolution assumes at
/// least (`%g`-like output: six). Data written with fewer digits show a coarser step, which
/// [`heading_resolution_rad`] finds in the samples.
pub const HEADING_SIGNIFICANT_DIGITS: i32 = 6;

/// The heading's resolution [rad] around a peak: the larger of its smallest non-zero step between
/// consecutive samples of `window` (the quantum of a rounded or encoded heading) and the last of
/// [`HEADING_SIGNIFICANT_DIGITS`] significant digits of the heading `psi_peak_rad` (the rounding that
/// writing the data leaves). Differences below it cannot order two samples.
pub fn heading_resolution_rad(
    psi: &[f64],
    window: std::ops::Range<usize>,
    psi_peak_rad: f64,
) -> f64 {
    let quantum = psi[window]
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|d| *d > 0.0 && d.is_finite())
        .fold(f64::INFINITY, f64::min);
    let quantum = if quantum.is_finite() { quantum } else { 0.0 };
    let magnitude = psi_peak_rad.abs();
    let digits = if magnitude > 0.0 && magnitude.is_finite() {
        10f64.powi(magnitude.log10().floor() as i32 + 1 - HEADING_SIGNIFICANT_DIGITS)
    } else {
        0.0
    };
    quantum.max(digits)
}

/// Time [s] and value [rad] of the peak of `sigma · dev` at sample `i_max`, the largest in `window`.
///
/// The peak is the plateau around `i_max`: the contiguous samples of the window within 1.5 heading
/// resolutions ([`heading_resolution_rad`]) of the largest. Rounded values differ by whole steps, so
/// half a step of margin takes in the samples one step below (before the rounding they may have been
/// the larger) and none further; a creep below the resolution is a tie. A single-sample plateau is
/// refined by the parabola through it and its two neighbours ([`parabola_peak`]); a longer one by the
/// least-squares parabola through the plateau and its two neighbours, which is exact on a smooth peak
/// and takes a flat-topped one at the vertex over its whole run, not at its first or last sample, so
/// that a change of the data below their resolution moves it by less than a sample.
fn refined_peak(
    t: &[f64],
    dev: &[f64],
    psi: &[f64],
    sigma: f64,
    window: std::ops::Range<usize>,
    i_max: usize,
) -> (f64, f64) {
    let peak_value = sigma * dev[i_max];
    let tol = 1.5 * heading_resolution_rad(psi, window.clone(), psi[i_max]);
    let on_plateau = |j: usize| window.contains(&j) && sigma * dev[j] >= peak_value - tol;
    let mut first = i_max;
    while first > 0 && on_plateau(first - 1) {
        first -= 1;
    }
    let mut last = i_max;
    while on_plateau(last + 1) {
        last += 1;
    }
    let middle = 0.5 * (t[first] + t[last]);
    if first == 0 || last + 1 >= t.len() {
        return (middle, peak_value);
    }
    if first == last {
        return parabola_peak(
            [t[i_max - 1], t[i_max], t[i_max + 1]],
            [sigma * dev[i_max - 1], peak_value, sigma * dev[i_max + 1]],
        );
    }
    least_squares_peak(&t[first - 1..=last + 1], &dev[first - 1..=last + 1], sigma)
        .unwrap_or((middle, peak_value))
}

/// Vertex of the least-squares parabola through `(t, sigma · y)` when it is a maximum inside their
/// span; `None` otherwise (or when the fit is singular).
fn least_squares_peak(t: &[f64], y: &[f64], sigma: f64) -> Option<(f64, f64)> {
    let (t_lo, t_hi) = (*t.first()?, *t.last()?);
    let (tc, half) = (0.5 * (t_lo + t_hi), 0.5 * (t_hi - t_lo));
    if half.is_nan() || half <= 0.0 {
        return None;
    }
    // Normal equations in x = (t − tc)/half ∈ [−1, 1]: y ≈ c0 + c1 x + c2 x².
    let (mut m, mut b) = ([[0.0; 3]; 3], [0.0; 3]);
    for (&ti, &yi) in t.iter().zip(y) {
        let x = (ti - tc) / half;
        let phi = [1.0, x, x * x];
        for r in 0..3 {
            for c in 0..3 {
                m[r][c] += phi[r] * phi[c];
            }
            b[r] += phi[r] * sigma * yi;
        }
    }
    let [c0, c1, c2] = solve3(m, b)?;
    if c2.is_nan() || c2 >= 0.0 {
        return None;
    }
    let x = -c1 / (2.0 * c2);
    (x.abs() <= 1.0).then(|| (tc + x * half, c0 - c1 * c1 / (4.0 * c2)))
}

/// Executes and overshoots of a zig-zag `rudder_deg`/`check_deg` to `side` (see the module docs).
pub fn zigzag_events(
    rec: &Recording,
    rudder_deg: f64,
    check_deg: f64,
    side: Side,
    ship: &Ship,
) -> Option<ZigZagEvents> {
    if !(check_deg.is_finite() && check_deg > 0.0) {
        return None;
    }
    let first = first_execute(rec, rudder_deg, side, ship)?;
    let t = &rec.t;
    let n = t.len();
    let s = side.sign();
    let check = check_deg.to_radians();
    let dev: Vec<f64> = rec.psi.iter().map(|p| s * (p - first.psi_rad)).collect();

    // Sample index after which to look for the next execute, and the executes with their sample index.
    let start = t.partition_point(|&x| x <= first.t_s);
    let mut executes = vec![(first.t_s, start)];
    let mut sigma = 1.0;
    let mut from = start;
    while let Some((i, w)) = crossing(&dev, sigma, check, from) {
        executes.push((t[i - 1] + w * (t[i] - t[i - 1]), i));
        sigma = -sigma;
        from = i + 1;
    }

    let mut overshoots = Vec::new();
    for k in 1..executes.len() {
        let sigma = if k % 2 == 1 { 1.0 } else { -1.0 };
        let lo = executes[k].1;
        let hi = executes.get(k + 1).map_or(n, |e| e.1);
        let Some(i_max) = (lo..hi).max_by(|&a, &b| {
            (sigma * dev[a])
                .total_cmp(&(sigma * dev[b]))
                .then(b.cmp(&a))
        }) else {
            break;
        };
        let peak_value = sigma * dev[i_max];
        let turned_back =
            executes.get(k + 1).is_some() || (i_max + 1..n).any(|j| sigma * dev[j] < peak_value);
        if !turned_back {
            break;
        }
        let (t_peak, value) = refined_peak(t, &dev, &rec.psi, sigma, lo..hi, i_max);
        overshoots.push(Overshoot {
            t_s: t_peak,
            angle_deg: (value - check).to_degrees(),
        });
    }
    Some(ZigZagEvents {
        first,
        executes_s: executes.iter().map(|e| e.0).collect(),
        overshoots,
    })
}

/// The reaction delay [s] of a recorded zig-zag's rudder reversals: the median, over the reversals the
/// record shows, of the time from the heading reaching the check angle (execute k+1, k ≥ 1) to the
/// rudder leaving its held angle towards the other side (the first sample past
/// [`execute_threshold_deg`], moved back along a rudder moving at the ship's rudder rate). A helmsman or an autopilot that reacts late
/// makes every overshoot larger than the standard law's immediate reversal would; a re-simulation
/// that compares overshoots with the record needs the record's own delay. A reversal whose rudder has
/// not left before the next check is not counted; a median below a tenth of the sampling interval is
/// read as 0 (an immediate reversal, within what the samples resolve). `None` for a record that is not a zig-zag with a measurable reversal.
pub fn check_reaction_delay_s(
    rec: &Recording,
    rudder_deg: f64,
    check_deg: f64,
    side: Side,
    ship: &Ship,
) -> Option<f64> {
    let ev = zigzag_events(rec, rudder_deg, check_deg, side, ship)?;
    let thr = execute_threshold_deg(rudder_deg).to_radians();
    let definite = DEFINITE_FRACTION * rudder_deg.to_radians();
    let rate = ship.rudder_rate_rad_s();
    let t = &rec.t;
    let mut delays: Vec<f64> = Vec::new();
    for k in 1..ev.executes_s.len() {
        let t_check = ev.executes_s[k];
        let t_next = ev.executes_s.get(k + 1).copied().unwrap_or(f64::INFINITY);
        // The rudder reverses towards the side opposite to the one it held: − side after the odd
        // checks, + side after the even ones.
        let towards = if k % 2 == 1 {
            -side.sign()
        } else {
            side.sign()
        };
        let i = t.partition_point(|&x| x < t_check);
        if i == 0 || i >= t.len() {
            continue;
        }
        // The last sample before the check: interpolating to the check itself would mix in the
        // reversal when it starts inside the sample interval. A rudder that already moves there (an
        // early reaction) gives a delay of about 0.
        let held = rec.delta[i - 1];
        // The reversal's stroke (not a step of a quantised rudder at its held angle), and its first
        // sample past the threshold.
        let until = t.partition_point(|&x| x < t_next);
        let Some((k, m)) = stroke(&rec.delta, i, until, held, towards, definite) else {
            continue;
        };
        let Some(j) = (m.max(i)..=k).find(|&j| towards * (rec.delta[j] - held) > thr) else {
            continue;
        };
        let a1 = towards * (rec.delta[j] - held);
        // Back from the first sample past the threshold along a rudder moving at the ship's rate: the
        // departure itself, where interpolating between the samples around the kink would put it up
        // to a fraction of a sample late.
        let departed = if rate.is_finite() && rate > 0.0 {
            t[j] - a1 / rate
        } else {
            t[j]
        };
        delays.push((departed - t_check).max(0.0));
    }
    if delays.is_empty() {
        return None;
    }
    let median = median(&delays);
    // Below a tenth of the sampling interval the delay is the interpolation's error, not a reaction
    // (a reversal at the check measures 1e-5 s on the default data): an immediate reversal.
    let interval = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
    Some(if median < 0.1 * interval { 0.0 } else { median })
}

/// Samples a rudder must hold its angle for before [`held_rudder_deg`] reads the angle from them.
const HELD_MIN_SAMPLES: usize = 5;

/// The rudder angle [deg] a zig-zag or turning record holds after its first execute towards `side`:
/// the median of |δ − δ₀| (δ₀ the approach's rudder, [`FirstExecute::rudder_rad`]) over the samples where the rudder is within
/// [`execute_threshold_deg`] of its largest departure and moves slower than a tenth of the ship's
/// rudder rate. `None` when fewer than [`HELD_MIN_SAMPLES`] samples do (a rudder reversed before it
/// reaches its angle, or a signal too noisy to tell): the declared angle can then not be checked.
pub fn held_rudder_deg(rec: &Recording, rudder_deg: f64, side: Side, ship: &Ship) -> Option<f64> {
    let first = first_execute(rec, rudder_deg, side, ship)?;
    let d0 = first.rudder_rad;
    let t = &rec.t;
    let start = t.partition_point(|&x| x < first.t_s);
    let largest = rec.delta[start..]
        .iter()
        .map(|d| (d - d0).abs())
        .fold(0.0_f64, f64::max);
    let near = execute_threshold_deg(rudder_deg).to_radians();
    let rate = ship.rudder_rate_rad_s();
    let slow = if rate.is_finite() && rate > 0.0 {
        0.1 * rate
    } else {
        f64::INFINITY
    };
    let held: Vec<f64> = (start.max(1)..t.len().saturating_sub(1))
        .filter(|&i| {
            let moving = (rec.delta[i + 1] - rec.delta[i - 1]).abs() / (t[i + 1] - t[i - 1]);
            (rec.delta[i] - d0).abs() >= largest - near && moving < slow
        })
        .map(|i| (rec.delta[i] - d0).abs())
        .collect();
    (held.len() >= HELD_MIN_SAMPLES).then(|| median(&held).to_degrees())
}

/// The heading turned [deg] at each rudder reversal of a zig-zag record, found from the rudder alone:
/// for reversal k the heading change from the first execute towards the side the ship was being
/// steered (positive when it has turned that way), at the last sample where the rudder still held
/// its angle before it crossed to the other side. A standard zig-zag reverses when this reaches the
/// check angle; much less than the declared check angle means the test used a smaller one, and every
/// overshoot measured beyond the declared angle is then too small. `None` for a record without a
/// first execute towards `side`; empty when the rudder never reverses.
pub fn heading_at_reversals_deg(
    rec: &Recording,
    rudder_deg: f64,
    side: Side,
    ship: &Ship,
) -> Option<Vec<f64>> {
    let first = first_execute(rec, rudder_deg, side, ship)?;
    let d0 = first.rudder_rad;
    let s = side.sign();
    let definite = DEFINITE_FRACTION * rudder_deg.to_radians();
    let near = execute_threshold_deg(rudder_deg).to_radians();
    let n = rec.t.len();
    let mut from = rec.t.partition_point(|&x| x < first.t_s);
    // +1 while the rudder is on the first execute's side (relative to `s`), −1 on the other.
    let mut on = 1.0;
    let mut turned = Vec::new();
    while let Some(other) = (from..n).find(|&i| on * s * (rec.delta[i] - d0) < -definite) {
        let held = rec.delta[from..other]
            .iter()
            .map(|d| on * s * (d - d0))
            .fold(f64::NEG_INFINITY, f64::max);
        let Some(departed) = (from..other)
            .rev()
            .find(|&i| on * s * (rec.delta[i] - d0) >= held - near)
        else {
            break;
        };
        turned.push((on * s * (rec.psi[departed] - first.psi_rad)).to_degrees());
        from = other;
        on = -on;
    }
    Some(turned)
}

/// Heading change from the original course [deg] beyond which a run has left its manoeuvre: a
/// turning circle turned this far against its rudder, or a zig-zag's heading this far off course (a
/// standard zig-zag stays within its check angle plus an overshoot of a few tens of degrees).
pub const LOST_MANOEUVRE_DEG: f64 = 90.0;

/// How a run of `manoeuvre` left it, in words, or `None`: a turning circle whose ship turns more than
/// [`LOST_MANOEUVRE_DEG`] the other way than its rudder, a zig-zag whose heading runs more than that
/// off the original course. The run itself may be finite and bounded (status ok), but its metrics
/// then describe no such manoeuvre, and a longer run does not define the missing ones.
pub fn lost_manoeuvre(rec: &Recording, manoeuvre: &Manoeuvre, ship: &Ship) -> Option<String> {
    let (rudder_deg, side, zigzag) = match *manoeuvre {
        Manoeuvre::ZigZag {
            rudder_deg, side, ..
        } => (rudder_deg, side, true),
        Manoeuvre::Turning { rudder_deg, side } => (rudder_deg, side, false),
        Manoeuvre::Free => return None,
    };
    let first = first_execute(rec, rudder_deg, side, ship)?;
    let start = rec.t.partition_point(|&t| t < first.t_s);
    let s = side.sign();
    let side_name = |sign: f64| if sign > 0.0 { "starboard" } else { "port" };
    let dev = |i: usize| (s * (rec.psi[i] - first.psi_rad)).to_degrees();
    if zigzag {
        let i = (start..rec.t.len()).find(|&i| dev(i).abs() > LOST_MANOEUVRE_DEG)?;
        Some(format!(
            "the heading runs more than {LOST_MANOEUVRE_DEG}° off the original course at t = {:.1} s ({:.0}° at the end): the rudder no longer brings it back, and the run is no zig-zag from there",
            rec.t[i],
            dev(rec.t.len() - 1).abs()
        ))
    } else {
        // Against the rudder from the furthest it had turned its way (0 at the execute): a turn that
        // winds up and then unwinds with the rudder still held is as lost as one that never wound.
        let mut furthest = 0.0_f64;
        let i = (start..rec.t.len()).find(|&i| {
            furthest = furthest.max(dev(i));
            dev(i) < furthest - LOST_MANOEUVRE_DEG
        })?;
        Some(format!(
            "the ship turns back to {} with the rudder held to {} (more than {LOST_MANOEUVRE_DEG}° from its furthest heading to {} by t = {:.1} s): the model turns against its rudder — a rudder force or yaw moment of the wrong sign, or a ship too unstable for this rudder angle — and no duration defines the turning metrics",
            side_name(-s),
            side_name(s),
            side_name(s),
            rec.t[i],
        ))
    }
}

fn zigzag_metrics(
    rec: &Recording,
    rudder_deg: f64,
    check_deg: f64,
    side: Side,
    ship: &Ship,
) -> Metrics {
    let Some(ev) = zigzag_events(rec, rudder_deg, check_deg, side, ship) else {
        return Metrics::default();
    };
    let scale = ship.u0 / ship.lpp;
    let e2 = ev.executes_s.get(1).copied();
    Metrics {
        overshoot_1: ev.overshoots.first().map(|o| o.angle_deg),
        overshoot_2: ev.overshoots.get(1).map(|o| o.angle_deg),
        t_a: e2.map(|e2| (e2 - ev.executes_s[0]) * scale),
        t_check: e2
            .zip(ev.overshoots.first())
            .map(|(e2, o)| (o.t_s - e2) * scale),
        ..Metrics::default()
    }
}

/// Least-squares circle (Kåsa fit: minimises Σ(x² + y² + D x + E y + F)²) through the points; its
/// radius, or `None` for fewer than three points or collinear points.
pub fn fit_circle_radius(x: &[f64], y: &[f64]) -> Option<f64> {
    let n = x.len().min(y.len());
    if n < 3 {
        return None;
    }
    // Centred coordinates keep the normal equations well conditioned far from the origin.
    let mx = x[..n].iter().sum::<f64>() / n as f64;
    let my = y[..n].iter().sum::<f64>() / n as f64;
    let mut a = [[0.0; 3]; 3];
    let mut rhs = [0.0; 3];
    for i in 0..n {
        let (xi, yi) = (x[i] - mx, y[i] - my);
        let row = [xi, yi, 1.0];
        let z = -(xi * xi + yi * yi);
        for r in 0..3 {
            for c in 0..3 {
                a[r][c] += row[r] * row[c];
            }
            rhs[r] += row[r] * z;
        }
    }
    let [d, e, f] = solve3(a, rhs)?;
    let r2 = 0.25 * (d * d + e * e) - f;
    (r2 > 0.0 && r2.is_finite()).then(|| r2.sqrt())
}

/// Gaussian elimination with partial pivoting.
fn solve3(mut a: [[f64; 3]; 3], mut b: [f64; 3]) -> Option<[f64; 3]> {
    let scale = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    for col in 0..3 {
        let p = (col..3).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[p][col].abs() <= 1e-12 * scale {
            return None;
        }
        a.swap(col, p);
        b.swap(col, p);
        let pivot = a[col];
        for row in col + 1..3 {
            let f = a[row][col] / pivot[col];
            for (x, p) in a[row].iter_mut().zip(pivot).skip(col) {
                *x -= f * p;
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = [0.0; 3];
    for row in (0..3).rev() {
        let s: f64 = (row + 1..3).map(|c| a[row][c] * x[c]).sum();
        x[row] = (b[row] - s) / a[row][row];
    }
    Some(x)
}

fn turning_metrics(rec: &Recording, rudder_deg: f64, side: Side, ship: &Ship) -> Metrics {
    let Some(first) = first_execute(rec, rudder_deg, side, ship) else {
        return Metrics::default();
    };
    let t = &rec.t;
    let n = t.len();
    let s = side.sign();
    let (sin0, cos0) = first.psi_rad.sin_cos();
    let along: Vec<f64> = (0..n)
        .map(|i| (rec.x0[i] - first.x0_m) * cos0 + (rec.y0[i] - first.y0_m) * sin0)
        .collect();
    let lateral: Vec<f64> = (0..n)
        .map(|i| s * (-(rec.x0[i] - first.x0_m) * sin0 + (rec.y0[i] - first.y0_m) * cos0))
        .collect();
    let dev: Vec<f64> = rec.psi.iter().map(|p| s * (p - first.psi_rad)).collect();
    let start = t.partition_point(|&x| x <= first.t_s);
    let at = |deg: f64| {
        crossing(&dev, 1.0, deg.to_radians(), start).map(|(i, w)| {
            let lerp = |c: &[f64]| c[i - 1] + w * (c[i] - c[i - 1]);
            (lerp(&along), lerp(&lateral))
        })
    };
    let l = ship.lpp;
    let at90 = at(90.0);
    let at180 = at(180.0);

    let steady_diameter = {
        let end = dev[n - 1];
        let window_start = end - std::f64::consts::TAU;
        if window_start >= std::f64::consts::PI {
            crossing(&dev, 1.0, window_start, start).and_then(|(i, _)| {
                fit_circle_radius(&rec.x0[i..], &rec.y0[i..]).map(|r| 2.0 * r / l)
            })
        } else {
            None
        }
    };
    Metrics {
        advance: at90.map(|p| p.0 / l),
        transfer: at90.map(|p| p.1 / l),
        tactical_diameter: at180.map(|p| p.1 / l),
        steady_diameter,
        ..Metrics::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parabola_vertex_of_an_exact_parabola() {
        // y = 3 − 2 (t − 1.3)², unevenly spaced samples.
        let f = |t: f64| 3.0 - 2.0 * (t - 1.3) * (t - 1.3);
        let ts = [1.0, 1.2, 1.5];
        let (tp, yp) = parabola_peak(ts, ts.map(f));
        assert!((tp - 1.3).abs() < 1e-12 && (yp - 3.0).abs() < 1e-12);
    }

    #[test]
    fn circle_fit_recovers_an_offset_circle() {
        let (x, y): (Vec<f64>, Vec<f64>) = (0..50)
            .map(|i| {
                let a = 0.1 + i as f64 * 0.1;
                (1000.0 + 7.5 * a.cos(), -300.0 + 7.5 * a.sin())
            })
            .unzip();
        let r = fit_circle_radius(&x, &y).unwrap();
        assert!((r - 7.5).abs() < 1e-9, "{r}");
        assert!(fit_circle_radius(&[0.0, 1.0, 2.0], &[0.0, 1.0, 2.0]).is_none());
    }

    #[test]
    fn threshold_is_half_a_degree_or_ten_percent() {
        assert_eq!(execute_threshold_deg(35.0), 0.5);
        assert!((execute_threshold_deg(2.0) - 0.2).abs() < 1e-15);
    }
}
