//! Known-answer properties of the estimators.
// Index loops over several parallel arrays read more clearly than zipped iterators.
#![allow(clippy::needless_range_loop)]

use crate::common::*;
use proptest::prelude::*;
use shipid_estimators::faer::Mat;
use shipid_estimators::*;

const SOLVERS: [Solver; 2] = [Solver::Fast, Solver::Qp];

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn lsq_recovers_coefficients_from_noise_free_data() {
    let phi = reduced_design(500);
    let beta = sway_like_coefficients(9);
    let y = target(&phi, &beta, 0.0, 0);
    let fast = fit(phi.as_ref(), &y, &Estimator::Lsq, None, Solver::Fast).unwrap();
    assert_eq!(fast.status, Status::Ok);
    for (b, t) in fast.coefficients.iter().zip(&beta) {
        assert!((b - t).abs() <= 1e-9 * t.abs(), "{b} vs {t}");
    }
    // The interior-point reference stops at its tolerances: 1e-6 relative.
    let qp = fit(phi.as_ref(), &y, &Estimator::Lsq, None, Solver::Qp).unwrap();
    for (b, t) in qp.coefficients.iter().zip(&beta) {
        assert!((b - t).abs() <= 1e-6 * t.abs(), "{b} vs {t}");
    }
}

/// The direct path takes J from its refinement pass and the step instead of a final pass
/// over Φ. On a noise-free fit ‖r₁‖² is mostly the first solve's error, which the step
/// removes (without the step's correction the reduced design reports 5e-32 for 2e-35), and
/// the path falls back to the explicit residual when the step is not small. Either way J is
/// J at the coefficients, to the
/// accuracy with which J can be evaluated at all: each residual carries a rounding error of
/// about ε‖y‖/√n, so J = ‖r‖²/2n is known to about ε‖y‖‖r‖/n (relative 3e-9 at a noise of
/// 1e-9, far above 1e-12).
#[test]
fn direct_lsq_objective_is_the_residual_at_its_coefficients_with_and_without_noise() {
    for (name, phi, p) in [
        ("reduced", reduced_design(1500), 9),
        ("full", full_design(4000), 22),
    ] {
        let beta = sway_like_coefficients(p);
        for noise in [0.0, 1e-9, 1e-3] {
            let y = target(&phi, &beta, noise, 3);
            let f = fit(phi.as_ref(), &y, &Estimator::Lsq, None, Solver::Fast).unwrap();
            let j = objective(phi.as_ref(), &y, &Estimator::Lsq, &f.coefficients).unwrap();
            let n = y.len() as f64;
            let y_norm = y.iter().map(|v| v * v).sum::<f64>().sqrt();
            let r_norm = (2.0 * n * j).sqrt();
            let evaluation_error = 16.0 * f64::EPSILON * y_norm * r_norm / n;
            assert!(
                (f.objective - j).abs() <= evaluation_error.max(1e-12 * j),
                "{name} noise {noise:e}: reported {:e}, at the coefficients {j:e} (evaluation error {evaluation_error:e})",
                f.objective
            );
        }
    }
}

#[test]
fn lsq_recovers_coefficients_of_the_full_set() {
    let phi = full_design(4000);
    let beta = sway_like_coefficients(22);
    let y = target(&phi, &beta, 0.0, 0);
    let f = fit(phi.as_ref(), &y, &Estimator::Lsq, None, Solver::Fast).unwrap();
    assert_eq!(f.status, Status::Ok);
    // κ(scaled) ≈ 8e3: coefficients to ~κ·ε relative to the largest.
    let err = max_abs_diff(&f.coefficients, &beta);
    assert!(err <= 1e-9, "max error {err:e}");
}

