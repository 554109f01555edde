//! Bands of a standard manoeuvre's metrics and track from replicated models (bootstrap replicates of a
//! polynomial or mmg fit, posterior draws of a sparse GP, an ensemble of inverse networks): every
//! replicate is simulated like the point model, and each metric's band is the central percentile
//! interval over the replicates whose run defines it. A replicate run that diverges is counted (its
//! metrics are undefined), never dropped silently. No I/O.

use std::sync::Arc;

use rayon::prelude::*;
use serde::Serialize;
use shipid_gp::{PosteriorDraw, PosteriorSampler};
use shipid_io::{DatasetRecording, InputError, Manoeuvre, Ship};
use shipid_model::{AbkowitzModel, ModelFile};
use shipid_sim::gp::{GP_KIND, GpDynamics, GpModelFile};
use shipid_sim::metrics::metrics;
use shipid_sim::{AbkowitzDynamics, Dynamics, Effect, SimStatus, WithEffects};
use shipid_uncertainty::{
    Band, SplitMix64, UncertaintyError, order_statistic_band, percentile_band,
};

use crate::bootstrap::replicate_rng;
use crate::error::{PipelineError, bad_input};
use crate::mmg::file::{MMG_KIND, MmgModelFile, ReplicateKind};
use crate::simulate::{SimGrid, simulate_manoeuvre, simulate_on_grid_from};
use crate::validate::closed_loop_in;
use shipid_sim::environment::KnownEnvironment;

pub use shipid_uncertainty::band::MIN_FINITE_REPLICATES;

