//! The identified Abkowitz model: coefficients of a set, the ship, the known acceleration derivatives,
//! and its accelerations for any state (used by `shipid_sim` to integrate it).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};
use shipid_io::{AddedMass, PrimeScale, Ship};

use crate::design::PrimeInertia;
use crate::set::{CoefficientSet, Dof, Powers, SetError, SetFile};

/// An Abkowitz model ready to evaluate.
#[derive(Debug, Clone, PartialEq)]
pub struct AbkowitzModel {
    pub set: CoefficientSet,
    /// Coefficients per DOF (prime system), in the set's term order.
    pub coefficients: [Vec<f64>; 3],
    pub ship: Ship,
    pub added_mass: AddedMass,
    inertia: PrimeInertia,
    /// Inverse of the mass matrix (prime), computed once.
    inverse_mass: [[f64; 3]; 3],
    scale: PrimeScale,
}

/// Why a model cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelError {
    #[error("{dof}: {got} coefficients for {expected} terms")]
    CoefficientCount {
        dof: Dof,
        expected: usize,
        got: usize,
    },
    #[error("coefficient {name} is not finite")]
    NonFinite { name: String },
    #[error("the mass matrix is singular (check the added masses)")]
    SingularMass,
    #[error("set: {0}")]
    Set(#[from] SetError),
    #[error("coefficient `{0}` is not a term of the set")]
    UnknownCoefficient(String),
    #[error("coefficient `{0}` is missing")]
    MissingCoefficient(String),
    #[error("[bootstrap]: {0}")]
    Bootstrap(String),
    /// A damaged `[calibration]`, naming the key.
    #[error(transparent)]
    Calibration(#[from] crate::calibration::CalibrationDamage),
}

impl AbkowitzModel {
    pub fn new(
        set: CoefficientSet,
        coefficients: [Vec<f64>; 3],
        ship: Ship,
        added_mass: AddedMass,
    ) -> Result<AbkowitzModel, ModelError> {
        for d in Dof::ALL {
            let (expected, got) = (set.terms[d.index()].len(), coefficients[d.index()].len());
            if expected != got {
                return Err(ModelError::CoefficientCount {
                    dof: d,
                    expected,
                    got,
                });
            }
            for (name, v) in set.names(d).into_iter().zip(&coefficients[d.index()]) {
                if !v.is_finite() {
                    return Err(ModelError::NonFinite { name });
                }
            }
        }
        let inertia = PrimeInertia::new(&ship, &added_mass, &set);
        let inverse_mass = invert3(inertia.mass_matrix()).ok_or(ModelError::SingularMass)?;
        Ok(AbkowitzModel {
            set,
            coefficients,
            ship,
            added_mass,
            inertia,
            inverse_mass,
            scale: PrimeScale::of(&ship),
        })
    }

    /// Hydrodynamic forces f_X, f_Y, f_N (prime) of the polynomial at a primed state.
    pub fn forces_prime(&self, du: f64, v: f64, r: f64, delta: f64) -> [f64; 3] {
        let powers = Powers::new(du, v, r, delta);
        std::array::from_fn(|d| {
            self.set.terms[d]
                .iter()
                .zip(&self.coefficients[d])
                .map(|(m, b)| b * m.eval_powers(&powers))
                .sum()
        })
    }

    /// Accelerations [u̇ m/s², v̇ m/s², ṙ rad/s²] of midship at (u, v [m/s], r [rad/s], δ [rad]).
    pub fn accelerations(&self, u: f64, v: f64, r: f64, delta: f64) -> [f64; 3] {
        let s = &self.scale;
        let (du, vp, rp) = (s.delta_u_prime(u), s.velocity_prime(v), s.yaw_rate_prime(r));
        let f = self.forces_prime(du, vp, rp, delta);
        let c = self.inertia.rigid_body_forces(du, vp, rp);
        let rhs = [f[0] + c[0], f[1] + c[1], f[2] + c[2]];
        let a: [f64; 3] =
            std::array::from_fn(|i| (0..3).map(|j| self.inverse_mass[i][j] * rhs[j]).sum());
        [
            s.acceleration_from_prime(a[0]),
            s.acceleration_from_prime(a[1]),
            s.yaw_acceleration_from_prime(a[2]),
        ]
    }

    /// Number of coefficients over the three DOFs (the length of [`AbkowitzModel::flat_coefficients`]).
    pub fn coefficient_total(&self) -> usize {
        self.coefficients.iter().map(Vec::len).sum()
    }

    /// The coefficients in DOF order (X, then Y, then N, each in the set's term order).
    pub fn flat_coefficients(&self) -> Vec<f64> {
        self.coefficients.concat()
    }

    /// The same model with coefficients `flat` in the order of [`AbkowitzModel::flat_coefficients`].
    pub fn with_flat_coefficients(&self, flat: &[f64]) -> Result<AbkowitzModel, ModelError> {
        let mut rest = flat;
        let coefficients: [Vec<f64>; 3] = std::array::from_fn(|d| {
            let (head, tail) = rest.split_at(self.coefficients[d].len().min(rest.len()));
            rest = tail;
            head.to_vec()
        });
        AbkowitzModel::new(self.set.clone(), coefficients, self.ship, self.added_mass)
    }

    /// [`AbkowitzModel::accelerations`] (the same values to the last bit) with their derivatives:
    /// `d_state[i][k]` = ∂a_i/∂x_k for x = (u \[m/s\], v \[m/s\], r \[rad/s\]), and `d_coefficients[n]` =
    /// ∂a/∂β_n in the order of [`AbkowitzModel::flat_coefficients`] (entries past the model's
    /// coefficients are left alone). The accelerations are linear in the coefficients, so ∂a/∂β is
    /// exact: the inverse mass matrix's column of the coefficient's DOF times its monomial. Sensitivity
    /// replays need both at every RK4 stage, in one pass over the terms.
    pub fn accelerations_and_derivatives(
        &self,
        u: f64,
        v: f64,
        r: f64,
        delta: f64,
        d_state: &mut [[f64; 3]; 3],
        d_coefficients: &mut [[f64; 3]],
    ) -> [f64; 3] {
        let s = &self.scale;
        let (du, vp, rp) = (s.delta_u_prime(u), s.velocity_prime(v), s.yaw_rate_prime(r));
        let powers = Powers::new(du, vp, rp, delta);
        // Primed accelerations → SI, and primed state → SI, for the chain rule.
        let out_scale = [
            s.acceleration_from_prime(1.0),
            s.acceleration_from_prime(1.0),
            s.yaw_acceleration_from_prime(1.0),
        ];
        let in_scale = [1.0 / s.u0_m_s, s.velocity_prime(1.0), s.yaw_rate_prime(1.0)];
        // Column d of the inverse mass matrix in SI accelerations per unit primed force of DOF d.
        let column: [[f64; 3]; 3] = std::array::from_fn(|d| {
            std::array::from_fn(|i| out_scale[i] * self.inverse_mass[i][d])
        });
        let mut f = [0.0; 3];
        let mut df = [[0.0; 3]; 3];
        let mut n = 0;
        for d in 0..3 {
            let mut sum = 0.0;
            for (m, b) in self.set.terms[d].iter().zip(&self.coefficients[d]) {
                let (value, gradient) = m.eval_with_gradient(&powers);
                sum += b * value;
                (0..3).for_each(|k| df[d][k] += b * gradient[k]);
                if let Some(slot) = d_coefficients.get_mut(n) {
                    *slot = std::array::from_fn(|i| column[d][i] * value);
                }
                n += 1;
            }
            f[d] = sum;
        }
        let c = self.inertia.rigid_body_forces(du, vp, rp);
        let dc = self.inertia.rigid_body_force_gradients(du, vp, rp);
        let rhs = [f[0] + c[0], f[1] + c[1], f[2] + c[2]];
        let a: [f64; 3] =
            std::array::from_fn(|i| (0..3).map(|j| self.inverse_mass[i][j] * rhs[j]).sum());
        for (i, row) in d_state.iter_mut().enumerate() {
            for (k, x) in row.iter_mut().enumerate() {
                let primed: f64 = (0..3)
                    .map(|j| self.inverse_mass[i][j] * (df[j][k] + dc[j][k]))
                    .sum();
                *x = out_scale[i] * primed * in_scale[k];
            }
        }
        [
            s.acceleration_from_prime(a[0]),
            s.acceleration_from_prime(a[1]),
            s.yaw_acceleration_from_prime(a[2]),
        ]
    }

    /// Coefficient by name ("Y_vvr"), prime system.
    pub fn coefficient(&self, name: &str) -> Option<f64> {
        Dof::ALL.iter().find_map(|&d| {
            let j = self.set.names(d).iter().position(|n| n == name)?;
            Some(self.coefficients[d.index()][j])
        })
    }
}

fn invert3(m: [[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    if !det.is_finite() || det.abs() < 1e-300 {
        return None;
    }
    let c = |a: usize, b: usize, c: usize, d: usize| m[a][b] * m[c][d] - m[a][d] * m[c][b];
    Some([
        [
            c(1, 1, 2, 2) / det,
            -c(0, 1, 2, 2) / det,
            c(0, 1, 1, 2) / det,
        ],
        [
            -c(1, 0, 2, 2) / det,
            c(0, 0, 2, 2) / det,
            -c(0, 0, 1, 2) / det,
        ],
        [
            c(1, 0, 2, 1) / det,
            -c(0, 0, 2, 1) / det,
            c(0, 0, 1, 1) / det,
        ],
    ])
}

/// How a model's coefficients were obtained.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct EstimatorInfo {
    /// lsq, bounded-lsq, ridge, lasso, svr.
    pub name: String,
    /// qp or fast.
    pub solver: String,
    /// Hyper-parameters used (lambda, alpha, c, epsilon).
    #[serde(default)]
    pub hyper: BTreeMap<String, f64>,
    /// True when the hyper-parameters were chosen by cross-validation.
    #[serde(default)]
    pub tuned: bool,
    /// Set when the estimator's coefficients were then refined in the output-error sense
    /// (`shipid fit --refine`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refinement: Option<Refinement>,
}

/// What an output-error refinement did to the estimator's coefficients.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Refinement {
    pub method: String,
    /// Replay segment length ÷ (L/U0).
    pub horizon_l_over_u0: f64,
    pub iterations: usize,
    /// Segment-replay position RMSE ÷ L on the training windows before and after.
    pub before_position_rmse_over_l: f64,
    pub after_position_rmse_over_l: f64,
    /// Segment-replay heading RMSE [deg] on the training windows before and after.
    pub before_heading_rmse_deg: f64,
    pub after_heading_rmse_deg: f64,
}

/// One training recording and the window of it that was used.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainingWindow {
    /// The data set, relative to the model file that holds this window (absolute when no relative
    /// path exists).
    pub dataset: String,
    /// Fingerprint of the data set file and this window's recording when the model was written
    /// (`fnv1a64:` + 16 hex digits); absent in older model files.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dataset_hash: Option<String>,
    pub recording: String,
    pub t_start_s: f64,
    pub t_end_s: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub overshoots: Option<u32>,
    /// "recorded" or how the accelerations were estimated.
    pub accelerations: String,
}

