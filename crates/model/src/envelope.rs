//! The identification range of an Abkowitz model: where its regression extrapolates.
//!
//! A polynomial identified from free-running manoeuvres has only seen the states those manoeuvres
//! visit. In calm water v′ and r′ move together (a turn sets its own drift angle), so states such as a
//! steady drift with counter-rudder — what a beam wind or a rudder offset produces — can lie far from
//! every training state although each of v′, r′ and δ stays inside its own training range. Per-variable
//! ranges miss that; the leverage of the regression does not ("hidden extrapolation", Montgomery, Peck &
//! Vining, *Introduction to Linear Regression Analysis*, 5th ed., §3.8):
//!
//! ```text
//!     h(x) = φ(x)ᵀ (ΦᵀΦ)⁻¹ φ(x)        Var(f̂(x)) = σ² h(x)
//! ```
//!
//! with φ(x) the set's monomials at the state and Φ the training design of one degree of freedom. A
//! state whose leverage exceeds the largest leverage of the training samples, h_max, lies outside the
//! ellipsoid that contains them all: the model's forces there are an extrapolation. The ratio
//! h(x)/h_max, largest over X, Y and N, is what [`IdentificationRange::leverage_ratio`] returns (above 1:
//! outside).
//!
//! Computed from the QR factor R of the column-scaled design (no normal equations, so the ratio is
//! accurate to about κ(Z)·ε): h(x) = ‖R⁻ᵀ S⁻¹ φ(x)‖².

use faer::Mat;

use crate::design::Samples;
use crate::set::{CoefficientSet, Dof, Powers};

/// Why an identification range cannot be formed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RangeError {
    #[error("{dof}: {samples} training samples for {terms} terms")]
    TooFewSamples {
        dof: Dof,
        samples: usize,
        terms: usize,
    },
    #[error(
        "{dof}: the training design is rank deficient (term {term} is a combination of the others)"
    )]
    RankDeficient { dof: Dof, term: String },
    #[error("a training state is not finite")]
    NonFinite,
}

/// Per degree of freedom: the column scales S and R of the scaled training design, and h_max.
#[derive(Debug, Clone)]
struct DofRange {
    /// 1/s_j (RMS of column j over the training samples).
    inv_scale: Vec<f64>,
    /// Upper triangle of R, row-major p × p.
    r: Vec<f64>,
    h_max: f64,
}

impl DofRange {
    /// ‖R⁻ᵀ S⁻¹ φ‖² by forward substitution on Rᵀ; `w` is scratch of at least φ's length.
    fn leverage(&self, phi: &[f64], w: &mut [f64]) -> f64 {
        let p = phi.len();
        let mut h = 0.0;
        for j in 0..p {
            let mut v = phi[j] * self.inv_scale[j];
            for (k, wk) in w[..j].iter().enumerate() {
                v -= self.r[k * p + j] * wk;
            }
            w[j] = v / self.r[j * p + j];
            h += w[j] * w[j];
        }
        h
    }
}

/// Where a model's regression was identified (see the module docs).
#[derive(Debug, Clone)]
pub struct IdentificationRange {
    set: CoefficientSet,
    /// `None` for training states that span no ellipsoid ([`IdentificationRange::nowhere`]).
    dofs: Option<[DofRange; 3]>,
    /// Why the training states span none, in words (`None` for a range that has an ellipsoid).
    degenerate: Option<String>,
}

/// A diagonal of R below this fraction of the largest marks a rank-deficient design.
const RANK_TOLERANCE: f64 = 1e-12;

impl IdentificationRange {
    /// The range of `set` identified on the training samples `s` (their states; accelerations unused).
    pub fn from_samples(
        set: &CoefficientSet,
        s: &Samples,
    ) -> Result<IdentificationRange, RangeError> {
        let states: Vec<[f64; 4]> = (0..s.len())
            .map(|i| [s.du[i], s.v[i], s.r[i], s.delta[i]])
            .collect();
        IdentificationRange::new(set, &states)
    }

