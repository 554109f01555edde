//! `shipid inverse TARGETS.toml` (paper 003): SVD variation modes of the 20-ship database, a simulated
//! motion-index database per target ship, the inverse network, and the inversion of each target motion
//! with a re-simulation; `shipid inverse-bench` times the database build.
//!
//! Outputs under `--out` (default `results/paper003/`): `modes.csv` and `modes.svg` (paper 003 Fig. 3),
//! per target `<target>/indexes.csv` (given vs obtained), `<target>/summary.md` (tables), `<target>/motions.svg`
//! (Fig. 6/7: red = simulated with the predicted hydrodynamics, black dashed = given indexes).

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use shipid_figures::inverse::{MotionFigure, motions_figure, write_modes};
use shipid_inverse::database::{ShipsFile, validate};
use shipid_inverse::indexes::{
    INDEX_LABELS, Manoeuvres, MotionIndexes, N_INDEXES, SimSettings, indexes_of,
    simulate_manoeuvres,
};
use shipid_inverse::mlp::TrainOptions;
use shipid_inverse::modes::VariationModes;
use shipid_inverse::pipeline::{
    InverseModel, SimulationDatabase, build_database, clip_weights, held_out, nearest, refine,
    sample_weights,
};
use shipid_inverse::target::{TargetShip, TargetsFile};
use shipid_io::write::write_atomic;

use crate::{CliError, Outcome, bad_input, failed};

/// Arguments of `shipid inverse`.
pub struct InverseArgs<'a> {
    pub targets: &'a Path,
    pub ships: &'a Path,
    pub samples: usize,
    pub seed: u64,
    pub modes: Option<usize>,
    pub out: &'a Path,
    pub max_resim: usize,
    /// Simulations per start of the refinement (0: network only, as in the paper).
    pub refine_evals: usize,
}

fn read_toml<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, CliError> {
    let text =
        std::fs::read_to_string(path).map_err(|e| bad_input(format!("{}: {e}", path.display())))?;
    toml::from_str(&text).map_err(|e| bad_input(format!("{}: {e}", path.display())))
}

pub fn load(ships: &Path, targets: &Path) -> Result<(VariationModes, Vec<TargetShip>), CliError> {
    let db: ShipsFile = read_toml(ships)?;
    validate(&db.ship).map_err(|e| bad_input(format!("{}: {e}", ships.display())))?;
    let modes = VariationModes::new(&db.ship)
        .map_err(|e| bad_input(format!("{}: {e}", ships.display())))?;
    let t: TargetsFile = read_toml(targets)?;
    for target in &t.target {
        target
            .validate()
            .map_err(|e| bad_input(format!("{}: {e}", targets.display())))?;
        for m in &target.motion {
            m.indexes().map_err(|e| {
                bad_input(format!(
                    "{}: target {}: {e}",
                    targets.display(),
                    target.name
                ))
            })?;
        }
    }
    if t.target.is_empty() {
        return Err(bad_input(format!("{}: no [[target]]", targets.display())));
    }
    Ok((modes, t.target))
}

