//! Fit times of every estimator × solver on an Abkowitz-like design (22 columns of the
//! full Y/N set from smooth zig-zag-like signals), one core (`Par::Seq`).
//!
//! `cargo bench -p shipid-estimators --bench fit`

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use shipid_estimators::*;

#[path = "../tests/it/common.rs"]
mod common;

fn setup(n: usize) -> (faer::Mat<f64>, Vec<f64>, Bounds, f64, f64) {
    let phi = common::full_design(n);
    let beta = common::sway_like_coefficients(22);
    let y = common::target(&phi, &beta, 0.02, 1);
    // Sign constraints on a third of the coefficients, several of them active.
    let mut lower = vec![f64::NEG_INFINITY; 22];
    let mut upper = vec![f64::INFINITY; 22];
    for j in (0..22).step_by(3) {
        if beta[j] < 0.0 {
            lower[j] = 0.5 * beta[j];
        } else {
            upper[j] = 0.5 * beta[j];
        }
    }
    let bounds = Bounds::new(lower, upper).unwrap();
    let alpha_max = *default_grid(&Family::Lasso, phi.as_ref(), &y)
        .unwrap()
        .last()
        .unwrap();
    let rms = (y.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
    (phi, y, bounds, alpha_max, rms)
}

fn bench_n4000(c: &mut Criterion) {
    faer::set_global_parallelism(faer::Par::Seq);
    let n = 4000;
    let (phi, y, bounds, alpha_max, rms) = setup(n);
    let svr = Estimator::Svr {
        c: 100.0 * rms / n as f64,
        epsilon: 0.01 * rms,
    };
    let cases: Vec<(&str, Estimator, Option<&Bounds>)> = vec![
        ("lsq", Estimator::Lsq, None),
        ("bounded_lsq", Estimator::BoundedLsq, Some(&bounds)),
        ("ridge", Estimator::Ridge { lambda: 1e-4 }, None),
        (
            "ridge_bounded",
            Estimator::Ridge { lambda: 1e-4 },
            Some(&bounds),
        ),
        (
            "lasso",
            Estimator::Lasso {
                alpha: 1e-3 * alpha_max,
            },
            None,
        ),
        (
            "lasso_bounded",
            Estimator::Lasso {
                alpha: 1e-3 * alpha_max,
            },
            Some(&bounds),
        ),
        ("svr", svr, None),
        ("svr_bounded", svr, Some(&bounds)),
    ];
    let mut g = c.benchmark_group("n4000_p22");
    g.sample_size(20).measurement_time(Duration::from_secs(3));
    for (name, est, b) in &cases {
        for solver in [Solver::Fast, Solver::Qp] {
            let id = format!(
                "{name}/{}",
                if solver == Solver::Fast { "fast" } else { "qp" }
            );
            g.bench_function(id, |bch| {
                bch.iter(|| black_box(fit(phi.as_ref(), &y, est, *b, solver).unwrap()))
            });
        }
    }
    g.bench_function("vif", |bch| {
        bch.iter(|| black_box(vif(phi.as_ref()).unwrap()))
    });
    g.bench_function("condition_number", |bch| {
        bch.iter(|| black_box(condition_number(phi.as_ref()).unwrap()))
    });
    let grid = default_grid(&Family::Ridge, phi.as_ref(), &y).unwrap();
    g.bench_function("tune_ridge_21x5folds/fast", |bch| {
        bch.iter(|| {
            black_box(
                tune(
                    phi.as_ref(),
                    &y,
                    &Family::Ridge,
                    &grid,
                    &Folds::Blocked { k: 5 },
                    None,
                    Solver::Fast,
                )
                .unwrap(),
            )
        })
    });
    g.finish();
}

fn bench_svr_n20000(c: &mut Criterion) {
    faer::set_global_parallelism(faer::Par::Seq);
    let n = 20000;
    let (phi, y, bounds, _, rms) = setup(n);
    let svr = Estimator::Svr {
        c: 100.0 * rms / n as f64,
        epsilon: 0.01 * rms,
    };
    let mut g = c.benchmark_group("n20000_p22");
    g.sample_size(10).measurement_time(Duration::from_secs(5));
    for (name, b) in [("svr", None), ("svr_bounded", Some(&bounds))] {
        for solver in [Solver::Fast, Solver::Qp] {
            let id = format!(
                "{name}/{}",
                if solver == Solver::Fast { "fast" } else { "qp" }
            );
            g.bench_function(id, |bch| {
                bch.iter(|| black_box(fit(phi.as_ref(), &y, &svr, b, solver).unwrap()))
            });
        }
    }
    for (name, est) in [
        ("lsq", Estimator::Lsq),
        ("ridge", Estimator::Ridge { lambda: 1e-4 }),
    ] {
        g.bench_function(format!("{name}/fast"), |bch| {
            bch.iter(|| black_box(fit(phi.as_ref(), &y, &est, None, Solver::Fast).unwrap()))
        });
    }
    g.finish();
}

criterion_group!(benches, bench_n4000, bench_svr_n20000);
criterion_main!(benches);
