//! Parameter uncertainty of a polynomial (Abkowitz) or mmg fit by a moving-block bootstrap.
//!
//! Each replicate redraws the training rows in blocks (within each recording, see
//! `shipid_uncertainty::resample`) and refits every DOF with the estimator *as resolved by the
//! original fit* (the same λ, α, C, ε: re-tuning inside every replicate would add the tuning's own
//! variance and cost a cross-validation per replicate; holding it fixed measures how much the data
//! move the coefficients for the choice the user got). The block length is the longest of the
//! decorrelation lags of the equation-error residuals over the DOFs and recordings, so that the most
//! slowly varying residual decides. A refined model (output error) is not refitted per replicate: its
//! replicates are the refined coefficients shifted by each replicate's departure from the
//! equation-error fit (the spread the data allow, centred on the model the user has). The mmg family
//! ([`bootstrap_mmg`]) is bootstrapped the same way over its equation-error samples, each replicate
//! re-identified by the family's variable projection with the resolved prior weight. No I/O.

use rayon::prelude::*;
use serde::Serialize;
use shipid_estimators::{Bounds, Estimator, Solver, Status, predict};
use shipid_io::Dataset;
use std::collections::BTreeMap;

use shipid_model::{AbkowitzModel, BootstrapRecord, Design, Dof, PrimeInertia, Samples, design};
use shipid_sim::{AbkowitzDynamics, Dynamics};
use shipid_uncertainty::{BlockLength, SplitMix64, block_length, replicate_rows, spread};

use crate::error::{PipelineError, bad_input};
use crate::mmg::file::{MmgBootstrapRecord, ReplicateKind};
use crate::mmg::identify::EqSample;
use crate::mmg::priors::{NONLINEAR_NAMES, ParamSpec, Role};
use crate::mmg::{MmgFit, MmgFitOptions, refit_problem};

/// The bootstrap in words, as the model file states it.
pub const METHOD: &str = "moving-block bootstrap of the training rows (blocks within each recording), \
every DOF refitted with the estimator and hyper-parameters the fit chose; a refined model's \
replicates are its coefficients shifted by each replicate's departure from the equation-error fit";

/// Largest number of replicates a fit may ask for (memory: replicates × coefficients numbers, and
/// each is one refit of three DOFs).
pub const MAX_REPLICATES: usize = 10_000;

/// The replicated coefficients of a fit.
#[derive(Debug, Clone, Serialize)]
pub struct Bootstrap {
    /// Replicates in draw order; each holds the coefficients per DOF in the set's term order.
    pub replicates: Vec<[Vec<f64>; 3]>,
    /// The block length used and how it was chosen.
    pub block: BlockLength,
    /// Seed of the replicate draws (SplitMix64).
    pub seed: u64,
    /// Replicate fits whose solver did not report `Ok` (kept out of `replicates`).
    pub rejected: usize,
}

impl Bootstrap {
    /// The model file's `[bootstrap]` table for replicates of `model`'s set.
    pub fn record(&self, model: &AbkowitzModel) -> BootstrapRecord {
        let mut standard_error = BTreeMap::new();
        let mut correlation = BTreeMap::new();
        let mut replicates = BTreeMap::new();
        for dof in Dof::ALL {
            let names = model.set.names(dof);
            let vectors: Vec<Vec<f64>> = self
                .replicates
                .iter()
                .map(|r| r[dof.index()].clone())
                .collect();
            if let Ok(s) = spread(&vectors) {
                standard_error.insert(
                    dof.as_str().to_string(),
                    names.iter().cloned().zip(s.std_error).collect(),
                );
                correlation.insert(dof.as_str().to_string(), s.correlation);
            }
            replicates.insert(
                dof.as_str().to_string(),
                names
                    .iter()
                    .enumerate()
                    .map(|(j, n)| (n.clone(), vectors.iter().map(|v| v[j]).collect()))
                    .collect(),
            );
        }
        BootstrapRecord {
            method: METHOD.into(),
            seed: self.seed,
            block_rows: self.block.rows,
            block_reason: block_reason(&self.block),
            rejected: self.rejected,
            standard_error,
            correlation,
            replicates,
        }
    }

    /// The replicates as simulation models of `base`'s set, ship and added masses (a replicate the model
    /// constructor rejects, e.g. a singular mass matrix, is left out).
    pub fn models(&self, base: &AbkowitzModel) -> Vec<Box<dyn Dynamics + Send + Sync>> {
        self.replicates
            .iter()
            .filter_map(|c| {
                AbkowitzModel::new(base.set.clone(), c.clone(), base.ship, base.added_mass).ok()
            })
            .map(|m| Box::new(AbkowitzDynamics(m)) as Box<dyn Dynamics + Send + Sync>)
            .collect()
    }
}

