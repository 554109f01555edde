//! What a re-simulation takes from the recording it is compared with: the recorded propeller rate (a
//! model that takes the rate, the mmg family, replays a recording at the rate it recorded, not at the
//! one it holds) and a zig-zag's reaction delay at its checks.

use shipid_io::{DatasetRecording, Manoeuvre, Recording, Side};
use shipid_pipeline::generate::T_EXECUTE_S;
use shipid_pipeline::replay::{replay_segment_in, segments};
use shipid_pipeline::simulate::straight_run_speed;
use shipid_pipeline::validate::{
    rates_between_runs_note, recorded_rate_notes, training_rates_note, validate_recording,
};
use shipid_sim::{
    Dynamics, MmgModel, RecordedRate, SimOptions, State, Turning, WithPropellerRate, simulate,
};

/// A 35° starboard turn of the MMG reference from U0, its propeller at `rate` (written to `n`).
fn turn_at(rate: RecordedRate) -> DatasetRecording {
    let model = MmgModel::kvlcc2();
    let ship = *model.ship();
    let mut turning = Turning::new(35.0, Side::Starboard, T_EXECUTE_S).unwrap();
    let driven = WithPropellerRate::new(&model, rate);
    let out = simulate(
        &driven,
        &mut turning,
        State::approach(ship.u0),
        &SimOptions::new(150.0).with_step(0.01, 0.05),
    )
    .unwrap();
    DatasetRecording {
        file: "tc35_sb.csv".into(),
        manoeuvre: Manoeuvre::Turning {
            rudder_deg: 35.0,
            side: Side::Starboard,
        },
        recording: out.recording,
    }
}

#[test]
fn validation_of_an_mmg_model_ignored_the_recorded_propeller_rate() {
    // The model holds its self-propulsion rate; the run was made 15 % faster. Before the recorded
    // rate drove the replay, validation ran the model at its own rate and blamed the model.
    let model = MmgModel::kvlcc2();
    let ship = *model.ship();
    let fast = 1.15 * model.propeller_rate();
    let r = turn_at(RecordedRate::constant(fast));
    assert_eq!(r.recording.n.as_ref().unwrap()[0], fast);
    let at_recorded = validate_recording(&model, &r, &ship);
    assert!(
        at_recorded.replay.heading_rmse_deg < 0.05,
        "{:?}",
        at_recorded.replay
    );
    let mrae = at_recorded.manoeuvre.as_ref().unwrap().mrae.unwrap();
    assert!(mrae < 2e-3, "closed-loop MRAE {mrae}");
    // The same run without its `n` column is replayed at the model's rate: far off.
    let mut without_n = r.clone();
    without_n.recording.n = None;
    let at_own = validate_recording(&model, &without_n, &ship);
    assert!(at_own.replay.heading_rmse_deg > 1.0, "{:?}", at_own.replay);
}

#[test]
fn a_segment_replay_follows_a_rate_that_drops_in_the_turn() {
    // A sea trial's rate falls as the ship slows in the turn: 11.85 to 9 1/s over the first 60 s.
    let model = MmgModel::kvlcc2();
    let own = model.propeller_rate();
    let schedule = Recording {
        t: vec![0.0, 10.0, 70.0],
        n: Some(vec![own, own, 0.76 * own]),
        ..Recording::default()
    };
    let mut r = turn_at(RecordedRate::of_recording(&schedule).unwrap());
    // The simulation writes the rate at its start; the recording carries the whole schedule.
    let rate = RecordedRate::of_recording(&schedule).unwrap();
    r.recording.n = Some(r.recording.t.iter().map(|&t| rate.at(t)).collect());
    let ship = *model.ship();
    let horizon_s = 10.0 * ship.lpp / ship.u0;
    let segs = segments(&r.recording, horizon_s);
    assert!(segs.len() >= 3);
    let mut without_n = r.recording.clone();
    without_n.n = None;
    // Heading error [°] at the end of each segment replayed from `rec`.
    let end_errors = |rec: &Recording| -> Vec<f64> {
        segs.iter()
            .map(|&(a, b)| {
                let (sim, ok) = replay_segment_in(&model, None, rec, a, b);
                assert!(ok, "segment {a}..{b} diverged");
                (sim.psi[sim.len() - 1] - rec.psi[b - 1]).abs().to_degrees()
            })
            .collect()
    };
    let (driven, own_rate) = (end_errors(&r.recording), end_errors(&without_n));
    // Where the rate has dropped (every segment after the first) the recorded rate is what replays
    // the run; the first segment's error is the replay's own (its smoothed start, its coarser step).
    for (k, (d, o)) in driven.iter().zip(&own_rate).enumerate().skip(1) {
        assert!(
            *d < 0.2 && *d < 0.1 * o,
            "segment {k}: {d}° driven, {o}° at the model's rate"
        );
    }
}

