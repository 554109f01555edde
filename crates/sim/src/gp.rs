//! A sparse Gaussian-process acceleration model (paper 001) as a [`Dynamics`], and its model file.
//!
//! Three independent GPs map the state and rudder x = (u [m/s], v [m/s], r [rad/s], δ [rad]) of midship
//! (project conventions: δ > 0 turns to starboard) to the accelerations u̇ [m/s²], v̇ [m/s²],
//! ṙ [rad/s²] (paper 001 eqs. 4–6 with the propeller rate constant, as in its §2.1). They share one
//! sparse set of training inputs (paper 001 Tab. 1) and have their own hyper-parameters. The model is
//! integrated by the same loop as every other model ([`crate::simulate`], fixed-step RK4); paper 001
//! integrated with explicit Euler steps at the 20 Hz sampling rate.
//!
//! The ship and added masses are kept so that effects that add external forces ([`crate::effects`]) can
//! turn a force into an acceleration; the GP itself does not use them.

use serde::{Deserialize, Serialize};
use shipid_gp::{Gp, GpError, Hyper, Points, Similarity, Termination};
use shipid_io::{AddedMass, Ship};
use shipid_model::TrainingWindow;

use crate::dynamics::{Dynamics, DynamicsError, Input, OwnRange, State};

/// The `kind` of a GP model file.
pub const GP_KIND: &str = "sparse-gp";
/// Inputs of the GPs, in order, with units.
pub const GP_INPUTS: [&str; 4] = ["u_m_s", "v_m_s", "r_rad_s", "delta_rad"];
/// Outputs (one GP each), in order, with units.
pub const GP_OUTPUTS: [&str; 3] = ["u_dot_m_s2", "v_dot_m_s2", "r_dot_rad_s2"];

/// How the sparse set was chosen (paper 001 Tab. 1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SparsificationInfo {
    /// Similarity threshold d_gen.
    pub similarity_threshold: f64,
    /// Per-input similarity scales l_i, in the inputs' units.
    pub scales: Vec<f64>,
    /// How the scales were chosen.
    pub scales_rule: String,
    /// Training samples walked.
    pub candidates: usize,
    /// Samples kept (= number of training points).
    pub kept: usize,
}

/// One output's GP: hyper-parameters, how they were found, and its targets at the sparse points.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GpOutputFile {
    /// One of [`GP_OUTPUTS`].
    pub name: String,
    /// Hyper-parameters in the units of the inputs and of this output.
    pub hyper: Hyper,
    pub log_marginal_likelihood: f64,
    pub optimiser_iterations: usize,
    pub optimiser_termination: Termination,
    /// Targets at the sparse points, in this output's unit.
    pub targets: Vec<f64>,
}

/// A sparse-GP model file (TOML), written by `shipid fit --estimator sparse-gp`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GpModelFile {
    pub shipid_version: String,
    /// [`GP_KIND`].
    pub kind: String,
    /// Names and units of the inputs ([`GP_INPUTS`]).
    pub inputs: Vec<String>,
    /// How the accelerations of the training data were obtained and the GP's conventions.
    pub method: String,
    pub ship: Ship,
    pub added_mass: AddedMass,
    #[serde(default)]
    pub training: Vec<TrainingWindow>,
    pub sparsification: SparsificationInfo,
    /// u̇, v̇, ṙ in this order.
    pub outputs: Vec<GpOutputFile>,
    /// The sparse training inputs, one row per point, columns as [`GpModelFile::inputs`].
    pub points: Vec<Vec<f64>>,
    /// Inflation factors of calibrated bands (`shipid fit --estimator sparse-gp --calibrate`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration: Option<shipid_model::calibration::FactorCalibrationRecord>,
}

/// Why a GP model file cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GpModelError {
    #[error("kind is `{0}`, expected `{GP_KIND}`")]
    Kind(String),
    #[error("inputs are {got:?}, expected {GP_INPUTS:?}")]
    Inputs { got: Vec<String> },
    #[error("outputs are {got:?}, expected {GP_OUTPUTS:?}")]
    Outputs { got: Vec<String> },
    #[error("output {output}: {source}")]
    Gp {
        output: String,
        #[source]
        source: GpError,
    },
}

/// The three GPs with the ship they describe.
#[derive(Debug, Clone)]
pub struct GpDynamics {
    pub ship: Ship,
    pub added_mass: AddedMass,
    /// u̇, v̇, ṙ.
    pub gps: [Gp; 3],
    /// The sparse points and the similarity that chose them: where the model was identified.
    pub points: Points,
    pub similarity: Similarity,
}

