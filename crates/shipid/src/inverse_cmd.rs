//! `shipid inverse TARGETS.toml` (paper 003): SVD variation modes of the 20-ship database, a simulated
//! motion-index database per target ship, the inverse network, and the inversion of each target motion
//! with a re-simulation; `shipid inverse-bench` times the database build.
//!
//! The 20-ship database is built into the binary (`--ships FILE` overrides it), so the command runs
//! from any directory.
//!
//! Outputs under `--out` (default `results/paper003/`): `modes.csv` and `modes.svg` (paper 003 Fig. 3),
//! `summary.json` (mode choice, rejections, weights at full precision with `inside_box`, the models'
//! metrics), per target `<target>/indexes.csv` (given vs obtained), `<target>/weights.csv`,
//! `<target>/summary.md` (tables), `<target>/motions.svg` (Fig. 6/7: red = simulated with the predicted
//! hydrodynamics, black dashed = given indexes) and the delivered `mmg` model file per motion
//! (`model.toml`, or `model_<motion>.toml` when the target has several) with its ensemble as
//! `[bootstrap]` replicates for `--bands`.

use std::fmt::Write as _;
use std::io::IsTerminal as _;
use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use shipid_figures::inverse::{MotionFigure, motions_figure, write_modes};
use shipid_inverse::database::{PAPER003_SHIPS_TOML, ShipsFile};
use shipid_inverse::indexes::{INDEX_KEYS, MotionIndexes, SimSettings};
use shipid_inverse::inversion::{
    CheckedTarget, DeliveredFit, FIT_WARN_MEAN_RELATIVE_ERROR, InputFault, MotionInversion,
    RefineOutcome, check_inputs, delivered_markdown, fit_toml_comment, header_markdown,
    indexes_csv, motions_markdown, outside_flags, outside_range,
};
use shipid_inverse::modes::VariationModes;
use shipid_inverse::physical::{Bound, MODEL_FILE_NAMES, PhysicalChecks, model_file_values};
use shipid_inverse::pipeline::{
    MAX_REFINE_EVALS, MIN_SAMPLES, SimulationDatabase, WEIGHT_RANGE_STD, build_database,
    sample_weights,
};
use shipid_inverse::run::{
    Ensemble, INTERIOR_MARGIN_SIGMA, MEMBER_MISMATCH_FACTOR, Progress, RESTART_JITTER_SIGMA,
    RESTARTS_PER_NETWORK, RunOptions, Spread, TargetRun, inside_box, max_refinement_starts,
    member_parameters, run_target,
};
use shipid_inverse::target::{TargetShip, TargetsFile};
use shipid_io::write::write_atomic;
use shipid_pipeline::mmg::file::{
    MMG_KIND, MmgBootstrapRecord, MmgEstimatorEntry, MmgModelFile, ParamEntry, PropellerEntry,
    ReplicateKind, RudderEntry, write_mmg_model_file,
};
use shipid_pipeline::mmg::geometry::MmgGeometry;
use shipid_pipeline::mmg::identify::DETERMINED_SHARE;
use shipid_pipeline::mmg::priors::priors;
use shipid_pipeline::simulate::simulate_manoeuvre;
use shipid_pipeline::spec::parse_manoeuvre;
use shipid_sim::{Dynamics, MmgModel, SimStatus, metrics};

use serde_json::{Map, Value, json};

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
    /// Whether `--resimulate` was given (a default capped at a small test set is no request to
    /// mention).
    pub max_resim_given: bool,
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

/// The variation modes of the database (`ships`, or the built-in one) and the checked targets'
/// particulars (see [`load_checked`]).
pub fn load(
    ships: Option<&Path>,
    targets: &Path,
) -> Result<(VariationModes, Vec<TargetShip>), CliError> {
    let (modes, checked) = load_checked(ships, targets)?;
    Ok((modes, checked.into_iter().map(|t| t.ship).collect()))
}

