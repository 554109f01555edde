//! `shipid validate MODEL.toml DATASET.toml [--json]`.

use std::path::Path;

use shipid_io::Dataset;
use shipid_pipeline::model_file::load_model;

use crate::{CliError, Outcome};

pub fn run(model_spec: &str, dataset: &Path, as_json: bool) -> Result<Outcome, CliError> {
    let model = load_model(model_spec)?;
    let ds = Dataset::load(dataset)?;
    Ok(crate::print::validation(
        model.as_ref(),
        model_spec,
        &ds,
        as_json,
    ))
}
