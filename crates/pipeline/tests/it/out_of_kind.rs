//! The out-of-kind term of a calibrated band (`shipid_pipeline::out_of_kind`): what a training set
//! counts as, the term at a band's level, and how it widens a band.

use shipid_io::{Manoeuvre, Side};
use shipid_pipeline::calibration::MetricFamily;
use shipid_pipeline::out_of_kind::{
    ModelFamily, OUT_OF_KIND, OUT_OF_KIND_LEVELS, TrainedKinds, add_out_of_kind, out_of_kind,
};

fn zz(angle: f64, side: Side) -> Manoeuvre {
    Manoeuvre::ZigZag {
        rudder_deg: angle,
        check_deg: angle,
        side,
    }
}

fn tc(angle: f64, side: Side) -> Manoeuvre {
    Manoeuvre::Turning {
        rudder_deg: angle,
        side,
    }
}

/// One concern: what a training set's manoeuvres count as.
fn check(training: &[Manoeuvre], expected: TrainedKinds) {
    assert_eq!(TrainedKinds::of(training), expected, "{training:?}");
}

#[test]
fn training_sets_count_as_the_kinds_and_angles_they_hold() {
    use Side::{Port, Starboard};
    use TrainedKinds::*;
    check(&[zz(35.0, Port)], ZigzagsOneAngle);
    // Both sides of one angle are one angle: the population study found them no better.
    check(&[zz(35.0, Port), zz(35.0, Starboard)], ZigzagsOneAngle);
    check(
        &[zz(10.0, Port), zz(20.0, Port), zz(35.0, Port)],
        ZigzagsSeveralAngles,
    );
    check(&[tc(35.0, Port), tc(35.0, Starboard)], TurningOnly);
    check(&[zz(20.0, Port), tc(35.0, Port)], Both);
    check(&[Manoeuvre::Free], Unknown);
    check(&[Manoeuvre::Free, zz(20.0, Port)], ZigzagsOneAngle);
    check(&[], Unknown);
}

#[test]
fn a_zigzag_fit_gets_a_turning_term_only_and_a_full_fit_none() {
    let zigzags = [zz(35.0, Side::Port)];
    for family in [
        ModelFamily::Polynomial,
        ModelFamily::Mmg,
        ModelFamily::SparseGp,
    ] {
        let o = out_of_kind(family, &zigzags, 0.9).expect("zig-zags alone have a term");
        assert_eq!(o.trained_on, ["zigzag"]);
        let keys: Vec<&str> = o.relative.keys().map(String::as_str).collect();
        assert_eq!(keys, ["turning-length"], "{family:?}");
        // At a level of the table the term is the table's quantile.
        let row = OUT_OF_KIND
            .iter()
            .find(|(f, t, m, _)| {
                *f == family
                    && *t == TrainedKinds::ZigzagsOneAngle
                    && *m == MetricFamily::TurningLength
            })
            .unwrap();
        assert_eq!(o.relative["turning-length"], row.3[3], "{family:?}");
        assert_eq!(OUT_OF_KIND_LEVELS[3], 0.9);
        let both = [zz(35.0, Side::Port), tc(35.0, Side::Port)];
        assert!(out_of_kind(family, &both, 0.9).is_none());
        assert!(out_of_kind(family, &[Manoeuvre::Free], 0.9).is_none());
    }
    let turns = out_of_kind(ModelFamily::Polynomial, &[tc(35.0, Side::Port)], 0.9).unwrap();
    let keys: Vec<&str> = turns.relative.keys().map(String::as_str).collect();
    assert_eq!(keys, ["overshoot", "zigzag-time"]);
}

#[test]
fn the_term_grows_with_the_level_and_more_angles_need_less() {
    for (_, _, _, q) in OUT_OF_KIND {
        assert!(
            q.windows(2).all(|w| w[0] <= w[1]),
            "quantiles not increasing: {q:?}"
        );
        assert!(q.iter().all(|v| *v >= 0.0), "{q:?}");
    }
    let zigzags = [zz(35.0, Side::Port)];
    let at = |level| {
        out_of_kind(ModelFamily::Polynomial, &zigzags, level)
            .unwrap()
            .relative["turning-length"]
    };
    // Between two levels of the table, between their quantiles.
    let (lo, mid, hi) = (at(0.8), at(0.85), at(0.9));
    assert!(lo <= mid && mid <= hi, "{lo} {mid} {hi}");
    let several = [
        zz(10.0, Side::Port),
        zz(20.0, Side::Port),
        zz(35.0, Side::Port),
    ];
    for family in [
        ModelFamily::Polynomial,
        ModelFamily::Mmg,
        ModelFamily::SparseGp,
    ] {
        let one = out_of_kind(family, &zigzags, 0.9).unwrap().relative["turning-length"];
        let more = out_of_kind(family, &several, 0.9).unwrap().relative["turning-length"];
        assert!(
            more < one,
            "{family:?}: several angles {more} against one {one}"
        );
    }
}

#[test]
fn the_term_is_added_in_quadrature_about_the_centre() {
    // Centre 3, half-width 0.4, 10 %: half-width √(0.4² + 0.3²) = 0.5.
    let (lo, hi) = add_out_of_kind((2.6, 3.4), 0.1);
    assert!(
        (lo - 2.5).abs() < 1e-12 && (hi - 3.5).abs() < 1e-12,
        "{lo} {hi}"
    );
    // A negative centre (a starboard transfer) widens by its magnitude.
    let (lo, hi) = add_out_of_kind((-3.4, -2.6), 0.1);
    assert!(
        (lo + 3.5).abs() < 1e-12 && (hi + 2.5).abs() < 1e-12,
        "{lo} {hi}"
    );
    // No term: unchanged; an infinite one: unbounded.
    assert_eq!(add_out_of_kind((2.6, 3.4), 0.0), (2.6, 3.4));
    assert_eq!(
        add_out_of_kind((2.6, 3.4), f64::INFINITY),
        (f64::NEG_INFINITY, f64::INFINITY)
    );
}

#[test]
fn a_level_beyond_the_study_says_its_term_is_a_bound() {
    let zigzags = [zz(35.0, Side::Port)];
    let at = |level| out_of_kind(ModelFamily::Polynomial, &zigzags, level).unwrap();
    assert!(!at(0.9).source.contains("bound"), "{}", at(0.9).source);
    let high = at(0.99);
    assert_eq!(
        high.relative["turning-length"],
        at(0.95).relative["turning-length"]
    );
    assert!(high.source.contains("a lower bound"), "{}", high.source);
    let low = at(0.3);
    assert_eq!(
        low.relative["turning-length"],
        at(0.5).relative["turning-length"]
    );
    assert!(low.source.contains("an upper bound"), "{}", low.source);
}
