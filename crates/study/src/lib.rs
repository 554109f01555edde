//! Studies: a TOML file describes a grid of identification experiments (training data × set ×
//! estimator × hyper-parameters × tests); this crate reads it (raw TOML → checked study → cases with
//! ids), runs the cases in parallel with resume, and builds the result tables. No printing: progress
//! goes through an optional bar the caller asks for.
//!
//! Module map: `study` (the file, its checks, the case grid; `raw_values` its values of more than one shape) ← `runner` (per-case fit, validation,
//! stored results, typed statuses and outcomes) ← `tables` (summary, coefficients, diagnostics) and
//! `record` (`study.toml`, `run.json`), `reference` (whose tables a folder holds, before `check
//! --bless` or a run writes over them); `lock` (one run per output folder), `output` (no link inside
//! the output folder followed out of it), `progress` (a bar or plain lines); `error`.

pub mod error;
pub mod lock;
pub mod output;
pub mod progress;
pub mod raw_values;
pub mod record;
pub mod reference;
pub mod runner;
pub mod study;
pub mod tables;

pub use error::StudyError;
pub use lock::RunLock;
pub use record::RunRecord;
pub use runner::{
    CaseOutcome, CaseResult, CaseStatus, OutcomeCounts, RunPlan, default_out, run_study,
};
pub use study::{
    Case, LARGE_RUN_CASES, LARGE_RUN_REPLICATE_SIMULATIONS, Study, StudySize, load_study,
    load_study_within,
};