impl GpDynamics {
    /// Rebuild the GPs (one Cholesky factorisation each) from a model file.
    pub fn from_file(f: &GpModelFile) -> Result<GpDynamics, GpModelError> {
        if f.kind != GP_KIND {
            return Err(GpModelError::Kind(f.kind.clone()));
        }
        if f.inputs.iter().map(String::as_str).ne(GP_INPUTS) {
            return Err(GpModelError::Inputs {
                got: f.inputs.clone(),
            });
        }
        if f.outputs.iter().map(|o| o.name.as_str()).ne(GP_OUTPUTS) {
            return Err(GpModelError::Outputs {
                got: f.outputs.iter().map(|o| o.name.clone()).collect(),
            });
        }
        let x = Points::from_rows(&f.points).map_err(|source| GpModelError::Gp {
            output: "points".into(),
            source,
        })?;
        if x.dims() != GP_INPUTS.len() {
            return Err(GpModelError::Gp {
                output: "points".into(),
                source: GpError::LengthMismatch {
                    what: "point dimension",
                    expected: GP_INPUTS.len(),
                    got: x.dims(),
                },
            });
        }
        let build = |o: &GpOutputFile| {
            Gp::new(x.clone(), o.targets.clone(), o.hyper.clone()).map_err(|source| {
                GpModelError::Gp {
                    output: o.name.clone(),
                    source,
                }
            })
        };
        let similarity = Similarity {
            scales: f.sparsification.scales.clone(),
            threshold: f.sparsification.similarity_threshold,
        };
        similarity
            .check(GP_INPUTS.len())
            .map_err(|source| GpModelError::Gp {
                output: "sparsification".into(),
                source,
            })?;
        Ok(GpDynamics {
            ship: f.ship,
            added_mass: f.added_mass,
            gps: [
                build(&f.outputs[0])?,
                build(&f.outputs[1])?,
                build(&f.outputs[2])?,
            ],
            points: x,
            similarity,
        })
    }

    /// Whether the state (u [m/s], v [m/s], r [rad/s], δ [rad]) lies within the identification range:
    /// some sparse point is at least d_gen similar to it — paper 001's test for "no new information",
    /// which every training sample passes by construction. Outside, no training data was near and the
    /// mean reverts towards its constant.
    pub fn covers(&self, u: f64, v: f64, r: f64, delta_rad: f64) -> bool {
        self.similarity.covered(&self.points, &[u, v, r, delta_rad])
    }

    /// Predictive mean and latent variance of the three accelerations at one state and rudder angle.
    pub fn predict_with_variance(
        &self,
        s: &State,
        delta_rad: f64,
    ) -> Result<([f64; 3], [f64; 3]), GpError> {
        let at = Points::new(4, vec![s.u, s.v, s.r, delta_rad])?;
        let mut mean = [0.0; 3];
        let mut var = [0.0; 3];
        for (k, gp) in self.gps.iter().enumerate() {
            let (m, v) = gp.predict(&at)?;
            mean[k] = m[0];
            var[k] = v[0];
        }
        Ok((mean, var))
    }
}

impl OwnRange for GpDynamics {
    fn covers(&self, u: f64, v: f64, r: f64, delta_rad: f64) -> bool {
        GpDynamics::covers(self, u, v, r, delta_rad)
    }
    fn criterion(&self) -> &'static str {
        "no sparse point of the GP d_gen-similar"
    }
}

impl Dynamics for GpDynamics {
    fn own_range(&self) -> Option<&dyn OwnRange> {
        Some(self)
    }

    fn accelerations_for(&self, s: &State, input: &Input) -> Result<[f64; 3], DynamicsError> {
        let x = [s.u, s.v, s.r, input.delta_rad];
        if x.iter().any(|v| !v.is_finite()) {
            return Err(DynamicsError::OutOfDomain(format!(
                "non-finite state {x:?}"
            )));
        }
        // Far from the training data the mean reverts to the prior (the training mean of each
        // acceleration); the simulation then drifts rather than diverges, and the replay RMSEs show it.
        Ok(std::array::from_fn(|k| self.gps[k].predict_mean(&x)))
    }

    fn ship(&self) -> &Ship {
        &self.ship
    }

    fn added_mass(&self) -> &AddedMass {
        &self.added_mass
    }
}
