//! Locate: where (recording, time window, DOF) and in which manoeuvring regime the model's
//! equation-error residual stands out. The residual — recorded (or differentiated) accelerations minus
//! the model's at the recorded state and rudder — points at the place; the replays cannot, since their
//! errors integrate.

use serde::Serialize;
use shipid_io::{Recording, Ship};

use crate::compare::Prepared;

/// A time window of one recording where the low-passed residual of one DOF stands out.
#[derive(Debug, Clone, Serialize)]
pub struct Located {
    pub recording: String,
    pub dof: &'static str,
    pub t_start: f64,
    pub t_end: f64,
    /// Mean equation-error residual over the window ÷ its noise scale (sign: recorded − model).
    pub mean_residual_over_noise: f64,
}

/// The residual of one DOF averaged over one manoeuvring regime (rudder moving, turning to port or
/// starboard, straight or checking).
#[derive(Debug, Clone, Serialize)]
pub struct Regime {
    pub regime: &'static str,
    pub dof: &'static str,
    pub samples: usize,
    /// Mean equation-error residual in the regime ÷ its noise scale.
    pub mean_residual_over_noise: f64,
}

const DOFS: [&str; 3] = ["surge", "sway", "yaw"];

/// Windows where the low-passed equation-error residual stands out (see [`Located`]).
pub(crate) fn locate(
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

/// Mean residual ÷ noise scale per regime and DOF over all recordings (empty regimes left out).
pub(crate) fn regimes(
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
