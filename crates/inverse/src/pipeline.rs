//! Paper 003's pipeline: sample mode weights, simulate the target ship's motion indexes (the simulation
//! database), train the inverse network indexes → weights, and invert given indexes.

use rand::Rng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;
use rayon::prelude::*;

use crate::database::Coefficients;
use crate::error::InverseError;
use crate::indexes::{IndexFailure, MotionIndexes, N_INDEXES, SimSettings, motion_indexes};
use crate::mlp::{Mlp, TrainOptions, TrainReport};
use crate::modes::VariationModes;
use crate::physical::PhysicalChecks;
use crate::target::TargetShip;

/// Mode weights are drawn uniformly within ± this many standard deviations (paper 003 §2.2).
pub const WEIGHT_RANGE_STD: f64 = 3.0;
/// Hidden layers of the inverse network (paper 003 §3.1).
pub const HIDDEN: [usize; 2] = [30, 30];

/// One simulated ship of the database.
#[derive(Debug, Clone, PartialEq)]
pub struct Sample {
    /// Mode weights x_i.
    pub weights: Vec<f64>,
    /// Its simulated indexes.
    pub indexes: MotionIndexes,
}

/// The simulation database of one target ship.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulationDatabase {
    /// Samples with all nine indexes, in draw order.
    pub samples: Vec<Sample>,
    /// Dropped draws: (draw number, why).
    pub dropped: Vec<(usize, IndexFailure)>,
    /// Draws requested.
    pub requested: usize,
}

impl SimulationDatabase {
    /// Why draws were dropped, counted by kind ("12 × turn +35 diverged; 3 × …"), most frequent
    /// first; "none" when nothing was.
    pub fn dropped_summary(&self) -> String {
        let mut kinds: std::collections::BTreeMap<String, usize> = Default::default();
        for (_, f) in &self.dropped {
            *kinds.entry(f.kind()).or_default() += 1;
        }
        if kinds.is_empty() {
            return "none".into();
        }
        let mut counted: Vec<(String, usize)> = kinds.into_iter().collect();
        counted.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
        counted
            .iter()
            .map(|(k, n)| format!("{n} × {k}"))
            .collect::<Vec<_>>()
            .join("; ")
    }

    /// The smallest and largest value of each index over the usable samples: a target index outside
    /// it is one no simulated ship reached, so the network extrapolates there.
    pub fn index_range(&self) -> [(f64, f64); N_INDEXES] {
        std::array::from_fn(|i| {
            self.samples
                .iter()
                .map(|s| s.indexes.0[i])
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(v), hi.max(v))
                })
        })
    }
}

/// `n` weight vectors of the first `n_modes` modes, uniform in ±3 σ_i, from `seed`.
pub fn sample_weights(
    modes: &VariationModes,
    n_modes: usize,
    n: usize,
    seed: u64,
) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            modes.weight_std[..n_modes]
                .iter()
                .map(|s| WEIGHT_RANGE_STD * s * rng.random_range(-1.0..=1.0))
                .collect()
        })
        .collect()
}

/// Indexes of the target with the coefficients of weights `x`; a ship that fails `checks` is
/// [`IndexFailure::Unphysical`] before any simulation.
pub fn simulate_weights(
    target: &TargetShip,
    modes: &VariationModes,
    x: &[f64],
    settings: &SimSettings,
    checks: &PhysicalChecks,
) -> Result<MotionIndexes, IndexFailure> {
    let c: Coefficients = modes.generate(x).map_err(|_| IndexFailure::NoModel)?;
    let model = target.model(&c).ok_or(IndexFailure::NoModel)?;
    checks.check(&model).map_err(IndexFailure::Unphysical)?;
    motion_indexes(&model, settings)
}