/// The notes a validation of a model that takes the rate (holding `own` 1/s) gives recordings of
/// the rates `rates` (one recording each, constant over 10 samples unless a pair is given).
fn check_notes(own: f64, rates: &[(f64, f64)], expected: &[&str]) {
    let notes = recorded_rate_notes(Some(own), &runs_at(rates));
    assert_eq!(notes.len(), usize::from(!expected.is_empty()), "{notes:?}");
    for e in expected {
        assert!(notes[0].contains(e), "{notes:?} lacks {e}");
    }
}

/// One recording per `(from, to)` pair, its rate going linearly from one to the other over 10 samples.
fn runs_at(rates: &[(f64, f64)]) -> Vec<DatasetRecording> {
    rates
        .iter()
        .enumerate()
        .map(|(k, &(from, to))| DatasetRecording {
            file: format!("run{k}.csv"),
            manoeuvre: Manoeuvre::Free,
            recording: Recording {
                t: (0..10).map(f64::from).collect(),
                n: Some(
                    (0..10)
                        .map(|i| from + (to - from) * i as f64 / 9.0)
                        .collect(),
                ),
                ..Recording::default()
            },
        })
        .collect()
}

#[test]
fn a_validation_says_which_recordings_run_at_another_rate() {
    check_notes(10.0, &[(10.0, 10.0), (10.05, 10.05)], &[]);
    check_notes(
        10.0,
        &[(10.0, 10.0), (11.0, 11.0)],
        &["run1.csv (11.000 1/s)"],
    );
    check_notes(
        10.0,
        &[(10.0, 8.0)],
        &["run0.csv (8.000–10.000 1/s)", "own 10.000"],
    );
}

#[test]
fn at_another_rate_the_reference_approaches_at_the_speed_of_its_advance_ratio() {
    // The MMG forces of a straight run are homogeneous of degree two in (u, n): the straight-run
    // speed scales with the rate, and at its own rate (solved for U0) it is U0.
    let model = MmgModel::kvlcc2();
    let u0 = model.ship().u0;
    for factor in [0.6, 0.8633, 1.0, 1.2] {
        let n = factor * model.propeller_rate();
        let driven = WithPropellerRate::new(&model, RecordedRate::constant(n));
        let u = straight_run_speed(&driven).unwrap();
        assert!((u / u0 - factor).abs() < 1e-9, "n = {n}: {u} m/s");
    }
    // No propeller: no straight run at any speed.
    let stopped = WithPropellerRate::new(&model, RecordedRate::constant(0.0));
    assert_eq!(straight_run_speed(&stopped), None);
}

#[test]
fn validation_of_a_zigzag_recorded_with_a_late_reversal_blamed_the_model() {
    // The recording's helmsman reverses 0.3 s after each check (the HSVA tests' ≈ 0.28 s). Before the
    // re-simulation took the recording's own delay, the exact model's overshoots came out smaller
    // than the recorded ones and validation blamed the model.
    let model = MmgModel::kvlcc2();
    let ship = *model.ship();
    let mut zz = shipid_sim::ZigZag::new(20.0, 20.0, Side::Port, T_EXECUTE_S)
        .unwrap()
        .with_reaction_delay(0.3)
        .unwrap();
    let out = simulate(
        &model,
        &mut zz,
        State::approach(ship.u0),
        &SimOptions::new(120.0).with_step(0.05, 0.1),
    )
    .unwrap();
    let r = DatasetRecording {
        file: "zz20_20_ps.csv".into(),
        manoeuvre: Manoeuvre::ZigZag {
            rudder_deg: 20.0,
            check_deg: 20.0,
            side: Side::Port,
        },
        recording: out.recording,
    };
    let v = validate_recording(&model, &r, &ship);
    let m = v.manoeuvre.as_ref().unwrap();
    let delay = m.reaction_delay_s.unwrap();
    assert!((delay - 0.3).abs() < 2e-3, "measured delay {delay}");
    assert!(m.mrae.unwrap() < 1e-3, "{m:?}");
}

