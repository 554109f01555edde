//! The settings of a fit as the caller gives them ([`Params`]) and, once checked,
//! ([`CheckedParams`]): the solvers take only the checked form, so none of them has to
//! re-validate a hyper-parameter or a bound, and none can forget to.

use crate::error::EstimatorError;
use crate::types::{Bounds, Estimator, Solver};

/// Estimator (with its hyper-parameters), optional bounds on the unscaled coefficients and
/// solver family, unchecked. [`Params::check`] turns them into the [`CheckedParams`] that
/// [`CheckedParams::fit`] takes, e.g.
/// `Params::new(Estimator::Ridge { lambda: 1e-4 }, Solver::Fast).check()?.fit(design, y)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Params {
    pub estimator: Estimator,
    pub bounds: Option<Bounds>,
    pub solver: Solver,
}

impl Params {
    /// No bounds.
    pub fn new(estimator: Estimator, solver: Solver) -> Self {
        Params {
            estimator,
            bounds: None,
            solver,
        }
    }

    pub fn with_bounds(mut self, bounds: Bounds) -> Self {
        self.bounds = Some(bounds);
        self
    }

    /// Everything that can be judged without the data: every hyper-parameter finite, ≥ 0
    /// and at most [`crate::MAX_HYPER_PARAMETER`] (λ, α, C, ε; C = 0 is a valid, if trivial,
    /// SVR whose solution is the point of the box nearest 0), and bounds of equal lengths with `lower ≤ upper`, no NaN,
    /// `lower < +∞`, `upper > −∞`. That the bounds have one entry per design column is
    /// checked by the fit, which knows the design.
    pub fn check(self) -> Result<CheckedParams, EstimatorError> {
        self.estimator.validate()?;
        if let Some(b) = &self.bounds {
            b.validate_pairs()?;
        }
        Ok(CheckedParams {
            estimator: self.estimator,
            bounds: self.bounds,
            solver: self.solver,
        })
    }
}

/// [`Params`] that passed [`Params::check`]; the only way to make one.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckedParams {
    estimator: Estimator,
    bounds: Option<Bounds>,
    solver: Solver,
}

impl CheckedParams {
    pub fn estimator(&self) -> &Estimator {
        &self.estimator
    }

    pub fn bounds(&self) -> Option<&Bounds> {
        self.bounds.as_ref()
    }

    pub fn solver(&self) -> Solver {
        self.solver
    }

    /// The one check left for the data: one bound per design column. [`Params::check`]
    /// made the two lengths equal, so the lower bounds' length decides (and is what the
    /// error names, as [`Bounds`]' own validation does).
    pub(crate) fn check_columns(&self, p: usize) -> Result<(), EstimatorError> {
        match &self.bounds {
            Some(b) if b.lower.len() != p => Err(EstimatorError::LengthMismatch {
                what: "lower bounds",
                expected: p,
                got: b.lower.len(),
            }),
            _ => Ok(()),
        }
    }
}