pub fn progress(n: usize, what: &str) -> ProgressBar {
    let bar = ProgressBar::new(n as u64);
    bar.set_style(
        ProgressStyle::with_template(&format!(
            "{{bar:40}} {{pos}}/{{len}} {what}  elapsed {{elapsed}} eta {{eta}}"
        ))
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}

pub fn build(
    target: &TargetShip,
    modes: &VariationModes,
    n_modes: usize,
    samples: usize,
    seed: u64,
    settings: &SimSettings,
) -> Result<(SimulationDatabase, f64), CliError> {
    let weights = sample_weights(modes, n_modes, samples, seed);
    let bar = progress(samples, "ships simulated (4 manoeuvres each)");
    let start = Instant::now();
    let db = build_database(target, modes, &weights, settings, &|| bar.inc(1))
        .map_err(|e| bad_input(e.to_string()))?;
    let secs = start.elapsed().as_secs_f64();
    bar.finish_and_clear();
    Ok((db, secs))
}

fn dropped_summary(db: &SimulationDatabase) -> String {
    let mut kinds: std::collections::BTreeMap<String, usize> = Default::default();
    for (_, f) in &db.dropped {
        *kinds.entry(f.kind()).or_default() += 1;
    }
    kinds
        .iter()
        .map(|(k, n)| format!("{n} × {k}"))
        .collect::<Vec<_>>()
        .join("; ")
}

/// `shipid inverse`.
pub fn run(a: &InverseArgs) -> Result<Outcome, CliError> {
    faer::set_global_parallelism(faer::Par::Seq);
    let (modes, targets) = load(a.ships, a.targets)?;
    let n95 = modes.modes_for(0.95);
    let n_modes = a.modes.unwrap_or(n95);
    if n_modes == 0 || n_modes > modes.singular_values.len() {
        return Err(bad_input(format!(
            "--modes {n_modes}: the database has {} modes",
            modes.singular_values.len()
        )));
    }
    std::fs::create_dir_all(a.out).map_err(failed)?;
    write_modes(a.out, &modes).map_err(failed)?;
    println!(
        "SVD of {} ships: mode 1 carries {:.1} %, {} modes reach 95 % ({:.1} %); using {} modes",
        modes.ship_ids.len(),
        100.0 * modes.contribution[0],
        n95,
        100.0 * modes.cumulative()[n95 - 1],
        n_modes
    );
    let settings = SimSettings::default();
    let mut outcome = Outcome::Ok;
    for target in &targets {
        let (db, secs) = build(target, &modes, n_modes, a.samples, a.seed, &settings)?;
        println!(
            "\n## {}\nsimulation database: {} ships requested, {} usable, {} dropped ({}) in {:.1} s",
            target.name,
            db.requested,
            db.samples.len(),
            db.dropped.len(),
            dropped_summary(&db),
            secs
        );
        let opts = TrainOptions {
            seed: a.seed,
            ..TrainOptions::default()
        };
        let model = InverseModel::train(&db, &opts).map_err(|e| failed(anyhow::anyhow!(e)))?;
        let held = held_out(target, &modes, &db, &model, &settings, a.max_resim);
        let mut md = String::new();
        let _ = writeln!(
            md,
            "Target {} ({}); {} modes; database {} requested, {} usable, {} dropped; built in {:.1} s.\n",
            target.name,
            target.source,
            n_modes,
            db.requested,
            db.samples.len(),
            db.dropped.len(),
            secs
        );
        let _ = writeln!(
            md,
            "Network 9-30-30-{n_modes}: {} epochs (best {}), MSE (standardised) train {:.3}, validation {:.3}; split {}/{}/{}.\n",
            model.report.epochs,
            model.report.best_epoch,
            model.report.train_mse,
            model.report.val_mse,
            model.split.train.len(),
            model.split.validation.len(),
            model.split.test.len()
        );
        let _ = writeln!(
            md,
            "Held-out test ({} samples): weight RMSE / σ per mode {} (predicting the mean: {}); \
             {} re-simulated ({} failed), mean |relative error| per index: {}.\n",
            held.n,
            fmt_list(&held.weight_rmse_sigma, 2),
            fmt_list(&held.baseline_rmse_sigma, 2),
            held.resimulated,
            held.resim_failed,
            INDEX_LABELS
                .iter()
                .zip(held.index_mare)
                .map(|(l, e)| format!("{l} {:.1} %", 100.0 * e))
                .collect::<Vec<_>>()
                .join(", ")
        );
        let mut csv = String::from("motion,index,given,obtained,relative_error\n");
        let mut figures: Vec<MotionFigure> = Vec::new();
        let _ = writeln!(
            md,
            "| motion | | {} | mean |rel. err.| |",
            INDEX_LABELS.join(" | ")
        );
        let _ = writeln!(md, "|---|---|{}---|", "---|".repeat(N_INDEXES));
        for m in &target.motion {
            let given = m.indexes().map_err(|e| bad_input(e.to_string()))?;
            let raw = model.predict(&given);
            let (x, clipped) = clip_weights(&modes, &raw);
            let (near, dist) = nearest(&db, &model, &given);
            let resim = |x: &[f64]| -> std::result::Result<(Manoeuvres, MotionIndexes), String> {
                let c = modes.generate(x).map_err(|e| e.to_string())?;
                let mdl = target
                    .model(&c)
                    .ok_or("no MMG model (no self-propulsion point)")?;
                let man = simulate_manoeuvres(&mdl, &settings).map_err(|e| e.to_string())?;
                let q = indexes_of(&man, &target.ship()).map_err(|e| e.to_string())?;
                Ok((man, q))
            };
            let row =
                |v: &[f64; N_INDEXES]| v.iter().map(|x| format!("{x:.3}")).collect::<Vec<_>>();
            let err_row = |q: &MotionIndexes| {
                let rel: [f64; N_INDEXES] =
                    std::array::from_fn(|i| (q.0[i] - given.0[i]) / given.0[i]);
                let mean = rel.iter().map(|r| r.abs()).sum::<f64>() / N_INDEXES as f64;
                (rel, mean)
            };
            let _ = writeln!(
                md,
                "| {} | given | {} | |",
                m.name,
                row(&given.0).join(" | ")
            );
            match resim(&x) {
                Ok((man, q)) => {
                    let (rel, mean) = err_row(&q);
                    let _ = writeln!(md, "| | obtained | {} | |", row(&q.0).join(" | "));
                    let _ = writeln!(
                        md,
                        "| | error | {} | {:.1} % |",
                        rel.iter()
                            .map(|r| format!("{:+.1} %", 100.0 * r))
                            .collect::<Vec<_>>()
                            .join(" | "),
                        100.0 * mean
                    );
                    for (i, label) in INDEX_LABELS.iter().enumerate() {
                        let _ = writeln!(
                            csv,
                            "{},{},{},{},{}",
                            m.name, label, given.0[i], q.0[i], rel[i]
                        );
                    }
                    figures.push(MotionFigure {
                        name: m.name.clone(),
                        given,
                        network: Some(man),
                        refined: None,
                    });
                }
                Err(why) => {
                    outcome = Outcome::SomeFailed;
                    let _ = writeln!(md, "| | obtained | failed: {why} | |");
                    for (i, label) in INDEX_LABELS.iter().enumerate() {
                        let _ = writeln!(csv, "{},{},{},,", m.name, label, given.0[i]);
                    }
                    figures.push(MotionFigure {
                        name: m.name.clone(),
                        given,
                        network: None,
                        refined: None,
                    });
                }
            }
            let sigma = |x: &[f64]| {
                fmt_list(
                    &x.iter()
                        .zip(&modes.weight_std)
                        .map(|(x, s)| x / s)
                        .collect::<Vec<_>>(),
                    2,
                )
            };
            let _ = writeln!(
                md,
                "| | weights x/σ | {}{} | |",
                sigma(&x),
                if clipped {
                    format!(" (network output {} clipped to ±3σ)", sigma(&raw))
                } else {
                    String::new()
                }
            );
            let nq = &db.samples[near].indexes;
            let (_, nmean) = err_row(nq);
            let _ = writeln!(
                md,
                "| | nearest database ship (distance {dist:.2} std) | {} | {:.1} % |",
                row(&nq.0).join(" | "),
                100.0 * nmean
            );
            if a.refine_evals > 0 {
                let starts = [x.clone(), db.samples[near].weights.clone()];
                let refined = refine(
                    target,
                    &modes,
                    &model,
                    &given,
                    &starts,
                    &settings,
                    a.refine_evals,
                );
                match refined.and_then(|r| resim(&r.weights).ok().map(|(man, _)| (r, man))) {
                    Some((r, man)) => {
                        let (rel, mean) = err_row(&r.indexes);
                        let _ = writeln!(
                            md,
                            "| | refined ({} simulations) | {} | |",
                            r.evaluations,
                            row(&r.indexes.0).join(" | ")
                        );
                        let _ = writeln!(
                            md,
                            "| | refined error | {} | {:.1} % |",
                            rel.iter()
                                .map(|r| format!("{:+.1} %", 100.0 * r))
                                .collect::<Vec<_>>()
                                .join(" | "),
                            100.0 * mean
                        );
                        let _ = writeln!(md, "| | refined weights x/σ | {} | |", sigma(&r.weights));
                        for (i, label) in INDEX_LABELS.iter().enumerate() {
                            let _ = writeln!(
                                csv,
                                "{} refined,{},{},{},{}",
                                m.name, label, given.0[i], r.indexes.0[i], rel[i]
                            );
                        }
                        if let Some(f) = figures.last_mut() {
                            f.refined = Some(man);
                        }
                    }
                    None => {
                        outcome = Outcome::SomeFailed;
                        let _ = writeln!(md, "| | refined | failed: no start simulates | |");
                    }
                }
            }
        }
        print!("{md}");
        let dir = a.out.join(slug(&target.name));
        std::fs::create_dir_all(&dir).map_err(failed)?;
        write_atomic(&dir.join("indexes.csv"), csv.as_bytes()).map_err(failed)?;
        write_atomic(&dir.join("summary.md"), md.as_bytes()).map_err(failed)?;
        let fig = dir.join("motions.svg");
        if let Err(e) = motions_figure(&fig, target, &figures) {
            eprintln!("warning: figure {} not drawn: {e:#}", fig.display());
        }
        println!("wrote {}", dir.display());
    }
    Ok(outcome)
}

fn fmt_list(v: &[f64], digits: usize) -> String {
    v.iter()
        .map(|x| format!("{x:.digits$}"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn slug(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect()
}
