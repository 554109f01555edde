//! The discrepancy diagnosis on generated data with a concealed effect: the verdict names the effect, its
//! parameters come back, the held-out fit improves, controls give `none`, the report has the keys of docs/data-format.md
//! and the augmented model carries the effect into later simulations.

use crate::common;

use std::path::Path;

use serde_json::Value;
use shipid_diagnose::bench::to_dataset;
use shipid_diagnose::{DiagnoseInput, DiagnoseOptions, Report, diagnose, model_level};
use shipid_estimators::Solver;
use shipid_pipeline::fit::{EstimatorSpec, WindowSpec, fit_dataset, load_set};
use shipid_pipeline::generate::generate_with;
use shipid_sim::{AbkowitzDynamics, Dynamics, Effect, MmgModel};

/// The model identified from the clean default data (full68, LSQ, all six recordings) and its own level.
fn identified() -> (AbkowitzDynamics, f64) {
    let clean = to_dataset(generate_with(None, &[]).unwrap(), "clean");
    let names: Vec<String> = clean.recordings.iter().map(|r| r.file.clone()).collect();
    let fit = fit_dataset(
        &clean,
        load_set("full68").unwrap(),
        &EstimatorSpec::named("lsq"),
        &names,
        WindowSpec::Whole,
        Solver::Fast,
    )
    .unwrap();
    let model = AbkowitzDynamics(fit.model);
    let level = model_level(
        &DiagnoseInput {
            base: &model,
            base_effects: &[],
            model_level_over_l: None,
            identification_range: None,
        },
        &clean,
        &DiagnoseOptions::default(),
    );
    (model, level)
}

/// The diagnosis of the default manoeuvres generated with the concealed `effects` and noise of
/// `seed` (noise-free without one).
fn diagnose_concealed(
    base: &(dyn Dynamics + Send + Sync),
    level: Option<f64>,
    effects: &[&str],
    seed: Option<u64>,
) -> Report {
    let effects: Vec<Effect> = effects.iter().map(|e| e.parse().unwrap()).collect();
    let ds = to_dataset(generate_with(seed, &effects).unwrap(), "concealed");
    diagnose(
        &DiagnoseInput {
            base,
            base_effects: &[],
            model_level_over_l: level,
            identification_range: None,
        },
        &ds,
        &DiagnoseOptions::default(),
    )
    .unwrap()
}

fn found(report: &Report) -> Effect {
    assert_eq!(report.effects.len(), 1, "{:?}", report.effects);
    report.effects[0].parse().unwrap()
}

/// `concealed` is diagnosed as `word` with the held-out position RMSE at least halved.
fn check(report: &Report, word: &str) {
    assert_eq!(report.verdict, word, "{}", report.explanation);
    assert!(
        report.fit_after.position_rmse_over_l < 0.5 * report.fit_before.position_rmse_over_l,
        "before {} after {}",
        report.fit_before.position_rmse_over_l,
        report.fit_after.position_rmse_over_l
    );
}

#[test]
fn a_current_is_named_and_its_speed_and_direction_recovered() {
    let base = MmgModel::kvlcc2();
    let r = diagnose_concealed(&base, None, &["current:speed=0.03,from=120"], Some(5));
    check(&r, "current");
    let Effect::Current(c) = found(&r) else {
        panic!("not a current")
    };
    assert!((c.speed_m_s - 0.03).abs() < 0.003, "{c:?}");
    assert!((c.from_deg - 120.0).abs() < 5.0, "{c:?}");
    // The mismatch is everywhere over ground; the turning circles drift most.
    assert!(!r.located.is_empty());
}

#[test]
fn shallow_water_is_named_against_the_reference_model() {
    let base = MmgModel::kvlcc2();
    let r = diagnose_concealed(&base, None, &["shallow_water:h_over_t=1.5"], Some(6));
    check(&r, "shallow_water");
    let Effect::ShallowWater(s) = found(&r) else {
        panic!("not shallow water")
    };
    assert!((s.depth_over_draft - 1.5).abs() < 0.1, "{s:?}");
}

