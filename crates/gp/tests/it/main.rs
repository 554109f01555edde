//! Integration tests of shipid-gp through its public API, in one test binary (one module per topic).

mod draw;
mod gp;
