//! VIF and condition numbers.
// Index loops over several parallel arrays read more clearly than zipped iterators.
#![allow(clippy::needless_range_loop)]

use crate::common::*;
use shipid_estimators::faer::Mat;
use shipid_estimators::*;

/// Sine and cosine columns over whole periods: zero mean and mutually orthogonal.
fn orthogonal_design(n: usize) -> Mat<f64> {
    let w = 2.0 * std::f64::consts::PI / n as f64;
    Mat::from_fn(n, 5, |i, j| {
        let t = i as f64 * w;
        match j {
            0 => (t).sin(),
            1 => 3.0 * (2.0 * t).cos(),
            2 => 0.01 * (3.0 * t).sin(),
            3 => 1.0, // constant: no VIF
            _ => 100.0 * (5.0 * t).cos(),
        }
    })
}

#[test]
fn vif_of_orthogonal_columns_is_one() {
    let v = vif(orthogonal_design(360).as_ref()).unwrap();
    assert_eq!(v[3], None);
    for j in [0, 1, 2, 4] {
        let x = v[j].unwrap();
        assert!((x - 1.0).abs() < 1e-12, "column {j}: {x}");
    }
}

#[test]
fn vif_of_nearly_collinear_columns_is_large() {
    let n = 500;
    let base = orthogonal_design(n);
    // x5 = x0 + 1e-4 · x1/3: R² of x5 on x0 is 1 − 1e-8·var(x1/3)/var(x5) ≈ 1 − 1e-8.
    let phi = Mat::<f64>::from_fn(n, 3, |i, j| match j {
        0 => base[(i, 0)],
        1 => base[(i, 0)] + 1e-4 * base[(i, 1)] / 3.0,
        _ => base[(i, 4)],
    });
    let v = vif(phi.as_ref()).unwrap();
    // Exact value: 1/(1 − R²) = (1 + 1e-8)/1e-8 for both collinear columns.
    let expected = (1.0 + 1e-8) / 1e-8;
    for j in [0, 1] {
        let x = v[j].unwrap();
        assert!(
            rel_diff(x, expected) < 1e-6,
            "column {j}: {x:e} vs {expected:e}"
        );
    }
    assert!((v[2].unwrap() - 1.0).abs() < 1e-9);
}

#[test]
fn vif_matches_an_explicit_regression_with_intercept() {
    let phi = full_design(800);
    let v = vif(phi.as_ref()).unwrap();
    assert_eq!(v[0], None, "the constant column has no VIF");
    let n = phi.nrows();
    for j in [3usize, 9, 17] {
        // Regress column j on the others (column 0 is the intercept) by LSQ.
        let others: Vec<usize> = (0..22).filter(|&k| k != j).collect();
        let x = Mat::<f64>::from_fn(n, 21, |i, t| phi[(i, others[t])]);
        let y: Vec<f64> = (0..n).map(|i| phi[(i, j)]).collect();
        let f = fit(x.as_ref(), &y, &Estimator::Lsq, None, Solver::Fast).unwrap();
        let mean = y.iter().sum::<f64>() / n as f64;
        let sst: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
        let sse = 2.0 * n as f64 * f.objective;
        let expected = sst / sse; // 1/(1 − R²)
        let got = v[j].unwrap();
        assert!(
            got > 10.0,
            "column {j} of an Abkowitz design should be collinear: {got}"
        );
        assert!(
            rel_diff(got, expected) < 1e-6,
            "column {j}: {got:e} vs {expected:e}"
        );
    }
}

#[test]
fn vif_of_exactly_collinear_columns_is_huge_or_infinite() {
    let base = orthogonal_design(200);
    let phi = Mat::<f64>::from_fn(200, 3, |i, j| match j {
        0 => base[(i, 0)],
        1 => 2.0 * base[(i, 0)] + 1.0,
        _ => base[(i, 1)],
    });
    let v = vif(phi.as_ref()).unwrap();
    assert!(v[0].unwrap() > 1e13, "{:?}", v);
    assert!(v[1].unwrap() > 1e13, "{:?}", v);
}

#[test]
fn condition_number_of_a_diagonal_design() {
    let d = [1.0, 1e-3, 5.0, -2.0];
    let phi = Mat::<f64>::from_fn(6, 4, |i, j| if i == j { d[j] } else { 0.0 });
    let k = condition_number(phi.as_ref()).unwrap();
    assert!(rel_diff(k, 5.0 / 1e-3) < 1e-12, "{k}");
    // Each column has one non-zero: after RMS scaling all singular values are equal.
    let ks = scaled_condition_number(phi.as_ref()).unwrap();
    assert!((ks - 1.0).abs() < 1e-12, "{ks}");
}

#[test]
fn condition_numbers_of_an_abkowitz_design() {
    let phi = full_design(4000);
    let raw = condition_number(phi.as_ref()).unwrap();
    let scaled = scaled_condition_number(phi.as_ref()).unwrap();
    assert!(raw > 1e5, "{raw:e}");
    assert!(
        scaled < raw / 10.0,
        "scaling should help: {scaled:e} vs {raw:e}"
    );
    // The LSQ fit reports the same scaled condition number.
    let y = target(&phi, &sway_like_coefficients(22), 0.01, 1);
    let f = fit(phi.as_ref(), &y, &Estimator::Lsq, None, Solver::Fast).unwrap();
    assert!(rel_diff(f.condition_number.unwrap(), scaled) < 1e-6);
}

#[test]
fn singular_design_has_infinite_condition_number() {
    let phi = Mat::<f64>::from_fn(10, 3, |i, j| if j == 2 { 0.0 } else { (i + j) as f64 });
    assert_eq!(condition_number(phi.as_ref()).unwrap(), f64::INFINITY);
    assert_eq!(
        scaled_condition_number(phi.as_ref()).unwrap(),
        f64::INFINITY
    );
    let wide = Mat::<f64>::from_fn(2, 3, |i, j| (i * 3 + j) as f64 + 1.0);
    assert_eq!(condition_number(wide.as_ref()).unwrap(), f64::INFINITY);
}

#[test]
fn contributions_sum_to_the_prediction() {
    let phi = reduced_design(300);
    let beta = sway_like_coefficients(9);
    let c = contributions(phi.as_ref(), &beta).unwrap();
    let pred = predict(phi.as_ref(), &beta).unwrap();
    for i in (0..300).step_by(37) {
        let s: f64 = (0..9).map(|j| c[(i, j)]).sum();
        assert!((s - pred[i]).abs() < 1e-15 + 1e-13 * pred[i].abs());
        assert_eq!(c[(i, 2)], phi[(i, 2)] * beta[2]);
    }
}
