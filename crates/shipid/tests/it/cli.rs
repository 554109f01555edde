//! The command line as users and other tools see it: names, JSON keys, exit codes, one-sentence errors.

use crate::common;

use serde_json::Value;

use crate::common::check_exit;

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
        "--dt must be a positive number of seconds, got -1",
    );
    check_exit(
        &[
            "generate",
            "--out",
            "target/never-written",
            "--manoeuvre",
            "turning:20:sb",
            "--manoeuvre",
            "turning:20:starboard",
        ],
        2,
        "--manoeuvre: tc20_sb.csv is asked for twice",
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
    // MMG reference check values: 20/20 starboard first 10.5° / 15.7°.
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

/// A reduced32 model fitted on the default data's ZZ20/20 port alone (rudder ≤ 20°), written into
/// `dir`: the data set's path and the model's.
fn fit_reduced32_on_zz20(dir: &std::path::Path) -> (String, std::path::PathBuf) {
    let model = dir.join("reduced32-zz20.toml");
    let ds = common::root().join("data/kvlcc2-mmg/dataset.toml");
    let ds = ds.to_str().unwrap().to_string();
    common::shipid_ok(&[
        "fit",
        &ds,
        "--set",
        "reduced32",
        "--recordings",
        "zz20_20_ps.csv",
        "--out",
        model.to_str().unwrap(),
    ]);
    (ds, model)
}

/// Regression: `validate` of a model trained on 20° of rudder against recordings at 35° gave their
/// `outside` share (a 45° turn of a model trained to 35° was 1 % outside) and no word that their
/// rudder was one the model never saw; `simulate` warned. Each recording past the training extremes
/// is now named with what it reaches, and its own training run is not.
#[test]
fn validate_names_the_recordings_past_the_training_extremes() {
    let dir = tempfile::tempdir().unwrap();
    let (ds, model) = fit_reduced32_on_zz20(dir.path());
    let (ds, model) = (ds.as_str(), model.to_str().unwrap());
    // The 35° runs diverge with this model (exit 1): their rows and warnings are still written.
    let out = common::shipid(&["validate", model, ds, "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let beyond = |file: &str| v["recordings"][file]["beyond_training"].to_string();
    assert!(
        beyond("zz35_35_ps.csv").contains("rudder up to 35.0° (training ≤ 20.0°)"),
        "{}",
        beyond("zz35_35_ps.csv")
    );
    assert_eq!(beyond("zz20_20_ps.csv"), "null");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("warning: tc35_ps.csv: the recording goes past the extremes of the states"),
        "{stderr}"
    );
    assert!(
        !stderr.contains("warning: zz20_20_ps.csv: the recording goes past"),
        "{stderr}"
    );
    // diagnose says it too: its mismatch there is partly the model's extrapolation.
    let out = common::shipid(&["diagnose", model, ds]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("warning: zz35_35_sb.csv: the recording goes past the extremes")
            && stderr.contains("partly the model's extrapolation"),
        "{stderr}"
    );
    assert!(
        !stderr.contains("warning: zz20_20_ps.csv: the recording goes past"),
        "{stderr}"
    );
}

/// Regression: a model file whose `[ship]` was edited after the fit (U0 tenfold) simulated a 49.5°
/// overshoot (14.3° true) as "0 % outside" without a word; `simulate` now compares the file's ship
/// with its training data set's.
#[test]
fn simulate_of_a_model_whose_ship_is_not_its_training_data_s_warns() {
    let dir = tempfile::tempdir().unwrap();
    let (_, model) = fit_reduced32_on_zz20(dir.path());
    let model_s = model.to_str().unwrap();
    let simulate = || {
        let out = common::shipid_ok(&["simulate", model_s, "--manoeuvre", "zigzag:20/20:port"]);
        String::from_utf8_lossy(&out.stderr).to_string()
    };
    assert!(!simulate().contains("its [ship] is not"));
    let text = std::fs::read_to_string(&model).unwrap();
    let edited = text.replacen("u0 = 1.179", "u0 = 11.79", 1);
    assert_ne!(edited, text, "no `u0 = 1.179` line to edit");
    std::fs::write(&model, edited).unwrap();
    let stderr = simulate();
    assert!(
        stderr.contains("its [ship] is not the ship of its training data")
            && stderr.contains("u0 11.79 m/s in the model, 1.179 m/s in the data set"),
        "{stderr}"
    );
}

#[test]
fn generate_simulates_the_manoeuvres_asked_for_and_a_current_only_carries_the_track_along() {
    let dir = tempfile::tempdir().unwrap();
    let gen_into = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let mut args = vec![
            "generate",
            "--out",
            out.to_str().unwrap(),
            "--manoeuvre",
            "zigzag:15/15:starboard",
            "--manoeuvre",
            "turning:20:port",
        ];
        args.extend_from_slice(extra);
        common::shipid_ok(&args);
        shipid_io::Dataset::load(&out.join("dataset.toml")).unwrap()
    };
    let calm = gen_into("calm", &[]);
    let files: Vec<&str> = calm.recordings.iter().map(|r| r.file.as_str()).collect();
    assert_eq!(files, ["zz15_15_sb.csv", "tc20_ps.csv"]);
    // The zig-zag goes to starboard first.
    let zz = &calm.recordings[0].recording;
    let first = zz.delta.iter().find(|d| d.abs() > 1e-3).unwrap();
    assert!(*first > 0.0, "first rudder {first}");

    // A uniform current from 120° (flowing towards 300°, x north, y east) changes nothing relative
    // to the water: same heading, and the track over ground is the calm one plus V_c·t.
    let drift = gen_into("current", &["--effect", "current:speed=0.05,from=120"]);
    let (vx, vy) = (
        0.05 * 300f64.to_radians().cos(),
        0.05 * 300f64.to_radians().sin(),
    );
    for (a, b) in calm.recordings.iter().zip(&drift.recordings) {
        let (a, b) = (&a.recording, &b.recording);
        assert_eq!(a.len(), b.len());
        for i in 0..a.len() {
            let t = a.t[i];
            assert!((a.psi[i] - b.psi[i]).abs() < 1e-6, "psi at {t} s");
            let (dx, dy) = (b.x0[i] - a.x0[i] - vx * t, b.y0[i] - a.y0[i] - vy * t);
            assert!(dx.hypot(dy) < 1e-4, "track at {t} s off by {dx}, {dy} m");
        }
    }
}
