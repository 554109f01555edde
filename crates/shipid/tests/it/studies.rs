//! Study files and the runner: bad study files are named errors (exit 2), an interrupted run resumes
//! without redoing or losing finished cases, a diverging case is a status row, output does not depend
//! on the number of threads.

use crate::common;

use std::collections::BTreeMap;
use std::path::Path;

use shipid::study_cmd::run_and_write;
use shipid_study::study::load_study;
use shipid_tables::Table;

const FIXTURES: &str = "crates/shipid/tests/fixtures/studies";

fn check_bad(name: &str, expected: &str) {
    let path = format!("{FIXTURES}/{name}");
    let out = common::shipid(&["run", &path, "--out", "/tmp/shipid-never-written"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{name}: {err}");
    assert_eq!(err.trim(), format!("error: {path}{expected}"), "{name}");
}

#[test]
fn bad_study_files_name_the_file_and_key() {
    check_bad(
        "unknown_key.toml",
        ":2:1: key `colour`: unknown field `colour`, expected one of `name`, `description`, `dataset`, `sets`, `training`, `estimator`, `test`, `check`, `bands`, `bootstrap`, `calibrate`",
    );
    check_bad(
        "unknown_estimator.toml",
        ": key `estimator[0].name`: unknown estimator `neural-net` (lsq, bounded-lsq, ridge, lasso, svr, sparse-gp)",
    );
    check_bad(
        "empty_grid.toml",
        ": key `sets`: the grid is empty: no coefficient set",
    );
    check_bad(
        "missing_recording.toml",
        ": key `training.recordings[0][0]`: recording `zz99_99_ps.csv` is not in crates/shipid/tests/fixtures/studies/../../../../../data/kvlcc2-mmg/dataset.toml",
    );
    check_bad(
        "too_many_overshoots.toml",
        ": key `training.overshoots`: 30 overshoots requested but `zz35_35_ps.csv` has 13",
    );
    check_bad(
        "ridge_without_lambda.toml",
        ": key `estimator[0].lambda`: the grid is empty: give lambda values or tune = true",
    );
    check_bad(
        "unknown_set.toml",
        ": key `sets[0]`: unknown coefficient set `reduced33` (not one of reduced32, full68, full74, chen2021 and no such file)",
    );
    check_bad(
        "gp_with_lambda.toml",
        ": key `estimator[0].lambda`: does not apply to sparse-gp (its one setting is `similarity`, the threshold d_gen)",
    );
    check_bad(
        "gp_similarity_out_of_range.toml",
        ": key `estimator[0].similarity`: similarity must be in (0, 1], not 1.5",
    );
    check_bad(
        "similarity_on_lsq.toml",
        ": key `estimator[0].similarity`: applies to sparse-gp only",
    );
    // A repeated grid value would give two cases one id (regression: they shared a directory).
    check_bad(
        "repeated_set.toml",
        ": key `sets[2]`: `reduced32` repeats sets[0]",
    );
    check_bad(
        "repeated_training.toml",
        ": key `training.recordings[2]`: repeats training.recordings[0]",
    );
    check_bad(
        "repeated_overshoots.toml",
        ": key `training.overshoots`: value 3 repeats value 2 (counting from 1): 4 OS twice",
    );
    check_bad(
        "repeated_lambda.toml",
        ": key `estimator[0].lambda`: a value appears twice in the grid (0.000001)",
    );
    check_bad(
        "repeated_similarity.toml",
        ": key `estimator[0].similarity`: a value appears twice in the grid (0.9)",
    );
    check_bad(
        "repeated_estimator.toml",
        ": key `estimator[2]`: repeats a case of estimator[0]",
    );
    check_bad(
        "missing_dataset.toml",
        ": key `dataset`: data set `crates/shipid/tests/fixtures/studies/nowhere/dataset.toml` not found",
    );
}

fn small_study() -> shipid_study::study::Study {
    load_study(&common::root().join(FIXTURES).join("small.toml")).unwrap()
}

fn result_files(dir: &Path) -> Vec<(String, std::time::SystemTime, Vec<u8>)> {
    let mut v: Vec<_> = std::fs::read_dir(dir.join("cases"))
        .unwrap()
        .map(|e| {
            let p = e.unwrap().path().join("result.json");
            (
                p.display().to_string(),
                p.metadata().unwrap().modified().unwrap(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

fn without_timing(t: &Table) -> Table {
    Table {
        columns: t
            .columns
            .iter()
            .filter(|(n, _)| n != "fit_time_s")
            .cloned()
            .collect(),
    }
}

#[test]
fn an_interrupted_study_resumes_without_redoing_or_losing_cases() {
    let study = small_study();
    assert_eq!(study.cases.len(), 3);
    let dir = tempfile::tempdir().unwrap();
    let first = run_and_write(&study, dir.path(), 2, false, false)
        .unwrap()
        .0;
    let first_summary = Table::read_csv(&dir.path().join("summary.csv")).unwrap();
    let before = result_files(dir.path());
    // Interrupt: the last case never finished (no result.json, a half-written temporary file instead).
    let victim = dir.path().join("cases").join(&study.cases[2].id);
    std::fs::remove_file(victim.join("result.json")).unwrap();
    std::fs::write(victim.join("result.json.tmp"), b"{\"case_id\": \"trunc").unwrap();
    std::thread::sleep(std::time::Duration::from_millis(20));
    let second = run_and_write(&study, dir.path(), 2, false, false)
        .unwrap()
        .0;
    let after = result_files(dir.path());
    assert_eq!(after.len(), 3, "the unfinished case was completed");
    for (b, a) in before.iter().zip(&after).take(2) {
        assert_eq!(b.1, a.1, "{} was not rewritten", b.0);
    }
    assert_eq!(
        first[2].tests, second[2].tests,
        "the redone case gives the same results"
    );
    assert_eq!(
        without_timing(&first_summary),
        without_timing(&Table::read_csv(&dir.path().join("summary.csv")).unwrap()),
        "tables complete after the resume"
    );
}

#[test]
fn output_does_not_depend_on_the_number_of_jobs() {
    let study = small_study();
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    run_and_write(&study, a.path(), 1, false, false).unwrap();
    run_and_write(&study, b.path(), 2, false, false).unwrap();
    for stem in ["summary", "coefficients", "diagnostics"] {
        let ta = Table::read_csv(&a.path().join(format!("{stem}.csv"))).unwrap();
        let tb = Table::read_csv(&b.path().join(format!("{stem}.csv"))).unwrap();
        assert_eq!(without_timing(&ta), without_timing(&tb), "{stem}");
    }
}

/// A diverged prediction is a result of the study: exit 0 with the divergence counted in the summary
/// line; `--strict` makes it exit 1.
#[test]
fn a_diverging_case_is_a_status_row_exit_0_and_exit_1_when_strict() {
    let dir = tempfile::tempdir().unwrap();
    let study = common::root()
        .join(FIXTURES)
        .join("one_overshoot_diverges.toml");
    let out_dir = dir.path().join("out");
    let out = common::shipid(&[
        "run",
        study.to_str().unwrap(),
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains("1 with a diverged prediction"),
        "the summary line counts the divergence: {stderr}"
    );
    assert!(out_dir.join("report.html").is_file());
    let strict = common::shipid(&[
        "run",
        study.to_str().unwrap(),
        "--out",
        out_dir.to_str().unwrap(),
        "--strict",
    ]);
    assert_eq!(
        strict.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&strict.stderr)
    );
    let t = Table::read_csv(&out_dir.join("summary.csv")).unwrap();
    let status: Vec<String> = (0..t.rows())
        .map(|i| t.column("status").unwrap().cell(i))
        .collect();
    assert!(
        status.iter().any(|s| s == "diverged"),
        "statuses {status:?}"
    );
    let at = t.column("diverged_at_s").unwrap();
    assert!(
        (0..t.rows()).any(|i| !at.cell(i).is_empty()),
        "the divergence time is kept"
    );
}

#[test]
fn check_reports_a_changed_number_and_exits_1() {
    let dir = tempfile::tempdir().unwrap();
    let reference = dir.path().join("reference");
    let study = format!("{FIXTURES}/small.toml");
    let bless = common::shipid(&[
        "check",
        &study,
        "--reference",
        reference.to_str().unwrap(),
        "--bless",
    ]);
    assert!(
        bless.status.success(),
        "{}",
        String::from_utf8_lossy(&bless.stderr)
    );
    let same = common::shipid(&["check", &study, "--reference", reference.to_str().unwrap()]);
    assert!(
        same.status.success(),
        "a fresh run matches its own reference"
    );
    // Tamper with one stored metric: the check must name it.
    let path = reference.join("summary.csv");
    let text = std::fs::read_to_string(&path).unwrap();
    let t = Table::read_csv(&path).unwrap();
    let stored = t.column("mrae").unwrap().cell(0);
    std::fs::write(&path, text.replacen(&stored, "0.5", 1)).unwrap();
    let changed = common::shipid(&["check", &study, "--reference", reference.to_str().unwrap()]);
    assert_eq!(changed.status.code(), Some(1));
    let out = String::from_utf8_lossy(&changed.stdout);
    let case = t.column("case").unwrap().cell(0);
    let test = t.column("test").unwrap().cell(0);
    assert!(
        out.contains(&format!(
            "summary: row 1 (case `{case}`, test `{test}`): `mrae` = {stored}, reference 0.5"
        )),
        "{out}"
    );
}

/// Regression: rows were compared by position, so the same reference stored in another row order
/// gave a difference in every cell.
#[test]
fn check_pairs_rows_by_case_and_test_so_a_reordered_reference_matches() {
    let dir = tempfile::tempdir().unwrap();
    let reference = dir.path().join("reference");
    let study = format!("{FIXTURES}/small.toml");
    let r = reference.to_str().unwrap();
    assert!(
        common::shipid(&["check", &study, "--reference", r, "--bless"])
            .status
            .success()
    );
    for stem in ["summary", "coefficients"] {
        let path = reference.join(format!("{stem}.csv"));
        let text = std::fs::read_to_string(&path).unwrap();
        let mut lines: Vec<&str> = text.lines().collect();
        lines[1..].reverse();
        std::fs::write(&path, lines.join("\n") + "\n").unwrap();
    }
    let again = common::shipid(&["check", &study, "--reference", r]);
    assert!(
        again.status.success(),
        "{}{}",
        String::from_utf8_lossy(&again.stdout),
        String::from_utf8_lossy(&again.stderr)
    );
}

/// Regression: links planted inside the output folder were followed: a run wrote its figures into
/// (and removed a stale figure from) the folder `figures` pointed to, its case files into the
/// folder a `cases/<id>` link pointed to, and overwrote the file `.shipid-run.lock` pointed to;
/// `plot` wrote through `figures` too. Each is refused, naming the link, exit 2, the target left
/// alone.
#[cfg(unix)]
#[test]
fn links_planted_in_the_output_folder_are_refused_and_never_followed() {
    use std::os::unix::fs::symlink;
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let study = format!("{FIXTURES}/small.toml");
    let o = out.to_str().unwrap();
    let first = common::shipid(&["run", &study, "--out", o, "--jobs", "2"]);
    assert!(
        first.status.success(),
        "{}",
        String::from_utf8_lossy(&first.stderr)
    );
    let victim = dir.path().join("victim");
    std::fs::create_dir_all(victim.join("figs")).unwrap();
    std::fs::write(victim.join("figs/heading_old.svg"), "mine").unwrap();
    std::fs::write(victim.join("lock"), "IMPORTANT").unwrap();
    let id = std::fs::read_dir(out.join("cases"))
        .unwrap()
        .flatten()
        .next()
        .unwrap()
        .file_name();
    let expect_refused = |args: &[&str], link: &Path| {
        let r = common::shipid(args);
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains(&format!("{}: a symbolic link", link.display())),
            "{err}"
        );
    };
    let run = ["run", study.as_str(), "--out", o, "--force"];
    // figures/ → elsewhere, for run and plot.
    std::fs::rename(out.join("figures"), dir.path().join("figures.bak")).unwrap();
    symlink(victim.join("figs"), out.join("figures")).unwrap();
    expect_refused(&run, &out.join("figures"));
    expect_refused(&["plot", &study, "--out", o], &out.join("figures"));
    std::fs::remove_file(out.join("figures")).unwrap();
    // cases/<id> → elsewhere.
    let case = out.join("cases").join(&id);
    std::fs::rename(&case, victim.join(&id)).unwrap();
    symlink(victim.join(&id), &case).unwrap();
    expect_refused(&run, &case);
    std::fs::remove_file(&case).unwrap();
    // The lock → a file.
    symlink(victim.join("lock"), out.join(".shipid-run.lock")).unwrap();
    expect_refused(&run, &out.join(".shipid-run.lock"));
    assert_eq!(
        std::fs::read_to_string(victim.join("lock")).unwrap(),
        "IMPORTANT"
    );
    let figs: Vec<_> = std::fs::read_dir(victim.join("figs"))
        .unwrap()
        .flatten()
        .collect();
    assert_eq!(figs.len(), 1, "only the victim's own file");
    assert_eq!(
        std::fs::read_to_string(victim.join("figs/heading_old.svg")).unwrap(),
        "mine"
    );
}

#[test]
fn refine_in_a_study_is_its_own_case_labelled_as_refined_and_its_replay_of_the_training_zigzag_is_closer()
 {
    let study = load_study(&common::root().join(FIXTURES).join("refine.toml")).unwrap();
    let ids: Vec<&str> = study.cases.iter().map(|c| c.id.as_str()).collect();
    assert_eq!(ids.len(), 2, "{ids:?}");
    assert!(
        !ids[0].contains("-oe") && ids[1].contains("lsq-oe"),
        "{ids:?}"
    );
    let dir = tempfile::tempdir().unwrap();
    let results = run_and_write(&study, dir.path(), 2, false, false)
        .unwrap()
        .0;
    let (lsq, refined) = (&results[0].tests[0], &results[1].tests[0]);
    assert_eq!(refined.replay_status, shipid_study::runner::TestStatus::Ok);
    // Whole open-loop replays of the 35° zig-zag drift in heading with either model (≈ 20° RMSE), so
    // the gain is modest there (≈ 9 %); the refinement's own target, the 10 L/U0 segment replays, is
    // tested in identification.rs.
    let rmse = |x: Option<f64>| x.expect("a replay that did not diverge has its RMSEs");
    assert!(rmse(refined.heading_rmse_deg) < rmse(lsq.heading_rmse_deg));
    assert!(
        rmse(refined.position_rmse_over_l) < 0.95 * rmse(lsq.position_rmse_over_l),
        "{:?} vs {:?}",
        refined.position_rmse_over_l,
        lsq.position_rmse_over_l
    );
    assert_ne!(results[0].coefficients, results[1].coefficients);
    // Regression (both cases were labelled "lsq 4 OS" in the tables and figures): the refined one is
    // told apart everywhere a reader meets it.
    let tables = std::fs::read_to_string(dir.path().join("summary.csv")).unwrap();
    assert!(
        tables.contains(",lsq-oe,"),
        "estimator column of the refined case"
    );
    let figures = dir.path().join("figures");
    let bars = std::fs::read_to_string(figures.join("coefficients_reduced32.svg")).unwrap();
    assert!(
        bars.contains("lsq-oe 4 OS"),
        "bar legend of the refined case"
    );
    let track = std::fs::read_to_string(figures.join("trajectories_zz35_35_ps.svg")).unwrap();
    assert!(
        track.contains("reduced32 lsq refined 4 OS"),
        "track legend of the refined case"
    );
}

#[test]
fn a_sparse_gp_case_needs_no_set_and_is_validated_and_drawn_like_the_polynomial_ones() {
    let study = load_study(&common::root().join(FIXTURES).join("gp_without_sets.toml")).unwrap();
    assert_eq!(study.cases.len(), 1);
    let case = &study.cases[0];
    assert!(
        case.id.starts_with("sparse-gp-d9.6e-1_zz35_35_ps_os4-"),
        "{}",
        case.id
    );
    assert_eq!((case.set.as_str(), case.solver.as_str()), ("none", "none"));
    let dir = tempfile::tempdir().unwrap();
    let results = run_and_write(&study, dir.path(), 1, false, false)
        .unwrap()
        .0;
    let r = &results[0];
    assert_eq!(r.status, shipid_study::CaseStatus::Ok, "{:?}", r.message);
    assert!(
        r.message.as_deref().unwrap_or("").contains("kept"),
        "{:?}",
        r.message
    );
    let outputs: Vec<&str> = r.dofs.iter().map(|d| d.dof.as_str()).collect();
    assert_eq!(outputs, ["u_dot_m_s2", "v_dot_m_s2", "r_dot_rad_s2"]);
    assert!(r.coefficients.is_empty() && r.vif.is_empty());
    // Trained on ZZ35/35 PS (4 OS) of the default data, the GP predicts the 20/20 zig-zag's
    // overshoots and times within a few percent (2.0 % measured; reduced32 LSQ: 11.6 %).
    let t = &r.tests[0];
    assert_eq!(
        (t.test.as_str(), t.status.as_str()),
        ("zz20_20_ps.csv", "ok")
    );
    let mrae = t.mrae.unwrap();
    assert!(mrae < 0.04, "MRAE {mrae}");
    // Its identification range is the sparse points' coverage: the 20/20 zig-zag's smaller drift and
    // yaw rate lie off the 35/35 one's orbit (98 % measured).
    let outside = t.outside_identification_range.unwrap();
    assert!(outside > 0.9, "{outside}");
    // The model file is the GP's, and the figures draw it.
    let model = std::fs::read_to_string(dir.path().join("cases").join(&case.id).join("model.toml"))
        .unwrap();
    assert!(model.contains("kind = \"sparse-gp\""));
    let heading =
        std::fs::read_to_string(dir.path().join("figures").join("heading_zz20_20_ps.svg")).unwrap();
    assert!(
        heading.contains("sparse-gp d_gen=0.96 4 OS"),
        "legend of the GP case"
    );
    let summary = std::fs::read_to_string(dir.path().join("summary.csv")).unwrap();
    assert!(
        summary.contains(",none,sparse-gp,none,"),
        "set, estimator, solver columns"
    );
}

/// The summary's `epsilon_X/Y/N` columns hold the ε each SVR fit used, the value its model file
/// records: given, the default share of each target's RMS, or the cross-validation's choice. Before
/// 0.2.1 the summary had only C (`hyper_*`), and a tuned ε was in the model files alone.
#[test]
fn the_summary_holds_the_epsilon_every_svr_fit_used() {
    let study = load_study(&common::root().join(FIXTURES).join("svr_epsilon.toml")).unwrap();
    assert_eq!(study.cases.len(), 4);
    let dir = tempfile::tempdir().unwrap();
    let results = run_and_write(&study, dir.path(), 2, false, false)
        .unwrap()
        .0;
    assert!(
        results
            .iter()
            .all(|r| r.status == shipid_study::CaseStatus::Ok),
        "{results:?}"
    );
    let summary = Table::read_csv(&dir.path().join("summary.csv")).unwrap();
    let cell = |name: &str, row: usize| summary.column(name).unwrap().cell(row);
    let hyper_of_model = |case: &str| -> toml::Table {
        let text = std::fs::read_to_string(dir.path().join("cases").join(case).join("model.toml"))
            .unwrap();
        let model: toml::Table = toml::from_str(&text).unwrap();
        model["estimator"]["hyper"].as_table().unwrap().clone()
    };
    let mut epsilons = Vec::new();
    for (row, case) in study.cases.iter().enumerate() {
        assert_eq!(
            cell("case", row),
            case.id,
            "one test recording: one row per case"
        );
        let per_dof: Vec<String> = ["X", "Y", "N"]
            .iter()
            .map(|k| cell(&format!("epsilon_{k}"), row))
            .collect();
        if case.estimator.name == "lsq" {
            assert_eq!(per_dof, ["", "", ""], "LSQ has no ε");
            continue;
        }
        let hyper = hyper_of_model(&case.id);
        let shown: Vec<f64> = per_dof.iter().map(|v| v.parse().unwrap()).collect();
        for (k, shown) in ["X", "Y", "N"].iter().zip(&shown) {
            let used = hyper[&format!("epsilon_{k}")].as_float().unwrap();
            assert_eq!(*shown, used, "{} epsilon_{k}", case.id);
        }
        epsilons.push(shown);
    }
    // Given: the same ε for every DOF. Default and tuned: per DOF, from each target's scale, so
    // X, Y and N differ; and the tuned choice is not the default everywhere.
    assert_eq!(epsilons[0], [2e-6; 3]);
    for e in &epsilons[1..] {
        assert!(e[0] != e[1] && e[1] != e[2], "{e:?}");
    }
    assert_ne!(epsilons[1], epsilons[2]);
}

/// Every case of `study` with one test row per test recording, each with its own MRAE (k / 1000 for
/// the k-th row, so no two cells print alike), as a run would give them.
fn fabricated_results(study: &shipid_study::Study) -> Vec<shipid_study::CaseResult> {
    use shipid_study::runner::{TestRow, TestStatus};
    let mut k = 0;
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
            tests: study
                .tests
                .iter()
                .map(|t| {
                    k += 1;
                    TestRow {
                        test: t.clone(),
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
                        mrae: Some(k as f64 / 1000.0),
                        outside_identification_range: None,
                        bands: Default::default(),
                    }
                })
                .collect(),
        })
        .collect()
}

/// The body cells of a markdown table (header and rule left out), without the row labels.
fn pivot_cells(md: &str) -> Vec<String> {
    md.lines()
        .skip(2)
        .flat_map(|l| {
            let cells: Vec<String> = l
                .trim_matches('|')
                .split('|')
                .map(|c| c.trim().to_string())
                .collect();
            cells.into_iter().skip(1)
        })
        .filter(|c| !c.is_empty())
        .collect()
}

/// Every shipped study (`studies/*.toml`) as `shipid table` loads it; the HSVA one on recordings
/// imported from ../shared (skipped visibly without them).
fn shipped_studies(scratch: &Path) -> Vec<shipid_study::Study> {
    let mut paths: Vec<_> = std::fs::read_dir(common::root().join("studies"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    paths.sort();
    let mut studies = Vec::new();
    for path in paths {
        let text = std::fs::read_to_string(&path).unwrap();
        let path = if text.contains("kvlcc2-hsva/imported") {
            let Some(source) = common::shared_hsva("hsva-parametric.toml's default pivot") else {
                continue;
            };
            let data = common::import_hsva(&source, &scratch.join("hsva"));
            let copy = scratch.join(path.file_name().unwrap());
            let text = text.replace(
                "../data/kvlcc2-hsva/imported/dataset.toml",
                data.to_str().unwrap(),
            );
            std::fs::write(&copy, text).unwrap();
            copy
        } else {
            path
        };
        studies.push(load_study(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display())));
    }
    studies
}

/// Regression (issue 25): the default pivot `window,test,mrae` put all cases of a window in one row,
/// so every cell showed the last case's MRAE and nine of ten cases of `estimators` vanished. Now
/// every case × test of every shipped study has its own cell, and an explicit pivot that would put
/// cases together is refused, naming them.
#[test]
fn every_shipped_studys_default_pivot_shows_every_case_and_test_once() {
    let scratch = tempfile::tempdir().unwrap();
    let studies = shipped_studies(scratch.path());
    assert!(studies.len() >= 6, "{} studies", studies.len());
    for study in &studies {
        let summary = shipid_study::tables::summary_table(study, &fabricated_results(study));
        let md = shipid_study::tables::summary_pivot(&summary, None)
            .unwrap_or_else(|e| panic!("{}: {e}", study.name));
        let mut cells = pivot_cells(&md);
        let n = study.cases.len() * study.tests.len();
        let mut expected: Vec<String> = (1..=n)
            .map(|k| format!("{:.1} %", k as f64 / 10.0))
            .collect();
        cells.sort();
        expected.sort();
        assert_eq!(cells, expected, "{}:\n{md}", study.name);
        if study.cases.len() > 1
            && study
                .cases
                .iter()
                .all(|c| c.window == study.cases[0].window)
        {
            let err = shipid_study::tables::summary_pivot(&summary, Some("window,test,mrae"))
                .unwrap_err()
                .to_string();
            let expected = format!(
                "{} rows fall into one cell (window `{}`, test `{}`), so all but the last would vanish: {}, {}",
                study.cases.len(),
                study.cases[0].window.label(),
                study.tests[0],
                study.cases[0].id,
                study.cases[1].id
            );
            assert!(err.starts_with(&expected), "{}: {err}", study.name);
        }
    }
}

#[test]
fn table_refuses_a_pivot_that_merges_cases_naming_them_and_the_pivot_that_separates_them() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let study = format!("{FIXTURES}/small.toml");
    common::shipid_ok(&["run", &study, "--out", out.to_str().unwrap()]);
    let ids: Vec<String> = small_study().cases.iter().map(|c| c.id.clone()).collect();
    let merged = common::shipid(&[
        "table",
        &study,
        "--out",
        out.to_str().unwrap(),
        "--pivot",
        "set,test,mrae",
    ]);
    let err = String::from_utf8_lossy(&merged.stderr);
    assert_eq!(merged.status.code(), Some(2), "{err}");
    assert!(
        err.contains(&format!(
            "3 rows fall into one cell (set `reduced32`, test `zz20_20_ps.csv`), so all but the last would vanish: {}, {}, {}",
            ids[0], ids[1], ids[2]
        )),
        "{err}"
    );
    assert!(
        err.contains("to tell them apart: --pivot window+set,test,mrae"),
        "{err}"
    );
    let shown = common::shipid_ok(&["table", &study, "--out", out.to_str().unwrap()]);
    let md = String::from_utf8_lossy(&shown.stdout);
    assert_eq!(pivot_cells(&md).len(), 3 * 2, "{md}");
}

fn lines_of(path: &Path) -> Vec<String> {
    // fit_time_s is the one column that differs between runs of the same cases (the measured time).
    let t = Table::read_csv(path).unwrap();
    let t = without_timing(&t);
    (0..t.rows())
        .map(|i| {
            t.columns
                .iter()
                .map(|(_, c)| c.cell(i))
                .collect::<Vec<_>>()
                .join(",")
        })
        .collect()
}

fn spawn_run(study: &Path, out: &Path, jobs: &str) -> std::process::Child {
    std::process::Command::new(env!("CARGO_BIN_EXE_shipid"))
        .args([
            "run",
            study.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--jobs",
            jobs,
        ])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap()
}

fn finished_cases(out: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<_> = std::fs::read_dir(out.join("cases"))
        .map(|d| {
            d.flatten()
                .filter_map(|e| {
                    let p = e.path().join("result.json");
                    std::fs::read(&p).ok().map(|b| (p.display().to_string(), b))
                })
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Regression (issue 25): two runs into one folder shared fixed temporary names and killed each
/// other, sometimes leaving no tables, exit 1. The second now refuses at once (exit 2), naming the
/// lock and the first run's pid; the first completes with every table.
#[test]
fn a_second_run_into_the_same_folder_refuses_and_the_first_completes() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let study = common::root().join("studies/gp.toml");
    let first = spawn_run(&study, &out, "1");
    let lock = out.join(shipid_study::lock::LOCK_FILE);
    while !std::fs::read_to_string(&lock).is_ok_and(|t| t.starts_with("pid ")) {
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let second = common::shipid(&[
        "run",
        study.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&second.stderr);
    assert_eq!(second.status.code(), Some(2), "{err}");
    assert_eq!(
        err.trim(),
        format!(
            "error: {}: another shipid run (pid {}) is writing into this folder; wait for it to finish or give another --out",
            lock.display(),
            first.id()
        )
    );
    let first_out = first.wait_with_output().unwrap();
    assert!(
        first_out.status.success(),
        "{}",
        String::from_utf8_lossy(&first_out.stderr)
    );
    assert!(!lock.exists(), "released at the end");
    let cases = load_study(&study).unwrap().cases.len();
    assert_eq!(lines_of(&out.join("summary.csv")).len(), cases * 6);
    assert_eq!(finished_cases(&out).len(), cases);
}

/// A run killed with `kill -9` halfway leaves its lock file and some finished cases; the next run
/// takes the lock over (saying so), keeps the finished cases as they were (their result.json,
/// measured fit times included, byte for byte: not recomputed) and ends with the tables of a clean
/// run (equal cell for cell but for the measured fit times).
#[test]
fn a_run_killed_halfway_resumes_without_recomputing_and_ends_with_a_clean_runs_tables() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let study = common::root().join("studies/gp.toml");
    let cases = load_study(&study).unwrap().cases.len();
    let mut victim = spawn_run(&study, &out, "1");
    while finished_cases(&out).len() < 3 {
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    victim.kill().unwrap();
    victim.wait().unwrap();
    let before = finished_cases(&out);
    assert!(
        before.len() < cases,
        "killed halfway: {} of {cases} cases finished",
        before.len()
    );
    assert!(out.join(shipid_study::lock::LOCK_FILE).exists());
    assert!(!out.join("summary.csv").exists());
    let resumed = common::shipid(&[
        "run",
        study.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&resumed.stderr);
    assert!(resumed.status.success(), "{err}");
    assert!(
        err.contains(&format!(
            "taken over from pid {}, which ended without releasing it (killed?)",
            victim.id()
        )),
        "{err}"
    );
    assert!(
        err.contains(&format!(
            "{} finished earlier, {} to run",
            before.len(),
            cases - before.len()
        )),
        "{err}"
    );
    let after: BTreeMap<String, Vec<u8>> = finished_cases(&out).into_iter().collect();
    assert_eq!(after.len(), cases);
    for (path, bytes) in &before {
        assert_eq!(&after[path], bytes, "{path} was recomputed");
    }
    let clean = dir.path().join("clean");
    common::shipid_ok(&[
        "run",
        study.to_str().unwrap(),
        "--out",
        clean.to_str().unwrap(),
    ]);
    for stem in ["summary", "coefficients", "diagnostics"] {
        let name = format!("{stem}.csv");
        assert_eq!(
            lines_of(&out.join(&name)),
            lines_of(&clean.join(&name)),
            "{name}"
        );
    }
}

#[test]
fn jobs_0_is_refused_by_every_command_that_has_jobs() {
    let study = format!("{FIXTURES}/small.toml");
    for command in [
        vec![
            "run",
            &study,
            "--jobs",
            "0",
            "--out",
            "/tmp/shipid-never-written",
        ],
        vec![
            "check",
            &study,
            "--jobs",
            "0",
            "--reference",
            "/tmp/shipid-never-written",
        ],
    ] {
        common::check_exit(
            &command,
            2,
            "invalid value '0' for '--jobs <JOBS>': give at least 1 parallel case",
        );
    }
    assert!(!Path::new("/tmp/shipid-never-written").exists());
}

/// Regression: a case's stored configuration named its data set by the path as typed, so a rerun from
/// another directory recomputed everything, while a rerun on changed recordings at the same path
/// silently reused results of the old data. Now the data are named by content.
#[test]
fn finished_cases_are_reused_for_the_same_data_from_anywhere_and_never_for_changed_data() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    std::fs::create_dir_all(&data).unwrap();
    for e in std::fs::read_dir(common::root().join("data/kvlcc2-mmg")).unwrap() {
        let p = e.unwrap().path();
        std::fs::copy(&p, data.join(p.file_name().unwrap())).unwrap();
    }
    let study = dir.path().join("study.toml");
    std::fs::write(
        &study,
        "name = \"one\"\ndataset = \"data/dataset.toml\"\nsets = [\"reduced32\"]\n[training]\nrecordings = [[\"zz35_35_ps.csv\"]]\novershoots = [4]\n[[estimator]]\nname = \"lsq\"\n[test]\nrecordings = [\"zz20_20_ps.csv\"]\n",
    )
    .unwrap();
    let out = dir.path().join("out");
    let run_from = |cwd: &Path, study: &str| {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_shipid"))
            .args(["run", study, "--out", out.to_str().unwrap()])
            .current_dir(cwd)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr).to_string();
        assert!(o.status.success(), "{err}");
        err
    };
    assert!(run_from(dir.path(), "study.toml").contains("0 finished earlier, 1 to run"));
    let elsewhere = run_from(&common::root(), study.to_str().unwrap());
    assert!(
        elsewhere.contains("1 finished earlier, 0 to run"),
        "{elsewhere}"
    );
    let test = data.join("zz20_20_ps.csv");
    let text = std::fs::read_to_string(&test).unwrap();
    std::fs::write(&test, format!("# edited\n{text}")).unwrap();
    let changed = run_from(dir.path(), "study.toml");
    assert!(
        changed.contains("0 finished earlier, 1 to run"),
        "{changed}"
    );
}

/// Regression: an interrupted `check` (Ctrl-C) left its scratch run under the temporary folder:
/// `Drop` does not run when a signal ends the process.
#[cfg(unix)]
#[test]
fn an_interrupted_check_removes_its_scratch_folder() {
    let tmp = tempfile::tempdir().unwrap();
    let scratch = || {
        std::fs::read_dir(tmp.path())
            .unwrap()
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().starts_with("shipid-check-"))
            .count()
    };
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_shipid"))
        .args([
            "check",
            "studies/estimators.toml",
            "--reference",
            "results/reference/estimators",
        ])
        .current_dir(common::root())
        .env("TMPDIR", tmp.path())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    while scratch() == 0 {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the check ended before its scratch folder was seen"
        );
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    let kill = std::process::Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let out = child.wait_with_output().unwrap();
    assert_eq!(
        out.status.code(),
        Some(130),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(scratch(), 0, "the scratch folder is left behind");
}
