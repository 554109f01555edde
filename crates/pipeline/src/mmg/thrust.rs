//! The propeller's inflow from a recorded thrust. No I/O.
//!
//! The MMG propeller model gives the thrust T = ρ n² D⁴ K_T(J) with J = u (1 − w_P) / (n D) and
//! 1 − w_P = (1 − w_P0)[1 + (1 − e^(−C₁|β_P|))(C₂ − 1)], β_P = β − x′_P r′ (C₂ of the sign of β_P).
//! A recorded thrust measures the inflow directly: the open-water curve inverted at
//! K_T = T / (ρ n² D⁴) gives J, hence 1 − w_P = J n D / u of each sample, and w_P0, C₁, C₂ follow by
//! bounded least squares on those samples alone. The equation error, where these four trade against
//! the rudder's inflow and the resistance, then holds them at the thrust's values.

use shipid_io::{Recording, Ship};
use shipid_sim::KnownEnvironment;
use shipid_sim::mmg::one_minus_wake;

use super::geometry::MmgGeometry;
use super::priors::ParamSpec;
use crate::lm::{LmPoint, lm_step, solve_small};

/// The parameters the recorded thrust determines, in this order.
pub const INFLOW_NAMES: [&str; 4] = ["w_p0", "c1", "c2_pos", "c2_neg"];

/// Samples below this share of U0, or with the propeller below this share of its median rate, carry
/// no usable advance ratio (J and 1 − w_P become ratios of small numbers).
pub const SLOW_SHARE: f64 = 0.2;

/// Fewest usable thrust samples for an estimate of four parameters.
pub const MIN_SAMPLES: usize = 40;

/// One sample's propeller inflow as the recorded thrust measures it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InflowSample {
    /// β_P = β − x′_P r′ [rad].
    pub beta_p_rad: f64,
    /// 1 − w_P [-].
    pub one_minus_w: f64,
}

/// w_P0, C₁, C₂ (β_P > 0, ≤ 0) from the recorded thrust, with their standard errors.
#[derive(Debug, Clone, PartialEq)]
pub struct InflowEstimate {
    /// In the order of [`INFLOW_NAMES`].
    pub values: [f64; 4],
    pub standard_errors: [f64; 4],
    /// Samples used.
    pub samples: usize,
    /// RMS of 1 − w_P about the fitted curve [-].
    pub residual_rms: f64,
    /// Recordings the samples came from.
    pub recordings: Vec<String>,
    /// Whether the fit held the four parameters here ([`hold_inflow`]).
    pub held: bool,
}

/// The advance ratio J ≥ 0 on the falling branch of K_T(J) = k0 + k1 J + k2 J² where it equals
/// `k_t`; `None` where the curve never reaches it there (a thrust above the bollard value, a curve
/// that does not fall) and for K_T ≤ 0 (a propeller that brakes or windmills: beyond the range an
/// open-water curve is measured and fitted over).
pub fn advance_ratio(k: [f64; 3], k_t: f64) -> Option<f64> {
    if k_t.is_nan() || k_t <= 0.0 {
        return None;
    }
    let [k0, k1, k2] = k;
    let falls = |j: f64| k1 + 2.0 * k2 * j < 0.0;
    let roots: Vec<f64> = if k2.abs() < 1e-12 {
        (k1 != 0.0).then(|| (k_t - k0) / k1).into_iter().collect()
    } else {
        let disc = k1 * k1 - 4.0 * k2 * (k0 - k_t);
        if disc < 0.0 {
            return None;
        }
        let s = disc.sqrt();
        vec![(-k1 - s) / (2.0 * k2), (-k1 + s) / (2.0 * k2)]
    };
    roots
        .into_iter()
        .filter(|&j| j.is_finite() && j >= 0.0 && falls(j))
        .min_by(f64::total_cmp)
}

/// The inflow samples of `rec` (water-relative, so that the inflow is the water's) with recorded
/// `thrust` [N] and propeller rates `n_hz` [1/s] per sample.
fn inflow_samples(
    rec: &Recording,
    thrust_n: &[f64],
    n_hz: &[f64],
    ship: &Ship,
    geometry: &MmgGeometry,
) -> Vec<InflowSample> {
    let d = geometry.propeller_diameter_m;
    let x_p = geometry.propeller_x_m / ship.lpp;
    let mut rates: Vec<f64> = n_hz.iter().copied().filter(|x| x.is_finite()).collect();
    if rates.is_empty() {
        return Vec::new();
    }
    rates.sort_by(f64::total_cmp);
    let median_rate = shipid_uncertainty::band::quantile(&rates, 0.5);
    (0..rec.len())
        .filter_map(|i| {
            let (u, v, r, n, t) = (rec.u[i], rec.v[i], rec.r[i], n_hz[i], thrust_n[i]);
            let speed = u.hypot(v);
            if !(u > SLOW_SHARE * ship.u0 && n > SLOW_SHARE * median_rate && t.is_finite()) {
                return None;
            }
            let k_t = t / (ship.rho * n * n * d.powi(4));
            let j = advance_ratio(geometry.k_t, k_t)?;
            let beta = (-v).atan2(u);
            Some(InflowSample {
                beta_p_rad: beta - x_p * r * ship.lpp / speed,
                one_minus_w: j * n * d / u,
            })
        })
        .collect()
}

