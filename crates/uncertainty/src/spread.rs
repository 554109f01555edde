//! Spread of replicated coefficient vectors.

use serde::Serialize;

use crate::UncertaintyError;

/// Standard errors and correlations of coefficients over bootstrap replicates.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Spread {
    /// Mean over the replicates, per coefficient.
    pub mean: Vec<f64>,
    /// Standard deviation over the replicates (the bootstrap standard error), per coefficient.
    pub std_error: Vec<f64>,
    /// Correlation matrix (row-major, k × k); 0 where a coefficient does not vary.
    pub correlation: Vec<Vec<f64>>,
}

/// The spread of `replicates` (each a coefficient vector of the same length; at least two).
pub fn spread(replicates: &[Vec<f64>]) -> Result<Spread, UncertaintyError> {
    let Some(first) = replicates.first() else {
        return Err(UncertaintyError::TooFewReplicates {
            finite: 0,
            total: 0,
            needed: 2,
        });
    };
    let k = first.len();
    if let Some(bad) = replicates.iter().find(|r| r.len() != k) {
        return Err(UncertaintyError::Ragged(k, bad.len()));
    }
    let n = replicates.len();
    if n < 2 {
        return Err(UncertaintyError::TooFewReplicates {
            finite: n,
            total: n,
            needed: 2,
        });
    }
    let mean: Vec<f64> = (0..k)
        .map(|j| replicates.iter().map(|r| r[j]).sum::<f64>() / n as f64)
        .collect();
    let mut cov = vec![vec![0.0; k]; k];
    for r in replicates {
        for i in 0..k {
            let di = r[i] - mean[i];
            for j in i..k {
                cov[i][j] += di * (r[j] - mean[j]);
            }
        }
    }
    let dof = (n - 1) as f64;
    // Fill the lower triangle from the upper one: each (i, j) is written twice, so index loops.
    #[allow(clippy::needless_range_loop)]
    for i in 0..k {
        for j in i..k {
            let c = cov[i][j] / dof;
            cov[i][j] = c;
            cov[j][i] = c;
        }
    }
    let std_error: Vec<f64> = (0..k).map(|i| cov[i][i].sqrt()).collect();
    let correlation = (0..k)
        .map(|i| {
            (0..k)
                .map(|j| {
                    let d = std_error[i] * std_error[j];
                    if d > 0.0 { cov[i][j] / d } else { 0.0 }
                })
                .collect()
        })
        .collect();
    Ok(Spread {
        mean,
        std_error,
        correlation,
    })
}
