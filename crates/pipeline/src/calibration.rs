//! Bands that carry the error of the model's structure, not only the noise of its data.
//!
//! A block bootstrap of one structure resamples the training data: it says how far the data leave
//! that structure's coefficients undetermined, and nothing about a manoeuvre the data never showed,
//! where the structure's own error dominates (docs/uncertainty.md measured 8–50 % coverage of nominal
//! 90 % bands). Three steps add that error, each from the training data alone:
//!
//! 1. **Several structures** ([`fit_ensemble`]): every coefficient set named is fitted to the same
//!    windows with the same estimator and bootstrapped; their replicates are pooled in equal shares,
//!    and the first set gives the point prediction. Where the structures disagree, the band widens.
//! 2. **Reach** ([`reach`]): how far a prediction runs outside the identification range of its
//!    training data. A regression's prediction variance at a state grows with that state's leverage
//!    h(x); averaged over the run, the half-width is scaled by √(mean of max(1, h/h_max)), 1 inside
//!    the range.
//! 3. **Inflation from the training recordings** ([`calibrate_ensemble`]): every training recording
//!    is re-simulated from its recorded start by the ensemble fitted to all of them (in sample), and
//!    — when there are two or more — by the ensemble refitted without it (held out). Each recorded
//!    metric's error is counted in units of its band's half-width and reach, `z = |value − centre| /
//!    (half-width · reach)`. The inflation factor of a metric family is the `level` quantile of its z
//!    (at least 1: a few small errors must not narrow a band below what the replicates give). A
//!    family with fewer than [`MIN_ERRORS`] values takes the factor of all families together; with
//!    none at all the band is not inflated ([`FamilyFactor::TooFew`]). In-sample errors say what the
//!    bands miss even where the data are (equation-error bias from noisy states, the structure's
//!    misfit); held-out ones what they miss on a manoeuvre the fit did not see.
//!
//! The widened band is centre ± factor · reach · half-width.
//!
//! Steps 2 and 3 are one code path for every model family ([`calibrate_fit`]): a family only says
//! how it fits a subset of the training recordings and what its band's replicates are
//! ([`FamilyFit`]): a polynomial ensemble ([`EnsembleSpec`], step 1), the mmg family's
//! block-bootstrap replicates ([`MmgFamily`]; its in-sample errors measure the equation-error bias
//! the bootstrap cannot see), the sparse GP's posterior draws ([`GpFamily`]). A family without a
//! regression of its own (mmg, GP) measures its reach by the leverage of [`STATE_RANGE_SET`] over
//! its training states.
//!
//! `shipid fit --bootstrap N --calibrate` stores the ensemble's replicates and the factors in the
//! model file's `[calibration]` ([`calibration_record`]; an mmg or sparse-GP file stores the
//! factors alone, [`factor_calibration_record`], over its own replicates); `simulate --bands` and
//! `validate --bands` read them back ([`stored_calibration`]) and widen the band by the stored
//! factor and the reach of the run at hand ([`StoredCalibration::bands`]). No I/O but the reading
//! of that model file and of its training data (for the identification range).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};
use shipid_estimators::Solver;
use shipid_io::{Dataset, Manoeuvre, PrimeScale, Recording, Ship};
use shipid_model::design::primed_state;
use shipid_model::{AbkowitzModel, CoefficientSet, IdentificationRange};
use shipid_sim::metrics::metrics;
use shipid_sim::{AbkowitzDynamics, Dynamics};
use shipid_uncertainty::band::quantile;
use shipid_uncertainty::{Band, UncertaintyError};

use shipid_model::OutOfKindRecord;
use shipid_model::calibration::FactorCalibrationRecord;
use shipid_model::{CalibrationRecord, FactorRecord, ModelFile, StructureRecord, TrainingWindow};
use shipid_sim::gp::{GP_KIND, GpDynamics, GpModelFile};
use shipid_sim::{Effect, WithEffects};

use crate::bands::{
    BandKind, BandRun, ManoeuvreBands, TrackBand, gp_draws, gp_file_draws, manoeuvre_bands,
    manoeuvre_bands_of, mmg_file_replicates, replicated_models,
};
use crate::bootstrap::{MmgBootstrap, bootstrap_fit, bootstrap_mmg};
use crate::error::{PipelineError, bad_input, failed};
use crate::fit::{EstimatorSpec, WindowSpec, fit_dataset};
use crate::metric_family::MAX_BAND_REACH;
use crate::mmg::file::{MMG_KIND, MmgModelFile};
use crate::mmg::{MmgFit, MmgFitOptions, MmgGeometry};
use crate::out_of_kind::{ModelFamily, add_out_of_kind, out_of_kind};
use crate::simulate::{simulate_manoeuvre, simulate_on_grid_from};
use crate::validate::closed_loop_in;

/// Fewest errors of a family for a factor of its own (below, the families' pooled one).
pub const MIN_ERRORS: usize = 3;

pub use crate::metric_family::MetricFamily;

/// The inflation factor of one family, or why it has none.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", tag = "outcome")]
pub enum FamilyFactor {
    /// From `errors` values of this family.
    Own { factor: f64, errors: usize },
    /// Too few of its own: the factor of all families' `errors` values together.
    Pooled { factor: f64, errors: usize },
    /// Too few errors at all: no inflation.
    TooFew { errors: usize },
}

impl FamilyFactor {
    /// The factor to apply (1 when there is none).
    pub fn factor(self) -> f64 {
        match self {
            FamilyFactor::Own { factor, .. } | FamilyFactor::Pooled { factor, .. } => factor,
            FamilyFactor::TooFew { .. } => 1.0,
        }
    }
}

/// Inflation factors per family at one nominal level.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Calibration {
    pub level: f64,
    /// Training recordings left out in turn (0 with a single one).
    pub folds: usize,
    pub factors: BTreeMap<MetricFamily, FamilyFactor>,
    /// The errors the factors come from: in sample, then held out in fold order.
    pub errors: Vec<BandError>,
    /// The term of the manoeuvre kinds the training recordings did not hold
    /// ([`crate::out_of_kind`]; None: they held both, or only free manoeuvres).
    pub out_of_kind: Option<OutOfKindRecord>,
}

/// One metric's error in units of its band ([`standardised_error`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BandError {
    pub family: MetricFamily,
    /// Whether the recording was left out of the fit (false: predicted by the ensemble fitted to it).
    pub held_out: bool,
    /// |value − centre| / (half-width · reach).
    pub z: f64,
    /// The reach of the held-out prediction ([`reach`]).
    pub reach: f64,
}

impl Calibration {
    /// The factor of `metric`'s family (1 for a metric of no family).
    pub fn factor(&self, metric: &str) -> f64 {
        MetricFamily::of(metric).map_or(1.0, |f| self.factor_of(f))
    }

    /// The factor of a family (1 when it has none).
    pub fn factor_of(&self, family: MetricFamily) -> f64 {
        self.factors.get(&family).map_or(1.0, |f| f.factor())
    }

