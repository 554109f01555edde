//! Divergence handling: unstable or failing models end with `SimStatus::Diverged` at the right time,
//! keep the samples before it and never panic; invalid input is a typed error.

use shipid_io::{AddedMass, Ship, Side};
use shipid_sim::{
    Dynamics, DynamicsError, Input, MmgModel, SimError, SimOptions, SimStatus, State, Turning,
    kvlcc2_ship, simulate,
};

/// Yaw that feeds itself: ṙ = λ r (an unstable first-order yaw mode), surge and sway at rest.
struct UnstableYaw {
    ship: Ship,
    lambda: f64,
}

impl Dynamics for UnstableYaw {
    fn accelerations_for(&self, s: &State, _input: &Input) -> Result<[f64; 3], DynamicsError> {
        Ok([0.0, 0.0, self.lambda * s.r])
    }
    fn ship(&self) -> &Ship {
        &self.ship
    }
    fn added_mass(&self) -> &AddedMass {
        &ZERO
    }
}

static ZERO: AddedMass = AddedMass {
    X_udot: 0.0,
    Y_vdot: 0.0,
    Y_rdot: 0.0,
    N_vdot: 0.0,
    N_rdot: 0.0,
};

/// Returns NaN accelerations (or an error) once the ship has passed `x_fail_m`.
struct FailsAhead {
    ship: Ship,
    x_fail_m: f64,
    as_error: bool,
}

impl Dynamics for FailsAhead {
    fn accelerations_for(&self, s: &State, _input: &Input) -> Result<[f64; 3], DynamicsError> {
        if s.x0 <= self.x_fail_m {
            Ok([0.0; 3])
        } else if self.as_error {
            Err(DynamicsError::OutOfDomain(
                "outside the fitted envelope".into(),
            ))
        } else {
            Ok([f64::NAN, 0.0, 0.0])
        }
    }
    fn ship(&self) -> &Ship {
        &self.ship
    }
    fn added_mass(&self) -> &AddedMass {
        &ZERO
    }
}

fn hold() -> Turning {
    Turning::new(10.0, Side::Starboard, 1e9).unwrap()
}

#[test]
fn unstable_model_diverges_at_the_predicted_time() {
    let ship = kvlcc2_ship();
    let (lambda, r0) = (0.2, 1e-3);
    let model = UnstableYaw { ship, lambda };
    let initial = State {
        r: r0,
        ..State::approach(ship.u0)
    };
    let opts = SimOptions::new(200.0);
    let out = simulate(&model, &mut hold(), initial, &opts).unwrap();
    // |r| L/U0 reaches the default bound 5 at t* = ln(5 U0 / (L r0)) / λ.
    let t_star = (5.0 * ship.u0 / (ship.lpp * r0)).ln() / lambda;
    let SimStatus::Diverged { t_s, reason } = &out.status else {
        panic!("expected divergence, got {:?}", out.status);
    };
    assert!(
        *t_s >= t_star && *t_s <= t_star + opts.dt_s + 1e-9,
        "t = {t_s}, predicted {t_star}"
    );
    assert!(reason.contains("L/U0"), "{reason}");
    let rec = &out.recording;
    assert!(!rec.is_empty() && *rec.t.last().unwrap() < *t_s);
    assert!(rec.r.iter().all(|r| r.abs() * ship.lpp / ship.u0 <= 5.0));
}

#[test]
fn nan_from_a_model_is_divergence_not_a_panic() {
    let ship = kvlcc2_ship();
    for as_error in [false, true] {
        let model = FailsAhead {
            ship,
            x_fail_m: 10.0 * ship.u0,
            as_error,
        };
        let out = simulate(
            &model,
            &mut hold(),
            State::approach(ship.u0),
            &SimOptions::new(60.0),
        )
        .unwrap();
        let SimStatus::Diverged { t_s, reason } = &out.status else {
            panic!("expected divergence, got {:?}", out.status);
        };
        // x0 passes 10 U0 at t = 10 s; the failing evaluation is in the step that starts at 10 s.
        assert!((*t_s - 10.0).abs() <= 0.05 + 1e-9, "t = {t_s}");
        if as_error {
            assert!(reason.contains("fitted envelope"), "{reason}");
        } else {
            assert!(reason.contains("non-finite"), "{reason}");
        }
        let rec = &out.recording;
        assert!(rec.len() >= 199 && rec.u.iter().chain(&rec.x0).all(|x| x.is_finite()));
        assert!(*rec.t.last().unwrap() <= *t_s);
    }
}

#[test]
fn model_failing_at_the_start_gives_an_empty_diverged_run() {
    let m = MmgModel::kvlcc2();
    let out = simulate(&m, &mut hold(), State::default(), &SimOptions::new(10.0)).unwrap();
    assert!(matches!(out.status, SimStatus::Diverged { t_s, .. } if t_s == 0.0));
    assert!(out.recording.is_empty());
}

#[test]
fn invalid_input_is_a_typed_error() {
    let m = MmgModel::kvlcc2();
    let init = State::approach(1.179);
    let bad = |opts: SimOptions| simulate(&m, &mut hold(), init, &opts).unwrap_err();
    assert!(matches!(
        bad(SimOptions::new(10.0).with_step(0.0, 0.05)),
        SimError::InvalidOptions { field: "dt_s", .. }
    ));
    assert!(matches!(
        bad(SimOptions::new(f64::NAN)),
        SimError::InvalidOptions {
            field: "duration_s",
            ..
        }
    ));
    assert!(matches!(
        bad(SimOptions::new(10.0).with_step(0.05, 0.12)),
        SimError::InvalidOptions {
            field: "sample_interval_s",
            ..
        }
    ));
    let nan_state = State {
        v: f64::NAN,
        ..init
    };
    assert!(matches!(
        simulate(&m, &mut hold(), nan_state, &SimOptions::new(1.0)),
        Err(SimError::InvalidInitialState(_))
    ));
}

#[test]
fn status_serialises_in_lower_case() {
    assert_eq!(
        serde_json::to_string(&SimStatus::Ok).unwrap(),
        r#"{"status":"ok"}"#
    );
    let d = SimStatus::Diverged {
        t_s: 12.5,
        reason: "speed".into(),
    };
    assert_eq!(
        serde_json::to_string(&d).unwrap(),
        r#"{"status":"diverged","t_s":12.5,"reason":"speed"}"#
    );
    let back: SimStatus =
        serde_json::from_str(r#"{"status":"diverged","t_s":12.5,"reason":"speed"}"#).unwrap();
    assert_eq!(back, d);
}

#[test]
fn sampling_is_on_the_interval_grid() {
    let m = MmgModel::kvlcc2();
    let mut c = Turning::new(35.0, Side::Port, 1.0).unwrap();
    let out = simulate(
        &m,
        &mut c,
        State::approach(1.179),
        &SimOptions::new(10.0).with_step(0.05, 0.5),
    )
    .unwrap();
    let rec = &out.recording;
    assert_eq!(rec.len(), 21);
    assert!(
        rec.t
            .iter()
            .enumerate()
            .all(|(i, t)| (t - 0.5 * i as f64).abs() < 1e-12)
    );
    assert_eq!(rec.n.as_ref().unwrap().len(), 21);
    // Rudder to port from 1 s at 15.8 °/s: −7.9° at 1.5 s, −35° from about 3.2 s on.
    assert!(
        (rec.delta[3].to_degrees() + 7.9).abs() < 1e-9,
        "{}",
        rec.delta[3].to_degrees()
    );
    assert!((rec.delta[20].to_degrees() + 35.0).abs() < 1e-9);
}
