//! An identified Abkowitz model ([`shipid_model::AbkowitzModel`]) as a [`Dynamics`], so that it is
//! integrated by the same simulation loop, controllers and metrics as the MMG reference.

use shipid_io::{AddedMass, Ship};
use shipid_model::AbkowitzModel;

use crate::dynamics::{Dynamics, DynamicsError, LinearHullDerivatives, State};

/// Wraps an identified model for simulation.
#[derive(Debug, Clone)]
pub struct AbkowitzDynamics(pub AbkowitzModel);

impl Dynamics for AbkowitzDynamics {
    fn accelerations(&self, s: &State, delta_rad: f64) -> Result<[f64; 3], DynamicsError> {
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
