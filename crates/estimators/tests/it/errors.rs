//! Invalid input gives a typed error, never a panic.

use proptest::prelude::*;
use shipid_estimators::faer::Mat;
use shipid_estimators::*;

fn design() -> Mat<f64> {
    Mat::from_fn(20, 3, |i, j| ((i * (j + 2)) as f64 * 0.37).sin())
}

fn y() -> Vec<f64> {
    (0..20).map(|i| (i as f64 * 0.2).cos()).collect()
}

#[test]
fn nan_in_the_design() {
    let mut phi = design();
    phi[(7, 2)] = f64::NAN;
    for solver in [Solver::Fast, Solver::Qp] {
        match fit(phi.as_ref(), &y(), &Estimator::Lsq, None, solver) {
            Err(EstimatorError::NonFinite {
                what: "design",
                row: 7,
                column: Some(2),
                value,
            }) => assert!(value.is_nan()),
            other => panic!("{other:?}"),
        }
    }
    assert!(matches!(
        vif(phi.as_ref()),
        Err(EstimatorError::NonFinite { .. })
    ));
    assert!(matches!(
        condition_number(phi.as_ref()),
        Err(EstimatorError::NonFinite { .. })
    ));
    phi[(7, 2)] = f64::INFINITY;
    assert!(matches!(
        fit(
            phi.as_ref(),
            &y(),
            &Estimator::Ridge { lambda: 1.0 },
            None,
            Solver::Fast
        ),
        Err(EstimatorError::NonFinite {
            row: 7,
            column: Some(2),
            ..
        })
    ));
}

#[test]
fn nan_in_the_target() {
    let mut t = y();
    t[3] = f64::NAN;
    assert!(matches!(
        fit(design().as_ref(), &t, &Estimator::Lsq, None, Solver::Fast),
        Err(EstimatorError::NonFinite {
            what: "target y",
            row: 3,
            column: None,
            ..
        })
    ));
}

#[test]
fn length_mismatch() {
    let short = &y()[..19];
    assert_eq!(
        fit(
            design().as_ref(),
            short,
            &Estimator::Lsq,
            None,
            Solver::Fast
        )
        .unwrap_err(),
        EstimatorError::LengthMismatch {
            what: "target y (rows of the design)",
            expected: 20,
            got: 19
        }
    );
    let b = Bounds::unbounded(2);
    assert!(matches!(
        fit(
            design().as_ref(),
            &y(),
            &Estimator::BoundedLsq,
            Some(&b),
            Solver::Fast
        ),
        Err(EstimatorError::LengthMismatch {
            expected: 3,
            got: 2,
            ..
        })
    ));
    assert!(matches!(
        objective(design().as_ref(), &y(), &Estimator::Lsq, &[1.0, 2.0]),
        Err(EstimatorError::LengthMismatch {
            expected: 3,
            got: 2,
            ..
        })
    ));
}

#[test]
fn lower_bound_above_upper_bound() {
    assert_eq!(
        Bounds::new(vec![0.0, 2.0, 0.0], vec![1.0, 1.0, 1.0]).unwrap_err(),
        EstimatorError::InvalidBounds {
            index: 1,
            lower: 2.0,
            upper: 1.0
        }
    );
    // Constructed directly, the fit still checks.
    let b = Bounds {
        lower: vec![0.0, 0.0, 5.0],
        upper: vec![1.0, 1.0, 4.0],
    };
    assert!(matches!(
        fit(
            design().as_ref(),
            &y(),
            &Estimator::BoundedLsq,
            Some(&b),
            Solver::Qp
        ),
        Err(EstimatorError::InvalidBounds { index: 2, .. })
    ));
    for (l, u) in [
        (f64::NAN, 1.0),
        (f64::INFINITY, f64::INFINITY),
        (f64::NEG_INFINITY, f64::NEG_INFINITY),
    ] {
        assert!(matches!(
            Bounds::new(vec![l], vec![u]),
            Err(EstimatorError::InvalidBounds { index: 0, .. })
        ));
    }
}

#[test]
fn negative_or_non_finite_hyper_parameters() {
    let cases = [
        (Estimator::Ridge { lambda: -1e-3 }, "lambda"),
        (Estimator::Lasso { alpha: -1.0 }, "alpha"),
        (Estimator::Ridge { lambda: f64::NAN }, "lambda"),
        (
            Estimator::Lasso {
                alpha: f64::INFINITY,
            },
            "alpha",
        ),
        (
            Estimator::Svr {
                c: -1.0,
                epsilon: 0.1,
            },
            "c",
        ),
        (
            Estimator::Svr {
                c: 1.0,
                epsilon: -0.1,
            },
            "epsilon",
        ),
    ];
    for (est, name) in cases {
        for solver in [Solver::Fast, Solver::Qp] {
            match fit(design().as_ref(), &y(), &est, None, solver) {
                Err(EstimatorError::InvalidHyperParameter { name: got, .. }) => {
                    assert_eq!(got, name)
                }
                other => panic!("{est:?}: {other:?}"),
            }
        }
    }
}

