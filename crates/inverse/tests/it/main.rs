//! Integration tests of shipid-inverse through its public API, in one test binary (one module per
//! topic).

mod degenerate;
mod paper003;
mod physical;