/// What a training window's `accelerations` says when they were measured; an estimate's text starts
/// with [`ESTIMATED_ACCELERATIONS`].
pub const RECORDED_ACCELERATIONS: &str = "recorded";
/// The start of the `accelerations` of a window whose accelerations were estimated from the motions.
pub const ESTIMATED_ACCELERATIONS: &str = "estimated";

/// The first fault (key, message) of a model file's `[[training]]` windows, keys as
/// `training[i].t_end_s`. Reports, `validate` and the bands' refits read these windows as the fit's
/// data: a reversed window made the range check say "the training windows hold no states", which
/// blamed the data, and an unknown `accelerations` is a statement about the fit no fit made.
pub fn training_fault(training: &[TrainingWindow]) -> Option<(String, String)> {
    for (i, w) in training.iter().enumerate() {
        let key = |field: &str| format!("training[{i}].{field}");
        for (field, v) in [("t_start_s", w.t_start_s), ("t_end_s", w.t_end_s)] {
            if !v.is_finite() {
                return Some((key(field), format!("must be a finite time [s], not {v}")));
            }
        }
        if w.t_end_s <= w.t_start_s {
            return Some((
                key("t_end_s"),
                format!(
                    "{} s is not after t_start_s = {} s: the window of {} holds no sample",
                    w.t_end_s, w.t_start_s, w.recording
                ),
            ));
        }
        let a = w.accelerations.as_str();
        if a != RECORDED_ACCELERATIONS && !a.starts_with(ESTIMATED_ACCELERATIONS) {
            return Some((
                key("accelerations"),
                format!(
                    "\"{a}\" is not how a fit obtains accelerations: \"{RECORDED_ACCELERATIONS}\" or \
                     \"{ESTIMATED_ACCELERATIONS}: …\" (as `shipid fit` writes it)"
                ),
            ));
        }
    }
    None
}

