//! The study file's layers: raw TOML → checked study (each axis resolved) → cases.

mod diverged_replay;
mod explains_nothing;
mod foreign_output;
mod grid;

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

const ONE_CASE: &str = r#"
name = "with_bands"
sets = ["reduced32"]
[training]
recordings = [["zz35_35_ps.csv"]]
[[estimator]]
name = "lsq"
[test]
recordings = ["zz20_20_ps.csv", "tc35_sb.csv"]
"#;

/// One concern: what the `bands` and `bootstrap` keys become (or the first fault they give).
fn check_bands(keys: &str, expected: Result<Option<(f64, usize)>, &str>) {
    let (_dir, path) = study_file(&format!("{keys}\n{ONE_CASE}"));
    let got = load_study(&path)
        .map(|s| s.bands.map(|b| (b.level, b.replicates)))
        .map_err(|e| {
            e.to_string()
                .split_once(": ")
                .map(|(_, rest)| rest.to_string())
                .unwrap()
        });
    match expected {
        Ok(v) => assert_eq!(got.ok(), Some(v), "keys {keys:?}"),
        Err(msg) => assert_eq!(got.err().as_deref(), Some(msg), "keys {keys:?}"),
    }
}

#[test]
fn bands_and_bootstrap_go_together_and_are_checked() {
    check_bands("", Ok(None));
    check_bands("bands = 0.9\nbootstrap = 200", Ok(Some((0.9, 200))));
    check_bands(
        "bands = 0.9",
        Err(
            "key `bootstrap`: missing: bands need replicates to take percentiles of (e.g. bootstrap = 200)",
        ),
    );
    check_bands(
        "bootstrap = 200",
        Err(
            "key `bands`: missing: bootstrap replicates are only used for bands (e.g. bands = 0.9)",
        ),
    );
    check_bands(
        "bands = 0.0\nbootstrap = 200",
        Err("key `bands`: 0 is not a level strictly between 0 and 1 (e.g. 0.9 for a 90 % band)"),
    );
    check_bands(
        "bands = nan\nbootstrap = 200",
        Err("key `bands`: NaN is not a level strictly between 0 and 1 (e.g. 0.9 for a 90 % band)"),
    );
    check_bands(
        "bands = 0.9\nbootstrap = 10001",
        Err("key `bootstrap`: 10001 replicates: give between 2 and 10000"),
    );
    check_bands(
        "bands = 0.9\nbootstrap = -1",
        Err("key `bootstrap`: -1 replicates: give between 2 and 10000"),
    );
    check_bands(
        "calibrate = true",
        Err(
            "key `calibrate`: widens bands, and there are none: give bands = 0.9 and bootstrap = 200 too",
        ),
    );
    check_bands(
        "bands = 0.5\nbootstrap = 2\ncalibrate = true",
        Ok(Some((0.5, 2))),
    );
}

/// A result of `study`'s one case whose ZZ20 test has an overshoot band that misses the record and
/// one that holds it.
fn banded_results(study: &shipid_study::Study) -> Vec<shipid_study::CaseResult> {
    use shipid_study::runner::{MetricBandRow, TestRow, TestStatus};
    let row = |test: &str, bands: Vec<(&str, MetricBandRow)>| TestRow {
        test: test.into(),
        kind: "zigzag".into(),
        status: TestStatus::Ok,
        diverged_at_s: None,
        replay_status: TestStatus::Ok,
        replay_diverged_at_s: None,
        position_rmse_over_l: Some(0.0),
        heading_rmse_deg: Some(0.0),
        u_rmse_m_s: Some(0.0),
        v_rmse_m_s: Some(0.0),
        r_rmse_deg_s: Some(0.0),
        recorded: Default::default(),
        predicted: None,
        relative_error: Default::default(),
        mrae: Some(0.1),
        outside_identification_range: None,
        bands: bands.into_iter().map(|(k, v)| (k.to_string(), v)).collect(),
    };
    study
        .cases
        .iter()
        .map(|c| shipid_study::CaseResult {
            case_id: c.id.clone(),
            status: shipid_study::CaseStatus::Ok,
            message: None,
            fit_time_s: Some(0.0),
            samples: 1,
            dofs: vec![],
            coefficients: vec![],
            vif: vec![],
            tests: vec![
                row(
                    "zz20_20_ps.csv",
                    vec![
                        (
                            "overshoot_1",
                            MetricBandRow::Band {
                                lo: 2.5,
                                hi: 11.25,
                                inside: Some(false),
                            },
                        ),
                        (
                            "overshoot_2",
                            MetricBandRow::Band {
                                lo: 3.5,
                                hi: 14.0,
                                inside: Some(true),
                            },
                        ),
                    ],
                ),
                row(
                    "tc35_sb.csv",
                    vec![(
                        "advance",
                        MetricBandRow::NoBand {
                            reason: "11 finite replicate values of 20".into(),
                        },
                    )],
                ),
            ],
        })
        .collect()
}

