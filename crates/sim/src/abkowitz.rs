//! An identified Abkowitz model ([`shipid_model::AbkowitzModel`]) as a [`Dynamics`], so that it is
//! integrated by the same simulation loop, controllers and metrics as the MMG reference.

use shipid_io::{AddedMass, Ship};
use shipid_model::AbkowitzModel;

use crate::dynamics::{Dynamics, DynamicsError, State};

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
}
