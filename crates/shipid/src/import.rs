//! `shipid import MAPPING.toml --out DIR [--source DIR]`.

use std::path::Path;

use shipid_io::write::write_dataset_with;

use crate::{CliError, Outcome, bad_input, failed};

pub fn run(mapping: &Path, out: &Path, source: Option<&Path>) -> Result<Outcome, CliError> {
    // Refused before any source is read: the mistake is in the command line, not in the data (the
    // sources themselves are guarded by the writer, which knows their names).
    crate::outputs::check_folder(
        "--out",
        out,
        &["dataset.toml"],
        &crate::outputs::Inputs::new().file(mapping, "the mapping file"),
    )?;
    let imported = shipid_io::import::import(mapping, source)?;
    // Named relative to the files written, not as typed: the bytes must not depend on the working
    // directory the import ran from.
    let mapping_name = shipid_pipeline::model_file::stored_path(&out.join("dataset.toml"), mapping);
    let comments = vec![
        format!(
            "Imported by shipid {} from {} (mapping {mapping_name}).",
            env!("CARGO_PKG_VERSION"),
            imported.dataset.name,
        ),
        "Project conventions: SI units, rudder positive to starboard (source sign converted)."
            .into(),
    ];
    let recs: Vec<_> = imported.recordings.iter().collect();
    write_dataset_with(
        out,
        &imported.dataset,
        &recs,
        &comments,
        &imported.files,
        &imported.inputs,
    )
    .map_err(|e| {
        if e.is_bad_input() {
            bad_input(e)
        } else {
            failed(e)
        }
    })?;
    for line in &imported.provenance {
        eprintln!("imported {line}");
    }
    eprintln!(
        "wrote {} recordings and {}",
        recs.len(),
        out.join("dataset.toml").display()
    );
    Ok(Outcome::Ok)
}
