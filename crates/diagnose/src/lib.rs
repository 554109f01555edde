//! Discrepancy diagnosis (`shipid diagnose`): compare a model with recordings it did not see, locate the
//! mismatch, name the physical effect that was left out, fit it and show the fit improve.
//!
//! No I/O here: [`diagnose`] takes a model and a loaded data set and returns a [`Report`] in the layout
//! of DATA.md ("A diagnosis report").
//!
//! How it decides (the numbers are [`DiagnoseOptions`]):
//! 1. **Compare.** Every recording is replayed in the model in *segments* of `horizon` (10 L/U0 by
//!    default) restarted from the recorded state (a 1.1 s centred mean, to keep the velocity noise out of
//!    the start), with the recorded rudder. Long open-loop replays of a zig-zag drift by whole ship
//!    lengths even for a good identified model (a small yaw-rate bias integrates into heading), which
//!    would hide every effect; segments keep the model's own error small and an effect's signature
//!    (a drift, a lag, a bias) intact. The equation-error residual — recorded (or differentiated)
//!    accelerations minus the model's at the recorded state and rudder — says *where* and in *which DOF*.
//! 2. **Name.** Every effect of the library ([`Family`]) is fitted to half of the recordings in the
//!    equation-error sense (cheap, no integration; Levenberg–Marquardt on a handful of physical
//!    parameters, base model fixed) and judged by the segment-replay position error on the other half;
//!    then the halves swap, so each recording is held out once.
//! 3. **Verdict.** A candidate is accepted when the held-out position RMSE of a typical recording (the
//!    geometric mean of after/before over recordings) is at least `min_gain` lower than the model's,
//!    at least 10 % lower in both halves, and the median recording improves by more than twice the
//!    noise floor of the recordings.
//!    Among accepted candidates, one with fewer parameters wins unless another is clearly better
//!    (`parsimony` per parameter). If the winner leaves more than half of the mismatch, pairs with it are
//!    tried. Nothing accepted: `none` when the mismatch is within what the model shows on its own
//!    training data (or within the noise), otherwise `unexplained`.
//! 4. **Model it.** The winner is refitted on all recordings; standard errors from the Gauss–Newton
//!    covariance with the residual autocorrelation accounted for by thinning the samples to one per
//!    smoothing window.

pub mod bench;

use std::collections::BTreeMap;

use rayon::prelude::*;
use serde::Serialize;
use shipid_io::{
    Accelerations, Dataset, PrimeScale, Recording, Ship, deriv::accelerations_or_estimate,
};
use shipid_model::IdentificationRange;
use shipid_sim::effects::{Asymmetry, Current, RudderLag, ShallowWater, Wind};
use shipid_sim::{
    Dynamics, Effect, RudderFilter, State, WithEffects,
};

use shipid_pipeline::lm::{LmPoint, dot, lm_step, solve_small};
use shipid_pipeline::range::{outside_count, share};
use shipid_pipeline::replay::{
    differentiator_margin, replay_segment, segments,
};
use shipid_pipeline::validate::interp;

/// Tunables of the diagnosis, with their reasons.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiagnoseOptions {
    /// Length of a replay segment ÷ (L/U0). 10 L/U0 is about one zig-zag period of KVLCC2: long enough
    /// for a current to drift the track by a visible amount, short enough that a model's own heading
    /// drift stays small.
    pub horizon_l_over_u0: f64,
    /// Smallest held-out relative reduction of the position RMSE for an effect to be accepted.
    pub min_gain: f64,
    /// Relative held-out error a candidate pays per parameter when candidates are ranked.
    pub parsimony: f64,
    /// A mismatch is real (and `unexplained` if nothing explains it) when the held-out position RMSE
    /// exceeds this multiple of the model's own level (on its training data, when known) plus the noise.
    pub real_mismatch_factor: f64,
    /// Largest number of equation-error samples per recording used in a fit.
    pub max_samples_per_recording: usize,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            horizon_l_over_u0: 10.0,
            min_gain: 0.3,
            parsimony: 0.03,
            real_mismatch_factor: 2.0,
            max_samples_per_recording: 400,
        }
    }
}

/// What an effect family is: its word, its parameters, and how to build it from them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Family {
    Current,
    Wind,
    RudderLag,
    /// `asymmetry` as a rudder neutral offset.
    RudderOffset,
    /// `asymmetry` as a constant side force and yaw moment (single-screw propeller).
    SideForce,
    ShallowWater,
}

impl Family {
    pub const ALL: [Family; 6] = [
        Family::Current,
        Family::Wind,
        Family::RudderLag,
        Family::RudderOffset,
        Family::SideForce,
        Family::ShallowWater,
    ];

    pub fn word(self) -> &'static str {
        match self {
            Family::Current => "current",
            Family::Wind => "wind",
            Family::RudderLag => "rudder_lag",
            Family::RudderOffset | Family::SideForce => "asymmetry",
            Family::ShallowWater => "shallow_water",
        }
    }

    /// Name of the candidate in reports (the word, and for `asymmetry` its form).
    pub fn label(self) -> &'static str {
        match self {
            Family::RudderOffset => "asymmetry(rudder_offset)",
            Family::SideForce => "asymmetry(side_force)",
            f => f.word(),
        }
    }

    /// Number of fitted parameters.
    pub fn dim(self) -> usize {
        match self {
            Family::Current | Family::Wind => 2,
            Family::RudderLag => 2,
            Family::RudderOffset => 1,
            Family::SideForce => 2,
            Family::ShallowWater => 1,
        }
    }

    /// Internal parameters are scaled to be of order one for the ship: velocities ÷ U0, times ÷ (L/U0),
    /// forces ÷ (½ρLTU0² · 10⁻³), moments ÷ (½ρL²TU0² · 10⁻³), the rudder offset in degrees.
    fn bounds(self) -> (Vec<f64>, Vec<f64>) {
        match self {
            Family::Current => (vec![-0.5, -0.5], vec![0.5, 0.5]),
            Family::Wind => (vec![-15.0, -15.0], vec![15.0, 15.0]),
            Family::RudderLag => (vec![0.0, 0.0], vec![2.0, 2.0]),
            Family::RudderOffset => (vec![-10.0], vec![10.0]),
            Family::SideForce => (vec![-20.0, -20.0], vec![20.0, 20.0]),
            // f − 1 of the shallow-water factor; f → 2 when the keel touches the bottom. (A separate yaw
            // factor, `f_yaw`, fitted no better on the benchmark and is left to the user.)
            Family::ShallowWater => (vec![0.0], vec![0.98]),
        }
    }

    /// Starting points of the fit (wind's force is quadratic in its speed, so it needs several).
    fn starts(self) -> Vec<Vec<f64>> {
        match self {
            Family::Current => vec![vec![0.0, 0.0]],
            Family::Wind => {
                let mut s = Vec::new();
                for speed in [1.0, 2.5, 5.0] {
                    for k in 0..12 {
                        let a = k as f64 * std::f64::consts::PI / 6.0;
                        s.push(vec![speed * a.cos(), speed * a.sin()]);
                    }
                }
                s
            }
            Family::RudderLag => vec![vec![0.05, 0.0], vec![0.0, 0.05]],
            Family::RudderOffset => vec![vec![0.0]],
            Family::SideForce => vec![vec![0.0, 0.0]],
            Family::ShallowWater => vec![vec![0.1]],
        }
    }

    /// The effect for internal parameters `p` on `ship`.
    pub fn effect(self, p: &[f64], ship: &Ship) -> Effect {
        let l_over_u0 = ship.lpp / ship.u0;
        let q = 0.5 * ship.rho * ship.lpp * ship.draft * ship.u0 * ship.u0 * 1e-3;
        let from_deg = |n: f64, e: f64| (-e).atan2(-n).to_degrees().rem_euclid(360.0);
        match self {
            Family::Current => Effect::Current(Current {
                speed_m_s: p[0].hypot(p[1]) * ship.u0,
                from_deg: from_deg(p[0], p[1]),
            }),
            Family::Wind => Effect::Wind(Wind {
                speed_m_s: p[0].hypot(p[1]) * ship.u0,
                from_deg: from_deg(p[0], p[1]),
                frontal_area_m2: None,
                lateral_area_m2: None,
            }),
            Family::RudderLag => Effect::RudderLag(RudderLag {
                time_constant_s: p[0].max(0.0) * l_over_u0,
                delay_s: p[1].max(0.0) * l_over_u0,
            }),
            Family::RudderOffset => Effect::Asymmetry(Asymmetry {
                rudder_offset_deg: p[0],
                y0_n: 0.0,
                n0_nm: 0.0,
            }),
            Family::SideForce => Effect::Asymmetry(Asymmetry {
                rudder_offset_deg: 0.0,
                y0_n: p[0] * q,
                n0_nm: p[1] * q * ship.lpp,
            }),
            Family::ShallowWater => Effect::ShallowWater(ShallowWater {
                depth_over_draft: depth_for_factor(1.0 + p[0].clamp(0.0, 0.98)),
                yaw_factor: None,
            }),
        }
    }
}

