//! Wall time and results of `shipid fit --refine` (the output-error refinement) on the default data,
//! for `bench/refine.md`.
//!
//! ```text
//! cargo xtask refine-bench [--shipid BIN] [--baseline BIN] [--sets reduced32,full68,full74,mmg]
//!     [--repeats N] [--dataset FILE]
//! ```
//!
//! Runs `BIN fit DATASET --set S --refine --out …` `N` times per set with each binary (`--baseline`
//! first when given, e.g. a build of an older commit; `--shipid` defaults to `target/release/shipid`)
//! and reports the median wall time of the command and the median fit time it prints (equation
//! error plus refinement). Then it compares what the binaries wrote: the refinement's cost (replay
//! error plus equation error, each ÷ its value at the LSQ start; [`refinement_cost`] of this build,
//! the same yardstick for both) on the training windows, and the validation of every recording of the
//! data set (whole replay position and heading RMSE, closed-loop MRAE) with the largest difference
//! between the binaries. The set `mmg` (the MMG family) is fitted and refined in this process through
//! the library on ZZ35/35 PS and on all recordings, whole (current build only).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use shipid_estimators::Solver;
use shipid_io::{Dataset, Recording};
use shipid_model::{AbkowitzModel, ModelFile};
use shipid_pipeline::fit::{EstimatorSpec, WindowSpec, fit_dataset, load_set};
use shipid_pipeline::mmg::{MmgFitOptions, fit_mmg_dataset, refine_mmg};
use shipid_pipeline::refine::{RefineOptions, refinement_cost};
use shipid_pipeline::validate::validate_recording;
use shipid_sim::AbkowitzDynamics;

struct Args {
    shipid: PathBuf,
    baseline: Option<PathBuf>,
    sets: Vec<String>,
    repeats: usize,
    dataset: PathBuf,
}

fn parse_args() -> Result<Args> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut a = Args {
        shipid: root.join("target/release/shipid"),
        baseline: None,
        sets: vec![
            "reduced32".into(),
            "full68".into(),
            "full74".into(),
            "mmg".into(),
        ],
        repeats: 3,
        dataset: root.join("data/kvlcc2-mmg/dataset.toml"),
    };
    let mut it = std::env::args().skip(2);
    while let Some(flag) = it.next() {
        let mut value = || it.next().with_context(|| format!("{flag} needs a value"));
        match flag.as_str() {
            "--shipid" => a.shipid = value()?.into(),
            "--baseline" => a.baseline = Some(value()?.into()),
            "--sets" => a.sets = value()?.split(',').map(String::from).collect(),
            "--repeats" => {
                a.repeats = value()?.parse().context("--repeats")?;
                if a.repeats == 0 {
                    bail!("--repeats must be at least 1");
                }
            }
            "--dataset" => a.dataset = value()?.into(),
            other => bail!(
                "unknown argument `{other}` (--shipid BIN, --baseline BIN, --sets A,B, --repeats N, --dataset FILE)"
            ),
        }
    }
    Ok(a)
}

/// One binary's runs of one set: median wall and printed fit times [s].
struct Timed {
    wall_s: f64,
    /// `None` when the command prints no "in … ms".
    fit_s: Option<f64>,
}

fn median(mut x: Vec<f64>) -> f64 {
    x.sort_by(f64::total_cmp);
    x[x.len() / 2]
}

fn time_fit(bin: &Path, dataset: &Path, set: &str, repeats: usize, out: &Path) -> Result<Timed> {
    let (mut walls, mut fits) = (Vec::new(), Vec::new());
    for _ in 0..repeats {
        let started = Instant::now();
        let run = Command::new(bin)
            .arg("fit")
            .arg(dataset)
            .args(["--set", set, "--refine", "--out"])
            .arg(out)
            .output()
            .with_context(|| format!("cannot run {}", bin.display()))?;
        walls.push(started.elapsed().as_secs_f64());
        let stdout = String::from_utf8_lossy(&run.stdout);
        if !run.status.success() {
            bail!(
                "{} fit --set {set} failed: {}",
                bin.display(),
                String::from_utf8_lossy(&run.stderr)
            );
        }
        // "fitted full74 with lsq on 27618 samples in 1330.58 ms → …"
        if let Some(ms) = stdout
            .split(" in ")
            .nth(1)
            .and_then(|s| s.split(" ms").next())
            .and_then(|s| s.trim().parse::<f64>().ok())
        {
            fits.push(ms / 1e3);
        }
    }
    Ok(Timed {
        wall_s: median(walls),
        fit_s: (fits.len() == repeats).then(|| median(fits)),
    })
}

