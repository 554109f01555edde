//! Integration tests of shipid-model through its public API, in one test binary (one module per topic).

mod sets_and_design;
