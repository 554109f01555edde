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

/// A simulated manoeuvre says how far it lies outside where the model was identified: an mmg model
/// fitted on ZZ35/35 port runs its own zig-zag inside the ellipsoid of its training states and the
/// 35° turn outside it, with the quantities beyond the training extent named; `validate` and
/// `diagnose` give the share outside for the mmg family too.
#[test]
fn a_turn_simulated_from_a_zigzag_fit_is_flagged_as_an_extrapolation() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("mmg.toml");
    let model = model.to_str().unwrap();
    let fitted = shipid_ok(&[
        "fit",
        "data/kvlcc2-mmg/dataset.toml",
        "--set",
        "mmg",
        "--recordings",
        "zz35_35_ps.csv",
        "--out",
        model,
    ]);
    let stdout = String::from_utf8_lossy(&fitted.stdout);
    assert!(
        stdout.contains("identified on: drift ≤ 17.") && stdout.contains("rudder ≤ 35.0°"),
        "{stdout}"
    );
    let again = dir.path().join("again.toml");
    let fitted = shipid_ok(&[
        "fit",
        "data/kvlcc2-mmg/dataset.toml",
        "--set",
        "mmg",
        "--recordings",
        "zz35_35_ps.csv",
        "--json",
        "--out",
        again.to_str().unwrap(),
    ]);
    let report: serde_json::Value = serde_json::from_slice(&fitted.stdout).unwrap();
    // The fit of the reference's own zig-zag leaves every parameter inside its bounds.
    assert_eq!(report["on_bound"], serde_json::json!([]), "{report}");
    // Each parameter's label as the text output lists it (y_vvr is prior-held on this run).
    assert_eq!(
        report["identifiability"]["y_v"], "determined-by-data",
        "{report}"
    );
    assert_eq!(report["identifiability"]["y_vvr"], "prior-held", "{report}");
    let extent = &report["training_extent"];
    assert!(
        extent["max_drift_deg"].as_f64().unwrap() > 17.0
            && extent["max_rudder_deg"].as_f64().unwrap() > 34.9,
        "{report}"
    );
    let run = |manoeuvre: &str| {
        let out = shipid_ok(&["simulate", model, "--manoeuvre", manoeuvre, "--json"]);
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        (v, String::from_utf8_lossy(&out.stderr).to_string())
    };
    let (zigzag, stderr) = run("zigzag:35/35:port");
    let range = &zigzag["identification_range"];
    assert_eq!(range["source"], "state-ellipsoid", "{zigzag}");
    assert!(range["outside"].as_f64().unwrap() < 0.05, "{zigzag}");
    assert!(!stderr.contains("extrapolation"), "{stderr}");
    let (turn, stderr) = run("turning:35:port");
    let range = &turn["identification_range"];
    assert!(range["outside"].as_f64().unwrap() > 0.5, "{turn}");
    assert!(
        range["run"]["max_yaw_rate_prime"].as_f64().unwrap()
            > range["training"]["max_yaw_rate_prime"].as_f64().unwrap(),
        "{turn}"
    );
    assert!(
        stderr.contains("of this run lies outside where the model was identified")
            && stderr.contains("r′ up to")
            && stderr.contains("its metrics are an extrapolation"),
        "{stderr}"
    );
    assert!(
        turn["warnings"].to_string().contains("extrapolation"),
        "{turn}"
    );
    let out = shipid_ok(&["validate", model, "data/kvlcc2-mmg/dataset.toml", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        v["identification_range"]["source"], "state-ellipsoid",
        "{v}"
    );
    let tc = v["recordings"]["tc35_ps.csv"]["outside_identification_range"]
        .as_f64()
        .unwrap_or_else(|| panic!("{v}"));
    let zz = v["recordings"]["zz35_35_ps.csv"]["outside_identification_range"]
        .as_f64()
        .unwrap_or_else(|| panic!("{v}"));
    assert!(tc > 0.5 && zz < 0.05, "{tc} {zz}");
    let out = shipid_ok(&["diagnose", model, "data/kvlcc2-mmg/dataset.toml"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("recorded states outside the model's identification range"),
        "{stdout}"
    );
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
    // docs/mmg.md, Identifiability: the 13 refits without one zig-zag spread the steady turn by
    // about ±10 % (the 35°/5° run decides it), the advance by about 1 %.
    let out = shipid_ok(&[
        "simulate",
        model,
        "--manoeuvre",
        "turning:35:port",
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["jackknife"]["refits"], 13, "{v}");
    let se = |metric: &str| v["jackknife"]["standard_errors"][metric].as_f64().unwrap();
    let relative = |metric: &str| se(metric) / v[metric].as_f64().unwrap();
    assert!(relative("steady_diameter") > 0.05, "{v}");
    assert!(relative("advance") < 0.03, "{v}");
}

/// A fit on three or more recordings carries its jackknife refits, and `simulate` runs them beside
/// the model: on the default data's four zig-zags (one model, no noise) they agree.
#[test]
fn simulate_runs_the_jackknife_refits_of_an_mmg_fit_beside_it() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("mmg.toml");
    let model = model.to_str().unwrap();
    let fitted = shipid_ok(&[
        "fit",
        "data/kvlcc2-mmg/dataset.toml",
        "--set",
        "mmg",
        "--recordings",
        "zz10_10_ps.csv,zz20_20_ps.csv,zz35_35_ps.csv,zz35_35_sb.csv",
        "--out",
        model,
        "--validate",
    ]);
    // fit --validate shows the table validate of the written file shows (below).
    let text = String::from_utf8_lossy(&fitted.stdout);
    assert!(text.contains("lie in the jackknife's range"), "{text}");
    let out = shipid_ok(&[
        "simulate",
        model,
        "--manoeuvre",
        "turning:35:starboard",
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["jackknife"]["refits"], 4, "{v}");
    assert_eq!(v["jackknife"]["diverged"], 0, "{v}");
    let point = v["tactical_diameter"].as_f64().unwrap();
    let range = &v["tactical_diameter_jackknife"];
    let (lo, hi) = (range[0].as_f64().unwrap(), range[1].as_f64().unwrap());
    assert!(lo <= hi && hi - lo < 0.01 * point, "{point} [{lo}, {hi}]");
    assert!((lo - point).abs() < 0.01 * point, "{point} [{lo}, {hi}]");
    let text = shipid_ok(&["simulate", model, "--manoeuvre", "turning:35:starboard"]);
    let text = String::from_utf8_lossy(&text.stdout);
    assert!(text.contains("jackknife: 4 refits"), "{text}");
    assert!(
        text.contains("tactical_diameter:") && text.contains("jackknife ["),
        "{text}"
    );
    // validate checks each recorded metric against the refits' range.
    let out = shipid_ok(&["validate", model, "data/kvlcc2-mmg/dataset.toml", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["jackknife"]["refits"], 4, "{v}");
    let turn = &v["jackknife"]["recordings"]["tc35_sb.csv"]["tactical_diameter"];
    let recorded = turn["recorded"].as_f64().unwrap();
    let (lo, hi) = (
        turn["jackknife"][0].as_f64().unwrap(),
        turn["jackknife"][1].as_f64().unwrap(),
    );
    assert!(
        lo <= hi && (recorded - 0.5 * (lo + hi)).abs() < 0.01 * recorded,
        "{turn}"
    );
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
    // The turn lies outside the ellipsoid of the zig-zag's states, for the mmg case as for reduced32.
    let result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(case.path().join("result.json")).unwrap())
            .unwrap();
    let outside = result["tests"][0]["outside_identification_range"]
        .as_f64()
        .unwrap_or_else(|| panic!("{result}"));
    assert!(outside > 0.5, "{outside}");
}

#[test]
fn simulate_and_validate_run_the_valley_of_a_refined_mmg_fit_beside_it() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("mmg.toml");
    let model = model.to_str().unwrap();
    shipid_ok(&[
        "fit",
        "data/kvlcc2-mmg/dataset.toml",
        "--set",
        "mmg",
        "--recordings",
        "zz35_35_ps.csv",
        "--out",
        model,
    ]);
    // A [valley] as `fit --tune --refine` writes it, made by hand so that the test stays fast: one
    // start in the valley with a weaker yaw damping (its turn is tighter), one above the tolerance.
    let text = std::fs::read_to_string(model).unwrap();
    let mut file: toml::Table = toml::from_str(&text).unwrap();
    let values: toml::Table = file["parameter"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            let name = p["name"].as_str().unwrap();
            let v = p["value"].as_float().unwrap();
            let v = if name == "n_r" { 0.95 * v } else { v };
            (name.to_string(), toml::Value::Float(v))
        })
        .collect();
    let start = |ratio: f64| {
        toml::Value::Table(toml::Table::from_iter([
            ("prior_weight".into(), toml::Value::Float(1e-4)),
            ("cost_ratio".into(), toml::Value::Float(ratio)),
            ("values".into(), toml::Value::Table(values.clone())),
        ]))
    };
    file.insert(
        "valley".into(),
        toml::Value::Table(toml::Table::from_iter([
            ("method".into(), toml::Value::String("by hand".into())),
            ("cost_tolerance".into(), toml::Value::Float(0.2)),
            (
                "start".into(),
                toml::Value::Array(vec![start(1.05), start(3.0)]),
            ),
        ])),
    );
    std::fs::write(model, toml::to_string(&file).unwrap()).unwrap();
    let out = shipid_ok(&[
        "simulate",
        model,
        "--manoeuvre",
        "turning:35:port",
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let point = v["tactical_diameter"].as_f64().unwrap();
    let range = &v["tactical_diameter_valley"];
    let (lo, hi) = (range[0].as_f64().unwrap(), range[1].as_f64().unwrap());
    assert!(lo < point - 0.01 && (hi - point).abs() < 1e-12, "{v}");
    assert_eq!(v["valley"]["starts"], 2, "{v}");
    assert_eq!(v["valley"]["in_valley"], 1, "{v}");
    assert_eq!(v["valley"]["members"][0]["cost_ratio"], 1.05, "{v}");
    let text = shipid_ok(&["simulate", model, "--manoeuvre", "turning:35:port"]);
    let stdout = String::from_utf8_lossy(&text.stdout);
    assert!(
        stdout.contains("valley [")
            && stdout
                .contains("1 of the 2 refinements from the other prior weights end within 20 %"),
        "{stdout}"
    );
    // validate: every recorded metric against the valley's range, the members re-simulated as the
    // model is.
    let out = shipid_ok(&["validate", model, "data/kvlcc2-mmg/dataset.toml", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let cell = &v["valley"]["recordings"]["tc35_ps.csv"]["tactical_diameter"];
    let (lo, hi) = (
        cell["valley"][0].as_f64().unwrap(),
        cell["valley"][1].as_f64().unwrap(),
    );
    let predicted = cell["predicted"].as_f64().unwrap();
    let recorded = cell["recorded"].as_f64().unwrap();
    assert!(
        lo < predicted - 0.01 && (hi - predicted).abs() < 1e-12,
        "{cell}"
    );
    assert_eq!(cell["inside"], lo <= recorded && recorded <= hi, "{cell}");
    assert_eq!(v["valley"]["in_valley"], 1, "{v}");
    let out = shipid_ok(&["validate", model, "data/kvlcc2-mmg/dataset.toml"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("lie in the valley's range")
            && stdout
                .lines()
                .any(|l| l.starts_with("tc35_ps.csv") && l.contains("tactical_diameter")),
        "{stdout}"
    );
    // A damaged start is named before anything runs.
    let damaged = dir.path().join("damaged.toml");
    let mut bad = file.clone();
    bad["valley"]["start"][0]["values"]["n_r"] = toml::Value::Float(f64::NAN);
    std::fs::write(&damaged, toml::to_string(&bad).unwrap()).unwrap();
    check_exit(
        &[
            "simulate",
            damaged.to_str().unwrap(),
            "--manoeuvre",
            "turning:35:port",
        ],
        2,
        "key `valley.start[0].values.n_r`",
    );
    check_exit(
        &[
            "validate",
            damaged.to_str().unwrap(),
            "data/kvlcc2-mmg/dataset.toml",
        ],
        2,
        "key `valley.start[0].values.n_r`",
    );
}

/// Regression: a fit that runs straight away from U0 at its own propeller rate starts `simulate`'s
/// manoeuvre from its straight-run speed, and its bootstrap replicates must start there too (they
/// started at U0, and the band lay beside the point: tactical diameter 3.400 L, band [3.28, 3.30]).
#[test]
fn the_bands_of_a_model_off_u0_start_where_the_point_does() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("mmg.toml");
    let model = model.to_str().unwrap();
    shipid_ok(&[
        "fit",
        "data/kvlcc2-mmg/dataset.toml",
        "--set",
        "mmg",
        "--recordings",
        "zz35_35_ps.csv",
        "--lambda",
        "1e-2",
        "--bootstrap",
        "24",
        "--out",
        model,
    ]);
    let out = shipid_ok(&[
        "simulate",
        model,
        "--manoeuvre",
        "turning:35:starboard",
        "--bands",
        "0.9",
        "--json",
    ]);
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("runs straight at"),
        "the fit was meant to run straight away from U0: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for metric in ["advance", "tactical_diameter"] {
        let point = v[metric].as_f64().unwrap();
        let band = &v[format!("{metric}_band")];
        let (lo, hi) = (band[0].as_f64().unwrap(), band[1].as_f64().unwrap());
        assert!(
            lo <= point && point <= hi,
            "{metric} {point} outside its band [{lo}, {hi}]: {v}"
        );
    }
}