/// A refined polynomial model file: the model and its refinement's iterations and training RMSEs.
fn refined_polynomial(out: &Path) -> Result<(AbkowitzModel, shipid_model::Refinement)> {
    let text = std::fs::read_to_string(out).with_context(|| format!("{}", out.display()))?;
    let file: ModelFile = toml::from_str(&text).with_context(|| format!("{}", out.display()))?;
    let how = file
        .estimator
        .refinement
        .clone()
        .context("the model file has no [estimator.refinement]")?;
    Ok((file.to_model()?, how))
}

/// The mmg family fitted and refined in this process on ZZ35/35 PS and on every recording (whole),
/// median times over `repeats`: table rows.
fn mmg_refinement(ds: &Dataset, repeats: usize) -> Result<Vec<String>> {
    let mut rows = Vec::new();
    for (label, recordings) in [
        ("zz35_35_ps.csv", vec!["zz35_35_ps.csv".to_string()]),
        ("all six", Vec::new()),
    ] {
        let opts = MmgFitOptions {
            recordings,
            window: WindowSpec::Whole,
            ..MmgFitOptions::default()
        };
        let added = ds.added_mass.context("the data set has no [added_mass]")?;
        let (mut fits, mut refines, mut last) = (Vec::new(), Vec::new(), None);
        for _ in 0..repeats {
            let started = Instant::now();
            let fit = fit_mmg_dataset(ds, &opts)?;
            fits.push(started.elapsed().as_secs_f64());
            let windows: Vec<Recording> = fit
                .windows
                .iter()
                .filter_map(|w| {
                    let r = &ds.recording(&w.recording)?.recording;
                    let lo = r.t.partition_point(|&t| t < w.t_start_s);
                    let hi = r.t.partition_point(|&t| t <= w.t_end_s);
                    Some(r.slice(lo..hi))
                })
                .collect();
            let started = Instant::now();
            let (_, how) = refine_mmg(&fit, added, &windows, &RefineOptions::default())?;
            refines.push(started.elapsed().as_secs_f64());
            last = Some((fit.estimate.params.len(), how));
        }
        let (parameters, how) = last.context("no repeat")?;
        rows.push(format!(
            "| {label} | {parameters} | {:.2} | {:.2} | {} | {:.2e} → {:.2e} | {:.4} → {:.4} |",
            median(fits),
            median(refines),
            how.iterations,
            how.before_position_rmse_over_l,
            how.after_position_rmse_over_l,
            how.before_heading_rmse_deg,
            how.after_heading_rmse_deg
        ));
    }
    Ok(rows)
}

/// Validation of a model on every recording: (position RMSE ÷ L, heading RMSE [deg], MRAE).
fn validation(model: &AbkowitzModel, ds: &Dataset) -> Vec<(String, f64, f64, Option<f64>)> {
    let dynamics = AbkowitzDynamics(model.clone());
    ds.recordings
        .iter()
        .map(|r| {
            let v = validate_recording(&dynamics, r, &ds.ship);
            (
                r.file.clone(),
                v.replay.position_rmse_over_l,
                v.replay.heading_rmse_deg,
                v.manoeuvre.and_then(|m| m.mrae),
            )
        })
        .collect()
}

