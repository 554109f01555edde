//! A model identified in a recorded wind, through the binary (issue 27): every family's model file
//! records the windage it was identified with under `[environment]`, loads back through the one
//! loader (the mmg and sparse-GP readers never see the table their format does not have), and
//! validates the windy recording it was identified on in its wind.

use std::path::PathBuf;

use crate::common::{root, shipid_ok};

/// The windy data set of the hostile corpus: one 20/20 zig-zag of the reference in a 4 m/s wind
/// from 30°, written as recorded channels, with a `[windage]` table.
fn windy_dataset() -> PathBuf {
    root().join(
        "crates/shipid/tests/hostile/environment_cli/fit_on_a_windy_recording_with_windage_names_it/dataset.toml",
    )
}

/// A fresh folder for one test's model files, removed when dropped.
struct Scratch(PathBuf);

impl Scratch {
    fn new(name: &str) -> Scratch {
        let dir = std::env::temp_dir().join(format!(
            "shipid-it-environment-{}-{name}",
            std::process::id()
        ));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// `fit` with `family_args` on the windy data set: the model file's `[environment]` names the windy
/// recording and the data set's windage (not assumed), and `validate --json` of the file on the same
/// data runs (the loader reads the file) with a replay error below `max_position_over_l`.
fn check(family_args: &[&str], max_position_over_l: f64) {
    let dir = Scratch::new(&family_args.join("-"));
    let model = dir.0.join("model.toml");
    let data = windy_dataset();
    let mut args = vec!["fit", data.to_str().unwrap()];
    args.extend_from_slice(family_args);
    args.extend(["--out", model.to_str().unwrap()]);
    shipid_ok(&args);
    let text = std::fs::read_to_string(&model).unwrap();
    let table: toml::Table = toml::from_str(&text).unwrap();
    let env = table["environment"].as_table().unwrap();
    assert_eq!(env["removed"].as_bool(), Some(true), "{family_args:?}");
    assert_eq!(env["windage_assumed"].as_bool(), Some(false));
    assert_eq!(env["wind_recordings"].as_array().unwrap().len(), 1);
    assert_eq!(
        env["windage"]["lateral_area_m2"].as_float(),
        Some(1.42),
        "{family_args:?}"
    );
    let out = shipid_ok(&[
        "validate",
        model.to_str().unwrap(),
        data.to_str().unwrap(),
        "--json",
    ]);
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let pos = json["recordings"]["windy.csv"]["replay"]["position_rmse_over_l"]
        .as_f64()
        .unwrap();
    assert!(
        pos < max_position_over_l,
        "{family_args:?}: {pos} L on its own windy run"
    );
}

#[test]
fn every_family_records_the_windage_it_was_identified_with_and_loads_back() {
    check(&["--set", "full74", "--estimator", "lsq"], 0.05);
    check(&["--set", "mmg", "--estimator", "bounded-lsq"], 0.005);
    check(&["--estimator", "sparse-gp"], 0.02);
}

/// Regression (`simulate --wind --out` wrote no wind channels, while `--current` wrote its own): a
/// run in a wind, written as a recording and read back as one, kept its current and lost its wind.
/// The time series now carries the wind as recorded channels: speed [m/s] and the direction it comes
/// from [rad], which is the asked 240°.
#[test]
fn simulate_in_a_wind_writes_the_wind_channels() {
    let dir = Scratch::new("simulate-wind");
    let out = dir.0.join("run.csv");
    shipid_ok(&[
        "simulate",
        "mmg:kvlcc2",
        "--manoeuvre",
        "zigzag:10/10:port",
        "--duration",
        "5",
        "--wind",
        "3,240",
        "--current",
        "0.05,90",
        "--out",
        out.to_str().unwrap(),
    ]);
    let text = std::fs::read_to_string(&out).unwrap();
    let mut rows = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = rows.next().unwrap().split(',').collect();
    let first: Vec<f64> = rows
        .next()
        .unwrap()
        .split(',')
        .map(|c| c.parse().unwrap())
        .collect();
    let at = |name: &str| {
        let i = header.iter().position(|h| *h == name);
        first[i.unwrap_or_else(|| panic!("no `{name}` column in {header:?}"))]
    };
    assert!((at("wind_speed") - 3.0).abs() < 1e-9);
    assert!((at("wind_from") - 240f64.to_radians()).abs() < 1e-6);
    assert!((at("current_speed") - 0.05).abs() < 1e-9);
    assert!((at("current_from") - 90f64.to_radians()).abs() < 1e-6);
}