/// The variation modes of the database (`ships`, or the built-in one) and the checked targets with
/// their motions; a database whose ships span fewer variations than n − 1 is warned about (its
/// noise modes are left out).
pub fn load_checked(
    ships: Option<&Path>,
    targets: &Path,
) -> Result<(VariationModes, Vec<CheckedTarget>), CliError> {
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
        let t = &t.ship;
        let s = slug(&t.name);
        if s.is_empty() {
            return Err(bad_input(format!(
                "{}: a [[target]] has an empty name (its tables go into a folder named after it)",
                targets.display()
            )));
        }
        if let Some(o) = targets_checked[..i]
            .iter()
            .find(|o| slug(&o.ship.name) == s)
        {
            return Err(bad_input(format!(
                "{}: targets `{}` and `{}` would both write into the folder `{s}`",
                targets.display(),
                o.ship.name,
                t.name
            )));
        }
    }
    if modes.rank_deficient() {
        let n = modes.ship_ids.len();
        let k = modes.singular_values.len();
        eprintln!(
            "warning: {ships_name}: the {n} ships span only {k} independent variation{} (n ships \
             give up to {}): some ships are linear combinations of others, and the singular values \
             of modes {}–{n} ({}) are rounding noise, left out; the inverse uses at most {k} modes",
            if k == 1 { "" } else { "s" },
            n - 1,
            k + 1,
            modes
                .noise_singular_values
                .iter()
                .map(|v| format!("{v:.1e}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
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

/// Seconds between the refinement's progress lines when stderr is no terminal (a log file), where
/// the bar is not drawn.
const PROGRESS_LINE_S: f64 = 30.0;

/// The refinement's progress: a bar of its simulations on a terminal, a line every
/// [`PROGRESS_LINE_S`] elsewhere.
struct RefinementProgress {
    bar: ProgressBar,
    name: String,
    most: usize,
    done: AtomicUsize,
    start: Instant,
    last_line: Mutex<f64>,
    terminal: bool,
}

impl RefinementProgress {
    fn new(name: &str, most: usize) -> RefinementProgress {
        let bar = ProgressBar::new(most as u64);
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} {pos} refinement simulations (at most {len})  elapsed {elapsed}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
        );
        RefinementProgress {
            bar,
            name: name.to_string(),
            most,
            done: AtomicUsize::new(0),
            start: Instant::now(),
            last_line: Mutex::new(0.0),
            terminal: std::io::stderr().is_terminal(),
        }
    }

    fn tick(&self) {
        self.bar.inc(1);
        let done = self.done.fetch_add(1, Ordering::Relaxed) + 1;
        if self.terminal {
            return;
        }
        let t = self.start.elapsed().as_secs_f64();
        let Ok(mut last) = self.last_line.lock() else {
            return;
        };
        if t - *last >= PROGRESS_LINE_S {
            *last = t;
            eprintln!(
                "{}: {done} refinement simulations of at most {} in {t:.0} s",
                self.name, self.most
            );
        }
    }
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
    let checks = physical_checks(target);
    let db = build_database(target, modes, &weights, settings, &checks, &|| bar.inc(1))
        .map_err(|e| bad_input(e.to_string()))?;
    let secs = start.elapsed().as_secs_f64();
    bar.finish_and_clear();
    Ok((db, secs))
}

/// Largest `--samples` run without `--allow-large`.
pub const MAX_SAMPLES: usize = 100_000;

/// Largest number of modes the search grows to: with twelve the paper's targets lie inside the box
/// (issue 28), and each further step costs a database.
pub const MAX_MODES: usize = 12;
/// Modes added per step of the search.
pub const MODE_STEP: usize = 2;
/// Networks of the ensemble that gives the model's band.
pub const NETWORKS: usize = 5;

/// Bounds of the mmg family (`shipid_pipeline::mmg::priors`) for the target's ship, so that every
/// ship the inverse accepts can be written as an `mmg` model file; and stable straight running.
fn physical_checks(target: &TargetShip) -> PhysicalChecks {
    let (ship, added, geometry) = target_geometry(target);
    PhysicalChecks {
        bounds: priors(&ship, &geometry, &added)
            .into_iter()
            .map(|p| Bound {
                name: p.name.to_string(),
                lower: p.lower,
                upper: p.upper,
            })
            .collect(),
        stable_straight_run: true,
    }
}

fn target_geometry(target: &TargetShip) -> (shipid_io::Ship, shipid_io::AddedMass, MmgGeometry) {
    let ship = target.ship();
    let p = target.mmg_parameters(&shipid_inverse::database::Coefficients(
        [0.0; shipid_inverse::database::N_COEF],
    ));
    let h = 0.5 * ship.rho * ship.lpp * ship.lpp * ship.draft;
    let added = shipid_io::AddedMass {
        X_udot: -p.m_x * h,
        Y_vdot: -p.m_y * h,
        Y_rdot: 0.0,
        N_vdot: 0.0,
        N_rdot: -p.j_z * h * ship.lpp * ship.lpp,
    };
    let geometry = MmgGeometry {
        propeller_diameter_m: p.propeller_diameter_m,
        propeller_x_m: p.x_p * ship.lpp,
        k_t: p.k_t,
        rudder_area_m2: p.rudder_area_m2,
        rudder_span_m: p.rudder_span_m,
        rudder_x_m: p.x_r * ship.lpp,
    };
    (ship, added, geometry)
}

/// The parameters the inverse holds fixed (from the targets file or KVLCC2) must lie within the
/// bounds of an `mmg` model file, or no ship of the target could be written as one.
fn check_fixed(target: &TargetShip, path: &Path) -> Result<(), CliError> {
    let checks = physical_checks(target);
    let p = target.mmg_parameters(&shipid_inverse::database::Coefficients(
        [0.0; shipid_inverse::database::N_COEF],
    ));
    let values = model_file_values(&p);
    for (k, name) in MODEL_FILE_NAMES.iter().enumerate() {
        let (found, _) = source_of(name, target, 0, false);
        let Some(b) = checks.bounds.iter().find(|b| b.name == *name) else {
            continue;
        };
        if found || (b.lower..=b.upper).contains(&values[k]) {
            continue;
        }
        let key = match *name {
            "t_p" => "t_p",
            "f_alpha" if target.f_alpha.is_some() => "f_alpha",
            "f_alpha" => "rudder_span_m / rudder_area_m2 (Fujii's f_alpha)",
            "r0" => "lpp_m, beam_m, draft_m, cb, u0_m_s (the resistance R'_0)",
            _ => "(fixed at KVLCC2's value)",
        };
        return Err(bad_input(format!(
            "{}: target {}: {key}: {name} = {} is outside [{}, {}], the bounds of an mmg model file \
             (docs/mmg.md); the inverse holds it fixed, so no ship of this target could be written",
            path.display(),
            target.name,
            values[k],
            b.lower,
            b.upper
        )));
    }
    Ok(())
}

/// Where each model-file parameter of an inverted ship comes from.
fn source_of(name: &str, target: &TargetShip, n_modes: usize, refined: bool) -> (bool, String) {
    let found = format!(
        "inverse network, {n_modes} modes{}",
        if refined { ", refined" } else { "" }
    );
    match name {
        "r0" => (
            false,
            "target particulars: Schoenherr friction × Watanabe form factor on Denny–Mumford's wetted surface".into(),
        ),
        "t_p" => (false, "targets file: t_p".into()),
        "f_alpha" if target.f_alpha.is_some() => (false, "targets file: f_alpha".into()),
        "f_alpha" => (false, "Fujii's formula from the targets file's rudder span and area".into()),
        "w_p0" | "c1" | "c2_pos" | "c2_neg" => {
            (false, "fixed: Yasukawa & Yoshimura 2015 KVLCC2".into())
        }
        _ => (true, found),
    }
}

/// Mode weights, ensemble and the model built from them, for one motion.
struct Delivered {
    /// The weights the model file holds: the best-matching ensemble member inside the sampled box
    /// (the best one when none is), else the network's refined or clipped answer.
    weights: Vec<f64>,
    refined: bool,
    /// Which answer it is, in words ("ensemble member 3 of 24 (…)").
    source: String,
    model: Option<MmgModel>,
    members: Option<(Vec<Vec<f64>>, Spread)>,
    dropped: usize,
}

fn deliver(
    target: &TargetShip,
    modes: &VariationModes,
    m: &MotionInversion,
    e: Option<&Ensemble>,
    checks: &PhysicalChecks,
) -> Delivered {
    // Every kept member matches the indexes about as well as the best (within
    // MEMBER_MISMATCH_FACTOR); among them a ship inside the sampled box is one the database's
    // variation describes, so it is delivered before a better-matching one on the box's edge.
    let members = e.map_or(&[][..], |e| &e.members[..]);
    let inside = members
        .iter()
        .position(|r| inside_box(modes, &r.weights).iter().all(|inside| *inside));
    let best = inside.or((!members.is_empty()).then_some(0));
    let (weights, refined, source) = match (best, &m.refined) {
        (Some(k), _) => (
            members[k].weights.clone(),
            true,
            match (inside, k) {
                (Some(_), 0) => format!(
                    "ensemble member 1 of {} (the best-matching, inside the trained box)",
                    members.len()
                ),
                (Some(_), k) => format!(
                    "ensemble member {} of {} (the best-matching inside the trained box; members \
                     1–{k} match better but sit on its edge)",
                    k + 1,
                    members.len()
                ),
                (None, _) => format!(
                    "ensemble member 1 of {} (the best-matching; none lies inside the trained box)",
                    members.len()
                ),
            },
        ),
        (None, RefineOutcome::Done { refined, .. }) => (
            refined.weights.clone(),
            true,
            "the first network's refined answer".to_string(),
        ),
        _ => (
            m.weights.clone(),
            false,
            "the first network's answer, clipped to the trained box (no refinement)".to_string(),
        ),
    };
    let model = modes
        .generate(&weights)
        .ok()
        .and_then(|c| target.model(&c))
        // An unphysical ship (the network's clipped answer without refinement) is no model to deliver.
        .filter(|model| checks.check(model).is_ok());
    Delivered {
        weights,
        refined,
        source,
        model,
        members: e.and_then(|e| member_parameters(target, modes, e)),
        dropped: e.map_or(0, |e| e.dropped),
    }
}

#[allow(clippy::too_many_arguments)]
fn model_file(
    target: &TargetShip,
    modes: &VariationModes,
    run: &TargetRun,
    motion: &MotionInversion,
    d: &Delivered,
    model: &MmgModel,
    seed: u64,
    fit: Option<&DeliveredFit>,
) -> MmgModelFile {
    let (ship, added, geometry) = target_geometry(target);
    let n_modes = run.choice.modes;
    let specs = priors(&ship, &geometry, &added);
    let values = model_file_values(model.parameters());
    let centre = model_file_values(
        &target.mmg_parameters(&modes.generate(&vec![0.0; n_modes]).unwrap_or(modes.mean)),
    );
    let se = |k: usize| d.members.as_ref().map_or(0.0, |(_, s)| s.std_error[k]);
    let parameters = MODEL_FILE_NAMES
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let (found, source) = source_of(name, target, n_modes, d.refined);
            let (lower, upper) = specs
                .iter()
                .find(|p| p.name == *name)
                .map_or((f64::NEG_INFINITY, f64::INFINITY), |p| (p.lower, p.upper));
            ParamEntry {
                name: name.to_string(),
                value: values[k],
                lower,
                upper,
                // The inverse has no prior term: a found parameter's centre is the database's mean
                // ship (all weights 0), around which the generator draws, with no weight.
                prior: if found { centre[k] } else { values[k] },
                prior_sd: if found { f64::INFINITY } else { 0.0 },
                prior_source: source,
                standard_error: if found { se(k) } else { 0.0 },
                data_share: if found { 1.0 } else { 0.0 },
                determined_by_data: found,
                jackknife_standard_error: None,
            }
        })
        .collect();
    let bootstrap = d.members.as_ref().map(|(vectors, spread)| MmgBootstrapRecord {
        replicate_kind: ReplicateKind::InverseEnsemble,
        method: format!(
            "not a bootstrap: an ensemble of {NETWORKS} inverse networks (seeds {seed}…{}) trained on one \
             simulated database, each refined by re-simulation from its own answer and {} starts \
             jittered by ±{RESTART_JITTER_SIGMA} σ around it; {} of {} kept (mismatch within \
             {MEMBER_MISMATCH_FACTOR} × the best), the best inside the sampled box is the point model",
            seed + NETWORKS as u64 - 1,
            RESTARTS_PER_NETWORK - 1,
            vectors.len(),
            vectors.len() + d.dropped
        ),
        seed,
        block_rows: 0,
        block_reason: "no blocks: members differ by the network's seed and the refinement's start, not \
                       by resampled data"
            .into(),
        rejected: d.dropped,
        standard_error: MODEL_FILE_NAMES
            .iter()
            .zip(&spread.std_error)
            .map(|(n, s)| (n.to_string(), *s))
            .collect(),
        order: MODEL_FILE_NAMES.iter().map(|n| n.to_string()).collect(),
        correlation: spread.correlation.clone(),
        replicates: MODEL_FILE_NAMES
            .iter()
            .enumerate()
            .map(|(k, n)| (n.to_string(), vectors.iter().map(|v| v[k]).collect()))
            .collect(),
    });
    MmgModelFile {
        shipid_version: env!("CARGO_PKG_VERSION").into(),
        kind: MMG_KIND.into(),
        ship,
        added_mass: added,
        propeller: PropellerEntry {
            diameter_m: geometry.propeller_diameter_m,
            x_m: geometry.propeller_x_m,
            k_t: geometry.k_t,
            rate_rps: model.propeller_rate(),
        },
        rudder: RudderEntry {
            area_m2: geometry.rudder_area_m2,
            span_m: geometry.rudder_span_m,
            x_m: geometry.rudder_x_m,
        },
        estimator: MmgEstimatorEntry {
            name: "inverse-network".into(),
            method: format!(
                "paper 003 inverse identification of target `{}`, motion `{}` from its nine motion \
                 indexes: SVD variation modes of the 20-ship database, mode weights by an MLP trained \
                 on {} simulated ships{}; modes: {}. No equation error: residual_rms is not defined \
                 (nan). Parameters without `inverse network` in their source are fixed. Delivered: {}; {}",
                target.name,
                motion.name,
                run.db.samples.len(),
                if d.refined {
                    ", refined by re-simulation (Nelder–Mead on the standardised index mismatch)"
                } else {
                    ""
                },
                run.choice.reason,
                d.source,
                fit_sentence(fit),
            ),
            prior_weight: 0.0,
            tuned: false,
            determined_share: DETERMINED_SHARE,
            samples: run.db.samples.len(),
            residual_rms: [f64::NAN; 3],
            cv: Vec::new(),
            cv_folds_refined: false,
            refinement: None,
            thrust_inflow: None,
            jackknife: None,
        },
        training: Vec::new(),
        parameters,
        bootstrap,
        calibration: None,
        valley: None,
    }
}

