//! The Abkowitz manoeuvring model as data and as equations. No I/O.
//!
//! - [`set`]: coefficient sets as TOML data ([`CoefficientSet`]); `full68`, `full74`, `reduced32` and `chen2021`
//!   are shipped in `crates/model/sets/`, a user set is any file of the same form;
//! - [`design`]: primed samples, design matrices Φ and targets y per degree of freedom (equations of motion in
//!   `docs/conventions.md`),
//!   per-term force contributions;
//! - [`abkowitz`]: an identified model ([`AbkowitzModel`]), its accelerations for any state, and the
//!   model file written by `shipid fit` ([`ModelFile`]);
//! - [`calibration`]: the model file's `[calibration]` (ensemble replicates per structure and
//!   inflation factors per metric family) and its checks;
//! - [`envelope`]: where an identified model's regression extrapolates ([`IdentificationRange`]: the
//!   leverage of a state against the training design).

pub mod abkowitz;
pub mod calibration;
pub mod design;
pub mod envelope;
pub mod set;

pub use abkowitz::{
    AbkowitzModel, AugmentedModelFile, BootstrapRecord, EffectEntry, EnvironmentRecord,
    EstimatorInfo, ModelError, ModelFile, Refinement, TrainingWindow, training_fault,
};
pub use calibration::{
    CalibrationDamage, CalibrationRecord, CheckedCalibration, FactorRecord, OutOfKindRecord,
    StructureRecord,
};
pub use design::{Design, PrimeInertia, Samples, design};
pub use envelope::{IdentificationRange, RangeError};
pub use set::{CoefficientSet, Dof, Known, Monomial, Powers, SetError, SetFile};