    /// The range of `set` identified on the primed training states (Δu′, v′, r′, δ [rad]).
    pub fn new(
        set: &CoefficientSet,
        states: &[[f64; 4]],
    ) -> Result<IdentificationRange, RangeError> {
        if states.iter().flatten().any(|v| !v.is_finite()) {
            return Err(RangeError::NonFinite);
        }
        let powers: Vec<Powers> = states
            .iter()
            .map(|&[du, v, r, d]| Powers::new(du, v, r, d))
            .collect();
        let range = |dof: Dof| dof_range(set, dof, &powers);
        let dofs = [range(Dof::X)?, range(Dof::Y)?, range(Dof::N)?];
        Ok(IdentificationRange {
            set: set.clone(),
            dofs: Some(dofs),
            degenerate: None,
        })
    }

    /// The range of training states that span no ellipsoid (a straight run: no rudder, drift or yaw;
    /// fewer states than terms): every state lies outside it, since the model was identified on
    /// none of the state space around them. `why` says which quantity did not vary.
    pub fn nowhere(set: &CoefficientSet, why: impl Into<String>) -> IdentificationRange {
        IdentificationRange {
            set: set.clone(),
            dofs: None,
            degenerate: Some(why.into()),
        }
    }

    /// Why the training states span no ellipsoid (`None` when they do): a
    /// [`IdentificationRange::nowhere`] range.
    pub fn degenerate(&self) -> Option<&str> {
        self.degenerate.as_deref()
    }

    /// max over X, Y, N of h(x)/h_max at the primed state (Δu′, v′, r′, δ [rad]): above 1 the state
    /// lies outside the training states' leverage ellipsoid of that equation. NaN for a non-finite
    /// state.
    pub fn leverage_ratio(&self, du: f64, v: f64, r: f64, delta: f64) -> f64 {
        if ![du, v, r, delta].iter().all(|x| x.is_finite()) {
            return f64::NAN;
        }
        let Some(dofs) = &self.dofs else {
            return f64::INFINITY;
        };
        let pw = Powers::new(du, v, r, delta);
        // One row and one scratch buffer for the three equations (called once per sample).
        let p = self.set.terms.iter().map(Vec::len).max().unwrap_or(0);
        let (mut row, mut w) = (Vec::with_capacity(p), vec![0.0; p]);
        let mut worst = 0.0f64;
        for (terms, range) in self.set.terms.iter().zip(dofs) {
            row.clear();
            row.extend(terms.iter().map(|t| t.eval_powers(&pw)));
            worst = worst.max(range.leverage(&row, &mut w) / range.h_max);
        }
        worst
    }
}