/// The reduced design (1000 samples) with a tenth column that is the first plus `sliver` times a
/// product of two motion signals: κ(Z) in 1e4…1e5 for the slivers used here.
fn near_collinear_design(sliver: f64, phase: f64) -> Mat<f64> {
    let base = reduced_design(1000);
    let sig = signals(1000, phase);
    Mat::<f64>::from_fn(1000, 10, |i, j| {
        if j < 9 {
            base[(i, j)]
        } else {
            base[(i, 0)] + sliver * sig[i][0] * sig[i][3]
        }
    })
}

/// κ(Z) between 1e4 and 1e5: the direct LSQ path (normal equations from the raw design's
/// cross products, one refinement step, κ from a Rayleigh quotient) must agree with the
/// QR-based reference in J, coefficients and condition number.
#[test]
fn direct_lsq_matches_the_reference_at_kappa_near_its_limit() {
    for sliver in [4e-3, 8e-3] {
        let phi = near_collinear_design(sliver, 0.3);
        let kappa = scaled_condition_number(phi.as_ref()).unwrap();
        assert!(kappa > 1e4 && kappa < 1e5, "{kappa:e}");
        let mut beta = sway_like_coefficients(9);
        beta.push(0.2);
        let y = target(&phi, &beta, 0.01, 3);
        let fast = fit(phi.as_ref(), &y, &Estimator::Lsq, None, Solver::Fast).unwrap();
        let qp = fit(phi.as_ref(), &y, &Estimator::Lsq, None, Solver::Qp).unwrap();
        assert_eq!(fast.status, Status::Ok);
        assert!(rel_diff(fast.condition_number.unwrap(), kappa) < 1e-6);
        assert!(
            rel_diff(fast.objective, qp.objective) < 1e-9,
            "{} vs {}",
            fast.objective,
            qp.objective
        );
        // Scaled coefficients as accurate as a QR solution: κ ε relative, with margin.
        let s = column_scales(phi.as_ref()).unwrap();
        let gmax = (0..10)
            .map(|j| (qp.coefficients[j] * s[j]).abs())
            .fold(0.0, f64::max);
        for j in 0..10 {
            let d = (fast.coefficients[j] - qp.coefficients[j]).abs() * s[j];
            assert!(
                d <= 1e-5 * gmax,
                "column {j}: {d:e} (QP stops at its own tolerance)"
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]

    /// κ(Z) in 2e4…1e5 is read from a Rayleigh quotient on Z (the Gram eigenvalue alone
    /// is not accurate there, and the fast LSQ path has no QR factor to take an SVD of):
    /// it must still agree with the SVD of the scaled design.
    #[test]
    fn condition_number_from_the_rayleigh_quotient_matches_the_svd(
        sliver in 1.5e-3f64..5e-3,
        phase in 0.0f64..1.0,
    ) {
        let phi = near_collinear_design(sliver, phase);
        let kappa = scaled_condition_number(phi.as_ref()).unwrap();
        prop_assert!(kappa > 1e4 && kappa < 1e5, "{kappa:e}");
        let mut beta = sway_like_coefficients(9);
        beta.push(0.2);
        let y = target(&phi, &beta, 1e-3, 1);
        let f = fit(phi.as_ref(), &y, &Estimator::Lsq, None, Solver::Fast).unwrap();
        let k = f.condition_number.unwrap();
        // The Gram eigenvalue alone is off by ~1e-7 here; the Rayleigh quotient is not.
        prop_assert!(rel_diff(k, kappa) < 1e-9, "{k:e} vs {kappa:e}");
    }
}

#[test]
fn lsq_qr_path_on_a_design_with_condition_near_1e6() {
    // κ(Z) ≈ 1e6 is beyond the semi-normal-equation path (κ ≤ 1e5): solved by QR.
    let base = reduced_design(1000);
    let sig = signals(1000, 0.3);
    // v plus a sliver of Δu·δ, a monomial outside the reduced set.
    let phi = Mat::<f64>::from_fn(1000, 10, |i, j| {
        if j < 9 {
            base[(i, j)]
        } else {
            base[(i, 0)] + 2e-5 * sig[i][0] * sig[i][3]
        }
    });
    let kappa = scaled_condition_number(phi.as_ref()).unwrap();
    assert!(
        kappa > 1e5 && kappa < ILL_CONDITIONED_THRESHOLD,
        "{kappa:e}"
    );
    let mut beta = sway_like_coefficients(9);
    beta.push(0.2);
    let y = target(&phi, &beta, 0.0, 0);
    let f = fit(phi.as_ref(), &y, &Estimator::Lsq, None, Solver::Fast).unwrap();
    assert_eq!(f.status, Status::Ok);
    assert!(rel_diff(f.condition_number.unwrap(), kappa) < 1e-6);
    let s = column_scales(phi.as_ref()).unwrap();
    let err = (0..10)
        .map(|j| (f.coefficients[j] - beta[j]).abs() * s[j])
        .fold(0.0, f64::max);
    let scale = (0..10).map(|j| beta[j].abs() * s[j]).fold(0.0, f64::max);
    assert!(err <= 1e-8 * scale, "{err:e} vs {scale:e}");
}

#[test]
fn lsq_semi_normal_and_qr_paths_agree() {
    // Unbounded LSQ on a moderately conditioned design takes the semi-normal path; with
    // bounds that never bind it goes through the QR factor and the active-set method.
    let phi = full_design(3000);
    let y = target(&phi, &sway_like_coefficients(22), 0.05, 13);
    let loose = Bounds::new(vec![-1e6; 22], vec![1e6; 22]).unwrap();
    let a = fit(phi.as_ref(), &y, &Estimator::Lsq, None, Solver::Fast).unwrap();
    let b = fit(
        phi.as_ref(),
        &y,
        &Estimator::Lsq,
        Some(&loose),
        Solver::Fast,
    )
    .unwrap();
    let s = column_scales(phi.as_ref()).unwrap();
    let scale = (0..22)
        .map(|j| a.coefficients[j].abs() * s[j])
        .fold(0.0, f64::max);
    for j in 0..22 {
        let d = (a.coefficients[j] - b.coefficients[j]).abs() * s[j];
        assert!(d <= 1e-10 * scale, "column {j}: {d:e}");
    }
}

#[test]
fn bounds_are_respected_and_active_bounds_bind() {
    let phi = reduced_design(800);
    let beta = sway_like_coefficients(9);
    let y = target(&phi, &beta, 0.02, 5);
    // Y_v ∈ [-0.2, 0]; Y_r fixed at 0.05; Y_δ ≥ 0.
    let mut lower = vec![f64::NEG_INFINITY; 9];
    let mut upper = vec![f64::INFINITY; 9];
    lower[0] = -0.2;
    upper[0] = 0.0;
    lower[1] = 0.05;
    upper[1] = 0.05;
    lower[2] = 0.0;
    let bounds = Bounds::new(lower, upper).unwrap();
    let rms = rms(&y);
    for est in [
        Estimator::BoundedLsq,
        Estimator::Lsq,
        Estimator::Ridge { lambda: 1e-4 },
        Estimator::Lasso { alpha: 1e-6 },
        Estimator::Svr {
            c: 1e3 * rms / 800.0,
            epsilon: 0.01 * rms,
        },
    ] {
        let fits: Vec<Fit> = SOLVERS
            .iter()
            .map(|&solver| fit(phi.as_ref(), &y, &est, Some(&bounds), solver).unwrap())
            .collect();
        for f in &fits {
            assert!(bounds.contains(&f.coefficients), "{est:?} {:?}", f.solver);
            assert_eq!(f.coefficients[1], 0.05, "{est:?} {:?}", f.solver);
            // Unconstrained, Y_δ would be about -0.06: the bound at 0 binds.
            assert!(
                f.coefficients[2].abs() < 1e-9,
                "{est:?} {:?}: {}",
                f.solver,
                f.coefficients[2]
            );
        }
        // Both solvers find the same coefficients, not only the same objective. Compared
        // in the scaled space, where every objective here is strongly convex or, for
        // LSQ, well conditioned (κ ≈ 400).
        let s = column_scales(phi.as_ref()).unwrap();
        let g0: Vec<f64> = fits[0]
            .coefficients
            .iter()
            .zip(&s)
            .map(|(b, s)| b * s)
            .collect();
        let g1: Vec<f64> = fits[1]
            .coefficients
            .iter()
            .zip(&s)
            .map(|(b, s)| b * s)
            .collect();
        let gmax = g0.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let d = max_abs_diff(&g0, &g1) / gmax;
        if let Estimator::Svr { .. } = est {
            // The interior point stops at a relative gap of about 1e-11 (the tight
            // tolerances of the QP path), and strong convexity (modulus 1) only bounds its
            // distance by √(2·gap); the fast solver ends on a KKT point to rounding. So the
            // objectives agree far inside the 1e-6 contract, the coefficients less closely.
            assert!(d < 1e-4, "{est:?}: {d:e}");
            let (fast, qp) = (fits[0].objective, fits[1].objective);
            assert!((fast - qp).abs() <= 1e-9 * qp.abs(), "{fast:e} vs {qp:e}");
        } else {
            assert!(d < 1e-6, "{est:?}: {d:e}");
        }
    }
}

#[test]
fn ridge_tends_to_lsq_as_lambda_vanishes() {
    let phi = full_design(2000);
    let beta = sway_like_coefficients(22);
    let y = target(&phi, &beta, 0.01, 9);
    let lsq = fit(phi.as_ref(), &y, &Estimator::Lsq, None, Solver::Fast).unwrap();
    let mut prev = f64::INFINITY;
    for lambda in [1e-6, 1e-8, 1e-10, 1e-12, 1e-14] {
        let r = fit(
            phi.as_ref(),
            &y,
            &Estimator::Ridge { lambda },
            None,
            Solver::Fast,
        )
        .unwrap();
        let d = max_abs_diff(&r.coefficients, &lsq.coefficients);
        assert!(d < prev, "λ = {lambda:e}: {d:e} not below {prev:e}");
        prev = d;
    }
    let scale = lsq.coefficients.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(prev <= 1e-6 * scale, "{prev:e}");
    // λ = 0 is exactly LSQ.
    let r0 = fit(
        phi.as_ref(),
        &y,
        &Estimator::Ridge { lambda: 0.0 },
        None,
        Solver::Fast,
    )
    .unwrap();
    assert_eq!(r0.coefficients, lsq.coefficients);
}

#[test]
fn ridge_shrinks_the_scaled_norm_monotonically() {
    let phi = full_design(1000);
    let y = target(&phi, &sway_like_coefficients(22), 0.05, 2);
    let scales = column_scales(phi.as_ref()).unwrap();
    let mut prev = f64::INFINITY;
    for lambda in [1e-8, 1e-6, 1e-4, 1e-2, 1.0] {
        let f = fit(
            phi.as_ref(),
            &y,
            &Estimator::Ridge { lambda },
            None,
            Solver::Fast,
        )
        .unwrap();
        let norm: f64 = f
            .coefficients
            .iter()
            .zip(&scales)
            .map(|(b, s)| (b * s).powi(2))
            .sum();
        assert!(norm < prev);
        prev = norm;
    }
}

#[test]
fn lasso_with_large_alpha_gives_zeros() {
    let phi = full_design(1000);
    let y = target(&phi, &sway_like_coefficients(22), 0.05, 4);
    let alpha_max = *default_grid(&Family::Lasso, phi.as_ref(), &y)
        .unwrap()
        .last()
        .unwrap();
    let fast = fit(
        phi.as_ref(),
        &y,
        &Estimator::Lasso { alpha: alpha_max },
        None,
        Solver::Fast,
    )
    .unwrap();
    assert!(
        fast.coefficients.iter().all(|&b| b == 0.0),
        "{:?}",
        fast.coefficients
    );
    let qp = fit(
        phi.as_ref(),
        &y,
        &Estimator::Lasso {
            alpha: 1.01 * alpha_max,
        },
        None,
        Solver::Qp,
    )
    .unwrap();
    let scales = column_scales(phi.as_ref()).unwrap();
    let rms = rms(&y);
    for (b, s) in qp.coefficients.iter().zip(&scales) {
        assert!((b * s).abs() <= 1e-7 * rms, "{b}");
    }
    // Just below α_max exactly one coefficient enters.
    let f = fit(
        phi.as_ref(),
        &y,
        &Estimator::Lasso {
            alpha: 0.99 * alpha_max,
        },
        None,
        Solver::Fast,
    )
    .unwrap();
    assert_eq!(f.coefficients.iter().filter(|&&b| b != 0.0).count(), 1);
}

#[test]
fn lasso_zeros_more_coefficients_as_alpha_grows() {
    let phi = full_design(2000);
    let y = target(&phi, &sway_like_coefficients(22), 0.02, 8);
    let grid = default_grid(&Family::Lasso, phi.as_ref(), &y).unwrap();
    let nonzeros: Vec<usize> = grid
        .iter()
        .map(|&alpha| {
            let f = fit(
                phi.as_ref(),
                &y,
                &Estimator::Lasso { alpha },
                None,
                Solver::Fast,
            )
            .unwrap();
            f.coefficients.iter().filter(|&&b| b != 0.0).count()
        })
        .collect();
    assert!(nonzeros[0] >= 10, "{nonzeros:?}");
    assert_eq!(*nonzeros.last().unwrap(), 0);
    assert!(
        nonzeros.first() > nonzeros.get(nonzeros.len() / 2),
        "{nonzeros:?}"
    );
}

#[test]
fn svr_with_wide_tube_gives_zero() {
    let phi = reduced_design(600);
    let y = target(&phi, &sway_like_coefficients(9), 0.05, 1);
    let ymax = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let est = Estimator::Svr {
        c: 10.0,
        epsilon: 1.01 * ymax,
    };
    let fast = fit(phi.as_ref(), &y, &est, None, Solver::Fast).unwrap();
    assert!(
        fast.coefficients.iter().all(|&b| b == 0.0),
        "{:?}",
        fast.coefficients
    );
    assert_eq!(fast.objective, 0.0);
    let qp = fit(phi.as_ref(), &y, &est, None, Solver::Qp).unwrap();
    assert!(qp.objective <= 1e-9, "{}", qp.objective);
}

#[test]
fn svr_tube_contains_the_inside_samples() {
    // With a large C, samples off the tube are few: at most p lie exactly on its edge
    // and the rest are strictly inside or outside.
    let phi = reduced_design(1000);
    let y = target(&phi, &sway_like_coefficients(9), 0.05, 12);
    let rms = rms(&y);
    let eps = 0.05 * rms;
    let f = fit(
        phi.as_ref(),
        &y,
        &Estimator::Svr {
            c: 1.0,
            epsilon: eps,
        },
        None,
        Solver::Fast,
    )
    .unwrap();
    assert_eq!(f.status, Status::Ok);
    let pred = predict(phi.as_ref(), &f.coefficients).unwrap();
    let on_edge = y
        .iter()
        .zip(&pred)
        .filter(|(a, b)| ((*a - *b).abs() - eps).abs() <= 1e-9 * rms)
        .count();
    assert!(
        (1..=9).contains(&on_edge),
        "{on_edge} samples on the tube edge"
    );
}

#[test]
fn column_scaling_does_not_change_lsq() {
    let phi = full_design(1500);
    let y = target(&phi, &sway_like_coefficients(22), 0.02, 21);
    let factors: Vec<f64> = (0..22).map(|j| 10f64.powi((j % 7) - 3)).collect();
    let scaled = Mat::<f64>::from_fn(1500, 22, |i, j| phi[(i, j)] * factors[j]);
    for solver in SOLVERS {
        let a = fit(phi.as_ref(), &y, &Estimator::Lsq, None, solver).unwrap();
        let b = fit(scaled.as_ref(), &y, &Estimator::Lsq, None, solver).unwrap();
        for j in 0..22 {
            let back = b.coefficients[j] * factors[j];
            let tol = if solver == Solver::Fast { 1e-8 } else { 1e-5 };
            assert!(
                (back - a.coefficients[j]).abs() <= tol * a.coefficients[j].abs().max(1e-3),
                "{solver:?} column {j}: {back} vs {}",
                a.coefficients[j]
            );
        }
        assert!(rel_diff(a.objective, b.objective) < 1e-9);
    }
}

#[test]
fn regularised_fits_are_invariant_to_column_units() {
    // The penalty acts on RMS-scaled coefficients, so changing a column's units only
    // rescales its coefficient.
    let phi = reduced_design(700);
    let y = target(&phi, &sway_like_coefficients(9), 0.05, 3);
    let factors: Vec<f64> = (0..9).map(|j: i32| 10f64.powi(j - 4)).collect();
    let scaled = Mat::<f64>::from_fn(700, 9, |i, j| phi[(i, j)] * factors[j]);
    for est in [
        Estimator::Ridge { lambda: 1e-3 },
        Estimator::Lasso { alpha: 1e-5 },
        Estimator::Svr {
            c: 0.05,
            epsilon: 1e-4,
        },
    ] {
        let a = fit(phi.as_ref(), &y, &est, None, Solver::Fast).unwrap();
        let b = fit(scaled.as_ref(), &y, &est, None, Solver::Fast).unwrap();
        for j in 0..9 {
            let back = b.coefficients[j] * factors[j];
            assert!(
                (back - a.coefficients[j]).abs() <= 1e-7 * a.coefficients[j].abs().max(1e-6),
                "{est:?} {j}"
            );
        }
    }
}

#[test]
fn objective_matches_the_documented_formulas() {
    let phi = Mat::<f64>::from_fn(4, 2, |i, j| {
        [[1.0, 2.0], [2.0, -1.0], [0.0, 3.0], [1.0, 1.0]][i][j]
    });
    let y = [1.0, 0.5, -1.0, 2.0];
    let beta = [0.5, -0.25];
    // Residuals y − Φβ = [1, -0.75, -0.25, 1.75]; RMS scales s = [√1.5, √3.75].
    let sse: f64 = 1.0 + 0.5625 + 0.0625 + 3.0625;
    let (s0, s1) = (1.5f64.sqrt(), 3.75f64.sqrt());
    let j = |e: Estimator| objective(phi.as_ref(), &y, &e, &beta).unwrap();
    assert!((j(Estimator::Lsq) - sse / 8.0).abs() < 1e-15);
    let ridge = sse / 8.0 + 0.5 * 0.3 * ((0.5 * s0).powi(2) + (0.25 * s1).powi(2));
    assert!((j(Estimator::Ridge { lambda: 0.3 }) - ridge).abs() < 1e-14);
    let lasso = sse / 8.0 + 0.2 * (0.5 * s0 + 0.25 * s1);
    assert!((j(Estimator::Lasso { alpha: 0.2 }) - lasso).abs() < 1e-14);
    // ε = 0.8: hinge terms 0.2, 0, 0, 0.95.
    let svr = 0.5 * ((0.5 * s0).powi(2) + (0.25 * s1).powi(2)) + 2.0 * (0.2 + 0.95);
    assert!(
        (j(Estimator::Svr {
            c: 2.0,
            epsilon: 0.8
        }) - svr)
            .abs()
            < 1e-14
    );
}

#[test]
fn zero_column_is_held_at_the_bound_nearest_zero() {
    let base = reduced_design(400);
    let y = target(&base, &sway_like_coefficients(9), 0.02, 6);
    let with_zero = Mat::<f64>::from_fn(400, 10, |i, j| {
        if j == 4 {
            0.0
        } else {
            base[(i, if j < 4 { j } else { j - 1 })]
        }
    });
    let mut lower = vec![f64::NEG_INFINITY; 10];
    let upper = vec![f64::INFINITY; 10];
    let reference = fit(
        base.as_ref(),
        &y,
        &Estimator::Ridge { lambda: 1e-5 },
        None,
        Solver::Fast,
    )
    .unwrap();
    for solver in SOLVERS {
        let f = fit(
            with_zero.as_ref(),
            &y,
            &Estimator::Ridge { lambda: 1e-5 },
            None,
            solver,
        )
        .unwrap();
        assert_eq!(f.zero_columns, vec![4]);
        // The data say nothing about column 4: not a fit that identifies every coefficient.
        assert_eq!(
            f.status,
            Status::RankDeficient {
                zero_columns: vec![4]
            },
            "{solver:?}"
        );
        assert!(f.status.is_solved() && !f.status.is_identified());
        assert_eq!(f.coefficients[4], 0.0);
        let others: Vec<f64> = f
            .coefficients
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != 4)
            .map(|(_, b)| *b)
            .collect();
        assert!(max_abs_diff(&others, &reference.coefficients) < 1e-6);
    }
    lower[4] = 0.7;
    let b = Bounds::new(lower, upper).unwrap();
    let f = fit(
        with_zero.as_ref(),
        &y,
        &Estimator::Lsq,
        Some(&b),
        Solver::Fast,
    )
    .unwrap();
    assert_eq!(f.coefficients[4], 0.7);
}

#[test]
fn near_singular_design_is_flagged() {
    // Two columns equal up to 1e-9 relative: κ ≈ 1e9 > 6.7e7.
    let base = reduced_design(500);
    let phi = Mat::<f64>::from_fn(500, 10, |i, j| {
        if j < 9 {
            base[(i, j)]
        } else {
            base[(i, 0)] * (1.0 + 1e-9 * ((i * 7919) % 13) as f64)
        }
    });
    let y = target(&base, &sway_like_coefficients(9), 0.01, 2);
    for solver in SOLVERS {
        let f = fit(phi.as_ref(), &y, &Estimator::Lsq, None, solver).unwrap();
        match f.status {
            Status::IllConditioned { condition_number } => {
                assert!(condition_number > 1e8, "{condition_number:e}")
            }
            other => panic!("{solver:?}: expected IllConditioned, got {other:?}"),
        }
        // Ridge with a sensible λ is well posed on the same design.
        let r = fit(
            phi.as_ref(),
            &y,
            &Estimator::Ridge { lambda: 1e-6 },
            None,
            solver,
        )
        .unwrap();
        assert_eq!(r.status, Status::Ok, "{solver:?}");
        assert!(r.condition_number.unwrap() < 1e4);
    }
}

#[test]
fn exactly_collinear_design_still_minimises_the_objective() {
    let base = reduced_design(300);
    let phi = Mat::<f64>::from_fn(300, 10, |i, j| {
        if j < 9 {
            base[(i, j)]
        } else {
            2.0 * base[(i, 3)]
        }
    });
    let y = target(&base, &sway_like_coefficients(9), 0.02, 5);
    let reference = fit(base.as_ref(), &y, &Estimator::Lsq, None, Solver::Fast).unwrap();
    let f = fit(phi.as_ref(), &y, &Estimator::Lsq, None, Solver::Fast).unwrap();
    assert!(
        matches!(f.status, Status::IllConditioned { .. }),
        "{:?}",
        f.status
    );
    assert!(rel_diff(f.objective, reference.objective) < 1e-9);
    // Minimum-norm split between the two identical directions.
    let s = column_scales(phi.as_ref()).unwrap();
    assert!((f.coefficients[3] * s[3] - f.coefficients[9] * s[9]).abs() < 1e-8);
}

#[test]
fn fewer_samples_than_columns() {
    let phi = random_design(5, 8, 3);
    let y: Vec<f64> = (0..5).map(|i| i as f64 - 2.0).collect();
    for solver in SOLVERS {
        let lsq = fit(phi.as_ref(), &y, &Estimator::Lsq, None, solver).unwrap();
        // Interpolates the data.
        assert!(lsq.objective < 1e-12, "{solver:?} {}", lsq.objective);
        assert!(matches!(lsq.status, Status::IllConditioned { .. }));
        let ridge = fit(
            phi.as_ref(),
            &y,
            &Estimator::Ridge { lambda: 0.1 },
            None,
            solver,
        )
        .unwrap();
        assert_eq!(ridge.status, Status::Ok);
    }
}

#[test]
fn serde_round_trip_of_the_configuration_types() {
    let est = Estimator::Svr {
        c: 0.5,
        epsilon: 1e-3,
    };
    let text = serde_json::to_string(&est).unwrap();
    assert_eq!(text, r#"{"kind":"svr","c":0.5,"epsilon":0.001}"#);
    assert_eq!(serde_json::from_str::<Estimator>(&text).unwrap(), est);
    let ridge: Estimator = serde_json::from_str(r#"{"kind":"ridge","lambda":1e-4}"#).unwrap();
    assert_eq!(ridge, Estimator::Ridge { lambda: 1e-4 });
    assert_eq!(serde_json::to_string(&Solver::Fast).unwrap(), r#""fast""#);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn lsq_is_exact_on_noise_free_random_designs(n in 12usize..200, p in 1usize..10, seed in any::<u64>()) {
        prop_assume!(n >= p + 2);
        let phi = random_design(n, p, seed);
        let s = column_scales(phi.as_ref()).unwrap();
        let beta: Vec<f64> = (0..p).map(|j| ((j + 1) as f64).cos() / s[j]).collect();
        let y = target(&phi, &beta, 0.0, 0);
        let f = fit(phi.as_ref(), &y, &Estimator::Lsq, None, Solver::Fast).unwrap();
        let kappa = f.condition_number.unwrap();
        for j in 0..p {
            prop_assert!((f.coefficients[j] - beta[j]).abs() * s[j] <= 1e-12 * kappa.max(1.0) * 10.0,
                "coefficient {}: {} vs {}", j, f.coefficients[j], beta[j]);
        }
    }

    #[test]
    fn every_estimator_stays_in_random_boxes(
        n in 20usize..120, p in 1usize..7, seed in any::<u64>(), which in 0usize..4, width in 0.0f64..2.0,
    ) {
        let phi = random_design(n, p, seed);
        let y = target(&phi, &vec![1.0; p], 0.2, seed);
        let fit0 = fit(phi.as_ref(), &y, &Estimator::Lsq, None, Solver::Fast).unwrap();
        let lower: Vec<f64> = fit0.coefficients.iter().map(|b| b - width * b.abs() * 0.5 + 0.1 * b.abs()).collect();
        let upper: Vec<f64> = lower.iter().zip(&fit0.coefficients).map(|(l, b)| l + width * b.abs() * 0.4).collect();
        let bounds = Bounds::new(lower, upper).unwrap();
        let est = [Estimator::BoundedLsq, Estimator::Ridge { lambda: 1e-3 }, Estimator::Lasso { alpha: 1e-3 }, Estimator::Svr { c: 1.0, epsilon: 0.01 }][which];
        for solver in SOLVERS {
            let f = fit(phi.as_ref(), &y, &est, Some(&bounds), solver).unwrap();
            prop_assert!(bounds.contains(&f.coefficients));
        }
    }
}
