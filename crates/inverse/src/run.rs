//! One target of `shipid inverse`, start to end: the number of modes chosen by growing it until the
//! network's answer and the refined weights of every motion lie inside the box the network was
//! trained on, then an ensemble of
//! networks (different seeds) and refinement restarts, whose members give the model's band.
//!
//! Why grow the modes: with six modes (95 % of the database's variation, paper 003) the refined
//! weights of realistic targets sit on the ±3σ edge of the sampled box: the targets need variation the
//! first six modes do not carry, and the network, trained inside the box, extrapolates. More modes give
//! the generator that variation inside the box. The network's own answer must be inside too: a
//! refinement can pull a target that lies outside back inside the box with six modes, and then
//! misses what the indexes do not fix (KVLCC2 variants: the 10/10 second overshoot 2.4–3.3° low;
//! with the answer inside, 8–12 modes, 0.2–1.3°). The box stays ±3σ (paper 003): widening it would mostly
//! add unphysical ships, which the physical checks then reject.

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;
use rayon::prelude::*;
pub use shipid_uncertainty::Spread;

use crate::error::InverseError;
use crate::indexes::{MotionIndexes, SimSettings};
use crate::inversion::{MotionInversion, RefineOutcome, invert_motion};
use crate::mlp::TrainOptions;
use crate::modes::VariationModes;
use crate::physical::PhysicalChecks;
use crate::pipeline::{
    HeldOut, InverseModel, Refined, SimulationDatabase, WEIGHT_RANGE_STD, build_database,
    clip_weights, held_out, mismatch_of_relative_errors, refine, sample_weights,
};
use crate::target::TargetShip;

/// A weight counts as inside the trained box when |x_i| ≤ (3 − this) σ_i: the refinement clamps to the
/// box, so a weight within this margin of the edge is one the search pushed against it.
pub const INTERIOR_MARGIN_SIGMA: f64 = 0.1;
/// An ensemble member is kept when its mismatch is at most this multiple of the best member's (its
/// standardised RMS index error at most twice the best): a network whose refinement stalls in a poor
/// local minimum does not describe the target and would only widen the band.
pub const MEMBER_MISMATCH_FACTOR: f64 = 4.0;

/// How a target is inverted.
#[derive(Debug, Clone, PartialEq)]
pub struct RunOptions {
    /// Simulated ships per database.
    pub samples: usize,
    pub seed: u64,
    /// `Some(n)`: exactly n modes, no search.
    pub fixed_modes: Option<usize>,
    /// The search starts here (the fewest modes reaching 95 % of the variation)…
    pub start_modes: usize,
    /// … grows by this many…
    pub mode_step: usize,
    /// … and stops here.
    pub max_modes: usize,
    /// Networks of the ensemble (seeds seed, seed + 1, …), each refined from
    /// [`RESTARTS_PER_NETWORK`] starts.
    pub networks: usize,
    /// Simulations per start of the refinement (0: network only, no ensemble).
    pub refine_evals: usize,
    /// Held-out samples re-simulated.
    pub max_resim: usize,
    pub settings: SimSettings,
    pub checks: PhysicalChecks,
}

/// One number of modes tried.
#[derive(Debug, Clone, PartialEq)]
pub struct Attempt {
    pub modes: usize,
    /// Usable and requested database samples.
    pub usable: usize,
    pub requested: usize,
    /// Per motion, the modes (1-based) whose refined weight is not interior; empty: all interior.
    pub on_edge: Vec<(String, Vec<usize>)>,
    /// Motions whose refinement failed.
    pub failed: Vec<String>,
    /// Per motion, the modes (1-based) where the network's own answer (before clipping) lies
    /// outside the trained box: the target's indexes are outside what the network was trained on,
    /// even when the refinement then finds interior weights.
    pub network_outside: Vec<(String, Vec<usize>)>,
}

impl Attempt {
    fn interior(&self) -> bool {
        self.failed.is_empty()
            && self.on_edge.iter().all(|(_, m)| m.is_empty())
            && self.network_outside.iter().all(|(_, m)| m.is_empty())
    }
}

/// How the number of modes was chosen, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct ModeChoice {
    pub modes: usize,
    pub attempts: Vec<Attempt>,
    /// The search reached `max_modes` without every network answer and refined weight interior.
    pub capped: bool,
    /// The choice in one sentence.
    pub reason: String,
}