/// Why the block has its length, as the model file states it.
fn block_reason(block: &BlockLength) -> String {
    match block.decorrelation_lag {
        Some(lag) => format!(
            "the equation-error residuals decorrelate after {lag} rows (autocorrelation inside \
             ±2/√n); floor n^(1/3) = {}, cap n/4 = {} rows",
            block.floor_rows, block.cap_rows
        ),
        None => format!(
            "the equation-error residuals stay correlated up to n/4 = {} rows: the cap",
            block.cap_rows
        ),
    }
}

/// The generator of replicate `k`, seeded from (seed, k): the draws do not depend on the number of
/// threads or the order replicates finish in.
pub fn replicate_rng(seed: u64, k: usize) -> SplitMix64 {
    SplitMix64::new(seed ^ (k as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15))
}

/// The block of the longest decorrelation lag over the residual series (one per DOF and recording).
fn longest_block<'a>(series: impl Iterator<Item = &'a [f64]>) -> Option<BlockLength> {
    let mut block: Option<BlockLength> = None;
    for s in series {
        let b = block_length(s);
        if block.is_none_or(|old| b.rows > old.rows) {
            block = Some(b);
        }
    }
    block
}

fn check_replicates(replicates: usize) -> Result<(), PipelineError> {
    if !(2..=MAX_REPLICATES).contains(&replicates) {
        return Err(bad_input(format!(
            "--bootstrap must be between 2 and {MAX_REPLICATES} replicates, got {replicates}"
        )));
    }
    Ok(())
}

/// The contiguous row range of every recording (group) of the rows, in order.
fn group_ranges(group: &[usize]) -> Vec<std::ops::Range<usize>> {
    let mut ranges: Vec<std::ops::Range<usize>> = Vec::new();
    for (i, g) in group.iter().enumerate() {
        match ranges.last_mut() {
            Some(r) if group[r.start] == *g => r.end = i + 1,
            _ => ranges.push(i..i + 1),
        }
    }
    ranges
}

/// A design restricted to `rows` (repeats allowed).
fn rows_of(d: &Design, rows: &[usize]) -> (faer::Mat<f64>, Vec<f64>) {
    let phi = faer::Mat::from_fn(rows.len(), d.phi.ncols(), |i, j| d.phi[(rows[i], j)]);
    (phi, rows.iter().map(|&r| d.y[r]).collect())
}

/// Bootstrap `replicates` refits of `model` (fitted to `samples` of `ds` with the per-DOF estimators
/// `estimators`, bounded when `bounded`), and shift them to `centre` (the refined coefficients, or the
/// fit's own).
#[allow(clippy::too_many_arguments)]
pub fn bootstrap_abkowitz(
    ds: &Dataset,
    model: &AbkowitzModel,
    centre: &[Vec<f64>; 3],
    samples: &Samples,
    estimators: &[Estimator; 3],
    bounded: bool,
    solver: Solver,
    replicates: usize,
    seed: u64,
) -> Result<Bootstrap, PipelineError> {
    check_replicates(replicates)?;
    let added = ds
        .added_mass
        .ok_or_else(|| bad_input(format!("{}: no [added_mass] table", ds.path.display())))?;
    let inertia = PrimeInertia::new(&ds.ship, &added, &model.set);
    let designs: Vec<Design> = Dof::ALL
        .iter()
        .map(|&dof| design(&model.set, dof, samples, &inertia))
        .collect();
    let bounds: Vec<Option<Bounds>> = designs
        .iter()
        .map(|d| {
            if bounded && model.set.has_bounds(d.dof) {
                let (lo, hi): (Vec<f64>, Vec<f64>) = d.bounds.iter().copied().unzip();
                Bounds::new(lo, hi).ok()
            } else {
                None
            }
        })
        .collect();
    let groups = group_ranges(&samples.group);
    // The longest decorrelation lag over DOFs and recordings decides the block.
    let residuals: Vec<Vec<f64>> = designs
        .iter()
        .zip(Dof::ALL)
        .map(|(d, dof)| {
            let pred =
                predict(d.phi.as_ref(), &model.coefficients[dof.index()]).unwrap_or_default();
            pred.iter().zip(&d.y).map(|(p, y)| y - p).collect()
        })
        .collect();
    let block = longest_block(
        residuals
            .iter()
            .flat_map(|r| groups.iter().map(move |g| &r[g.clone()])),
    )
    .ok_or_else(|| bad_input("no training rows to bootstrap"))?;
    let fits: Vec<Option<[Vec<f64>; 3]>> = (0..replicates)
        .into_par_iter()
        .map(|k| {
            let mut rng = replicate_rng(seed, k);
            let rows = replicate_rows(&groups, block.rows, &mut rng).ok()?;
            let mut out: [Vec<f64>; 3] = Default::default();
            for (i, d) in designs.iter().enumerate() {
                let (phi, y) = rows_of(d, &rows);
                let fit = shipid_estimators::fit(
                    phi.as_ref(),
                    &y,
                    &estimators[i],
                    bounds[i].as_ref(),
                    solver,
                )
                .ok()?;
                // A replicate whose solve did not converge, or whose blocks left a column without
                // information, is no draw of the coefficients: counted, not kept.
                if !matches!(fit.status, Status::Ok | Status::IllConditioned { .. }) {
                    return None;
                }
                out[i] = fit
                    .coefficients
                    .iter()
                    .zip(&model.coefficients[i])
                    .zip(&centre[i])
                    .map(|((rep, fitted), c)| c + (rep - fitted))
                    .collect();
            }
            Some(out)
        })
        .collect();
    let rejected = fits.iter().filter(|f| f.is_none()).count();
    Ok(Bootstrap {
        replicates: fits.into_iter().flatten().collect(),
        block,
        seed,
        rejected,
    })
}

