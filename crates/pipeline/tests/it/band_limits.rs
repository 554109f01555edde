//! What a band may claim: it holds its own point, it stays within the metric's physical limits, and
//! past the reach a calibration speaks for it is dropped with the reason, metric and track alike
//! (`shipid_pipeline::bands::holding_point`, `calibration::{widen_metric, widen_track}`).

use std::collections::BTreeMap;

use shipid_pipeline::bands::{TrackBand, holding_point};
use shipid_pipeline::calibration::{widen_metric, widen_track};
use shipid_pipeline::metric_family::{
    MAX_BAND_REACH, MAX_CALIBRATION_FACTOR, MetricFamily, factor_beyond_cap, factor_cap_fault,
};
use shipid_uncertainty::{Band, UncertaintyError};

fn band(lo: f64, hi: f64) -> Band {
    Band {
        lo,
        hi,
        level: 0.9,
        finite: 200,
        undefined: 0,
    }
}

fn check_point(raw: (f64, f64), point: Option<f64>, expected: Option<(f64, f64)>) {
    let got = holding_point(Ok(band(raw.0, raw.1)), point);
    match expected {
        Some(e) => {
            let b = got.unwrap();
            assert_eq!((b.lo, b.hi), e, "{raw:?} around {point:?}");
        }
        None => assert_eq!(got.unwrap_err(), UncertaintyError::PointUndefined),
    }
}

/// Regression: a sparse GP's y0 band at the end of a 35° turn was [-55.8, 37.9] m around a point of
/// -77.3 m (its draws revert to the training mean, the mean run does not), and the GP's TC35 gave a
/// steady-diameter band [0.195, 12.48] beside a point that defines no steady diameter.
#[test]
fn band_excludes_its_own_point_and_band_of_an_undefined_point() {
    check_point((-55.8, 37.9), Some(-77.3), Some((-77.3, 37.9)));
    check_point((1.0, 2.0), Some(2.5), Some((1.0, 2.5)));
    check_point((1.0, 2.0), Some(1.5), Some((1.0, 2.0)));
    check_point((0.195, 12.48), None, None);
    check_point((0.195, 12.48), Some(f64::NAN), None);
}

fn check_widened(metric: &str, raw: (f64, f64), factor: f64, reach: f64, expected: (f64, f64)) {
    let w = widen_metric(&band(raw.0, raw.1), metric, factor, reach, None);
    assert!(
        (w.lo - expected.0).abs() < 1e-9 && (w.hi - expected.1).abs() < 1e-9,
        "{metric} {raw:?} × {factor} × {reach}: [{}, {}], expected {expected:?}",
        w.lo,
        w.hi
    );
}

/// Regression: a GP's ZZ35 gave `overshoot_1 band [-1597, 1620]` and `t_a [-89, 93]`: widening about
/// the centre carried bands of non-negative metrics below zero. They stop at their physical limit;
/// the transfer (a ship that kicks outwards has a negative one) and the heading have none.
#[test]
fn calibrated_band_of_a_non_negative_metric_goes_below_zero() {
    // centre 3, half 1, widened 4 × → [-1, 7] → clipped at 0.
    check_widened("overshoot_1", (2.0, 4.0), 2.0, 2.0, (0.0, 7.0));
    check_widened("overshoot_2", (2.0, 4.0), 2.0, 2.0, (0.0, 7.0));
    check_widened("t_a", (2.0, 4.0), 2.0, 2.0, (0.0, 7.0));
    check_widened("t_check", (2.0, 4.0), 2.0, 2.0, (0.0, 7.0));
    check_widened("advance", (2.0, 4.0), 2.0, 2.0, (0.0, 7.0));
    check_widened("tactical_diameter", (2.0, 4.0), 2.0, 2.0, (0.0, 7.0));
    check_widened("steady_diameter", (2.0, 4.0), 2.0, 2.0, (0.0, 7.0));
    check_widened("transfer", (2.0, 4.0), 2.0, 2.0, (-1.0, 7.0));
    // Inside the limit nothing changes.
    check_widened("t_a", (2.0, 4.0), 1.0, 1.5, (1.5, 4.5));
}

