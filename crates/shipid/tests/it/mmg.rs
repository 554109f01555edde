//! `shipid fit --set mmg`: the model file it writes is a model every command takes; on the HSVA
//! zig-zags, the 35° turn it predicts (docs/mmg.md).

use crate::common::{check_exit, import_hsva, shared_hsva, shipid, shipid_ok};

/// A metric of `shipid simulate MODEL --manoeuvre M --json`.
fn simulated(model: &str, manoeuvre: &str, metric: &str) -> f64 {
    let out = shipid_ok(&["simulate", model, "--manoeuvre", manoeuvre, "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    v[metric]
        .as_f64()
        .unwrap_or_else(|| panic!("{metric} in {v}"))
}

#[test]
fn fit_set_mmg_writes_a_model_file_that_simulate_and_validate_take() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("mmg.toml");
    let model = model.to_str().unwrap();
    let out = shipid_ok(&[
        "fit",
        "data/kvlcc2-mmg/dataset.toml",
        "--set",
        "mmg",
        "--estimator",
        "bounded-lsq",
        "--recordings",
        "zz35_35_ps.csv",
        "--out",
        model,
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("prior-held"), "{stdout}");
    let text = std::fs::read_to_string(model).unwrap();
    assert!(text.contains("kind = \"mmg\""), "{text}");
    // The turn the fit never saw, against the reference's.
    for side in ["port", "starboard"] {
        let m = format!("turning:35:{side}");
        let fitted = simulated(model, &m, "tactical_diameter");
        let reference = simulated("mmg:kvlcc2", &m, "tactical_diameter");
        assert!(
            (fitted / reference - 1.0).abs() < 0.01,
            "{side}: {fitted} vs {reference}"
        );
    }
    shipid_ok(&["validate", model, "data/kvlcc2-mmg/dataset.toml"]);
}

#[test]
fn set_mmg_refuses_an_estimator_it_has_not() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("m.toml");
    check_exit(
        &[
            "fit",
            "data/kvlcc2-mmg/dataset.toml",
            "--set",
            "mmg",
            "--estimator",
            "svr",
            "--out",
            model.to_str().unwrap(),
        ],
        2,
        "expected bounded-lsq or ridge",
    );
    assert!(!model.exists());
}

#[test]
fn mmg_from_the_hsva_zigzags_predicts_the_35_degree_turn_of_docs_mmg() {
    let Some(source) =
        shared_hsva("mmg_from_the_hsva_zigzags_predicts_the_35_degree_turn_of_docs_mmg")
    else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let dataset = import_hsva(&source, &dir.path().join("hsva"));
    // The import mapping carries the propeller (HSVA's D, its open-water points) and the rudder.
    let model = dir.path().join("mmg.toml");
    let model = model.to_str().unwrap();
    let fit = shipid(&[
        "fit",
        dataset.to_str().unwrap(),
        "--set",
        "mmg",
        "--estimator",
        "bounded-lsq",
        "--tune",
        "--out",
        model,
    ]);
    assert!(
        fit.status.success(),
        "{}",
        String::from_utf8_lossy(&fit.stderr)
    );
    // docs/mmg.md: tactical diameters of 3.6–3.7 L, 15–18 % above the MMG reference's 3.1 L (3.9–4.0 L
    // before the cubic damping terms' bounds: the zig-zags leave the N' cubic terms to extrapolate).
    for side in ["port", "starboard"] {
        let d = simulated(model, &format!("turning:35:{side}"), "tactical_diameter");
        assert!((3.4..3.9).contains(&d), "{side}: tactical diameter {d} L");
    }
}

#[test]
fn a_study_names_set_mmg_beside_a_polynomial_set() {
    let dir = tempfile::tempdir().unwrap();
    let study = dir.path().join("mmg.toml");
    let dataset = crate::common::root().join("data/kvlcc2-mmg/dataset.toml");
    std::fs::write(
        &study,
        format!(
            "name = \"mmg\"\ndescription = \"mmg beside reduced32\"\ndataset = {:?}\nsets = [\"reduced32\", \"mmg\"]\n\n[training]\nrecordings = [[\"zz35_35_ps.csv\"]]\n\n[[estimator]]\nname = \"bounded-lsq\"\n\n[test]\nrecordings = [\"tc35_sb.csv\"]\n",
            dataset.to_str().unwrap()
        ),
    )
    .unwrap();
    let out = dir.path().join("out");
    shipid_ok(&[
        "run",
        study.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let mmg_row = summary
        .lines()
        .find(|l| l.starts_with("mmg_"))
        .unwrap_or_else(|| panic!("{summary}"));
    assert!(mmg_row.contains(",ok,"), "{mmg_row}");
    let case = std::fs::read_dir(out.join("cases"))
        .unwrap()
        .flatten()
        .find(|e| e.file_name().to_string_lossy().starts_with("mmg_"))
        .unwrap();
    let model = std::fs::read_to_string(case.path().join("model.toml")).unwrap();
    assert!(model.contains("kind = \"mmg\""));
}
