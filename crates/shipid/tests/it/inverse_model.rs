//! The model `shipid inverse` delivers: its `mmg` model file reproduces the inverse command's own
//! re-simulation when `simulate` reads it back, its weights are written at full precision, and every
//! parameter names its source.

use serde_json::Value;
use shipid_inverse::indexes::{SimSettings, motion_indexes};

use crate::common;

/// The KVLCC2 target of `data/paper003/targets.toml` alone (a small, fast run).
fn kvlcc2_targets() -> String {
    let all = std::fs::read_to_string(common::root().join("data/paper003/targets.toml"))
        .expect("targets file");
    let second = all
        .match_indices("[[target]]")
        .nth(1)
        .map(|(i, _)| i)
        .expect("two targets");
    all[..second].to_string()
}

fn json_of(stdout: &[u8]) -> Value {
    serde_json::from_slice(stdout).expect("JSON on stdout")
}

/// `shipid inverse TARGETS --out OUT` with `extra` flags (exit 0, or 1 for a model flagged on the
/// box's edge) and its `summary.json`.
fn run_inverse(targets: &std::path::Path, out: &std::path::Path, extra: &[&str]) -> Value {
    let mut args = vec!["inverse", targets.to_str().expect("utf-8")];
    args.extend_from_slice(extra);
    args.extend(["--out", out.to_str().expect("utf-8")]);
    let run = common::shipid(&args);
    assert!(
        matches!(run.status.code(), Some(0 | 1)),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).expect("summary.json"))
        .expect("summary JSON")
}

/// `got` against `want`, relative to |want| (the same model simulated twice: solver tolerance).
fn check_same(what: &str, got: f64, want: f64) {
    assert!(
        (got - want).abs() <= 1e-9 * want.abs().max(1e-12),
        "{what}: the model file gives {got}, the inverse run {want}"
    );
}

#[test]
fn the_model_file_reproduces_the_inverse_re_simulation() {
    let dir = tempfile::tempdir().expect("temp dir");
    let targets = dir.path().join("kvlcc2.toml");
    std::fs::write(&targets, kvlcc2_targets()).expect("write targets");
    let out = dir.path().join("out");
    let summary = run_inverse(
        &targets,
        &out,
        &[
            "--samples",
            "150",
            "--resimulate",
            "2",
            "--refine-evals",
            "20",
        ],
    );
    let motion = &summary["targets"][0]["motions"][0];
    assert_eq!(motion["model_file"], "model.toml", "{motion}");
    let model_path = out.join("kvlcc2/model.toml");
    let model = model_path.to_str().expect("utf-8");

    // The 10/10 zig-zag and the 20° turn of `simulate` reading the file, against the inverse
    // command's simulation of the ship it built in memory.
    for (key, spec, metrics) in [
        (
            "zigzag_10_10_starboard",
            "zigzag:10/10:starboard",
            &["overshoot_1", "overshoot_2"][..],
        ),
        (
            "turning_20_starboard",
            "turning:20:starboard",
            &["advance", "tactical_diameter"][..],
        ),
    ] {
        let sim =
            json_of(&common::shipid_ok(&["simulate", model, "--manoeuvre", spec, "--json"]).stdout);
        for m in metrics {
            let want = motion["model_metrics"][key][m]
                .as_f64()
                .unwrap_or_else(|| panic!("{key}.{m} in summary.json: {motion}"));
            let got = sim[m].as_f64().expect("metric in simulate's JSON");
            check_same(&format!("{spec} {m}"), got, want);
        }
    }

    // The nine indexes of the model read back through the one model loader.
    let loaded = shipid_pipeline::model_file::load_model(model).expect("the model file loads");
    let q = motion_indexes(loaded.as_ref(), &SimSettings::default()).expect("simulates");
    let want = motion["model_indexes"].as_array().expect("nine indexes");
    assert_eq!(want.len(), 9);
    for (i, w) in want.iter().enumerate() {
        check_same(&format!("index {i}"), q.0[i], w.as_f64().expect("a number"));
    }

    // weights.csv holds the model's weights at full precision: they parse back to the same f64.
    let csv = std::fs::read_to_string(out.join("kvlcc2/weights.csv")).expect("weights.csv");
    let weights = motion["weights"].as_array().expect("weights");
    let delivered: Vec<f64> = csv
        .lines()
        .filter(|l| l.starts_with("Tab3,model,"))
        .map(|l| {
            l.split(',')
                .nth(3)
                .expect("weight column")
                .parse()
                .expect("f64")
        })
        .collect();
    assert_eq!(delivered.len(), weights.len(), "{csv}");
    for (got, want) in delivered.iter().zip(weights) {
        assert_eq!(*got, want.as_f64().expect("a number"), "full precision");
    }

    // Every parameter names where it comes from.
    let text = std::fs::read_to_string(&model_path).expect("model.toml");
    let file: toml::Table = toml::from_str(&text).expect("TOML");
    let params = file["parameter"].as_array().expect("[[parameter]]");
    assert_eq!(params.len(), 31);
    let source = |name: &str| -> String {
        params
            .iter()
            .find(|p| p["name"].as_str() == Some(name))
            .and_then(|p| p["prior_source"].as_str())
            .unwrap_or_else(|| panic!("no {name}"))
            .to_string()
    };
    assert!(
        source("n_r").starts_with("inverse network, "),
        "{}",
        source("n_r")
    );
    assert!(source("t_r").starts_with("inverse network, "));
    assert_eq!(source("w_p0"), "fixed: Yasukawa & Yoshimura 2015 KVLCC2");
    assert_eq!(source("t_p"), "targets file: t_p");
}