/// h/T whose [`ShallowWater::factor`] is `f` (bisection: the factor falls monotonically with depth).
pub fn depth_for_factor(f: f64) -> f64 {
    let factor = |h: f64| {
        ShallowWater {
            depth_over_draft: h,
            yaw_factor: None,
        }
        .factor()
    };
    if f <= factor(100.0) {
        return 100.0;
    }
    let (mut lo, mut hi) = (1.0 + 1e-9, 100.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if factor(mid) > f {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// One recording ready for the diagnosis.
#[derive(Debug, Clone)]
pub struct Prepared {
    pub file: String,
    pub rec: Recording,
    pub acc: Accelerations,
    /// Indices of the equation-error samples (thinned).
    pub samples: Vec<usize>,
}

/// Prepare the recordings of `ds`: accelerations (recorded or differentiated) and the thinned samples.
pub fn prepare(ds: &Dataset, ship: &Ship, opts: &DiagnoseOptions) -> Vec<Prepared> {
    ds.recordings
        .iter()
        .filter(|r| r.recording.len() >= 20)
        .map(|r| {
            let (acc, _) = accelerations_or_estimate(&r.recording, ship);
            let n = r.recording.len();
            let margin = differentiator_margin(n);
            let usable = n - 2 * margin;
            let stride = usable.div_ceil(opts.max_samples_per_recording).max(1);
            let samples = (margin..n - margin).step_by(stride).collect();
            Prepared {
                file: r.file.clone(),
                rec: r.recording.clone(),
                acc,
                samples,
            }
        })
        .collect()
}


/// The acting rudder for the recorded one through `filter`, at the recording's samples.
fn filtered_rudder(filter: &mut dyn RudderFilter, rec: &Recording) -> Vec<f64> {
    let (t, d) = (&rec.t, &rec.delta);
    let mut out = Vec::with_capacity(t.len());
    out.push(filter.step(t[0], 0.0, [d[0]; 3])[0]);
    for i in 0..t.len() - 1 {
        let h = t[i + 1] - t[i];
        let y = filter.step(t[i], h, [d[i], 0.5 * (d[i] + d[i + 1]), d[i + 1]]);
        out.push(y[2]);
    }
    out
}

/// Equation-error residuals [m/s², m/s², rad/s²] of `model` at the thinned samples of `p`
/// (`None` where the model fails).
fn residuals(model: &dyn Dynamics, p: &Prepared) -> Vec<Option<[f64; 3]>> {
    let delta = match model.model_rudder_filter() {
        Some(mut f) => filtered_rudder(f.as_mut(), &p.rec),
        None => p.rec.delta.clone(),
    };
    p.samples
        .iter()
        .map(|&i| {
            let a = model
                .accelerations(&State::of_recording(&p.rec, i), delta[i])
                .ok()?;
            let rec = [p.acc.u_dot[i], p.acc.v_dot[i], p.acc.r_dot[i]];
            let e = [rec[0] - a[0], rec[1] - a[1], rec[2] - a[2]];
            e.iter().all(|x| x.is_finite()).then_some(e)
        })
        .collect()
}

/// Robust scale (1.4826 × median absolute value) per DOF of the residuals.
fn robust_scale(res: &[Vec<Option<[f64; 3]>>]) -> [f64; 3] {
    std::array::from_fn(|d| {
        let mut a: Vec<f64> = res.iter().flatten().flatten().map(|e| e[d].abs()).collect();
        if a.is_empty() {
            return 1.0;
        }
        let mid = a.len() / 2;
        a.select_nth_unstable_by(mid, |x, y| x.total_cmp(y));
        let s = 1.4826 * a[mid];
        if s > 0.0 && s.is_finite() { s } else { 1.0 }
    })
}

/// A model with effects: the base (without its own effects) and the effects to apply.
struct Composite<'a> {
    base: &'a (dyn Dynamics + Send + Sync),
    effects: Vec<Effect>,
}

impl Composite<'_> {
    fn model(&self) -> Option<WithEffects<&(dyn Dynamics + Send + Sync)>> {
        WithEffects::new(self.base, &self.effects).ok()
    }
}

fn combine(base_effects: &[Effect], extra: &[Effect]) -> Vec<Effect> {
    let mut all: Vec<Effect> = base_effects
        .iter()
        .filter(|e| !extra.iter().any(|x| x.kind() == e.kind()))
        .copied()
        .collect();
    all.extend_from_slice(extra);
    all
}

/// Weighted equation-error residual vector of a composite over recordings `idx` (failures penalised).
fn weighted_residual(
    c: &Composite,
    prep: &[Prepared],
    idx: &[usize],
    scale: &[f64; 3],
) -> Vec<f64> {
    let Some(model) = c.model() else {
        return vec![1e3; idx.iter().map(|&i| prep[i].samples.len() * 3).sum()];
    };
    let mut out = Vec::new();
    for &i in idx {
        for e in residuals(&model, &prep[i]) {
            match e {
                Some(e) => (0..3).for_each(|d| out.push(e[d] / scale[d])),
                None => out.extend([1e3; 3]),
            }
        }
    }
    out
}

/// Result of a least-squares fit of effect parameters.
#[derive(Debug, Clone)]
struct FitResult {
    params: Vec<f64>,
    cost: f64,
    /// Standard errors of the internal parameters (Gauss–Newton covariance).
    std_err: Vec<f64>,
}


/// Projected Levenberg–Marquardt with forward-difference Jacobian on `f`, within `lo..hi`.
fn levenberg_marquardt(
    f: &(dyn Fn(&[f64]) -> Vec<f64> + Sync),
    start: &[f64],
    lo: &[f64],
    hi: &[f64],
) -> FitResult {
    let k = start.len();
    let clamp = |p: &mut Vec<f64>| (0..k).for_each(|j| p[j] = p[j].clamp(lo[j], hi[j]));
    let mut p = start.to_vec();
    clamp(&mut p);
    let r = f(&p);
    let cost = r.iter().map(|x| x * x).sum::<f64>();
    let mut at = LmPoint { p, r, cost };
    let mut lambda = 1e-3;
    // Set by the first iteration (there always is one); the last one's gives the covariance.
    let mut jac: Vec<Vec<f64>> = Vec::new();
    for _ in 0..40 {
        // The columns in parallel: near the end of a diagnosis one long fit is often all that is left.
        jac = (0..k)
            .into_par_iter()
            .map(|j| {
                let h = 1e-4 * (hi[j] - lo[j]).max(1e-12);
                let mut q = at.p.clone();
                // Step inwards at an upper bound.
                let step = if q[j] + h > hi[j] { -h } else { h };
                q[j] += step;
                let rq = f(&q);
                rq.iter().zip(&at.r).map(|(a, b)| (a - b) / step).collect()
            })
            .collect();
        // A parameter at a bound that the descent direction pushes outwards stays there: the projected
        // full step would cut it back, and the others' steps, computed as if it moved, would crawl.
        let free_jac: Vec<Vec<f64>> = jac
            .iter()
            .enumerate()
            .map(|(j, col)| {
                let g = dot(col, &at.r);
                let pinned = (at.p[j] <= lo[j] && g > 0.0) || (at.p[j] >= hi[j] && g < 0.0);
                if pinned {
                    vec![0.0; col.len()]
                } else {
                    col.clone()
                }
            })
            .collect();
        let improved =
            lm_step(&free_jac, &mut at, &mut lambda, 8, clamp, f).is_some_and(|rel| rel > 1e-7);
        if !improved {
            break;
        }
    }
    // Covariance σ² (JᵀJ)⁻¹ at the solution, σ² from the residual.
    let m = at.r.len().max(k + 1);
    let s2 = at.cost / (m - k) as f64;
    let jtj: Vec<Vec<f64>> = (0..k)
        .map(|a| (0..k).map(|b| dot(&jac[a], &jac[b])).collect())
        .collect();
    let std_err = (0..k)
        .map(|j| {
            let mut e = vec![0.0; k];
            e[j] = 1.0;
            solve_small(&jtj, &e).map_or(f64::NAN, |col| (s2 * col[j]).max(0.0).sqrt())
        })
        .collect();
    FitResult {
        params: at.p,
        cost: at.cost,
        std_err,
    }
}


/// Starting points of a joint fit of `families`: the product of each family's grid of starts (small:
/// wind has 36, the others 1–2). Where `alone[i]` holds family i's parameters fitted alone to the same
/// recordings, the first family starts from there only (a pair is tried because its first member
/// already explains part of the mismatch) and the others' grids gain that point.
fn start_grid(families: &[Family], alone: &[Option<&[f64]>]) -> Vec<Vec<f64>> {
    families
        .iter()
        .enumerate()
        .fold(vec![vec![]], |starts, (i, f)| {
            let fitted = alone.get(i).copied().flatten().map(<[f64]>::to_vec);
            let own: Vec<Vec<f64>> = match (i, fitted) {
                (0, Some(p)) => vec![p],
                (_, Some(p)) => f.starts().into_iter().chain([p]).collect(),
                (_, None) => f.starts(),
            };
            starts
                .iter()
                .flat_map(|s| {
                    own.iter().map(move |t| {
                        let mut u = s.clone();
                        u.extend_from_slice(t);
                        u
                    })
                })
                .collect()
        })
}

/// Fit `families` jointly on recordings `idx` with the base (and its effects) fixed, from `starts`
/// (see [`start_grid`]): every start is costed, and the best `refine` are refined.
#[allow(clippy::too_many_arguments)]
fn fit_families(
    base: &(dyn Dynamics + Send + Sync),
    base_effects: &[Effect],
    families: &[Family],
    prep: &[Prepared],
    idx: &[usize],
    scale: &[f64; 3],
    starts: Vec<Vec<f64>>,
    refine: usize,
) -> (Vec<Effect>, FitResult) {
    let ship = *base.ship();
    let dims: Vec<usize> = families.iter().map(|f| f.dim()).collect();
    let split = |p: &[f64]| -> Vec<Effect> {
        let mut at = 0;
        families
            .iter()
            .zip(&dims)
            .map(|(f, &d)| {
                let e = f.effect(&p[at..at + d], &ship);
                at += d;
                e
            })
            .collect()
    };
    let (mut lo, mut hi) = (Vec::new(), Vec::new());
    for f in families {
        let (l, h) = f.bounds();
        lo.extend(l);
        hi.extend(h);
    }
    let k: usize = dims.iter().sum();
    let mut starts: Vec<Vec<f64>> = starts.into_iter().filter(|s| s.len() == k).collect();
    if starts.is_empty() {
        starts = start_grid(families, &[]);
    }
    let objective = |p: &[f64]| {
        let c = Composite {
            base,
            effects: combine(base_effects, &split(p)),
        };
        weighted_residual(&c, prep, idx, scale)
    };
    // Several starts: rank them by their cost, refine the best.
    let mut ranked: Vec<(f64, Vec<f64>)> = starts
        .into_par_iter()
        .map(|s| (objective(&s).iter().map(|x| x * x).sum::<f64>(), s))
        .collect();
    ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
    let best = ranked[..ranked.len().min(refine.max(1))]
        .par_iter()
        .map(|(_, s)| levenberg_marquardt(&objective, s, &lo, &hi))
        .min_by(|a, b| a.cost.total_cmp(&b.cost))
        .expect("a start grid is never empty");
    (split(&best.params), best)
}

/// A candidate judged across the folds: per-recording held-out scores, and the parameters
/// fitted to each fold (by fold index).
type CrossFit = (Vec<ReplayScore>, Vec<(usize, Vec<f64>)>);

/// One fold's fit: the fold trained on, its parameters, and the held-out recordings' scores.
type FoldFit = (usize, Vec<f64>, Vec<(usize, ReplayScore)>);

/// Position and heading errors of segment replays.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct ReplayScore {
    /// Sum of squared position errors [m²] and their count.
    #[serde(skip)]
    pub sum_sq_pos: f64,
    #[serde(skip)]
    pub sum_sq_psi: f64,
    #[serde(skip)]
    pub count: usize,
    /// Segments that diverged.
    pub diverged_segments: usize,
}