/// The ensemble of one motion: refined weights of every network that simulates, best first.
#[derive(Debug, Clone, PartialEq)]
pub struct Ensemble {
    /// Kept members, ascending mismatch; the first is the point estimate.
    pub members: Vec<Refined>,
    /// Networks whose refinement failed or whose mismatch exceeded [`MEMBER_MISMATCH_FACTOR`] × best.
    pub dropped: usize,
}

/// A target inverted.
#[derive(Debug, Clone, PartialEq)]
pub struct TargetRun {
    pub choice: ModeChoice,
    pub db: SimulationDatabase,
    pub build_time_s: f64,
    /// The first network (seed `seed`): the summary's tables are its.
    pub model: InverseModel,
    pub held: HeldOut,
    pub motions: Vec<MotionInversion>,
    /// Per motion (same order), the ensemble; empty when the refinement was not asked for.
    pub ensembles: Vec<Ensemble>,
}

/// Per weight whether it lies inside the trained box with the margin.
pub fn inside_box(modes: &VariationModes, x: &[f64]) -> Vec<bool> {
    x.iter()
        .zip(&modes.weight_std)
        .map(|(v, s)| v.abs() <= (WEIGHT_RANGE_STD - INTERIOR_MARGIN_SIGMA) * s)
        .collect()
}

struct Stage {
    db: SimulationDatabase,
    secs: f64,
    model: InverseModel,
    motions: Vec<MotionInversion>,
}

fn stage(
    target: &TargetShip,
    modes: &VariationModes,
    given: &[(String, MotionIndexes)],
    n_modes: usize,
    o: &RunOptions,
    progress: &Progress,
) -> Result<Stage, InverseError> {
    let weights = sample_weights(modes, n_modes, o.samples, o.seed);
    let start = std::time::Instant::now();
    let db = build_database(
        target,
        modes,
        &weights,
        &o.settings,
        &o.checks,
        progress.ship,
    )?;
    let secs = start.elapsed().as_secs_f64();
    let model = InverseModel::train(
        &db,
        &TrainOptions {
            seed: o.seed,
            ..TrainOptions::default()
        },
    )?;
    let motions = given
        .iter()
        .map(|(name, q)| {
            invert_motion(
                target,
                modes,
                &db,
                &model,
                &o.settings,
                &o.checks,
                name,
                *q,
                o.refine_evals,
                progress.refinement,
            )
        })
        .collect();
    Ok(Stage {
        db,
        secs,
        model,
        motions,
    })
}

fn attempt_of(modes: &VariationModes, n: usize, st: &Stage) -> Attempt {
    let mut on_edge = Vec::new();
    let mut failed = Vec::new();
    let outside = |w: &[f64]| -> Vec<usize> {
        w.iter()
            .zip(&modes.weight_std)
            .enumerate()
            .filter(|(_, (x, s))| x.abs() > WEIGHT_RANGE_STD * **s)
            .map(|(i, _)| i + 1)
            .collect()
    };
    let network_outside = st
        .motions
        .iter()
        .map(|m| (m.name.clone(), outside(&m.network_weights)))
        .collect();
    for m in &st.motions {
        match &m.refined {
            RefineOutcome::Done { refined, .. } => on_edge.push((
                m.name.clone(),
                inside_box(modes, &refined.weights)
                    .iter()
                    .enumerate()
                    .filter(|(_, inside)| !**inside)
                    .map(|(i, _)| i + 1)
                    .collect(),
            )),
            RefineOutcome::Failed => failed.push(m.name.clone()),
            // Without refinement the network's own output is what the model uses.
            RefineOutcome::NotAsked => on_edge.push((
                m.name.clone(),
                inside_box(modes, &m.network_weights)
                    .iter()
                    .enumerate()
                    .filter(|(_, inside)| !**inside)
                    .map(|(i, _)| i + 1)
                    .collect(),
            )),
        }
    }
    Attempt {
        modes: n,
        usable: st.db.samples.len(),
        requested: st.db.requested,
        on_edge,
        failed,
        network_outside,
    }
}