pub fn run() -> Result<()> {
    let a = parse_args()?;
    let ds = Dataset::load(&a.dataset)?;
    let scratch = std::env::temp_dir().join(format!("shipid-refine-bench-{}", std::process::id()));
    std::fs::create_dir_all(&scratch)?;
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "data {}, {} repeat(s), load average before: {}",
        a.dataset
            .canonicalize()
            .unwrap_or(a.dataset.clone())
            .display(),
        a.repeats,
        load.split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );
    if a.sets.iter().any(|s| s != "mmg") {
        println!();
        println!(
            "| set | binary | wall [s] | fit [s] | iterations | training cost | pos/L after | ψ after [°] |"
        );
        println!("|---|---|---|---|---|---|---|---|");
    }
    let mut comparisons = Vec::new();
    let mut mmg_rows = Vec::new();
    for set in &a.sets {
        let binaries: Vec<(&str, &PathBuf)> = a
            .baseline
            .iter()
            .map(|b| ("baseline", b))
            .chain(std::iter::once(("current", &a.shipid)))
            .collect();
        if set == "mmg" {
            mmg_rows.extend(mmg_refinement(&ds, a.repeats)?);
            continue;
        }
        let polynomial = load_set(set)?;
        // The LSQ start every binary refines, and its training windows.
        let start = fit_dataset(
            &ds,
            polynomial,
            &EstimatorSpec::named("lsq"),
            &[],
            WindowSpec::Whole,
            Solver::Fast,
        )?;
        let recs: Vec<Recording> = start
            .file
            .training
            .iter()
            .filter_map(|w| {
                let r = &ds.recording(&w.recording)?.recording;
                let lo = r.t.partition_point(|&t| t < w.t_start_s);
                let hi = r.t.partition_point(|&t| t <= w.t_end_s);
                Some(r.slice(lo..hi))
            })
            .collect();
        let start_dynamics = AbkowitzDynamics(start.model.clone());
        let opts = RefineOptions::default();
        let mut runs = Vec::new();
        for (label, bin) in binaries {
            let out = scratch.join(format!("{label}_{set}.toml"));
            let timed = time_fit(bin, &a.dataset, set, a.repeats, &out)?;
            let (model, how) = refined_polynomial(&out)?;
            let cost = refinement_cost(
                &start_dynamics,
                &AbkowitzDynamics(model.clone()),
                &recs,
                &opts,
            )?;
            let fit = timed.fit_s.map_or("–".into(), |s| format!("{s:.2}"));
            println!(
                "| {set} | {label} | {:.2} | {fit} | {} | {:.9} | {:.6} | {:.4} |",
                timed.wall_s,
                how.iterations,
                cost,
                how.after_position_rmse_over_l,
                how.after_heading_rmse_deg
            );
            runs.push((label, validation(&model, &ds)));
        }
        comparisons.push((set.clone(), runs));
    }
    if !mmg_rows.is_empty() {
        println!();
        println!(
            "MMG family in this build (`fit_mmg_dataset` + `refine_mmg`, Parametric's finite-difference derivatives):"
        );
        println!();
        println!(
            "| training (whole) | parameters | equation-error fit [s] | refinement [s] | iterations | pos/L before → after | ψ before → after [°] |"
        );
        println!("|---|---|---|---|---|---|---|");
        for row in &mmg_rows {
            println!("{row}");
        }
    }
    if comparisons.is_empty() {
        std::fs::remove_dir_all(&scratch).ok();
        return Ok(());
    }
    println!();
    println!("Validation on every recording (whole replay; closed-loop MRAE):");
    println!();
    println!(
        "| set | recording | pos/L | ψ RMSE [°] | MRAE | largest difference between the binaries |"
    );
    println!("|---|---|---|---|---|---|");
    for (set, runs) in &comparisons {
        let Some((_, last)) = runs.last() else {
            continue;
        };
        for (k, (file, pos, psi, mrae)) in last.iter().enumerate() {
            let diff = runs
                .iter()
                .map(|(_, v)| {
                    let (_, p, s, m) = &v[k];
                    let dm = match (m, mrae) {
                        (Some(a), Some(b)) => 100.0 * (a - b).abs(),
                        _ => 0.0,
                    };
                    ((p - pos).abs(), (s - psi).abs(), dm)
                })
                .fold((0.0_f64, 0.0_f64, 0.0_f64), |acc, d| {
                    (acc.0.max(d.0), acc.1.max(d.1), acc.2.max(d.2))
                });
            let mrae = mrae.map_or("–".into(), |m| format!("{:.2} %", 100.0 * m));
            println!(
                "| {set} | {file} | {pos:.4} | {psi:.4} | {mrae} | pos/L {:.1e}, ψ {:.1e}°, MRAE {:.1e} %-points |",
                diff.0, diff.1, diff.2
            );
        }
    }
    std::fs::remove_dir_all(&scratch).ok();
    Ok(())
}