#[test]
fn a_study_with_bands_has_lo_hi_inside_columns_and_one_without_has_none() {
    use shipid_study::tables::{summary_pivot, summary_table};
    let (_dir, path) = study_file(&format!("bands = 0.9\nbootstrap = 20\n{ONE_CASE}"));
    let study = load_study(&path).unwrap();
    let t = summary_table(&study, &banded_results(&study));
    let text = |name: &str| -> Vec<String> {
        let c = t.column(name).unwrap_or_else(|| panic!("no column {name}"));
        (0..t.rows()).map(|i| c.cell(i)).collect()
    };
    assert_eq!(text("overshoot_1_lo"), ["2.5", ""]);
    assert_eq!(text("overshoot_1_hi"), ["11.25", ""]);
    assert_eq!(text("overshoot_1_inside"), ["no", ""]);
    assert_eq!(text("overshoot_2_inside"), ["yes", ""]);
    // No band: no bounds and no verdict, not a zero-width band.
    assert_eq!(text("advance_lo"), ["", ""]);
    assert_eq!(text("advance_inside"), ["", ""]);

    let md = summary_pivot(&t, Some("window,test,overshoot_1_band")).unwrap();
    assert!(md.contains("| whole | [2.500, 11.25] outside |  |"), "{md}");
    let md = summary_pivot(&t, Some("window,test,overshoot_2_inside")).unwrap();
    assert!(md.contains("| whole | yes |  |"), "{md}");

    // The same study without the keys: the summary's columns are those of every earlier run.
    let (_dir2, plain) = study_file(ONE_CASE);
    let plain = load_study(&plain).unwrap();
    let t = summary_table(&plain, &banded_results(&plain));
    assert!(
        t.columns
            .iter()
            .all(|(n, _)| !n.ends_with("_lo") && !n.ends_with("_hi") && !n.ends_with("_inside"))
    );
}

#[test]
fn a_band_pivot_that_would_merge_two_cases_is_refused_naming_them() {
    use shipid_study::tables::{summary_pivot, summary_table};
    let two_sets = ONE_CASE.replace(
        r#"sets = ["reduced32"]"#,
        r#"sets = ["reduced32", "full68"]"#,
    );
    let (_dir, path) = study_file(&format!("bands = 0.9\nbootstrap = 20\n{two_sets}"));
    let study = load_study(&path).unwrap();
    let t = summary_table(&study, &banded_results(&study));
    let err = summary_pivot(&t, Some("window,test,overshoot_1_band"))
        .unwrap_err()
        .to_string();
    for c in &study.cases {
        assert!(err.contains(&c.id), "{err} names {}", c.id);
    }
    // The default pivot separates them by set.
    let md = summary_pivot(&t, None).unwrap();
    assert!(
        md.contains("| reduced32 / whole |") && md.contains("| full68 / whole |"),
        "{md}"
    );
}

#[test]
fn a_fit_failed_case_adds_no_phantom_column_to_the_default_table() {
    use shipid_study::tables::{summary_pivot, summary_table};
    let two_sets = ONE_CASE.replace(
        r#"sets = ["reduced32"]"#,
        r#"sets = ["reduced32", "full68"]"#,
    );
    let (_dir, path) = study_file(&two_sets);
    let study = load_study(&path).unwrap();
    let mut results = banded_results(&study);
    results[1].status = shipid_study::CaseStatus::FitFailed;
    results[1].tests.clear();
    let md = summary_pivot(&summary_table(&study, &results), None).unwrap();
    let header = md.lines().next().unwrap();
    assert!(!header.contains('–'), "{md}");
    assert_eq!(header.matches('|').count(), 2 + study.tests.len(), "{md}");
    assert!(
        md.contains(&format!(
            "{}: fit-failed, no test results",
            study.cases[1].id
        )),
        "{md}"
    );
}

/// One concern: what a `[check]` table gives (`None`: accepted; else the first fault, without the
/// file's name). Column names are checked against the tables the study writes.
fn check_tolerance(check: &str, expected: Option<&str>) {
    let (_dir, path) = study_file(&format!("{ONE_CASE}[check]\n{check}\n"));
    let got = load_study(&path)
        .map_err(shipid_study::StudyError::from)
        .and_then(|s| shipid_study::tables::check_tolerance_columns(&s))
        .map_err(|e| {
            e.to_string()
                .split_once(": ")
                .map(|(_, rest)| rest.to_string())
                .unwrap()
        });
    assert_eq!(got.err().as_deref(), expected, "{check}");
}