/// A model file (TOML), written by `shipid fit`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelFile {
    pub shipid_version: String,
    pub kind: String,
    pub ship: Ship,
    pub added_mass: AddedMass,
    pub set: SetFile,
    pub estimator: EstimatorInfo,
    #[serde(default)]
    pub training: Vec<TrainingWindow>,
    /// Coefficients per DOF: name → value (prime system I, U0 of the ship, midship, δ + to starboard).
    pub coefficients: BTreeMap<String, BTreeMap<String, f64>>,
    /// Physical effects that are part of the model (found by `shipid diagnose`); every simulation of the
    /// model applies them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub effects: Vec<EffectEntry>,
    /// Block-bootstrap replicates of the coefficients (`shipid fit --bootstrap N`), from which
    /// `simulate --bands` and `validate` draw their bands.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bootstrap: Option<BootstrapRecord>,
    /// What calibrated bands need (`shipid fit --bootstrap N --calibrate`): the pooled ensemble's
    /// replicates per structure and the inflation factor per metric family.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration: Option<crate::calibration::CalibrationRecord>,
    /// The recorded wind and current removed from the training recordings before identification
    /// (absent when they were calm).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub environment: Option<EnvironmentRecord>,
}

/// What a model file records of the environment its training recordings carried (`[environment]`,
/// written by every family): the recorded wind and current were known inputs, removed before the
/// hydrodynamics were identified, so the model is a calm-water model and every simulation of a
/// recording adds that recording's own wind and current back.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvironmentRecord {
    /// True: the recorded environment was subtracted before identification.
    pub removed: bool,
    /// Training recordings with a recorded wind.
    #[serde(default)]
    pub wind_recordings: Vec<String>,
    /// Training recordings with a recorded current.
    #[serde(default)]
    pub current_recordings: Vec<String>,
    /// True when the data set gave no `[windage]` and the windage below was assumed.
    #[serde(default)]
    pub windage_assumed: bool,
    /// The windage the recorded wind's force was computed with (absent without a recorded wind).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub windage: Option<shipid_io::Windage>,
}

