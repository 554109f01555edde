//! Integration tests of the diagnosis crate (one binary, a module per concern).

mod known_wind;
mod own_misfit;
mod own_winds;
mod probe11;