impl ReplayScore {
    fn add(&mut self, o: &ReplayScore) {
        self.sum_sq_pos += o.sum_sq_pos;
        self.sum_sq_psi += o.sum_sq_psi;
        self.count += o.count;
        self.diverged_segments += o.diverged_segments;
    }
    pub fn position_rmse(&self) -> f64 {
        (self.sum_sq_pos / self.count.max(1) as f64).sqrt()
    }
    pub fn heading_rmse_rad(&self) -> f64 {
        (self.sum_sq_psi / self.count.max(1) as f64).sqrt()
    }
}


/// Position error ÷ L that segment replays make with an exact model on its own noise-free recordings
/// (rudder interpolated between samples, RK4 at another step than the generator's, six-digit CSV):
/// the MMG reference replays its own clean data to 1e-4 L; below ten times that, a mismatch is not
/// real whatever the noise estimate says (it is zero on noise-free data).
pub const REPLAY_RESOLUTION_OVER_L: f64 = 1e-3;

/// Largest position error ÷ L one sample contributes: a segment that diverges (or leaves the model's
/// domain) counts as this much wrong from then on, so that one runaway segment does not outweigh a
/// whole data set.
pub const POSITION_ERROR_CAP_OVER_L: f64 = 1.0;

/// Segment-replay score of `model` on recording `rec`.
fn replay_score(model: &dyn Dynamics, rec: &Recording, horizon_s: f64) -> ReplayScore {
    let mut s = ReplayScore::default();
    let cap = POSITION_ERROR_CAP_OVER_L * model.ship().lpp;
    for (a, b) in segments(rec, horizon_s) {
        let (sim, ok) = replay_segment(model, rec, a, b);
        if !ok {
            s.diverged_segments += 1;
        }
        let t0 = rec.t[a];
        let end = sim.t.last().copied().unwrap_or(-1.0);
        for i in a..b {
            let t = rec.t[i] - t0;
            if sim.is_empty() || t > end + 1e-9 {
                let missing = b - i;
                s.sum_sq_pos += missing as f64 * cap * cap;
                s.sum_sq_psi += missing as f64 * 1.0;
                s.count += missing;
                break;
            }
            let at = |y: &[f64]| interp(&sim.t, y, t);
            let e = (at(&sim.x0) - rec.x0[i]).hypot(at(&sim.y0) - rec.y0[i]);
            s.sum_sq_pos += e.min(cap).powi(2);
            s.sum_sq_psi += (at(&sim.psi) - rec.psi[i]).powi(2).min(1.0);
            s.count += 1;
        }
    }
    s
}

/// Times and north and east positions [m] of each segment replay (for figures).
pub fn segment_tracks(model: &dyn Dynamics, rec: &Recording, horizon_s: f64) -> Vec<SegmentTrack> {
    segments(rec, horizon_s)
        .into_iter()
        .map(|(a, b)| {
            let (sim, _) = replay_segment(model, rec, a, b);
            SegmentTrack {
                t_s: sim.t.iter().map(|t| t + rec.t[a]).collect(),
                x0: sim.x0,
                y0: sim.y0,
            }
        })
        .collect()
}

