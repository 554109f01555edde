//! An identified Abkowitz model ([`shipid_model::AbkowitzModel`]) as a [`Dynamics`], so that it is
//! integrated by the same simulation loop, controllers and metrics as the MMG reference.

use shipid_io::{AddedMass, PrimeScale, Ship};
use shipid_model::AbkowitzModel;

use crate::dynamics::{Dynamics, DynamicsError, Input, LinearHullDerivatives, Parametric, State};

/// Wraps an identified model for simulation.
#[derive(Debug, Clone)]
pub struct AbkowitzDynamics(pub AbkowitzModel);

impl Dynamics for AbkowitzDynamics {
    fn accelerations_for(&self, s: &State, input: &Input) -> Result<[f64; 3], DynamicsError> {
        let delta_rad = input.delta_rad;
        // The polynomial is only trusted where it is finite; the simulation loop turns a non-finite
        // result into a divergence status.
        Ok(self.0.accelerations(s.u, s.v, s.r, delta_rad))
    }

    fn ship(&self) -> &Ship {
        &self.0.ship
    }

    fn added_mass(&self) -> &AddedMass {
        &self.0.added_mass
    }

    /// Y_v, Y_r, N_v, N_r of the polynomial converted from the prime system I (½ρL²U0², ½ρL³U0²) to the
    /// MMG normalisation (½ρLdU², ½ρL²dU²): both multiply by L/d. `None` when the set lacks one.
    fn linear_hull_derivatives(&self) -> Option<LinearHullDerivatives> {
        let m = &self.0;
        let l_over_d = m.ship.lpp / m.ship.draft;
        let c = |name: &str| m.coefficient(name).map(|x| x * l_over_d);
        Some(LinearHullDerivatives {
            y_v: c("Y_v")?,
            y_r: c("Y_r")?,
            n_v: c("N_v")?,
            n_r: c("N_r")?,
        })
    }
}

/// θ = every coefficient, in the order of [`AbkowitzModel::flat_coefficients`]. The accelerations
/// are linear in θ and polynomial in the state, so both derivatives are analytic.
impl Parametric for AbkowitzDynamics {
    fn parameters(&self) -> Vec<f64> {
        self.0.flat_coefficients()
    }

    fn with_parameters(&self, theta: &[f64]) -> Option<Self> {
        (theta.len() == self.0.coefficient_total())
            .then(|| {
                self.0
                    .with_flat_coefficients(theta)
                    .ok()
                    .map(AbkowitzDynamics)
            })
            .flatten()
    }

    /// A coefficient's unit changes its DOF's force by the RMS of that force on the states: the
    /// DOF's force RMS over the RMS of the term's monomial. A term whose monomial never moves, or a
    /// DOF without force, has none.
    fn parameter_units(&self, states: &[(State, f64)]) -> Vec<Option<f64>> {
        let m = &self.0;
        let s = PrimeScale::of(&m.ship);
        let primed: Vec<[f64; 4]> = states
            .iter()
            .map(|(x, delta)| {
                [
                    s.delta_u_prime(x.u),
                    s.velocity_prime(x.v),
                    s.yaw_rate_prime(x.r),
                    *delta,
                ]
            })
            .collect();
        let n = primed.len().max(1) as f64;
        let mut units = Vec::with_capacity(m.coefficient_total());
        for d in 0..3 {
            let force_rms = (primed
                .iter()
                .map(|&[du, v, r, dl]| m.forces_prime(du, v, r, dl)[d].powi(2))
                .sum::<f64>()
                / n)
                .sqrt();
            for term in &m.set.terms[d] {
                let term_rms = (primed
                    .iter()
                    .map(|&[du, v, r, dl]| term.eval(du, v, r, dl).powi(2))
                    .sum::<f64>()
                    / n)
                    .sqrt();
                units.push((term_rms > 1e-12 && force_rms > 0.0).then(|| force_rms / term_rms));
            }
        }
        units
    }

    fn analytic_sensitivities(&self) -> bool {
        true
    }

    fn sensitivities(
        &self,
        state: &State,
        delta_rad: f64,
        d_state: &mut [[f64; 3]; 3],
        d_theta: &mut [[f64; 3]],
    ) -> Result<[f64; 3], DynamicsError> {
        Ok(self
            .0
            .accelerations_and_derivatives(state.u, state.v, state.r, delta_rad, d_state, d_theta))
    }
}