/// The eight IMO metrics of one run as `Metrics::entries` gives them.
type MetricEntries = [(&'static str, Option<f64>); 8];

/// One metric's point prediction and band.
#[derive(Debug, Clone, Serialize)]
pub struct MetricBand {
    /// Metric key as `shipid simulate --json` names it (e.g. `tactical_diameter`, `overshoot_1`; units
    /// as there: lengths ÷ L, angles in degrees, times × U0/L).
    pub metric: &'static str,
    /// The point model's value (None when its run does not define the metric).
    pub point: Option<f64>,
    /// The band, or why there is none (too few replicates define the metric).
    #[serde(serialize_with = "band_or_reason")]
    pub band: Result<Band, UncertaintyError>,
}

fn band_or_reason<S: serde::Serializer>(
    band: &Result<Band, UncertaintyError>,
    s: S,
) -> Result<S::Ok, S::Error> {
    match band {
        Ok(b) => b.serialize(s),
        Err(e) => s.serialize_str(&e.to_string()),
    }
}

/// Pointwise band of a track sampled at common times.
#[derive(Debug, Clone, Serialize)]
pub struct TrackBand {
    /// Times [s] (the point run's samples, thinned).
    pub t_s: Vec<f64>,
    /// Earth-fixed x [m] band, lower and upper, per time (None where fewer than
    /// `shipid_uncertainty::band::MIN_FINITE_REPLICATES` replicate runs reach that time).
    pub x0_m: Vec<Option<(f64, f64)>>,
    /// Earth-fixed y [m] band.
    pub y0_m: Vec<Option<(f64, f64)>>,
    /// Heading [deg] band.
    pub psi_deg: Vec<Option<(f64, f64)>>,
    /// Series (`x0_m`, `y0_m`, `psi_deg`) whose band was dropped, and why (their entries are all
    /// None): a calibrated run beyond the range the calibration speaks for.
    #[serde(skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub without_band: std::collections::BTreeMap<&'static str, String>,
}

/// `band` stretched to hold `point` (None: no band, for a point that defines no value). A band is
/// read as the uncertainty *of the prediction shown*: replicates whose runs part from the point run
/// (a GP's draws, which revert to the training mean where the mean run does not; a bootstrap whose
/// replicates sit on one side of a nonlinear response) put its percentiles beside the point, and a
/// band that excludes its own point says nothing about that point.
pub fn holding_point(
    band: Result<Band, UncertaintyError>,
    point: Option<f64>,
) -> Result<Band, UncertaintyError> {
    let band = band?;
    match point {
        Some(p) if p.is_finite() => Ok(Band {
            lo: band.lo.min(p),
            hi: band.hi.max(p),
            ..band
        }),
        _ => Err(UncertaintyError::PointUndefined),
    }
}

/// Bands of one manoeuvre.
#[derive(Debug, Clone, Serialize)]
pub struct ManoeuvreBands {
    pub level: f64,
    pub replicates: usize,
    /// Replicate runs that diverged before the end of the manoeuvre.
    pub diverged: usize,
    /// Which: the indices of those replicates (an ensemble's tell its structures).
    pub diverged_members: Vec<usize>,
    pub metrics: Vec<MetricBand>,
    pub track: Option<TrackBand>,
}

/// Largest number of track samples kept per band (enough for a figure; bounds memory for long runs).
const TRACK_SAMPLES: usize = 400;

/// How every model of a band is run: the same way as the point prediction the band goes with.
#[derive(Clone, Copy)]
pub enum BandRun<'a> {
    /// The standard manoeuvre from a steady approach at U0, standard step and duration (`simulate`).
    Standard,
    /// The standard manoeuvre on a given step and duration (`simulate --dt/--duration`), from a
    /// straight approach at the given speed [m/s] (U0, or the point model's straight-run speed at its
    /// own propeller rate: `simulate`'s approach, so that the point and its replicates start alike).
    Grid(&'a SimGrid, f64),
    /// The recording's own manoeuvre from its recorded initial state and first execute, for its
    /// recorded length, as `validate` re-simulates it ([`closed_loop_in`]), in its recorded wind and
    /// current when it has them (`None`: calm).
    Recording(&'a DatasetRecording, Option<&'a KnownEnvironment>),
}

/// Simulate `point` and every model of `replicates` through `m`, each as `how` says; the `level`
/// bands of the metrics and of the track (percentiles of the replicates).
pub fn manoeuvre_bands(
    point: &dyn Dynamics,
    replicates: &[Box<dyn Dynamics + Send + Sync>],
    m: &Manoeuvre,
    ship: &Ship,
    level: f64,
    how: BandRun,
) -> Result<ManoeuvreBands, PipelineError> {
    manoeuvre_bands_of(point, replicates, BandKind::Bootstrap, m, ship, level, how)
}

/// [`manoeuvre_bands`] for replicates of `kind`: an inverse ensemble's bands are its order
/// statistics ([`order_statistic_band`]), the others' their percentiles.
pub fn manoeuvre_bands_of(
    point: &dyn Dynamics,
    replicates: &[Box<dyn Dynamics + Send + Sync>],
    kind: BandKind,
    m: &Manoeuvre,
    ship: &Ship,
    level: f64,
    how: BandRun,
) -> Result<ManoeuvreBands, PipelineError> {
    let run = |model: &dyn Dynamics| match how {
        BandRun::Standard => simulate_manoeuvre(model, m, None, None),
        BandRun::Grid(g, approach_m_s) => simulate_on_grid_from(model, m, g, approach_m_s),
        BandRun::Recording(r, env) => {
            closed_loop_in(model, r, ship, env.cloned()).ok_or_else(|| {
                bad_input(format!(
                    "{}: no standard manoeuvre to re-simulate for a band",
                    r.file
                ))
            })
        }
    };
    let point_run = run(point)?;
    let point_metrics = metrics(&point_run.recording, m, ship);
    let runs: Vec<Option<shipid_sim::SimOutput>> = replicates
        .par_iter()
        .map(|model| run(model.as_ref()).ok())
        .collect();
    let diverged_members: Vec<usize> = runs
        .iter()
        .enumerate()
        .filter(|(_, r)| {
            r.as_ref()
                .is_none_or(|r| !matches!(r.status, SimStatus::Ok))
        })
        .map(|(i, _)| i)
        .collect();
    let diverged = diverged_members.len();
    let replicate_metrics: Vec<Option<MetricEntries>> = runs
        .iter()
        .map(|r| {
            r.as_ref()
                .filter(|r| matches!(r.status, SimStatus::Ok))
                .map(|r| metrics(&r.recording, m, ship).entries())
        })
        .collect();
    let metrics = point_metrics
        .entries()
        .iter()
        .enumerate()
        .map(|(i, &(name, value))| MetricBand {
            metric: name,
            point: value,
            band: holding_point(
                kind.band(
                    replicate_metrics.iter().map(|e| e.and_then(|e| e[i].1)),
                    level,
                ),
                value,
            ),
        })
        .collect();
    let track = (!point_run.recording.t.is_empty())
        .then(|| track_band(&point_run.recording, &runs, kind, level));
    Ok(ManoeuvreBands {
        level,
        replicates: replicates.len(),
        diverged,
        diverged_members,
        metrics,
        track,
    })
}

/// Linear interpolation of `y(t)` at `at` (None outside the samples).
fn at_time(t: &[f64], y: &[f64], at: f64) -> Option<f64> {
    let i = t.partition_point(|&s| s < at);
    if i == 0 {
        return (t.first() == Some(&at)).then(|| y[0]);
    }
    if i >= t.len() {
        return None;
    }
    let w = (at - t[i - 1]) / (t[i] - t[i - 1]);
    Some(y[i - 1] + w * (y[i] - y[i - 1]))
}

fn track_band(
    point: &shipid_io::Recording,
    runs: &[Option<shipid_sim::SimOutput>],
    kind: BandKind,
    level: f64,
) -> TrackBand {
    let step = point.t.len().div_ceil(TRACK_SAMPLES).max(1);
    let times: Vec<f64> = point.t.iter().step_by(step).copied().collect();
    let band_of = |series: fn(&shipid_io::Recording) -> &Vec<f64>, scale: f64| {
        times
            .iter()
            .map(|&at| {
                let values = runs.iter().map(|r| {
                    r.as_ref()
                        .and_then(|r| at_time(&r.recording.t, series(&r.recording), at))
                        .map(|v| v * scale)
                });
                let own = at_time(&point.t, series(point), at).map(|v| v * scale);
                holding_point(kind.band(values, level), own)
                    .ok()
                    .map(|b| (b.lo, b.hi))
            })
            .collect::<Vec<_>>()
    };
    TrackBand {
        x0_m: band_of(|r| &r.x0, 1.0),
        y0_m: band_of(|r| &r.y0, 1.0),
        psi_deg: band_of(|r| &r.psi, 180.0 / std::f64::consts::PI),
        t_s: times,
        without_band: std::collections::BTreeMap::new(),
    }
}

/// What a band without calibration is drawn from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum BandKind {
    /// Block-bootstrap replicates of a polynomial or mmg fit.
    Bootstrap,
    /// Functions drawn from a sparse GP's posterior.
    PosteriorDraws,
    /// The kept members of an inverse ensemble (`shipid inverse`), banded by order statistics.
    Ensemble,
}

impl BandKind {
    /// The `level` band of values of replicates of this kind.
    pub fn band(
        self,
        values: impl IntoIterator<Item = Option<f64>>,
        level: f64,
    ) -> Result<Band, UncertaintyError> {
        match self {
            BandKind::Ensemble => order_statistic_band(values, level),
            BandKind::Bootstrap | BandKind::PosteriorDraws => percentile_band(values, level),
        }
    }

    /// What the replicated models are called, in the plural.
    pub fn noun(self) -> &'static str {
        match self {
            BandKind::Bootstrap => "bootstrap replicates",
            BandKind::PosteriorDraws => "posterior draws",
            BandKind::Ensemble => "ensemble members",
        }
    }

    /// What the band covers, in one sentence.
    pub fn what(self) -> &'static str {
        match self {
            BandKind::Bootstrap => {
                "bootstrap only: coefficient uncertainty of the fit (moving-block bootstrap), given the model's structure; not the structure's own error (docs/uncertainty.md)"
            }
            BandKind::PosteriorDraws => {
                "posterior draws of the sparse GP, each simulated: the GP's own uncertainty given its kernel and sparse points; not calibrated (docs/uncertainty.md)"
            }
            BandKind::Ensemble => {
                "inverse ensemble: the kept members (networks × refinement restarts that match the motion indexes), each simulated; order statistics that hold one more member with the level's probability (at 90 % and up to 38 members: their range, which holds every member, the delivered one included); what the indexes leave undetermined, not calibrated (docs/uncertainty.md)"
            }
        }
    }
}