#[test]
fn rudder_lag_and_a_rudder_offset_are_found_against_an_identified_model() {
    let (base, level) = identified();
    let r = diagnose_concealed(&base, Some(level), &["rudder_lag:tau=1.6"], Some(7));
    check(&r, "rudder_lag");
    let Effect::RudderLag(l) = found(&r) else {
        panic!("not a lag")
    };
    // Delay and time constant trade off; their sum is the phase lag a zig-zag sees.
    assert!((l.time_constant_s + l.delay_s - 1.6).abs() < 0.3, "{l:?}");
    let r = diagnose_concealed(&base, Some(level), &["asymmetry:offset=-2"], Some(8));
    check(&r, "asymmetry");
    let Effect::Asymmetry(a) = found(&r) else {
        panic!("not an asymmetry")
    };
    assert!((a.rudder_offset_deg + 2.0).abs() < 0.4, "{a:?}");
}

#[test]
fn effect_free_recordings_give_none() {
    let (base, level) = identified();
    for seed in [11, 12] {
        let r = diagnose_concealed(&base, Some(level), &[], Some(seed));
        assert_eq!(r.verdict, "none", "seed {seed}: {}", r.explanation);
        assert!(r.effects.is_empty());
    }
}

/// Regression: two concealed effects that each explain too little alone for the acceptance rule (the
/// wind alone even makes the fit worse) were `unexplained`, because pairs were only tried with an
/// accepted single effect.
#[test]
fn a_current_with_a_wind_is_found_as_a_pair() {
    let r = diagnose_concealed(
        &MmgModel::kvlcc2(),
        None,
        &["current:speed=0.02,from=45", "wind:speed=4.5,from=300"],
        Some(1),
    );
    let kinds: Vec<&str> = r
        .effects
        .iter()
        .map(|e| e.parse::<Effect>().unwrap().kind())
        .collect();
    assert!(
        kinds.contains(&"current") && kinds.contains(&"wind"),
        "{}: {:?}",
        r.explanation,
        r.effects
    );
    assert!(
        r.fit_after.position_rmse_over_l < 0.2 * r.fit_before.position_rmse_over_l,
        "{}",
        r.explanation
    );
}

/// Regression: segment replays started from a plain mean of the samples around the segment's start,
/// biased wherever r and v curve and by half a window of travel at a recording's first sample, so
/// that the MMG reference replayed on its own noise-free recordings missed them by 0.015 L and the
/// verdict was `unexplained`.
#[test]
fn the_reference_replays_its_own_noise_free_recordings_exactly_and_finds_nothing() {
    let report = diagnose_concealed(&MmgModel::kvlcc2(), None, &[], None);
    assert!(
        report.fit_before.position_rmse_over_l < 1e-3,
        "{}",
        report.fit_before.position_rmse_over_l
    );
    assert!(report.fit_before.heading_rmse_deg < 0.01);
    assert_eq!(report.verdict, "none");
}

fn write_dataset(dir: &Path, effect: &str) {
    common::shipid_ok(&[
        "generate",
        "--out",
        dir.to_str().unwrap(),
        "--noise",
        "3",
        "--effect",
        effect,
    ]);
}