    /// `metric`'s band widened by this calibration at a run's `reach` ([`widen_metric`]).
    pub fn widen(&self, band: &Band, metric: &str, reach: f64) -> Band {
        widen_metric(
            band,
            metric,
            self.factor(metric),
            reach,
            self.out_of_kind.as_ref(),
        )
    }
}

/// `metric`'s calibrated band: widened about its centre by `factor · reach`, or — for a metric of a
/// kind the training recordings did not hold, when `out_of_kind` has a term for its family — the
/// raw band with that term added in quadrature ([`crate::out_of_kind::add_out_of_kind`]). One
/// source of model-form error per kind: the factor of such a family can only be borrowed from the
/// other kind's errors (in units of the other kind's bands; on the HSVA zig-zags that turned a
/// ±0.11 L turning band into ±16 L), while the term is measured on that kind itself.
pub fn widen_metric(
    band: &Band,
    metric: &str,
    factor: f64,
    reach: f64,
    out_of_kind: Option<&OutOfKindRecord>,
) -> Band {
    let widened = match out_of_kind_of(out_of_kind, metric) {
        Some(relative) => {
            let (lo, hi) = add_out_of_kind((band.lo, band.hi), relative);
            Band { lo, hi, ..*band }
        }
        None => widen(band, factor, reach),
    };
    within_physical_limits(widened, metric)
}

/// `band` with its lower end raised to `metric`'s physical limit
/// ([`crate::metric_family::physical_lower_limit`]): widening about the centre can carry a band of
/// a time or a diameter below zero, where no value lies (the band's replicates and its point do not:
/// they are values of the metric).
fn within_physical_limits(band: Band, metric: &str) -> Band {
    match crate::metric_family::physical_lower_limit(metric) {
        Some(limit) => Band {
            lo: band.lo.max(limit),
            hi: band.hi.max(limit),
            ..band
        },
        None => band,
    }
}

/// The out-of-kind relative half-width of `metric`'s family, if the record has one.
fn out_of_kind_of(out_of_kind: Option<&OutOfKindRecord>, metric: &str) -> Option<f64> {
    let family = MetricFamily::of(metric)?;
    out_of_kind?.relative.get(family.as_str()).copied()
}

fn factor_of(mut z: Vec<f64>, level: f64) -> f64 {
    z.sort_by(f64::total_cmp);
    quantile(&z, level).max(1.0)
}

/// The factors of standardised errors `z` at `level`; `folds` recordings held out.
pub fn calibrate(z: &[BandError], level: f64, folds: usize) -> Calibration {
    let finite: Vec<BandError> = z.iter().copied().filter(|h| h.z.is_finite()).collect();
    let all: Vec<f64> = finite.iter().map(|h| h.z).collect();
    let factors = MetricFamily::ALL
        .iter()
        .map(|&fam| {
            let own: Vec<f64> = finite
                .iter()
                .filter(|h| h.family == fam)
                .map(|h| h.z)
                .collect();
            let factor = if own.len() >= MIN_ERRORS {
                FamilyFactor::Own {
                    errors: own.len(),
                    factor: factor_of(own, level),
                }
            } else if all.len() >= MIN_ERRORS {
                FamilyFactor::Pooled {
                    errors: all.len(),
                    factor: factor_of(all.clone(), level),
                }
            } else {
                FamilyFactor::TooFew { errors: all.len() }
            };
            (fam, factor)
        })
        .collect();
    Calibration {
        level,
        folds,
        factors,
        errors: finite,
        out_of_kind: None,
    }
}

/// `|value − centre| / (half-width · reach)` of a band; None for a band of no width.
pub fn standardised_error(band: &Band, value: f64, reach: f64) -> Option<f64> {
    let half = 0.5 * (band.hi - band.lo) * reach;
    (half > 0.0 && value.is_finite()).then(|| (value - 0.5 * (band.lo + band.hi)).abs() / half)
}

/// The band widened about its centre by `factor · reach`.
pub fn widen(band: &Band, factor: f64, reach: f64) -> Band {
    let (lo, hi) = widen_interval((band.lo, band.hi), factor * reach);
    Band { lo, hi, ..*band }
}

/// `(lo, hi)` with its half-width scaled by `k` about the same centre.
fn widen_interval((lo, hi): (f64, f64), k: f64) -> (f64, f64) {
    let (centre, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
    (centre - k * half, centre + k * half)
}

/// √(mean over the run's samples of max(1, h/h_max)): 1 for a run inside the identification range,
/// growing with how far and how long it leaves it. 1 for an empty run.
pub fn reach(range: &IdentificationRange, rec: &Recording, ship: &Ship) -> f64 {
    let scale = PrimeScale::of(ship);
    let (mut sum, mut n) = (0.0, 0usize);
    for i in 0..rec.len() {
        let [du, v, r, d] = primed_state(rec, &scale, i);
        let ratio = range.leverage_ratio(du, v, r, d);
        // A training range of no extent (a straight run) holds no state: the recording lies
        // wholly beyond it, not within it.
        if ratio == f64::INFINITY {
            return f64::INFINITY;
        }
        if ratio.is_finite() {
            sum += ratio.max(1.0);
            n += 1;
        }
    }
    if n == 0 { 1.0 } else { (sum / n as f64).sqrt() }
}

/// The point model of the first structure, its identification range, and the replicates of every
/// structure pooled.
pub struct Ensemble {
    pub point: AbkowitzModel,
    pub range: Option<IdentificationRange>,
    pub replicates: Vec<Box<dyn Dynamics + Send + Sync>>,
    /// Block length [rows] of each structure's bootstrap, in the order of the sets.
    pub block_rows: Vec<usize>,
}

/// How an ensemble is fitted: its structures (the first gives the point prediction), the estimator,
/// training windows and solver they share, and the bootstrap replicates (pooled over the sets) and
/// their seed.
#[derive(Clone, Copy)]
pub struct EnsembleSpec<'a> {
    pub sets: &'a [CoefficientSet],
    pub estimator: &'a EstimatorSpec,
    pub window: WindowSpec,
    pub solver: Solver,
    pub replicates: usize,
    pub seed: u64,
}

/// Fit every set of `how` to `recordings` of `ds` and bootstrap each with `replicates / sets`
/// replicates (at least 2).
pub fn fit_ensemble(
    ds: &Dataset,
    how: &EnsembleSpec,
    recordings: &[String],
) -> Result<Ensemble, PipelineError> {
    fit_ensemble_stored(ds, how, recordings).map(|(e, _)| e)
}