/// The fit of the delivered model in one sentence, for the model file's `method`.
fn fit_sentence(fit: Option<&DeliveredFit>) -> String {
    let Some(fit) = fit else {
        return "its re-simulation of the nine indexes failed.".into();
    };
    let mut s = format!(
        "its own re-simulated indexes miss the targets by a mean |relative error| of {:.1} % ({}).",
        100.0 * fit.mean_abs,
        fit.errors_text()
    );
    if fit.misses() {
        let _ = write!(
            s,
            " MORE THAN {:.0} %: the targets may lie outside what the database's ships can reach; \
             this model is not the target's ship.",
            100.0 * FIT_WARN_MEAN_RELATIVE_ERROR
        );
    }
    let outside = fit.outside_text();
    if !outside.is_empty() {
        let _ = write!(
            s,
            " Targets outside the simulated database's range: {}.",
            outside.join("; ")
        );
    }
    s
}

/// The 10/10 zig-zag and the 20° turning circle of a model, as `shipid simulate` runs them.
fn standard_metrics(model: &MmgModel) -> Value {
    let mut o = Map::new();
    for (key, spec) in [
        ("zigzag_10_10_starboard", "zigzag:10/10:starboard"),
        ("turning_20_starboard", "turning:20:starboard"),
    ] {
        let v = parse_manoeuvre(spec)
            .ok()
            .and_then(|m| {
                let out = simulate_manoeuvre(model, &m, None, None).ok()?;
                Some(match out.status {
                    SimStatus::Ok => json!(metrics(&out.recording, &m, model.ship())),
                    SimStatus::Diverged { t_s, reason } => {
                        json!({"status": "diverged", "t_s": t_s, "reason": reason})
                    }
                })
            })
            .unwrap_or(Value::Null);
        o.insert(key.into(), v);
    }
    Value::Object(o)
}

