//! The proof with a recorded wind as known input, CI-sized (the full grid is `cargo xtask
//! bench-known-wind`, docs/benchmarks.md): a base identified from windy training runs with the wind as
//! input, a concealed strong wind found with its direction, a control with the wind kept left alone,
//! and replays that feel the recorded wind.

use shipid_diagnose::known_wind::{
    KnownWindCase, WindRun, hydrodynamic_dataset, run_case, training_dataset,
};
use shipid_diagnose::{DiagnoseInput, DiagnoseOptions, Verdict, conceal, model_level};
use shipid_pipeline::mmg::{MmgFitOptions, fit_mmg_dataset};
use shipid_sim::MmgModel;

/// The mmg family identified from the training runs with their recorded wind as input, and its own
/// level on them (identified once for every test of the binary).
pub(crate) fn base() -> (MmgModel, f64) {
    static BASE: std::sync::OnceLock<(MmgModel, f64)> = std::sync::OnceLock::new();
    BASE.get_or_init(|| {
        let training = training_dataset().unwrap();
        let hydro = hydrodynamic_dataset(&training).unwrap();
        let model = fit_mmg_dataset(&hydro, &MmgFitOptions::default())
            .unwrap()
            .model;
        let level = model_level(&input(&model, None), &training, &DiagnoseOptions::default());
        (model, level)
    })
    .clone()
}

pub(crate) fn input(model: &MmgModel, level: Option<f64>) -> DiagnoseInput<'_> {
    DiagnoseInput {
        base: model,
        base_effects: &[],
        model_level_over_l: level,
        identification_range: None,
    }
}

/// What a case must give: the verdict, and for a concealed wind the largest direction error and the
/// smallest held-out improvement.
struct Expected {
    verdict: Verdict,
    /// A `wind` verdict in its per-recording form (a wind of its own on each run).
    per_recording: bool,
    max_direction_error_deg: Option<f64>,
    min_improvement: Option<f64>,
}

fn check(model: &MmgModel, level: f64, case: &KnownWindCase, expected: Expected) {
    let row = run_case(
        &input(model, Some(level)),
        &DiagnoseOptions::default(),
        case,
    )
    .unwrap();
    assert_eq!(
        row.verdict, expected.verdict,
        "{}: {}",
        case.id, row.effects
    );
    assert_eq!(row.per_recording, expected.per_recording, "{}", case.id);
    if let Some(max) = expected.max_direction_error_deg {
        let d = row.direction_error_deg().unwrap();
        assert!(d <= max, "{}: direction error {d}°", case.id);
        let check = row.check.as_ref().unwrap();
        assert!(check.verdict_right, "{}", case.id);
    }
    if let Some(min) = expected.min_improvement {
        assert!(
            row.improvement() >= min,
            "{}: improvement {}",
            case.id,
            row.improvement()
        );
    }
}

#[test]
fn a_concealed_wind_is_found_and_a_recorded_one_is_part_of_the_base() {
    let (model, level) = base();
    let strong = WindRun {
        speed_m_s: 4.5,
        from_deg: 130.0,
        gust: 0.0,
        seed: 7,
    };
    check(
        &model,
        level,
        &KnownWindCase {
            id: "wind-4.5-steady".into(),
            wind: strong,
            control: false,
            seed: 0,
            own_winds: false,
        },
        Expected {
            verdict: Verdict::Wind,
            per_recording: false,
            max_direction_error_deg: Some(30.0),
            min_improvement: Some(0.5),
        },
    );
    check(
        &model,
        level,
        &KnownWindCase {
            id: "control-4.5-gusty".into(),
            wind: WindRun {
                gust: 0.3,
                ..strong
            },
            control: true,
            seed: 1,
            own_winds: false,
        },
        Expected {
            verdict: Verdict::None,
            per_recording: false,
            max_direction_error_deg: None,
            min_improvement: None,
        },
    );
}

