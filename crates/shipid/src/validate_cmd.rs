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
    for w in ship_warnings(model_spec, model.ship(), model.added_mass(), &ds, dataset) {
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
    added_mass: &shipid_io::AddedMass,
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
    let mut differences = shipid_pipeline::model_file::ship_differences(model_ship, &ds.ship);
    differences.extend(hardware_differences(model_spec, added_mass, ds));
    if !differences.is_empty() {
        warnings.push(format!(
            "{model_spec} on {}: the ships differ ({}): the errors below compare different ships",
            dataset.display(),
            differences.join("; ")
        ));
    }
    warnings
}

/// Relative difference of a propeller's diameter, a rudder's area or span, or an added mass above
/// which a model and a data set describe different hardware (two descriptions of one propeller agree
/// to their rounding).
const HARDWARE_TOLERANCE: f64 = 0.02;

/// Where the model's propeller, rudder (an mmg model's) or added masses are not the data set's: the
/// particulars of the hull agreed, so nothing was said, while an mmg model fitted with a 0.216 m
/// propeller replayed a 0.204 m propeller's recordings 14 % slow on every straight.
fn hardware_differences(
    model_spec: &str,
    added_mass: &shipid_io::AddedMass,
    ds: &Dataset,
) -> Vec<String> {
    let differs = |m: f64, d: f64| (m - d).abs() > HARDWARE_TOLERANCE * m.abs().max(d.abs());
    let mut out = Vec::new();
    let mut compare = |key: &str, m: f64, d: f64, unit: &str| {
        if differs(m, d) {
            out.push(format!(
                "{key} {} {unit} in the model, {} {unit} in the data set",
                shipid_io::error::number(m),
                shipid_io::error::number(d)
            ));
        }
    };
    if let Some(p) = mmg_parameters(model_spec) {
        if let Some(prop) = &ds.propeller {
            compare(
                "propeller diameter",
                p.propeller_diameter_m,
                prop.diameter_m,
                "m",
            );
        }
        if let Some(r) = &ds.rudder {
            compare("rudder area", p.rudder_area_m2, r.area_m2, "m²");
            compare("rudder span", p.rudder_span_m, r.span_m, "m");
        }
    }
    if let Some(a) = &ds.added_mass {
        // Scaled by the larger of the pair's masses (inertias): a coupling term near zero in both
        // is not a difference.
        let m = ds.ship.rho * ds.ship.displacement;
        let l = ds.ship.lpp;
        for (key, mv, dv, scale, unit) in [
            ("X_udot", added_mass.X_udot, a.X_udot, m, "kg"),
            ("Y_vdot", added_mass.Y_vdot, a.Y_vdot, m, "kg"),
            ("Y_rdot", added_mass.Y_rdot, a.Y_rdot, m * l, "kg m"),
            ("N_vdot", added_mass.N_vdot, a.N_vdot, m * l, "kg m"),
            (
                "N_rdot",
                added_mass.N_rdot,
                a.N_rdot,
                m * l * l * 0.0625,
                "kg m²",
            ),
        ] {
            if (mv - dv).abs() > HARDWARE_TOLERANCE * mv.abs().max(dv.abs()).max(0.01 * scale) {
                out.push(format!(
                    "added mass {key} {} {unit} in the model, {} {unit} in the data set",
                    shipid_io::error::number(mv),
                    shipid_io::error::number(dv)
                ));
            }
        }
    }
    out
}

/// The MMG parameters of `model_spec` when it is an mmg model (the reference or a file).
fn mmg_parameters(model_spec: &str) -> Option<shipid_sim::MmgParameters> {
    if model_spec == "mmg:kvlcc2" {
        return Some(shipid_sim::MmgParameters::kvlcc2());
    }
    let path = Path::new(model_spec);
    let text = std::fs::read_to_string(path).ok()?;
    shipid_pipeline::mmg::file::load_mmg_model_if_kind(path, &text)
        .ok()
        .flatten()
        .map(|m| *m.parameters())
}
