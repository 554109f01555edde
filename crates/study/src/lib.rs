//! Studies: a TOML file describes a grid of identification experiments (training data × set ×
//! estimator × hyper-parameters × tests); this crate reads it (raw TOML → checked study → cases with
//! ids), runs the cases in parallel with resume, and builds the result tables. No printing: progress
//! goes through an optional bar the caller asks for.
//!
//! Module map: `study` (the file, its checks, the case grid) ← `runner` (per-case fit, validation,
//! stored results, typed statuses) ← `tables` (summary, coefficients, diagnostics); `error`.

pub mod error;
pub mod runner;
pub mod study;
pub mod tables;

pub use error::StudyError;
pub use runner::{CaseResult, CaseStatus, default_out, run_study};
pub use study::{Case, Study, load_study};