/// The range of one degree of freedom over the training states' `powers`.
fn dof_range(set: &CoefficientSet, dof: Dof, powers: &[Powers]) -> Result<DofRange, RangeError> {
    let n = powers.len();
    let terms = &set.terms[dof.index()];
    let p = terms.len();
    if n <= p {
        return Err(RangeError::TooFewSamples {
            dof,
            samples: n,
            terms: p,
        });
    }
    let phi = Mat::<f64>::from_fn(n, p, |i, j| terms[j].eval_powers(&powers[i]));
    let inv_scale: Vec<f64> = (0..p)
        .map(|j| {
            let ss: f64 = (0..n).map(|i| phi[(i, j)] * phi[(i, j)]).sum();
            let rms = (ss / n as f64).sqrt();
            if rms > 0.0 { 1.0 / rms } else { 0.0 }
        })
        .collect();
    let z = Mat::<f64>::from_fn(n, p, |i, j| phi[(i, j)] * inv_scale[j]);
    let qr = z.as_ref().qr();
    let rf = qr.thin_R();
    let mut r = vec![0.0; p * p];
    for i in 0..p {
        for j in i..p {
            r[i * p + j] = rf[(i, j)];
        }
    }
    let largest = (0..p).fold(0.0f64, |m, j| m.max(r[j * p + j].abs()));
    if let Some(j) = (0..p).find(|&j| {
        inv_scale[j] == 0.0
            || r[j * p + j].abs().partial_cmp(&(RANK_TOLERANCE * largest))
                != Some(std::cmp::Ordering::Greater)
    }) {
        return Err(RangeError::RankDeficient {
            dof,
            term: set.names(dof)[j].clone(),
        });
    }
    let mut range = DofRange {
        inv_scale,
        r,
        h_max: 0.0,
    };
    // The training rows are Φ's own rows: the same values leverage_ratio forms for a state.
    let (mut row, mut w) = (vec![0.0; p], vec![0.0; p]);
    for i in 0..n {
        for (j, x) in row.iter_mut().enumerate() {
            *x = phi[(i, j)];
        }
        range.h_max = range.h_max.max(range.leverage(&row, &mut w));
    }
    Ok(range)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Training states of a calm-water manoeuvre: v′ tied to r′ (v′ = −0.3 r′) with δ following r′.
    fn calm(n: usize) -> Samples {
        let mut s = Samples::default();
        for i in 0..n {
            let ph = i as f64 / n as f64 * 12.0;
            let r = 0.4 * ph.sin() + 0.05 * (3.0 * ph).cos();
            s.du.push(-0.05 * r * r + 0.01 * (7.0 * ph).cos());
            s.v.push(-0.3 * r + 0.01 * (5.0 * ph).sin());
            s.r.push(r);
            s.delta.push(0.6 * (ph + 0.4).sin());
        }
        s
    }

    fn check(state: [f64; 4], outside: bool) {
        let set = CoefficientSet::builtin("reduced32").unwrap();
        let range = IdentificationRange::from_samples(&set, &calm(2000)).unwrap();
        let ratio = range.leverage_ratio(state[0], state[1], state[2], state[3]);
        assert_eq!(ratio > 1.0, outside, "state {state:?}: ratio {ratio}");
    }

    #[test]
    fn states_the_manoeuvre_visited_are_inside() {
        let s = calm(2000);
        for i in [17, 400, 1234] {
            check([s.du[i], s.v[i], s.r[i], s.delta[i]], false);
        }
        check([0.0; 4], false);
    }

    #[test]
    fn a_steady_drift_with_counter_rudder_is_outside_although_each_variable_is_in_range() {
        // v′ = 0.1 and δ = −0.2 rad are each well inside their training ranges, r′ = 0.
        check([0.0, 0.1, 0.0, -0.2], true);
        // Beyond the largest yaw rate: plain extrapolation.
        check([0.0, -0.3 * 0.6, 0.6, 0.0], true);
    }

    #[test]
    fn the_training_samples_reach_the_ratio_one_and_no_more() {
        let set = CoefficientSet::builtin("full68").unwrap();
        let s = calm(1500);
        let range = IdentificationRange::from_samples(&set, &s).unwrap();
        let ratios: Vec<f64> = (0..s.len())
            .map(|i| range.leverage_ratio(s.du[i], s.v[i], s.r[i], s.delta[i]))
            .collect();
        let top = ratios.iter().cloned().fold(0.0f64, f64::max);
        assert!((top - 1.0).abs() < 1e-9, "largest training ratio {top}");
    }

    #[test]
    fn a_range_of_no_ellipsoid_puts_every_state_outside() {
        let set = CoefficientSet::builtin("reduced32").unwrap();
        let range = IdentificationRange::nowhere(&set, "the rudder angle is constant");
        assert_eq!(range.degenerate(), Some("the rudder angle is constant"));
        assert_eq!(range.leverage_ratio(0.0, 0.0, 0.0, 0.0), f64::INFINITY);
        assert!(range.leverage_ratio(f64::NAN, 0.0, 0.0, 0.0).is_nan());
    }

    #[test]
    fn a_design_without_rudder_variation_is_rank_deficient() {
        let set = CoefficientSet::builtin("reduced32").unwrap();
        let mut s = calm(500);
        s.delta.iter_mut().for_each(|d| *d = 0.0);
        assert!(matches!(
            IdentificationRange::from_samples(&set, &s),
            Err(RangeError::RankDeficient { .. })
        ));
    }
}