/// "`name`: `what` in mode(s) 2, 4" for every motion with modes in `per_motion`.
fn modes_of<'a>(
    per_motion: &'a [(String, Vec<usize>)],
    what: &'a str,
) -> impl Iterator<Item = String> + 'a {
    per_motion
        .iter()
        .filter(|(_, m)| !m.is_empty())
        .map(move |(name, m)| {
            format!(
                "{name} {what} in mode{} {}",
                if m.len() > 1 { "s" } else { "" },
                m.iter()
                    .map(|i| i.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })
}

fn describe(a: &Attempt) -> String {
    let edge = format!("on the ±{WEIGHT_RANGE_STD}σ edge");
    let outside = format!("(the network's answer) outside the ±{WEIGHT_RANGE_STD}σ box");
    let mut parts: Vec<String> = modes_of(&a.on_edge, &edge).collect();
    parts.extend(modes_of(&a.network_outside, &outside));
    parts.extend(a.failed.iter().map(|n| format!("{n}: refinement failed")));
    parts.join("; ")
}

/// What [`run_target`] reports as it goes.
pub struct Progress<'a> {
    /// Called per simulated database ship.
    pub ship: &'a (dyn Fn() + Sync),
    /// Called per simulation of a refinement (the first network's and the ensemble's).
    pub refinement: &'a (dyn Fn() + Sync),
}

/// Inverts every motion of `target`: modes chosen (grown from `start_modes` by `mode_step` up to
/// `max_modes` until every network answer and refined weight is interior, or `fixed_modes`), then the
/// ensemble. `progress` says how it goes.
pub fn run_target(
    target: &TargetShip,
    modes: &VariationModes,
    given: &[(String, MotionIndexes)],
    o: &RunOptions,
    progress: &Progress,
) -> Result<TargetRun, InverseError> {
    let available = modes.singular_values.len();
    let candidates: Vec<usize> = match o.fixed_modes {
        Some(n) => vec![n],
        None => {
            let mut c = vec![o.start_modes.min(o.max_modes)];
            while let Some(&last) = c.last()
                && last < o.max_modes
            {
                c.push((last + o.mode_step.max(1)).min(o.max_modes));
            }
            c
        }
    };
    if let Some(&bad) = candidates.iter().find(|&&n| n == 0 || n > available) {
        return Err(InverseError::Invalid(format!(
            "{bad} modes: the database has {available} modes, give 1–{available}"
        )));
    }
    let mut attempts = Vec::new();
    let mut chosen: Option<(usize, Stage)> = None;
    let mut short: Option<String> = None;
    for &n in &candidates {
        let st = match stage(target, modes, given, n, o, progress) {
            Ok(st) => st,
            // More modes draw more unphysical ships: when too few remain to train on, the search
            // keeps the last count that could be trained and says why it stopped.
            Err(InverseError::TooFewSamples { valid, total, .. }) if chosen.is_some() => {
                short = Some(format!(
                    "search stopped at {n} modes: only {valid} of {total} simulated ships usable"
                ));
                break;
            }
            Err(e) => return Err(e),
        };
        let a = attempt_of(modes, n, &st);
        let done = a.interior();
        attempts.push(a);
        chosen = Some((n, st));
        if done {
            break;
        }
    }
    let (n_modes, st) = chosen.ok_or_else(|| InverseError::Invalid("no mode count".into()))?;
    let last = &attempts[attempts.len() - 1];
    let capped = !last.interior();
    let history = attempts
        .iter()
        .filter(|a| !a.interior())
        .map(|a| format!("{} modes: {}", a.modes, describe(a)))
        .collect::<Vec<_>>()
        .join("; ");
    let reason = match (o.fixed_modes, capped, &short) {
        (None, true, Some(why)) => format!(
            "{n_modes} modes, not interior ({history}); {why}; the weights on the edge are flagged"
        ),
        _ => String::new(),
    };
    let reason = if !reason.is_empty() {
        reason
    } else {
        match (o.fixed_modes, capped) {
            (Some(n), false) => {
                format!(
                    "{n} modes as asked (--modes); every network answer and refined weight is \
                     interior"
                )
            }
            (Some(n), true) => format!(
                "{n} modes as asked (--modes); not interior: {}",
                describe(last)
            ),
            (None, false) if attempts.len() == 1 => format!(
                "{n_modes} modes (the fewest reaching 95 % of the variation): every network answer \
                 and refined weight lies inside ±{}σ",
                WEIGHT_RANGE_STD - INTERIOR_MARGIN_SIGMA
            ),
            (None, false) => format!(
                "{n_modes} modes: the fewest (from {} in steps of {}) with every network answer and \
                 refined weight inside ±{}σ; {history}",
                o.start_modes,
                o.mode_step,
                WEIGHT_RANGE_STD - INTERIOR_MARGIN_SIGMA
            ),
            (None, true) => format!(
                "cap of {} modes reached without every network answer and refined weight interior \
                 ({history}); the weights on the edge are flagged",
                o.max_modes
            ),
        }
    };
    let held = held_out(
        target,
        modes,
        &st.db,
        &st.model,
        &o.settings,
        &o.checks,
        o.max_resim,
    );
    let ensembles = if o.refine_evals == 0 {
        Vec::new()
    } else {
        ensembles(target, modes, given, &st, &held, o, progress.refinement)?
    };
    Ok(TargetRun {
        choice: ModeChoice {
            modes: n_modes,
            attempts,
            capped,
            reason,
        },
        db: st.db,
        build_time_s: st.secs,
        model: st.model,
        held,
        motions: st.motions,
        ensembles,
    })
}

