//! Paper 003 (Guzelbulut 2025, "Identification of Ship Maneuvering Behavior Using Singular Value
//! Decomposition-Based Hydrodynamic Variations", J. Mar. Sci. Eng. 13, 496): identification of a ship's
//! hydrodynamics from standard motion indexes only (advance, tactical diameter, speed loss, zig-zag
//! overshoots and their times), without time series.
//!
//! - [`database`]: the 20-ship MMG database of paper 003 Tab. 1 and the behaviour vector h (forces on a
//!   β/r' grid plus interaction coefficients repeated 10×).
//! - [`modes`]: SVD of the variation matrix, mode contributions, the generator c̄ + Σ x_i w_i.
//! - [`target`]: the target ship's MMG model from generated coefficients (straight-run resistance from
//!   Schoenherr friction with a form factor, added masses from Zhou et al. when not given).
//! - [`indexes`]: the nine motion indexes from ±35° turns and ±20/20 zig-zags (reusing `shipid-sim`).
//! - [`mlp`]: the inverse network (two hidden layers of 30, tanh, Adam, early stopping).
//! - [`physical`]: physical checks on generated and identified ships (parameter bounds, stable
//!   straight running); rejected samples are counted.
//! - [`pipeline`]: simulation database (rayon), training with a 70/15/15 split, held-out check.
//! - [`inversion`]: a target's motions inverted (network, clipping, re-simulation, nearest database
//!   ship, refinement) and the tables that report them.
//!
//! No I/O; every failure of user input is an [`InverseError`], a failed simulation an
//! [`indexes::IndexFailure`] status.

pub mod database;
pub mod error;
pub mod indexes;
pub mod inversion;
pub mod mlp;
pub mod modes;
pub mod physical;
pub mod pipeline;
pub mod run;
pub mod target;

pub use error::InverseError;
