//! Integration tests of the pipeline crate: one test binary, one module per concern.

mod band_limits;
mod bands;
mod calibration;
mod envelope;
mod environment;
mod execute_time;
mod family_calibration;
mod generate_environment;
mod mmg;
mod mmg_identifiability;
mod mmg_jackknife;
mod mmg_model_file;
mod out_of_kind;
mod propeller_rate;
mod refine;
mod relative_wind;
mod stored_calibration;
mod thrust;