/// Simulates every weight vector in parallel (rayon); `tick` is called once per finished draw (for a
/// progress bar). Draws that fail are dropped and listed.
pub fn build_database(
    target: &TargetShip,
    modes: &VariationModes,
    weights: &[Vec<f64>],
    settings: &SimSettings,
    checks: &PhysicalChecks,
    tick: &(dyn Fn() + Sync),
) -> Result<SimulationDatabase, InverseError> {
    target.validate()?;
    let results: Vec<Result<MotionIndexes, IndexFailure>> = weights
        .par_iter()
        .map(|x| {
            let r = simulate_weights(target, modes, x, settings, checks);
            tick();
            r
        })
        .collect();
    let mut samples = Vec::new();
    let mut dropped = Vec::new();
    for (k, (x, r)) in weights.iter().zip(results).enumerate() {
        match r {
            Ok(q) if q.0.iter().all(|v| v.is_finite() && *v != 0.0) => samples.push(Sample {
                weights: x.clone(),
                indexes: q,
            }),
            Ok(_) => dropped.push((
                k,
                IndexFailure::Missing {
                    manoeuvre: "all",
                    what: "finite non-zero indexes",
                },
            )),
            Err(e) => dropped.push((k, e)),
        }
    }
    Ok(SimulationDatabase {
        samples,
        dropped,
        requested: weights.len(),
    })
}

/// Per-column mean and standard deviation.
#[derive(Debug, Clone, PartialEq)]
pub struct Standardiser {
    pub mean: Vec<f64>,
    pub std: Vec<f64>,
}

impl Standardiser {
    /// Fitted to the rows `rows`; a constant column gets std 1.
    pub fn fit(rows: &[Vec<f64>]) -> Standardiser {
        let n = rows.len().max(1) as f64;
        let k = rows.first().map_or(0, |r| r.len());
        let mean: Vec<f64> = (0..k)
            .map(|j| rows.iter().map(|r| r[j]).sum::<f64>() / n)
            .collect();
        let std = (0..k)
            .map(|j| {
                let s = (rows.iter().map(|r| (r[j] - mean[j]).powi(2)).sum::<f64>() / n).sqrt();
                if s > 0.0 { s } else { 1.0 }
            })
            .collect();
        Standardiser { mean, std }
    }

    pub fn apply(&self, x: &[f64]) -> Vec<f64> {
        x.iter()
            .zip(self.mean.iter().zip(&self.std))
            .map(|(v, (m, s))| (v - m) / s)
            .collect()
    }

    pub fn invert(&self, z: &[f64]) -> Vec<f64> {
        z.iter()
            .zip(self.mean.iter().zip(&self.std))
            .map(|(v, (m, s))| m + v * s)
            .collect()
    }
}

/// Indices of the 70/15/15 train/validation/test split of `n` samples (seeded shuffle).
#[derive(Debug, Clone, PartialEq)]
pub struct Split {
    pub train: Vec<usize>,
    pub validation: Vec<usize>,
    pub test: Vec<usize>,
}

impl Split {
    pub fn new(n: usize, seed: u64) -> Split {
        let mut idx: Vec<usize> = (0..n).collect();
        idx.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
        let n_train = (0.70 * n as f64).round() as usize;
        let n_val = (0.15 * n as f64).round() as usize;
        Split {
            train: idx[..n_train].to_vec(),
            validation: idx[n_train..n_train + n_val].to_vec(),
            test: idx[n_train + n_val..].to_vec(),
        }
    }
}

/// The trained inverse map motion indexes → mode weights.
#[derive(Debug, Clone, PartialEq)]
pub struct InverseModel {
    pub input: Standardiser,
    pub output: Standardiser,
    pub net: Mlp,
    pub report: TrainReport,
    pub split: Split,
}

/// Fewest usable samples to train on.
pub const MIN_SAMPLES: usize = 20;

