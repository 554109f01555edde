//! Compare: the recordings made ready (accelerations, thinned samples), the model's equation-error
//! residuals and their robust scale, segment-replay scores, the noise floor, and the model's own level.
//!
//! Long open-loop replays of a zig-zag drift by whole ship lengths even for a good identified model (a
//! small yaw-rate bias integrates into heading), which would hide every effect; replays in segments
//! restarted from the recorded state keep the model's own error small and an effect's signature (a
//! drift, a lag, a bias) intact.

use rayon::prelude::*;
use serde::Serialize;
use shipid_io::{
    Accelerations, Dataset, PrimeScale, Recording, Ship, deriv::accelerations_or_estimate,
};
use shipid_pipeline::environment::ChosenWindage;
use shipid_pipeline::range::outside_count;
use shipid_pipeline::replay::{differentiator_margin, replay_segment_in, segments};
use shipid_pipeline::validate::{interp, replay_errors, replay_in};
use shipid_sim::{
    Dynamics, Effect, KnownEnvironment, RudderFilter, State, WithEffects, WithEnvironment,
};

use crate::error::DiagnoseError;
use crate::input::{BaseRange, DiagnoseInput, DiagnoseOptions};

/// One recording ready for the diagnosis.
#[derive(Debug, Clone)]
pub struct Prepared {
    pub file: String,
    pub rec: Recording,
    pub acc: Accelerations,
    /// Indices of the equation-error samples (thinned).
    pub samples: Vec<usize>,
    /// The wind and current the recording carries (time origin at its first sample): part of the base,
    /// so that what the diagnosis finds is an environment the recording does not carry.
    pub env: Option<KnownEnvironment>,
}

/// The recorded environment of every recording of `ds` (same order), with `windage` for a recorded
/// wind.
pub fn environments(
    ds: &Dataset,
    windage: &ChosenWindage,
) -> Result<Vec<Option<KnownEnvironment>>, DiagnoseError> {
    ds.recordings
        .iter()
        .map(|r| {
            KnownEnvironment::of_recording(&r.recording, Some(&windage.windage), &ds.ship).map_err(
                |e| DiagnoseError::Environment {
                    recording: r.file.clone(),
                    reason: e.to_string(),
                },
            )
        })
        .collect()
}

/// Prepare the recordings of `ds`: accelerations (recorded or differentiated), the thinned samples and
/// the recorded environment (a recorded wind through `windage`).
pub fn prepare(
    ds: &Dataset,
    ship: &Ship,
    opts: &DiagnoseOptions,
    windage: &ChosenWindage,
) -> Result<Vec<Prepared>, DiagnoseError> {
    let envs = environments(ds, windage)?;
    Ok(ds
        .recordings
        .iter()
        .zip(envs)
        .filter(|(r, _)| r.recording.len() >= 20)
        .map(|(r, env)| {
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
                env,
            }
        })
        .collect())
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
pub(crate) fn residuals(model: &dyn Dynamics, p: &Prepared) -> Vec<Option<[f64; 3]>> {
    let delta = match model.model_rudder_filter() {
        Some(mut f) => filtered_rudder(f.as_mut(), &p.rec),
        None => p.rec.delta.clone(),
    };
    // The recorded wind and current act on the model as they acted on the ship: the residual is what
    // neither the model nor the recorded environment explains.
    let in_env = p.env.clone().map(|e| WithEnvironment::new(model, e));
    let model: &dyn Dynamics = match &in_env {
        Some(m) => m,
        None => model,
    };
    let t0 = p.rec.t[0];
    p.samples
        .iter()
        .map(|&i| {
            let a = model
                .accelerations_at(p.rec.t[i] - t0, &State::of_recording(&p.rec, i), delta[i])
                .ok()?;
            let rec = [p.acc.u_dot[i], p.acc.v_dot[i], p.acc.r_dot[i]];
            let e = [rec[0] - a[0], rec[1] - a[1], rec[2] - a[2]];
            e.iter().all(|x| x.is_finite()).then_some(e)
        })
        .collect()
}

/// Robust scale (1.4826 × median absolute value) per DOF of the residuals.
pub(crate) fn robust_scale(res: &[Vec<Option<[f64; 3]>>]) -> [f64; 3] {
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
pub(crate) struct Composite<'a> {
    pub base: &'a (dyn Dynamics + Send + Sync),
    pub effects: Vec<Effect>,
}

impl Composite<'_> {
    pub fn model(&self) -> Option<WithEffects<&(dyn Dynamics + Send + Sync)>> {
        WithEffects::new(self.base, &self.effects).ok()
    }
}

