//! SVG figures (`plotters`): a study run's trajectories, headings, coefficient convergence, coefficient
//! and VIF bars and force contributions (`study`); a diagnosis's segment-replay tracks and residuals
//! (`diagnosis`); paper 003's variation modes and motions (`inverse`). Each figure that cannot be drawn
//! is a warning for the caller, never a failed run.

pub mod diagnosis;
pub mod error;
pub mod inverse;
pub mod study;

/// Tick labels of every axis, in plotters' font units (its SVG writes 0.81 px per unit): its default
/// of 12 drew 9.7 px digits under 12 px axis titles in a 1000 px figure, smaller than any text of the
/// report around it; 15 draws them as large as the axis titles.
pub(crate) const TICK_LABEL_PX: u32 = 15;

/// Height of the area under an x axis: its tick labels and its title below them. 30 and 35 let the
/// title overlap the digits once the ticks grew to 15 units (the diagnosis's residual panels).
pub(crate) const X_LABEL_AREA_PX: u32 = 45;

/// Width of the area left of a y axis: tick labels of up to five characters (`-0.25`) and the rotated
/// title beside them. Wider areas stay where the labels are longer (names of coefficients).
pub(crate) const Y_LABEL_AREA_PX: u32 = 60;

pub use error::FigureError;
pub use study::{FigureReport, write_figures};
