//! Posterior draws: at the training points they have the posterior's mean and variance; far from every
//! training point they revert to the prior mean, as the documented approximation says.

use std::sync::Arc;

use shipid_gp::*;

/// Standard normals from a fixed linear congruential stream (Box–Muller): enough for a test.
fn normals(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    let mut uniform = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 + 1.0) / (1u64 << 53) as f64
    };
    move || {
        let (u1, u2) = (uniform(), uniform());
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

/// A noisy 1-D GP: sin(x) at 15 points on [0, 6] with noise 0.1.
fn noisy_sine() -> Gp {
    let xs: Vec<f64> = (0..15).map(|i| i as f64 * 6.0 / 14.0).collect();
    let y: Vec<f64> = xs
        .iter()
        .enumerate()
        .map(|(i, x)| x.sin() + 0.1 * if i % 2 == 0 { 1.0 } else { -1.0 })
        .collect();
    Gp::new(
        Points::new(1, xs).unwrap(),
        y,
        Hyper {
            length_scales: vec![1.0],
            signal_std: 1.0,
            noise_std: 0.1,
        },
    )
    .unwrap()
}

/// Check the empirical mean and variance of `draws` draws at `x` against `(mean, var)`.
fn check(gp: &Arc<Gp>, draws: usize, x: f64, expected: (f64, f64)) {
    let sampler = PosteriorSampler::new(Arc::clone(gp)).unwrap();
    let mut normal = normals(42);
    let values: Vec<f64> = (0..draws)
        .map(|_| sampler.draw(&mut normal).unwrap().value(&[x]))
        .collect();
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let (m, v) = expected;
    // Mean within 4 standard errors; variance within 4 standard errors of a normal sample variance.
    assert!(
        (mean - m).abs() < 4.0 * (v / n).sqrt() + 1e-12,
        "at {x}: draw mean {mean}, posterior mean {m}"
    );
    assert!(
        (var - v).abs() < 4.0 * v * (2.0 / (n - 1.0)).sqrt() + 1e-12,
        "at {x}: draw variance {var}, posterior variance {v}"
    );
}

#[test]
fn draws_have_the_posterior_mean_and_variance_at_the_training_points() {
    let gp = Arc::new(noisy_sine());
    for i in [0usize, 4, 7, 14] {
        let x = gp.points().row(i)[0];
        let (m, v) = gp.predict(&Points::new(1, vec![x]).unwrap()).unwrap();
        check(&gp, 4000, x, (m[0], v[0]));
    }
}

#[test]
fn draws_revert_to_the_prior_mean_far_from_the_data() {
    let gp = Arc::new(noisy_sine());
    check(&gp, 200, 60.0, (gp.prior_mean(), 0.0));
}

#[test]
fn a_draw_is_one_function() {
    // The same draw evaluated twice at one point gives one value: a trajectory that returns to a state
    // meets the same acceleration.
    let gp = Arc::new(noisy_sine());
    let sampler = PosteriorSampler::new(Arc::clone(&gp)).unwrap();
    let draw = sampler.draw(&mut normals(1)).unwrap();
    let other = sampler.draw(&mut normals(2)).unwrap();
    assert_eq!(draw.value(&[2.5]), draw.value(&[2.5]));
    assert_ne!(draw.value(&[2.5]), other.value(&[2.5]));
}