/// The replicated models of the model file `spec` as simulation models: the bootstrap replicates of a
/// polynomial (each with the file's effects) or mmg file, the posterior draws of a sparse GP. Bad input
/// when the file holds no replicates (a model without them has no band, and saying so beats a band
/// of zero width).
pub fn replicate_models(spec: &str) -> Result<Vec<Box<dyn Dynamics + Send + Sync>>, PipelineError> {
    replicated_models(spec).map(|(models, _)| models)
}

/// [`replicate_models`] and what they are.
pub fn replicated_models(
    spec: &str,
) -> Result<(Vec<Box<dyn Dynamics + Send + Sync>>, BandKind), PipelineError> {
    let path = std::path::Path::new(spec);
    if !path.is_file() {
        return Err(bad_input(format!(
            "{spec}: --bands needs a model file with bootstrap replicates (`shipid fit … --bootstrap \
             N`) or a sparse-GP model file; `{spec}` is not one"
        )));
    }
    let (text, kind) = crate::environment::model_file_family_text(path)?;
    match kind.as_deref() {
        Some("abkowitz") => abkowitz_replicates(path, &text).map(|m| (m, BandKind::Bootstrap)),
        Some(MMG_KIND) => mmg_replicates(path, &text),
        Some(GP_KIND) => gp_posterior_draws(path, &text).map(|m| (m, BandKind::PosteriorDraws)),
        _ => Err(bad_input(format!(
            "{spec}: --bands needs the replicates of a polynomial or mmg model file (`shipid fit … \
             --bootstrap N`) or a sparse-GP model file; this model is {}: bands for it are not \
             available",
            kind.map_or("not a fitted model file".into(), |k| format!(
                "of kind `{k}`"
            ))
        ))),
    }
}