/// [`fit_ensemble`], with each structure's set and replicates as a model file's `[calibration]`
/// stores them.
pub fn fit_ensemble_stored(
    ds: &Dataset,
    how: &EnsembleSpec,
    recordings: &[String],
) -> Result<(Ensemble, Vec<StructureRecord>), PipelineError> {
    let (sets, spec) = (how.sets, how.estimator);
    let mut point = None;
    let mut models = Vec::new();
    let mut block_rows = Vec::new();
    let mut stored = Vec::new();
    let share = (how.replicates / sets.len().max(1)).max(2);
    for set in sets {
        let out = fit_dataset(ds, set.clone(), spec, recordings, how.window, how.solver)?;
        if let Some(none) = out.no_information() {
            return Err(failed(format!("{}: {none}", set.name)));
        }
        let boot = bootstrap_fit(ds, &out, spec, how.solver, share, how.seed)?;
        models.extend(boot.models(&out.model));
        block_rows.push(boot.block.rows);
        stored.push(StructureRecord {
            set: set.file.clone(),
            block_rows: boot.block.rows,
            replicates: boot.record(&out.model).replicates,
        });
        if point.is_none() {
            let range = IdentificationRange::from_samples(&out.model.set, &out.training).ok();
            point = Some((out.model, range));
        }
    }
    let (point, range) = point.ok_or_else(|| bad_input("no coefficient set for the ensemble"))?;
    Ok((
        Ensemble {
            point,
            range,
            replicates: models,
            block_rows,
        },
        stored,
    ))
}

/// One fit of a model family with what its band needs: the point model, the replicated models of
/// its band (bootstrap replicates, posterior draws), and the identification range of its training
/// data (None: the reach is taken as 1).
pub struct FittedBands {
    pub point: Box<dyn Dynamics + Send + Sync>,
    pub replicates: Vec<Box<dyn Dynamics + Send + Sync>>,
    pub range: Option<IdentificationRange>,
}

impl FittedBands {
    pub fn source(&self) -> BandSource<'_> {
        BandSource {
            point: self.point.as_ref(),
            replicates: &self.replicates,
            range: self.range.as_ref(),
        }
    }
}

/// A fit's band as the calibration reads it (borrowed: an [`Ensemble`] keeps its point model as
/// coefficients, a [`FittedBands`] as a simulation model).
#[derive(Clone, Copy)]
pub struct BandSource<'a> {
    pub point: &'a dyn Dynamics,
    pub replicates: &'a [Box<dyn Dynamics + Send + Sync>],
    pub range: Option<&'a IdentificationRange>,
}

/// What the calibration needs of a model family: a fit on any subset of the training recordings,
/// with the replicated models of its band. The in-sample errors, the held-out refits and the factors
/// are one code path for every family ([`calibrate_fit`]); a family only says how it fits:
/// polynomial ensembles ([`EnsembleSpec`]), the mmg family ([`MmgFamily`]), the sparse GP
/// ([`GpFamily`]).
pub trait FamilyFit: Sync {
    /// Fit to `recordings` of `ds` (every recording when empty).
    fn fit(&self, ds: &Dataset, recordings: &[String]) -> Result<FittedBands, PipelineError>;
    /// Which family this is (its out-of-kind term, [`crate::out_of_kind`]).
    fn model_family(&self) -> ModelFamily;
}

impl FamilyFit for EnsembleSpec<'_> {
    fn model_family(&self) -> ModelFamily {
        ModelFamily::Polynomial
    }

    fn fit(&self, ds: &Dataset, recordings: &[String]) -> Result<FittedBands, PipelineError> {
        let e = fit_ensemble(ds, self, recordings)?;
        Ok(FittedBands {
            point: Box::new(AbkowitzDynamics(e.point)),
            replicates: e.replicates,
            range: e.range,
        })
    }
}

/// The bands of manoeuvre `m` run as `how` says, and the reach of the point run outside the
/// source's identification range (1 without a range or without a run).
pub fn source_bands(
    src: BandSource,
    m: &Manoeuvre,
    ship: &Ship,
    level: f64,
    how: BandRun,
) -> Result<(ManoeuvreBands, f64), PipelineError> {
    let bands = manoeuvre_bands(src.point, src.replicates, m, ship, level, how)?;
    Ok((bands, run_reach(src.point, src.range, m, ship, how)))
}

/// The reach of `point`'s run of `m` (as `how` says) outside `range`; 1 without either.
fn run_reach(
    point: &dyn Dynamics,
    range: Option<&IdentificationRange>,
    m: &Manoeuvre,
    ship: &Ship,
    how: BandRun,
) -> f64 {
    let Some(range) = range else {
        return 1.0;
    };
    let run = match how {
        BandRun::Standard => simulate_manoeuvre(point, m, None, None).ok(),
        BandRun::Grid(g, approach_m_s) => simulate_on_grid_from(point, m, g, approach_m_s).ok(),
        BandRun::Recording(r, env) => closed_loop_in(point, r, ship, env.cloned()),
    };
    run.map_or(1.0, |run| reach(range, &run.recording, ship))
}

/// The ensemble's bands of manoeuvre `m` run as `how` says, and the reach of its point run.
pub fn ensemble_bands(
    e: &Ensemble,
    m: &Manoeuvre,
    ship: &Ship,
    level: f64,
    how: BandRun,
) -> Result<(ManoeuvreBands, f64), PipelineError> {
    let point = AbkowitzDynamics(e.point.clone());
    source_bands(e.source(&point), m, ship, level, how)
}

impl Ensemble {
    /// The ensemble as the calibration reads it, with `point` its point model as a simulation model.
    pub fn source<'a>(&'a self, point: &'a AbkowitzDynamics) -> BandSource<'a> {
        BandSource {
            point,
            replicates: &self.replicates,
            range: self.range.as_ref(),
        }
    }
}

/// The errors of the fit `src` on `recordings` (its own training recordings, or a held-out one),
/// each re-simulated from its recorded start: what the bands miss even where the data are. With a
/// single training recording these are the only errors to calibrate on.
pub fn recording_errors(
    src: BandSource,
    ds: &Dataset,
    recordings: &[String],
    level: f64,
) -> Result<Vec<BandError>, PipelineError> {
    let mut z = Vec::new();
    for name in recordings {
        let r = ds
            .recording(name)
            .ok_or_else(|| bad_input(format!("no recording `{name}` in the data set")))?;
        if matches!(r.manoeuvre, Manoeuvre::Free) {
            continue;
        }
        let env = crate::environment::recording_environment(ds, &r.recording)?.0;
        let (bands, reach) = source_bands(
            src,
            &r.manoeuvre,
            &ds.ship,
            level,
            BandRun::Recording(r, env.as_ref()),
        )?;
        let recorded = metrics(&r.recording, &r.manoeuvre, &ds.ship);
        for (b, (_, value)) in bands.metrics.iter().zip(recorded.entries()) {
            let (Ok(band), Some(value), Some(family)) =
                (&b.band, value, MetricFamily::of(b.metric))
            else {
                continue;
            };
            if let Some(v) = standardised_error(band, value, reach) {
                z.push(BandError {
                    family,
                    held_out: false,
                    z: v,
                    reach,
                });
            }
        }
    }
    Ok(z)
}

