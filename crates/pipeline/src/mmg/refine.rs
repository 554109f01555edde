//! Output-error refinement of an identified MMG model (`fit --set mmg --refine`): the generic
//! refinement of [`crate::refine`] over the 31 identified parameters, within their physical bounds.

use shipid_io::{AddedMass, Recording, Ship};
use shipid_model::Refinement;
use shipid_sim::dynamics::Parametric;
use shipid_sim::{Dynamics, DynamicsError, Input, MmgModel, State};

use super::MmgFit;
use super::geometry::MmgGeometry;
use super::identify::assemble;
use super::priors::ParamSpec;
use crate::error::{PipelineError, bad_input};
use crate::refine::{RefineOptions, refine};

/// An MMG model with its identified parameters as the vector θ of [`Parametric`] (the known ship,
/// added masses, propeller, rudder and propeller rate stay fixed).
#[derive(Debug, Clone)]
pub struct ParametricMmg {
    model: MmgModel,
    added: AddedMass,
    geometry: MmgGeometry,
    rate_hz: f64,
    names: Vec<&'static str>,
    theta: Vec<f64>,
    bounds: Vec<(f64, f64)>,
}

impl ParametricMmg {
    /// The parameterised model of a fit.
    pub fn of_fit(fit: &MmgFit, added: AddedMass) -> ParametricMmg {
        let params = &fit.estimate.params;
        let specs: Vec<&ParamSpec> = params.iter().map(|p| &p.spec).collect();
        let theta: Vec<f64> = params.iter().map(|p| p.value).collect();
        ParametricMmg::new(
            fit.model.clone(),
            added,
            fit.geometry,
            fit.propeller_rate_hz,
            &specs,
            &theta,
        )
    }

    /// The parameterised `model` whose identified parameters `specs` have the values `theta`.
    pub fn new(
        model: MmgModel,
        added: AddedMass,
        geometry: MmgGeometry,
        rate_hz: f64,
        specs: &[&ParamSpec],
        theta: &[f64],
    ) -> ParametricMmg {
        ParametricMmg {
            model,
            added,
            geometry,
            rate_hz,
            names: specs.iter().map(|p| p.name).collect(),
            theta: theta.to_vec(),
            bounds: specs.iter().map(|p| (p.lower, p.upper)).collect(),
        }
    }

    /// The MMG model.
    pub fn model(&self) -> &MmgModel {
        &self.model
    }
}

impl Dynamics for ParametricMmg {
    fn accelerations_for(&self, state: &State, input: &Input) -> Result<[f64; 3], DynamicsError> {
        self.model.accelerations_for(state, input)
    }
    fn wrapped(&self) -> Option<&dyn Dynamics> {
        Some(&self.model)
    }
    fn ship(&self) -> &Ship {
        self.model.ship()
    }
    fn added_mass(&self) -> &AddedMass {
        self.model.added_mass()
    }
}

impl Parametric for ParametricMmg {
    fn parameters(&self) -> Vec<f64> {
        self.theta.clone()
    }

    fn with_parameters(&self, theta: &[f64]) -> Option<Self> {
        if theta.len() != self.theta.len() {
            return None;
        }
        let get = |name: &str| {
            self.names
                .iter()
                .position(|n| *n == name)
                .map_or(f64::NAN, |k| theta[k])
        };
        let ship = *self.model.ship();
        let params = assemble(&ship, &self.added, &self.geometry, &get);
        let model = MmgModel::at_rate(ship, params, self.rate_hz).ok()?;
        Some(ParametricMmg {
            model,
            theta: theta.to_vec(),
            ..self.clone()
        })
    }

    fn parameter_bounds(&self) -> Vec<(f64, f64)> {
        self.bounds.clone()
    }
}

/// Refine `fit` on its training windows `recordings` in the output-error sense. The parameters'
/// values change; their standard errors and data shares stay those of the equation-error estimate.
pub fn refine_mmg(
    fit: &MmgFit,
    added: AddedMass,
    recordings: &[Recording],
    opts: &RefineOptions,
) -> Result<(MmgFit, Refinement), PipelineError> {
    let start = ParametricMmg::of_fit(fit, added);
    let refined =
        refine(&start, recordings, opts).map_err(|e| bad_input(format!("--refine: {e}")))?;
    let mut out = MmgFit {
        model: refined.model.model.clone(),
        estimate: fit.estimate.clone(),
        geometry: fit.geometry,
        lambda: fit.lambda,
        estimator: fit.estimator,
        cv: fit.cv.clone(),
        cv_folds_refined: fit.cv_folds_refined,
        windows: fit.windows.clone(),
        propeller_rate_hz: fit.propeller_rate_hz,
        samples: fit.samples,
        samples_available: fit.samples_available,
        fit_time_s: fit.fit_time_s,
        inflow: fit.inflow.clone(),
    };
    for (p, v) in out.estimate.params.iter_mut().zip(&refined.model.theta) {
        p.value = *v;
        p.at_bound = !p.spec.is_held() && (*v <= p.spec.lower || *v >= p.spec.upper);
    }
    Ok((out, refined.refinement))
}
