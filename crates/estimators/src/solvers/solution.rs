//! What every solver returns, and the two facts about a box that the fast solvers and the
//! SVR solver share; kept apart from both so that neither has to import the other.

use crate::types::Status;

/// A solution in the scaled space, before unscaling and status refinement.
pub(crate) struct Solution {
    pub(crate) gamma: Vec<f64>,
    pub(crate) status: Status,
    pub(crate) iterations: usize,
}

pub(crate) fn is_unbounded(lo: &[f64], hi: &[f64]) -> bool {
    lo.iter().all(|&l| l == f64::NEG_INFINITY) && hi.iter().all(|&h| h == f64::INFINITY)
}

pub(crate) fn max_active_set_iterations(q: usize) -> usize {
    100 * (q + 1)
}