#[test]
fn empty_design() {
    let empty = Mat::<f64>::zeros(0, 3);
    assert_eq!(
        fit(empty.as_ref(), &[], &Estimator::Lsq, None, Solver::Fast).unwrap_err(),
        EstimatorError::EmptyDesign { rows: 0, cols: 3 }
    );
    let no_cols = Mat::<f64>::zeros(5, 0);
    assert_eq!(
        fit(
            no_cols.as_ref(),
            &[0.0; 5],
            &Estimator::Lsq,
            None,
            Solver::Qp
        )
        .unwrap_err(),
        EstimatorError::EmptyDesign { rows: 5, cols: 0 }
    );
    assert!(matches!(
        vif(no_cols.as_ref()),
        Err(EstimatorError::EmptyDesign { .. })
    ));
}

#[test]
fn invalid_tuning_input() {
    let (phi, t) = (design(), y());
    assert_eq!(
        tune(
            phi.as_ref(),
            &t,
            &Family::Ridge,
            &[],
            &Folds::Blocked { k: 4 },
            None,
            Solver::Fast
        )
        .unwrap_err(),
        EstimatorError::EmptyGrid
    );
    assert!(matches!(
        tune(
            phi.as_ref(),
            &t,
            &Family::Ridge,
            &[1.0, -1.0],
            &Folds::Blocked { k: 4 },
            None,
            Solver::Fast
        ),
        Err(EstimatorError::InvalidHyperParameter { name: "lambda", .. })
    ));
    for folds in [
        Folds::Blocked { k: 1 },
        Folds::Blocked { k: 21 },
        Folds::Groups(vec![3; 20]),
    ] {
        assert!(matches!(
            tune(
                phi.as_ref(),
                &t,
                &Family::Ridge,
                &[1.0],
                &folds,
                None,
                Solver::Fast
            ),
            Err(EstimatorError::InvalidFolds(_))
        ));
    }
    assert!(matches!(
        tune(
            phi.as_ref(),
            &t,
            &Family::Lasso,
            &[1.0],
            &Folds::Groups(vec![0; 7]),
            None,
            Solver::Fast
        ),
        Err(EstimatorError::LengthMismatch {
            expected: 20,
            got: 7,
            ..
        })
    ));
    assert!(matches!(
        default_grid(&Family::Svr { epsilon: -1.0 }, phi.as_ref(), &t),
        Err(EstimatorError::InvalidHyperParameter {
            name: "epsilon",
            ..
        })
    ));
}

#[test]
fn errors_display_their_cause() {
    let e = EstimatorError::NonFinite {
        what: "design",
        row: 4,
        column: Some(1),
        value: f64::NAN,
    };
    assert_eq!(
        e.to_string(),
        "non-finite value NaN in design at row 4, column 1"
    );
    let e = EstimatorError::InvalidBounds {
        index: 2,
        lower: 1.0,
        upper: 0.0,
    };
    assert_eq!(
        e.to_string(),
        "invalid bounds for coefficient 2: lower 1, upper 0"
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    /// Arbitrary (possibly non-finite) entries never panic: either a typed error or a fit.
    #[test]
    fn arbitrary_input_never_panics(
        n in 0usize..12,
        p in 0usize..5,
        entries in proptest::collection::vec(prop_oneof![
            4 => -1e3f64..1e3,
            1 => Just(f64::NAN),
            1 => Just(f64::INFINITY),
            1 => Just(0.0),
            1 => Just(1e-310),
            1 => Just(1e300),
        ], 60),
        which in 0usize..5,
        hyper in prop_oneof![Just(-1.0f64), Just(0.0), 1e-6f64..10.0],
        fast in any::<bool>(),
    ) {
        let phi = Mat::<f64>::from_fn(n, p, |i, j| entries[(i * 5 + j) % 60]);
        let t: Vec<f64> = (0..n).map(|i| entries[(i * 7 + 3) % 60]).collect();
        let est = [
            Estimator::Lsq,
            Estimator::BoundedLsq,
            Estimator::Ridge { lambda: hyper },
            Estimator::Lasso { alpha: hyper },
            Estimator::Svr { c: hyper, epsilon: 0.1 },
        ][which];
        let solver = if fast { Solver::Fast } else { Solver::Qp };
        let bounds = Bounds::new(vec![-1.0; p], vec![1.0; p]).unwrap();
        let finite = t.iter().all(|v| v.is_finite())
            && (0..p).all(|j| (0..n).all(|i| phi[(i, j)].is_finite()));
        match fit(phi.as_ref(), &t, &est, Some(&bounds), solver) {
            Ok(f) => {
                prop_assert!(n > 0 && p > 0 && finite && (which < 2 || hyper >= 0.0));
                prop_assert!(f.coefficients.iter().all(|b| b.is_finite()));
                prop_assert!(bounds.contains(&f.coefficients));
            }
            Err(EstimatorError::NonFinite { .. }) => prop_assert!(!finite),
            Err(EstimatorError::EmptyDesign { .. }) => prop_assert!(n == 0 || p == 0),
            Err(EstimatorError::InvalidHyperParameter { .. }) => prop_assert!(hyper < 0.0),
            Err(e) => prop_assert!(false, "unexpected error {e:?}"),
        }
    }
}
