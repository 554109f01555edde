//! Tester's findings A2 (stale figures), A7 (figure names colliding) and A9 (cases dropped silently).

use std::path::{Path, PathBuf};

use shipid_figures::write_figures;
use shipid_study::tables::write_tables;
use shipid_study::{Study, load_study, run_study};

/// A one-case-per-set study in a fresh folder, run into `<dir>/out`.
fn run(sets: &[&str], set_files: &[&str]) -> (tempfile::TempDir, Study, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../model/sets/reduced32.toml");
    for f in set_files {
        let to = dir.path().join(f);
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::copy(&shipped, to).unwrap();
    }
    let dataset = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/kvlcc2-mmg/dataset.toml");
    let path = dir.path().join("study.toml");
    std::fs::write(
        &path,
        format!(
            "name = \"figs\"\ndataset = {:?}\nsets = {sets:?}\n[training]\n\
             recordings = [[\"zz35_35_ps.csv\"]]\novershoots = [4]\n[[estimator]]\nname = \"lsq\"\n\
             [test]\nrecordings = [\"zz20_20_ps.csv\"]\n",
            dataset.display().to_string()
        ),
    )
    .unwrap();
    let study = load_study(&path).unwrap();
    let out = dir.path().join("out");
    let results = run_study(&study, &out, 1, false, false).unwrap();
    write_tables(&study, &results, &out).unwrap();
    (dir, study, out)
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn sets_whose_names_sanitise_alike_get_figures_of_their_own() {
    let (_dir, study, out) = run(&["a/b.toml", "a_b.toml"], &["a/b.toml", "a_b.toml"]);
    let report = write_figures(&study, &out);
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    let coefficient_figures: Vec<String> = names(&out.join("figures"))
        .into_iter()
        .filter(|n| n.starts_with("coefficients_"))
        .collect();
    assert_eq!(coefficient_figures.len(), 2, "{coefficient_figures:?}");
    // A name that is already safe keeps its plain file name.
    assert!(names(&out.join("figures")).contains(&"trajectories_zz20_20_ps.svg".to_string()));
}

#[test]
fn figures_of_an_earlier_run_are_removed_and_the_users_files_kept() {
    let (_dir, study, out) = run(&["reduced32"], &[]);
    let figures = out.join("figures");
    std::fs::create_dir_all(&figures).unwrap();
    // Left by a run with bands and by another study; beside them the user's own files.
    for stale in [
        "bands_zz20_20_ps.svg",
        "coefficients_full74.svg",
        "forces_old_case_tc35_ps.svg",
    ] {
        std::fs::write(figures.join(stale), "<svg/>").unwrap();
    }
    for own in ["my_sketch.svg", "notes.txt"] {
        std::fs::write(figures.join(own), "mine").unwrap();
    }
    let report = write_figures(&study, &out);
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    assert_eq!(report.removed.len(), 3, "{:?}", report.removed);
    let left = names(&figures);
    for stale in [
        "bands_zz20_20_ps.svg",
        "coefficients_full74.svg",
        "forces_old_case_tc35_ps.svg",
    ] {
        assert!(!left.contains(&stale.to_string()), "{left:?}");
    }
    assert!(left.contains(&"my_sketch.svg".into()) && left.contains(&"notes.txt".into()));
    assert!(
        left.contains(&"coefficients_reduced32.svg".into()),
        "{left:?}"
    );
}

#[test]
fn a_case_without_its_model_or_with_a_corrupt_result_is_named_in_the_warnings() {
    let (_dir, study, out) = run(&["reduced32", "full68"], &[]);
    let (a, b) = (&study.cases[0].id, &study.cases[1].id);
    std::fs::remove_file(out.join("cases").join(a).join("model.toml")).unwrap();
    std::fs::write(out.join("cases").join(b).join("result.json"), "{ not json").unwrap();
    let report = write_figures(&study, &out);
    assert_eq!(report.warnings.len(), 2, "{:?}", report.warnings);
    assert!(report.warnings[0].contains(a.as_str()) && report.warnings[0].contains("model.toml"));
    assert!(report.warnings[1].contains(b.as_str()) && report.warnings[1].contains("result.json"));
}