fn weights_csv_rows(csv: &mut String, motion: &str, what: &str, x: &[f64], modes: &VariationModes) {
    let inside = inside_box(modes, x);
    for (i, v) in x.iter().enumerate() {
        let s = modes.weight_std[i];
        let _ = writeln!(
            csv,
            "{motion},{what},{},{v},{s},{},{}",
            i + 1,
            v / s,
            inside[i]
        );
    }
}

/// `shipid inverse`.
pub fn run(a: &InverseArgs) -> Result<Outcome, CliError> {
    faer::set_global_parallelism(faer::Par::Seq);
    let mut inputs = crate::outputs::Inputs::new().file(a.targets, "the targets file");
    if let Some(ships) = a.ships {
        inputs = inputs.file(ships, "the ships database");
    }
    crate::outputs::check_folder(
        "--out",
        a.out,
        &["summary.json", "modes.csv", "modes.svg"],
        &inputs,
    )?;
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
    if a.refine_evals > MAX_REFINE_EVALS {
        let starts = max_refinement_starts(NETWORKS, (MAX_MODES - 1).div_ceil(MODE_STEP) + 1);
        return Err(bad_input(format!(
            "--refine-evals {}: more than {MAX_REFINE_EVALS} simulations per refinement start. The \
             simplex stops by itself after a few hundred to a few thousand; each motion refines from \
             up to {starts} starts of 4 simulated manoeuvres each (about 1 ms of CPU), so this would \
             run up to {:.0} CPU hours per motion. Give 0–{MAX_REFINE_EVALS} (default 150).",
            a.refine_evals,
            starts as f64 * a.refine_evals as f64 * 1e-3 / 3600.0
        )));
    }
    let (modes, targets) = load_checked(a.ships, a.targets)?;
    let n95 = modes.modes_for(0.95);
    if let Some(n) = a.modes
        && (n == 0 || n > modes.singular_values.len())
    {
        let k = modes.singular_values.len();
        return Err(bad_input(if k == 1 {
            format!("--modes {n}: the database has 1 mode; give 1")
        } else {
            format!("--modes {n}: the database has {k} modes; give 1–{k}")
        }));
    }
    for target in &targets {
        check_fixed(&target.ship, a.targets)?;
    }
    let max_modes = MAX_MODES.clamp(n95, modes.singular_values.len());
    std::fs::create_dir_all(a.out).map_err(|e| crate::write_failed(a.out, e))?;
    write_modes(a.out, &modes).map_err(failed)?;
    println!(
        "SVD of {} ships: mode 1 carries {:.1} %, {} modes reach 95 % ({:.1} %); {}",
        modes.ship_ids.len(),
        100.0 * modes.contribution[0],
        n95,
        100.0 * modes.cumulative()[n95 - 1],
        match a.modes {
            Some(n) => format!("using {n} modes (--modes)"),
            None => format!(
                "modes grown from {n95} by {MODE_STEP} up to {max_modes} until every network answer and refined weight is inside the trained box"
            ),
        }
    );
    let settings = SimSettings::default();
    let mut outcome = Outcome::Ok;
    let mut summary_targets = Vec::new();
    for checked in &targets {
        let target = &checked.ship;
        let given: &[(String, MotionIndexes)] = &checked.motions;
        let opts = RunOptions {
            samples: a.samples,
            seed: a.seed,
            fixed_modes: a.modes,
            start_modes: n95,
            mode_step: MODE_STEP,
            max_modes,
            networks: NETWORKS,
            refine_evals: a.refine_evals,
            max_resim: a.max_resim,
            settings,
            checks: physical_checks(target),
        };
        let attempts_max = if a.modes.is_some() {
            1
        } else {
            (max_modes - n95).div_ceil(MODE_STEP) + 1
        };
        let bars = MultiProgress::new();
        let bar = bars.add(progress(
            a.samples * attempts_max,
            "ships simulated (4 manoeuvres each)",
        ));
        let most = max_refinement_starts(NETWORKS, attempts_max) * given.len() * a.refine_evals;
        let refinement = RefinementProgress::new(&target.name, most);
        // No refinement (--refine-evals 0): no bar for it.
        let rbar = if most > 0 {
            bars.add(refinement.bar.clone())
        } else {
            ProgressBar::hidden()
        };
        let run = run_target(
            target,
            &modes,
            given,
            &opts,
            &Progress {
                ship: &|| bar.inc(1),
                refinement: &|| refinement.tick(),
            },
        )
        .map_err(|e| {
            failed(anyhow::anyhow!(
                "{}: target {}: {e}",
                a.targets.display(),
                target.name
            ))
        })?;
        bar.finish_and_clear();
        rbar.finish_and_clear();
        let db = &run.db;
        let n_modes = run.choice.modes;
        println!(
            "\n## {}\nmodes: {}\nsimulation database: {} ships requested, {} usable, {} dropped ({}) in {:.1} s",
            target.name,
            run.choice.reason,
            db.requested,
            db.samples.len(),
            db.dropped.len(),
            db.dropped_summary(),
            run.build_time_s
        );
        let motions = &run.motions;
        // A motion without a delivered model is a failure (below); the network's own answer failing
        // to re-simulate (often an unphysical ship) is reported in the table, and the refined model
        // replaces it.
        if motions.iter().any(|m| m.refined == RefineOutcome::Failed) {
            outcome = Outcome::SomeFailed;
        }
        let dir = a.out.join(slug(&target.name));
        std::fs::create_dir_all(&dir).map_err(|e| crate::write_failed(&dir, e))?;
        let mut weights_csv =
            String::from("motion,weights,mode,weight,sigma,weight_over_sigma,inside_box\n");
        let mut motion_json = Vec::new();
        let mut model_lines = String::new();
        let mut fit_tables = String::new();
        for (i, m) in motions.iter().enumerate() {
            let e = run.ensembles.get(i);
            let d = deliver(target, &modes, m, e, &opts.checks);
            weights_csv_rows(
                &mut weights_csv,
                &m.name,
                "network",
                &m.network_weights,
                &modes,
            );
            if let RefineOutcome::Done { refined, .. } = &m.refined {
                weights_csv_rows(
                    &mut weights_csv,
                    &m.name,
                    "refined",
                    &refined.weights,
                    &modes,
                );
            }
            // The model file's own weights: the best-matching member inside the box, which need not
            // be member 1 (the best-matching of all).
            weights_csv_rows(&mut weights_csv, &m.name, "model", &d.weights, &modes);
            for (k, member) in e.map_or(&[][..], |e| &e.members[..]).iter().enumerate() {
                weights_csv_rows(
                    &mut weights_csv,
                    &m.name,
                    &format!("member {}", k + 1),
                    &member.weights,
                    &modes,
                );
            }
            let file_name = if motions.len() == 1 {
                "model.toml".to_string()
            } else {
                format!("model_{}.toml", slug(&m.name))
            };
            let inside = inside_box(&modes, &d.weights);
            let mut mj = json!({
                "name": m.name,
                "given_indexes": m.given.0,
                "network_weights": m.network_weights,
                "network_clipped": m.clipped,
                "weights": d.weights,
                "weights_refined": d.refined,
                "weight_sigma": &modes.weight_std[..d.weights.len()],
                "inside_box": inside,
                "all_inside_box": inside.iter().all(|b| *b),
                "ensemble_members": d.members.as_ref().map_or(0, |(v, _)| v.len()),
                // Mean squared standardised index mismatch of each kept member, best (the model) first.
                "ensemble_mismatch": e.map_or(Vec::new(), |e| e.members.iter().map(|r| r.objective).collect()),
                "ensemble_dropped": d.dropped,
            });
            mj["delivered"] = json!(d.source);
            let range = db.index_range();
            let outside = outside_range(&m.given, &range);
            mj["target_outside_database"] = json!(outside_flags(&m.given, &range));
            mj["database_index_min"] = json!(range.map(|r| r.0));
            mj["database_index_max"] = json!(range.map(|r| r.1));
            if !outside.is_empty() {
                eprintln!(
                    "warning: {} / {}: target indexes outside the range of the {} simulated ships \
                     (the network extrapolates there): {}",
                    target.name,
                    m.name,
                    db.samples.len(),
                    outside.join("; ")
                );
            }
            match &d.model {
                Some(model) => {
                    let resim = shipid_inverse::inversion::resimulate(
                        target,
                        &modes,
                        &settings,
                        &opts.checks,
                        &d.weights,
                    );
                    let fit = resim
                        .as_ref()
                        .ok()
                        .map(|r| DeliveredFit::new(&m.given, &r.indexes, db));
                    let file = model_file(target, &modes, &run, m, &d, model, a.seed, fit.as_ref());
                    let mut text = inverse_header(
                        &write_mmg_model_file(&file).map_err(|e| failed(anyhow::anyhow!(e)))?,
                    );
                    if let Some(fit) = &fit {
                        text.push_str(&fit_toml_comment(&d.source, fit));
                    }
                    let path = dir.join(&file_name);
                    write_atomic(&path, text.as_bytes())
                        .map_err(|e| crate::write_failed(&path, e))?;
                    mj["model_file"] = json!(file_name);
                    mj["model_indexes"] = resim.map_or(Value::Null, |r| json!(r.indexes.0));
                    mj["model_fit"] = fit.as_ref().map_or(Value::Null, |f| {
                        json!({
                            "given": f.given.0,
                            "obtained": f.obtained.0,
                            "relative_error": f.relative,
                            "mean_abs_relative_error": f.mean_abs,
                            "warn_above_mean_abs_relative_error": FIT_WARN_MEAN_RELATIVE_ERROR,
                            "misses_targets": f.misses(),
                        })
                    });
                    match &fit {
                        Some(f) => {
                            let _ = writeln!(
                                model_lines,
                                "model of {} delivered: {}; its own re-simulated indexes miss the \
                                 targets by a mean |relative error| of {:.1} % ({})",
                                m.name,
                                d.source,
                                100.0 * f.mean_abs,
                                f.errors_text()
                            );
                            fit_tables
                                .push_str(&delivered_markdown(&m.name, &file_name, &d.source, f));
                            if f.misses() {
                                eprintln!(
                                    "WARNING: {} / {}: the delivered model ({}, {}) misses its \
                                     targets by {:.1} % on average, more than {:.0} %: {}. The \
                                     targets may lie outside what the database's ships can reach{}; \
                                     this model is not the target's ship.",
                                    target.name,
                                    m.name,
                                    path.display(),
                                    d.source,
                                    100.0 * f.mean_abs,
                                    100.0 * FIT_WARN_MEAN_RELATIVE_ERROR,
                                    f.errors_text(),
                                    if outside.is_empty() {
                                        String::new()
                                    } else {
                                        format!(" (outside its range: {})", outside.join("; "))
                                    }
                                );
                            }
                        }
                        None => {
                            let _ = writeln!(
                                model_lines,
                                "model of {} delivered: {}; its re-simulation failed",
                                m.name, d.source
                            );
                        }
                    }
                    mj["model_metrics"] = standard_metrics(model);
                    let _ = writeln!(
                        model_lines,
                        "model of {} ({}): {}; weights inside the trained box: {}",
                        m.name,
                        path.display(),
                        fmt_metrics(&mj["model_metrics"]),
                        if inside.iter().all(|b| *b) {
                            "all".to_string()
                        } else {
                            format!(
                                "not modes {}",
                                inside
                                    .iter()
                                    .enumerate()
                                    .filter(|(_, b)| !**b)
                                    .map(|(k, _)| (k + 1).to_string())
                                    .collect::<Vec<_>>()
                                    .join(", ")
                            )
                        }
                    );
                }
                None => {
                    outcome = Outcome::SomeFailed;
                    mj["model_file"] = Value::Null;
                    let _ = writeln!(
                        model_lines,
                        "model of {}: none (its weights give no physical MMG model)",
                        m.name
                    );
                }
            }
            motion_json.push(mj);
        }
        // The test set bounds the re-simulations: a larger request is capped, and the summary says
        // so rather than let "8 re-simulated" read as the answer to "--resimulate 1000".
        let held = &run.held;
        let capped = (a.max_resim_given && a.max_resim > held.n).then(|| {
            format!(
                "--resimulate {} asks for more than the {} held-out test samples: all {} were re-simulated ({} succeeded, {} failed).",
                a.max_resim,
                held.n,
                held.resimulated,
                held.resimulated - held.resim_failed.min(held.resimulated),
                held.resim_failed
            )
        });
        if let Some(note) = &capped {
            eprintln!("note: {}: {note}", target.name);
        }
        let md = header_markdown(target, n_modes, db, run.build_time_s, &run.model, &run.held)
            + &capped.map_or(String::new(), |n| format!("{n}\n\n"))
            + &format!("Modes: {}.\n\n", run.choice.reason)
            + &motions_markdown(motions, &modes, db)
            + "\n"
            + &model_lines
            + &fit_tables;
        let csv = indexes_csv(motions);
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
        for (name, text) in [
            ("indexes.csv", csv.as_bytes()),
            ("summary.md", md.as_bytes()),
            ("weights.csv", weights_csv.as_bytes()),
        ] {
            let path = dir.join(name);
            write_atomic(&path, text).map_err(|e| crate::write_failed(&path, e))?;
        }
        let fig = dir.join("motions.svg");
        if let Err(e) = motions_figure(&fig, target, &figures) {
            eprintln!("warning: figure {} not drawn: {e:#}", fig.display());
        }
        let mut dropped: std::collections::BTreeMap<String, usize> = Default::default();
        for (_, f) in &db.dropped {
            *dropped.entry(f.kind()).or_default() += 1;
        }
        summary_targets.push(json!({
            "name": target.name,
            "folder": slug(&target.name),
            "modes": n_modes,
            "box_sigma": WEIGHT_RANGE_STD,
            "interior_margin_sigma": INTERIOR_MARGIN_SIGMA,
            "mode_choice": {
                "reason": run.choice.reason,
                "capped": run.choice.capped,
                "attempts": run.choice.attempts.iter().map(|t| json!({
                    "modes": t.modes,
                    "usable": t.usable,
                    "requested": t.requested,
                    "on_edge": t.on_edge.iter().map(|(n, m)| json!({"motion": n, "modes": m})).collect::<Vec<_>>(),
                    "refinement_failed": t.failed,
                })).collect::<Vec<_>>(),
            },
            "database": {
                "requested": db.requested,
                "usable": db.samples.len(),
                "dropped": dropped,
            },
            "motions": motion_json,
        }));
        println!("wrote {}", dir.display());
    }
    let summary = json!({
        "shipid_version": env!("CARGO_PKG_VERSION"),
        "index_keys": INDEX_KEYS,
        "modes_for_95_percent": n95,
        "seed": a.seed,
        "samples": a.samples,
        "networks": NETWORKS,
        "targets": summary_targets,
    });
    let path = a.out.join("summary.json");
    let text = serde_json::to_string_pretty(&summary).map_err(|e| failed(anyhow::anyhow!(e)))?;
    write_atomic(&path, text.as_bytes()).map_err(|e| crate::write_failed(&path, e))?;
    println!("wrote {}", path.display());
    Ok(outcome)
}

