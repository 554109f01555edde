//! Parameter uncertainty of a polynomial (Abkowitz) fit by a moving-block bootstrap.
//!
//! Each replicate redraws the training rows in blocks (within each recording, see
//! `shipid_uncertainty::resample`) and refits every DOF with the estimator *as resolved by the
//! original fit* (the same λ, α, C, ε: re-tuning inside every replicate would add the tuning's own
//! variance and cost a cross-validation per replicate; holding it fixed measures how much the data
//! move the coefficients for the choice the user got). The block length is the longest of the
//! decorrelation lags of the equation-error residuals over the DOFs and recordings, so that the most
//! slowly varying residual decides. A refined model (output error) is not refitted per replicate: its
//! replicates are the refined coefficients shifted by each replicate's departure from the
//! equation-error fit (the spread the data allow, centred on the model the user has). No I/O.

use rayon::prelude::*;
use serde::Serialize;
use shipid_estimators::{Bounds, Estimator, Solver, Status, predict};
use shipid_io::Dataset;
use std::collections::BTreeMap;

use shipid_model::{AbkowitzModel, BootstrapRecord, Design, Dof, PrimeInertia, Samples, design};
use shipid_sim::{AbkowitzDynamics, Dynamics};
use shipid_uncertainty::{BlockLength, SplitMix64, block_length, replicate_rows, spread};

use crate::error::{PipelineError, bad_input};

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
            block_reason: match self.block.decorrelation_lag {
                Some(lag) => format!(
                    "the equation-error residuals decorrelate after {lag} rows (autocorrelation \
                     inside ±2/√n); floor n^(1/3) = {}, cap n/4 = {} rows",
                    self.block.floor_rows, self.block.cap_rows
                ),
                None => format!(
                    "the equation-error residuals stay correlated up to n/4 = {} rows: the cap",
                    self.block.cap_rows
                ),
            },
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

/// The contiguous row range of every recording (group) of the samples, in order.
fn group_ranges(samples: &Samples) -> Vec<std::ops::Range<usize>> {
    let mut ranges: Vec<std::ops::Range<usize>> = Vec::new();
    for (i, g) in samples.group.iter().enumerate() {
        match ranges.last_mut() {
            Some(r) if samples.group[r.start] == *g => r.end = i + 1,
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
    if !(2..=MAX_REPLICATES).contains(&replicates) {
        return Err(bad_input(format!(
            "--bootstrap must be between 2 and {MAX_REPLICATES} replicates, got {replicates}"
        )));
    }
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
    let groups = group_ranges(samples);
    // The longest decorrelation lag over DOFs and recordings decides the block.
    let mut block: Option<BlockLength> = None;
    for (d, dof) in designs.iter().zip(Dof::ALL) {
        let pred = predict(d.phi.as_ref(), &model.coefficients[dof.index()]).unwrap_or_default();
        let resid: Vec<f64> = pred.iter().zip(&d.y).map(|(p, y)| y - p).collect();
        for g in &groups {
            let b = block_length(&resid[g.clone()]);
            if block.is_none_or(|old| b.rows > old.rows) {
                block = Some(b);
            }
        }
    }
    let block = block.ok_or_else(|| bad_input("no training rows to bootstrap"))?;
    let fits: Vec<Option<[Vec<f64>; 3]>> = (0..replicates)
        .into_par_iter()
        .map(|k| {
            // One generator per replicate, seeded from (seed, k): the draws do not depend on the
            // number of threads or the order replicates finish in.
            let mut rng = SplitMix64::new(seed ^ (k as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
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
