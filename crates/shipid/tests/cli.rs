//! The command line as users and other tools see it: names, JSON keys, exit codes, one-sentence errors.

mod common;

use serde_json::Value;

fn check_exit(args: &[&str], code: i32, stderr_has: &str) {
    let out = common::shipid(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "{args:?}: {err}");
    assert!(err.contains(stderr_has), "{args:?}: stderr was {err}");
}

#[test]
fn bad_input_exits_with_2_and_names_the_problem() {
    check_exit(
        &["metrics", "no/such/dataset.toml"],
        2,
        "error: no/such/dataset.toml: file not found",
    );
    check_exit(
        &[
            "metrics",
            "crates/io/tests/fixtures/bad_input/unknown_key.toml",
        ],
        2,
        "unknown_key.toml:2:1: key `colour`: unknown field `colour`",
    );
    check_exit(
        &["simulate", "mmg:kvlcc2", "--manoeuvre", "zigzag:20:port"],
        2,
        "zig-zag angles must be written rudder/check",
    );
    check_exit(
        &["simulate", "mmg:other", "--manoeuvre", "turning:35:port"],
        2,
        "unknown model `mmg:other`",
    );
    check_exit(
        &[
            "simulate",
            "mmg:kvlcc2",
            "--manoeuvre",
            "turning:35:port",
            "--dt=-1",
        ],
        2,
        "invalid simulation option dt_s = -1",
    );
    check_exit(&["frobnicate"], 2, "unrecognized subcommand");
}

#[test]
fn simulate_prints_status_and_metric_keys() {
    let out = common::shipid_ok(&[
        "simulate",
        "mmg:kvlcc2",
        "--manoeuvre",
        "zigzag:20/20:starboard",
        "--json",
    ]);
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["status"], "ok");
    // DOMAIN.md §6: 20/20 starboard first 10.5° / 15.7°.
    assert!(
        (v["overshoot_1"].as_f64().unwrap() - 10.5).abs() <= 0.3,
        "{v}"
    );
    assert!(
        (v["overshoot_2"].as_f64().unwrap() - 15.7).abs() <= 0.3,
        "{v}"
    );
    for key in ["t_a", "t_check"] {
        assert!(v[key].as_f64().is_some(), "{key} in {v}");
    }
    assert!(v.get("advance").is_none(), "no turning keys for a zig-zag");
}

#[test]
fn simulate_writes_a_readable_time_series() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("tc.csv");
    common::shipid_ok(&[
        "simulate",
        "mmg:kvlcc2",
        "--manoeuvre",
        "turning:35:port",
        "--duration",
        "120",
        "--out",
        csv.to_str().unwrap(),
    ]);
    let rec = shipid_io::recording::read_recording(&csv).unwrap();
    assert!((rec.t.last().unwrap() - 120.0).abs() < 1e-9);
    assert!(
        rec.psi.last().unwrap() < &-1.0,
        "a port turn turns the heading negative"
    );
}

#[test]
fn metrics_json_has_one_entry_per_recording() {
    let out = common::shipid_ok(&["metrics", "data/kvlcc2-mmg/dataset.toml", "--json"]);
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let recs = v["recordings"].as_object().unwrap();
    assert_eq!(recs.len(), 6);
    assert_eq!(recs["tc35_sb.csv"]["kind"], "turning");
    assert!(recs["tc35_sb.csv"]["tactical_diameter"].as_f64().is_some());
    assert!(recs["zz35_35_sb.csv"]["overshoot_2"].as_f64().is_some());
}

/// `validate` says how much of each recording lies outside the range the model was identified on: a
/// model trained on one zig-zag sees the turning circles mostly outside, its own training manoeuvre
/// inside; the reference model (no training data) gets no such key.
#[test]
fn validate_reports_the_share_of_states_outside_the_identification_range() {
    let dir = common::root().join("target/test-validate-range");
    std::fs::create_dir_all(&dir).unwrap();
    let model = dir.join("reduced32-zz35.toml");
    let ds = common::root().join("data/kvlcc2-mmg/dataset.toml");
    let (ds, model) = (ds.to_str().unwrap(), model.to_str().unwrap());
    common::shipid_ok(&[
        "fit",
        ds,
        "--set",
        "reduced32",
        "--estimator",
        "lsq",
        "--recordings",
        "zz35_35_ps.csv",
        "--overshoots",
        "4",
        "--out",
        model,
    ]);
    let outside = |model: &str, file: &str| {
        let out = common::shipid_ok(&["validate", model, ds, "--json"]);
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        v["recordings"][file]["outside_identification_range"].as_f64()
    };
    for tc in ["tc35_ps.csv", "tc35_sb.csv"] {
        let f = outside(model, tc).unwrap();
        assert!(f > 0.5, "{tc}: {f}");
    }
    // The training window ends after four overshoots; the rest of the record repeats them.
    let own = outside(model, "zz35_35_ps.csv").unwrap();
    assert!(own < 0.02, "{own}");
    assert_eq!(outside("mmg:kvlcc2", "tc35_ps.csv"), None);
}
