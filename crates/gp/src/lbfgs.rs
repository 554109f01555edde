//! Limited-memory BFGS (Nocedal & Wright 2006, Alg. 7.4 and 7.5) with a backtracking Armijo line search.
//!
//! Written here because the GP needs a small unconstrained quasi-Newton minimiser over a handful of
//! log-hyper-parameters and the workspace has no optimisation crate; it is tested on the Rosenbrock
//! function and on quadratics (tests below). The curvature pair of a step is kept only when
//! sᵀy > 0, so the two-loop recursion always gives a descent direction; an objective that cannot be
//! evaluated at a trial point (`None`, e.g. a failed Cholesky) is treated as +∞ and the step is shortened.

/// Why the minimiser stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Termination {
    /// ‖∇f‖∞ fell below the gradient tolerance.
    Gradient,
    /// The relative decrease of f over an iteration fell below the function tolerance.
    Stalled,
    /// No step along the search direction decreased f (at a minimum to machine precision).
    LineSearch,
    /// The iteration limit was reached.
    MaxIterations,
    /// f or ∇f could not be evaluated at the starting point.
    BadStart,
}

/// Options of [`minimize`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LbfgsOptions {
    pub max_iterations: usize,
    /// Number of curvature pairs kept.
    pub memory: usize,
    /// Stop when ‖∇f‖∞ ≤ this.
    pub gradient_tolerance: f64,
    /// Stop when (f_k − f_{k+1}) ≤ this · max(|f_k|, 1).
    pub function_tolerance: f64,
}

impl Default for LbfgsOptions {
    fn default() -> Self {
        LbfgsOptions {
            max_iterations: 200,
            memory: 8,
            gradient_tolerance: 1e-6,
            function_tolerance: 1e-10,
        }
    }
}

