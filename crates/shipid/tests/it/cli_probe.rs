//! Regressions of the command-line probe (findings A6, A7): what a file written by the binary records
//! about how it was made.

use std::path::Path;
use std::process::Command;

use crate::common;

/// Run the binary in `dir` and require success.
fn shipid_in(dir: &Path, args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_shipid"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("the shipid binary runs");
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{args:?}: {err}");
    err
}

/// Finding A6: the CSV's provenance line left out --dt, --duration, --wind and --current, so the
/// file's own record of how it was made could not reproduce it.
#[test]
fn simulate_csv_provenance_names_every_option_that_shapes_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("s.csv");
    common::shipid_ok(&[
        "simulate",
        "mmg:kvlcc2",
        "--manoeuvre",
        "zigzag:20/20:port",
        "--dt",
        "0.1",
        "--duration",
        "30",
        "--wind",
        "5,90",
        "--current",
        "0.1,0",
        "--propeller-rate",
        "8",
        "--out",
        csv.to_str().unwrap(),
    ]);
    let text = std::fs::read_to_string(&csv).unwrap();
    let first = text.lines().next().unwrap();
    for piece in [
        "--manoeuvre zigzag:20/20:port",
        "--dt 0.1",
        "--duration 30",
        "--wind 5,90",
        "--current 0.1,0",
        "--propeller-rate 8",
    ] {
        assert!(first.contains(piece), "{piece:?} not in {first:?}");
    }
}

/// Finding A6: the duration as simulated, not as asked, is the one the provenance records.
#[test]
fn simulate_csv_provenance_gives_the_duration_simulated() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("s.csv");
    common::shipid_ok(&[
        "simulate",
        "mmg:kvlcc2",
        "--manoeuvre",
        "turning:35:port",
        "--dt",
        "0.4",
        "--duration",
        "1.1",
        "--out",
        csv.to_str().unwrap(),
    ]);
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(
        text.lines()
            .next()
            .unwrap()
            .contains("--dt 0.4 --duration 1.2"),
        "{}",
        text.lines().next().unwrap()
    );
}

/// Finding A7: run.json stored `study_file` as typed, relative to the working directory of `shipid
/// run`, and `report` printed it verbatim from anywhere; it is stored absolute.
#[test]
fn run_json_names_the_study_file_whatever_folder_run_was_started_in() {
    let top = tempfile::tempdir().unwrap();
    let work = top.path().join("work");
    std::fs::create_dir_all(&work).unwrap();
    let fixture = common::root().join("crates/shipid/tests/fixtures/studies/small.toml");
    let dataset =
        std::fs::canonicalize(common::root().join("data/kvlcc2-mmg/dataset.toml")).unwrap();
    let text = std::fs::read_to_string(fixture).unwrap().replace(
        "../../../../../data/kvlcc2-mmg/dataset.toml",
        dataset.to_str().unwrap(),
    );
    std::fs::write(work.join("s.toml"), text).unwrap();
    shipid_in(&work, &["run", "s.toml", "--out", "../out"]);
    let record: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(top.path().join("out/run.json")).unwrap())
            .unwrap();
    let stored = Path::new(record["study_file"].as_str().unwrap());
    assert!(stored.is_absolute(), "{}", stored.display());
    assert_eq!(
        std::fs::canonicalize(stored).unwrap(),
        std::fs::canonicalize(work.join("s.toml")).unwrap()
    );
    // The page rebuilt from another folder names the same file.
    shipid_in(
        Path::new("/"),
        &["report", top.path().join("out").to_str().unwrap()],
    );
    let html = std::fs::read_to_string(top.path().join("out/report.html")).unwrap();
    assert!(html.contains(&stored.display().to_string()));
}
