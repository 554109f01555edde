//! The MMG model at a given propeller rate (the recorded one) instead of its self-propulsion rate.

use shipid_sim::{Dynamics, MmgError, MmgModel, MmgParameters, State, kvlcc2_ship};

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
