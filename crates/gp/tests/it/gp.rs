//! The GP on noise-free synthetic data: recovery of a known smooth function, the sparsifier on a small
//! hand-made example, and the analytic LML gradient against finite differences.

use shipid_gp::*;

/// Paper 001 eq. (14).
fn test_function(x1: f64, x2: f64) -> f64 {
    x1 * x2.sin() + x2 * x1.sin()
}

fn grid(step: f64, lo: f64, hi: f64) -> Vec<[f64; 2]> {
    let n = ((hi - lo) / step).round() as usize;
    let mut out = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            out.push([lo + i as f64 * step, lo + j as f64 * step]);
        }
    }
    out
}

fn points(p: &[[f64; 2]]) -> Points {
    Points::new(2, p.iter().flat_map(|a| a.iter().copied()).collect()).unwrap()
}

#[test]
fn recovers_the_paper_test_function_between_the_training_points() {
    // Training: a 0.5-spaced grid on [-3, 3]² (169 points); test: the midpoints between them.
    let train = grid(0.5, -3.0, 3.0);
    let y: Vec<f64> = train.iter().map(|p| test_function(p[0], p[1])).collect();
    let (gp, training) = Gp::train(points(&train), y, &TrainOptions::default()).unwrap();
    assert!(training.iterations > 0);
    let test: Vec<[f64; 2]> = grid(0.5, -2.75, 2.75);
    let (mean, var) = gp.predict(&points(&test)).unwrap();
    let mut worst: f64 = 0.0;
    for (p, m) in test.iter().zip(&mean) {
        worst = worst.max((m - test_function(p[0], p[1])).abs());
        // The fast mean (blocked, negligible far points left out) equals the full kernel product.
        assert!((gp.predict_mean(p) - m).abs() < 1e-9, "at {p:?}");
    }
    // |y| reaches ~5 on this domain; a smooth interpolant of a noise-free function does far better
    // than 1 %.
    assert!(worst < 0.01, "worst error {worst}");
    // Noise-free data: the learned noise is tiny compared with the signal.
    assert!(
        gp.hyper().noise_std < 1e-2 * gp.hyper().signal_std,
        "{:?}",
        gp.hyper()
    );
    // The latent variance is small between close points.
    assert!(
        var.iter().all(|v| *v < 1e-3),
        "max var {:?}",
        var.iter().cloned().fold(0.0, f64::max)
    );
}

#[test]
fn variance_is_zero_at_data_and_the_prior_far_away() {
    let x = Points::new(1, vec![0.0, 1.0, 2.0]).unwrap();
    let h = Hyper {
        length_scales: vec![1.0],
        signal_std: 2.0,
        noise_std: 1e-6,
    };
    let gp = Gp::new(x, vec![1.0, 2.0, 0.0], h).unwrap();
    let (mean, var) = gp
        .predict(&Points::new(1, vec![1.0, 100.0]).unwrap())
        .unwrap();
    assert!((mean[0] - 2.0).abs() < 1e-6, "interpolates: {}", mean[0]);
    assert!(var[0] < 1e-6, "{}", var[0]);
    // Far from the data: prior mean (mean of y = 1) and prior variance σ_f² = 4.
    assert!((mean[1] - 1.0).abs() < 1e-12);
    assert!((var[1] - 4.0).abs() < 1e-12);
    assert!((gp.predict_mean(&[1.0]) - mean[0]).abs() < 1e-12);
}

#[test]
fn lml_gradient_matches_finite_differences() {
    let pts: Vec<[f64; 2]> = (0..40)
        .map(|i| {
            let t = i as f64 * 0.37;
            [t.sin() * 2.0, (1.3 * t).cos() * 1.5]
        })
        .collect();
    let y: Vec<f64> = pts
        .iter()
        .enumerate()
        .map(|(i, p)| test_function(p[0], p[1]) + 0.05 * ((i * 7919) % 13) as f64 / 13.0)
        .collect();
    let x = points(&pts);
    let h = Hyper {
        length_scales: vec![0.8, 1.7],
        signal_std: 1.4,
        noise_std: 0.2,
    };
    let (_, grad) = log_marginal_likelihood(&x, &y, &h).unwrap();
    let theta = h.to_log();
    for j in 0..theta.len() {
        let step = 1e-5;
        let at = |d: f64| {
            let mut t = theta.clone();
            t[j] += d;
            log_marginal_likelihood(&x, &y, &Hyper::from_log(&t))
                .unwrap()
                .0
        };
        let fd = (at(step) - at(-step)) / (2.0 * step);
        assert!(
            (fd - grad[j]).abs() <= 1e-6 * (1.0 + fd.abs()),
            "θ_{j}: analytic {} vs finite difference {fd}",
            grad[j]
        );
    }
}

#[test]
fn lml_matches_a_hand_computed_two_point_case() {
    // Two points 1 apart, ℓ = 1, σ_f = 1, σ_n = 0.5, y = (1, −1) (mean 0):
    // K_y = [[1.25, e^{-1/2}], [e^{-1/2}, 1.25]] (+ jitter), yᵀK_y⁻¹y = 2/(1.25 − e^{-1/2}).
    let x = Points::new(1, vec![0.0, 1.0]).unwrap();
    let h = Hyper {
        length_scales: vec![1.0],
        signal_std: 1.0,
        noise_std: 0.5,
    };
    let (lml, _) = log_marginal_likelihood(&x, &[1.0, -1.0], &h).unwrap();
    let (a, b) = (1.25 + JITTER, (-0.5f64).exp());
    let expected =
        -0.5 * 2.0 / (a - b) - 0.5 * (a * a - b * b).ln() - (2.0 * std::f64::consts::PI).ln();
    assert!((lml - expected).abs() < 1e-12, "{lml} vs {expected}");
}