/// Regression: `abs = inf` (or 1e300) passed every value, a negative or NaN tolerance failed equal
/// values, a misspelt column (`mrea`, `MRAE`) was ignored without a word, and a tolerance for
/// `fit_time_s` (documented as never compared) compared it.
#[test]
fn check_tolerances_are_finite_bounded_and_name_numeric_columns() {
    check_tolerance("mrae = { abs = 1e-6, rel = 1e-4 }", None);
    check_tolerance("value = { abs = 1.0 }", None);
    check_tolerance(
        "mrae = { abs = inf }",
        Some("key `check.mrae.abs`: inf must be finite (an infinite tolerance passes every value)"),
    );
    check_tolerance(
        "mrae = { abs = 1e300 }",
        Some(
            "key `check.mrae.abs`: 1e300 must be at most 1000000 (a larger one passes any value of the tables)",
        ),
    );
    check_tolerance(
        "mrae = { rel = 2.0 }",
        Some(
            "key `check.mrae.rel`: 2 must be at most 1 (a larger one passes any value of the tables)",
        ),
    );
    check_tolerance(
        "mrae = { abs = -1.0 }",
        Some("key `check.mrae.abs`: -1 must not be negative (it would fail equal values)"),
    );
    check_tolerance(
        "mrae = { rel = nan }",
        Some("key `check.mrae.rel`: NaN is not a number (it would fail every comparison)"),
    );
    check_tolerance(
        "mrae = { abs = 1e-6, tol = 1.0 }",
        Some("key `check.mrae`: \"tol\" is not a key of a tolerance: it has `abs` and `rel` only"),
    );
    check_tolerance(
        "fit_time_s = { abs = 0.0 }",
        Some(
            "key `check.fit_time_s`: the fit's wall time varies between runs and is never compared: remove this tolerance",
        ),
    );
    for (key, hint) in [
        ("mrea", " (did you mean `mrae`?)"),
        ("MRAE", " (did you mean `mrae`?)"),
        ("case", ""),
    ] {
        let (_dir, path) = study_file(&format!("{ONE_CASE}[check]\n{key} = {{ abs = 1e-3 }}\n"));
        let study = load_study(&path).unwrap();
        let msg = shipid_study::tables::check_tolerance_columns(&study)
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains(&format!(
                "key `check.{key}`: no numeric column `{key}` in the summary or coefficients table{hint}; tolerances apply to "
            )),
            "{msg}"
        );
        assert!(!msg.contains("fit_time_s"), "{msg}");
    }
}

/// Regression: a tolerance written as a list was read by position with extras dropped (`[0.5]`
/// was abs 0.5, `[1e-6, 1e-4, 99]` dropped 99, `[]` the default), a form no document names.
#[test]
fn a_tolerance_written_as_a_list_is_refused_naming_the_key() {
    for list in ["[0.5]", "[1e-6, 1e-4, 99]", "[]"] {
        let (_dir, path) = study_file(&format!("{ONE_CASE}[check]\nmrae = {list}\n"));
        let err = load_study(&path)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(
            err.contains("key `check.mrae`: invalid type: sequence, expected a tolerance table such as { abs = 1e-6, rel = 1e-4 }"),
            "{list}: {err}"
        );
    }
    let (_dir, path) = study_file(&format!("{ONE_CASE}[check]\nmrae = {{ rel = 1 }}\n"));
    let check = load_study(&path).unwrap().check;
    assert_eq!(
        check["mrae"],
        shipid_study::study::Tolerance { abs: 0.0, rel: 1.0 }
    );
}

/// Regression: two recordings of 121 characters trained together made a case id over 255 bytes,
/// and the run failed late with "File name too long". The id's readable part is cut; its hash
/// (of the whole configuration) keeps cut ids apart.
#[test]
fn case_ids_of_long_recording_names_fit_a_file_name() {
    let data = tempfile::tempdir().unwrap();
    let long = |n: u32| format!("{}{n}.csv", "a".repeat(121));
    let source = dataset();
    let mut text = std::fs::read_to_string(&source).unwrap();
    let from = source.parent().unwrap();
    for (old, n) in [("zz35_35_ps.csv", 1), ("zz35_35_sb.csv", 2)] {
        std::fs::copy(from.join(old), data.path().join(long(n))).unwrap();
        text = text.replace(old, &long(n));
    }
    for other in [
        "zz10_10_ps.csv",
        "zz20_20_ps.csv",
        "tc35_ps.csv",
        "tc35_sb.csv",
    ] {
        std::fs::copy(from.join(other), data.path().join(other)).unwrap();
    }
    std::fs::write(data.path().join("dataset.toml"), text).unwrap();
    let study = data.path().join("study.toml");
    std::fs::write(
        &study,
        format!(
            "name = \"long\"\ndataset = \"dataset.toml\"\nsets = [\"reduced32\"]\n[training]\n\
             recordings = [[\"{a}\", \"{b}\"], [\"{a}\"]]\novershoots = [2, 3]\n[[estimator]]\n\
             name = \"lsq\"\n[test]\nrecordings = [\"{a}\"]\n",
            a = long(1),
            b = long(2)
        ),
    )
    .unwrap();
    let cases = load_study(&study).unwrap().cases;
    assert_eq!(cases.len(), 4);
    for c in &cases {
        assert!(
            c.id.len() <= shipid_study::study::MAX_READABLE_ID + 9,
            "{}",
            c.id
        );
    }
    let ids: std::collections::BTreeSet<&str> = cases.iter().map(|c| c.id.as_str()).collect();
    assert_eq!(ids.len(), 4, "cut ids stay apart");
}