impl InverseModel {
    /// Trains on `db` (features ln|q| except the speed ratio, both sides standardised with the training
    /// part's statistics).
    pub fn train(
        db: &SimulationDatabase,
        opts: &TrainOptions,
    ) -> Result<InverseModel, InverseError> {
        let n = db.samples.len();
        if n < MIN_SAMPLES {
            return Err(InverseError::TooFewSamples {
                valid: n,
                total: db.requested,
                needed: MIN_SAMPLES,
                reasons: db.dropped_summary(),
            });
        }
        let split = Split::new(n, opts.seed);
        let feats: Vec<Vec<f64>> = db
            .samples
            .iter()
            .map(|s| s.indexes.features().to_vec())
            .collect();
        let outs: Vec<Vec<f64>> = db.samples.iter().map(|s| s.weights.clone()).collect();
        let pick = |rows: &[Vec<f64>], idx: &[usize]| -> Vec<Vec<f64>> {
            idx.iter().map(|&i| rows[i].clone()).collect()
        };
        let input = Standardiser::fit(&pick(&feats, &split.train));
        let output = Standardiser::fit(&pick(&outs, &split.train));
        let zx = |idx: &[usize]| -> Vec<Vec<f64>> {
            idx.iter().map(|&i| input.apply(&feats[i])).collect()
        };
        let zy = |idx: &[usize]| -> Vec<Vec<f64>> {
            idx.iter().map(|&i| output.apply(&outs[i])).collect()
        };
        let n_out = outs[0].len();
        let mut net = Mlp::new(&[N_INDEXES, HIDDEN[0], HIDDEN[1], n_out], opts.seed);
        let report = net.train(
            &zx(&split.train),
            &zy(&split.train),
            &zx(&split.validation),
            &zy(&split.validation),
            opts,
        );
        Ok(InverseModel {
            input,
            output,
            net,
            report,
            split,
        })
    }

    /// Predicted mode weights for indexes `q`.
    pub fn predict(&self, q: &MotionIndexes) -> Vec<f64> {
        let z = self.net.predict(&self.input.apply(&q.features()));
        self.output.invert(&z)
    }
}

/// Errors of the network on the held-out test samples.
#[derive(Debug, Clone, PartialEq)]
pub struct HeldOut {
    /// Test samples.
    pub n: usize,
    /// RMS error of the predicted weight per mode, in units of that mode's σ_i.
    pub weight_rmse_sigma: Vec<f64>,
    /// RMS error a constant prediction (the training mean) would have, same units: √3 ≈ 1.73 for
    /// uniform draws in ±3σ.
    pub baseline_rmse_sigma: Vec<f64>,
    /// Samples re-simulated with their predicted weights (a failure is counted, not averaged).
    pub resimulated: usize,
    /// Re-simulations that failed.
    pub resim_failed: usize,
    /// Mean absolute relative error per index of the re-simulated indexes against the true ones [-];
    /// `None` when none was re-simulated (`max_resim` 0) or every re-simulation failed: not
    /// measured.
    pub index_mare: Option<[f64; N_INDEXES]>,
}

/// Inverts the test part of `db`, compares the weights, and re-simulates up to `max_resim` of them to
/// compare the indexes.
pub fn held_out(
    target: &TargetShip,
    modes: &VariationModes,
    db: &SimulationDatabase,
    model: &InverseModel,
    settings: &SimSettings,
    checks: &PhysicalChecks,
    max_resim: usize,
) -> HeldOut {
    let test: Vec<&Sample> = model.split.test.iter().map(|&i| &db.samples[i]).collect();
    let k = model.output.mean.len();
    let preds: Vec<Vec<f64>> = test.iter().map(|s| model.predict(&s.indexes)).collect();
    let rms = |f: &dyn Fn(usize, usize) -> f64, j: usize| {
        let n = test.len().max(1) as f64;
        ((0..test.len()).map(|i| f(i, j).powi(2)).sum::<f64>() / n).sqrt() / modes.weight_std[j]
    };
    let weight_rmse_sigma = (0..k)
        .map(|j| rms(&|i, j| preds[i][j] - test[i].weights[j], j))
        .collect();
    let baseline_rmse_sigma = (0..k)
        .map(|j| rms(&|i, j| model.output.mean[j] - test[i].weights[j], j))
        .collect();
    let m = test.len().min(max_resim);
    let resim: Vec<Option<MotionIndexes>> = (0..m)
        .into_par_iter()
        .map(|i| simulate_weights(target, modes, &preds[i], settings, checks).ok())
        .collect();
    let mut sum = [0.0; N_INDEXES];
    let mut ok = 0usize;
    for (i, r) in resim.iter().enumerate() {
        if let Some(q) = r {
            ok += 1;
            for (acc, (got, want)) in sum.iter_mut().zip(q.0.iter().zip(test[i].indexes.0)) {
                *acc += ((got - want) / want).abs();
            }
        }
    }
    HeldOut {
        n: test.len(),
        weight_rmse_sigma,
        baseline_rmse_sigma,
        resimulated: m,
        resim_failed: m - ok,
        index_mare: (ok > 0).then(|| sum.map(|s| s / ok as f64)),
    }
}