/// [`recording_errors`] of a polynomial ensemble.
pub fn in_sample_errors(
    e: &Ensemble,
    ds: &Dataset,
    recordings: &[String],
    level: f64,
) -> Result<Vec<BandError>, PipelineError> {
    let point = AbkowitzDynamics(e.point.clone());
    recording_errors(e.source(&point), ds, recordings, level)
}

/// Leave each of `recordings` out in turn, fit `family` on the rest, and give the errors of the
/// left-out recording's metrics (none with a single recording).
pub fn refit_errors(
    family: &dyn FamilyFit,
    ds: &Dataset,
    recordings: &[String],
    level: f64,
) -> Result<Vec<BandError>, PipelineError> {
    let mut z = Vec::new();
    if recordings.len() < 2 {
        return Ok(z);
    }
    for (i, left) in recordings.iter().enumerate() {
        let rest: Vec<String> = recordings
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != i)
            .map(|(_, r)| r.clone())
            .collect();
        let fitted = family.fit(ds, &rest)?;
        z.extend(
            recording_errors(fitted.source(), ds, std::slice::from_ref(left), level)?
                .into_iter()
                .map(|b| BandError {
                    held_out: true,
                    ..b
                }),
        );
    }
    Ok(z)
}

/// [`refit_errors`] of a polynomial ensemble fitted as `how` says.
pub fn held_out_errors(
    ds: &Dataset,
    how: &EnsembleSpec,
    recordings: &[String],
    level: f64,
) -> Result<Vec<BandError>, PipelineError> {
    refit_errors(how, ds, recordings, level)
}

/// The calibration of the fit `src` of `family` to `recordings` of `ds`: the factors of its errors
/// on its own recordings and of the held-out refits' errors ([`calibrate`]).
pub fn calibrate_fit(
    src: BandSource,
    family: &dyn FamilyFit,
    ds: &Dataset,
    recordings: &[String],
    level: f64,
) -> Result<Calibration, PipelineError> {
    let mut z = recording_errors(src, ds, recordings, level)?;
    z.extend(refit_errors(family, ds, recordings, level)?);
    let folds = if recordings.len() < 2 {
        0
    } else {
        recordings.len()
    };
    let training: Vec<Manoeuvre> = crate::fit::chosen_recordings(ds, recordings)?
        .iter()
        .map(|r| r.manoeuvre)
        .collect();
    Ok(Calibration {
        out_of_kind: out_of_kind(family.model_family(), &training, level),
        ..calibrate(&z, level, folds)
    })
}

/// The calibration of the ensemble `e`, fitted as `how` says to `recordings` of `ds`
/// ([`calibrate_fit`]).
pub fn calibrate_ensemble(
    e: &Ensemble,
    ds: &Dataset,
    how: &EnsembleSpec,
    recordings: &[String],
    level: f64,
) -> Result<Calibration, PipelineError> {
    let point = AbkowitzDynamics(e.point.clone());
    calibrate_fit(e.source(&point), how, ds, recordings, level)
}

pub use crate::range::{STATE_RANGE_SET, state_range_of};

/// The [`STATE_RANGE_SET`] range of the training windows `window` of `recordings` of `ds`.
pub fn state_range(
    ds: &Dataset,
    recordings: &[String],
    window: WindowSpec,
) -> Option<IdentificationRange> {
    let scale = PrimeScale::of(&ds.ship);
    let mut states = Vec::new();
    for r in crate::fit::chosen_recordings(ds, recordings).ok()? {
        let range = crate::fit::window_range(r, ds, window).ok()?;
        states.extend(range.map(|i| primed_state(&r.recording, &scale, i)));
    }
    state_range_of(&states)
}

/// The [`STATE_RANGE_SET`] range of a model file's training windows (None when its training data
/// cannot be read).
fn stored_state_range(spec: &str, windows: &[TrainingWindow]) -> Option<IdentificationRange> {
    let (_, ds, _) = crate::range::training_data(spec)?;
    state_range_of(&crate::range::window_states(&ds, windows))
}

/// The mmg family as the calibration refits it: the options of the fit (its recordings are
/// replaced by each fold's), the propeller and rudder, whether each refit is refined in the
/// output-error sense as the fit was (`--refine`), and the block-bootstrap replicates and seed.
#[derive(Clone)]
pub struct MmgFamily {
    pub opts: MmgFitOptions,
    pub geometry: MmgGeometry,
    pub refine: bool,
    pub replicates: usize,
    pub seed: u64,
}

impl MmgFamily {
    /// Fit (and refine, when asked) the mmg model to `recordings` of `ds`.
    pub fn fit_mmg(&self, ds: &Dataset, recordings: &[String]) -> Result<MmgFit, PipelineError> {
        let opts = self.options(ds, recordings);
        let fit = crate::mmg::fit_mmg(ds, &self.geometry, &opts)?;
        if !self.refine {
            return Ok(fit);
        }
        let added = ds
            .added_mass
            .ok_or_else(|| bad_input(format!("{}: no [added_mass] table", ds.path.display())))?;
        let windows = crate::mmg::training_samples(ds, &opts)?.recordings;
        let refine = crate::refine::RefineOptions::for_dataset(ds);
        Ok(crate::mmg::refine_mmg(&fit, added, &windows, &refine)?.0)
    }

    fn options(&self, ds: &Dataset, recordings: &[String]) -> MmgFitOptions {
        let mut opts = MmgFitOptions {
            recordings: recordings.to_vec(),
            ..self.opts.clone()
        };
        if opts.propeller_rate_hz.is_none() {
            opts.propeller_rate_hz = ds.propeller.as_ref().and_then(|p| p.rate_rps);
        }
        if self.refine {
            opts.refine_folds = Some(crate::refine::RefineOptions::for_dataset(ds));
        }
        opts
    }

    /// The band of `fit` (to `recordings` of `ds`): its block-bootstrap replicates as models, the
    /// replicates themselves (for the model file's `[bootstrap]`), and the state range of its
    /// training windows.
    pub fn bands_of(
        &self,
        ds: &Dataset,
        fit: &MmgFit,
        recordings: &[String],
    ) -> Result<(FittedBands, MmgBootstrap), PipelineError> {
        let opts = self.options(ds, recordings);
        let boot = bootstrap_mmg(ds, fit, &opts, self.replicates, self.seed)?;
        let added = ds
            .added_mass
            .ok_or_else(|| bad_input(format!("{}: no [added_mass] table", ds.path.display())))?;
        let mut file = crate::mmg::model_file(fit, added);
        file.bootstrap = Some(boot.record());
        let replicates = file
            .replicate_models(&ds.path)?
            .into_iter()
            .map(|m| Box::new(m) as Box<dyn Dynamics + Send + Sync>)
            .collect();
        Ok((
            FittedBands {
                point: Box::new(fit.model.clone()),
                replicates,
                range: state_range(ds, recordings, self.opts.window),
            },
            boot,
        ))
    }
}

