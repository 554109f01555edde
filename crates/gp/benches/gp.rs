//! Training and prediction times of the sparse GP at the size of paper 001 (about 300 sparse points,
//! four inputs u, v, r, δ), one core (`Par::Seq`).
//!
//! `cargo bench -p shipid-gp --bench gp`
//!
//! The data are a smooth synthetic stand-in for the ship's accelerations (a zig-zag-like trajectory
//! through a 4-D input space with a nonlinear response), so that the bench needs no recordings. The
//! prediction bench evaluates the predictive mean 4 × 3700 times for each of three outputs: an RK4
//! replay of a 185 s run at 20 Hz (the HSVA 25/5 validation run). The same figures on the real data
//! come from `shipid fit --estimator sparse-gp` (train) and the `hsva_gp` example (replay).

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use shipid_gp::*;

fn trajectory(n: usize) -> (Points, [Vec<f64>; 3]) {
    let mut data = Vec::with_capacity(4 * n);
    let mut y: [Vec<f64>; 3] = Default::default();
    for i in 0..n {
        let t = i as f64 * 0.05;
        // Rudder amplitude changes between "runs" so the data cover a range of δ.
        let amp = 0.25 + 0.35 * ((i / 3700) as f64 / 4.0);
        let delta = amp * (0.11 * t).sin().signum() * (1.0 - (-0.5 * (t % 28.0)).exp());
        let r = 0.02 * (0.11 * t - 0.6).sin() * amp / 0.3;
        let v = -0.03 * (0.11 * t - 0.8).sin() * amp / 0.3;
        let u = 1.18 - 0.1 * amp * (0.22 * t).sin().abs();
        data.extend_from_slice(&[u, v, r, delta]);
        // Deterministic measurement-like noise, a few % of each signal.
        let noise = |k: usize| ((i * 7919 + k * 104_729) % 1000) as f64 / 1000.0 - 0.5;
        y[0].push(-0.02 * (u - 1.18) - 0.5 * v * r - 0.01 * delta * delta + 2e-5 * noise(0));
        y[1].push(-0.3 * v + 0.05 * r + 0.02 * delta - 2.0 * v * v * v + 2e-4 * noise(1));
        y[2].push(-0.01 * v - 0.08 * r - 0.004 * delta + 0.3 * v * r * r + 2e-5 * noise(2));
    }
    (Points::new(4, data).unwrap(), y)
}

/// The similarity threshold that keeps about 300 points (bisection), as paper 001's 312.
fn threshold_for_300(x: &Points) -> f64 {
    let (mut lo, mut hi) = (0.5, 0.9999);
    for _ in 0..30 {
        let mid = 0.5 * (lo + hi);
        let kept = sparsify(
            x,
            &Similarity {
                scales: half_ranges(x),
                threshold: mid,
            },
        )
        .unwrap()
        .len();
        if kept < 300 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

fn sparse_set() -> (Points, [Vec<f64>; 3]) {
    let (x, y) = trajectory(4 * 3800);
    let sim = Similarity {
        scales: half_ranges(&x),
        threshold: threshold_for_300(&x),
    };
    let keep = sparsify(&x, &sim).unwrap();
    let pick = |v: &Vec<f64>| keep.iter().map(|&i| v[i]).collect::<Vec<f64>>();
    (x.select(&keep), [pick(&y[0]), pick(&y[1]), pick(&y[2])])
}

fn bench(c: &mut Criterion) {
    faer::set_global_parallelism(faer::Par::Seq);
    let (x, y) = sparse_set();
    eprintln!("sparse set: {} points", x.len());
    let mut g = c.benchmark_group("sparse-gp");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    for (k, yi) in y.iter().enumerate() {
        let (_, t) = Gp::train(x.clone(), yi.clone(), &TrainOptions::default()).unwrap();
        eprintln!(
            "output {k}: {} iterations, {} evaluations",
            t.iterations, t.evaluations
        );
    }
    g.bench_function(format!("train 1 output, {} points", x.len()), |b| {
        b.iter(|| black_box(Gp::train(x.clone(), y[1].clone(), &TrainOptions::default()).unwrap()))
    });
    g.bench_function(format!("train 3 outputs, {} points", x.len()), |b| {
        b.iter(|| {
            for yi in &y {
                black_box(Gp::train(x.clone(), yi.clone(), &TrainOptions::default()).unwrap());
            }
        })
    });
    let gps: Vec<Gp> = y
        .iter()
        .map(|yi| {
            Gp::train(x.clone(), yi.clone(), &TrainOptions::default())
                .unwrap()
                .0
        })
        .collect();
    let (traj, _) = trajectory(3700);
    g.bench_function("predict mean, 3 outputs x 4 x 3700 states", |b| {
        b.iter(|| {
            let mut s = 0.0;
            for i in 0..traj.len() {
                for _stage in 0..4 {
                    for gp in &gps {
                        s += gp.predict_mean(traj.row(i));
                    }
                }
            }
            black_box(s)
        })
    });
    g.bench_function("sparsify 15200 samples", |b| {
        let (x, _) = trajectory(4 * 3800);
        let sim = Similarity {
            scales: half_ranges(&x),
            threshold: threshold_for_300(&x),
        };
        b.iter(|| black_box(sparsify(&x, &sim).unwrap()))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
