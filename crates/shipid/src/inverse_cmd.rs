//! `shipid inverse TARGETS.toml` (paper 003): SVD variation modes of the 20-ship database, a simulated
//! motion-index database per target ship, the inverse network, and the inversion of each target motion
//! with a re-simulation; `shipid inverse-bench` times the database build.
//!
//! The 20-ship database is built into the binary (`--ships FILE` overrides it), so the command runs
//! from any directory.
//!
//! Outputs under `--out` (default `results/paper003/`): `modes.csv` and `modes.svg` (paper 003 Fig. 3),
//! per target `<target>/indexes.csv` (given vs obtained), `<target>/summary.md` (tables), `<target>/motions.svg`
//! (Fig. 6/7: red = simulated with the predicted hydrodynamics, black dashed = given indexes).

use std::path::Path;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use shipid_figures::inverse::{MotionFigure, motions_figure, write_modes};
use shipid_inverse::database::{PAPER003_SHIPS_TOML, ShipsFile};
use shipid_inverse::indexes::SimSettings;
use shipid_inverse::inversion::{
    InputFault, MotionInversion, RefineOutcome, check_inputs, header_markdown, indexes_csv,
    invert_motion, motions_markdown,
};
use shipid_inverse::mlp::TrainOptions;
use shipid_inverse::modes::VariationModes;
use shipid_inverse::pipeline::{
    InverseModel, MIN_SAMPLES, SimulationDatabase, build_database, held_out, sample_weights,
};
use shipid_inverse::target::{TargetShip, TargetsFile};
use shipid_io::write::write_atomic;

use crate::{CliError, Outcome, bad_input, failed};

/// Arguments of `shipid inverse`.
pub struct InverseArgs<'a> {
    pub targets: &'a Path,
    /// The hydrodynamic database; `None`: the one built in (paper 003 Tab. 1).
    pub ships: Option<&'a Path>,
    pub samples: usize,
    pub seed: u64,
    pub modes: Option<usize>,
    pub out: &'a Path,
    pub max_resim: usize,
    /// Simulations per start of the refinement (0: network only, as in the paper).
    pub refine_evals: usize,
    /// Run more than [`MAX_SAMPLES`] samples per target.
    pub allow_large: bool,
}

fn read_toml<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, CliError> {
    let text =
        std::fs::read_to_string(path).map_err(|e| bad_input(format!("{}: {e}", path.display())))?;
    parse_toml(&text, &path.display().to_string())
}

fn parse_toml<T: serde::de::DeserializeOwned>(text: &str, name: &str) -> Result<T, CliError> {
    toml::from_str(text).map_err(|e| bad_input(format!("{name}: {e}")))
}

/// How the built-in database is named in messages.
const BUILT_IN_SHIPS: &str = "the built-in ships database (data/paper003/ships.toml)";

/// The variation modes of the database (`ships`, or the built-in one) and the checked targets.
pub fn load(
    ships: Option<&Path>,
    targets: &Path,
) -> Result<(VariationModes, Vec<TargetShip>), CliError> {
    let (db, ships_name): (ShipsFile, String) = match ships {
        Some(p) => (read_toml(p)?, p.display().to_string()),
        None => (
            parse_toml(PAPER003_SHIPS_TOML, BUILT_IN_SHIPS)?,
            BUILT_IN_SHIPS.into(),
        ),
    };
    let t: TargetsFile = read_toml(targets)?;
    let (modes, targets_checked) = check_inputs(&db, t).map_err(|fault| match fault {
        InputFault::Ships(e) => bad_input(format!("{ships_name}: {e}")),
        InputFault::Targets(e) => bad_input(format!("{}: {e}", targets.display())),
    })?;
    // Each target writes into a folder named after it: two names of one folder would overwrite
    // each other's tables, and an empty one would write into --out itself.
    for (i, t) in targets_checked.iter().enumerate() {
        let s = slug(&t.name);
        if s.is_empty() {
            return Err(bad_input(format!(
                "{}: a [[target]] has an empty name (its tables go into a folder named after it)",
                targets.display()
            )));
        }
        if let Some(o) = targets_checked[..i].iter().find(|o| slug(&o.name) == s) {
            return Err(bad_input(format!(
                "{}: targets `{}` and `{}` would both write into the folder `{s}`",
                targets.display(),
                o.name,
                t.name
            )));
        }
    }
    Ok((modes, targets_checked))
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

/// Largest `--samples` run without `--allow-large`.
pub const MAX_SAMPLES: usize = 100_000;

/// `shipid inverse`.
pub fn run(a: &InverseArgs) -> Result<Outcome, CliError> {
    faer::set_global_parallelism(faer::Par::Seq);
    if a.samples < MIN_SAMPLES {
        return Err(bad_input(format!(
            "--samples {}: the network needs at least {MIN_SAMPLES} simulated ships per target",
            a.samples
        )));
    }
    // Each sample is four simulated manoeuvres (about 2 ms each here) and a row the network trains
    // on: 2603 (paper 003) takes seconds, a hundred thousand already minutes per target.
    if a.samples > MAX_SAMPLES && !a.allow_large {
        return Err(bad_input(format!(
            "--samples {}: more than {MAX_SAMPLES} simulated ships per target (4 manoeuvres each, simulated and kept in memory); pass --allow-large to run it anyway",
            a.samples
        )));
    }
    let (modes, targets) = load(a.ships, a.targets)?;
    let n95 = modes.modes_for(0.95);
    let n_modes = a.modes.unwrap_or(n95);
    if n_modes == 0 || n_modes > modes.singular_values.len() {
        return Err(bad_input(format!(
            "--modes {n_modes}: the database has {} modes",
            modes.singular_values.len()
        )));
    }
    std::fs::create_dir_all(a.out).map_err(|e| crate::write_failed(a.out, e))?;
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
        let motions: Vec<MotionInversion> = target
            .motion
            .iter()
            .map(|m| {
                let given = m.indexes().map_err(|e| bad_input(e.to_string()))?;
                Ok(invert_motion(
                    target,
                    &modes,
                    &db,
                    &model,
                    &settings,
                    &m.name,
                    given,
                    a.refine_evals,
                ))
            })
            .collect::<Result<_, CliError>>()?;
        if motions.iter().any(MotionInversion::failed) {
            outcome = Outcome::SomeFailed;
        }
        let md = header_markdown(target, n_modes, &db, secs, &model, &held)
            + &motions_markdown(&motions, &modes, &db);
        let csv = indexes_csv(&motions);
        let figures: Vec<MotionFigure> = motions
            .iter()
            .map(|m| MotionFigure {
                name: m.name.clone(),
                given: m.given,
                network: m.network.as_ref().ok().map(|s| s.manoeuvres.clone()),
                refined: match &m.refined {
                    RefineOutcome::Done { manoeuvres, .. } => Some((**manoeuvres).clone()),
                    _ => None,
                },
            })
            .collect();
        print!("{md}");
        let dir = a.out.join(slug(&target.name));
        std::fs::create_dir_all(&dir).map_err(|e| crate::write_failed(&dir, e))?;
        for (name, text) in [
            ("indexes.csv", csv.as_bytes()),
            ("summary.md", md.as_bytes()),
        ] {
            let path = dir.join(name);
            write_atomic(&path, text).map_err(|e| crate::write_failed(&path, e))?;
        }
        let fig = dir.join("motions.svg");
        if let Err(e) = motions_figure(&fig, target, &figures) {
            eprintln!("warning: figure {} not drawn: {e:#}", fig.display());
        }
        println!("wrote {}", dir.display());
    }
    Ok(outcome)
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