fn abkowitz_replicates(
    path: &std::path::Path,
    text: &str,
) -> Result<Vec<Box<dyn Dynamics + Send + Sync>>, PipelineError> {
    let spec = path.display();
    let file: ModelFile = toml::from_str(text).map_err(|e| InputError::toml(path, text, &e))?;
    let Some(record) = &file.bootstrap else {
        return Err(InputError::key(
            path,
            "bootstrap",
            "missing: --bands needs replicates; refit with `shipid fit … --bootstrap 200`",
        )
        .into());
    };
    let model = file
        .to_model()
        .map_err(|e| bad_input(format!("{spec}: {e}")))?;
    let vectors = record
        .coefficient_vectors(&model.set)
        .map_err(|e| InputError::key(path, "bootstrap", e.to_string()))?;
    let effects: Vec<Effect> = file
        .effects
        .iter()
        .map(|e| e.effect.parse::<Effect>())
        .collect::<Result<_, _>>()
        .map_err(|e| InputError::key(path, "effects", e.to_string()))?;
    let mut models: Vec<Box<dyn Dynamics + Send + Sync>> = Vec::with_capacity(vectors.len());
    for c in vectors {
        let Ok(m) = AbkowitzModel::new(model.set.clone(), c, model.ship, model.added_mass) else {
            continue;
        };
        if effects.is_empty() {
            models.push(Box::new(AbkowitzDynamics(m)));
        } else {
            let wrapped = WithEffects::new(AbkowitzDynamics(m), &effects)
                .map_err(|e| InputError::key(path, "effects", e.to_string()))?;
            models.push(Box::new(wrapped));
        }
    }
    Ok(models)
}

fn mmg_replicates(
    path: &std::path::Path,
    text: &str,
) -> Result<(Vec<Box<dyn Dynamics + Send + Sync>>, BandKind), PipelineError> {
    let file: MmgModelFile = toml::from_str(text).map_err(|e| InputError::toml(path, text, &e))?;
    let kind = match file.bootstrap.as_ref().map(|b| b.replicate_kind) {
        Some(ReplicateKind::InverseEnsemble) => BandKind::Ensemble,
        _ => BandKind::Bootstrap,
    };
    mmg_file_replicates(&file, path).map(|m| (m, kind))
}

