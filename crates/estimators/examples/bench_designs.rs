//! Times `Solver::Fast` (and optionally `Solver::Qp`) of one estimator on the designs
//! exported by `fit_bench --export DIR` (bench/designs), without the polars-heavy shipid
//! crate: a quick loop for solver work. Prints one line per design: the fastest of the
//! repeats (ms; the least disturbed one on a shared machine) and their median, iterations, objective,
//! condition number and status, and with `--qp` the relative objective difference to the
//! QP. CASE is svr (default), ridge, lasso or lsq, unbounded. The figures of record come
//! from `bench/run.sh`.
//!
//! ```text
//! cargo run --release -p shipid-estimators --example bench_designs -- DIR [CASE] [--qp] [--repeats N] [--only ID_PART]
//! ```

use std::path::Path;
use std::time::Instant;

use serde_json::Value;
use shipid_estimators::faer::Mat;
use shipid_estimators::{Estimator, Solver, fit};

fn read_csv(path: &Path) -> Result<Vec<Vec<f64>>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    text.lines()
        .skip(1)
        .enumerate()
        .map(|(k, line)| {
            line.split(',')
                .map(|v| {
                    v.parse::<f64>()
                        .map_err(|e| format!("{}:{}: {e}", path.display(), k + 2))
                })
                .collect()
        })
        .collect()
}

fn main() {
    if let Err(e) = run() {
        eprintln!("bench_designs: {e}");
        std::process::exit(2);
    }
}

fn run() -> Result<(), String> {
    // One core, as in `fit_bench` and the Python side; faer's default thread pool spins
    // waiting threads that would inflate the sub-millisecond fits measured here.
    shipid_estimators::faer::set_global_parallelism(shipid_estimators::faer::Par::Seq);
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dir = Path::new(
        args.first()
            .ok_or("usage: bench_designs DIR [CASE] [--qp]")?,
    );
    let case = args
        .get(1)
        .filter(|a| !a.starts_with("--"))
        .map_or("svr", |s| s.as_str());
    let with_qp = args.iter().any(|a| a == "--qp");
    let repeats: usize = args
        .iter()
        .position(|a| a == "--repeats")
        .and_then(|k| args.get(k + 1))
        .map_or(Ok(5), |v| v.parse().map_err(|e| format!("--repeats: {e}")))?;
    let only = args
        .iter()
        .position(|a| a == "--only")
        .and_then(|k| args.get(k + 1))
        .cloned();
    let manifest: Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join("manifest.json")).map_err(|e| e.to_string())?,
    )
    .map_err(|e| e.to_string())?;
    let problems = manifest["problems"]
        .as_array()
        .ok_or("manifest: no problems")?;
    let mut total = 0.0;
    for p in problems {
        let s = |k: &str| p[k].as_str().unwrap_or_default().to_string();
        if only.as_ref().is_some_and(|o| !s("id").contains(o.as_str())) {
            continue;
        }
        let phi_rows = read_csv(&dir.join(s("phi")))?;
        let y: Vec<f64> = read_csv(&dir.join(s("y")))?
            .into_iter()
            .map(|r| r[0])
            .collect();
        let (n, q) = (phi_rows.len(), phi_rows[0].len());
        let phi = Mat::<f64>::from_fn(n, q, |i, j| phi_rows[i][j]);
        let f = |k: &str| p[k].as_f64().unwrap_or(f64::NAN);
        let est = match case {
            "svr" => Estimator::Svr {
                c: f("c"),
                epsilon: f("epsilon"),
            },
            "ridge" => Estimator::Ridge {
                lambda: f("lambda"),
            },
            "lasso" => Estimator::Lasso { alpha: f("alpha") },
            _ => Estimator::Lsq,
        };
        let run = || fit(phi.as_ref(), &y, &est, None, Solver::Fast);
        let first = run().map_err(|e| e.to_string())?;
        let mut times: Vec<f64> = (0..repeats)
            .map(|_| {
                let t = Instant::now();
                let out = run();
                let dt = t.elapsed().as_secs_f64();
                std::hint::black_box(out.ok());
                dt
            })
            .collect();
        times.sort_by(f64::total_cmp);
        let best = times.first().copied().unwrap_or(f64::NAN);
        let median = times.get(times.len() / 2).copied().unwrap_or(f64::NAN);
        total += best;
        let mut line = format!(
            "{:28} n={n:5} p={q:2} fast {:8.3} ms (median {:8.3}) it={:4} J={:.12e} κ={:.1e} {:?}",
            s("id"),
            best * 1e3,
            median * 1e3,
            first.iterations,
            first.objective,
            first.condition_number.unwrap_or(f64::NAN),
            first.status
        );
        if with_qp {
            let qp = fit(phi.as_ref(), &y, &est, None, Solver::Qp).map_err(|e| e.to_string())?;
            line += &format!(
                " dJ(fast-qp)/|J_qp|={:+.1e}",
                (first.objective - qp.objective) / qp.objective.abs()
            );
        }
        println!("{line}");
    }
    println!("total {:.3} ms", total * 1e3);
    Ok(())
}
