//! The per-estimator solvers, in the scaled space of a validated [`crate::problem::Problem`]:
//! `Fast` (direct LSQ, semi-normal / QR / Cholesky, the active-set method, the SVR interior
//! point) and `Qp` (clarabel). They return a scaled-space solution; unscaling, the status
//! and the condition number are decided above them, in [`crate::fit`].

pub(crate) mod active_set;
pub(crate) mod direct;
pub(crate) mod fast;
pub(crate) mod qp;
pub(crate) mod solution;
pub(crate) mod svr;