/// The `[bootstrap]` replicates of the mmg model file `file` (read from `path`) as simulation
/// models; its point model is checked first, a fault names the key.
pub fn mmg_file_replicates(
    file: &MmgModelFile,
    path: &std::path::Path,
) -> Result<Vec<Box<dyn Dynamics + Send + Sync>>, PipelineError> {
    file.to_model(path)?;
    Ok(file
        .replicate_models(path)?
        .into_iter()
        .map(|m| Box::new(m) as Box<dyn Dynamics + Send + Sync>)
        .collect())
}

/// The refinements of an mmg model file's `[valley]` that ended within its tolerance of the file's
/// own (`fit --set mmg --tune --refine`), which a prediction runs beside the point model.
pub struct Valley {
    /// Cost ratio at or below which a start is in the valley is 1 + this.
    pub cost_tolerance: f64,
    /// Starts the fit tried (the valley's members, those that ended higher and those that failed).
    pub starts: usize,
    /// (λ of the start, cost ratio, model) of every start in the valley.
    pub members: Vec<(f64, f64, shipid_sim::MmgModel)>,
}

impl Valley {
    /// What the valley's ranges mean, in words.
    pub fn what(&self) -> &'static str {
        if self.members.is_empty() {
            "no other start ends as low: the recordings choose this minimum"
        } else {
            "models the training recordings do not tell apart; where their predictions differ, the \
             recordings do not determine this manoeuvre (the valley ranges include this model)"
        }
    }
}

/// The models a prediction runs beside an mmg model file's own: its valley and its jackknife refits.
#[derive(Default)]
pub struct BesideModels {
    /// `[valley]` (`fit --tune --refine`).
    pub valley: Option<Valley>,
    /// `[estimator.jackknife]` with its refits' values (three or more training recordings).
    pub jackknife: Option<Jackknife>,
}

/// The [`BesideModels`] of the model file `spec`, read once: none for a built-in model, a file of
/// another kind or an mmg file without them. A damaged table names its key.
pub fn beside_of(spec: &str) -> Result<BesideModels, PipelineError> {
    let path = std::path::Path::new(spec);
    if !path.is_file() {
        return Ok(BesideModels::default());
    }
    let (text, kind) = crate::environment::model_file_family_text(path)?;
    if kind.as_deref() != Some(MMG_KIND) {
        return Ok(BesideModels::default());
    }
    let file: MmgModelFile =
        toml::from_str(&text).map_err(|e| InputError::toml(path, &text, &e))?;
    if file.valley.is_none() && file.estimator.jackknife.is_none() {
        return Ok(BesideModels::default());
    }
    file.to_model(path)?;
    let valley = match &file.valley {
        Some(record) => Some(Valley {
            cost_tolerance: record.cost_tolerance,
            starts: record.starts.len(),
            members: file.valley_models(path)?,
        }),
        None => None,
    };
    let members = file.jackknife_models(path)?;
    let jackknife = (!members.is_empty()).then_some(Jackknife { members });
    Ok(BesideModels { valley, jackknife })
}

/// One member of a valley through one manoeuvre: its start, cost ratio and metrics (`None`: its run
/// diverged or could not be made).
#[derive(Debug, Clone, Serialize)]
pub struct ValleyMemberRun {
    pub prior_weight: f64,
    pub cost_ratio: f64,
    pub metrics: Option<shipid_sim::Metrics>,
}

/// A valley through one manoeuvre: every member's run, and each metric's range over the point model
/// and the members whose runs define it (metric key, lo, hi; only metrics the point run defines).
#[derive(Debug, Clone)]
pub struct ValleyRun {
    pub members: Vec<ValleyMemberRun>,
    pub ranges: Vec<(&'static str, f64, f64)>,
}

impl ValleyRun {
    /// Members whose run diverged.
    pub fn diverged(&self) -> usize {
        self.members.iter().filter(|m| m.metrics.is_none()).count()
    }