/// The inflow samples of training windows `recordings` (each in its recorded environment, through
/// the water, and named by `names`) that record a thrust, with their rate `n` or `default_rate_hz`;
/// and the names of the windows that gave some.
pub fn inflow_of_windows<'a>(
    recordings: &[Recording],
    environments: &[Option<KnownEnvironment>],
    names: impl Iterator<Item = &'a str>,
    default_rate_hz: Option<f64>,
    ship: &Ship,
    geometry: &MmgGeometry,
) -> (Vec<InflowSample>, Vec<String>) {
    let mut samples = Vec::new();
    let mut named = Vec::new();
    for ((rec, env), name) in recordings.iter().zip(environments).zip(names) {
        let Some(thrust_n) = rec.thrust.as_ref().filter(|t| t.len() == rec.len()) else {
            continue;
        };
        let n_hz: Vec<f64> = match (&rec.n, default_rate_hz) {
            (Some(n), _) if n.len() == rec.len() => n.clone(),
            (Some(_), _) => continue,
            (None, Some(n)) => vec![n; rec.len()],
            (None, None) => continue,
        };
        let water = env
            .as_ref()
            .map_or_else(|| rec.clone(), |e| e.water_relative(rec));
        let found = inflow_samples(&water, thrust_n, &n_hz, ship, geometry);
        if !found.is_empty() {
            samples.extend(found);
            named.push(name.to_string());
        }
    }
    (samples, named)
}

/// w_P0, C₁, C₂ by bounded least squares on `samples`, within the bounds of `specs` (their entries
/// named in [`INFLOW_NAMES`]) and from their prior centres; `None` with fewer than [`MIN_SAMPLES`]
/// samples or specs that lack one of the four.
pub fn estimate_inflow(
    samples: &[InflowSample],
    specs: &[ParamSpec],
    recordings: Vec<String>,
) -> Option<InflowEstimate> {
    if samples.len() < MIN_SAMPLES {
        return None;
    }
    let spec = |name: &str| specs.iter().find(|s| s.name == name);
    let bounds: Vec<(f64, f64)> = INFLOW_NAMES
        .iter()
        .map(|n| spec(n).map(|s| (s.lower, s.upper)))
        .collect::<Option<_>>()?;
    let project = |p: &mut Vec<f64>| {
        for (x, (lo, hi)) in p.iter_mut().zip(&bounds) {
            *x = x.clamp(*lo, *hi);
        }
    };
    let residuals = |p: &[f64]| -> Vec<f64> {
        samples
            .iter()
            .map(|s| one_minus_wake(p[0], p[1], [p[2], p[3]], s.beta_p_rad) - s.one_minus_w)
            .collect()
    };
    let mut p: Vec<f64> = INFLOW_NAMES
        .iter()
        .map(|n| spec(n).map_or(0.0, |s| s.prior))
        .collect();
    project(&mut p);
    let r = residuals(&p);
    let mut at = LmPoint {
        cost: r.iter().map(|x| x * x).sum(),
        p,
        r,
    };
    let jacobian = |at: &LmPoint| -> Vec<Vec<f64>> {
        (0..4)
            .map(|k| {
                let h = 1e-7 * at.p[k].abs().max(1.0);
                let mut q = at.p.clone();
                q[k] += h;
                residuals(&q)
                    .iter()
                    .zip(&at.r)
                    .map(|(a, b)| (a - b) / h)
                    .collect()
            })
            .collect()
    };
    let mut lambda = 1e-3;
    for _ in 0..200 {
        let jac = jacobian(&at);
        match lm_step(&jac, &mut at, &mut lambda, 12, project, residuals) {
            Some(rel) if rel > 1e-12 => {}
            _ => break,
        }
    }
    let m = samples.len();
    let sigma2 = at.cost / (m.saturating_sub(4).max(1)) as f64;
    let jac = jacobian(&at);
    let jtj: Vec<Vec<f64>> = (0..4)
        .map(|a| (0..4).map(|b| crate::lm::dot(&jac[a], &jac[b])).collect())
        .collect();
    let standard_errors: [f64; 4] = std::array::from_fn(|k| {
        let mut e = vec![0.0; 4];
        e[k] = 1.0;
        solve_small(&jtj, &e).map_or(f64::INFINITY, |col| (sigma2 * col[k]).max(0.0).sqrt())
    });
    Some(InflowEstimate {
        values: [at.p[0], at.p[1], at.p[2], at.p[3]],
        standard_errors,
        samples: m,
        residual_rms: (at.cost / m as f64).sqrt(),
        recordings,
        held: false,
    })
}

/// `specs` with the four inflow parameters held at `estimate` (bounds and prior collapsed onto the
/// value, the standard error as the prior's width, the thrust named as the source).
pub fn hold_inflow(specs: &mut [ParamSpec], estimate: &InflowEstimate) {
    for (k, name) in INFLOW_NAMES.iter().enumerate() {
        if let Some(s) = specs.iter_mut().find(|s| s.name == *name) {
            let value = estimate.values[k];
            s.lower = value;
            s.upper = value;
            s.prior = value;
            s.prior_sd = estimate.standard_errors[k].max(1e-9);
            s.source = format!(
                "the recorded thrust: K_T(J) inverted at T/(ρn²D⁴) on {} samples of {}, 1 − w_P fitted by bounded least squares (RMS {:.3}); held in the fit",
                estimate.samples,
                estimate.recordings.join(", "),
                estimate.residual_rms
            );
        }
    }
}
