//! How far each parameter moves when one training recording leaves the fit: the delete-one-recording
//! jackknife. The information matrix's standard errors count every sample as independent; the
//! samples of one recording share its misfit (its own tank run, its own departure from the
//! structure), so when the recordings disagree about a parameter the information matrix still calls
//! it determined. On the 13 HSVA zig-zags it called X′_vv ± 0.016 while the refits without one run
//! spread it ± 0.081, and the three largest runs out moved X′_vr by several of its standard errors
//! (docs/mmg.md, "Identifiability").

use rayon::prelude::*;
use shipid_io::Dataset;

use super::{MmgFit, MmgFitOptions, refit_problem};
use crate::PipelineError;

/// Fewer training recordings leave too little to compare: each refit would lose half the data.
pub const JACKKNIFE_MIN_RECORDINGS: usize = 3;

/// At most this many refits: more training recordings are dealt round-robin into this many groups,
/// each refit leaving one group out (the grouped jackknife), so that a data set of hundreds of short
/// recordings costs 20 refits, not hundreds.
pub const JACKKNIFE_MAX_GROUPS: usize = 20;

/// The refits of a fit with each training recording left out in turn.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordingJackknife {
    /// Refits that failed, each named by what it left out, with the reason; the standard errors are
    /// over the others.
    pub failed: Vec<String>,
    /// Per parameter (the fit's order), √((g − 1)/g Σ (θ₋ᵢ − θ̄)²) over the g refits.
    pub standard_errors: Vec<f64>,
    /// Each refit that succeeded: the training windows it left out, by their recordings' file names
    /// (one each up to [`JACKKNIFE_MAX_GROUPS`] recordings, `a.csv + b.csv + …` beyond), and its
    /// parameters (the fit's order).
    pub refits: Vec<(String, Vec<f64>)>,
}

/// The delete-one-recording jackknife of `fit` on its training samples (`opts`, as the fit was made),
/// with its priors and prior weight; `None` with fewer than [`JACKKNIFE_MIN_RECORDINGS`] training
/// windows or fewer than that many refits that succeed. `fit` is the equation-error estimate (before
/// any refinement, as its standard errors are): each refit starts from it.
pub fn recording_jackknife(
    ds: &Dataset,
    fit: &MmgFit,
    opts: &MmgFitOptions,
) -> Result<Option<RecordingJackknife>, PipelineError> {
    if fit.windows.len() < JACKKNIFE_MIN_RECORDINGS {
        return Ok(None);
    }
    let (problem, phi_hat) = refit_problem(ds, fit, opts)?;
    let all: Vec<usize> = (0..problem.samples.len()).collect();
    let groups = group_count(fit.windows.len());
    let refits: Vec<Result<Vec<f64>, String>> = (0..groups)
        .into_par_iter()
        .map(|g| {
            let kept: Vec<usize> = all
                .iter()
                .copied()
                .filter(|&i| problem.samples[i].group % groups != g)
                .collect();
            let (phi, beta, _) = problem
                .solve(&phi_hat, &kept, fit.lambda)
                .map_err(|e| e.to_string())?;
            let theta = problem.theta_of(&phi, &beta);
            match theta.iter().all(|v| v.is_finite()) {
                true => Ok(theta),
                false => Err("a parameter is not finite".into()),
            }
        })
        .collect();
    let left_out: Vec<String> = (0..groups)
        .map(|g| {
            fit.windows
                .iter()
                .skip(g)
                .step_by(groups)
                .map(|w| w.recording.as_str())
                .collect::<Vec<_>>()
                .join(" + ")
        })
        .collect();
    let (mut kept, mut failed) = (Vec::new(), Vec::new());
    for (refit, name) in refits.into_iter().zip(left_out) {
        match refit {
            Ok(theta) => kept.push((name, theta)),
            Err(why) => failed.push(format!("{name}: {why}")),
        }
    }
    let thetas: Vec<&[f64]> = kept.iter().map(|(_, theta)| theta.as_slice()).collect();
    let Some(standard_errors) = jackknife_standard_errors(&thetas) else {
        return Ok(None);
    };
    Ok(Some(RecordingJackknife {
        failed,
        standard_errors,
        refits: kept,
    }))
}

/// How many refits a jackknife over `windows` training windows makes; window k is in group
/// k mod that count.
pub fn group_count(windows: usize) -> usize {
    windows.min(JACKKNIFE_MAX_GROUPS)
}

/// √((g − 1)/g Σ (θᵢ − θ̄)²) per component over the g leave-one-out estimates; `None` for fewer than
/// [`JACKKNIFE_MIN_RECORDINGS`].
pub fn jackknife_standard_errors(thetas: &[&[f64]]) -> Option<Vec<f64>> {
    let g = thetas.len();
    if g < JACKKNIFE_MIN_RECORDINGS {
        return None;
    }
    let width = thetas[0].len();
    Some(
        (0..width)
            .map(|k| {
                let mean = thetas.iter().map(|t| t[k]).sum::<f64>() / g as f64;
                let ss: f64 = thetas.iter().map(|t| (t[k] - mean).powi(2)).sum();
                ((g as f64 - 1.0) / g as f64 * ss).sqrt()
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn many_recordings_are_grouped_into_at_most_twenty_refits() {
        assert_eq!(group_count(3), 3);
        assert_eq!(group_count(13), 13);
        assert_eq!(group_count(20), 20);
        assert_eq!(group_count(500), JACKKNIFE_MAX_GROUPS);
    }

    #[test]
    fn the_jackknife_of_a_mean_is_its_standard_error() {
        // Leave-one-out means of x = [1, 2, 3, 4]: the jackknife gives sd(x)/√n exactly.
        let x = [1.0, 2.0, 3.0, 4.0];
        let sum: f64 = x.iter().sum();
        let loo: Vec<Vec<f64>> = x.iter().map(|v| vec![(sum - v) / 3.0]).collect();
        let refs: Vec<&[f64]> = loo.iter().map(Vec::as_slice).collect();
        let se = jackknife_standard_errors(&refs).unwrap()[0];
        let sd = (x.iter().map(|v| (v - 2.5f64).powi(2)).sum::<f64>() / 3.0).sqrt();
        assert!((se - sd / 2.0).abs() < 1e-12, "{se} vs {}", sd / 2.0);
        assert_eq!(jackknife_standard_errors(&refs[..2]), None);
    }
}
