//! The study file's layers: raw TOML → checked study (each axis resolved) → cases.

use std::path::{Path, PathBuf};

use shipid_pipeline::fit::WindowSpec;
use shipid_study::study::{CheckedStudy, GP, NO_SET, RawStudy, load_study};

fn dataset() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/kvlcc2-mmg/dataset.toml")
}

/// A study file in a fresh directory; the directory lives as long as the returned guard.
fn study_file(body: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("study.toml");
    let text = format!("dataset = {:?}\n{body}", dataset().display().to_string());
    std::fs::write(&path, text).unwrap();
    (dir, path)
}

const MIXED: &str = r#"
name = "mixed"
sets = ["reduced32", "full68"]
[training]
recordings = [["zz35_35_ps.csv"], ["zz20_20_ps.csv", "tc35_ps.csv"]]
overshoots = { from = 2, to = 3 }
[[estimator]]
name = "sparse-gp"
similarity = [0.9, 0.95]
[[estimator]]
name = "ridge"
lambda = [1e-6, 1e-4]
[test]
recordings = "all"
"#;

#[test]
fn the_checked_study_resolves_each_axis_before_crossing_them() {
    let (_dir, path) = study_file(MIXED);
    let checked = CheckedStudy::from_raw(&path, RawStudy::read(&path).unwrap()).unwrap();
    assert_eq!(
        checked.windows,
        [WindowSpec::Overshoots(2), WindowSpec::Overshoots(3)]
    );
    let estimators: Vec<_> = checked
        .estimators
        .iter()
        .map(|e| {
            (
                e.spec.name.as_str(),
                e.spec.similarity,
                e.spec.lambda,
                e.solver.as_str(),
            )
        })
        .collect();
    assert_eq!(
        estimators,
        [
            (GP, Some(0.9), None, "none"),
            (GP, Some(0.95), None, "none"),
            ("ridge", None, Some(1e-6), "fast"),
            ("ridge", None, Some(1e-4), "fast"),
        ]
    );
    assert_eq!(checked.tests.len(), checked.dataset.recordings.len());

    // sets × polynomial estimators × training × windows, then the GP's cases without a set.
    let cases = checked.cases();
    assert_eq!(cases.len(), 2 * 2 * 2 * 2 + 2 * 2 * 2);
    assert!(cases[..16].iter().all(|c| c.estimator.name == "ridge"));
    assert!(
        cases[16..]
            .iter()
            .all(|c| c.set == NO_SET && c.estimator.name == GP)
    );
    assert_eq!(
        (cases[0].set.as_str(), cases[8].set.as_str()),
        ("reduced32", "full68")
    );
    assert_eq!(cases[1].window, WindowSpec::Overshoots(3));
    assert_eq!(cases[2].training, ["zz20_20_ps.csv", "tc35_ps.csv"]);

    assert_eq!(load_study(&path).unwrap().cases, cases);
}

fn first_fault(body: &str) -> String {
    let (_dir, path) = study_file(body);
    let err = load_study(&path).err().expect("a faulty study");
    err.to_string()
        .split_once(": ")
        .map(|(_, rest)| rest.to_string())
        .unwrap()
}

#[test]
fn with_several_faults_the_first_in_check_order_is_reported() {
    // An unknown set and a missing test recording: sets are checked first.
    let sets_then_tests = r#"
name = "two_faults"
sets = ["nope"]
[training]
recordings = [["zz35_35_ps.csv"]]
[[estimator]]
name = "lsq"
[test]
recordings = ["nope.csv"]
"#;
    assert_eq!(
        first_fault(sets_then_tests),
        "key `sets[0]`: unknown coefficient set `nope` (not one of reduced32, full68, full74, chen2021 and no such file)"
    );

    // Repeats are looked for once the whole estimator axis is known, so a later unknown estimator
    // is reported before an earlier repeat.
    let repeat_then_unknown = r#"
name = "two_faults"
sets = ["reduced32"]
[training]
recordings = [["zz35_35_ps.csv"]]
[[estimator]]
name = "lsq"
[[estimator]]
name = "lsq"
[[estimator]]
name = "neural-net"
[test]
recordings = "all"
"#;
    assert_eq!(
        first_fault(repeat_then_unknown),
        "key `estimator[2].name`: unknown estimator `neural-net` (lsq, bounded-lsq, ridge, lasso, svr, sparse-gp)"
    );
}
