//! `shipid inverse` as a user runs it: bad targets are exit 2 with the key named; a small run writes
//! its tables and figures.

use crate::common;

use crate::common::check_exit;

#[test]
fn bad_targets_exit_2_and_name_the_key() {
    check_exit(
        &[
            "inverse",
            "crates/shipid/tests/fixtures/inverse/negative_length.toml",
        ],
        2,
        "lpp_m = -320",
    );
    check_exit(
        &[
            "inverse",
            "crates/shipid/tests/fixtures/inverse/zero_index.toml",
        ],
        2,
        "index t1_p20 = 0",
    );
    check_exit(
        &["inverse", "no/such/targets.toml"],
        2,
        "no/such/targets.toml",
    );
}

#[test]
fn a_small_run_writes_tables_and_figures() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().to_str().expect("utf-8 path");
    let run = common::shipid(&[
        "inverse",
        "data/paper003/targets.toml",
        "--samples",
        "200",
        "--modes",
        "6",
        "--resimulate",
        "5",
        "--refine-evals",
        "10",
        "--out",
        out,
    ]);
    let stdout = String::from_utf8_lossy(&run.stdout);
    // 0, or 1 when a target motion cannot be re-simulated: both are completed runs.
    assert!(
        matches!(run.status.code(), Some(0 | 1)),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(stdout.contains("6 modes reach 95 %"), "{stdout}");
    for f in [
        "modes.csv",
        "modes.svg",
        "kvlcc2/summary.md",
        "kvlcc2/motions.svg",
    ] {
        assert!(dir.path().join(f).is_file(), "{f} missing");
    }
    // Regression: the motions figure had no legend saying which colour is which. (A network answer
    // that is an unphysical ship has no curve, so the legend is looked for in both targets' figures.)
    let motions: String = ["kvlcc2/motions.svg", "virtual/motions.svg"]
        .iter()
        .map(|f| std::fs::read_to_string(dir.path().join(f)).unwrap())
        .collect();
    for label in ["weights (paper 003)", "refined by re-simulation"] {
        assert!(motions.contains(label), "legend entry {label}");
    }
    let csv = std::fs::read_to_string(dir.path().join("virtual/indexes.csv")).expect("written");
    // Header + 9 indexes × 3 motions, + 9 × 3 refined rows.
    assert_eq!(csv.lines().count(), 1 + 27 + 27, "{csv}");
    assert!(csv.lines().any(|l| l.starts_with("M02 refined,t2 U/L,11,")));
}