    /// The range of `metric`, when the point run defines it.
    pub fn range(&self, metric: &str) -> Option<(f64, f64)> {
        self.ranges
            .iter()
            .find(|r| r.0 == metric)
            .map(|r| (r.1, r.2))
    }
}

/// Run every member of `valley` through `m` as `run` runs a model (the same way as the point
/// prediction whose metrics are `point`), and the metrics' ranges.
pub fn valley_run(
    valley: &Valley,
    point: &shipid_sim::Metrics,
    m: &Manoeuvre,
    ship: &Ship,
    run: impl Fn(&dyn Dynamics) -> Option<shipid_sim::SimOutput> + Sync,
) -> ValleyRun {
    let members: Vec<ValleyMemberRun> = valley
        .members
        .par_iter()
        .map(|(lambda, ratio, model)| ValleyMemberRun {
            prior_weight: *lambda,
            cost_ratio: *ratio,
            metrics: run(model)
                .filter(|out| matches!(out.status, SimStatus::Ok))
                .map(|out| metrics(&out.recording, m, ship)),
        })
        .collect();
    let ranges = metric_ranges(
        point,
        std::iter::once(point).chain(members.iter().filter_map(|m| m.metrics.as_ref())),
    );
    ValleyRun { members, ranges }
}

/// (metric key, lo, hi) over `runs`, for the metrics `point` defines.
fn metric_ranges<'a>(
    point: &shipid_sim::Metrics,
    runs: impl Iterator<Item = &'a shipid_sim::Metrics>,
) -> Vec<(&'static str, f64, f64)> {
    let mut ranges: Vec<(&'static str, f64, f64)> = point
        .entries()
        .iter()
        .filter_map(|(key, v)| v.map(|_| (*key, f64::INFINITY, f64::NEG_INFINITY)))
        .collect();
    for k in runs {
        for (key, v) in k.entries() {
            if let (Some(v), Some(r)) = (v, ranges.iter_mut().find(|r| r.0 == key)) {
                r.1 = r.1.min(v);
                r.2 = r.2.max(v);
            }
        }
    }
    ranges.retain(|r| r.1 <= r.2);
    ranges
}

/// The refits of an mmg model file's `[estimator.jackknife]` (each without one training recording,
/// `fit --set mmg` on three or more), which a prediction runs beside the point model: where their
/// predictions differ, the training set decides the prediction.
pub struct Jackknife {
    /// (what the refit left out, its model).
    pub members: Vec<(String, shipid_sim::MmgModel)>,
}

impl Jackknife {
    /// What the jackknife's ranges mean, in words.
    pub fn what(&self) -> &'static str {
        "the fit repeated without each training recording in turn: a wide range says that which \
         recordings trained the model decides this prediction (the standard error is the jackknife's, \
         √((g − 1)/g Σ (m₋ᵢ − m̄)²))"
    }
}

