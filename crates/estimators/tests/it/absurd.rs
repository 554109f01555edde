//! Regularisation so large that the fit ignores the data (tester's findings A5, H2): refused when
//! it is absurd for any data, and said by `explains_nothing` when this data's target is lost.

use shipid_estimators::faer::Mat;
use shipid_estimators::{
    Estimator, EstimatorError, MAX_HYPER_PARAMETER, Solver, explains_nothing, fit, predict,
};

fn design() -> Mat<f64> {
    Mat::from_fn(20, 3, |i, j| ((i * (j + 2)) as f64 * 0.37).sin())
}

fn y() -> Vec<f64> {
    (0..20).map(|i| (i as f64 * 0.2).cos()).collect()
}

#[test]
fn regularisation_beyond_the_bound_is_refused_naming_it() {
    for (est, name) in [
        (Estimator::Ridge { lambda: 1e308 }, "lambda"),
        (Estimator::Lasso { alpha: 1e308 }, "alpha"),
        (
            Estimator::Svr {
                c: 1e300,
                epsilon: 0.01,
            },
            "c",
        ),
        (
            Estimator::Svr {
                c: 1.0,
                epsilon: 1e16,
            },
            "epsilon",
        ),
    ] {
        for solver in [Solver::Fast, Solver::Qp] {
            match fit(design().as_ref(), &y(), &est, None, solver) {
                Err(e @ EstimatorError::InvalidHyperParameter { .. }) => {
                    let EstimatorError::InvalidHyperParameter { name: got, .. } = &e else {
                        unreachable!()
                    };
                    assert_eq!(*got, name);
                    assert!(e.to_string().contains("<= 1e15"), "{e}");
                }
                other => panic!("{est:?}: {other:?}"),
            }
        }
    }
    // The bound itself is a value a fit takes.
    let at = Estimator::Ridge {
        lambda: MAX_HYPER_PARAMETER,
    };
    assert!(fit(design().as_ref(), &y(), &at, None, Solver::Fast).is_ok());
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

/// The fit's residual and target RMS, and whether it explains nothing of the target.
fn judged(est: Estimator) -> bool {
    let (phi, t) = (design(), y());
    let f = fit(phi.as_ref(), &t, &est, None, Solver::Fast).unwrap();
    let p = predict(phi.as_ref(), &f.coefficients).unwrap();
    let r: Vec<f64> = t.iter().zip(&p).map(|(a, b)| a - b).collect();
    explains_nothing(&f.coefficients, rms(&r), rms(&t))
}

#[test]
fn a_fit_that_ignores_its_target_says_so_and_a_fit_that_explains_it_does_not() {
    assert!(!judged(Estimator::Lsq));
    assert!(!judged(Estimator::Ridge { lambda: 1e-4 }));
    // A penalty far beyond the data's scale leaves every coefficient (almost) zero.
    assert!(judged(Estimator::Ridge { lambda: 1e12 }));
    assert!(judged(Estimator::Lasso { alpha: 1e6 }));
    // An ε-tube wider than the target's spread holds every sample: all zeros at any C.
    let wide = 10.0 * y().iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(judged(Estimator::Svr {
        c: 1.0,
        epsilon: wide
    }));
    // A zero target has nothing to explain.
    assert!(!explains_nothing(&[0.0, 0.0], 0.0, 0.0));
    assert!(explains_nothing(&[0.0, 0.0], 1.0, 1.0));
    assert!(explains_nothing(&[1e-3, 0.0], 0.9995, 1.0));
    assert!(!explains_nothing(&[1e-3, 0.0], 0.99, 1.0));
}