/// One segment replay's track: recording time [s] and earth-fixed position x0 (north), y0 (east) [m].
#[derive(Debug, Clone)]
pub struct SegmentTrack {
    pub t_s: Vec<f64>,
    pub x0: Vec<f64>,
    pub y0: Vec<f64>,
}

/// Noise of a signal sampled at times `t` (DATA.md allows uneven sampling): the residual of each
/// sample from the straight line through its neighbours, `e = x₁ − (h₂x₀ + h₁x₂)/(h₁ + h₂)`, has
/// variance `σ²(1 + (h₁² + h₂²)/(h₁ + h₂)²)` for white noise and vanishes for motion that is linear
/// over the two steps (smooth motion at the rates of these recordings adds almost nothing). With even
/// steps this is the second difference, variance 6σ². The plain second difference would read an
/// uneven step as noise: a position moving at U0 with steps of 0.1 and 0.2 s is off by 0.1 s · U0.
fn noise_sigma(t: &[f64], x: &[f64]) -> f64 {
    let (mut e2, mut weight) = (0.0, 0.0);
    for (tw, xw) in t.windows(3).zip(x.windows(3)) {
        let (h1, h2) = (tw[1] - tw[0], tw[2] - tw[1]);
        let h = h1 + h2;
        if !(h1 > 0.0 && h2 > 0.0) {
            continue;
        }
        let e = xw[1] - (h2 * xw[0] + h1 * xw[2]) / h;
        e2 += e * e;
        weight += 1.0 + (h1 * h1 + h2 * h2) / (h * h);
    }
    if weight > 0.0 {
        (e2 / weight).sqrt()
    } else {
        0.0
    }
}

// ---------------------------------------------------------------- report

/// A candidate effect in the report (DATA.md).
#[derive(Debug, Clone, Serialize)]
pub struct Candidate {
    pub effect: String,
    /// Typical held-out relative reduction of a recording's position RMSE (1 − geometric mean of
    /// after/before over recordings), less `parsimony` per parameter.
    pub score: f64,
    /// Parameters fitted on all recordings (keys of the effect syntax; SI units, degrees).
    pub parameters: BTreeMap<String, f64>,
    /// Fraction of the mismatch above the noise floor that the effect removes on held-out recordings.
    pub explains: f64,
    /// Held-out position RMSE ÷ L with the effect.
    pub held_out_position_rmse_over_l: f64,
    pub n_parameters: usize,
    pub accepted: bool,
}

#[derive(Debug, Clone, Serialize)]
pub struct Located {
    pub recording: String,
    pub dof: &'static str,
    pub t_start: f64,
    pub t_end: f64,
    /// Mean equation-error residual over the window ÷ its noise scale (sign: recorded − model).
    pub mean_residual_over_noise: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct Regime {
    pub regime: &'static str,
    pub dof: &'static str,
    pub samples: usize,
    /// Mean equation-error residual in the regime ÷ its noise scale.
    pub mean_residual_over_noise: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct Fit {
    pub position_rmse_over_l: f64,
    pub heading_rmse_deg: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct RecordingFit {
    pub recording: String,
    pub before_position_rmse_over_l: f64,
    pub after_position_rmse_over_l: f64,
    /// Fraction of the recording's states outside the base model's identification range (leverage
    /// above the largest of its training states, [`IdentificationRange`]), when that range is known.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outside_identification_range: Option<f64>,
}

/// The diagnosis report (DATA.md "A diagnosis report"; keys after `fit_after` are additions).
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    pub verdict: String,
    pub candidates: Vec<Candidate>,
    pub located: Vec<Located>,
    pub fit_before: Fit,
    pub fit_after: Fit,
    /// The effects chosen (several when a combination was needed), in the effect syntax.
    pub effects: Vec<String>,
    /// One standard error of each chosen parameter.
    pub standard_errors: BTreeMap<String, f64>,
    pub per_recording: Vec<RecordingFit>,
    pub regimes: Vec<Regime>,
    /// Replay segment length [s] of every position/heading RMSE here.
    pub horizon_s: f64,
    /// Position RMSE ÷ L expected from the recordings' noise alone.
    pub noise_floor_position_rmse_over_l: f64,
    /// The model's own held-out-style level on its training recordings, when known.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model_level_position_rmse_over_l: Option<f64>,
    /// Fraction of all recorded states outside the base model's identification range, when known: there
    /// the base model's own forces are an extrapolation, and a mismatch left after the effect is likely
    /// the base model's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outside_identification_range: Option<f64>,
    pub explanation: String,
}

/// The base model and the held-out evaluation of a set of effects.
struct Judge<'a> {
    base: &'a (dyn Dynamics + Send + Sync),
    base_effects: &'a [Effect],
    prep: &'a [Prepared],
    horizon_s: f64,
    scale: [f64; 3],
    folds: [Vec<usize>; 2],
}

impl Judge<'_> {
    fn score(&self, effects: &[Effect], idx: &[usize]) -> Vec<ReplayScore> {
        let c = Composite {
            base: self.base,
            effects: combine(self.base_effects, effects),
        };
        let Some(model) = c.model() else {
            return idx
                .iter()
                .map(|_| ReplayScore {
                    sum_sq_pos: f64::INFINITY,
                    count: 1,
                    ..Default::default()
                })
                .collect();
        };
        idx.par_iter()
            .map(|&i| replay_score(&model, &self.prep[i].rec, self.horizon_s))
            .collect()
    }

    /// Fit on one fold, score on the other, both ways: per-recording held-out scores and the
    /// parameters fitted to each fold.
    /// `alone[k]` holds each family's parameters fitted alone to fold k, where known (see
    /// [`start_grid`]).
    fn cross(&self, families: &[Family], alone: &[Vec<Option<&[f64]>>; 2]) -> CrossFit {
        // The two folds in parallel: a wind's grid of starts makes one candidate's folds the longest
        // tasks of a diagnosis.
        let folds: Vec<FoldFit> = (0..2)
            .into_par_iter()
            .filter(|&k| !self.folds[1 - k].is_empty())
            .map(|k| {
                let (train, test) = (&self.folds[k], &self.folds[1 - k]);
                let (effects, fit) = fit_families(
                    self.base,
                    self.base_effects,
                    families,
                    self.prep,
                    train,
                    &self.scale,
                    start_grid(families, &alone[k]),
                    3,
                );
                let sc = self.score(&effects, test);
                if std::env::var_os("SHIPID_DEBUG").is_some() {
                    eprintln!(
                        "fold {k}: {:?} -> {:?}",
                        effects.iter().map(|e| e.to_string()).collect::<Vec<_>>(),
                        sc.iter()
                            .map(|s| s.position_rmse() / self.base.ship().lpp)
                            .collect::<Vec<_>>()
                    );
                }
                (k, fit.params, test.iter().copied().zip(sc).collect())
            })
            .collect();
        let mut out = vec![ReplayScore::default(); self.prep.len()];
        let mut fitted = Vec::new();
        for (k, params, scores) in folds {
            fitted.push((k, params));
            scores.into_iter().for_each(|(i, s)| out[i] = s);
        }
        (out, fitted)
    }
}

fn pooled(scores: &[ReplayScore]) -> ReplayScore {
    let mut s = ReplayScore::default();
    scores.iter().for_each(|x| s.add(x));
    s
}

/// A candidate's held-out assessment.
struct Assessed {
    name: String,
    n_parameters: usize,
    /// Pooled held-out position RMSE ÷ L with the effect.
    after_l: f64,
    /// Typical relative improvement less the parsimony charge.
    score: f64,
    explains: f64,
    accepted: bool,
}

/// A winner's score may be this close to a rival's (as a share of the winner's) before the report says
/// the recordings hardly tell the two apart.
const NEAR_TIE_SHARE: f64 = 0.25;