/// Bootstrap a finished fit (`shipid fit --bootstrap N`): replicates around the model the fit wrote
/// (refined or not), with the estimators it resolved.
pub fn bootstrap_fit(
    ds: &Dataset,
    out: &crate::fit::FitOutput,
    spec: &crate::fit::EstimatorSpec,
    solver: Solver,
    replicates: usize,
    seed: u64,
) -> Result<Bootstrap, PipelineError> {
    let estimators = [0, 1, 2].map(|i| out.dofs[i].fit.estimator);
    // The equation-error coefficients (before any refinement) are what each replicate departs from.
    let equation_error = AbkowitzModel::new(
        out.model.set.clone(),
        [0, 1, 2].map(|i| out.dofs[i].fit.coefficients.clone()),
        out.model.ship,
        out.model.added_mass,
    )
    .map_err(|e| bad_input(format!("the equation-error fit is unusable: {e}")))?;
    bootstrap_abkowitz(
        ds,
        &equation_error,
        &out.model.coefficients,
        &out.training,
        &estimators,
        spec.uses_bounds(),
        solver,
        replicates,
        seed,
    )
}

/// The mmg bootstrap in words, as the model file states it.
pub const MMG_METHOD: &str = "moving-block bootstrap of the equation-error samples (blocks within each \
recording), every replicate re-identified by the same variable projection with the estimator and the \
prior weight λ the fit resolved (held fixed), started from the fit; the replicates are the file's \
parameters shifted by each replicate's departure from the equation-error estimate, kept inside the \
parameters' bounds";

/// The replicated parameters of an mmg fit.
#[derive(Debug, Clone, Serialize)]
pub struct MmgBootstrap {
    /// Parameter names in the order of every replicate (the model file's `[[parameter]]` order).
    pub names: Vec<String>,
    /// Replicates in draw order.
    pub replicates: Vec<Vec<f64>>,
    pub block: BlockLength,
    pub seed: u64,
    /// Replicates whose re-identification failed (kept out of `replicates`).
    pub rejected: usize,
}

impl MmgBootstrap {
    /// The model file's `[bootstrap]` table.
    pub fn record(&self) -> MmgBootstrapRecord {
        let spread = spread(&self.replicates).ok();
        MmgBootstrapRecord {
            replicate_kind: ReplicateKind::BlockBootstrap,
            method: MMG_METHOD.into(),
            seed: self.seed,
            block_rows: self.block.rows,
            block_reason: block_reason(&self.block),
            rejected: self.rejected,
            standard_error: spread
                .as_ref()
                .map(|s| {
                    self.names
                        .iter()
                        .cloned()
                        .zip(s.std_error.clone())
                        .collect()
                })
                .unwrap_or_default(),
            order: self.names.clone(),
            correlation: spread.map(|s| s.correlation).unwrap_or_default(),
            replicates: self
                .names
                .iter()
                .enumerate()
                .map(|(j, n)| (n.clone(), self.replicates.iter().map(|r| r[j]).collect()))
                .collect(),
        }
    }
}

/// θ (every parameter, in the order of `specs`) of the outer parameters φ and the hull derivatives
/// β; a parameter of neither keeps its prior.
fn mmg_theta(specs: &[ParamSpec], phi: &[f64], beta: &[Vec<f64>; 3]) -> Vec<f64> {
    specs
        .iter()
        .map(|s| match s.role {
            Role::Hull { dof, column } => beta[dof][column],
            Role::Nonlinear => NONLINEAR_NAMES
                .iter()
                .position(|n| *n == s.name)
                .map_or(s.prior, |k| phi[k]),
        })
        .collect()
}