/// Regression (`slow-tests-u0-mismatch`): an mmg model identified from runs at 6 rps (steady at
/// 0.6 m/s) in a data set whose U0 is 1.179 m/s started `simulate`'s standard manoeuvres at U0 with
/// its own 6 rps, slowing down through the execute (tactical diameter 3.67 L instead of 3.12 L).
#[test]
fn a_model_at_its_own_rate_starts_a_standard_manoeuvre_from_its_straight_run() {
    use shipid_pipeline::simulate::{OwnRateApproach, own_rate_approach};
    let check = |model: &dyn Dynamics, expected: OwnRateApproach| {
        let got = own_rate_approach(model);
        match (got, expected) {
            (
                OwnRateApproach::StraightRun { speed_m_s, rate_hz },
                OwnRateApproach::StraightRun {
                    speed_m_s: want_u,
                    rate_hz: want_n,
                },
            ) => assert!(
                (speed_m_s - want_u).abs() < 0.01 * want_u && rate_hz == want_n,
                "{got:?} against {expected:?}"
            ),
            _ => assert_eq!(got, expected),
        }
    };
    let reference = MmgModel::kvlcc2();
    let ship = *reference.ship();
    check(&reference, OwnRateApproach::AtU0);
    let own = reference.propeller_rate();
    // The same ship at half its rate: the advance ratio holds, so it runs straight at half its speed.
    let slow = MmgModel::at_rate(ship, *reference.parameters(), 0.5 * own).unwrap();
    check(
        &slow,
        OwnRateApproach::StraightRun {
            speed_m_s: straight_run_speed(&WithPropellerRate::new(
                &reference,
                RecordedRate::constant(0.5 * own),
            ))
            .unwrap(),
            rate_hz: 0.5 * own,
        },
    );
    // A model whose rate is fixed by a recording takes no other: its approach is U0.
    let driven = WithPropellerRate::new(&reference, RecordedRate::constant(0.5 * own));
    check(&driven, OwnRateApproach::AtU0);
}

/// Regression (`rate-differs-between-runs-no-warning`): a polynomial fitted on runs at 11.85 and at
/// 6 rps said nothing, and its validation then named one of its own training runs as recorded at a
/// rate other than the model's.
#[test]
fn a_fit_without_a_rate_input_on_runs_at_different_rates_says_so() {
    let check = |rates: &[f64], expected: Option<&str>| {
        let pairs: Vec<(f64, f64)> = rates.iter().map(|&n| (n, n)).collect();
        let note = rates_between_runs_note(&runs_at(&pairs));
        match expected {
            None => assert_eq!(note, None),
            Some(e) => assert!(note.as_deref().is_some_and(|n| n.contains(e)), "{note:?}"),
        }
    };
    check(&[10.0], None);
    check(&[10.0, 10.05, 9.97], None);
    check(
        &[11.852, 6.0],
        Some("different propeller rates (run0.csv 11.852, run1.csv 6.000 1/s)"),
    );
}

/// Regression: an mmg fit of recordings at 10 and 11 1/s simulated its standard manoeuvres at the
/// samples' median rate without a word; within 1 % the rates count as one.
#[test]
fn an_mmg_fit_says_when_its_training_runs_differ_in_rate() {
    let note = training_rates_note(10.5, &runs_at(&[(10.0, 10.0), (11.0, 11.0)])).unwrap();
    for words in [
        "run0.csv 10.000, run1.csv 11.000 1/s",
        "own rate",
        "10.500 1/s",
    ] {
        assert!(note.contains(words), "{note} lacks {words}");
    }
    assert_eq!(
        training_rates_note(10.0, &runs_at(&[(10.0, 10.0), (10.05, 10.05)])),
        None
    );
}