impl FamilyFit for MmgFamily {
    fn model_family(&self) -> ModelFamily {
        ModelFamily::Mmg
    }
    fn fit(&self, ds: &Dataset, recordings: &[String]) -> Result<FittedBands, PipelineError> {
        let fit = self.fit_mmg(ds, recordings)?;
        Ok(self.bands_of(ds, &fit, recordings)?.0)
    }
}

/// The sparse GP as the calibration refits it: the windows and similarity threshold of the fit,
/// and the posterior draws of each refit's band (as many, and seeded, as `simulate --bands` draws:
/// [`crate::bands::GP_DRAWS`], [`crate::bands::GP_DRAW_SEED`]).
#[derive(Clone, Copy)]
pub struct GpFamily {
    pub window: WindowSpec,
    pub similarity: f64,
    pub draws: usize,
    pub seed: u64,
}

impl GpFamily {
    /// The band of the sparse GP `model` fitted to `recordings` of `ds`: its posterior draws and the
    /// state range of its training windows.
    pub fn bands_of(
        &self,
        ds: &Dataset,
        model: GpDynamics,
        recordings: &[String],
    ) -> Result<FittedBands, PipelineError> {
        let replicates = gp_draws(&model, self.draws, self.seed)
            .map_err(|e| failed(format!("posterior draws: {e}")))?;
        Ok(FittedBands {
            point: Box::new(model),
            replicates,
            range: state_range(ds, recordings, self.window),
        })
    }
}

impl FamilyFit for GpFamily {
    fn model_family(&self) -> ModelFamily {
        ModelFamily::SparseGp
    }
    fn fit(&self, ds: &Dataset, recordings: &[String]) -> Result<FittedBands, PipelineError> {
        let (_, model, _) =
            crate::fit_gp::fit_gp_dataset(ds, recordings, self.window, self.similarity)?;
        self.bands_of(ds, model, recordings)
    }
}

/// The calibration in words, as the model file's `[calibration]` states it.
pub const METHOD: &str = "pooled moving-block bootstrap replicates of every structure (equal shares, \
the same windows, estimator and seed), each band widened about its centre by the reach of the run \
outside the identification range and by the inflation factor of its metric family: the `level` \
quantile (at least 1) of the training recordings' standardised errors, in sample and left out in \
turn (docs/uncertainty.md)";

/// The model file's `[calibration]` of calibration `c`, made as `how` says from the ensemble whose
/// structures are `structures` ([`fit_ensemble_stored`]).
pub fn calibration_record(
    c: &Calibration,
    how: &EnsembleSpec,
    structures: Vec<StructureRecord>,
) -> CalibrationRecord {
    CalibrationRecord {
        method: METHOD.into(),
        level: c.level,
        seed: how.seed,
        folds: c.folds,
        factors: factor_records(c),
        out_of_kind: c.out_of_kind.clone(),
        structures,
    }
}

/// The calibration of an mmg or sparse-GP fit in words, as its model file's `[calibration]` states
/// it.
pub const FAMILY_METHOD: &str = "the model file's own replicates (mmg: its [bootstrap]; sparse GP: \
its posterior draws), each band widened about its centre by the reach of the run outside the \
training states' range (the leverage of a third-order polynomial in du', v', r', delta) and by the \
inflation factor of its metric family: the `level` quantile (at least 1) of the training \
recordings' standardised errors, in sample and left out in turn, each refit made as the fit was \
(docs/uncertainty.md)";

/// The `[calibration]` of an mmg or sparse-GP model file: calibration `c` of a fit whose refits
/// had `replicates` replicates drawn with `seed`.
pub fn factor_calibration_record(
    c: &Calibration,
    replicates: usize,
    seed: u64,
) -> FactorCalibrationRecord {
    FactorCalibrationRecord {
        method: FAMILY_METHOD.into(),
        level: c.level,
        seed,
        folds: c.folds,
        replicates,
        factors: factor_records(c),
        out_of_kind: c.out_of_kind.clone(),
    }
}

/// Every family's factor as a model file stores it, with how many of its errors were in sample and
/// held out.
fn factor_records(c: &Calibration) -> BTreeMap<String, FactorRecord> {
    MetricFamily::ALL
        .iter()
        .map(|&fam| {
            let f = c
                .factors
                .get(&fam)
                .copied()
                .unwrap_or(FamilyFactor::TooFew { errors: 0 });
            let counted: Vec<&BandError> = c
                .errors
                .iter()
                .filter(|e| matches!(f, FamilyFactor::Pooled { .. }) || e.family == fam)
                .collect();
            let (outcome, errors) = match f {
                FamilyFactor::Own { errors, .. } => ("own", errors),
                FamilyFactor::Pooled { errors, .. } => ("pooled", errors),
                FamilyFactor::TooFew { errors } => ("too-few", errors),
            };
            (
                fam.as_str().to_string(),
                FactorRecord {
                    outcome: outcome.into(),
                    factor: f.factor(),
                    errors,
                    in_sample: counted.iter().filter(|e| !e.held_out).count(),
                    held_out: counted.iter().filter(|e| e.held_out).count(),
                },
            )
        })
        .collect()
}

/// A model file's calibration, ready to band a run: the pooled replicates of every structure (with
/// the file's effects), the factors, and the identification range of its training data (None when
/// that data cannot be read: the reach is then taken as 1 and said).
pub struct StoredCalibration {
    pub level: f64,
    pub folds: usize,
    /// What the replicates are.
    pub source: CalibratedSource,
    /// Each structure's name and number of replicates, the model's own first (one entry, the
    /// family's name, for an mmg or sparse-GP file).
    pub structures: Vec<(String, usize)>,
    pub factors: BTreeMap<MetricFamily, FamilyFactor>,
    /// The term of the manoeuvre kinds the training recordings did not hold.
    pub out_of_kind: Option<OutOfKindRecord>,
    pub replicates: Vec<Box<dyn Dynamics + Send + Sync>>,
    pub range: Option<IdentificationRange>,
}

/// What a calibrated band's replicates are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CalibratedSource {
    /// The pooled bootstrap replicates of a polynomial file's `[calibration.structure]`s.
    Ensemble,
    /// The block-bootstrap replicates of an mmg file's `[bootstrap]`.
    MmgBootstrap,
    /// Posterior draws of a sparse-GP file.
    PosteriorDraws,
}

impl CalibratedSource {
    /// What the replicated models are called, in the plural.
    pub fn noun(self) -> &'static str {
        match self {
            CalibratedSource::Ensemble => "ensemble replicates",
            CalibratedSource::MmgBootstrap => "bootstrap replicates",
            CalibratedSource::PosteriorDraws => "posterior draws",
        }
    }
}

/// Bands of one run widened by a stored calibration.
pub struct CalibratedBands {
    /// The pooled percentile bands, every metric's widened; the track band's positions by the
    /// turning lengths' factor and its heading by the overshoots', times the reach.
    pub bands: ManoeuvreBands,
    /// The run's reach outside the identification range (1 when the range is unknown).
    pub reach: f64,
}