/// Refinement starts per round jittered around the best match so far: with [`MAX_RESTART_ROUNDS`]
/// rounds, enough for a band's [`BAND_MEMBERS`] when every network's answer is an unphysical ship.
pub const BEST_RESTARTS_PER_ROUND: usize = BAND_MEMBERS.div_ceil(MAX_RESTART_ROUNDS) + 1;

/// Refinement restarts per network: its own answer and this many less one starts jittered around it.
pub const RESTARTS_PER_NETWORK: usize = 6;
/// Members a band needs: the bands' fewest defining replicates (`shipid_pipeline::bands`). An ensemble
/// with fewer kept members after a round of restarts gets another round, up to
/// [`MAX_RESTART_ROUNDS`].
pub const BAND_MEMBERS: usize = 20;
/// Refinement starts of one motion at most: the first network's two (its answer and the nearest
/// database ship) per number of modes tried, and [`MAX_RESTART_ROUNDS`] rounds of the ensemble's.
pub fn max_refinement_starts(networks: usize, mode_attempts: usize) -> usize {
    2 * mode_attempts
        + MAX_RESTART_ROUNDS * (networks.max(1) * RESTARTS_PER_NETWORK + BEST_RESTARTS_PER_ROUND)
}

/// Rounds of restarts at most (each [`RESTARTS_PER_NETWORK`] − 1 jittered starts per network).
pub const MAX_RESTART_ROUNDS: usize = 3;
/// Half-width of the uniform jitter of a restart's start, per mode [σ_i].
pub const RESTART_JITTER_SIGMA: f64 = 1.0;