#[test]
fn replays_of_windy_runs_feel_their_recorded_wind() {
    // The MMG reference replays its own windy runs to the replay resolution when the wind is known,
    // and misses by far more with the channels concealed.
    let reference = MmgModel::kvlcc2();
    let mut ds = training_dataset().unwrap();
    let opts = DiagnoseOptions::default();
    let known = model_level(&input(&reference, None), &ds, &opts);
    conceal(&mut ds).unwrap();
    let concealed = model_level(&input(&reference, None), &ds, &opts);
    assert!(known < 1e-3, "with the wind known: {known} L");
    assert!(concealed > 10.0 * known, "{concealed} L against {known} L");
}

#[test]
fn a_recorded_wind_that_reads_half_the_true_one_is_found_against_the_recorded() {
    // The anemometer of these runs reads half the wind's speed: the diagnosis, with the recorded
    // wind part of the base, finds the missing half in the same direction and says that together
    // the ship felt the true wind.
    let (model, level) = base();
    let case = KnownWindCase {
        id: "half-read-anemometer".into(),
        wind: WindRun {
            speed_m_s: 4.5,
            from_deg: 250.0,
            gust: 0.0,
            seed: 3,
        },
        control: true,
        seed: 2,
        own_winds: false,
    };
    let mut ds = shipid_diagnose::known_wind::case_dataset(&case).unwrap();
    for r in &mut ds.recordings {
        let w = r.recording.wind.as_mut().unwrap();
        w.speed_m_s.iter_mut().for_each(|s| *s *= 0.5);
    }
    let report = shipid_diagnose::diagnose(
        &input(&model, Some(level)),
        &ds,
        &DiagnoseOptions::default(),
    )
    .unwrap();
    assert_eq!(report.verdict, Verdict::Wind, "{}", report.explanation);
    let against = &report.against_recorded[0];
    assert_eq!(against.flow, "wind");
    assert!(
        against.direction_difference_deg < 10.0,
        "{}",
        against.sentence()
    );
    assert!(
        (against.felt_speed_m_s - 4.5).abs() < 0.3,
        "{}",
        against.sentence()
    );
    assert!(report.explanation.contains("the recordings carry a wind"));
}

#[test]
fn one_run_diagnosed_alone_finds_its_own_wind() {
    // Real trials meet a different wind on every run, and one wind cannot explain them all: each
    // run is diagnosed on its own (`diagnose --recording`), judged on the two halves of its time.
    // Regression: a single recording had no held-out half, so no effect could ever be accepted.
    let (model, level) = base();
    for (id, from_deg) in [("alone-from-060", 60.0), ("alone-from-200", 200.0)] {
        let case = KnownWindCase {
            id: id.into(),
            wind: WindRun {
                speed_m_s: 4.5,
                from_deg,
                gust: 0.0,
                seed: 5,
            },
            control: false,
            seed: 4,
            own_winds: false,
        };
        let mut ds = shipid_diagnose::known_wind::case_dataset(&case).unwrap();
        ds.recordings.retain(|r| r.file.starts_with("zz20"));
        assert_eq!(ds.recordings.len(), 1);
        conceal(&mut ds).unwrap();
        let report = shipid_diagnose::diagnose(
            &input(&model, Some(level)),
            &ds,
            &DiagnoseOptions::default(),
        )
        .unwrap();
        assert_eq!(
            report.verdict,
            Verdict::Wind,
            "{id}: {}",
            report.explanation
        );
        let found: shipid_sim::Effect = report.effects[0].parse().unwrap();
        let shipid_sim::Effect::Wind(w) = found else {
            panic!("{id}: {}", report.effects[0]);
        };
        let error = ((w.from_deg - from_deg + 540.0).rem_euclid(360.0) - 180.0).abs();
        assert!(error < 30.0, "{id}: found from {}°", w.from_deg);
        assert!(
            (w.speed_m_s - 4.5).abs() < 1.0,
            "{id}: found {} m/s",
            w.speed_m_s
        );
    }
}
