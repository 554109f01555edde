//! Shared test data: Abkowitz-like designs from smooth, sinusoid-driven manoeuvre signals.
#![allow(dead_code)]

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use shipid_estimators::faer::Mat;

/// Smooth zig-zag-like signals (Δu, v, r, δ) at `n` samples over four periods.
pub fn signals(n: usize, phase: f64) -> Vec<[f64; 4]> {
    let w = 2.0 * std::f64::consts::PI * 4.0 / n as f64;
    (0..n)
        .map(|i| {
            let t = i as f64 * w + phase;
            let delta = 0.6 * t.sin() + 0.08 * (3.0 * t).sin();
            let v = 0.12 * (t - 0.6).sin() + 0.015 * (2.3 * t).sin();
            let r = 0.35 * (t - 1.1).sin() + 0.03 * (1.7 * t).cos();
            let du = -0.08 * (1.0 - (2.0 * t).cos()) - 0.01 * (0.5 * t).sin();
            [du, v, r, delta]
        })
        .collect()
}

/// The 9-column set v, r, δ, v³, v²r, vr², r³, Δu·v, Δu·r.
pub fn reduced_design(n: usize) -> Mat<f64> {
    let s = signals(n, 0.3);
    Mat::from_fn(n, 9, |i, j| {
        let [du, v, r, d] = s[i];
        match j {
            0 => v,
            1 => r,
            2 => d,
            3 => v * v * v,
            4 => v * v * r,
            5 => v * r * r,
            6 => r * r * r,
            7 => du * v,
            _ => du * r,
        }
    })
}

/// The 22 velocity/rudder columns of the full Y/N set (1, Δu, Δu², v, r, δ, cubic and
/// cross terms, Δu couplings).
pub fn full_design(n: usize) -> Mat<f64> {
    full_design_with_phase(n, 0.3)
}

pub fn full_design_with_phase(n: usize, phase: f64) -> Mat<f64> {
    let s = signals(n, phase);
    Mat::from_fn(n, 22, |i, j| {
        let [du, v, r, d] = s[i];
        match j {
            0 => 1.0,
            1 => du,
            2 => du * du,
            3 => v,
            4 => r,
            5 => d,
            6 => v * v * v,
            7 => r * r * r,
            8 => d * d * d,
            9 => v * v * r,
            10 => v * r * r,
            11 => v * v * d,
            12 => v * d * d,
            13 => r * r * d,
            14 => r * d * d,
            15 => v * r * d,
            16 => du * v,
            17 => du * r,
            18 => du * d,
            19 => du * du * v,
            20 => du * du * r,
            _ => du * du * d,
        }
    })
}

/// Coefficients of the size found for KVLCC2 sway (prime system), repeated as needed.
pub fn sway_like_coefficients(p: usize) -> Vec<f64> {
    let base = [
        -0.31, 0.083, -0.06, -1.6, 0.38, -0.39, 0.008, 0.05, -0.02, 0.1, -0.04, 0.02, 0.003,
        -0.001, 0.07, -0.03, 0.2, -0.05, 0.01, 0.04, -0.02, 0.005,
    ];
    (0..p).map(|j| base[j % base.len()]).collect()
}

/// y = Φβ + Gaussian noise with standard deviation `noise` × rms(Φβ).
pub fn target(phi: &Mat<f64>, beta: &[f64], noise: f64, seed: u64) -> Vec<f64> {
    let n = phi.nrows();
    let clean: Vec<f64> = (0..n)
        .map(|i| (0..phi.ncols()).map(|j| phi[(i, j)] * beta[j]).sum())
        .collect();
    let rms = (clean.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
    let mut rng = StdRng::seed_from_u64(seed);
    let normal = Normal::new(0.0, 1.0).unwrap();
    clean
        .into_iter()
        .map(|v| v + noise * rms * normal.sample(&mut rng))
        .collect()
}

/// A random Gaussian design with columns of different magnitudes.
pub fn random_design(n: usize, p: usize, seed: u64) -> Mat<f64> {
    let mut rng = StdRng::seed_from_u64(seed);
    let normal = Normal::new(0.0, 1.0).unwrap();
    let mags: Vec<f64> = (0..p)
        .map(|_| 10f64.powf(rng.random_range(-2.0..2.0)))
        .collect();
    Mat::from_fn(n, p, |_, j| mags[j] * normal.sample(&mut rng))
}

/// `√(Σ vᵢ²/n)`, the scale that tolerances, tubes and hyper-parameters are set against.
pub fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

pub fn rel_diff(a: f64, b: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs()).max(f64::MIN_POSITIVE)
}