/// The accepted candidate that names none of the winner's words and scores within
/// [`NEAR_TIE_SHARE`] of it (the best such one), as an index into `words`/`scores`/`accepted`.
/// Why: the verdict is one word, and with a base whose own error is large where the recordings go
/// (manoeuvres it was not identified from), a current and a wind from the same side can explain the
/// same share of the mismatch; the verdict then rests on a few thousandths of score, and the user
/// should read that rather than a confident word.
fn near_rival(
    winner: usize,
    words: &[Vec<&str>],
    scores: &[f64],
    accepted: &[bool],
) -> Option<usize> {
    let w = scores[winner];
    (0..scores.len())
        .filter(|&i| {
            i != winner
                && accepted[i]
                && !words[i].iter().any(|x| words[winner].contains(x))
                && scores[i] >= w - NEAR_TIE_SHARE * w.abs()
        })
        .max_by(|&x, &y| scores[x].total_cmp(&scores[y]))
}

/// Everything the diagnosis needs besides the data.
pub struct DiagnoseInput<'a> {
    /// The model without its own effects.
    pub base: &'a (dyn Dynamics + Send + Sync),
    /// The model's own effects (kept; a candidate of the same kind replaces it).
    pub base_effects: &'a [Effect],
    /// The model's level on its training recordings (position RMSE ÷ L of segment replays), if known.
    pub model_level_over_l: Option<f64>,
    /// Where the base model was identified (an Abkowitz model with readable training data, or a
    /// sparse GP), if known.
    pub identification_range: Option<BaseRange<'a>>,
}

/// Where a base model was identified, tested one recorded state at a time.
#[derive(Clone, Copy)]
pub enum BaseRange<'a> {
    /// A polynomial's leverage envelope: outside where the leverage exceeds every training state's.
    Leverage(&'a IdentificationRange),
    /// A sparse GP's coverage: outside where no sparse point is d_gen-similar
    /// ([`shipid_sim::GpDynamics::covers`]).
    Coverage(&'a shipid_sim::GpDynamics),
}

impl<'a> BaseRange<'a> {
    /// The leverage range where there is one, else the GP's coverage.
    pub fn of(
        leverage: Option<&'a IdentificationRange>,
        gp: Option<&'a shipid_sim::GpDynamics>,
    ) -> Option<BaseRange<'a>> {
        leverage
            .map(BaseRange::Leverage)
            .or(gp.map(BaseRange::Coverage))
    }

    /// What "outside" means, for the report's explanation.
    pub fn criterion(self) -> &'static str {
        match self {
            BaseRange::Leverage(_) => "leverage above its training maximum",
            BaseRange::Coverage(_) => "no sparse point of the GP d_gen-similar",
        }
    }
}

/// The explanation mentions the identification range when at least this fraction of the recorded
/// states lies outside it (and the mismatch is real).
const OUTSIDE_WORTH_SAYING: f64 = 0.05;

/// Per recording, how many of its thinned samples lie outside `range`, and how many there are.
fn outside_counts(range: BaseRange, prep: &[Prepared], ship: &Ship) -> Vec<(usize, usize)> {
    let s = PrimeScale::of(ship);
    prep.iter()
        .map(|p| match range {
            BaseRange::Leverage(r) => outside_count(r, &p.rec, &s, p.samples.iter().copied()),
            BaseRange::Coverage(gp) => {
                let rec = &p.rec;
                let outside = p
                    .samples
                    .iter()
                    .filter(|&&i| !gp.covers(rec.u[i], rec.v[i], rec.r[i], rec.delta[i]))
                    .count();
                (outside, p.samples.len())
            }
        })
        .collect()
}

/// Equation-error residuals of the model (with its effects) per recording, each DOF divided by its robust
/// scale over the data set: (file, times [s], [surge, sway, yaw]) at the thinned samples (for figures).
pub type ResidualSeries = (String, Vec<f64>, Vec<[f64; 3]>);

pub fn normalised_residuals(
    input: &DiagnoseInput,
    ds: &Dataset,
    opts: &DiagnoseOptions,
) -> Vec<ResidualSeries> {
    let ship = *input.base.ship();
    let prep = prepare(ds, &ship, opts);
    let c = Composite {
        base: input.base,
        effects: input.base_effects.to_vec(),
    };
    let Some(model) = c.model() else {
        return Vec::new();
    };
    let res: Vec<Vec<Option<[f64; 3]>>> = prep.iter().map(|p| residuals(&model, p)).collect();
    let scale = robust_scale(&res);
    prep.iter()
        .zip(res)
        .map(|(p, r)| {
            let (t, e): (Vec<f64>, Vec<[f64; 3]>) = p
                .samples
                .iter()
                .zip(r)
                .filter_map(|(&i, e)| {
                    let e = e?;
                    Some((p.rec.t[i], std::array::from_fn(|d| e[d] / scale[d])))
                })
                .unzip();
            (p.file.clone(), t, e)
        })
        .collect()
}

/// Segment-replay position RMSE ÷ L of a model (with effects) on a data set: the model's own level on
/// its training data.
pub fn model_level(input: &DiagnoseInput, ds: &Dataset, opts: &DiagnoseOptions) -> f64 {
    let ship = *input.base.ship();
    let horizon_s = opts.horizon_l_over_u0 * ship.lpp / ship.u0;
    let c = Composite {
        base: input.base,
        effects: input.base_effects.to_vec(),
    };
    let Some(model) = c.model() else {
        return f64::NAN;
    };
    let scores: Vec<ReplayScore> = ds
        .recordings
        .par_iter()
        .map(|r| replay_score(&model, &r.recording, horizon_s))
        .collect();
    pooled(&scores).position_rmse() / ship.lpp
}

