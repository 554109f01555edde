//! Paper 001 Tab. 2: sparse-set size against prediction error, training time and prediction time on the
//! 2-D test function y = x₁ sin x₂ + x₂ sin x₁ (paper 001 eq. 14) sampled on the 0.2-spaced grid of
//! [−6, 6]² (3721 points; the paper gives the spacing and count, not the domain: [−6, 6] is assumed).
//!
//! `cargo run --release -p shipid-gp --example tab2 [-- OUT.md]`
//!
//! For each target size the similarity threshold d_gen is found by bisection (scales l = the half range,
//! 6, in both dimensions), the GP is trained on the kept points (hyper-parameters by maximum marginal
//! likelihood, L-BFGS) and predicts all 3721 grid points. Prediction error = mean squared error over the
//! grid (our reading of the paper's "prediction error"). Above 1500 points one marginal-likelihood
//! evaluation costs seconds (O(n³)), so those rows reuse the hyper-parameters of the next smaller set and
//! only condition on the points (one Cholesky factorisation); their training time is that conditioning.
//! Times are wall-clock on one thread (faer `Par::Seq`).

use std::time::Instant;

use shipid_gp::{Gp, Points, Similarity, TrainOptions, half_ranges, sparsify};

fn f(x1: f64, x2: f64) -> f64 {
    x1 * x2.sin() + x2 * x1.sin()
}

fn main() {
    faer::set_global_parallelism(faer::Par::Seq);
    let mut data = Vec::new();
    for i in 0..=60 {
        for j in 0..=60 {
            data.extend_from_slice(&[-6.0 + 0.2 * i as f64, -6.0 + 0.2 * j as f64]);
        }
    }
    let grid = Points::new(2, data).expect("finite grid");
    let y: Vec<f64> = (0..grid.len())
        .map(|i| f(grid.row(i)[0], grid.row(i)[1]))
        .collect();
    let scales = half_ranges(&grid);
    let kept_at = |threshold: f64| {
        sparsify(
            &grid,
            &Similarity {
                scales: scales.clone(),
                threshold,
            },
        )
        .expect("valid similarity")
    };
    // Paper 001 Tab. 2: sizes and its figures (error, training s, prediction s).
    let paper = [
        (3721, "2.13×10⁻⁵", "54.01", "0.0057"),
        (1122, "9.33×10⁻⁵", "26.63", "0.0032"),
        (723, "1.08×10⁻⁴", "7.14", "0.0022"),
        (350, "1.96×10⁻⁴", "0.68", "0.0016"),
        (142, "5.12×10⁻³", "0.29", "0.0013"),
    ];
    let mut rows = Vec::new();
    let mut hyper_of_smaller = None;
    for &(target, p_err, p_train, p_pred) in paper.iter().rev() {
        let (threshold, keep) = if target >= grid.len() {
            (1.0, kept_at(1.0))
        } else {
            let (mut lo, mut hi) = (0.0f64, 1.0f64);
            for _ in 0..50 {
                let mid = 0.5 * (lo + hi);
                if kept_at(mid).len() < target {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            (hi, kept_at(hi))
        };
        let x = grid.select(&keep);
        let ys: Vec<f64> = keep.iter().map(|&i| y[i]).collect();
        let started = Instant::now();
        let (gp, how) = if keep.len() > 1500 {
            let h = hyper_of_smaller
                .clone()
                .expect("a smaller set was trained first");
            (
                Gp::new(x, ys, h).expect("conditioning"),
                "conditioned (hyper-parameters of the next smaller set)",
            )
        } else {
            let (gp, t) = Gp::train(x, ys, &TrainOptions::default()).expect("training");
            eprintln!(
                "{} points: {} iterations, {:?}",
                keep.len(),
                t.iterations,
                t.termination
            );
            (gp, "trained")
        };
        let train_s = started.elapsed().as_secs_f64();
        hyper_of_smaller = Some(gp.hyper().clone());
        let started = Instant::now();
        let pred: Vec<f64> = (0..grid.len())
            .map(|i| gp.predict_mean(grid.row(i)))
            .collect();
        let predict_s = started.elapsed().as_secs_f64();
        let mse = pred
            .iter()
            .zip(&y)
            .map(|(p, t)| (p - t).powi(2))
            .sum::<f64>()
            / y.len() as f64;
        eprintln!(
            "{} points (d_gen {threshold:.6}): MSE {mse:.3e}, train {train_s:.3} s, predict {predict_s:.4} s, {how}",
            keep.len()
        );
        rows.push(format!(
            "| {} | {threshold:.6} | {mse:.2e} | {train_s:.3} | {predict_s:.4} | {how} | {target} | {p_err} | {p_train} | {p_pred} |",
            keep.len()
        ));
    }
    rows.reverse();
    let mut out = String::from(
        "| sparse set | d_gen | MSE over the grid | training [s] | prediction of 3721 points [s] | hyper-parameters | paper: set | paper: error | paper: training [s] | paper: prediction [s] |\n|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        out.push_str(&r);
        out.push('\n');
    }
    print!("{out}");
    if let Some(path) = std::env::args().nth(1) {
        std::fs::write(&path, &out).expect("write the table");
    }
}
