//! Integration tests of shipid-io through its public API, in one test binary: one module per topic.
//! Fixture files are under `tests/fixtures/` (paths relative to the package root, the working directory
//! of `cargo test`).

mod bad_input;
mod channel_consistency;
mod conventions;
mod input_checks;
mod prime_and_derivatives;
mod propeller_loading;
mod propeller_rudder;
mod readers_never_panic;
mod relative_wind;
mod special_outputs;