/// The coefficient uncertainty of a fit by a moving-block bootstrap, as stored in its model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BootstrapRecord {
    /// How the replicates were drawn and refitted, in words.
    pub method: String,
    /// Seed of the replicate draws (SplitMix64 per replicate).
    pub seed: u64,
    /// Rows per block, and why that length.
    pub block_rows: usize,
    pub block_reason: String,
    /// Replicate refits that did not converge or lost a regressor's information (not stored).
    pub rejected: usize,
    /// Bootstrap standard error per DOF and coefficient (prime system, as `coefficients`).
    pub standard_error: BTreeMap<String, BTreeMap<String, f64>>,
    /// Correlation matrix per DOF, rows and columns in the set's term order.
    pub correlation: BTreeMap<String, Vec<Vec<f64>>>,
    /// Replicate values per DOF and coefficient; entry k of every list belongs to replicate k.
    pub replicates: BTreeMap<String, BTreeMap<String, Vec<f64>>>,
}

impl BootstrapRecord {
    /// The replicates as coefficient vectors in the set's term order, checked against the set.
    pub fn coefficient_vectors(
        &self,
        set: &CoefficientSet,
    ) -> Result<Vec<[Vec<f64>; 3]>, ModelError> {
        crate::calibration::replicate_vectors(&self.replicates, set).map_err(ModelError::Bootstrap)
    }
}

