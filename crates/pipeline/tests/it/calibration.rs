//! The calibration of band widths: held-out inflation per metric family, widening, reach, and the
//! structure ensemble (`shipid_pipeline::calibration`).

use std::path::Path;

use shipid_estimators::Solver;
use shipid_io::Dataset;
use shipid_model::{CoefficientSet, IdentificationRange};
use shipid_pipeline::bands::BandRun;
use shipid_pipeline::calibration::{
    BandError, EnsembleSpec, FamilyFactor, MetricFamily, calibrate, ensemble_bands, fit_ensemble,
    held_out_errors, in_sample_errors, reach, standardised_error, widen,
};
use shipid_pipeline::fit::{EstimatorSpec, WindowSpec, fit_dataset};
use shipid_uncertainty::Band;

fn band(lo: f64, hi: f64) -> Band {
    Band {
        lo,
        hi,
        level: 0.9,
        finite: 100,
        undefined: 0,
    }
}

fn held(family: MetricFamily, z: &[f64]) -> Vec<BandError> {
    z.iter()
        .map(|&z| BandError {
            family,
            held_out: true,
            z,
            reach: 1.0,
        })
        .collect()
}

/// One concern: the factor of each family from a list of held-out errors.
fn check(z: Vec<BandError>, expected: [FamilyFactor; 3]) {
    let c = calibrate(&z, 0.9, 3);
    let got: Vec<FamilyFactor> = MetricFamily::ALL.iter().map(|f| c.factors[f]).collect();
    assert_eq!(got, expected, "held-out errors {z:?}");
}

#[test]
fn family_factors_are_the_level_quantile_of_held_out_errors_never_below_one() {
    use FamilyFactor::*;
    // Nothing held out (one training recording): no inflation.
    check(vec![], [TooFew { errors: 0 }; 3]);
    // Ten overshoot errors 0.5 … 5: the 0.9 quantile (type 7) is 4.55; the other families have
    // none of their own and take the pooled factor of the same ten.
    let over = held(
        MetricFamily::Overshoot,
        &[0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0],
    );
    let own = Own {
        factor: 4.55,
        errors: 10,
    };
    let pooled = Pooled {
        factor: 4.55,
        errors: 10,
    };
    check(over.clone(), [own, pooled, pooled]);
    // Errors well inside their bands do not narrow them.
    let small = held(MetricFamily::ZigzagTime, &[0.1, 0.2, 0.3]);
    check(
        small.clone(),
        [
            Pooled {
                factor: 1.0,
                errors: 3,
            },
            Own {
                factor: 1.0,
                errors: 3,
            },
            Pooled {
                factor: 1.0,
                errors: 3,
            },
        ],
    );
    // A non-finite error (a band of no width) is not counted.
    let mut with_nan = small;
    with_nan.push(BandError {
        family: MetricFamily::ZigzagTime,
        held_out: true,
        z: f64::NAN,
        reach: 1.0,
    });
    assert_eq!(calibrate(&with_nan, 0.9, 2).errors.len(), 3);
}

#[test]
fn widening_keeps_the_centre_and_scales_the_half_width_by_factor_and_reach() {
    let b = band(2.0, 4.0);
    let w = widen(&b, 1.5, 2.0);
    assert_eq!((w.lo, w.hi), (0.0, 6.0));
    // The standardised error is what the widening undoes: a value at z = 1.5 lies on the edge.
    assert_eq!(standardised_error(&b, 6.0, 2.0), Some(1.5));
    assert_eq!(standardised_error(&b, 3.0, 1.0), Some(0.0));
    assert_eq!(standardised_error(&band(3.0, 3.0), 3.0, 1.0), None);
}

/// Whole recordings, the fast solver, seed 1.
fn how<'a>(
    sets: &'a [CoefficientSet],
    estimator: &'a EstimatorSpec,
    replicates: usize,
) -> EnsembleSpec<'a> {
    EnsembleSpec {
        sets,
        estimator,
        window: WindowSpec::Whole,
        solver: Solver::Fast,
        replicates,
        seed: 1,
    }
}