/// Diagnose `ds` against the model (see the module docs).
pub fn diagnose(input: &DiagnoseInput, ds: &Dataset, opts: &DiagnoseOptions) -> Option<Report> {
    let base = input.base;
    let ship = *base.ship();
    let lpp = ship.lpp;
    let horizon_s = opts.horizon_l_over_u0 * lpp / ship.u0;
    let prep = prepare(ds, &ship, opts);
    if prep.is_empty() {
        return None;
    }
    let base_c = Composite {
        base,
        effects: input.base_effects.to_vec(),
    };
    let base_model = base_c.model()?;
    let base_res: Vec<Vec<Option<[f64; 3]>>> =
        prep.iter().map(|p| residuals(&base_model, p)).collect();
    let scale = robust_scale(&base_res);
    let folds: [Vec<usize>; 2] = if prep.len() >= 2 {
        [
            (0..prep.len()).step_by(2).collect(),
            (1..prep.len()).step_by(2).collect(),
        ]
    } else {
        [vec![0], vec![]]
    };
    let judge = Judge {
        base,
        base_effects: input.base_effects,
        prep: &prep,
        horizon_s,
        scale,
        folds: folds.clone(),
    };
    let all: Vec<usize> = (0..prep.len()).collect();
    let before_each = judge.score(&[], &all);
    let before = pooled(&before_each);
    let before_l = before.position_rmse() / lpp;

    // Noise floor: position noise plus the drift from the remaining initial-velocity noise over a segment.
    let (mut sp, mut sv) = (0.0, 0.0);
    for p in &prep {
        let t = &p.rec.t;
        sp += noise_sigma(t, &p.rec.x0).powi(2) + noise_sigma(t, &p.rec.y0).powi(2);
        sv += noise_sigma(t, &p.rec.u).powi(2) + noise_sigma(t, &p.rec.v).powi(2);
    }
    let n = prep.len() as f64;
    let sigma_pos = (sp / n).sqrt();
    let sigma_vel_init = (sv / n).sqrt() / 11f64.sqrt();
    let noise_floor =
        (sigma_pos.powi(2) + (sigma_vel_init * horizon_s / 3f64.sqrt()).powi(2)).sqrt() / lpp;

    // Candidates, each judged held-out (in parallel).
    let single: Vec<(Family, CrossFit)> = Family::ALL
        .par_iter()
        .map(|&f| (f, judge.cross(&[f], &Default::default())))
        .collect();
    // Typical per-recording change: the geometric mean of after/before over recordings, so that one
    // recording the base model already fits badly (or where a segment runs away) cannot decide alone.
    let typical_ratio = |idx: &[usize], scores: &[ReplayScore]| {
        let logs: Vec<f64> = idx
            .iter()
            .map(|&i| {
                let b = before_each[i].position_rmse().max(1e-12);
                (scores[i].position_rmse().max(1e-12) / b).ln()
            })
            .collect();
        (logs.iter().sum::<f64>() / logs.len().max(1) as f64).exp()
    };
    let fold_ok = |scores: &[ReplayScore]| {
        folds
            .iter()
            .filter(|f| !f.is_empty())
            .all(|f| typical_ratio(f, scores) < 0.9)
    };
    let assess = |name: String, k: usize, scores: &[ReplayScore]| {
        let after_l = pooled(scores).position_rmse() / lpp;
        let gain = 1.0 - typical_ratio(&all, scores);
        let excess = (before_l - noise_floor).max(1e-300);
        let explains = ((before_l - after_l) / excess).clamp(0.0, 1.0);
        let mut drops: Vec<f64> = (0..scores.len())
            .map(|i| (before_each[i].position_rmse() - scores[i].position_rmse()) / lpp)
            .collect();
        drops.sort_by(f64::total_cmp);
        let median_drop = drops.get(drops.len() / 2).copied().unwrap_or(0.0);
        let accepted = gain >= opts.min_gain && fold_ok(scores) && median_drop > 2.0 * noise_floor;
        Assessed {
            name,
            n_parameters: k,
            after_l,
            score: gain - opts.parsimony * k as f64,
            explains,
            accepted,
        }
    };
    // Each candidate with its assessment and its cross fit (held-out scores, and the fold fits that
    // warm start its final fit).
    let mut assessed: Vec<(Vec<Family>, Assessed, CrossFit)> = single
        .into_iter()
        .map(|(f, cross)| (vec![f], assess(f.label().into(), f.dim(), &cross.0), cross))
        .collect();
    let rank = |a: &Assessed| a.score;
    // The accepted candidate with the highest score.
    let best_accepted = |assessed: &[(Vec<Family>, Assessed, CrossFit)]| {
        assessed
            .iter()
            .enumerate()
            .filter(|(_, a)| a.1.accepted)
            .max_by(|x, y| rank(&x.1.1).total_cmp(&rank(&y.1.1)))
            .map(|(i, _)| i)
    };
    let mut best = best_accepted(&assessed);

    let model_level = input.model_level_over_l;
    let real_threshold = model_level.unwrap_or(0.0) * opts.real_mismatch_factor
        + 3.0 * noise_floor
        + REPLAY_RESOLUTION_OVER_L;

    // A combination when one effect alone leaves a real mismatch: the winner paired with every other
    // effect when it leaves more than half of the mismatch; when no single effect is accepted although
    // the mismatch is real, the best-scoring single paired with every other (its partner may make
    // things worse alone, as a wind beside a current does) and the second with the third (two
    // concealed effects can each explain too little alone to pass).
    let mut order: Vec<usize> = (0..assessed.len()).collect();
    order.sort_by(|&x, &y| rank(&assessed[y].1).total_cmp(&rank(&assessed[x].1)));
    let lead = match best {
        Some(b) => {
            let a = &assessed[b].1;
            (a.explains < 0.5 && a.after_l > 3.0 * noise_floor).then_some((b, false))
        }
        None if before_l > real_threshold => order.first().map(|&i| (i, true)),
        None => None,
    };
    if let Some((lead, none_passed)) = lead {
        let after_l = assessed[lead].1.after_l;
        let first = assessed[lead].0[0];
        let mut pairs: Vec<Vec<Family>> = Family::ALL
            .iter()
            .filter(|&&f| f.word() != first.word())
            .map(|&f| vec![first, f])
            .collect();
        if let (true, [_, second, third, ..]) = (none_passed, order.as_slice()) {
            let (f, g) = (assessed[*second].0[0], assessed[*third].0[0]);
            if f.word() != g.word() {
                pairs.push(vec![f, g]);
            }
        }
        // A single effect's parameters fitted to fold k (from its cross fit above).
        let fold_fit = |f: Family, k: usize| -> Option<&[f64]> {
            let (_, _, (_, fits)) = assessed.iter().find(|(fams, _, _)| fams[..] == [f])?;
            fits.iter()
                .find(|(fk, _)| *fk == k)
                .map(|(_, p)| p.as_slice())
        };
        let pairs: Vec<(Vec<Family>, CrossFit)> = pairs
            .into_par_iter()
            .map(|fams| {
                // The members' own fits to the same fold are starts (see `start_grid`).
                let alone = [0, 1].map(|k| fams.iter().map(|&f| fold_fit(f, k)).collect());
                let s = judge.cross(&fams, &alone);
                (fams, s)
            })
            .collect();
        for (fams, cross) in pairs {
            let name = fams.iter().map(|f| f.label()).collect::<Vec<_>>().join("+");
            let k = fams.iter().map(|f| f.dim()).sum();
            let mut a = assess(name, k, &cross.0);
            // A pair must beat the single effect clearly, on the held-out recordings.
            a.accepted = a.accepted && a.after_l < 0.7 * after_l;
            assessed.push((fams, a, cross));
        }
        best = best_accepted(&assessed);
    }

    // Final parameters on all recordings, for every candidate (reported) — the chosen one's are the model.
    // From the better of the two fold fits: the grid of starts was searched there already.
    let finals: Vec<(Vec<Effect>, FitResult)> = assessed
        .par_iter()
        .map(|(fams, _, (_, warm))| {
            let warm = warm.iter().map(|(_, p)| p.clone()).collect();
            fit_families(base, input.base_effects, fams, &prep, &all, &scale, warm, 1)
        })
        .collect();
    let candidates: Vec<Candidate> = assessed
        .iter()
        .zip(&finals)
        .map(|((_, a, _), (effects, _))| Candidate {
            effect: a.name.clone(),
            score: a.score,
            parameters: effects
                .iter()
                .flat_map(|e| {
                    let multi = effects.len() > 1;
                    e.parameters().into_iter().map(move |(k, v)| {
                        let key = if multi {
                            format!("{}.{k}", e.kind())
                        } else {
                            k.to_string()
                        };
                        (key, v)
                    })
                })
                .collect(),
            explains: a.explains,
            held_out_position_rmse_over_l: a.after_l,
            n_parameters: a.n_parameters,
            accepted: a.accepted,
        })
        .collect();

    let (verdict, effects, std_errors, after_scores, explanation) = match best {
        Some(b) => {
            let (fams, a, (s, _)) = &assessed[b];
            let (effects, fit) = &finals[b];
            let std_errors = standard_errors(fams, effects, fit, &ship);
            let words: Vec<Vec<&str>> = assessed
                .iter()
                .map(|(f, _, _)| f.iter().map(|x| x.word()).collect())
                .collect();
            let scores: Vec<f64> = assessed.iter().map(|x| x.1.score).collect();
            let accepted: Vec<bool> = assessed.iter().map(|x| x.1.accepted).collect();
            let rival = near_rival(b, &words, &scores, &accepted).map(|i| {
                let r = &assessed[i].1;
                format!(
                    "; but {} explains nearly as much ({:.0} %, score {:.3} against {:.3}): these recordings hardly tell the two apart with this model",
                    r.name,
                    100.0 * r.explains,
                    r.score,
                    a.score
                )
            });
            (
                fams[0].word().to_string(),
                effects.clone(),
                std_errors,
                s.clone(),
                format!(
                    "{} explains {:.0} % of the held-out mismatch (position RMSE {:.4} L → {:.4} L, noise floor {:.4} L){}",
                    a.name,
                    100.0 * a.explains,
                    before_l,
                    a.after_l,
                    noise_floor,
                    rival.unwrap_or_default()
                ),
            )
        }
        None => {
            let real = before_l > real_threshold;
            (
                if real { "unexplained" } else { "none" }.to_string(),
                Vec::new(),
                BTreeMap::new(),
                before_each.clone(),
                if real {
                    format!(
                        "held-out position RMSE {before_l:.4} L exceeds the model's own level and the noise ({real_threshold:.4} L), and no effect of the library reduces it by {:.0} % in both halves",
                        100.0 * opts.min_gain
                    )
                } else {
                    format!(
                        "no effect reduces the mismatch beyond the noise; position RMSE {before_l:.4} L is within the model's own level and the noise ({real_threshold:.4} L)"
                    )
                },
            )
        }
    };
    let after = pooled(&after_scores);
    let worse: Vec<&str> = prep
        .iter()
        .zip(before_each.iter().zip(&after_scores))
        .filter(|(_, (b, a))| a.position_rmse() > 1.1 * b.position_rmse())
        .map(|(p, _)| p.file.as_str())
        .collect();
    let explanation = if worse.is_empty() || effects.is_empty() {
        explanation
    } else {
        format!(
            "{explanation}; but it makes {} of {} recordings worse ({}), so part of the mismatch is not this effect",
            worse.len(),
            prep.len(),
            worse.join(", ")
        )
    };
    let outside: Option<Vec<(usize, usize)>> = input
        .identification_range
        .map(|range| outside_counts(range, &prep, &ship));
    let outside_all = outside
        .as_ref()
        .map(|c| share(c.iter().fold((0, 0), |(o, t), &(co, ct)| (o + co, t + ct))));
    let explanation = match outside_all {
        Some(f) if f >= OUTSIDE_WORTH_SAYING && before_l > real_threshold => format!(
            "{explanation}; {:.0} % of the recorded states lie outside the base model's identification range ({}), where its own forces are extrapolated: part of any mismatch left there is the base model's",
            100.0 * f,
            input.identification_range.map_or("", BaseRange::criterion)
        ),
        _ => explanation,
    };
    let per_recording = prep
        .iter()
        .zip(before_each.iter().zip(&after_scores))
        .enumerate()
        .map(|(k, (p, (b, a)))| RecordingFit {
            recording: p.file.clone(),
            before_position_rmse_over_l: b.position_rmse() / lpp,
            after_position_rmse_over_l: a.position_rmse() / lpp,
            outside_identification_range: outside.as_ref().map(|c| share(c[k])),
        })
        .collect();
    let located = locate(&prep, &base_res, &scale, &ship);
    let regimes = regimes(&prep, &base_res, &scale, &ship);
    Some(Report {
        verdict,
        candidates,
        located,
        fit_before: Fit {
            position_rmse_over_l: before_l,
            heading_rmse_deg: before.heading_rmse_rad().to_degrees(),
        },
        fit_after: Fit {
            position_rmse_over_l: after.position_rmse() / lpp,
            heading_rmse_deg: after.heading_rmse_rad().to_degrees(),
        },
        effects: effects.iter().map(|e| e.to_string()).collect(),
        standard_errors: std_errors,
        per_recording,
        regimes,
        horizon_s,
        noise_floor_position_rmse_over_l: noise_floor,
        model_level_position_rmse_over_l: model_level,
        outside_identification_range: outside_all,
        explanation,
    })
}