fn family_factor(f: &FactorRecord) -> FamilyFactor {
    match f.outcome.as_str() {
        "own" => FamilyFactor::Own {
            factor: f.factor,
            errors: f.errors,
        },
        "pooled" => FamilyFactor::Pooled {
            factor: f.factor,
            errors: f.errors,
        },
        _ => FamilyFactor::TooFew { errors: f.errors },
    }
}

impl StoredCalibration {
    /// The factor of metric family `family` (1 when the calibration has none for it).
    pub fn family_factor(&self, family: MetricFamily) -> f64 {
        self.factors.get(&family).map_or(1.0, |f| f.factor())
    }

    /// The factor of `metric`'s family (1 for a metric of no family).
    pub fn factor(&self, metric: &str) -> f64 {
        MetricFamily::of(metric).map_or(1.0, |f| self.family_factor(f))
    }

    /// Which band this is, in one line: "calibrated: ensemble of reduced32 (200 replicates), factor
    /// overshoot 2.10 (own, 4 errors), …".
    pub fn describe(&self) -> String {
        let structures: Vec<String> = self
            .structures
            .iter()
            .map(|(name, n)| format!("{name} ({n} replicates)"))
            .collect();
        let replicates = match self.source {
            CalibratedSource::Ensemble => format!("ensemble of {}", structures.join(" + ")),
            CalibratedSource::MmgBootstrap | CalibratedSource::PosteriorDraws => format!(
                "{} {} ({})",
                self.structures
                    .iter()
                    .map(|(name, _)| name.as_str())
                    .collect::<Vec<_>>()
                    .join(" + "),
                self.source.noun(),
                self.replicates.len()
            ),
        };
        let range = match self.source {
            CalibratedSource::Ensemble => "the identification range",
            CalibratedSource::MmgBootstrap | CalibratedSource::PosteriorDraws => {
                "the training states' range"
            }
        };
        let factors: Vec<String> = self
            .factors
            .iter()
            .map(|(fam, f)| match f {
                FamilyFactor::Own { factor, errors } => {
                    format!("{} {factor:.2} (own, {errors} errors)", fam.as_str())
                }
                FamilyFactor::Pooled { factor, errors } => {
                    format!("{} {factor:.2} (pooled, {errors} errors)", fam.as_str())
                }
                FamilyFactor::TooFew { errors } => {
                    format!("{} 1 (too few errors: {errors})", fam.as_str())
                }
            })
            .collect();
        let held = if self.folds == 0 {
            "in-sample errors only (one training recording)".to_string()
        } else {
            format!("in-sample and {} held-out folds", self.folds)
        };
        let out_of_kind = match &self.out_of_kind {
            Some(o) => {
                format!(
                    "; trained on {} only, so the other kind's metrics take, instead of their factor \
                 and reach, an out-of-kind term of {} (relative half-width measured on a \
                 population of ships, docs/uncertainty.md)",
                    o.trained_on.join(" and "),
                    crate::out_of_kind::terms_in_words(o)
                ) + &crate::out_of_kind::level_note(self.level)
                    + &crate::out_of_kind::caveat(o)
            }
            None => String::new(),
        };
        format!(
            "calibrated: {replicates}, factor {} from {held}, times the reach outside {range}{}{out_of_kind}",
            factors.join(", "),
            if self.range.is_none() {
                " (unknown: the training data cannot be read; taken as 1)"
            } else {
                ""
            }
        )
    }

    /// The bands of manoeuvre `m` run as `how` says, with `point` (the model file's own model) as
    /// the point prediction: the pooled replicates' percentile band of every metric, widened by its
    /// family's factor and the point run's reach.
    pub fn bands(
        &self,
        point: &dyn Dynamics,
        m: &Manoeuvre,
        ship: &Ship,
        how: BandRun,
    ) -> Result<CalibratedBands, PipelineError> {
        let mut bands = manoeuvre_bands(point, &self.replicates, m, ship, self.level, how)?;
        let reach = run_reach(point, self.range.as_ref(), m, ship, how);
        let beyond = reach > MAX_BAND_REACH;
        // How much each family's bands widened in this run: the track follows it.
        let mut widened_by: BTreeMap<MetricFamily, f64> = BTreeMap::new();
        for b in &mut bands.metrics {
            if let Ok(band) = &b.band {
                // A metric the out-of-kind term bands does not take the reach; every other one
                // does, and past the cap the factor · reach widening is no longer a measurement.
                if beyond && out_of_kind_of(self.out_of_kind.as_ref(), b.metric).is_none() {
                    b.band = Err(UncertaintyError::BeyondRange {
                        reach,
                        cap: MAX_BAND_REACH,
                    });
                    continue;
                }
                let w = widen_metric(
                    band,
                    b.metric,
                    self.factor(b.metric),
                    reach,
                    self.out_of_kind.as_ref(),
                );
                if let Some(fam) = MetricFamily::of(b.metric)
                    && band.hi > band.lo
                {
                    let k = (w.hi - w.lo) / (band.hi - band.lo);
                    let e = widened_by.entry(fam).or_insert(k);
                    *e = e.max(k);
                }
                b.band = Ok(w);
            }
        }
        if let Some(track) = &mut bands.track {
            widen_track(track, &widened_by, |fam| self.family_factor(fam), reach);
        }
        Ok(CalibratedBands { bands, reach })
    }
}

/// One series of a track band: [lo, hi] per time, None where it has no band.
type TrackSeries = Vec<Option<(f64, f64)>>;