/// `x` clipped to the sampled range ±3 σ_i of each mode, and whether any weight was clipped. The network
/// was trained on that range only; far outside it its output is an extrapolation.
pub fn clip_weights(modes: &VariationModes, x: &[f64]) -> (Vec<f64>, bool) {
    let mut clipped = false;
    let y = x
        .iter()
        .zip(&modes.weight_std)
        .map(|(v, s)| {
            let lim = WEIGHT_RANGE_STD * s;
            if v.abs() > lim {
                clipped = true;
            }
            v.clamp(-lim, lim)
        })
        .collect();
    (y, clipped)
}

/// The database sample nearest to `q` in the network's standardised feature space, and that distance
/// (≈ 1 is one standard deviation of each index): a measure of how far a target lies outside what the
/// database covers.
pub fn nearest(db: &SimulationDatabase, model: &InverseModel, q: &MotionIndexes) -> (usize, f64) {
    let zq = model.input.apply(&q.features());
    db.samples
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let z = model.input.apply(&s.indexes.features());
            let d2: f64 = z.iter().zip(&zq).map(|(a, b)| (a - b).powi(2)).sum();
            (i, (d2 / N_INDEXES as f64).sqrt())
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or((0, f64::NAN))
}

/// Largest number of simulations per start of [`refine`] (`--refine-evals`). The simplex over at
/// most 20 mode weights stops by itself once its values agree to 1e-6, after a few hundred to a few
/// thousand simulations; beyond that a cap only adds waiting. And every simulation is four
/// manoeuvres (about 1 ms of CPU): with the ensemble's hundred-odd starts per motion, 10 000 per
/// start is already up to half an hour of CPU per motion — 4 000 000 000 would be decades.
pub const MAX_REFINE_EVALS: usize = 10_000;

/// Weights refined by re-simulation (see [`refine`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Refined {
    /// Mode weights, within ±3 σ.
    pub weights: Vec<f64>,
    /// Indexes simulated with them.
    pub indexes: MotionIndexes,
    /// Mean squared standardised feature mismatch (the objective).
    pub objective: f64,
    /// Simulations spent.
    pub evaluations: usize,
}

/// The [`mismatch`] of indexes that miss `given` by the relative errors `relative` (each index
/// moved away from `given` by that fraction): how well a match within those errors scores.
pub fn mismatch_of_relative_errors(
    model: &InverseModel,
    given: &MotionIndexes,
    relative: &[f64; N_INDEXES],
) -> f64 {
    let moved = MotionIndexes(std::array::from_fn(|i| given.0[i] * (1.0 + relative[i])));
    mismatch(model, &moved, given)
}

/// Mean squared mismatch of the network features of `q` and `given`, each in units of the training
/// standard deviation of that feature.
pub fn mismatch(model: &InverseModel, q: &MotionIndexes, given: &MotionIndexes) -> f64 {
    let (a, b) = (q.features(), given.features());
    (0..N_INDEXES)
        .map(|i| ((a[i] - b[i]) / model.input.std[i]).powi(2))
        .sum::<f64>()
        / N_INDEXES as f64
}