/// Standard errors of the physical parameters by finite differences of the internal → physical map.
fn standard_errors(
    fams: &[Family],
    effects: &[Effect],
    fit: &FitResult,
    ship: &Ship,
) -> BTreeMap<String, f64> {
    let mut out = BTreeMap::new();
    let mut at = 0;
    for (f, e) in fams.iter().zip(effects) {
        let d = f.dim();
        let p = &fit.params[at..at + d];
        let se = &fit.std_err[at..at + d];
        let base: Vec<(&str, f64)> = f.effect(p, ship).parameters();
        let mut var = vec![0.0; base.len()];
        // A physical parameter that no fitted one moves is fixed by the family (e.g. the offset
        // variant's n0 and y0): it has no standard error, not a zero one.
        let mut fitted = vec![false; base.len()];
        for j in 0..d {
            let h = (se[j] * 1e-2).max(1e-9);
            let mut q = p.to_vec();
            q[j] += h;
            let moved = f.effect(&q, ship).parameters();
            for (k, ((_, a), (_, b))) in base.iter().zip(&moved).enumerate() {
                let mut diff = b - a;
                if base[k].0 == "from_deg" {
                    diff = (diff + 180.0).rem_euclid(360.0) - 180.0;
                }
                var[k] += (diff / h * se[j]).powi(2);
                fitted[k] |= diff != 0.0;
            }
        }
        for (((key, _), v), _) in base.iter().zip(var).zip(&fitted).filter(|(_, f)| **f) {
            let name = if fams.len() > 1 {
                format!("{}.{key}", e.kind())
            } else {
                key.to_string()
            };
            if v.is_finite() {
                out.insert(name, v.sqrt());
            }
        }
        at += d;
    }
    out
}

const DOFS: [&str; 3] = ["surge", "sway", "yaw"];

/// Windows where the low-passed equation-error residual stands out (see [`Located`]).
fn locate(
    prep: &[Prepared],
    res: &[Vec<Option<[f64; 3]>>],
    scale: &[f64; 3],
    ship: &Ship,
) -> Vec<Located> {
    // Running mean over 3 L/U0; a window is located where it exceeds three standard errors of a running
    // mean of the residual's white part (σ from first differences: the differentiated accelerations are
    // noisy, so single samples say little), for at least one L/U0.
    let l_over_u0 = ship.lpp / ship.u0;
    let window_s = 3.0 * l_over_u0;
    let mut found = Vec::new();
    for (p, r) in prep.iter().zip(res) {
        let t: Vec<f64> = p.samples.iter().map(|&i| p.rec.t[i]).collect();
        for d in 0..3 {
            let z: Vec<f64> = r
                .iter()
                .map(|e| e.map_or(0.0, |e| e[d] / scale[d]))
                .collect();
            if z.len() < 3 {
                continue;
            }
            let sigma = (z.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f64>()
                / (2.0 * (z.len() - 1) as f64))
                .sqrt();
            let (lp, limit): (Vec<f64>, Vec<f64>) = (0..z.len())
                .map(|i| {
                    let a = t.partition_point(|&x| x < t[i] - 0.5 * window_s);
                    let b = t.partition_point(|&x| x <= t[i] + 0.5 * window_s);
                    let m = (b - a).max(1) as f64;
                    (z[a..b].iter().sum::<f64>() / m, 3.0 * sigma / m.sqrt())
                })
                .unzip();
            let out = |i: usize| lp[i].abs() > limit[i];
            let mut i = 0;
            while i < lp.len() {
                if out(i) {
                    let sign = lp[i].signum();
                    let j0 = i;
                    while i < lp.len() && out(i) && lp[i].signum() == sign {
                        i += 1;
                    }
                    let (ts, te) = (t[j0], t[i - 1]);
                    if te - ts >= l_over_u0 {
                        let mean = lp[j0..i].iter().sum::<f64>() / (i - j0) as f64;
                        found.push(Located {
                            recording: p.file.clone(),
                            dof: DOFS[d],
                            t_start: ts,
                            t_end: te,
                            mean_residual_over_noise: mean,
                        });
                    }
                } else {
                    i += 1;
                }
            }
        }
    }
    found.sort_by(|a, b| {
        let w = |x: &Located| (x.t_end - x.t_start) * x.mean_residual_over_noise.abs();
        w(b).total_cmp(&w(a))
    });
    found.truncate(24);
    found
}

/// Regime of a sample: rudder moving, steady turn to port/starboard, or straight.
fn regime_of(rec: &Recording, i: usize, ship: &Ship) -> &'static str {
    let n = rec.len();
    let (a, b) = (i.saturating_sub(2), (i + 2).min(n - 1));
    let rate = if b > a {
        (rec.delta[b] - rec.delta[a]) / (rec.t[b] - rec.t[a])
    } else {
        0.0
    };
    let r_prime = rec.r[i] * ship.lpp / ship.u0;
    if rate.abs() > 0.5 * ship.rudder_rate.to_radians() {
        "rudder_moving"
    } else if r_prime < -0.1 {
        "turning_port"
    } else if r_prime > 0.1 {
        "turning_starboard"
    } else {
        "straight_or_checking"
    }
}

