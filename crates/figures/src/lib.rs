//! SVG figures (`plotters`): a study run's trajectories, headings, coefficient convergence, coefficient
//! and VIF bars and force contributions (`study`); a diagnosis's segment-replay tracks and residuals
//! (`diagnosis`); paper 003's variation modes and motions (`inverse`). Each figure that cannot be drawn
//! is a warning for the caller, never a failed run.

pub mod diagnosis;
pub mod error;
pub mod inverse;
pub mod study;

pub use error::FigureError;
pub use study::{FigureReport, write_figures};
