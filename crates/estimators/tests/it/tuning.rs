//! Cross-validated tuning and fold construction.
// Index loops over several parallel arrays read more clearly than zipped iterators.
#![allow(clippy::needless_range_loop)]

use crate::common::*;
use proptest::prelude::*;
use shipid_estimators::faer::Mat;
use shipid_estimators::*;

/// Mean squared error of the force predicted by `beta` against the true force on another
/// manoeuvre (different phase of the same signals): what tuning is meant to minimise.
fn transfer_error(beta: &[f64], truth: &[f64]) -> f64 {
    let test = full_design_with_phase(3000, 2.0);
    let p = predict(test.as_ref(), beta).unwrap();
    let t = predict(test.as_ref(), truth).unwrap();
    p.iter()
        .zip(&t)
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        / p.len() as f64
}

fn problem() -> (Mat<f64>, Vec<f64>, Vec<f64>) {
    // A short, noisy record of the full 22-term set: LSQ overfits.
    let phi = full_design(600);
    let truth = sway_like_coefficients(22);
    let y = target(&phi, &truth, 0.5, 17);
    (phi, y, truth)
}

#[test]
fn ridge_tuning_picks_a_lambda_near_the_best_transfer_error() {
    let (phi, y, truth) = problem();
    let grid = default_grid(&Family::Ridge, phi.as_ref(), &y).unwrap();
    let t = tune(
        phi.as_ref(),
        &y,
        &Family::Ridge,
        &grid,
        &Folds::Blocked { k: 4 },
        None,
        Solver::Fast,
    )
    .unwrap();
    assert_eq!(t.curve.len(), grid.len());
    assert_eq!(t.estimator, Estimator::Ridge { lambda: t.best });
    let errors: Vec<f64> = grid
        .iter()
        .map(|&lambda| {
            let f = fit(
                phi.as_ref(),
                &y,
                &Estimator::Ridge { lambda },
                None,
                Solver::Fast,
            )
            .unwrap();
            transfer_error(&f.coefficients, &truth)
        })
        .collect();
    let best_possible = errors.iter().cloned().fold(f64::INFINITY, f64::min);
    let k = grid.iter().position(|&g| g == t.best).unwrap();
    // The selected λ is an interior grid point (neither end of the grid) ...
    assert!(k > 0 && k + 1 < grid.len(), "λ = {:e}", t.best);
    // ... that transfers nearly as well as the best λ in hindsight, and far better than
    // the unregularised end of the grid.
    assert!(
        errors[k] <= 2.0 * best_possible,
        "{:e} vs {:e}",
        errors[k],
        best_possible
    );
    assert!(
        errors[k] < 0.5 * errors[0],
        "{:e} vs {:e}",
        errors[k],
        errors[0]
    );
    // The CV curve has its minimum where `best` says.
    let min_mse = t.curve.iter().map(|c| c.mse).fold(f64::INFINITY, f64::min);
    assert_eq!(t.curve[k].mse, min_mse);
    assert!(
        t.curve
            .iter()
            .all(|c| c.fold_mse.len() == 4 && c.failed_fits == 0)
    );
}

#[test]
fn lasso_and_svr_tuning_beat_the_ends_of_their_grids() {
    let (phi, y, _) = problem();
    for family in [
        Family::Lasso,
        Family::Svr {
            epsilon: 0.01 * 0.06,
        },
    ] {
        let grid = default_grid(&family, phi.as_ref(), &y).unwrap();
        let t = tune(
            phi.as_ref(),
            &y,
            &family,
            &grid,
            &Folds::Blocked { k: 4 },
            None,
            Solver::Fast,
        )
        .unwrap();
        let first = t.curve.first().unwrap().mse;
        let last = t.curve.last().unwrap().mse;
        let best = t.curve.iter().find(|c| c.param == t.best).unwrap().mse;
        assert!(best <= first && best <= last, "{family:?}");
        assert!(
            best < 0.9 * first.max(last),
            "{family:?}: {best:e} {first:e} {last:e}"
        );
    }
}

#[test]
fn tuning_with_both_solvers_agrees() {
    let phi = reduced_design(600);
    let y = target(&phi, &sway_like_coefficients(9), 0.2, 4);
    let grid = log_grid(1e-7, 1e-1, 7);
    let a = tune(
        phi.as_ref(),
        &y,
        &Family::Ridge,
        &grid,
        &Folds::Blocked { k: 3 },
        None,
        Solver::Fast,
    )
    .unwrap();
    let b = tune(
        phi.as_ref(),
        &y,
        &Family::Ridge,
        &grid,
        &Folds::Blocked { k: 3 },
        None,
        Solver::Qp,
    )
    .unwrap();
    assert_eq!(a.best, b.best);
    for (x, z) in a.curve.iter().zip(&b.curve) {
        assert!(rel_diff(x.mse, z.mse) < 1e-6);
    }
}