/// The base's effects with `extra` added; an extra effect replaces the base's of the same kind.
pub(crate) fn combine(base_effects: &[Effect], extra: &[Effect]) -> Vec<Effect> {
    let mut all: Vec<Effect> = base_effects
        .iter()
        .filter(|e| !extra.iter().any(|x| x.kind() == e.kind()))
        .cloned()
        .collect();
    all.extend_from_slice(extra);
    all
}

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

/// Segment-replay score of `model` on recording `rec` in its recorded environment `env`.
pub(crate) fn replay_score(
    model: &dyn Dynamics,
    env: Option<&KnownEnvironment>,
    rec: &Recording,
    horizon_s: f64,
) -> ReplayScore {
    let mut s = ReplayScore::default();
    let cap = POSITION_ERROR_CAP_OVER_L * model.ship().lpp;
    for (a, b) in segments(rec, horizon_s) {
        let (sim, ok) = replay_segment_in(model, env, rec, a, b);
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

/// Times and north and east positions [m] of each segment replay in the recorded environment `env`
/// (for figures).
pub fn segment_tracks(
    model: &dyn Dynamics,
    env: Option<&KnownEnvironment>,
    rec: &Recording,
    horizon_s: f64,
) -> Vec<SegmentTrack> {
    segments(rec, horizon_s)
        .into_iter()
        .map(|(a, b)| {
            let (sim, _) = replay_segment_in(model, env, rec, a, b);
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

/// Noise of a signal sampled at times `t` (recordings may be unevenly sampled, docs/data-format.md):
/// the residual of each sample from the straight line through its neighbours,
/// `e = x₁ − (h₂x₀ + h₁x₂)/(h₁ + h₂)`, has
/// variance `σ²(1 + (h₁² + h₂²)/(h₁ + h₂)²)` for white noise and vanishes for motion that is linear
/// over the two steps (smooth motion at the rates of these recordings adds almost nothing). With even
/// steps this is the second difference, variance 6σ². The plain second difference would read an
/// uneven step as noise: a position moving at U0 with steps of 0.1 and 0.2 s is off by 0.1 s · U0.
pub(crate) fn noise_sigma(t: &[f64], x: &[f64]) -> f64 {
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

/// All recordings' replays as one score.
pub(crate) fn pooled(scores: &[ReplayScore]) -> ReplayScore {
    let mut s = ReplayScore::default();
    scores.iter().for_each(|x| s.add(x));
    s
}

/// Per recording, how many of its thinned samples lie outside `range`, and how many there are.
pub(crate) fn outside_counts(
    range: BaseRange,
    prep: &[Prepared],
    ship: &Ship,
) -> Vec<(usize, usize)> {
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
) -> Result<Vec<ResidualSeries>, DiagnoseError> {
    let ship = *input.base.ship();
    let prep = prepare(ds, &ship, opts, &ChosenWindage::of_dataset(ds))?;
    let c = Composite {
        base: input.base,
        effects: input.base_effects.to_vec(),
    };
    let Some(model) = c.model() else {
        return Ok(Vec::new());
    };
    let res: Vec<Vec<Option<[f64; 3]>>> = prep.iter().map(|p| residuals(&model, p)).collect();
    let scale = robust_scale(&res);
    Ok(prep
        .iter()
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
        .collect())
}

/// Segment-replay position RMSE ÷ L of a model (with effects) on a data set, each recording in its
/// recorded environment: the model's own level on its training data. NaN when the model with its
/// effects cannot be built or a recorded environment cannot be used.
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
    let Ok(envs) = environments(ds, &ChosenWindage::of_dataset(ds)) else {
        return f64::NAN;
    };
    let scores: Vec<ReplayScore> = ds
        .recordings
        .par_iter()
        .zip(envs.par_iter())
        .map(|(r, env)| replay_score(&model, env.as_ref(), &r.recording, horizon_s))
        .collect();
    pooled(&scores).position_rmse() / ship.lpp
}

/// Segment-replay scores of `model` on the recordings `idx` of `prep`.
pub(crate) fn replay_scores<M: Dynamics + Sync>(
    model: &M,
    prep: &[Prepared],
    idx: &[usize],
    horizon_s: f64,
) -> Vec<ReplayScore> {
    idx.par_iter()
        .map(|&i| replay_score(model, prep[i].env.as_ref(), &prep[i].rec, horizon_s))
        .collect()
}

/// Position RMSE ÷ L of the whole-record replay of `model` (what `shipid validate` reports): `rec`
/// replayed from its first sample with its recorded rudder, wind and current (`env`). A replay that
/// stops short (diverges) is infinitely bad; a recording too short to replay is `None`.
pub(crate) fn whole_replay(
    model: &dyn Dynamics,
    rec: &Recording,
    env: Option<&KnownEnvironment>,
) -> Option<f64> {
    if rec.len() < 20 {
        return None;
    }
    let sim = replay_in(model, rec, env.cloned());
    let e = replay_errors(&sim, rec, model.ship());
    let completed = matches!(sim.status, shipid_sim::SimStatus::Ok);
    Some(if completed && e.position_rmse_over_l.is_finite() {
        e.position_rmse_over_l
    } else {
        f64::INFINITY
    })
}

/// Position RMSE ÷ L of segment replays expected from the recordings' noise alone: the position noise
/// plus the drift from the remaining initial-velocity noise over a segment.
fn noise_floor_over_l(prep: &[Prepared], horizon_s: f64, lpp: f64) -> f64 {
    let (mut sp, mut sv) = (0.0, 0.0);
    // A recording shorter than the horizon is one segment as long as the recording: its drift is
    // that of its own length.
    for p in prep {
        let t = &p.rec.t;
        let span = t.last().unwrap_or(&0.0) - t.first().unwrap_or(&0.0);
        let segment_s = horizon_s.min(span.max(0.0));
        sp += noise_sigma(t, &p.rec.x0).powi(2) + noise_sigma(t, &p.rec.y0).powi(2);
        sv += (noise_sigma(t, &p.rec.u).powi(2) + noise_sigma(t, &p.rec.v).powi(2))
            * segment_s.powi(2);
    }
    let n = prep.len() as f64;
    let sigma_pos = (sp / n).sqrt();
    // Initial-velocity noise (a local fit of about 11 samples) times the segment's length.
    let drift = (sv / n).sqrt() / 11f64.sqrt();
    (sigma_pos.powi(2) + (drift / 3f64.sqrt()).powi(2)).sqrt() / lpp
}

/// The model as given against the recordings: what every candidate is measured against.
pub(crate) struct Baseline {
    pub ship: Ship,
    /// Replay segment length [s] of every position/heading RMSE.
    pub horizon_s: f64,
    pub prep: Vec<Prepared>,
    /// Equation-error residuals of the model with its own effects, per recording.
    pub residuals: Vec<Vec<Option<[f64; 3]>>>,
    /// Robust scale of those residuals per DOF: the unit of every fit's residuals, so that the DOFs
    /// weigh alike whatever their units.
    pub scale: [f64; 3],
    /// Segment-replay scores of the model per recording and their pooled position RMSE ÷ L.
    pub before_each: Vec<ReplayScore>,
    pub before_l: f64,
    /// Position RMSE ÷ L expected from the recordings' noise alone.
    pub noise_floor: f64,
    /// The windage of the recorded wind and of the wind family: the data set's, else assumed.
    pub windage: ChosenWindage,
}

impl Baseline {
    /// Refused when no recording is long enough, the model with its own effects cannot be built or a
    /// recorded environment cannot be used.
    pub fn of(
        input: &DiagnoseInput,
        ds: &Dataset,
        opts: &DiagnoseOptions,
    ) -> Result<Baseline, DiagnoseError> {
        let ship = *input.base.ship();
        let horizon_s = opts.horizon_l_over_u0 * ship.lpp / ship.u0;
        let windage = ChosenWindage::of_dataset(ds);
        let prep = prepare(ds, &ship, opts, &windage)?;
        if prep.is_empty() {
            return Err(DiagnoseError::NothingToDiagnose);
        }
        let base = Composite {
            base: input.base,
            effects: input.base_effects.to_vec(),
        };
        let model = base.model().ok_or(DiagnoseError::Model)?;
        let residuals: Vec<Vec<Option<[f64; 3]>>> =
            prep.iter().map(|p| residuals(&model, p)).collect();
        let scale = robust_scale(&residuals);
        let all: Vec<usize> = (0..prep.len()).collect();
        let before_each = replay_scores(&model, &prep, &all, horizon_s);
        let before_l = pooled(&before_each).position_rmse() / ship.lpp;
        let noise_floor = noise_floor_over_l(&prep, horizon_s, ship.lpp);
        Ok(Baseline {
            ship,
            horizon_s,
            before_l,
            prep,
            residuals,
            scale,
            before_each,
            noise_floor,
            windage,
        })
    }

    /// Held-out position RMSE ÷ L above which the mismatch is real (and `unexplained` when nothing
    /// explains it): a multiple of the model's own level on its training data, when known, plus the
    /// noise and what replays resolve.
    pub fn real_threshold(&self, model_level_over_l: Option<f64>, opts: &DiagnoseOptions) -> f64 {
        model_level_over_l.unwrap_or(0.0) * opts.real_mismatch_factor
            + 3.0 * self.noise_floor
            + REPLAY_RESOLUTION_OVER_L
    }
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
        let score = replay_score(&model, None, &rec, horizon_s);
        assert_eq!(score.diverged_segments, 0);
        let rmse_over_l = score.position_rmse() / ship.lpp;
        assert!(rmse_over_l < 1e-3, "position RMSE {rmse_over_l} L");
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
