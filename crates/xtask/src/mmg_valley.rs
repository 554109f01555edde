//! The output-error refinement's valley on a data set (docs/mmg.md, "The refinement's valley"): the
//! mmg fit at every prior weight of the cross-validation grid, each refined on all the data set's
//! recordings, scored on one common objective (the refinement's, normalised at the start of the
//! default prior weight's fit), with the training replay errors and the 35° turns each predicts.
//! Refinements that end on about the same objective but predict different turns are what the
//! recordings cannot decide. `cargo xtask mmg-valley [DATASET]` prints a Markdown table.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result};
use rayon::prelude::*;
use shipid_io::{Dataset, Manoeuvre, Recording, Side};
use shipid_pipeline::mmg::{
    CV_GRID, DEFAULT_PRIOR_WEIGHT, MmgFitOptions, MmgGeometry, ParametricMmg, PriorWeight, fit_mmg,
    refine_mmg,
};
use shipid_pipeline::refine::{RefineOptions, refinement_costs};
use shipid_pipeline::simulate::simulate_manoeuvre;
use shipid_sim::{Dynamics, SimStatus, metrics};

/// Simulated time of each turn [s ÷ (L/U0)]: long enough for the steady diameter.
const TURN_DURATION_L_OVER_U0: f64 = 200.0;

pub fn run(dataset: &Path) -> Result<String> {
    let ds = Dataset::load(dataset).with_context(|| dataset.display().to_string())?;
    let geometry = MmgGeometry::of_dataset(&ds)?;
    let added = ds.added_mass.context("the data set has no [added_mass]")?;
    let recordings: Vec<Recording> = ds.recordings.iter().map(|r| r.recording.clone()).collect();
    let refine = RefineOptions::for_dataset(&ds);
    let fitted: Vec<_> = CV_GRID
        .par_iter()
        .map(|&lambda| -> Result<_> {
            let opts = MmgFitOptions {
                prior_weight: PriorWeight::Fixed(lambda),
                ..MmgFitOptions::default()
            };
            let fit = fit_mmg(&ds, &geometry, &opts)?;
            let (refined, how) = refine_mmg(&fit, added, &recordings, &refine)?;
            Ok((lambda, fit, refined, how))
        })
        .collect::<Result<_>>()?;
    let reference = fitted
        .iter()
        .find(|f| f.0 == DEFAULT_PRIOR_WEIGHT)
        .map(|f| ParametricMmg::of_fit(&f.1, added))
        .context("the default prior weight is not on the grid")?;
    let duration_s = TURN_DURATION_L_OVER_U0 * ds.ship.lpp / ds.ship.u0;
    let mut md = format!(
        "mmg refinements of {} from the prior weights of the cross-validation grid; objective: the \
         refinement's, normalised at the start λ = {DEFAULT_PRIOR_WEIGHT:e}; turns ÷ L, port / starboard\n\n\
         | λ of the start | objective | replay position RMSE [L] | heading RMSE [°] | iterations | tactical diameter | steady diameter |\n\
         |---|---|---|---|---|---|---|\n",
        dataset.display()
    );
    let candidates: Vec<ParametricMmg> = fitted
        .iter()
        .map(|(_, _, refined, _)| ParametricMmg::of_fit(refined, added))
        .collect();
    let costs = refinement_costs(
        &reference,
        &candidates.iter().collect::<Vec<_>>(),
        &recordings,
        &refine,
    )?;
    for ((lambda, _, refined, how), cost) in fitted.iter().zip(costs) {
        let turn = |side| -> String {
            let m = Manoeuvre::Turning {
                rudder_deg: 35.0,
                side,
            };
            match simulate_manoeuvre(&refined.model, &m, None, Some(duration_s)) {
                Ok(out) if matches!(out.status, SimStatus::Ok) => {
                    let k = metrics(&out.recording, &m, refined.model.ship());
                    let f = |x: Option<f64>| x.map_or("–".into(), |v| format!("{v:.2}"));
                    format!("{}|{}", f(k.tactical_diameter), f(k.steady_diameter))
                }
                _ => "diverged|diverged".into(),
            }
        };
        let (port, starboard) = (turn(Side::Port), turn(Side::Starboard));
        let (p, s): (Vec<&str>, Vec<&str>) =
            (port.split('|').collect(), starboard.split('|').collect());
        writeln!(
            md,
            "| {lambda:e} | {cost:.4} | {:.4} | {:.3} | {} | {} / {} | {} / {} |",
            how.after_position_rmse_over_l,
            how.after_heading_rmse_deg,
            how.iterations,
            p[0],
            s[0],
            p[1],
            s[1]
        )?;
    }
    Ok(md)
}