#[test]
fn grouped_folds_hold_out_whole_recordings() {
    // Two recordings stacked; labels 7 and 3 (any values), interleaved blocks.
    let labels: Vec<usize> = (0..10)
        .map(|i| if (i / 3) % 2 == 0 { 7 } else { 3 })
        .collect();
    let sets = Folds::Groups(labels.clone()).validation_sets(10).unwrap();
    assert_eq!(sets, vec![vec![3, 4, 5, 9], vec![0, 1, 2, 6, 7, 8]]);
    for (set, label) in sets.iter().zip([3, 7]) {
        assert!(set.iter().all(|&i| labels[i] == label));
    }
    // Tuning over recordings runs and reports one MSE per recording.
    let phi = reduced_design(400);
    let y = target(&phi, &sway_like_coefficients(9), 0.1, 2);
    let groups: Vec<usize> = (0..400).map(|i| i / 100).collect();
    let t = tune(
        phi.as_ref(),
        &y,
        &Family::Ridge,
        &[1e-6, 1e-3],
        &Folds::Groups(groups),
        None,
        Solver::Fast,
    )
    .unwrap();
    assert!(t.curve.iter().all(|c| c.fold_mse.len() == 4));
}

#[test]
fn blocked_folds_small_example() {
    let sets = Folds::Blocked { k: 3 }.validation_sets(10).unwrap();
    assert_eq!(sets, vec![vec![0, 1, 2], vec![3, 4, 5], vec![6, 7, 8, 9]]);
}

#[test]
fn default_grids_are_increasing_logarithmic() {
    let (phi, y, _) = problem();
    for family in [Family::Ridge, Family::Lasso, Family::Svr { epsilon: 1e-3 }] {
        let g = default_grid(&family, phi.as_ref(), &y).unwrap();
        assert!(g.len() >= 10);
        let ratio = g[1] / g[0];
        for w in g.windows(2) {
            assert!(w[1] > w[0]);
            assert!(rel_diff(w[1] / w[0], ratio) < 1e-9);
        }
    }
    let g = log_grid(1e-3, 1e1, 5);
    for (a, b) in g.iter().zip([1e-3, 1e-2, 1e-1, 1.0, 1e1]) {
        assert!(rel_diff(*a, b) < 1e-12, "{a} vs {b}");
    }
}

proptest! {
    #[test]
    fn blocked_folds_are_contiguous_and_partition_the_samples(n in 2usize..500, k in 2usize..20) {
        prop_assume!(k <= n);
        let sets = Folds::Blocked { k }.validation_sets(n).unwrap();
        prop_assert_eq!(sets.len(), k);
        let mut next = 0;
        for s in &sets {
            prop_assert!(!s.is_empty());
            // Contiguous and in order: each block starts where the previous one ended.
            prop_assert_eq!(s[0], next);
            for w in s.windows(2) {
                prop_assert_eq!(w[1], w[0] + 1);
            }
            next = s[s.len() - 1] + 1;
            // Balanced to within one sample.
            prop_assert!(s.len() == n / k || s.len() == n / k + 1);
        }
        prop_assert_eq!(next, n);
    }
}

#[test]
fn svr_tuning_over_c_and_epsilon_keeps_the_least_validation_error() {
    let (phi, y, _) = problem();
    let folds = Folds::Blocked { k: 4 };
    let epsilons = default_epsilon_grid(&y);
    let rms = rms(&y);
    let shares: Vec<f64> = epsilons.iter().map(|e| e / rms).collect();
    for (got, want) in shares
        .iter()
        .zip([1e-3, 3.162e-3, 1e-2, 3.162e-2, 1e-1, 3.162e-1])
    {
        assert!((got / want - 1.0).abs() < 1e-3, "{shares:?}");
    }
    let t = tune_svr(phi.as_ref(), &y, &epsilons, &folds, None, Solver::Fast).unwrap();
    let c_grid = default_grid(&Family::Svr { epsilon: 0.0 }, phi.as_ref(), &y).unwrap();
    assert_eq!(t.curve.len(), epsilons.len() * c_grid.len());
    // Grid order, C fastest; every point labelled with its ε.
    for (k, point) in t.curve.iter().enumerate() {
        assert_eq!(point.param, c_grid[k % c_grid.len()]);
        assert_eq!(point.epsilon, Some(epsilons[k / c_grid.len()]));
    }
    let best = t
        .curve
        .iter()
        .min_by(|a, b| a.mse.total_cmp(&b.mse))
        .unwrap();
    assert_eq!(
        t.estimator,
        Estimator::Svr {
            c: best.param,
            epsilon: best.epsilon.unwrap()
        }
    );
    assert_eq!(t.best, best.param);
    // Each ε's row is the one-parameter tuning at that ε, fit for fit.
    for (row, &epsilon) in epsilons.iter().enumerate() {
        let one = tune(
            phi.as_ref(),
            &y,
            &Family::Svr { epsilon },
            &c_grid,
            &folds,
            None,
            Solver::Fast,
        )
        .unwrap();
        for (a, b) in one.curve.iter().zip(&t.curve[row * c_grid.len()..]) {
            assert_eq!((a.param, a.mse), (b.param, b.mse));
            assert_eq!(a.epsilon, None);
        }
    }
    // No ε is no grid.
    assert!(matches!(
        tune_svr(phi.as_ref(), &y, &[], &folds, None, Solver::Fast),
        Err(EstimatorError::EmptyGrid)
    ));
}