fn default_data() -> Dataset {
    Dataset::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/kvlcc2-mmg/dataset.toml"))
        .expect("the shipped default data load")
}

#[test]
fn reach_is_one_on_the_training_recording_and_grows_on_a_manoeuvre_outside_its_range() {
    let ds = default_data();
    let spec = EstimatorSpec {
        lambda: Some(1e-6),
        ..EstimatorSpec::named("ridge")
    };
    let out = fit_dataset(
        &ds,
        CoefficientSet::builtin("reduced32").unwrap(),
        &spec,
        &["zz10_10_ps.csv".into()],
        WindowSpec::Whole,
        Solver::Fast,
    )
    .unwrap();
    let range = IdentificationRange::from_samples(&out.model.set, &out.training).unwrap();
    let trained = reach(
        &range,
        &ds.recording("zz10_10_ps.csv").unwrap().recording,
        &ds.ship,
    );
    let turning = reach(
        &range,
        &ds.recording("tc35_ps.csv").unwrap().recording,
        &ds.ship,
    );
    assert_eq!(trained, 1.0);
    assert!(
        turning > 2.0,
        "a 35° turn from a 10° zig-zag: reach {turning}"
    );
}

#[test]
fn each_training_recording_is_predicted_in_sample_and_held_out_and_one_recording_has_no_fold() {
    let ds = default_data();
    let sets = [CoefficientSet::builtin("reduced32").unwrap()];
    let spec = EstimatorSpec {
        lambda: Some(1e-6),
        ..EstimatorSpec::named("ridge")
    };
    let one: Vec<String> = vec!["zz35_35_ps.csv".into()];
    assert!(
        held_out_errors(&ds, &how(&sets, &spec, 40), &one, 0.9)
            .unwrap()
            .is_empty()
    );
    let e = fit_ensemble(&ds, &how(&sets, &spec, 40), &one).unwrap();
    let own = in_sample_errors(&e, &ds, &one, 0.9).unwrap();
    // ZZ35's overshoots and times, none of them held out, none a turning length.
    assert!((1..=4).contains(&own.len()), "{own:?}");
    // The re-simulation stays near the recorded states, so near the range (not exactly inside it).
    assert!(own.iter().all(|b| !b.held_out && b.reach < 1.1), "{own:?}");

    let two: Vec<String> = vec!["zz35_35_ps.csv".into(), "zz20_20_ps.csv".into()];
    let z = held_out_errors(&ds, &how(&sets, &spec, 40), &two, 0.9).unwrap();
    assert!((2..=8).contains(&z.len()), "held-out errors {z:?}");
    assert!(
        z.iter()
            .all(|b| b.held_out && b.family != MetricFamily::TurningLength)
    );
}

#[test]
fn the_ensemble_pools_every_structures_replicates_and_predicts_with_the_first() {
    let ds = default_data();
    let sets = [
        CoefficientSet::builtin("reduced32").unwrap(),
        CoefficientSet::builtin("full68").unwrap(),
    ];
    let spec = EstimatorSpec {
        lambda: Some(1e-6),
        ..EstimatorSpec::named("ridge")
    };
    let e = fit_ensemble(&ds, &how(&sets, &spec, 60), &["zz35_35_ps.csv".into()]).unwrap();
    assert_eq!(e.point.set.name, "reduced32");
    assert_eq!(e.block_rows.len(), 2);
    assert!(
        (50..=60).contains(&e.replicates.len()),
        "{} replicates",
        e.replicates.len()
    );
    let m = ds.recording("zz20_20_ps.csv").unwrap().manoeuvre;
    let (bands, r) = ensemble_bands(&e, &m, &ds.ship, 0.9, BandRun::Standard).unwrap();
    assert!(r >= 1.0);
    assert!(bands.metrics.iter().any(|b| b.band.is_ok()));
}
