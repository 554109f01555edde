//! The MMG model at a given propeller rate (the recorded one) instead of its self-propulsion rate, and
//! driven by a recorded rate.

use shipid_io::Recording;
use shipid_sim::{
    Dynamics, MmgError, MmgModel, MmgParameters, RecordedRate, State, WithPropellerRate,
    kvlcc2_ship,
};

fn turning_state() -> State {
    State {
        u: 0.9,
        v: -0.12,
        r: 0.05,
        ..State::default()
    }
}

#[test]
fn at_the_self_propulsion_rate_the_model_is_the_reference() {
    let reference = MmgModel::kvlcc2();
    let at = MmgModel::at_rate(
        kvlcc2_ship(),
        MmgParameters::kvlcc2(),
        reference.propeller_rate(),
    )
    .unwrap();
    let s = turning_state();
    assert_eq!(at.accelerations(&s, 0.5), reference.accelerations(&s, 0.5));
}

#[test]
fn forces_at_a_rate_are_those_of_the_model_built_at_that_rate() {
    let reference = MmgModel::kvlcc2();
    let s = turning_state();
    for n_hz in [0.0, 5.0, 10.2295, 15.0] {
        let built = MmgModel::at_rate(kvlcc2_ship(), MmgParameters::kvlcc2(), n_hz).unwrap();
        assert_eq!(
            reference.forces_at_rate(&s, -0.3, n_hz).unwrap(),
            built.forces(&s, -0.3).unwrap(),
            "n = {n_hz}"
        );
    }
}

#[test]
fn a_faster_propeller_pushes_harder_and_steers_harder() {
    let m = MmgModel::kvlcc2();
    let s = State::approach(1.179);
    let slow = m.forces_at_rate(&s, 0.3, 10.0).unwrap();
    let fast = m.forces_at_rate(&s, 0.3, 12.0).unwrap();
    assert!(fast.propeller_x > slow.propeller_x);
    // The slipstream speeds up the rudder inflow: a larger normal force at the same angle.
    assert!(fast.rudder_normal.abs() > slow.rudder_normal.abs());
}

#[test]
fn a_rate_that_is_not_a_finite_non_negative_number_is_refused() {
    for n_hz in [-1.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            MmgModel::at_rate(kvlcc2_ship(), MmgParameters::kvlcc2(), n_hz),
            Err(MmgError::InvalidParameter {
                name: "propeller_rate_hz",
                ..
            })
        ));
    }
}

/// The MMG model driven by `rate` against the same model built at the rate it gives at each time.
fn check_driven(rate: &RecordedRate, times_s: &[f64]) {
    let model = MmgModel::kvlcc2();
    let driven = WithPropellerRate::new(&model, rate.clone());
    let s = turning_state();
    for &t in times_s {
        let built = MmgModel::at_rate(kvlcc2_ship(), MmgParameters::kvlcc2(), rate.at(t)).unwrap();
        assert_eq!(
            driven.accelerations_at(t, &s, 0.4).unwrap(),
            built.accelerations(&s, 0.4).unwrap(),
            "t = {t} s"
        );
    }
}

#[test]
fn a_recorded_rate_drives_the_model_at_every_time() {
    let own = MmgModel::kvlcc2().propeller_rate();
    check_driven(&RecordedRate::constant(own), &[0.0, 10.0]);
    // A rate that drops from 12 to 9 1/s over 20 s of a recording that starts at t = 5 s; held at
    // the ends.
    let rec = Recording {
        t: vec![5.0, 15.0, 25.0],
        n: Some(vec![12.0, 10.5, 9.0]),
        ..Recording::default()
    };
    let rate = RecordedRate::of_recording(&rec).unwrap();
    assert_eq!(rate.at(5.0), 11.25);
    check_driven(&rate, &[-1.0, 0.0, 5.0, 20.0, 40.0]);
    check_driven(&rate.replay_from(15.0), &[0.0, 5.0, 10.0]);
}

#[test]
fn a_recording_without_a_usable_rate_drives_nothing() {
    let t = vec![0.0, 1.0];
    for n in [None, Some(vec![10.0]), Some(vec![10.0, f64::NAN])] {
        let rec = Recording {
            t: t.clone(),
            n: n.clone(),
            ..Recording::default()
        };
        assert_eq!(RecordedRate::of_recording(&rec), None, "n = {n:?}");
    }
}

/// Regression (the ahead thrust curve evaluated at n < 0 gave a forward thrust: a ship with its
/// propeller astern at −8 rps kept its speed better than one with the propeller stopped): the model
/// has no astern quadrant and says so instead of answering.
#[test]
fn a_propeller_turning_astern_has_no_forces() {
    let m = MmgModel::kvlcc2();
    let s = State::approach(1.179);
    for n_hz in [-8.0, -1e-3] {
        assert!(
            matches!(
                m.forces_at_rate(&s, 0.0, n_hz),
                Err(shipid_sim::DynamicsError::PropellerAstern { .. })
            ),
            "n = {n_hz}"
        );
    }
    assert!(m.forces_at_rate(&s, 0.0, 0.0).is_ok());
}
