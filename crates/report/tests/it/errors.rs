use std::fs;
use std::path::Path;

use shipid_report::{DiagnosisFiles, ReportError, RunMeta, diagnosis_page, study_page};

use crate::fixture;
use crate::study::copy_dir;

fn study_err(dir: &Path) -> ReportError {
    study_page(dir, &RunMeta::default()).unwrap_err()
}

#[test]
fn a_folder_without_summary_csv_is_an_io_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let e = study_err(dir.path());
    assert!(matches!(e, ReportError::Io { .. }), "{e:?}");
    assert_eq!(e.path(), dir.path().join("summary.csv"));
    assert!(e.to_string().contains("summary.csv"));
}

#[test]
fn a_summary_without_case_column_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("summary.csv"), "name,value\na,1\n").unwrap();
    let e = study_err(dir.path());
    assert!(matches!(e, ReportError::Invalid { .. }), "{e:?}");
    assert!(e.to_string().contains("summary.csv") && e.to_string().contains("case"));
}

#[test]
fn ragged_csv_broken_json_and_toml_name_their_file() {
    let dir = tempfile::tempdir().unwrap();
    copy_dir(&fixture("study"), dir.path());
    let case = dir
        .path()
        .join("cases/reduced32_lsq_fast_zz35_35_ps_os2-122d3577");
    fs::write(case.join("result.json"), "{ not json").unwrap();
    let e = study_err(dir.path());
    assert!(matches!(e, ReportError::Json { .. }), "{e:?}");
    assert_eq!(e.path(), case.join("result.json"));

    fs::remove_file(case.join("result.json")).unwrap();
    fs::write(dir.path().join("study.toml"), "name = ").unwrap();
    let e = study_err(dir.path());
    assert!(matches!(e, ReportError::Toml { .. }), "{e:?}");
    assert_eq!(e.path(), dir.path().join("study.toml"));

    fs::remove_file(dir.path().join("study.toml")).unwrap();
    fs::write(dir.path().join("coefficients.csv"), "case,dof\na,X,extra\n").unwrap();
    let e = study_err(dir.path());
    assert!(matches!(e, ReportError::Csv { .. }), "{e:?}");
    assert_eq!(e.path(), dir.path().join("coefficients.csv"));
}

#[test]
fn a_json_that_is_not_a_diagnosis_report_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("report.json"), r#"{"candidates": []}"#).unwrap();
    let e = diagnosis_page(&DiagnosisFiles::in_dir(dir.path()), &RunMeta::default()).unwrap_err();
    assert!(matches!(e, ReportError::Invalid { .. }), "{e:?}");
    assert!(e.to_string().contains("report.json") && e.to_string().contains("verdict"));
    let e = diagnosis_page(
        &DiagnosisFiles::in_dir(&dir.path().join("nowhere")),
        &RunMeta::default(),
    )
    .unwrap_err();
    assert!(matches!(e, ReportError::Io { .. }), "{e:?}");
}
