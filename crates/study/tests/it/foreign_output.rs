//! `shipid plot` drew another study's folder under this study's name (tester's finding C).

use shipid_study::tables::{check_output_of, write_tables};
use shipid_study::{StudyError, load_study};

use super::{ONE_CASE, banded_results, study_file};

#[test]
fn an_output_folder_of_another_study_is_refused_naming_a_case() {
    let (_a, this) = study_file(ONE_CASE);
    let this = load_study(&this).unwrap();
    let other = ONE_CASE.replace(r#"sets = ["reduced32"]"#, r#"sets = ["full68"]"#);
    let (_b, other) = study_file(&other);
    let other = load_study(&other).unwrap();
    let out = tempfile::tempdir().unwrap();
    write_tables(&other, &banded_results(&other), out.path()).unwrap();

    let err = check_output_of(&this, out.path()).unwrap_err();
    assert!(err.is_bad_input(), "{err}");
    assert!(matches!(err, StudyError::NotThisStudy { .. }));
    let msg = err.to_string();
    assert!(
        msg.contains("summary.csv") && msg.contains(&other.cases[0].id),
        "{msg}"
    );
    assert!(check_output_of(&other, out.path()).is_ok());
    // No run at all: refused, pointing at `shipid run`.
    let empty = tempfile::tempdir().unwrap();
    let msg = check_output_of(&this, empty.path())
        .unwrap_err()
        .to_string();
    assert!(msg.contains("shipid run"), "{msg}");
}
