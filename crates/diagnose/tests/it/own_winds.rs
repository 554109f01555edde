//! Runs each in a wind of its own (real trials meet a different wind on every run), CI-sized: the
//! per-recording wind family names each run's concealed wind, and leaves runs whose winds are
//! recorded alone. (The one-wind case, which must stay one wind for all, is in `known_wind`.)

use shipid_diagnose::known_wind::{KnownWindCase, WindRun, case_dataset};
use shipid_diagnose::{
    DiagnoseOptions, Report, RevealCheck, Verdict, angle_difference_deg, conceal, diagnose, reveal,
};

use crate::known_wind::{base, input};

/// Four runs (the zig-zags), each in its own steady wind of 2.5–4.5 m/s from its own direction.
fn four_runs_in_own_winds(seed: u64) -> shipid_io::Dataset {
    let case = KnownWindCase {
        id: format!("own-winds-s{seed}"),
        wind: WindRun {
            speed_m_s: 3.5,
            from_deg: 0.0,
            gust: 0.0,
            seed,
        },
        control: false,
        seed,
        own_winds: true,
    };
    let mut ds = case_dataset(&case).unwrap();
    ds.recordings.retain(|r| r.file.starts_with("zz"));
    assert_eq!(ds.recordings.len(), 4);
    ds
}

/// The diagnosis of `ds` against the base, with the wind channels concealed when `concealed`, and
/// the reveal check.
fn diagnosed(mut ds: shipid_io::Dataset, concealed: bool) -> (Report, Option<RevealCheck>) {
    let (model, level) = base();
    let hidden = concealed.then(|| conceal(&mut ds).unwrap());
    let report = diagnose(
        &input(&model, Some(level)),
        &ds,
        &DiagnoseOptions::default(),
    )
    .unwrap();
    let check = hidden.map(|c| reveal(report.verdict, &[], &report.per_recording_wind, &c));
    (report, check)
}

#[test]
fn data_set_of_runs_in_different_winds_was_unexplained() {
    // Regression: one wind was fitted to every run, and runs in winds from different directions
    // were `unexplained`. Each run's wind is now found on its own, judged on its time halves.
    let ds = four_runs_in_own_winds(31);
    let winds: Vec<(f64, f64)> = ds
        .recordings
        .iter()
        .map(|r| {
            let w = shipid_diagnose::FlowSummary::of(r.recording.wind.as_ref()).unwrap();
            (w.speed_mean_m_s, w.from_mean_deg)
        })
        .collect();
    // The data set is what the test claims: 2.5–4.5 m/s, directions at least 45° apart.
    assert!(
        winds.iter().all(|w| (2.4..=4.6).contains(&w.0)),
        "{winds:?}"
    );
    assert!(
        winds.iter().enumerate().all(|(i, a)| winds[i + 1..]
            .iter()
            .all(|b| angle_difference_deg(a.1, b.1) >= 45.0)),
        "{winds:?}"
    );
    let (report, check) = diagnosed(ds, true);
    assert_eq!(report.verdict, Verdict::Wind, "{}", report.explanation);
    assert!(report.effects.is_empty(), "{:?}", report.effects);
    assert_eq!(report.per_recording_wind.len(), 4, "{}", report.explanation);
    let check = check.unwrap();
    assert!(check.verdict_right, "{:?}", check.lines());
    assert_eq!(check.wind_per_recording.len(), 4);
    for w in &check.wind_per_recording {
        let d = w.wind.direction_error_deg.unwrap();
        assert!(d <= 30.0, "{}: direction error {d}°", w.recording);
    }
    let improvement =
        1.0 - report.fit_after.position_rmse_over_l / report.fit_before.position_rmse_over_l;
    assert!(
        improvement >= 0.5,
        "improvement {improvement}: {}",
        report.explanation
    );
}

#[test]
fn runs_whose_own_winds_are_recorded_are_left_alone() {
    // The control: the same kind of runs with their wind channels kept (part of the base).
    let (report, _) = diagnosed(four_runs_in_own_winds(32), false);
    assert_eq!(report.verdict, Verdict::None, "{}", report.explanation);
    assert!(report.per_recording_wind.is_empty());
}
