//! The refinement's valley (`fit --set mmg --refine`, docs/mmg.md "The refinement's valley"): the
//! fit at every other prior weight of the cross-validation grid, each refined on the same training
//! windows, and its cost on the delivered model's refinement objective. Refinements that end about
//! as low as the delivered one are models the recordings cannot tell apart; where they predict a
//! manoeuvre differently (a turn extrapolated from zig-zags), the spread of their predictions is a
//! part of the uncertainty that a bootstrap around one minimum does not see. No I/O.

use std::collections::BTreeMap;

use rayon::prelude::*;
use shipid_io::{AddedMass, Dataset, Recording};

use super::refine::{ParametricMmg, refine_mmg};
use super::{CV_GRID, MmgFit, MmgFitOptions, PriorWeight, fit_mmg_dataset};
use crate::error::PipelineError;
use crate::refine::{RefineOptions, refinement_costs};

/// A start belongs to the valley when its refinement ends at most this fraction above the delivered
/// model's cost. The refinement stops on a relative decrease before flat directions have converged,
/// so the cost does not rank minima finely: on the default data (ZZ35/35 … TC35, all six recordings)
/// starts that predict both 35° turns identically to 1e-4 L end 3–11 % apart; on the 13 HSVA
/// zig-zags the starts end within 4 % and predict the 35° turn 3.4–3.7 L tactical. A start that ends
/// well above (a different, worse minimum) is reported and left out.
pub const VALLEY_COST_TOLERANCE: f64 = 0.2;

/// How one start of the valley ended.
#[derive(Debug, Clone)]
pub enum ValleyOutcome {
    /// Refined: its cost ÷ the delivered model's on the delivered model's refinement objective, and
    /// the refined parameters by model-file name.
    Refined {
        cost_ratio: f64,
        values: BTreeMap<String, f64>,
    },
    /// Its fit or refinement failed (why).
    Failed(String),
}

/// One start of the valley: the prior weight of its equation-error fit and how its refinement ended.
#[derive(Debug, Clone)]
pub struct ValleyStart {
    pub prior_weight: f64,
    pub outcome: ValleyOutcome,
}

impl ValleyStart {
    /// Whether it ended within [`VALLEY_COST_TOLERANCE`] of the delivered model's cost.
    pub fn in_valley(&self) -> bool {
        matches!(self.outcome, ValleyOutcome::Refined { cost_ratio, .. }
            if cost_ratio <= 1.0 + VALLEY_COST_TOLERANCE)
    }
}

/// The other starts of `delivered` (the refinement of `start`, which `opts` fitted): the fit of `ds`
/// at every prior weight of [`CV_GRID`] other than `start`'s, refined like it on `recordings`, each
/// scored on the delivered refinement's objective. In grid order; a start that fails is an outcome,
/// not an error.
pub fn refine_valley(
    ds: &Dataset,
    opts: &MmgFitOptions,
    start: &MmgFit,
    delivered: &MmgFit,
    added: AddedMass,
    recordings: &[Recording],
    refine: &RefineOptions,
) -> Result<Vec<ValleyStart>, PipelineError> {
    let others: Vec<f64> = CV_GRID
        .iter()
        .copied()
        .filter(|&l| l != start.lambda)
        .collect();
    let refined: Vec<Result<MmgFit, PipelineError>> = others
        .par_iter()
        .map(|&lambda| {
            let opts = MmgFitOptions {
                prior_weight: PriorWeight::Fixed(lambda),
                refine_folds: None,
                ..opts.clone()
            };
            fit_mmg_dataset(ds, &opts)
                .and_then(|fit| refine_mmg(&fit, added, recordings, refine))
                .map(|(fit, _)| fit)
        })
        .collect();
    // Every cost on the delivered refinement's problem, built once: the delivered model first.
    let models: Vec<ParametricMmg> = std::iter::once(delivered)
        .chain(refined.iter().filter_map(|r| r.as_ref().ok()))
        .map(|fit| ParametricMmg::of_fit(fit, added))
        .collect();
    let candidates: Vec<&ParametricMmg> = models.iter().collect();
    let costs = refinement_costs(
        &ParametricMmg::of_fit(start, added),
        &candidates,
        recordings,
        refine,
    )
    .map_err(|e| crate::error::bad_input(format!("--refine: {e}")))?;
    let delivered_cost = costs[0].max(f64::MIN_POSITIVE);
    let mut member_costs = costs[1..].iter();
    Ok(others
        .into_iter()
        .zip(refined)
        .map(|(lambda, fit)| ValleyStart {
            prior_weight: lambda,
            outcome: match fit {
                Ok(fit) => ValleyOutcome::Refined {
                    cost_ratio: member_costs.next().copied().unwrap_or(f64::NAN) / delivered_cost,
                    values: fit
                        .estimate
                        .params
                        .iter()
                        .map(|p| (p.spec.name.to_string(), p.value))
                        .collect(),
                },
                Err(e) => ValleyOutcome::Failed(e.to_string()),
            },
        })
        .collect())
}