/// The ensemble of each motion: the other networks, trained on the same database with their own seeds
/// (their own initialisation, split and batches), and per network [`RESTARTS_PER_NETWORK`]
/// refinements (from its answer and from seeded starts jittered by ±[`RESTART_JITTER_SIGMA`] σ around
/// it), and [`BEST_RESTARTS_PER_ROUND`] refinements from starts jittered around the best match so
/// far, all with the first network's mismatch (so that members are compared on one scale), together
/// with the first network's own refinement; members ranked by mismatch. Networks see the indexes
/// differently; restarts find the other weights that match them about as well: the spread of both is
/// what the indexes leave undetermined.
fn ensembles(
    target: &TargetShip,
    modes: &VariationModes,
    given: &[(String, MotionIndexes)],
    st: &Stage,
    held: &HeldOut,
    o: &RunOptions,
    on_eval: &(dyn Fn() + Sync),
) -> Result<Vec<Ensemble>, InverseError> {
    let others: Vec<InverseModel> = (1..o.networks.max(1) as u64)
        .into_par_iter()
        .map(|k| {
            InverseModel::train(
                &st.db,
                &TrainOptions {
                    seed: o.seed.wrapping_add(k),
                    ..TrainOptions::default()
                },
            )
        })
        .collect::<Result<_, _>>()?;
    let nets: Vec<&InverseModel> = std::iter::once(&st.model).chain(&others).collect();
    Ok(given
        .iter()
        .zip(&st.motions)
        .enumerate()
        .map(|(motion, ((_, q), m))| {
            // A ship whose indexes miss the target by the network's own held-out errors matches it
            // as well as the method can tell: a best member far better than that is luck, not
            // information, and 4 × its mismatch would keep too few.
            let precision = match &held.index_mare {
                Some(mare) if mare.iter().all(|e| e.is_finite()) => {
                    mismatch_of_relative_errors(&st.model, q, mare)
                }
                _ => 0.0,
            };
            let mut candidates: Vec<Refined> = Vec::new();
            if let RefineOutcome::Done { refined, .. } = &m.refined {
                candidates.push(refined.clone());
            }
            let mut tried = 1;
            let mut members = Vec::new();
            for round in 0..MAX_RESTART_ROUNDS {
                let mut starts: Vec<Vec<f64>> = Vec::new();
                for (k, net) in nets.iter().enumerate() {
                    let (answer, _) = clip_weights(modes, &net.predict(q));
                    let mut rng = ChaCha8Rng::seed_from_u64(
                        o.seed
                            .wrapping_add(1000 * k as u64)
                            .wrapping_add(motion as u64)
                            .wrapping_add(1_000_000 * round as u64),
                    );
                    // The first network's own answer is refined already (with the nearest ship).
                    if k > 0 && round == 0 {
                        starts.push(answer.clone());
                    }
                    for _ in 1..RESTARTS_PER_NETWORK {
                        starts.push(jittered(modes, &answer, &mut rng));
                    }
                }
                // Jittered around the best match so far too: a target outside the trained box
                // (network answers clipped to its edge, often unphysical ships) has its only
                // simulating starts near the refined answer, and the spread of the weights that match
                // the indexes about as well is what the ensemble is for.
                if let Some(best) = candidates
                    .iter()
                    .min_by(|a, b| a.objective.total_cmp(&b.objective))
                {
                    let mut rng = ChaCha8Rng::seed_from_u64(
                        o.seed
                            .wrapping_add(999_999)
                            .wrapping_add(motion as u64)
                            .wrapping_add(1_000_000 * round as u64),
                    );
                    for _ in 0..BEST_RESTARTS_PER_ROUND {
                        starts.push(jittered(modes, &best.weights, &mut rng));
                    }
                }
                tried += starts.len();
                candidates.par_extend(starts.par_iter().filter_map(|start| {
                    refine(
                        target,
                        modes,
                        &st.model,
                        q,
                        std::slice::from_ref(start),
                        &o.settings,
                        &o.checks,
                        o.refine_evals,
                        on_eval,
                    )
                }));
                candidates.sort_by(|a, b| a.objective.total_cmp(&b.objective));
                members = candidates.clone();
                if let Some(best) = members.first().map(|b| b.objective) {
                    members.retain(|r| r.objective <= member_tolerance(best, precision));
                }
                if members.len() >= BAND_MEMBERS {
                    break;
                }
            }
            Ensemble {
                dropped: tried - members.len(),
                members,
            }
        })
        .collect())
}

/// A restart's start: `around` moved by a uniform ±[`RESTART_JITTER_SIGMA`] σ per mode, clipped to
/// the box.
fn jittered(modes: &VariationModes, around: &[f64], rng: &mut ChaCha8Rng) -> Vec<f64> {
    let moved: Vec<f64> = around
        .iter()
        .zip(&modes.weight_std)
        .map(|(x, s)| x + RESTART_JITTER_SIGMA * s * rng.random_range(-1.0..=1.0))
        .collect();
    clip_weights(modes, &moved).0
}

/// The largest mismatch of a kept member: [`MEMBER_MISMATCH_FACTOR`] × the best one's, and never
/// below `precision`, the mismatch of a ship that misses the indexes by the network's held-out
/// errors.
pub fn member_tolerance(best: f64, precision: f64) -> f64 {
    (MEMBER_MISMATCH_FACTOR * best.max(1e-12)).max(precision)
}

/// An ensemble's members as MMG parameter vectors ([`crate::physical::MODEL_FILE_NAMES`] order) and
/// their spread; `None` for fewer than two members (no band).
pub fn member_parameters(
    target: &TargetShip,
    modes: &VariationModes,
    e: &Ensemble,
) -> Option<(Vec<Vec<f64>>, shipid_uncertainty::Spread)> {
    let vectors: Vec<Vec<f64>> = e
        .members
        .iter()
        .filter_map(|m| {
            let c = modes.generate(&m.weights).ok()?;
            Some(crate::physical::model_file_values(&target.mmg_parameters(&c)).to_vec())
        })
        .collect();
    let spread = shipid_uncertainty::spread(&vectors).ok()?;
    Some((vectors, spread))
}
