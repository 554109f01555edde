//! Functions drawn from a GP's posterior, consistent over a whole trajectory.
//!
//! A band of a simulated manoeuvre needs the posterior over *functions*, not the pointwise variance:
//! one draw must give the same acceleration whenever the trajectory comes back to the same state.
//! A draw is pathwise conditioning (Wilson et al. 2020, "Efficiently sampling functions from Gaussian
//! process posteriors", eq. 8) with the prior path represented at the training points themselves
//! (the inducing-point, or Nyström, approximation):
//!
//! ```text
//! g ~ N(0, K) at the training points X,   ε ~ N(0, σ_n² I)
//! f_s(x) = m + k(x, X) [K⁻¹ g + K_y⁻¹ (y − m − g − ε)]
//! ```
//!
//! At the training points, f_s(X) = g + K K_y⁻¹ (y − m − g − ε) has exactly the posterior mean
//! K K_y⁻¹ (y − m) and covariance K − K K_y⁻¹ K. Between them the draw interpolates like the mean;
//! far from every training point it reverts, like the mean, to m: the draws carry the uncertainty the
//! data leave where there are data, and no extrapolation uncertainty (the identification-range
//! warning says where that applies). A draw costs what the mean costs to evaluate (one kernel sum
//! over the training points, with its own weights).

use std::sync::Arc;

use faer::{Mat, Side};

use crate::error::GpError;
use crate::gp::{Gp, kernel_matrix};

/// What every draw of one GP shares: the GP and the Cholesky factor of its prior covariance K at the
/// training points.
#[derive(Debug, Clone)]
pub struct PosteriorSampler {
    gp: Arc<Gp>,
    /// Lower Cholesky factor of K (σ_f² (C + jitter I)).
    prior_factor: Mat<f64>,
}

/// One function drawn from the posterior.
#[derive(Debug, Clone)]
pub struct PosteriorDraw {
    gp: Arc<Gp>,
    /// σ_f² w, with w the draw's weights on the training points.
    weights: Vec<f64>,
}

impl PosteriorSampler {
    /// Factor the prior covariance of `gp` once for all its draws.
    pub fn new(gp: Arc<Gp>) -> Result<PosteriorSampler, GpError> {
        let k = kernel_matrix(gp.points(), gp.hyper());
        let prior_factor = k
            .llt(Side::Lower)
            .map_err(|_| GpError::NotPositiveDefinite {
                noise_std: gp.hyper().noise_std,
            })?
            .L()
            .to_owned();
        Ok(PosteriorSampler { gp, prior_factor })
    }

    /// One posterior function, from standard normal numbers given by `normal` (2 n of them, n the
    /// number of training points): the caller owns the generator, so draws are reproducible.
    pub fn draw(&self, normal: &mut dyn FnMut() -> f64) -> Result<PosteriorDraw, GpError> {
        let gp = &self.gp;
        let n = gp.points().len();
        let par = faer::get_global_parallelism();
        let z = Mat::<f64>::from_fn(n, 1, |_, _| normal());
        let noise_std = gp.hyper().noise_std;
        let eps: Vec<f64> = (0..n).map(|_| noise_std * normal()).collect();
        // g = L_K z, a prior path at the training points.
        let g = &self.prior_factor * &z;
        // K_y⁻¹ (y − m − g − ε) with the GP's own factor of K_y.
        let mut r = Mat::<f64>::from_fn(n, 1, |i, _| {
            gp.targets()[i] - gp.prior_mean() - g[(i, 0)] - eps[i]
        });
        let l = gp.cholesky();
        faer::linalg::triangular_solve::solve_lower_triangular_in_place(
            l.as_ref(),
            r.as_mut(),
            par,
        );
        faer::linalg::triangular_solve::solve_upper_triangular_in_place(
            l.transpose(),
            r.as_mut(),
            par,
        );
        // K⁻¹ g = L_K⁻ᵀ z.
        let mut kg = z;
        faer::linalg::triangular_solve::solve_upper_triangular_in_place(
            self.prior_factor.transpose(),
            kg.as_mut(),
            par,
        );
        let sf2 = gp.hyper().signal_std * gp.hyper().signal_std;
        let weights: Vec<f64> = (0..n).map(|i| sf2 * (kg[(i, 0)] + r[(i, 0)])).collect();
        if weights.iter().any(|w| !w.is_finite()) {
            return Err(GpError::NotPositiveDefinite { noise_std });
        }
        Ok(PosteriorDraw {
            gp: Arc::clone(&self.gp),
            weights,
        })
    }
}

impl PosteriorDraw {
    /// The drawn function's value at `x` (a point of the GP's dimension).
    pub fn value(&self, x: &[f64]) -> f64 {
        self.gp.prior_mean() + self.gp.kernel_sum(x, &self.weights)
    }
}
