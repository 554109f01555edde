//! `shipid report DIR`: one self-contained HTML page for a study output folder or a diagnosis folder.

use std::path::Path;

use shipid_report::{DiagnosisFiles, RunMeta};

use crate::{CliError, Outcome, bad_input, failed};

pub fn run(dir: &Path, study: Option<&Path>) -> Result<Outcome, CliError> {
    let meta = RunMeta {
        tool_version: Some(env!("CARGO_PKG_VERSION").into()),
        study_file: study.map(shipid_pipeline::model_file::absolute_path),
        ..RunMeta::default()
    };
    if !dir.is_dir() {
        return Err(bad_input(format!(
            "{}: no such folder (give the output folder of `shipid run` or of `shipid diagnose --plots`)",
            dir.display()
        )));
    }
    let mut inputs = crate::outputs::Inputs::new();
    if let Some(study) = study {
        // The page names it as the study the results came from: a path that is not a file would be
        // named all the same.
        if !study.is_file() {
            return Err(bad_input(format!(
                "--study {}: not a file (give the study file the results in {} came from)",
                study.display(),
                dir.display()
            )));
        }
        inputs = inputs.file(study, "the study file");
        // The page is headed with this study: results of another one would be shown under its
        // name, which `table` and `plot` refuse too.
        if dir.join("report.json").is_file() {
            return Err(bad_input(format!(
                "--study {}: {} is a diagnosis folder (report.json), which no study wrote; drop --study",
                study.display(),
                dir.display()
            )));
        }
        let s = shipid_study::load_study(study)
            .map_err(|e| bad_input(format!("--study {}: {e}", study.display())))?;
        shipid_study::tables::check_output_of(&s, dir)
            .map_err(|e| bad_input(format!("--study {}: {e}", study.display())))?;
    }
    crate::outputs::check_folder("DIR", dir, &[shipid_report::REPORT_FILE], &inputs)?;
    let html = if dir.join("report.json").is_file() {
        shipid_report::diagnosis_page(&DiagnosisFiles::in_dir(dir), &meta)
    } else if dir.join("summary.csv").is_file() {
        shipid_report::study_page_with_warnings(dir, &meta).map(|(html, notes)| {
            for n in notes {
                eprintln!("warning: {n}");
            }
            html
        })
    } else {
        return Err(bad_input(format!(
            "{}: neither a study output folder (summary.csv) nor a diagnosis folder (report.json)",
            dir.display()
        )));
    }
    .map_err(|e| CliError::BadInput(e.into()))?;
    let path = shipid_report::write_report(dir, &html).map_err(failed)?;
    println!("report: {}", path.display());
    Ok(Outcome::Ok)
}
