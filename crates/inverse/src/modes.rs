//! SVD variation modes of the hydrodynamic database (paper 003 §2.2, eqs. 7–11).
//!
//! Every ship's behaviour vector h_i ([`crate::database::behaviour`]) minus the mean h̄ is a column of the
//! variation matrix H_var (323 × n_ships); H_var = U Σ Vᵀ. Mode i is the column u_i, its contribution
//! λ_i = σ_i² / Σσ² (eq. 10), and the generator is h_gen = h̄ + Σ_i x_i u_i (eq. 11) with the weight x_i
//! drawn within ±3 std of the i-th row of C = Σ Vᵀ (the ships' own weights).
//!
//! Because h is linear in the 24 coefficients (h = A c), u_i = A w_i with w_i = C_var v_i / s_i, where
//! C_var holds the ships' coefficients minus their mean. The generator therefore produces coefficients
//! directly: c_gen = c̄ + Σ x_i w_i, whose behaviour vector is exactly h_gen.

use faer::Mat;

use crate::database::{Coefficients, DatabaseShip, N_COEF, behaviour, behaviour_len, validate};
use crate::error::{InverseError, readable};

/// The variation modes of a database.
#[derive(Debug, Clone, PartialEq)]
pub struct VariationModes {
    /// Ship ids in column order.
    pub ship_ids: Vec<String>,
    /// Mean coefficients c̄.
    pub mean: Coefficients,
    /// Mean behaviour vector h̄ (length 323).
    pub mean_behaviour: Vec<f64>,
    /// Singular values s_i, descending.
    pub singular_values: Vec<f64>,
    /// Self contribution λ_i = s_i² / Σ s² [-].
    pub contribution: Vec<f64>,
    /// Mode vectors u_i in behaviour space (columns, each of length 323).
    pub behaviour_modes: Vec<Vec<f64>>,
    /// Mode vectors w_i in coefficient space (u_i = A w_i).
    pub coefficient_modes: Vec<Coefficients>,
    /// Standard deviation of the ships' weights per mode (row i of C = ΣVᵀ; sample std, n − 1).
    pub weight_std: Vec<f64>,
    /// Weights of each database ship, `ship_weights[ship][mode]` (C transposed).
    pub ship_weights: Vec<Vec<f64>>,
    /// The singular values left out as rounding noise (at most
    /// [`NOISE_RELATIVE_SINGULAR_VALUE`] × the norm of the ships' behaviour vectors): one for the
    /// subtracted mean, more when ships are linear combinations of others.
    pub noise_singular_values: Vec<f64>,
}

/// A singular value at most this fraction of the norm of the ships' behaviour vectors (their
/// Frobenius norm) is rounding noise, not variation: subtracting the mean leaves relative errors of
/// about 1e-16, and the smallest real mode of paper 003's database is 1e-3 of that norm.
pub const NOISE_RELATIVE_SINGULAR_VALUE: f64 = 1e-9;

impl VariationModes {
    /// Whether the ships span fewer independent variations than n − 1 (some ships are linear
    /// combinations of others): the modes beyond are left out as noise.
    pub fn rank_deficient(&self) -> bool {
        self.singular_values.len() + 1 < self.ship_ids.len()
    }
}

