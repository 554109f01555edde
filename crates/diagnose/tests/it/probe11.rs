//! Regressions of a probe of `diagnose` (2026-12): a changed ship named as a wind or an asymmetry,
//! recordings shorter than the replay horizon diagnosed `none`, mismatch windows located on an exact
//! model's own clean data. Data-driven: each test is a list of cases, one check per concern.

use shipid_diagnose::bench::to_dataset;
use shipid_diagnose::{DiagnoseInput, DiagnoseOptions, Report, diagnose};
use shipid_io::Dataset;
use shipid_pipeline::generate::{default_manoeuvres, generate_model, generate_with};
use shipid_sim::mmg::{MmgParameters, kvlcc2_ship};
use shipid_sim::{Effect, MmgModel};

/// The default manoeuvres of the KVLCC2 with its rudder area × `area_factor`, tank noise of `seed`,
/// keeping the recordings whose file starts with one of `keep`.
fn changed_rudder(area_factor: f64, seed: u64, keep: &[&str]) -> Dataset {
    let params = MmgParameters {
        rudder_area_m2: MmgParameters::kvlcc2().rudder_area_m2 * area_factor,
        ..MmgParameters::kvlcc2()
    };
    let model = MmgModel::new(kvlcc2_ship(), params).unwrap();
    let g = generate_model(&model, "changed rudder", Some(seed), &default_manoeuvres()).unwrap();
    let mut ds = to_dataset(g, "changed-rudder");
    ds.recordings
        .retain(|r| keep.iter().any(|k| r.file.starts_with(k)));
    assert!(!ds.recordings.is_empty());
    ds
}

/// The diagnosis against the MMG reference (an exact base for the calm-water ship), judged against
/// the noise (no own level).
fn against_reference(ds: &Dataset) -> Report {
    let model = MmgModel::kvlcc2();
    diagnose(
        &DiagnoseInput {
            base: &model,
            base_effects: &[],
            model_level_over_l: None,
            identification_range: None,
        },
        ds,
        &DiagnoseOptions::default(),
    )
    .unwrap()
}

/// A changed ship is no named effect: the verdict is none of `wrong`, and the explanation claims no
/// wind the diagnosis did not find.
fn check_not_named(id: &str, report: &Report, wrong: &[&str]) {
    let verdict = report.verdict.word();
    assert!(
        !wrong.contains(&verdict),
        "{id}: verdict {verdict}: {}",
        report.explanation
    );
    if verdict != "wind" {
        assert!(
            !report.explanation.contains("they were in one wind"),
            "{id}: {}",
            report.explanation
        );
    }
}

/// Probe finding 1: a 25 % smaller rudder on the four zig-zags was `wind`, 5.8 m/s from astern, with
/// "they were in one wind", and the augmented model made the whole-record replays worse (zz10
/// 2.5 → 25 L); probe finding 2: one turning circle of it alone was `asymmetry` (a side force whose
/// sign flipped with the turn), one zig-zag alone `wind`.
#[test]
fn a_smaller_rudder_is_not_named_wind_or_asymmetry() {
    let cases: [(&str, &[&str]); 4] = [
        ("four zig-zags", &["zz"]),
        ("one turning circle to port", &["tc35_ps"]),
        ("one turning circle to starboard", &["tc35_sb"]),
        ("one zig-zag 35/35", &["zz35_35_ps"]),
    ];
    for (id, keep) in cases {
        let report = against_reference(&changed_rudder(0.75, 400, keep));
        check_not_named(id, &report, &["wind", "asymmetry", "none"]);
    }
}

/// The held-back candidate is in the report with the evidence against it.
#[test]
fn a_held_back_effect_says_why() {
    let report = against_reference(&changed_rudder(0.75, 400, &["zz"]));
    let held: Vec<&str> = report
        .candidates
        .iter()
        .filter_map(|c| c.held_back.as_deref())
        .collect();
    assert!(
        held.iter()
            .any(|h| h.contains("whole-record replays get worse")),
        "{held:?}"
    );
    assert!(
        report.explanation.contains("is not the verdict"),
        "{}",
        report.explanation
    );
}

/// Every recording cut to its first `samples` samples.
fn first_samples(mut ds: Dataset, samples: usize) -> Dataset {
    for r in &mut ds.recordings {
        r.recording = r.recording.slice(0..samples.min(r.recording.len()));
    }
    ds
}

/// Probe finding 4: recordings of 6 s (a concealed current of 0.03 m/s) under the 59-s horizon were
/// `none`, with a noise floor of 59-s segments (0.0051 L) above the current's whole mismatch; the
/// horizon is now shortened to the recordings, and said: the diagnosis is the one asked for with
/// that horizon.
#[test]
fn recordings_shorter_than_the_horizon_shorten_it() {
    let effect: Effect = "current:speed=0.03,from=120".parse().unwrap();
    for (seed, samples) in [(5, 60), (6, 150)] {
        let ds = first_samples(
            to_dataset(
                generate_with(Some(seed), std::slice::from_ref(&effect)).unwrap(),
                "short",
            ),
            samples,
        );
        let id = format!("seed {seed}, {samples} samples");
        let report = against_reference(&ds);
        let length_s = ds
            .recordings
            .iter()
            .map(|r| r.recording.t[samples - 1] - r.recording.t[0])
            .fold(0.0, f64::max);
        assert!(
            (report.horizon_s - length_s).abs() < 1e-9,
            "{id}: {}",
            report.horizon_s
        );
        assert!(
            report
                .horizon_note
                .as_deref()
                .is_some_and(|n| n.contains("shorter than the replay horizon")),
            "{id}: {:?}",
            report.horizon_note
        );
        let ship = ds.ship;
        let asked = DiagnoseOptions {
            horizon_l_over_u0: length_s / (ship.lpp / ship.u0),
            ..DiagnoseOptions::default()
        };
        let model = MmgModel::kvlcc2();
        let direct = diagnose(
            &DiagnoseInput {
                base: &model,
                base_effects: &[],
                model_level_over_l: None,
                identification_range: None,
            },
            &ds,
            &asked,
        )
        .unwrap();
        assert_eq!(report.verdict, direct.verdict, "{id}");
        let (a, b) = (
            report.noise_floor_position_rmse_over_l,
            direct.noise_floor_position_rmse_over_l,
        );
        assert!(
            (a - b).abs() <= 1e-12 * b.max(1.0),
            "{id}: noise floor {a} against {b}"
        );
        // Not the floor of 59-s segments: below the mismatch the current makes.
        assert!(
            a < report.fit_before.position_rmse_over_l,
            "{id}: floor {a}"
        );
    }
}

/// Probe finding 8: the exact model on its own noise-free recordings (verdict none, held-out
/// 0.0001 L) listed 13 "mismatch located" windows.
#[test]
fn no_mismatch_is_located_where_there_is_none() {
    let cases: [(&str, Option<u64>); 2] = [("noise-free", None), ("tank noise", Some(3))];
    for (id, seed) in cases {
        let ds = to_dataset(generate_with(seed, &[]).unwrap(), "calm");
        let report = against_reference(&ds);
        assert_eq!(
            report.verdict.word(),
            "none",
            "{id}: {}",
            report.explanation
        );
        assert!(report.located.is_empty(), "{id}: {:?}", report.located);
    }
}