#[test]
fn the_report_follows_data_md_and_the_augmented_model_carries_the_effect() {
    let dir = common::root().join("target/test-diagnose-cli");
    let _ = std::fs::remove_dir_all(&dir);
    write_dataset(&dir, "current:speed=0.04,from=200");
    let ds = dir.join("dataset.toml");
    let report = dir.join("report.json");
    let out = common::shipid_ok(&[
        "diagnose",
        "mmg:kvlcc2",
        ds.to_str().unwrap(),
        "--json",
        report.to_str().unwrap(),
        "--plots",
        dir.join("figures").to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("verdict: current"), "{stdout}");
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(v["verdict"], "current");
    let c = &v["candidates"][0];
    for key in ["effect", "score", "parameters", "explains"] {
        assert!(!c[key].is_null(), "candidate key {key}");
    }
    let cur = v["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["effect"] == "current")
        .unwrap();
    assert!((cur["parameters"]["speed"].as_f64().unwrap() - 0.04).abs() < 0.004);
    assert!(!cur["parameters"]["from_deg"].is_null());
    let l = &v["located"][0];
    for key in ["recording", "dof", "t_start", "t_end"] {
        assert!(!l[key].is_null(), "located key {key}");
    }
    let before = v["fit_before"]["position_rmse_over_l"].as_f64().unwrap();
    let after = v["fit_after"]["position_rmse_over_l"].as_f64().unwrap();
    assert!(after < 0.5 * before, "{before} → {after}");
    let track = std::fs::read_to_string(dir.join("figures/tc35_sb-tracks.svg")).unwrap();
    assert!(
        track.contains("model + effect (after)"),
        "legend of the replays"
    );
    assert!(
        track.contains("position error of the segment replays"),
        "the error-over-time panel"
    );

    // The augmented model: a file with `base = "mmg:kvlcc2"` and the current; simulating it replays the
    // current, so the recording is matched far better than by the base.
    let aug = dir.join("report.model.toml");
    let text = std::fs::read_to_string(&aug).unwrap();
    assert!(
        text.contains("base = \"mmg:kvlcc2\"") && text.contains("current:speed="),
        "{text}"
    );
    let rmse = |model: &str| {
        let out = common::shipid_ok(&["validate", model, ds.to_str().unwrap(), "--json"]);
        let v: Value = serde_json::from_slice(&out.stdout).unwrap();
        v["recordings"]["tc35_ps.csv"]["replay"]["position_rmse_over_l"]
            .as_f64()
            .unwrap()
    };
    let (b, a) = (rmse("mmg:kvlcc2"), rmse(aug.to_str().unwrap()));
    assert!(a < 0.2 * b, "base {b} augmented {a}");
}

#[test]
fn a_bad_effect_in_a_model_file_names_the_key() {
    let dir = common::root().join("target/test-diagnose-bad-effect");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("model.toml");
    std::fs::write(
        &path,
        "shipid_version = \"0\"\nbase = \"mmg:kvlcc2\"\n[[effects]]\neffect = \"current:speed=-1,from=0\"\nsource = \"test\"\n",
    )
    .unwrap();
    let out = common::shipid(&[
        "simulate",
        path.to_str().unwrap(),
        "--manoeuvre",
        "turning:35:port",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("key `effects[0].effect`") && err.contains("speed"),
        "{err}"
    );
}

/// A model identified on one zig-zag, diagnosed against all six default manoeuvres: the turning
/// circles lie outside its identification range and the report says so, while the model identified on
/// all six sees every state of them inside its range. (Wrong units of the states, e.g. degrees for δ or
/// unprimed velocities, would put everything outside.)
#[test]
fn states_a_model_was_not_identified_on_are_reported_outside_its_identification_range() {
    use shipid_model::IdentificationRange;
    use shipid_pipeline::fit::training_samples;

    let clean = to_dataset(generate_with(None, &[]).unwrap(), "clean");
    let one = vec!["zz35_35_ps.csv".to_string()];
    let set = load_set("reduced32").unwrap();
    let fit = fit_dataset(
        &clean,
        set.clone(),
        &EstimatorSpec::named("lsq"),
        &one,
        WindowSpec::Overshoots(4),
        Solver::Fast,
    )
    .unwrap();
    let (samples, _) = training_samples(&clean, &one, WindowSpec::Overshoots(4)).unwrap();
    let range = IdentificationRange::from_samples(&set, &samples).unwrap();
    let model = AbkowitzDynamics(fit.model);
    let report = diagnose(
        &DiagnoseInput {
            base: &model,
            base_effects: &[],
            model_level_over_l: None,
            identification_range: Some(shipid_diagnose::BaseRange::Leverage(&range)),
        },
        &clean,
        &DiagnoseOptions::default(),
    )
    .unwrap();
    let fraction = |file: &str| {
        report
            .per_recording
            .iter()
            .find(|p| p.recording == file)
            .and_then(|p| p.outside_identification_range)
            .unwrap()
    };
    for tc in ["tc35_ps.csv", "tc35_sb.csv"] {
        assert!(fraction(tc) > 0.5, "{tc}: {}", fraction(tc));
    }
    assert!(
        fraction("zz35_35_ps.csv") < 0.05,
        "{}",
        fraction("zz35_35_ps.csv")
    );
    assert!(report.outside_identification_range.unwrap() > 0.2);
    assert!(
        report.explanation.contains("identification range"),
        "{}",
        report.explanation
    );

    let all: Vec<String> = clean.recordings.iter().map(|r| r.file.clone()).collect();
    let full = load_set("full68").unwrap();
    let (samples, _) = training_samples(&clean, &all, WindowSpec::Whole).unwrap();
    let range = IdentificationRange::from_samples(&full, &samples).unwrap();
    let (model, level) = identified();
    let report = diagnose(
        &DiagnoseInput {
            base: &model,
            base_effects: &[],
            model_level_over_l: Some(level),
            identification_range: Some(shipid_diagnose::BaseRange::Leverage(&range)),
        },
        &clean,
        &DiagnoseOptions::default(),
    )
    .unwrap();
    assert_eq!(report.outside_identification_range, Some(0.0));
}

/// Regression (issue 25): an augmented model named its base by an absolute path and lost the base's
/// training data, and a copy of a polynomial base kept data-set paths relative to the working
/// directory. Now both name what they need relative to themselves, with fingerprints: they keep working
/// wherever they are used from and when moved together with what they name, and a changed base is
/// refused.
#[test]
fn augmented_models_name_their_base_and_data_relative_to_themselves() {
    let top = tempfile::tempdir().unwrap();
    let t = top.path();
    let path = |p: &str| t.join(p).to_str().unwrap().to_string();
    common::shipid_ok(&[
        "generate",
        "--out",
        &path("gen"),
        "--effect",
        "current:speed=0.05,from=120",
    ]);
    common::shipid_ok(&[
        "fit",
        "data/kvlcc2-mmg/dataset.toml",
        "--out",
        &path("work/base/model.toml"),
    ]);
    // A wrapper around the polynomial model (as diagnose writes for a base that is not a polynomial
    // file): its own base by a relative path with its fingerprint.
    let base_hash =
        shipid_pipeline::model_file::files_hash(&[&t.join("work/base/model.toml")]).unwrap();
    std::fs::write(
        t.join("work/base/wrap.toml"),
        format!(
            "shipid_version = \"0\"\nbase = \"model.toml\"\nbase_hash = \"{base_hash}\"\n[[effects]]\neffect = \"wind:speed=0.01,from=0\"\nsource = \"test\"\n"
        ),
    )
    .unwrap();
    let run = common::shipid_ok(&[
        "diagnose",
        &path("work/base/wrap.toml"),
        &path("gen/dataset.toml"),
        "--model-out",
        &path("work/out/aug.toml"),
    ]);
    let stdout = String::from_utf8_lossy(&run.stdout);
    // The wrapper's training data are its base's.
    assert!(
        stdout.contains("model's own level (training data /"),
        "{stdout}"
    );
    let aug = std::fs::read_to_string(t.join("work/out/aug.toml")).unwrap();
    assert!(
        aug.contains("base = \"../base/wrap.toml\"") && aug.contains("base_hash = \"fnv1a64:"),
        "{aug}"
    );
    // The copy of a polynomial base: its training data set relative to the copy.
    common::shipid_ok(&[
        "diagnose",
        &path("work/base/model.toml"),
        &path("gen/dataset.toml"),
        "--model-out",
        &path("work/out/copy.toml"),
    ]);
    let copy = std::fs::read_to_string(t.join("work/out/copy.toml")).unwrap();
    let base = std::fs::read_to_string(t.join("work/base/model.toml")).unwrap();
    let dataset_line = |text: &str| {
        text.lines()
            .find(|l| l.starts_with("dataset = "))
            .unwrap()
            .to_string()
    };
    // Both folders are two levels below `t`: the same relative path.
    assert_eq!(dataset_line(&copy), dataset_line(&base));
    // Moved together, the wrapper and its base still load and still find the training data, from a
    // working directory that is neither.
    std::fs::rename(t.join("work"), t.join("moved")).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_shipid"))
        .args(["validate", "out/aug.toml", "../gen/dataset.toml"])
        .current_dir(t.join("moved"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    // The training data are found (no warning that they cannot be read or changed); the current
    // carries the recorded states past the training extremes, which validate names.
    assert!(
        err.lines()
            .filter(|l| l.contains("warning"))
            .all(|l| l.contains("goes past the extremes of the states")),
        "{err}"
    );
    // A changed base is refused, naming the key and both files.
    let wrap = t.join("moved/base/wrap.toml");
    let text = std::fs::read_to_string(&wrap).unwrap();
    std::fs::write(&wrap, format!("{text}# edited\n")).unwrap();
    common::check_exit(
        &[
            "validate",
            &path("moved/out/aug.toml"),
            &path("gen/dataset.toml"),
        ],
        2,
        "aug.toml: key `base_hash`",
    );
}

/// `text` holds every one of `needles` (`what` names the text in the message).
fn check_has(what: &str, text: &str, needles: &[&str]) {
    for n in needles {
        assert!(text.contains(n), "{what} lacks {n:?}:\n{text}");
    }
}

/// Probe finding 6: the caveat on the standard errors (they leave out the base model's own error,
/// which put h/T at 1.669 ± 0.008 for a true 1.6) was printed only: the JSON report and the augmented
/// model carried the bare numbers. Probe finding 9: `shipid report DIR` on a diagnosis folder lost the
/// model and data set (report.json held neither).
#[test]
fn standard_errors_say_what_they_cover_and_a_rebuilt_page_keeps_model_and_data_set() {
    let dir = common::root().join("target/test-diagnose-probe11");
    let _ = std::fs::remove_dir_all(&dir);
    write_dataset(&dir, "shallow_water:h_over_t=1.6");
    let ds = dir.join("dataset.toml");
    let plots = dir.join("page");
    let out = common::shipid_ok(&[
        "diagnose",
        "mmg:kvlcc2",
        ds.to_str().unwrap(),
        "--plots",
        plots.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    check_has(
        "stdout",
        &stdout,
        &["verdict: shallow_water", "± one standard error: covers"],
    );
    let report = std::fs::read_to_string(plots.join("report.json")).unwrap();
    let v: Value = serde_json::from_str(&report).unwrap();
    let basis = &v["standard_error_basis"];
    for key in ["covers", "leaves_out"] {
        assert!(
            basis[key].is_string(),
            "standard_error_basis.{key}: {report}"
        );
    }
    assert_eq!(v["model"], "mmg:kvlcc2");
    assert_eq!(v["dataset"], ds.to_str().unwrap());
    let model = std::fs::read_to_string(plots.join("report.model.toml")).unwrap();
    check_has(
        "augmented model",
        &model,
        &["standard errors: covers", "leaves out"],
    );
    // Rebuilt from the folder alone, the page names what was diagnosed as the first one did.
    common::shipid_ok(&["report", plots.to_str().unwrap()]);
    let page = std::fs::read_to_string(plots.join("report.html")).unwrap();
    check_has(
        "rebuilt page",
        &page,
        &[
            "Diagnosis of mmg:kvlcc2",
            "<dt>data set</dt>",
            "<dt>model</dt><dd>mmg:kvlcc2</dd>",
        ],
    );
}
