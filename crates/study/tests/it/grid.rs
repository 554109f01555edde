//! The grid's checks before any case runs: one id per case, one spelling per set file, one order per
//! training combination, the run's size counted from the axes, and time windows against the
//! recordings they cut (tester's findings A4, A6, A10, H3, H4).

use std::path::Path;

use shipid_study::study::load_study;
use shipid_study::{StudyError, load_study_within};

use super::study_file;

/// The first fault of a study body (whose data set line `study_file` adds), or its case ids.
fn load(dir_setup: impl FnOnce(&Path), body: &str) -> Result<Vec<String>, String> {
    let (dir, path) = study_file(body);
    dir_setup(dir.path());
    load_study(&path)
        .map(|s| s.cases.iter().map(|c| c.id.clone()).collect())
        .map_err(|e| e.to_string())
}

fn set_file(dir: &Path, name: &str) {
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../model/sets/reduced32.toml");
    let to = dir.join(name);
    std::fs::create_dir_all(to.parent().unwrap()).unwrap();
    std::fs::copy(shipped, to).unwrap();
}

fn body(sets: &str, training: &str, extra: &str) -> String {
    format!(
        "name = \"g\"\nsets = {sets}\n{extra}\n[training]\nrecordings = {training}\n\
         [[estimator]]\nname = \"lsq\"\n[test]\nrecordings = [\"zz20_20_ps.csv\"]\n"
    )
}

