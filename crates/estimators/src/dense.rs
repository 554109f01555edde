//! Dense linear algebra at the shapes of Abkowitz designs (n ≈ 1e3–1e4 rows, p ≤ 22
//! columns): the fused column passes and their run-time instruction-set dispatch, the small
//! symmetric eigensolver, and the factorisations built on faer. Nothing here knows about
//! estimators, so the solvers and the fit logic depend on it and never the reverse.

pub(crate) mod kernels;
pub(crate) mod linalg;
pub(crate) mod small_eig;