fn track(n: usize) -> TrackBand {
    TrackBand {
        t_s: (0..n).map(|i| i as f64).collect(),
        x0_m: vec![Some((0.0, 2.0)); n],
        y0_m: vec![Some((-1.0, 1.0)); n],
        psi_deg: vec![Some((-10.0, 10.0)); n],
        without_band: BTreeMap::new(),
    }
}

/// (widening per family in the run, family factor, reach) → the widening of (x0, y0, ψ), or None
/// for a dropped series.
fn check_track(
    widened_by: &[(MetricFamily, f64)],
    factor: f64,
    reach: f64,
    expected: [Option<f64>; 3],
) {
    let mut t = track(3);
    let by: BTreeMap<MetricFamily, f64> = widened_by.iter().copied().collect();
    widen_track(&mut t, &by, |_| factor, reach);
    let raw = track(3);
    let series = [
        ("x0_m", &t.x0_m, &raw.x0_m),
        ("y0_m", &t.y0_m, &raw.y0_m),
        ("psi_deg", &t.psi_deg, &raw.psi_deg),
    ];
    for ((name, got, raw), want) in series.into_iter().zip(expected) {
        match want {
            Some(k) => {
                let ((lo, hi), (rlo, rhi)) = (got[1].unwrap(), raw[1].unwrap());
                assert!(
                    ((hi - lo) / (rhi - rlo) - k).abs() < 1e-9,
                    "{name}: widened {} ×, expected {k} ×",
                    (hi - lo) / (rhi - rlo)
                );
                assert!(!t.without_band.contains_key(name));
            }
            None => {
                assert!(got.iter().all(Option::is_none), "{name} is dropped");
                assert!(
                    t.without_band[name].contains("beyond the training range"),
                    "{name}: {:?}",
                    t.without_band.get(name)
                );
            }
        }
    }
}

/// Regression: a sparse GP's 35° turn gave a heading band of [-1749350, 1741626]° at 252 s: the
/// heading took the overshoots' factor times a reach of 139, although the turn has no overshoot
/// band and its turning lengths (an out-of-kind term) widened 1.3 ×. A series whose family has no
/// band widens as the run's metric bands did; with no metric band past the reach cap it is dropped
/// with the reason, as the metrics are.
#[test]
fn heading_track_band_takes_the_overshoot_factor_times_the_reach() {
    use MetricFamily::*;
    // A turn: the heading follows the turning lengths.
    check_track(
        &[(TurningLength, 1.3)],
        1.79,
        139.0,
        [Some(1.3), Some(1.3), Some(1.3)],
    );
    // A zig-zag: the positions follow the widest of the run's bands.
    check_track(
        &[(Overshoot, 2.0), (ZigzagTime, 3.0)],
        1.5,
        1.5,
        [Some(3.0), Some(3.0), Some(2.0)],
    );
    // No metric band, within the cap: factor × reach.
    check_track(&[], 2.0, 1.5, [Some(3.0), Some(3.0), Some(3.0)]);
    // No metric band, beyond the cap: dropped.
    check_track(&[], 2.0, MAX_BAND_REACH * 1.5, [None, None, None]);
}

fn check_cap(factors: &[(&str, f64)], expected: Option<(&str, f64)>) {
    let names: Vec<String> = factors.iter().map(|(k, _)| k.to_string()).collect();
    let got = factor_beyond_cap(names.iter().zip(factors.iter().map(|(_, f)| *f)));
    assert_eq!(
        got.map(|(k, f)| (k.as_str(), f)),
        expected,
        "factors {factors:?}"
    );
}

/// `fit --calibrate` leaves out a calibration that the loader would refuse (a file it cannot read
/// back); both ask the same question of the factors.
#[test]
fn factor_beyond_cap_names_the_first_family_past_the_cap() {
    check_cap(&[("overshoot", 23.0), ("turning_length", 1.0)], None);
    check_cap(&[("overshoot", MAX_CALIBRATION_FACTOR)], None);
    check_cap(
        &[
            ("overshoot", 2.0),
            ("turning_length", 150.0),
            ("zigzag_time", 400.0),
        ],
        Some(("turning_length", 150.0)),
    );
    let fault = factor_cap_fault([(&"overshoot".to_string(), 1e3)]).unwrap();
    assert_eq!(fault.0, "calibration.factors.overshoot.factor");
    assert!(fault.1.contains("1000"), "{}", fault.1);
}