#[test]
fn equivalent_set_paths_are_refused_as_one_set_named_twice() {
    for (sets, second) in [
        (r#"["myset.toml", "./myset.toml"]"#, "sets[1]"),
        (
            r#"["myset.toml", "reduced32", "sub/../myset.toml"]"#,
            "sets[2]",
        ),
    ] {
        let err = load(
            |d| {
                set_file(d, "myset.toml");
                std::fs::create_dir_all(d.join("sub")).unwrap();
            },
            &body(sets, r#"[["zz35_35_ps.csv"]]"#, ""),
        )
        .unwrap_err();
        assert!(
            err.contains(second) && err.contains("same file as sets[0]"),
            "{err}"
        );
    }
}

#[test]
fn a_training_combination_in_another_order_is_refused_as_a_repeat() {
    let err = load(
        |_| {},
        &body(
            r#"["reduced32"]"#,
            r#"[["zz35_35_ps.csv", "tc35_ps.csv"], ["tc35_ps.csv", "zz35_35_ps.csv"]]"#,
            "",
        ),
    )
    .unwrap_err();
    assert!(
        err.contains("training.recordings[1]") && err.contains("another order"),
        "{err}"
    );
}

#[test]
fn two_cases_whose_ids_collide_are_refused_naming_both() {
    // The two names sanitise alike and their FNV-1a hashes agree in the 32 bits of the id.
    let (a, b) = ("s ;]'=.toml", "s_!%@!.toml");
    let err = load(
        |d| {
            set_file(d, a);
            set_file(d, b);
        },
        &body(&format!("[{a:?}, {b:?}]"), r#"[["zz35_35_ps.csv"]]"#, ""),
    )
    .unwrap_err();
    assert!(
        err.contains("share the id") && err.contains(a) && err.contains(b),
        "{err}"
    );
}

#[test]
fn a_case_folder_never_starts_with_a_dot() {
    let ids = load(
        |d| {
            set_file(d, ".hidden.toml");
            set_file(d, "up/x.toml");
        },
        &body(
            r#"[".hidden.toml", "../up/x.toml"]"#,
            r#"[["zz35_35_ps.csv"]]"#,
            "",
        ),
    );
    // `../up/x.toml` is beside the study's folder, not in it: only the first exists.
    let err = ids.unwrap_err();
    assert!(err.contains("sets[1]"), "{err}");
    let ids = load(
        |d| set_file(d, ".hidden.toml"),
        &body(r#"[".hidden.toml"]"#, r#"[["zz35_35_ps.csv"]]"#, ""),
    )
    .unwrap();
    assert!(ids.iter().all(|id| !id.starts_with('.')), "{ids:?}");
}

#[test]
fn a_huge_grid_is_refused_from_its_axes_without_building_its_cases() {
    // 4000 λ × 2500 windows: ten million cases, refused as the product of the axes' lengths.
    let lambdas: Vec<String> = (1..=4000).map(|k| format!("{k}e-7")).collect();
    let windows: Vec<String> = (0..2500)
        .map(|k| format!("[{}.0, {}.0]", k % 50, 100 + k / 50))
        .collect();
    let text = format!(
        "name = \"huge\"\nsets = [\"reduced32\"]\n[training]\nrecordings = [[\"zz35_35_ps.csv\"]]\n\
         windows = [{}]\n[[estimator]]\nname = \"ridge\"\nlambda = [{}]\n[test]\nrecordings = \"all\"\n",
        windows.join(", "),
        lambdas.join(", ")
    );
    let (_dir, path) = study_file(&text);
    match load_study_within(&path, false) {
        Err(e @ StudyError::TooLarge { .. }) => {
            assert!(e.is_bad_input());
            let msg = e.to_string();
            assert!(
                msg.contains("10000000 cases (1 set(s) × 4000 estimator setting(s) × 1 training combination(s) × 2500 window(s)), more than 5000: nothing was run; give --allow-large"),
                "{msg}"
            );
        }
        Err(e) => panic!("{e}"),
        Ok(s) => panic!("{} cases accepted", s.cases.len()),
    }
}

/// Also the regression of the refusal that said "× replicates × tests" without their counts.
#[test]
fn bootstrap_replicates_count_in_the_size_of_a_run() {
    let lambdas: Vec<String> = (1..=20).map(|k| format!("{k}e-6")).collect();
    let text = format!(
        "name = \"boot\"\nbands = 0.9\nbootstrap = 10000\nsets = [\"reduced32\"]\n[training]\n\
         recordings = [[\"zz35_35_ps.csv\"]]\n[[estimator]]\nname = \"ridge\"\nlambda = [{}]\n\
         [test]\nrecordings = \"all\"\n",
        lambdas.join(", ")
    );
    let (_dir, path) = study_file(&text);
    // 20 cases × 10 000 replicates × 6 tests.
    let err = load_study_within(&path, false).err().unwrap().to_string();
    assert!(
        err.contains("1200000 bootstrap replicate simulations (20 cases (")
            && err.contains(" × 10000 replicates × 6 tests), more than 1000000"),
        "{err}"
    );
    assert_eq!(load_study_within(&path, true).unwrap().cases.len(), 20);
}

fn windows_study(windows: &str) -> Result<shipid_study::Study, String> {
    let (_dir, path) = study_file(&format!(
        "name = \"w\"\nsets = [\"reduced32\"]\n[training]\nrecordings = [[\"zz35_35_ps.csv\"]]\n\
         windows = {windows}\n[[estimator]]\nname = \"lsq\"\n[test]\nrecordings = [\"zz20_20_ps.csv\"]\n"
    ));
    load_study(&path).map_err(|e| e.to_string())
}

#[test]
fn a_window_outside_the_recording_is_refused_or_warned_with_the_span_fitted() {
    for (windows, window, why) in [
        (
            "[[-10.0, 1e9]]",
            "[-10, 1000000000] is not a time window",
            "before 0 s",
        ),
        (
            "[[0.0, 100.0], [50.0, 50.0]]",
            "[50, 50] is not a time window",
            "(window 2,",
        ),
        ("[[500.0, 600.0]]", "[500, 600] (window 1", "too few to fit"),
        ("[[0.0, 0.05]]", "[0, 0.05] (window 1", "too few to fit"),
    ] {
        let err = windows_study(windows).err().unwrap_or_default();
        assert!(
            err.contains("key `training.windows`") && err.contains(window) && err.contains(why),
            "{windows}: {err}"
        );
    }
    let study = windows_study("[[0.0, 100.0], [10.0, 1e7]]").unwrap();
    assert_eq!(study.warnings.len(), 1, "{:?}", study.warnings);
    let w = &study.warnings[0];
    assert!(
        w.contains("training.windows[1]") && w.contains("zz35_35_ps.csv") && w.contains("10–480 s"),
        "{w}"
    );
}

/// Regression: `[[0, 120, 5]]` (and `[[0, 120, "x"]]`) ran as `[0, 120]`, the extras dropped.
#[test]
fn a_time_window_with_extra_elements_is_refused_naming_the_key() {
    for (windows, given) in [
        ("[[0, 120, 5]]", "not 3 values"),
        ("[[0, 120, 5, 6, 7]]", "not 5 values"),
        ("[[0, 120, \"x\"]]", "not 3 values"),
        ("[[120]]", "not 1 value"),
    ] {
        let err = windows_study(windows).err().unwrap_or_default();
        assert!(
            err.contains("key `training.windows`: a time window is [start, end] in seconds")
                && err.contains(given),
            "{windows}: {err}"
        );
    }
}

/// Regression: `windows = [[0, 1e300]]` ran, and its 301 digits landed in ids, tables and the
/// report; `shipid fit --window` refuses times beyond a recording's largest `t`.
#[test]
fn a_window_beyond_the_largest_recorded_time_is_refused_as_fit_window_refuses_it() {
    for windows in ["[[0, 1e300]]", "[[0, 100000001]]"] {
        let err = windows_study(windows).err().unwrap_or_default();
        assert!(
            err.contains("key `training.windows`")
                && err.contains("times beyond 1e8 s")
                && err.len() < 300,
            "{windows}: {err}"
        );
    }
    assert!(windows_study("[[0, 1e8]]").is_ok());
}

/// Regression: `-0.0` passed the repeat checks as a value of its own: `lambda = [0.0, -0.0]` gave
/// two cases of one fit (`l0e0`, `l-0e0`), a window `[-0.0, 120]` one labelled `-0-120 s`.
#[test]
fn negative_zero_is_zero_so_it_repeats_zero() {
    let err = windows_study("[[0, 120], [-0.0, 120]]")
        .err()
        .unwrap_or_default();
    assert!(
        err.contains("key `training.windows`: value 2 repeats value 1"),
        "{err}"
    );
    let ids = load(
        |_| {},
        &body(r#"["reduced32"]"#, r#"[["zz35_35_ps.csv"]]"#, "")
            .replace("name = \"lsq\"", "name = \"ridge\"\nlambda = [0.0, -0.0]"),
    );
    let err = ids.err().unwrap_or_default();
    assert!(
        err.contains("key `estimator[0].lambda`: a value appears twice in the grid (0)"),
        "{err}"
    );
    let ids = load(
        |_| {},
        &body(r#"["reduced32"]"#, r#"[["zz35_35_ps.csv"]]"#, "")
            .replace("name = \"lsq\"", "name = \"ridge\"\nlambda = -0.0"),
    )
    .unwrap();
    assert!(ids[0].contains("-l0e0_"), "{ids:?}");
    let study = windows_study("[[-0.0, 120]]").unwrap();
    assert!(
        study.cases[0].id.contains("_t0-120-"),
        "{}",
        study.cases[0].id
    );
}

/// Regression: a 300-character name passed the checks and the run failed with exit 1 and the
/// OS's "File name too long" twice, when it made its results folder.
#[test]
fn a_study_name_too_long_for_a_folder_is_refused_naming_the_key() {
    let long = body(r#"["reduced32"]"#, r#"[["zz35_35_ps.csv"]]"#, "")
        .replace("name = \"g\"", &format!("name = \"{}\"", "a".repeat(300)));
    let err = load(|_| {}, &long).unwrap_err();
    assert!(
        err.contains("key `name`: 300 characters") && err.contains("at most 100"),
        "{err}"
    );
    let at_most = body(r#"["reduced32"]"#, r#"[["zz35_35_ps.csv"]]"#, "")
        .replace("name = \"g\"", &format!("name = \"{}\"", "a".repeat(100)));
    assert!(load(|_| {}, &at_most).is_ok());
}

/// Regression: the summary's `training` column joins a combination's names with `+`, so
/// `["a+b.csv"]` and `["a", "b.csv"]` both read `a+b.csv`.
#[test]
fn a_training_recording_whose_name_holds_a_plus_is_refused() {
    let err = load(
        |_| {},
        &body(
            r#"["reduced32"]"#,
            r#"[["zz35_35_ps.csv"], ["a+b.csv"]]"#,
            "",
        ),
    )
    .unwrap_err();
    assert!(
        err.contains("key `training.recordings[1][0]`: `a+b.csv` holds a `+`"),
        "{err}"
    );
}