/// check(points, scales, threshold, expected kept indices)
fn check_sparsify(p: &[[f64; 2]], scales: [f64; 2], threshold: f64, expected: &[usize]) {
    let kept = sparsify(
        &points(p),
        &Similarity {
            scales: scales.to_vec(),
            threshold,
        },
    )
    .unwrap();
    assert_eq!(
        kept, expected,
        "points {p:?}, scales {scales:?}, d_gen {threshold}"
    );
}

#[test]
fn sparsifier_keeps_the_expected_points() {
    // d = exp(−Δx²) with l = 1. Threshold e^{-1}: a point is new when it is farther than 1 from every
    // kept point. Walk: 0 kept; 0.5 (d = e^{-0.25}) dropped; 1.2 kept; 1.9 (0.7 from 1.2) dropped;
    // 2.3 (1.1 from 1.2) kept; 0.1 dropped (close to 0); 5 kept.
    let line = [
        [0.0, 0.0],
        [0.5, 0.0],
        [1.2, 0.0],
        [1.9, 0.0],
        [2.3, 0.0],
        [0.1, 0.0],
        [5.0, 0.0],
    ];
    check_sparsify(&line, [1.0, 1.0], (-1.0f64).exp(), &[0, 2, 4, 6]);
    // Threshold 1: everything distinct is new.
    check_sparsify(&line, [1.0, 1.0], 1.0, &[0, 1, 2, 3, 4, 5, 6]);
    // A larger scale along x1 makes points more similar along it: with l₁ = 3, 1.2 is only 0.4 scaled
    // units from 0 and is dropped; 2.3 (0.77) dropped; 5 (1.67) kept.
    check_sparsify(&line, [3.0, 1.0], (-1.0f64).exp(), &[0, 6]);
    // The second dimension counts too: (0, 0.5) and (0.5, 0.5) are within distance 1 of (0, 0), but
    // (0.9, 0.9) is 1.27 away.
    check_sparsify(
        &[[0.0, 0.0], [0.0, 0.5], [0.5, 0.5], [0.9, 0.9]],
        [1.0, 1.0],
        (-1.0f64).exp(),
        &[0, 3],
    );
    // Exact duplicates are never kept (similarity 1 is not below any threshold ≤ 1).
    check_sparsify(&[[1.0, 1.0], [1.0, 1.0]], [1.0, 1.0], 1.0, &[0]);
}

#[test]
fn sparsifying_the_paper_grid_spreads_points_evenly() {
    // Paper 001 §3: the 0.2-spaced grid (3721 points). With scales equal to the half range and
    // d_gen = exp(−(0.1)²·2), kept points are at least 0.1·half-range apart in the scaled norm…
    let g = grid(0.2, -6.0, 6.0);
    assert_eq!(g.len(), 3721);
    let x = points(&g);
    let sim = Similarity {
        scales: half_ranges(&x),
        threshold: (-0.05f64).exp(),
    };
    let kept = sparsify(&x, &sim).unwrap();
    let s = x.select(&kept);
    for i in 0..s.len() {
        for j in 0..i {
            assert!(sim.similarity(s.row(i), s.row(j)) < sim.threshold);
        }
    }
    // …and every grid point is similar to some kept point (coverage: nothing is left out).
    for i in 0..x.len() {
        let best = (0..s.len())
            .map(|j| sim.similarity(x.row(i), s.row(j)))
            .fold(0.0, f64::max);
        assert!(best >= sim.threshold);
    }
}

#[test]
fn bad_input_is_a_typed_error() {
    let x = Points::new(1, vec![0.0, 1.0]).unwrap();
    assert!(matches!(
        Gp::train(x.clone(), vec![1.0], &TrainOptions::default()),
        Err(GpError::LengthMismatch { .. })
    ));
    assert!(matches!(
        Gp::train(x.clone(), vec![1.0, f64::NAN], &TrainOptions::default()),
        Err(GpError::NonFinite { .. })
    ));
    assert!(matches!(
        Points::new(2, vec![0.0, 1.0, 2.0]),
        Err(GpError::LengthMismatch { .. })
    ));
    assert!(matches!(
        Points::new(1, vec![f64::INFINITY]),
        Err(GpError::NonFinite { .. })
    ));
    for threshold in [0.0, 1.5, f64::NAN] {
        assert!(matches!(
            sparsify(
                &x,
                &Similarity {
                    scales: vec![1.0],
                    threshold
                }
            ),
            Err(GpError::InvalidParameter { .. })
        ));
    }
    let bad = Hyper {
        length_scales: vec![-1.0],
        signal_std: 1.0,
        noise_std: 0.1,
    };
    assert!(matches!(
        Gp::new(x, vec![0.0, 1.0], bad),
        Err(GpError::InvalidParameter { .. })
    ));
}