/// The KVLCC2 target with `motion`'s nine indexes in place of Tab. 3's.
fn kvlcc2_target_with(indexes: &[f64; 9]) -> String {
    let block = kvlcc2_targets();
    let motion = block.find("[[target.motion]]").expect("a motion");
    let mut text = block[..motion].to_string();
    text.push_str("[[target.motion]]\nname = \"variant\"\n");
    for (key, value) in shipid_inverse::indexes::INDEX_KEYS.iter().zip(indexes) {
        text.push_str(&format!("{key} = {value}\n"));
    }
    text
}

#[test]
fn variant_outside_the_trained_box_kept_six_modes_and_had_no_band() {
    // The shape of issue 28's hidden check: a KVLCC2 variant from the MMG with changed hull
    // derivatives (N'_r × 0.85, Y'_v × 1.10), its nine indexes inverted, its 10/10 zig-zag and 20°
    // turn (not among the indexes) predicted. The mode search stopped at 6 modes because the
    // refinement found interior weights although the network's answer lay outside the box (up to
    // 6σ): the 10/10 second overshoot came out 2.4° low, and every jittered restart around the
    // network's clipped, unphysical answer failed, so no member but the first was kept and the
    // model file had no band. Now the modes grow until the network's answer is inside too, restarts
    // also start around the best match, and the prediction is within 2° / 10 % or inside its band.
    let dir = tempfile::tempdir().expect("temp dir");
    let truth_text =
        std::fs::read_to_string(common::root().join("data/paper003/kvlcc2-truth.toml"))
            .expect("truth");
    let mut truth: toml::Table = toml::from_str(&truth_text).expect("TOML");
    for p in truth["parameter"].as_array_mut().expect("[[parameter]]") {
        let factor = match p["name"].as_str() {
            Some("n_r") => 0.85,
            Some("y_v") => 1.10,
            _ => continue,
        };
        let v = p["value"].as_float().expect("a value");
        p["value"] = toml::Value::Float(v * factor);
    }
    let truth_path = dir.path().join("variant.toml");
    std::fs::write(&truth_path, toml::to_string(&truth).expect("TOML")).expect("write");
    let variant = truth_path.to_str().expect("utf-8");
    let loaded = shipid_pipeline::model_file::load_model(variant).expect("the variant loads");
    let q = motion_indexes(loaded.as_ref(), &SimSettings::default()).expect("simulates");
    let targets = dir.path().join("variant-targets.toml");
    std::fs::write(&targets, kvlcc2_target_with(&q.0)).expect("write targets");
    let out = dir.path().join("out");
    let summary = run_inverse(&targets, &out, &[]);
    let target = &summary["targets"][0];
    assert!(
        target["modes"].as_u64().expect("modes") > 6,
        "{}",
        target["mode_choice"]
    );
    let members = target["motions"][0]["ensemble_members"]
        .as_u64()
        .expect("members");
    assert!(members >= 20, "{members} members: too few for a band");
    let model = out.join("kvlcc2/model.toml");
    let model = model.to_str().expect("utf-8");
    for (spec, checks) in [
        (
            "zigzag:10/10:starboard",
            &[("overshoot_1", 2.0, false), ("overshoot_2", 2.0, false)][..],
        ),
        (
            "turning:20:starboard",
            &[("advance", 0.10, true), ("tactical_diameter", 0.10, true)][..],
        ),
    ] {
        let want = json_of(
            &common::shipid_ok(&["simulate", variant, "--manoeuvre", spec, "--json"]).stdout,
        );
        let got = json_of(
            &common::shipid_ok(&[
                "simulate",
                model,
                "--manoeuvre",
                spec,
                "--bands",
                "0.9",
                "--json",
            ])
            .stdout,
        );
        for &(m, tolerance, relative) in checks {
            let (t, p) = (
                want[m].as_f64().expect("truth"),
                got[m].as_f64().expect("point"),
            );
            let band = got[format!("{m}_band")].as_array().expect("a band");
            let (lo, hi) = (band[0].as_f64().unwrap(), band[1].as_f64().unwrap());
            let error = if relative {
                (p - t).abs() / t.abs()
            } else {
                (p - t).abs()
            };
            assert!(
                error <= tolerance || (lo..=hi).contains(&t),
                "{spec} {m}: truth {t}, model {p} [{lo}, {hi}]"
            );
        }
    }
}
