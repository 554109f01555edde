//! The identification pipeline of shipid, as a library with no knowledge of the command line: training
//! windows and fits (Abkowitz polynomials by the estimators, sparse GPs), the output-error refinement,
//! validation against recordings, the identification range of a model, the default data set's
//! generation and the one loader of model files that every command uses.
//!
//! Module map (arrows are the only imports between modules, so there are no circles):
//! `error` ← everything; `lm` (Levenberg–Marquardt step, small solves); `validate` (replays, closed-loop
//! metrics, RMS; imports nothing of this crate but `range`); `replay` (segment replays) → `lm`,
//! `validate`; `fit` (windows, polynomial fit) → `refine` → `lm`, `replay`, `validate`; `fit_gp` →
//! `fit`; `range` (identification range); `spec` (manoeuvre specs) ← `generate` (default data) ←
//! `simulate` (standard manoeuvres); `model_file` (the loader) → `fit_gp`;
//! `bootstrap` (block-bootstrap replicates of a polynomial or mmg fit); `bands` (replicated models'
//! manoeuvre bands) → `simulate`; `calibration` (ensemble, reach, inflation, a model file's
//! `[calibration]`) → `bands`, `bootstrap`, `fit`, `range`. `cargo xtask circles`
//! checks that these stay one-way.

pub mod bands;
pub mod bootstrap;
pub mod calibration;
pub mod environment;
pub mod error;
pub mod excitation;
pub mod fit;
pub mod fit_gp;
pub mod generate;
pub mod lm;
pub mod metric_family;
pub mod mmg;
pub mod model_file;
pub mod out_of_kind;
pub mod range;
pub mod refine;
pub mod replay;
pub mod simulate;
pub mod spec;
pub mod toml_text;
pub mod validate;

pub use error::{PipelineError, bad_input, failed};
