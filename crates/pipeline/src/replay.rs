//! Replays of recordings in a model: the whole recording with its rudder ([`crate::validate`]) or
//! in segments restarted from the recorded state (the diagnosis and the output-error refinement score
//! a model by these). No I/O.

use shipid_io::Recording;
use shipid_sim::{Dynamics, Replay, SimOptions, SimStatus, State};

use crate::lm::solve_small;
use crate::validate::DT_OVER_L_OVER_U0;

/// Samples left out at each end of a recording of `n` samples for equation errors: there a
/// differentiator is one-sided.
pub fn differentiator_margin(n: usize) -> usize {
    (n / 50).max(5).min(n / 4)
}

/// Value at sample `i` of a least-squares quadratic in time through the `2·half + 1` samples around it
/// (the window shifted inwards at the ends of the recording): the segment's initial state with the
/// measurement noise averaged out. A plain mean would be biased wherever the signal curves (r and v
/// around a rudder reversal) and, at the first sample, by the ship's own motion (half a window of
/// travel, 0.04 L), and a replay inherits that bias for its whole horizon: the MMG reference replayed
/// on its own noise-free recordings missed them by 0.015 L with the mean.
pub fn local_quadratic_at(t: &[f64], x: &[f64], i: usize, half: usize) -> f64 {
    let n = x.len().min(t.len());
    if n == 0 {
        return f64::NAN;
    }
    let width = (2 * half + 1).min(n);
    let a = i.saturating_sub(half).min(n - width);
    let b = a + width;
    if width < 3 {
        return x[i.min(n - 1)];
    }
    // Normal equations of x ≈ c0 + c1 τ + c2 τ², τ = (t − t_i)/scale, scaled for conditioning.
    let scale = ((t[b - 1] - t[a]) / 2.0).max(f64::MIN_POSITIVE);
    let mut m = [[0.0; 3]; 3];
    let mut rhs = [0.0; 3];
    for k in a..b {
        let tau = (t[k] - t[i.min(n - 1)]) / scale;
        let basis = [1.0, tau, tau * tau];
        for (r, br) in basis.iter().enumerate() {
            rhs[r] += br * x[k];
            for (c, bc) in basis.iter().enumerate() {
                m[r][c] += br * bc;
            }
        }
    }
    match solve_small(&m.iter().map(|row| row.to_vec()).collect::<Vec<_>>(), &rhs) {
        Some(c) if c[0].is_finite() => c[0],
        _ => x[a..b].iter().sum::<f64>() / width as f64,
    }
}

/// Segment boundaries of a recording for the horizon.
pub fn segments(rec: &Recording, horizon_s: f64) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut a = 0;
    let n = rec.len();
    while a + 10 < n {
        let t_end = rec.t[a] + horizon_s;
        let b = rec.t.partition_point(|&t| t <= t_end).min(n);
        if b <= a + 10 {
            break;
        }
        out.push((a, b));
        a = b - 1;
    }
    out
}

/// Longest RK4 step of a segment replay ÷ (L/U0): 0.1 s for the KVLCC2 model, twice the re-simulation
/// step of `validate` ([`DT_OVER_L_OVER_U0`]). A diagnosis spends most of its time in these replays
/// (RK4 on ship motions with time constants of several seconds); on a concealed current + wind case of
/// the default data the held-out RMSEs before and after the effect agree with the 0.05 s step's to
/// 5e-8 relative (a 0.2 s step, which straddles the rudder's 0.1 s samples, to 6e-4).
pub const SEGMENT_STEP_OVER_L_OVER_U0: f64 = 2.0 * DT_OVER_L_OVER_U0;

/// Replay one segment; returns the simulated recording (possibly cut short) and status.
pub fn replay_segment(
    model: &dyn Dynamics,
    rec: &Recording,
    a: usize,
    b: usize,
) -> (Recording, bool) {
    let half = 5;
    let t0 = rec.t[a];
    let t: Vec<f64> = rec.t[a..b].iter().map(|x| x - t0).collect();
    let delta = rec.delta[a..b].to_vec();
    let init = State {
        u: local_quadratic_at(&rec.t, &rec.u, a, half),
        v: local_quadratic_at(&rec.t, &rec.v, a, half),
        r: local_quadratic_at(&rec.t, &rec.r, a, half),
        x0: local_quadratic_at(&rec.t, &rec.x0, a, half),
        y0: local_quadratic_at(&rec.t, &rec.y0, a, half),
        psi: local_quadratic_at(&rec.t, &rec.psi, a, half),
    };
    let ship = model.ship();
    let duration = *t.last().unwrap_or(&0.0);
    // Whole steps that end on the segment's last sample (a step that fell short would leave that
    // sample unreplayed, counted as a divergence), none longer than the replay step.
    let dt_max = SEGMENT_STEP_OVER_L_OVER_U0 * ship.lpp / ship.u0;
    let dt = duration / (duration / dt_max - 1e-9).ceil().max(1.0);
    let Ok(mut ctrl) = Replay::new(t, delta) else {
        return (Recording::default(), false);
    };
    let mut opts = SimOptions::new(duration).with_step(dt, dt);
    opts.initial_rudder_rad = rec.delta[a];
    match shipid_sim::simulate(model, &mut ctrl, init, &opts) {
        Ok(out) => (out.recording, matches!(out.status, SimStatus::Ok)),
        Err(_) => (Recording::default(), false),
    }
}