fn regimes(
    prep: &[Prepared],
    res: &[Vec<Option<[f64; 3]>>],
    scale: &[f64; 3],
    ship: &Ship,
) -> Vec<Regime> {
    let names = [
        "straight_or_checking",
        "turning_port",
        "turning_starboard",
        "rudder_moving",
    ];
    let mut sums = [[0.0; 3]; 4];
    let mut counts = [0usize; 4];
    for (p, r) in prep.iter().zip(res) {
        for (&i, e) in p.samples.iter().zip(r) {
            let Some(e) = e else { continue };
            let k = names
                .iter()
                .position(|n| *n == regime_of(&p.rec, i, ship))
                .unwrap_or(0);
            counts[k] += 1;
            (0..3).for_each(|d| sums[k][d] += e[d] / scale[d]);
        }
    }
    let mut out = Vec::new();
    for k in 0..4 {
        if counts[k] == 0 {
            continue;
        }
        for (d, dof) in DOFS.iter().enumerate() {
            out.push(Regime {
                regime: names[k],
                dof,
                samples: counts[k],
                mean_residual_over_noise: sums[k][d] / counts[k] as f64,
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use shipid_sim::SimOptions;

    #[test]
    fn a_segment_ending_between_replay_steps_is_replayed_to_its_last_sample() {
        // Sampled every 0.07 s, the 10 L/U0 segments end on no multiple of the replay step. A replay
        // rounded to whole steps used to stop short of the last sample, which then counted as a
        // divergence with 1 L of error (0.03 L of RMSE over a segment of some 850 samples).
        let model = shipid_sim::MmgModel::kvlcc2();
        let ship = *model.ship();
        let mut zigzag =
            shipid_sim::ZigZag::new(20.0, 20.0, shipid_io::Side::Starboard, 1.0).unwrap();
        let rec = shipid_sim::simulate(
            &model,
            &mut zigzag,
            State::approach(ship.u0),
            &SimOptions::new(150.0).with_step(0.01, 0.07),
        )
        .unwrap()
        .recording;
        let horizon_s = DiagnoseOptions::default().horizon_l_over_u0 * ship.lpp / ship.u0;
        assert!(segments(&rec, horizon_s).len() >= 2);
        let score = replay_score(&model, &rec, horizon_s);
        assert_eq!(score.diverged_segments, 0);
        let rmse_over_l = score.position_rmse() / ship.lpp;
        assert!(rmse_over_l < 1e-3, "position RMSE {rmse_over_l} L");
    }

    #[test]
    fn a_rudder_offset_reports_the_error_of_the_offset_only() {
        // Regression: the offset variant of `asymmetry` also printed "± n0 0.0000 ± y0 0.0000" for the
        // side force and moment it keeps at zero.
        let ship = *shipid_sim::MmgModel::kvlcc2().ship();
        let fit = FitResult {
            params: vec![0.5],
            cost: 0.0,
            std_err: vec![0.02],
        };
        let fams = [Family::RudderOffset];
        let effects = [fams[0].effect(&fit.params, &ship)];
        let se = standard_errors(&fams, &effects, &fit, &ship);
        assert_eq!(se.len(), 1, "{se:?}");
        let (key, value) = se.iter().next().unwrap();
        assert!(key.contains("offset"), "{key}");
        assert!((value - 0.02).abs() < 1e-9, "{value}");
    }

    #[test]
    fn depth_for_factor_inverts_the_shallow_water_factor() {
        for h in [1.2, 1.5, 2.0, 3.0] {
            let f = ShallowWater {
                depth_over_draft: h,
                yaw_factor: None,
            }
            .factor();
            assert!((depth_for_factor(f) - h).abs() < 1e-6, "h/T {h}");
        }
    }

    fn check_rival(candidates: &[(&str, f64, bool)], winner: usize, expected: Option<usize>) {
        let words: Vec<Vec<&str>> = candidates
            .iter()
            .map(|c| c.0.split('+').collect())
            .collect();
        let scores: Vec<f64> = candidates.iter().map(|c| c.1).collect();
        let accepted: Vec<bool> = candidates.iter().map(|c| c.2).collect();
        assert_eq!(
            near_rival(winner, &words, &scores, &accepted),
            expected,
            "{candidates:?}"
        );
    }

    #[test]
    fn a_near_tie_names_the_rival_word_and_a_clear_win_does_not() {
        // The head wind off the base's manoeuvres (bench/diagnose-unseen.sh, seed 39).
        check_rival(
            &[
                ("current", 0.400, true),
                ("wind", 0.397, true),
                ("rudder_lag", -0.06, false),
            ],
            0,
            Some(1),
        );
        // Clear win; the runner-up scores less than three quarters of the winner.
        check_rival(&[("current", 0.70, true), ("wind", 0.50, true)], 0, None);
        // Not accepted: no rival.
        check_rival(&[("current", 0.40, true), ("wind", 0.39, false)], 0, None);
        // A pair or a variant holding the winner's word is no rival.
        check_rival(
            &[
                ("wind", 0.36, true),
                ("wind+asymmetry", 0.45, true),
                ("asymmetry", 0.1, true),
            ],
            0,
            None,
        );
        // The best of several rivals.
        check_rival(
            &[
                ("current", 0.40, true),
                ("wind", 0.33, true),
                ("shallow_water", 0.38, true),
            ],
            0,
            Some(2),
        );
    }

    #[test]
    fn levenberg_marquardt_fits_an_exponential() {
        let t: Vec<f64> = (0..50).map(|i| i as f64 * 0.1).collect();
        let f = |p: &[f64]| -> Vec<f64> {
            t.iter()
                .map(|&x| p[0] * (-p[1] * x).exp() - 2.0 * (-0.7 * x).exp())
                .collect()
        };
        let fit = levenberg_marquardt(&f, &[1.0, 0.1], &[0.0, 0.0], &[5.0, 5.0]);
        assert!((fit.params[0] - 2.0).abs() < 1e-5 && (fit.params[1] - 0.7).abs() < 1e-5);
    }

    #[test]
    fn levenberg_marquardt_holds_a_parameter_at_the_bound_the_optimum_lies_beyond() {
        // Coupled residuals whose unconstrained optimum has p0 = 2 beyond its bound 1: the constrained
        // optimum is p0 = 1, p1 = 1.2. Projecting full steps (p1's step computed as if p0 moved to 2)
        // used to creep towards it for all 40 iterations, as a shallow-water factor or a lag at 0 did.
        let evaluations = std::sync::atomic::AtomicUsize::new(0);
        let f = |p: &[f64]| -> Vec<f64> {
            evaluations.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            vec![p[0] - 2.0, p[1] + 0.8 * p[0] - 2.0, 0.1 * (p[1] - 1.2)]
        };
        let fit = levenberg_marquardt(&f, &[0.5, 0.0], &[0.0, -5.0], &[1.0, 5.0]);
        assert_eq!(fit.params[0], 1.0);
        assert!((fit.params[1] - 1.2).abs() < 1e-6, "p1 = {}", fit.params[1]);
        let n = evaluations.into_inner();
        assert!(n <= 30, "{n} evaluations");
    }

    /// `noise_sigma` on `x(t) = 5 sin(0.05 t) + U0·t` (a ship's position through a turn) plus white
    /// noise of σ = 0.01, sampled at `t`.
    fn check_noise_sigma(t: &[f64], expected: f64) {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        let x: Vec<f64> = t
            .iter()
            .map(|&ti| {
                (0.05 * ti).sin() * 5.0
                    + 1.179 * ti
                    + 0.01 * (rng.random::<f64>() - 0.5) * 12f64.sqrt()
            })
            .collect();
        let s = noise_sigma(t, &x);
        assert!((s - expected).abs() < 0.05 * expected, "{s} vs {expected}");
    }

    #[test]
    fn noise_sigma_of_white_noise_on_a_smooth_signal() {
        let t: Vec<f64> = (0..20000).map(|i| i as f64 * 0.01).collect();
        check_noise_sigma(&t, 0.01);
    }

    #[test]
    fn noise_sigma_of_unevenly_sampled_motion_is_the_noise_not_the_step_changes() {
        // A 10 Hz record with 40 % of the samples dropped at random (steps of 0.1–0.5 s): the
        // plain second difference read 0.1 s · U0 ≈ 0.12 m of "noise" into every uneven step.
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let t: Vec<f64> = (0..20000)
            .map(|i| i as f64 * 0.1)
            .filter(|_| rng.random::<f64>() >= 0.4)
            .collect();
        check_noise_sigma(&t, 0.01);
    }
}
