//! The crate's integration tests, one binary (one link of the crate and its dependencies
//! instead of one per file); each module was a test file of its own, and `common` holds
//! the data generators and helpers they share.

mod absurd;
mod agreement;
mod common;
mod diagnostics;
mod errors;
mod properties;
mod tuning;