/// Result of [`minimize`].
#[derive(Debug, Clone, PartialEq)]
pub struct Minimum {
    pub x: Vec<f64>,
    pub f: f64,
    pub gradient: Vec<f64>,
    pub iterations: usize,
    pub evaluations: usize,
    pub termination: Termination,
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Minimise `f` from `x0`. `f(x)` returns the value and gradient, or `None` where it is undefined.
pub fn minimize<F>(mut f: F, x0: &[f64], opts: &LbfgsOptions) -> Minimum
where
    F: FnMut(&[f64]) -> Option<(f64, Vec<f64>)>,
{
    let mut x = x0.to_vec();
    let mut evaluations = 1;
    let Some((mut fx, mut g)) =
        f(&x).filter(|(v, g)| v.is_finite() && g.iter().all(|d| d.is_finite()))
    else {
        return Minimum {
            x,
            f: f64::NAN,
            gradient: vec![f64::NAN; x0.len()],
            iterations: 0,
            evaluations,
            termination: Termination::BadStart,
        };
    };
    let mut s_hist: Vec<Vec<f64>> = Vec::new();
    let mut y_hist: Vec<Vec<f64>> = Vec::new();
    let mut iterations = 0;
    let termination = loop {
        if g.iter().fold(0.0f64, |m, v| m.max(v.abs())) <= opts.gradient_tolerance {
            break Termination::Gradient;
        }
        if iterations >= opts.max_iterations {
            break Termination::MaxIterations;
        }
        iterations += 1;
        // Two-loop recursion: d = −H g.
        let mut q = g.clone();
        let mut alphas = vec![0.0; s_hist.len()];
        for k in (0..s_hist.len()).rev() {
            let rho = 1.0 / dot(&y_hist[k], &s_hist[k]);
            alphas[k] = rho * dot(&s_hist[k], &q);
            for (qi, yi) in q.iter_mut().zip(&y_hist[k]) {
                *qi -= alphas[k] * yi;
            }
        }
        let gamma = match (s_hist.last(), y_hist.last()) {
            (Some(s), Some(y)) => dot(s, y) / dot(y, y),
            // First step: unit length along −g, so that a badly scaled gradient cannot jump far.
            _ => 1.0 / g.iter().map(|v| v * v).sum::<f64>().sqrt().max(1e-300),
        };
        for qi in &mut q {
            *qi *= gamma;
        }
        for k in 0..s_hist.len() {
            let rho = 1.0 / dot(&y_hist[k], &s_hist[k]);
            let beta = rho * dot(&y_hist[k], &q);
            for (qi, si) in q.iter_mut().zip(&s_hist[k]) {
                *qi += (alphas[k] - beta) * si;
            }
        }
        let mut d: Vec<f64> = q.iter().map(|v| -v).collect();
        let mut slope = dot(&g, &d);
        if slope >= 0.0 {
            // Lost descent (rounding): restart from steepest descent.
            s_hist.clear();
            y_hist.clear();
            let norm = g.iter().map(|v| v * v).sum::<f64>().sqrt().max(1e-300);
            d = g.iter().map(|v| -v / norm).collect();
            slope = dot(&g, &d);
        }
        // Backtracking Armijo search, c1 = 1e-4, halving.
        let mut step = 1.0;
        let mut accepted = None;
        for _ in 0..50 {
            let trial: Vec<f64> = x.iter().zip(&d).map(|(xi, di)| xi + step * di).collect();
            evaluations += 1;
            if let Some((ft, gt)) = f(&trial)
                && ft.is_finite()
                && gt.iter().all(|v| v.is_finite())
                && ft <= fx + 1e-4 * step * slope
            {
                accepted = Some((trial, ft, gt));
                break;
            }
            step *= 0.5;
        }
        let Some((x_new, f_new, g_new)) = accepted else {
            break Termination::LineSearch;
        };
        let s: Vec<f64> = x_new.iter().zip(&x).map(|(a, b)| a - b).collect();
        let y: Vec<f64> = g_new.iter().zip(&g).map(|(a, b)| a - b).collect();
        let decrease = fx - f_new;
        x = x_new;
        g = g_new;
        let f_old = fx;
        fx = f_new;
        if dot(&s, &y) > 1e-12 * dot(&y, &y).sqrt() * dot(&s, &s).sqrt() {
            s_hist.push(s);
            y_hist.push(y);
            if s_hist.len() > opts.memory {
                s_hist.remove(0);
                y_hist.remove(0);
            }
        }
        if decrease <= opts.function_tolerance * f_old.abs().max(1.0) {
            break Termination::Stalled;
        }
    };
    Minimum {
        x,
        f: fx,
        gradient: g,
        iterations,
        evaluations,
        termination,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rosenbrock(x: &[f64]) -> Option<(f64, Vec<f64>)> {
        let (a, b) = (x[0], x[1]);
        let f = (1.0 - a).powi(2) + 100.0 * (b - a * a).powi(2);
        let g = vec![
            -2.0 * (1.0 - a) - 400.0 * a * (b - a * a),
            200.0 * (b - a * a),
        ];
        Some((f, g))
    }

    #[test]
    fn finds_the_rosenbrock_minimum() {
        let m = minimize(rosenbrock, &[-1.2, 1.0], &LbfgsOptions::default());
        assert!(
            (m.x[0] - 1.0).abs() < 1e-5 && (m.x[1] - 1.0).abs() < 1e-5,
            "{m:?}"
        );
        assert!(m.f < 1e-10);
    }

    #[test]
    fn solves_an_ill_scaled_quadratic() {
        // f = ½ Σ cᵢ (xᵢ − i)², condition number 1e6.
        let c = [1e-3, 1.0, 1e3];
        let f = |x: &[f64]| {
            let v = (0..3).map(|i| 0.5 * c[i] * (x[i] - i as f64).powi(2)).sum();
            Some((v, (0..3).map(|i| c[i] * (x[i] - i as f64)).collect()))
        };
        let opts = LbfgsOptions {
            gradient_tolerance: 1e-10,
            // f reaches 1e-10 long before x is converged: stop on the gradient only.
            function_tolerance: 0.0,
            ..LbfgsOptions::default()
        };
        let m = minimize(f, &[5.0, 5.0, 5.0], &opts);
        for i in 0..3 {
            assert!((m.x[i] - i as f64).abs() < 1e-5, "{m:?}");
        }
    }

    #[test]
    fn undefined_regions_shorten_the_step() {
        // f = (x − 2)² defined only for x < 2.5: the first trial steps beyond it must be rejected.
        let f = |x: &[f64]| (x[0] < 2.5).then(|| ((x[0] - 2.0).powi(2), vec![2.0 * (x[0] - 2.0)]));
        let m = minimize(f, &[-10.0], &LbfgsOptions::default());
        assert!((m.x[0] - 2.0).abs() < 1e-6, "{m:?}");
    }

    #[test]
    fn a_start_outside_the_domain_is_reported() {
        let m = minimize(|_: &[f64]| None, &[0.0], &LbfgsOptions::default());
        assert_eq!(m.termination, Termination::BadStart);
    }
}