/// The jackknife through one manoeuvre: each refit's metrics (`None`: its run diverged), each
/// metric's range over the refits and its jackknife standard error (only metrics the point run
/// defines, and standard errors over at least three refits that define them).
#[derive(Debug, Clone)]
pub struct JackknifeRun {
    pub members: Vec<(String, Option<shipid_sim::Metrics>)>,
    pub ranges: Vec<(&'static str, f64, f64)>,
    pub standard_errors: Vec<(&'static str, f64)>,
}

impl JackknifeRun {
    /// Refits whose run diverged.
    pub fn diverged(&self) -> usize {
        self.members.iter().filter(|m| m.1.is_none()).count()
    }
}

/// Run every refit of `jackknife` through `m` as `run` runs a model (as the point prediction whose
/// metrics are `point` was run).
pub fn jackknife_run(
    jackknife: &Jackknife,
    point: &shipid_sim::Metrics,
    m: &Manoeuvre,
    ship: &Ship,
    run: impl Fn(&dyn Dynamics) -> Option<shipid_sim::SimOutput> + Sync,
) -> JackknifeRun {
    let members: Vec<(String, Option<shipid_sim::Metrics>)> = jackknife
        .members
        .par_iter()
        .map(|(name, model)| {
            let metrics = run(model)
                .filter(|out| matches!(out.status, SimStatus::Ok))
                .map(|out| metrics(&out.recording, m, ship));
            (name.clone(), metrics)
        })
        .collect();
    let runs: Vec<&shipid_sim::Metrics> = members.iter().filter_map(|m| m.1.as_ref()).collect();
    let ranges = metric_ranges(point, runs.iter().copied());
    let standard_errors = ranges
        .iter()
        .filter_map(|(key, _, _)| {
            let values: Vec<f64> = runs
                .iter()
                .filter_map(|k| k.entries().iter().find(|e| e.0 == *key)?.1)
                .collect();
            let refs: Vec<&[f64]> = values.iter().map(std::slice::from_ref).collect();
            crate::mmg::jackknife::jackknife_standard_errors(&refs).map(|se| (*key, se[0]))
        })
        .collect();
    JackknifeRun {
        members,
        ranges,
        standard_errors,
    }
}

/// Models a prediction runs beside the point model: the valley of a refined fit (`--tune
/// --refine`), or the refits of its jackknife (three or more training recordings).
#[derive(Clone, Copy)]
pub enum Beside<'a> {
    Valley(&'a Valley),
    Jackknife(&'a Jackknife),
}

impl Beside<'_> {
    /// Each metric's range over the members through `m` (each run as `run` runs a model, as the
    /// point prediction whose metrics are `point` was), and how many of their runs diverged.
    pub fn ranges(
        &self,
        point: &shipid_sim::Metrics,
        m: &Manoeuvre,
        ship: &Ship,
        run: impl Fn(&dyn Dynamics) -> Option<shipid_sim::SimOutput> + Sync,
    ) -> (Vec<(&'static str, f64, f64)>, usize) {
        match self {
            Beside::Valley(v) => {
                let r = valley_run(v, point, m, ship, run);
                let diverged = r.diverged();
                (r.ranges, diverged)
            }
            Beside::Jackknife(j) => {
                let r = jackknife_run(j, point, m, ship, run);
                let diverged = r.diverged();
                (r.ranges, diverged)
            }
        }
    }
}

/// A recorded metric against a range over models beside the point model: (recording, metric,
/// recorded, predicted, (lo, hi), inside).
pub type RangeRow = (String, &'static str, f64, f64, (f64, f64), bool);

/// Each recorded metric of every recording whose closed-loop re-simulation `validated` holds, against
/// its range over `beside` (each member re-simulated as the validation re-simulated the model, whose
/// metrics are taken from there), and the members' runs that diverged.
pub fn recorded_in_ranges(
    validated: &[crate::validate::ValidatedRecording],
    model_spec: &str,
    ds: &shipid_io::Dataset,
    beside: Beside,
) -> (Vec<RangeRow>, usize) {
    let windage = crate::validate::validation_windage(model_spec, ds);
    let mut rows = Vec::new();
    let mut diverged = 0;
    for v in validated {
        let (Some(r), Some(comparison)) = (ds.recording(&v.file), &v.validation.manoeuvre) else {
            continue;
        };
        let Some(point) = &comparison.predicted else {
            continue;
        };
        let env = crate::validate::validation_environment(&windage, ds, r);
        let (ranges, gone) = beside.ranges(point, &r.manoeuvre, &ds.ship, |m| {
            closed_loop_in(m, r, &ds.ship, env.clone())
        });
        diverged += gone;
        for ((key, value), (_, predicted)) in
            comparison.recorded.entries().iter().zip(point.entries())
        {
            let range = ranges.iter().find(|x| x.0 == *key).map(|x| (x.1, x.2));
            let (Some(value), Some(predicted), Some((lo, hi))) = (*value, predicted, range) else {
                continue;
            };
            rows.push((
                r.file.clone(),
                *key,
                value,
                predicted,
                (lo, hi),
                lo <= value && value <= hi,
            ));
        }
    }
    (rows, diverged)
}

/// Posterior functions drawn per sparse-GP band, and the seed of their draws: the posterior is in the
/// model file, so its bands need no replicates stored; a fixed seed makes them reproducible.
pub const GP_DRAWS: usize = 200;
pub const GP_DRAW_SEED: u64 = 1;

/// The three accelerations of one posterior draw of a sparse-GP model.
struct GpDrawDynamics {
    ship: Ship,
    added_mass: shipid_io::AddedMass,
    /// u̇, v̇, ṙ.
    draws: [PosteriorDraw; 3],
}

impl Dynamics for GpDrawDynamics {
    fn accelerations_for(
        &self,
        s: &shipid_sim::State,
        input: &shipid_sim::Input,
    ) -> Result<[f64; 3], shipid_sim::DynamicsError> {
        let x = [s.u, s.v, s.r, input.delta_rad];
        if x.iter().any(|v| !v.is_finite()) {
            return Err(shipid_sim::DynamicsError::OutOfDomain(format!(
                "non-finite state {x:?}"
            )));
        }
        Ok(std::array::from_fn(|k| self.draws[k].value(&x)))
    }

    fn ship(&self) -> &Ship {
        &self.ship
    }

    fn added_mass(&self) -> &shipid_io::AddedMass {
        &self.added_mass
    }
}

/// Standard normal numbers from SplitMix64 (Box–Muller), so that draws do not depend on a library
/// generator's stream.
fn normals(rng: &mut SplitMix64) -> impl FnMut() -> f64 + '_ {
    let mut spare: Option<f64> = None;
    move || {
        if let Some(z) = spare.take() {
            return z;
        }
        // Uniforms in (0, 1]: the logarithm stays finite.
        let mut uniform = || ((rng.next_u64() >> 11) as f64 + 1.0) / (1u64 << 53) as f64;
        let (u1, u2) = (uniform(), uniform());
        let radius = (-2.0 * u1.ln()).sqrt();
        let angle = 2.0 * std::f64::consts::PI * u2;
        spare = Some(radius * angle.sin());
        radius * angle.cos()
    }
}

/// [`GP_DRAWS`] functions drawn from the posterior of `model`'s three GPs (`shipid_gp::draw`), each
/// as a simulation model; draw k is seeded from ([`GP_DRAW_SEED`], k), so it does not depend on the
/// number of threads.
pub fn gp_draws(
    model: &GpDynamics,
    draws: usize,
    seed: u64,
) -> Result<Vec<Box<dyn Dynamics + Send + Sync>>, shipid_gp::GpError> {
    let samplers = model
        .gps
        .iter()
        .map(|gp| PosteriorSampler::new(Arc::new(gp.clone())))
        .collect::<Result<Vec<_>, _>>()?;
    (0..draws)
        .into_par_iter()
        .map(|k| {
            let mut rng = replicate_rng(seed, k);
            let mut normal = normals(&mut rng);
            let [a, b, c] = [0, 1, 2].map(|i| samplers[i].draw(&mut normal));
            Ok(Box::new(GpDrawDynamics {
                ship: model.ship,
                added_mass: model.added_mass,
                draws: [a?, b?, c?],
            }) as Box<dyn Dynamics + Send + Sync>)
        })
        .collect()
}

fn gp_posterior_draws(
    path: &std::path::Path,
    text: &str,
) -> Result<Vec<Box<dyn Dynamics + Send + Sync>>, PipelineError> {
    let file: GpModelFile = toml::from_str(text).map_err(|e| InputError::toml(path, text, &e))?;
    gp_file_draws(&file, path)
}

/// The [`GP_DRAWS`] posterior draws (seed [`GP_DRAW_SEED`]) of the sparse-GP model file `file`
/// (read from `path`), as `--bands` draws them.
pub fn gp_file_draws(
    file: &GpModelFile,
    path: &std::path::Path,
) -> Result<Vec<Box<dyn Dynamics + Send + Sync>>, PipelineError> {
    let model =
        GpDynamics::from_file(file).map_err(|e| bad_input(format!("{}: {e}", path.display())))?;
    gp_draws(&model, GP_DRAWS, GP_DRAW_SEED)
        .map_err(|e| crate::error::failed(format!("{}: posterior draws: {e}", path.display())))
}
