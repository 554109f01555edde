//! The reference QP (clarabel) and the fast solvers must reach the same objective.
// Index loops over several parallel arrays read more clearly than zipped iterators.
#![allow(clippy::needless_range_loop)]

use crate::common::*;
use proptest::prelude::*;
use shipid_estimators::faer::Mat;
use shipid_estimators::*;

const REL_TOL: f64 = 1e-6;

/// Fits with both solvers, checks the documented invariants and returns (fast, qp).
fn both(phi: &Mat<f64>, y: &[f64], est: &Estimator, bounds: Option<&Bounds>) -> (Fit, Fit) {
    let fast = fit(phi.as_ref(), y, est, bounds, Solver::Fast).unwrap();
    let qp = fit(phi.as_ref(), y, est, bounds, Solver::Qp).unwrap();
    for f in [&fast, &qp] {
        assert!(
            f.status.is_solved(),
            "{:?} {:?}: {:?}",
            f.solver,
            est,
            f.status
        );
        if let Some(b) = bounds {
            assert!(
                b.contains(&f.coefficients),
                "{:?} {:?} leaves the bounds",
                f.solver,
                est
            );
        }
        // The reported J is J at the reported coefficients (the direct LSQ path updates
        // its residual sum of squares algebraically, hence a rounding-level tolerance).
        let j = objective(phi.as_ref(), y, est, &f.coefficients).unwrap();
        assert!(
            rel_diff(j, f.objective) <= 1e-12,
            "{:?} {est:?}: reported J {:e}, J at its coefficients {j:e}",
            f.solver,
            f.objective
        );
    }
    (fast, qp)
}

fn assert_agree(phi: &Mat<f64>, y: &[f64], est: &Estimator, bounds: Option<&Bounds>) {
    let (fast, qp) = both(phi, y, est, bounds);
    let d = rel_diff(fast.objective, qp.objective);
    assert!(
        d <= REL_TOL,
        "{est:?} bounded={}: fast {:.15e} vs qp {:.15e} (rel {d:.2e})",
        bounds.is_some(),
        fast.objective,
        qp.objective
    );
}

fn estimators(phi: &Mat<f64>, y: &[f64]) -> Vec<Estimator> {
    let alpha_max = *default_grid(&Family::Lasso, phi.as_ref(), y)
        .unwrap()
        .last()
        .unwrap();
    let n = y.len() as f64;
    let rms = rms(y);
    vec![
        Estimator::Lsq,
        Estimator::BoundedLsq,
        Estimator::Ridge { lambda: 1e-6 },
        Estimator::Ridge { lambda: 1e-2 },
        Estimator::Lasso {
            alpha: 1e-4 * alpha_max,
        },
        Estimator::Lasso {
            alpha: 0.05 * alpha_max,
        },
        Estimator::Svr {
            c: 100.0 * rms / n,
            epsilon: 0.01 * rms,
        },
        Estimator::Svr {
            c: 1e4 * rms / n,
            epsilon: 0.1 * rms,
        },
    ]
}

/// Bounds that cut through the unbounded solution for every third coefficient.
fn cutting_bounds(beta: &[f64]) -> Bounds {
    let p = beta.len();
    let mut lower = vec![f64::NEG_INFINITY; p];
    let mut upper = vec![f64::INFINITY; p];
    for j in 0..p {
        let b = beta[j];
        match j % 3 {
            0 => lower[j] = b + 0.3 * b.abs(),
            1 => {
                lower[j] = -0.5 * b.abs();
                upper[j] = 0.5 * b.abs();
            }
            _ => {}
        }
    }
    Bounds::new(lower, upper).unwrap()
}

#[test]
fn abkowitz_reduced_set_n500() {
    let phi = reduced_design(500);
    assert!(condition_number(phi.as_ref()).unwrap() >= 1e4);
    let beta = sway_like_coefficients(9);
    let y = target(&phi, &beta, 0.03, 7);
    let bounds = cutting_bounds(&beta);
    for est in estimators(&phi, &y) {
        assert_agree(&phi, &y, &est, None);
        assert_agree(&phi, &y, &est, Some(&bounds));
    }
}

#[test]
fn abkowitz_full_set_n4000() {
    let phi = full_design(4000);
    let kappa = condition_number(phi.as_ref()).unwrap();
    assert!(kappa >= 1e4, "condition number {kappa:.3e}");
    let beta = sway_like_coefficients(22);
    let y = target(&phi, &beta, 0.02, 11);
    let bounds = cutting_bounds(&beta);
    for est in estimators(&phi, &y) {
        assert_agree(&phi, &y, &est, None);
        assert_agree(&phi, &y, &est, Some(&bounds));
    }
}