/// A physical effect that is part of a model, with where it came from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EffectEntry {
    /// The effect in the syntax of `shipid generate --effect` (`current:speed=0.05,from_deg=120`; SI
    /// units, directions in degrees clockwise from north, the direction the flow comes from).
    pub effect: String,
    /// Where the parameters come from (e.g. the diagnosis that fitted them, and on which recordings).
    pub source: String,
    /// One-standard-error uncertainty per parameter key, when known.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub standard_error: BTreeMap<String, f64>,
}

/// A model file that is another model plus effects: used when the base is not itself a model file
/// (`base = "mmg:kvlcc2"`), or to keep a base file untouched (`base = "path/to/model.toml"`, relative to
/// this file).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AugmentedModelFile {
    pub shipid_version: String,
    pub base: String,
    /// Fingerprint of the base's model file when this file was written (`fnv1a64:` + 16 hex digits);
    /// absent in older files and for `mmg:` bases.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base_hash: Option<String>,
    pub effects: Vec<EffectEntry>,
}

impl ModelFile {
    /// The file for a model.
    pub fn from_model(
        m: &AbkowitzModel,
        estimator: EstimatorInfo,
        training: Vec<TrainingWindow>,
    ) -> ModelFile {
        let mut coefficients = BTreeMap::new();
        for d in Dof::ALL {
            let per: BTreeMap<String, f64> = m
                .set
                .names(d)
                .into_iter()
                .zip(m.coefficients[d.index()].iter().copied())
                .collect();
            coefficients.insert(d.as_str().to_string(), per);
        }
        ModelFile {
            shipid_version: env!("CARGO_PKG_VERSION").to_string(),
            kind: "abkowitz".into(),
            ship: m.ship,
            added_mass: m.added_mass,
            set: m.set.file.clone(),
            estimator,
            training,
            coefficients,
            effects: Vec::new(),
            bootstrap: None,
            calibration: None,
            environment: None,
        }
    }

    /// Rebuild the model; every coefficient of the set must be present and nothing else.
    pub fn to_model(&self) -> Result<AbkowitzModel, ModelError> {
        let set = CoefficientSet::from_file(self.set.clone())?;
        let mut coefficients: [Vec<f64>; 3] = Default::default();
        for d in Dof::ALL {
            let given = self
                .coefficients
                .get(d.as_str())
                .cloned()
                .unwrap_or_default();
            let names = set.names(d);
            for name in given.keys() {
                if !names.contains(name) {
                    return Err(ModelError::UnknownCoefficient(name.clone()));
                }
            }
            for name in names {
                let v = *given
                    .get(&name)
                    .ok_or_else(|| ModelError::MissingCoefficient(name.clone()))?;
                coefficients[d.index()].push(v);
            }
        }
        AbkowitzModel::new(set, coefficients, self.ship, self.added_mass)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn window(t_start_s: f64, t_end_s: f64, accelerations: &str) -> TrainingWindow {
        TrainingWindow {
            dataset: "dataset.toml".into(),
            dataset_hash: None,
            recording: "zz10_10_ps.csv".into(),
            t_start_s,
            t_end_s,
            overshoots: None,
            accelerations: accelerations.into(),
        }
    }

    /// Regression: `t_end_s = -5` (before its start), a NaN time and `accelerations = "telepathy"`
    /// were read; each is refused naming its window's key, and what `fit` writes is read.
    #[test]
    fn a_training_window_that_no_fit_writes_is_refused_naming_its_key() {
        let estimated = "estimated: local cubic least squares (Savitzky–Golay), window 0.100 L/U0";
        let good = [
            window(0.0, 420.6, "recorded"),
            window(5.0, 480.0, estimated),
        ];
        assert_eq!(training_fault(&good), None);
        let key = |w: TrainingWindow| {
            let mut all = good.to_vec();
            all.push(w);
            training_fault(&all).map(|(k, _)| k)
        };
        assert_eq!(
            key(window(0.0, -5.0, "recorded")).as_deref(),
            Some("training[2].t_end_s")
        );
        assert_eq!(
            key(window(3.0, 3.0, "recorded")).as_deref(),
            Some("training[2].t_end_s")
        );
        assert_eq!(
            key(window(f64::NAN, 3.0, "recorded")).as_deref(),
            Some("training[2].t_start_s")
        );
        assert_eq!(
            key(window(0.0, 3.0, "telepathy")).as_deref(),
            Some("training[2].accelerations")
        );
    }
}
