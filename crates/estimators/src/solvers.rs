//! The per-estimator solvers, in the scaled space of a validated [`crate::problem::Problem`]:
//! `Fast` (direct LSQ, semi-normal / QR / Cholesky, the active-set method, the SVR interior
//! point) and `Qp` (clarabel). They return a [`solution::Solution`]; unscaling, the status
//! and the condition number are decided above them, in [`mod@crate::fit`], so a solver only
//! has to minimise J.

pub(crate) mod active_set;
pub(crate) mod direct;
pub(crate) mod fast;
pub(crate) mod qp;
pub(crate) mod solution;
pub(crate) mod svr;
