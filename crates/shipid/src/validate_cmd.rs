//! `shipid validate MODEL.toml DATASET.toml [--json] [--bands LEVEL]`.

use std::path::Path;

use shipid_io::Dataset;
use shipid_io::Ship;
use shipid_pipeline::model_file::{load_model, ship_mismatch};

use crate::{CliError, Outcome};

pub fn run(
    model_spec: &str,
    dataset: &Path,
    as_json: bool,
    bands: Option<f64>,
) -> Result<Outcome, CliError> {
    if let Some(level) = bands
        && !(level > 0.0 && level < 1.0)
    {
        return Err(crate::bad_input(format!(
            "--bands must be a level strictly between 0 and 1 (e.g. 0.9), got {level}"
        )));
    }
    let model = load_model(model_spec)?;
    // Before the validation: a model without replicates (or with a damaged calibration) is refused
    // at once.
    let replicates = bands
        .map(|level| shipid_pipeline::calibration::ModelBands::of(model_spec, level))
        .transpose()?;
    let shipid_pipeline::bands::BesideModels { valley, jackknife } =
        shipid_pipeline::bands::beside_of(model_spec)?;
    let ds = Dataset::load(dataset)?;
    shipid_pipeline::validate::require_recordings(&ds)?;
    // Validation still runs: its errors are what the user asked for; the warnings say what they
    // cannot mean.
    for w in ship_warnings(model_spec, model.ship(), &ds, dataset) {
        eprintln!("warning: {w}");
    }
    // A sparse GP carries its own identification range; a polynomial's needs its training data.
    if model.own_range().is_none() {
        for w in crate::print::training_range_warnings(model_spec, "column `outside`") {
            eprintln!("warning: {w}");
        }
    }
    Ok(crate::print::validation_with_bands(
        model.as_ref(),
        model_spec,
        &ds,
        as_json,
        bands
            .zip(replicates.as_ref())
            .map(|(level, source)| crate::print::BandCheck { level, source }),
        valley.as_ref(),
        jackknife.as_ref(),
    ))
}

/// What `validate` and `simulate --replay` say when the model's ship is not the data set's: both
/// replay the recordings and give their errors in the data set's L and U0, which then compare
/// different ships.
pub fn ship_warnings(
    model_spec: &str,
    model_ship: &Ship,
    ds: &Dataset,
    dataset: &Path,
) -> Vec<String> {
    let mut warnings = Vec::new();
    if let Some(m) = ship_mismatch(model_ship, &ds.ship) {
        warnings.push(format!(
            "{model_spec} on {}: {m}: the errors below compare different ships",
            dataset.display()
        ));
    }
    let differences = shipid_pipeline::model_file::ship_differences(model_ship, &ds.ship);
    if !differences.is_empty() {
        warnings.push(format!(
            "{model_spec} on {}: the ships differ ({}): the errors below compare different ships",
            dataset.display(),
            differences.join("; ")
        ));
    }
    warnings
}
