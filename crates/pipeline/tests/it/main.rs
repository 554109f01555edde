//! Integration tests of the pipeline crate: one test binary, one module per concern.

mod bands;
mod mmg;
mod refine;
