//! Fits that ignore the data were "status ok" (tester's findings A5, H2).

use shipid_study::load_study;
use shipid_study::runner::{CaseStatus, run_case};

use super::study_file;

fn study(estimator: &str) -> Result<shipid_study::Study, String> {
    let (_dir, path) = study_file(&format!(
        "name = \"x\"\nsets = [\"reduced32\"]\n[training]\nrecordings = [[\"zz35_35_ps.csv\"]]\n\
         overshoots = [4]\n[[estimator]]\n{estimator}\n[test]\nrecordings = [\"zz20_20_ps.csv\"]\n"
    ));
    load_study(&path).map_err(|e| e.to_string())
}

#[test]
fn an_svr_whose_tube_holds_every_sample_is_a_case_that_explains_nothing() {
    let s = study("name = \"svr\"\nc = 1.0\nepsilon = 0.01").unwrap();
    let (result, model) = run_case(&s, &s.cases[0]);
    assert_eq!(result.status, CaseStatus::ExplainsNothing, "{result:?}");
    assert_eq!(result.status.as_str(), "explains-nothing");
    assert!(result.status.has_model() && model.is_some());
    assert!(
        result
            .dofs
            .iter()
            .all(|d| d.status == CaseStatus::ExplainsNothing)
    );
    // The same estimator with a tube inside the data explains it.
    let s = study("name = \"svr\"\nc = 1.0\nepsilon = 1e-6").unwrap();
    assert_eq!(run_case(&s, &s.cases[0]).0.status, CaseStatus::Ok);
}

#[test]
fn an_absurd_regularisation_is_refused_naming_its_key() {
    for (estimator, key) in [
        (
            "name = \"ridge\"\nlambda = [1e-4, 1e308]",
            "estimator[0].lambda",
        ),
        ("name = \"lasso\"\nalpha = 1e308", "estimator[0].alpha"),
        (
            "name = \"svr\"\nc = 1e300\nepsilon = 0.01",
            "estimator[0].c",
        ),
    ] {
        let err = study(estimator).err().unwrap_or_default();
        assert!(
            err.contains(key) && err.contains("1e15"),
            "{estimator}: {err}"
        );
    }
}