/// The model file's text with a header that says where it comes from (the shared writer's header
/// speaks of recordings).
fn inverse_header(text: &str) -> String {
    let body: String = text
        .lines()
        .skip_while(|l| l.starts_with('#'))
        .map(|l| format!("{l}\n"))
        .collect();
    format!(
        "# MMG model (Yasukawa & Yoshimura 2015 structure) identified by shipid {} from motion indexes \
         only (paper 003 inverse method).\n# Each [[parameter]]: value, bounds and its source \
         (`prior_source`: inverse network or fixed); standard_error is the spread of the\n# ensemble of \
         networks stored under [bootstrap] (not a bootstrap: see its `method`). \
         docs/reproductions/paper003.md explains it.\n{body}",
        env!("CARGO_PKG_VERSION")
    )
}

fn fmt_metrics(v: &Value) -> String {
    let get = |m: &str, k: &str| {
        v[m][k]
            .as_f64()
            .map_or("-".to_string(), |x| format!("{x:.2}"))
    };
    format!(
        "10/10 zig-zag overshoots {}° / {}°, 20° turn advance {} L, tactical diameter {} L",
        get("zigzag_10_10_starboard", "overshoot_1"),
        get("zigzag_10_10_starboard", "overshoot_2"),
        get("turning_20_starboard", "advance"),
        get("turning_20_starboard", "tactical_diameter"),
    )
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
