//! Gaussian-process regression for shipid (paper 001: Chen, Wang & Xue 2021): pure computation, no I/O.
//!
//! - [`points`]: a row-major set of input points.
//! - [`sparsify`]: the similarity walk of paper 001 Tab. 1 that keeps a small, evenly spread subset.
//! - [`gp`]: GP regression with the squared-exponential ARD kernel; hyper-parameters by maximising the log
//!   marginal likelihood with analytic gradients; Cholesky-based prediction with variance (faer).
//! - [`lbfgs`]: the quasi-Newton minimiser used for the hyper-parameters.
//! - [`draw`]: functions drawn from the posterior, consistent over a trajectory (for bands).
//!
//! ```
//! use shipid_gp::{Gp, Points, Similarity, TrainOptions, sparsify};
//!
//! // y = sin(x) on 201 points; keep the points at least ~0.2 apart, then learn.
//! let xs: Vec<f64> = (0..=200).map(|i| i as f64 * 0.03).collect();
//! let x = Points::new(1, xs.clone())?;
//! let keep = sparsify(&x, &Similarity { scales: vec![1.0], threshold: (-0.04f64).exp() })?;
//! let y: Vec<f64> = keep.iter().map(|&i| xs[i].sin()).collect();
//! let (gp, _) = Gp::train(x.select(&keep), y, &TrainOptions::default())?;
//! assert!((gp.predict_mean(&[1.0]) - 1.0f64.sin()).abs() < 1e-3);
//! # Ok::<(), shipid_gp::GpError>(())
//! ```

pub mod draw;
pub mod error;
pub mod gp;
pub mod lbfgs;
pub mod points;
pub mod sparsify;

pub use draw::{PosteriorDraw, PosteriorSampler};
pub use error::GpError;
pub use gp::{Gp, Hyper, JITTER, TrainOptions, Training, log_marginal_likelihood};
pub use lbfgs::{LbfgsOptions, Minimum, Termination, minimize};
pub use points::Points;
pub use sparsify::{Similarity, half_ranges, sparsify};