/// Not in paper 003: a Nelder–Mead search over the mode weights (in units of σ_i, clipped to ±3σ) that
/// minimises [`mismatch`] of re-simulated indexes, started from each of `starts` in turn (e.g. the
/// network's clipped prediction and the nearest database ship) with `max_evals` simulations each. It
/// turns the network's answer into one that is consistent with the simulator; the best result over the
/// starts is returned, `None` when no start simulates. `on_eval` is called after each simulation (a
/// progress count).
#[allow(clippy::too_many_arguments)]
pub fn refine(
    target: &TargetShip,
    modes: &VariationModes,
    model: &InverseModel,
    given: &MotionIndexes,
    starts: &[Vec<f64>],
    settings: &SimSettings,
    checks: &PhysicalChecks,
    max_evals: usize,
    on_eval: &(dyn Fn() + Sync),
) -> Option<Refined> {
    let k = starts.first()?.len();
    let sigma = &modes.weight_std[..k];
    let lim = WEIGHT_RANGE_STD;
    let to_x = |z: &[f64]| -> Vec<f64> {
        z.iter()
            .zip(sigma)
            .map(|(zi, s)| zi.clamp(-lim, lim) * s)
            .collect()
    };
    let mut evaluations = 0usize;
    let mut best: Option<Refined> = None;
    let mut eval = |z: &[f64], best: &mut Option<Refined>| -> f64 {
        evaluations += 1;
        on_eval();
        let x = to_x(z);
        match simulate_weights(target, modes, &x, settings, checks) {
            Ok(q) => {
                let j = mismatch(model, &q, given);
                if best.as_ref().is_none_or(|b| j < b.objective) {
                    *best = Some(Refined {
                        weights: x,
                        indexes: q,
                        objective: j,
                        evaluations: 0,
                    });
                }
                j
            }
            Err(_) => f64::INFINITY,
        }
    };
    for start in starts {
        let z0: Vec<f64> = start.iter().zip(sigma).map(|(x, s)| x / s).collect();
        // Initial simplex: the start and a step of 0.5 σ along each mode (towards the inside).
        let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(k + 1);
        let f0 = eval(&z0, &mut best);
        simplex.push((z0.clone(), f0));
        for i in 0..k {
            let mut z = z0.clone();
            z[i] += if z[i] > 0.0 { -0.5 } else { 0.5 };
            let f = eval(&z, &mut best);
            simplex.push((z, f));
        }
        let mut used = k + 1;
        while used < max_evals {
            simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
            if (simplex[k].1 - simplex[0].1).abs() < 1e-6 && simplex[0].1.is_finite() {
                break;
            }
            let centroid: Vec<f64> = (0..k)
                .map(|d| simplex[..k].iter().map(|p| p.0[d]).sum::<f64>() / k as f64)
                .collect();
            let along = |t: f64| -> Vec<f64> {
                centroid
                    .iter()
                    .zip(&simplex[k].0)
                    .map(|(c, w)| (c + t * (c - w)).clamp(-lim, lim))
                    .collect()
            };
            let zr = along(1.0);
            let fr = eval(&zr, &mut best);
            used += 1;
            if fr < simplex[0].1 {
                let ze = along(2.0);
                let fe = eval(&ze, &mut best);
                used += 1;
                simplex[k] = if fe < fr { (ze, fe) } else { (zr, fr) };
            } else if fr < simplex[k - 1].1 {
                simplex[k] = (zr, fr);
            } else {
                let zc = along(-0.5);
                let fc = eval(&zc, &mut best);
                used += 1;
                if fc < simplex[k].1 {
                    simplex[k] = (zc, fc);
                } else {
                    let z_best = simplex[0].0.clone();
                    for p in simplex.iter_mut().skip(1) {
                        p.0 =
                            p.0.iter()
                                .zip(&z_best)
                                .map(|(a, b)| b + 0.5 * (a - b))
                                .collect();
                        p.1 = eval(&p.0, &mut best);
                        used += 1;
                    }
                }
            }
        }
    }
    best.map(|b| Refined { evaluations, ..b })
}