#[test]
fn abkowitz_full_set_n1500_with_constant_column_bounded_at_zero() {
    // Sign constraints of the kind used for physical plausibility: Y_v ≤ 0, N_r ≤ 0.
    let phi = full_design(1500);
    let beta = sway_like_coefficients(22);
    let y = target(&phi, &beta, 0.05, 3);
    let mut lower = vec![f64::NEG_INFINITY; 22];
    let mut upper = vec![f64::INFINITY; 22];
    upper[3] = 0.0;
    lower[4] = 0.0;
    lower[0] = 0.0;
    upper[0] = 0.0;
    let bounds = Bounds::new(lower, upper).unwrap();
    for est in estimators(&phi, &y) {
        assert_agree(&phi, &y, &est, Some(&bounds));
        let f = fit(phi.as_ref(), &y, &est, Some(&bounds), Solver::Fast).unwrap();
        assert_eq!(f.coefficients[0], 0.0);
    }
}

#[derive(Debug, Clone)]
struct Case {
    n: usize,
    p: usize,
    seed: u64,
    noise: f64,
    bounded: bool,
    which: usize,
    strength: f64,
}

fn case() -> impl Strategy<Value = Case> {
    (
        20usize..160,
        1usize..9,
        any::<u64>(),
        0.01f64..0.5,
        any::<bool>(),
        0usize..5,
        0.0f64..1.0,
    )
        .prop_map(|(n, p, seed, noise, bounded, which, strength)| Case {
            n,
            p,
            seed,
            noise,
            bounded,
            which,
            strength,
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn random_designs_agree(c in case()) {
        let phi = random_design(c.n, c.p, c.seed);
        let beta: Vec<f64> = (0..c.p).map(|j| ((j as f64 + 1.0) * 1.7).sin() / phi_scale(&phi, j)).collect();
        let y = target(&phi, &beta, c.noise, c.seed ^ 0x5eed);
        let n = c.n as f64;
        let rms = rms(&y);
        let alpha_max = *default_grid(&Family::Lasso, phi.as_ref(), &y).unwrap().last().unwrap();
        let est = match c.which {
            0 => Estimator::Lsq,
            1 => Estimator::BoundedLsq,
            2 => Estimator::Ridge { lambda: 10f64.powf(-8.0 + 9.0 * c.strength) },
            3 => Estimator::Lasso { alpha: alpha_max * 10f64.powf(-4.0 + 4.2 * c.strength) },
            _ => Estimator::Svr { c: rms / n * 10f64.powf(-1.0 + 5.0 * c.strength), epsilon: 0.3 * c.strength * rms },
        };
        let bounds = cutting_bounds(&beta);
        let b = if c.bounded { Some(&bounds) } else { None };
        let fast = fit(phi.as_ref(), &y, &est, b, Solver::Fast).unwrap();
        let qp = fit(phi.as_ref(), &y, &est, b, Solver::Qp).unwrap();
        prop_assert!(fast.status.is_solved(), "fast {:?}", fast.status);
        prop_assert!(qp.status.is_solved(), "qp {:?}", qp.status);
        if let Some(b) = b {
            prop_assert!(b.contains(&fast.coefficients));
            prop_assert!(b.contains(&qp.coefficients));
        }
        let d = rel_diff(fast.objective, qp.objective);
        prop_assert!(d <= REL_TOL, "{:?}: fast {:e} qp {:e} rel {:e}", est, fast.objective, qp.objective, d);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn abkowitz_designs_agree(
        n in 500usize..1500,
        phase in 0.0f64..6.0,
        noise in 0.005f64..0.1,
        bounded in any::<bool>(),
        which in 0usize..4,
        strength in 0.0f64..1.0,
        seed in any::<u64>(),
    ) {
        let phi = full_design_with_phase(n, phase);
        prop_assert!(condition_number(phi.as_ref()).unwrap() >= 1e4);
        let beta = sway_like_coefficients(22);
        let y = target(&phi, &beta, noise, seed);
        let nf = n as f64;
        let rms = rms(&y);
        let alpha_max = *default_grid(&Family::Lasso, phi.as_ref(), &y).unwrap().last().unwrap();
        let est = match which {
            0 => Estimator::BoundedLsq,
            1 => Estimator::Ridge { lambda: 10f64.powf(-9.0 + 8.0 * strength) },
            2 => Estimator::Lasso { alpha: alpha_max * 10f64.powf(-5.0 + 4.5 * strength) },
            _ => Estimator::Svr { c: rms / nf * 10f64.powf(5.0 * strength), epsilon: 0.2 * strength * rms },
        };
        let bounds = cutting_bounds(&beta);
        let b = if bounded { Some(&bounds) } else { None };
        let fast = fit(phi.as_ref(), &y, &est, b, Solver::Fast).unwrap();
        let qp = fit(phi.as_ref(), &y, &est, b, Solver::Qp).unwrap();
        prop_assert!(fast.status.is_solved(), "fast {:?}", fast.status);
        prop_assert!(qp.status.is_solved(), "qp {:?}", qp.status);
        let d = rel_diff(fast.objective, qp.objective);
        prop_assert!(d <= REL_TOL, "{:?}: fast {:e} qp {:e} rel {:e}", est, fast.objective, qp.objective, d);
    }
}

fn phi_scale(phi: &Mat<f64>, j: usize) -> f64 {
    let n = phi.nrows() as f64;
    ((0..phi.nrows())
        .map(|i| phi[(i, j)] * phi[(i, j)])
        .sum::<f64>()
        / n)
        .sqrt()
}
