//! The integration tests of the `shipid` binary and the pipeline it drives: one test binary, one
//! module per concern (one link of the workspace's heavy dependencies instead of one per file).

mod cli;
mod cli_probe;
mod common;
mod diagnose;
mod embedded_data;
mod environment;
mod foreign_dir;
mod hostile;
mod hsva_import;
mod hsva_paper001;
mod identification;
mod inverse_cli;
mod inverse_model;
mod mmg;
mod plots;
mod sparse_gp;
mod studies;