/// The track band widened like the metrics of the run: positions as the turning-length bands
/// widened, the heading as the overshoot bands (a raw track band beside widened metric bands would
/// show its reader the narrower, untrusted one). A series whose family has no band in this run (the
/// heading of a turning circle, the positions of a zig-zag) widens as the run's other metric bands
/// did, the most of them: the track is the same run those metrics measure. Only a run with no metric
/// band at all takes its family's factor times the reach, and past [`MAX_BAND_REACH`] it has no track
/// band (the series is emptied and the reason given in `without_band`), as its metrics have none.
/// `widened_by` holds each family's widening (widened ÷ raw width) in this run.
pub fn widen_track(
    track: &mut TrackBand,
    widened_by: &BTreeMap<MetricFamily, f64>,
    family_factor: impl Fn(MetricFamily) -> f64,
    reach: f64,
) {
    let widest = widened_by.values().copied().reduce(f64::max);
    let k = |fam: MetricFamily| -> Result<f64, String> {
        match (widened_by.get(&fam), widest) {
            (Some(&k), _) | (None, Some(k)) => Ok(k),
            (None, None) if reach <= MAX_BAND_REACH => Ok(family_factor(fam) * reach),
            (None, None) => Err(UncertaintyError::BeyondRange {
                reach,
                cap: MAX_BAND_REACH,
            }
            .to_string()),
        }
    };
    let series: [(&'static str, &mut TrackSeries, MetricFamily); 3] = [
        ("x0_m", &mut track.x0_m, MetricFamily::TurningLength),
        ("y0_m", &mut track.y0_m, MetricFamily::TurningLength),
        ("psi_deg", &mut track.psi_deg, MetricFamily::Overshoot),
    ];
    for (name, values, fam) in series {
        match k(fam) {
            Ok(k) => {
                for interval in values.iter_mut().flatten() {
                    *interval = widen_interval(*interval, k);
                }
            }
            Err(why) => {
                values.iter_mut().for_each(|v| *v = None);
                track.without_band.insert(name, why);
            }
        }
    }
}

/// The calibration of the model file `spec` at `level`: None when it is no fitted model file
/// (polynomial, mmg or sparse GP) or has no `[calibration]` (its bands are then its replicates'
/// alone). Bad input, naming the key, for a damaged table, and for a `level` other than the one the
/// factors were obtained at.
pub fn stored_calibration(
    spec: &str,
    level: f64,
) -> Result<Option<StoredCalibration>, PipelineError> {
    let path = std::path::Path::new(spec);
    if !path.is_file() {
        return Ok(None);
    }
    let (text, kind) = crate::environment::model_file_family_text(path)?;
    match kind.as_deref() {
        Some("abkowitz") => {
            // The polynomial format has `[environment]`: its own reader, on the whole text.
            let whole =
                std::fs::read_to_string(path).map_err(|e| shipid_io::InputError::read(path, &e))?;
            polynomial_calibration(spec, &whole, level)
        }
        Some(MMG_KIND) => own_replicates(
            spec,
            &text,
            level,
            CalibratedSource::MmgBootstrap,
            |f: &MmgModelFile| (f.calibration.as_ref(), &f.training),
            |f| mmg_file_replicates(f, path),
        ),
        Some(GP_KIND) => own_replicates(
            spec,
            &text,
            level,
            CalibratedSource::PosteriorDraws,
            |f: &GpModelFile| (f.calibration.as_ref(), &f.training),
            |f| gp_file_draws(f, path),
        ),
        _ => Ok(None),
    }
}

/// A level other than the calibration's is refused, naming the key.
fn check_stored_level(spec: &str, stored: f64, level: f64) -> Result<(), PipelineError> {
    if (stored - level).abs() > 1e-9 {
        return Err(bad_input(format!(
            "{spec}: its calibration was obtained at level {stored} (key `calibration.level`) and \
             widens bands of that level only: use --bands {stored}, or refit with --calibrate {level}"
        )));
    }
    Ok(())
}

/// The factors of an mmg or sparse-GP `[calibration]`, checked (a damaged key named) at `level`.
fn stored_factors(
    spec: &str,
    record: &FactorCalibrationRecord,
    level: f64,
) -> Result<BTreeMap<MetricFamily, FamilyFactor>, PipelineError> {
    let path = std::path::Path::new(spec);
    record
        .check()
        .map_err(|e| shipid_io::InputError::key(path, &e.key, e.reason))?;
    crate::metric_family::check_factor_cap(path, &record.factors)?;
    check_stored_level(spec, record.level, level)?;
    Ok(family_factors(&record.factors))
}

/// A checked record's factors by family.
fn family_factors(stored: &BTreeMap<String, FactorRecord>) -> BTreeMap<MetricFamily, FamilyFactor> {
    MetricFamily::ALL
        .iter()
        .filter_map(|&fam| stored.get(fam.as_str()).map(|f| (fam, family_factor(f))))
        .collect()
}

/// The calibration of an mmg or sparse-GP file (`spec`, of type `F`) over its own replicates:
/// `parts` gives its `[calibration]` and training windows, `replicates` makes the replicates once
/// the record has been checked at `level`; the reach comes from its training windows.
fn own_replicates<F: serde::de::DeserializeOwned>(
    spec: &str,
    text: &str,
    level: f64,
    source: CalibratedSource,
    parts: impl Fn(&F) -> (Option<&FactorCalibrationRecord>, &[TrainingWindow]),
    replicates: impl FnOnce(&F) -> Result<Vec<Box<dyn Dynamics + Send + Sync>>, PipelineError>,
) -> Result<Option<StoredCalibration>, PipelineError> {
    let path = std::path::Path::new(spec);
    let file: F = toml::from_str(text).map_err(|e| shipid_io::InputError::toml(path, text, &e))?;
    let (Some(record), training) = parts(&file) else {
        return Ok(None);
    };
    let factors = stored_factors(spec, record, level)?;
    let replicates = replicates(&file)?;
    let name = match source {
        CalibratedSource::PosteriorDraws => "sparse-GP",
        CalibratedSource::Ensemble | CalibratedSource::MmgBootstrap => MMG_KIND,
    };
    Ok(Some(StoredCalibration {
        level: record.level,
        folds: record.folds,
        source,
        structures: vec![(name.to_string(), replicates.len())],
        factors,
        out_of_kind: record.out_of_kind.clone(),
        replicates,
        range: stored_state_range(spec, training),
    }))
}

/// A polynomial file's `[calibration]`: its structures' pooled replicates (with the file's effects).
fn polynomial_calibration(
    spec: &str,
    text: &str,
    level: f64,
) -> Result<Option<StoredCalibration>, PipelineError> {
    let path = std::path::Path::new(spec);
    let file: ModelFile =
        toml::from_str(text).map_err(|e| shipid_io::InputError::toml(path, text, &e))?;
    let Some(record) = &file.calibration else {
        return Ok(None);
    };
    let checked = record
        .check(&file.set.name)
        .map_err(|e| shipid_io::InputError::key(path, &e.key, e.reason))?;
    crate::metric_family::check_factor_cap(path, &checked.factors)?;
    check_stored_level(spec, record.level, level)?;
    let effects: Vec<Effect> = file
        .effects
        .iter()
        .map(|e| e.effect.parse::<Effect>())
        .collect::<Result<_, _>>()
        .map_err(|e| shipid_io::InputError::key(path, "effects", e.to_string()))?;
    let mut replicates: Vec<Box<dyn Dynamics + Send + Sync>> = Vec::new();
    let mut structures = Vec::new();
    for (set, vectors) in checked.structures {
        structures.push((set.name.clone(), vectors.len()));
        for c in vectors {
            let Ok(m) = AbkowitzModel::new(set.clone(), c, file.ship, file.added_mass) else {
                continue;
            };
            if effects.is_empty() {
                replicates.push(Box::new(AbkowitzDynamics(m)));
            } else {
                let wrapped = WithEffects::new(AbkowitzDynamics(m), &effects)
                    .map_err(|e| shipid_io::InputError::key(path, "effects", e.to_string()))?;
                replicates.push(Box::new(wrapped));
            }
        }
    }
    let factors = family_factors(&checked.factors);
    let range = crate::range::training_data(spec)
        .as_ref()
        .and_then(crate::range::identification_range);
    Ok(Some(StoredCalibration {
        level: record.level,
        folds: record.folds,
        source: CalibratedSource::Ensemble,
        structures,
        factors,
        out_of_kind: record.out_of_kind.clone(),
        replicates,
        range,
    }))
}

/// The bands `simulate --bands` and `validate --bands` give for a model file: calibrated when the
/// file has a `[calibration]`, else its replicates' raw percentiles.
pub enum ModelBands {
    Calibrated(Box<StoredCalibration>),
    Raw {
        kind: BandKind,
        replicates: Vec<Box<dyn Dynamics + Send + Sync>>,
    },
}

/// The bands of one run and, when calibrated, its reach.
pub struct RunBands {
    pub bands: ManoeuvreBands,
    pub reach: Option<f64>,
}

impl ModelBands {
    /// Simulations the bands add to a run: one per replicate.
    pub fn runs(&self) -> usize {
        match self {
            ModelBands::Calibrated(c) => c.replicates.len(),
            ModelBands::Raw { replicates, .. } => replicates.len(),
        }
    }

    /// The bands of the model file `spec` at `level` (see [`stored_calibration`] and
    /// `bands::replicate_models` for what is refused).
    pub fn of(spec: &str, level: f64) -> Result<ModelBands, PipelineError> {
        if let Some(c) = stored_calibration(spec, level)? {
            return Ok(ModelBands::Calibrated(Box::new(c)));
        }
        let (replicates, kind) = replicated_models(spec)?;
        Ok(ModelBands::Raw { kind, replicates })
    }

    /// `calibrated`, `bootstrap`, `posterior-draws` or `ensemble`.
    pub fn kind(&self) -> &'static str {
        match self {
            ModelBands::Calibrated(_) => "calibrated",
            ModelBands::Raw {
                kind: BandKind::Bootstrap,
                ..
            } => "bootstrap",
            ModelBands::Raw {
                kind: BandKind::PosteriorDraws,
                ..
            } => "posterior-draws",
            ModelBands::Raw {
                kind: BandKind::Ensemble,
                ..
            } => "ensemble",
        }
    }

    /// What the replicated models are called, in the plural.
    pub fn noun(&self) -> &'static str {
        match self {
            ModelBands::Calibrated(c) => c.source.noun(),
            ModelBands::Raw { kind, .. } => kind.noun(),
        }
    }

    /// For an ensemble of several structures, how many of each structure's replicates are among
    /// `diverged` (replicate indices, structures in their stored order): "full68 50 of 50, …", or
    /// `None` for one structure or another kind of band.
    pub fn diverged_by_structure(&self, diverged: &[usize]) -> Option<String> {
        let ModelBands::Calibrated(c) = self else {
            return None;
        };
        if c.source != CalibratedSource::Ensemble || c.structures.len() < 2 {
            return None;
        }
        let mut start = 0;
        let parts: Vec<String> = c
            .structures
            .iter()
            .map(|(name, n)| {
                let lost = diverged
                    .iter()
                    .filter(|&&i| (start..start + n).contains(&i))
                    .count();
                start += n;
                format!("{name} {lost} of {n}")
            })
            .collect();
        Some(parts.join(", "))
    }

    /// Which band this is, in one line.
    pub fn what(&self) -> String {
        match self {
            ModelBands::Calibrated(c) => c.describe(),
            ModelBands::Raw { kind, .. } => kind.what().into(),
        }
    }

    /// Why `level` asks more than these replicates resolve, or `None`: n replicates' interpolated
    /// percentiles reach their extremes once the level passes (n − 1)/(n + 1), the probability that
    /// their range holds one more draw; a band asked beyond it is that range labelled with a level
    /// it does not have (200 posterior draws called a 99.9999 % band). An inverse ensemble's order
    /// statistics say so in their own description.
    pub fn beyond_resolution(&self, level: f64) -> Option<String> {
        if matches!(
            self,
            ModelBands::Raw {
                kind: BandKind::Ensemble,
                ..
            }
        ) {
            return None;
        }
        let n = self.replicates() as f64;
        let resolved = (n - 1.0) / (n + 1.0);
        (level > resolved).then(|| {
            format!(
                "{} {} resolve bands up to about {:.1} %: beyond it a band is their range, which holds one more draw with probability {:.1} %, not the {} % asked; ask a lower level or store more replicates",
                self.replicates(),
                self.noun(),
                100.0 * resolved,
                100.0 * resolved,
                shipid_io::error::number(100.0 * level)
            )
        })
    }

    pub fn replicates(&self) -> usize {
        match self {
            ModelBands::Calibrated(c) => c.replicates.len(),
            ModelBands::Raw { replicates, .. } => replicates.len(),
        }
    }

    /// The factor per metric family of a calibrated band (empty otherwise).
    pub fn factors(&self) -> BTreeMap<&'static str, f64> {
        match self {
            ModelBands::Calibrated(c) => c
                .factors
                .iter()
                .map(|(fam, f)| (fam.as_str(), f.factor()))
                .collect(),
            ModelBands::Raw { .. } => BTreeMap::new(),
        }
    }

    /// The out-of-kind term of a calibrated band (None otherwise, or when the training held every
    /// kind).
    pub fn out_of_kind(&self) -> Option<&OutOfKindRecord> {
        match self {
            ModelBands::Calibrated(c) => c.out_of_kind.as_ref(),
            ModelBands::Raw { .. } => None,
        }
    }

    /// The bands of manoeuvre `m` run as `how` says around `point` (the file's own model).
    pub fn bands(
        &self,
        point: &dyn Dynamics,
        m: &Manoeuvre,
        ship: &Ship,
        level: f64,
        how: BandRun,
    ) -> Result<RunBands, PipelineError> {
        match self {
            ModelBands::Calibrated(c) => c.bands(point, m, ship, how).map(|b| RunBands {
                bands: b.bands,
                reach: Some(b.reach),
            }),
            ModelBands::Raw { replicates, kind } => {
                manoeuvre_bands_of(point, replicates, *kind, m, ship, level, how)
                    .map(|bands| RunBands { bands, reach: None })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ensemble(structures: &[(&str, usize)]) -> ModelBands {
        ModelBands::Calibrated(Box::new(StoredCalibration {
            level: 0.9,
            folds: 2,
            source: CalibratedSource::Ensemble,
            structures: structures
                .iter()
                .map(|(n, k)| (n.to_string(), *k))
                .collect(),
            factors: BTreeMap::new(),
            out_of_kind: None,
            replicates: Vec::new(),
            range: None,
        }))
    }

    /// Regression: half of a four-structure ensemble diverged in a turn and the band's description
    /// still named all four; the replicates are pooled in the structures' order, so their indices
    /// tell which structure each diverged one belongs to.
    #[test]
    fn diverged_replicates_are_counted_per_structure() {
        let bands = ensemble(&[("reduced32", 3), ("full68", 2), ("chen2021", 2)]);
        assert_eq!(
            bands.diverged_by_structure(&[3, 4, 6]).as_deref(),
            Some("reduced32 0 of 3, full68 2 of 2, chen2021 1 of 2")
        );
        assert_eq!(
            ensemble(&[("reduced32", 3)]).diverged_by_structure(&[0]),
            None
        );
    }
}