/// Bootstrap `replicates` re-identifications of the mmg fit `fit` (the model the file holds, refined
/// or not) on the training samples of `opts` in `ds`, with the fit's estimator, priors and prior
/// weight λ held fixed.
///
/// Each replicate starts from the equation-error estimate φ̂ (a local identification: the bootstrap
/// measures how the data move the estimate the user got, not which other minima exist). The
/// equation-error estimate the departures are measured from is one solve on all samples from the
/// file's φ: the fit itself when unrefined, the equation-error optimum nearest the refined model
/// otherwise.
pub fn bootstrap_mmg(
    ds: &Dataset,
    fit: &MmgFit,
    opts: &MmgFitOptions,
    replicates: usize,
    seed: u64,
) -> Result<MmgBootstrap, PipelineError> {
    check_replicates(replicates)?;
    let (problem, start) = refit_problem(ds, fit, opts)?;
    let centre: Vec<f64> = fit.estimate.params.iter().map(|p| p.value).collect();
    let all: Vec<usize> = (0..problem.samples.len()).collect();
    let (phi_hat, beta_hat, _) = problem.solve(&start, &all, fit.lambda)?;
    let theta_hat = mmg_theta(&problem.specs, &phi_hat, &beta_hat);
    // Residuals of the equation error (prime forces per DOF) for the block length.
    let model = problem.model_of(&phi_hat, &beta_hat, fit.propeller_rate_hz)?;
    let q_of =
        |s: &EqSample| 0.5 * ds.ship.rho * ds.ship.lpp * ds.ship.draft * s.state.speed().powi(2);
    let residuals: Vec<Vec<f64>> = (0..3)
        .map(|d| {
            problem
                .samples
                .iter()
                .map(|s| {
                    let lever = if d == 2 { ds.ship.lpp } else { 1.0 };
                    model
                        .forces_at_rate(&s.state, s.delta_rad, s.n_hz)
                        .map_or(f64::NAN, |f| {
                            (s.needed[d] - f.total()[d]) / (q_of(s) * lever)
                        })
                })
                .collect()
        })
        .collect();
    let group: Vec<usize> = problem.samples.iter().map(|s| s.group).collect();
    let groups = group_ranges(&group);
    let block = longest_block(
        residuals
            .iter()
            .flat_map(|r| groups.iter().map(move |g| &r[g.clone()])),
    )
    .ok_or_else(|| bad_input("no training samples to bootstrap"))?;
    // Each replicate's departure from the all-sample estimate θ̂.
    let departures: Vec<Option<Vec<f64>>> = (0..replicates)
        .into_par_iter()
        .map(|k| {
            let rows = replicate_rows(&groups, block.rows, &mut replicate_rng(seed, k)).ok()?;
            let (phi, beta, _) = problem.solve(&phi_hat, &rows, fit.lambda).ok()?;
            let theta = mmg_theta(&problem.specs, &phi, &beta);
            let d: Vec<f64> = theta.iter().zip(&theta_hat).map(|(t, h)| t - h).collect();
            d.iter().all(|v| v.is_finite()).then_some(d)
        })
        .collect();
    // A resample repeats blocks and so holds less information than the data; the prior pulls each
    // refit towards itself a little more than it pulls the fit, and where the prior sits far from what
    // the data show every replicate lands on the prior's side (a full-scale ship, whose resistance
    // prior is Reynolds-scaled: every replicate's R′0 below the fit's, a band beside its own point
    // prediction). The cloud is centred on the fit: the mean departure (the bootstrap's estimate of
    // that bias) is taken out of every replicate, which keeps the spread.
    let kept: Vec<&Vec<f64>> = departures.iter().flatten().collect();
    let bias: Vec<f64> = (0..theta_hat.len())
        .map(|j| kept.iter().map(|d| d[j]).sum::<f64>() / kept.len().max(1) as f64)
        .collect();
    let fits: Vec<Option<Vec<f64>>> = departures
        .into_iter()
        .map(|d| {
            let d = d?;
            let shifted: Vec<f64> = problem
                .specs
                .iter()
                .zip(d.iter().zip(&bias).zip(&centre))
                .map(|(s, ((d, b), c))| (c + d - b).clamp(s.lower, s.upper))
                .collect();
            shifted.iter().all(|v| v.is_finite()).then_some(shifted)
        })
        .collect();
    let rejected = fits.iter().filter(|f| f.is_none()).count();
    Ok(MmgBootstrap {
        names: problem.specs.iter().map(|s| s.name.to_string()).collect(),
        replicates: fits.into_iter().flatten().collect(),
        block,
        seed,
        rejected,
    })
}