impl VariationModes {
    /// SVD of the variation matrix of `ships`.
    pub fn new(ships: &[DatabaseShip]) -> Result<VariationModes, InverseError> {
        validate(ships)?;
        let n = ships.len();
        let coefs: Vec<Coefficients> = ships.iter().map(|s| s.coefficients()).collect();
        let mut mean = [0.0; N_COEF];
        for c in &coefs {
            for (m, v) in mean.iter_mut().zip(c.0) {
                *m += v / n as f64;
            }
        }
        let mean = Coefficients(mean);
        let mean_behaviour = behaviour(&mean);
        let rows = behaviour_len();
        let hs: Vec<Vec<f64>> = coefs.iter().map(behaviour).collect();
        let h_var = Mat::<f64>::from_fn(rows, n, |i, j| hs[j][i] - mean_behaviour[i]);
        let svd = h_var
            .thin_svd()
            .map_err(|e| InverseError::Svd(format!("{e:?}")))?;
        let (u, s, v) = (svd.U(), svd.S().column_vector(), svd.V());
        // Singular values at rounding level are no variation of the ships: n ships give at most
        // n − 1 modes (the mean is subtracted), and copies or linear combinations of ships fewer.
        // Such a mode's direction is noise; a network trained on its weight learns noise.
        let scale = hs
            .iter()
            .map(|h| h.iter().map(|x| x * x).sum::<f64>())
            .sum::<f64>()
            .sqrt();
        let noise_level = NOISE_RELATIVE_SINGULAR_VALUE * scale;
        let all: Vec<f64> = (0..s.nrows()).map(|i| s[i]).collect();
        if all.iter().any(|x| !x.is_finite()) || !scale.is_finite() {
            return Err(InverseError::Database(
                "the variation matrix is not finite (a coefficient too large?)".into(),
            ));
        }
        let k = all.iter().take_while(|&&x| x > noise_level).count();
        if k == 0 {
            return Err(InverseError::Database(format!(
                "the {n} ships do not vary: the largest singular value of their variation matrix \
                 is {} against {} for the ships' behaviour vectors, rounding noise, so there \
                 is no variation mode to generate ships from",
                readable(&all.first().copied().unwrap_or(0.0)),
                readable(&scale)
            )));
        }
        let noise_singular_values = all[k..].to_vec();
        let singular_values: Vec<f64> = all[..k].to_vec();
        let total: f64 = singular_values.iter().map(|x| x * x).sum();
        let contribution = singular_values.iter().map(|x| x * x / total).collect();
        let behaviour_modes = (0..k)
            .map(|i| (0..rows).map(|r| u[(r, i)]).collect())
            .collect();
        let coefficient_modes = (0..k)
            .map(|i| {
                let mut w = [0.0; N_COEF];
                if singular_values[i] > 0.0 {
                    for (j, c) in coefs.iter().enumerate() {
                        for (wq, (cq, mq)) in w.iter_mut().zip(c.0.iter().zip(mean.0)) {
                            *wq += (cq - mq) * v[(j, i)] / singular_values[i];
                        }
                    }
                }
                Coefficients(w)
            })
            .collect();
        let ship_weights: Vec<Vec<f64>> = (0..n)
            .map(|j| (0..k).map(|i| singular_values[i] * v[(j, i)]).collect())
            .collect();
        let weight_std = (0..k)
            .map(|i| {
                let m = ship_weights.iter().map(|w| w[i]).sum::<f64>() / n as f64;
                (ship_weights.iter().map(|w| (w[i] - m).powi(2)).sum::<f64>() / (n - 1) as f64)
                    .sqrt()
            })
            .collect();
        Ok(VariationModes {
            ship_ids: ships.iter().map(|s| s.id.clone()).collect(),
            mean,
            mean_behaviour,
            singular_values,
            contribution,
            behaviour_modes,
            coefficient_modes,
            weight_std,
            ship_weights,
            noise_singular_values,
        })
    }

    /// Cumulative contribution of the first 1, 2, … modes.
    pub fn cumulative(&self) -> Vec<f64> {
        self.contribution
            .iter()
            .scan(0.0, |acc, x| {
                *acc += x;
                Some(*acc)
            })
            .collect()
    }

    /// Smallest number of modes whose cumulative contribution reaches `fraction` (e.g. 0.95).
    pub fn modes_for(&self, fraction: f64) -> usize {
        let c = self.cumulative();
        c.iter()
            .position(|&x| x >= fraction - 1e-12)
            .map_or(c.len(), |i| i + 1)
    }

    /// Coefficients c̄ + Σ x_i w_i for the weights `x` of the first `x.len()` modes.
    pub fn generate(&self, x: &[f64]) -> Result<Coefficients, InverseError> {
        if x.len() > self.coefficient_modes.len() {
            return Err(InverseError::Invalid(format!(
                "{} weights for {} modes",
                x.len(),
                self.coefficient_modes.len()
            )));
        }
        if let Some(bad) = x.iter().find(|v| !v.is_finite()) {
            return Err(InverseError::Invalid(format!(
                "mode weight {bad} is not finite"
            )));
        }
        let mut c = self.mean.0;
        for (xi, w) in x.iter().zip(&self.coefficient_modes) {
            for (cq, wq) in c.iter_mut().zip(w.0) {
                *cq += xi * wq;
            }
        }
        Ok(Coefficients(c))
    }

    /// Weights x_i = u_iᵀ (h(c) − h̄) of the first `n_modes` modes for coefficients `c`.
    pub fn project(&self, c: &Coefficients, n_modes: usize) -> Vec<f64> {
        let h = behaviour(c);
        self.behaviour_modes
            .iter()
            .take(n_modes)
            .map(|u| {
                u.iter()
                    .zip(h.iter().zip(&self.mean_behaviour))
                    .map(|(ui, (hi, mi))| ui * (hi - mi))
                    .sum()
            })
            .collect()
    }
}
