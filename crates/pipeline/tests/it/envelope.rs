//! What `simulate` says about a run outside where its model was identified: the warning's threshold
//! and the quantities named beyond the training states' extent.

use shipid_pipeline::range::{
    EXTRAPOLATION_WARNING_SHARE, RangeSource, RunReach, StateExtent, state_range_of,
};

/// An extent whose highest speed is U0 (every run and training here approaches at U0).
fn extent(drift_deg: f64, r_prime: f64, rudder_deg: f64, speed: f64) -> StateExtent {
    StateExtent {
        max_drift_deg: drift_deg,
        max_yaw_rate_prime: r_prime,
        max_rudder_deg: rudder_deg,
        min_speed_over_u0: speed,
        max_speed_over_u0: 1.0,
    }
}

/// `expected`: `None` for no warning, else the fragments the warning must hold.
fn check(outside: f64, run: StateExtent, training: Option<StateExtent>, expected: Option<&[&str]>) {
    let reach = RunReach {
        source: RangeSource::StateEllipsoid,
        outside,
        run,
        training,
        degenerate: None,
    };
    match (reach.warning("m.toml", false), expected) {
        (None, None) => {}
        (Some(w), Some(fragments)) => {
            for f in fragments {
                assert!(w.contains(f), "`{f}` not in: {w}");
            }
        }
        (got, want) => panic!("{got:?} where {want:?} was expected"),
    }
}

#[test]
fn a_run_outside_the_training_states_is_warned_about_with_what_lies_beyond() {
    let training = extent(13.2, 0.61, 35.0, 0.58);
    // A turn from zig-zags: wider drift, faster yaw, slower.
    check(
        0.99,
        extent(21.9, 0.89, 35.0, 0.32),
        Some(training),
        Some(&[
            "99 % of this run",
            "the ellipsoid of its training states",
            "drift up to 21.9° (training ≤ 13.2°)",
            "r′ up to 0.89 (training ≤ 0.61)",
            "speed down to 0.32 U0 (training ≥ 0.58 U0)",
            "its metrics are an extrapolation",
        ]),
    );
    // A small zig-zag from a large one: every quantity within its extent, the combination not.
    check(
        0.5,
        extent(5.0, 0.3, 10.0, 0.9),
        Some(training),
        Some(&["in combinations the training did not visit"]),
    );
    // A rudder angle above the training's by more than half a degree is named; at it, not.
    check(
        0.2,
        extent(10.0, 0.5, 35.4, 0.7),
        Some(training),
        Some(&["in combinations"]),
    );
    check(
        0.2,
        extent(10.0, 0.5, 40.0, 0.7),
        Some(training),
        Some(&["rudder up to 40.0° (training ≤ 35.0°)"]),
    );
    // No training extent (its data unreadable): the share alone.
    check(
        0.3,
        extent(10.0, 0.5, 35.0, 0.7),
        None,
        Some(&["30 %", "cannot be read"]),
    );
    // At or below the threshold: no warning within the training extent; past its extremes, the
    // warning says so (below).
    check(
        EXTRAPOLATION_WARNING_SHARE,
        extent(21.9, 0.89, 35.0, 0.32),
        Some(training),
        Some(&["goes past the extremes", "only 5 % of it lies outside"]),
    );
    check(0.0, extent(5.0, 0.2, 10.0, 0.9), Some(training), None);
    // A run that diverged has no metrics: the warning says where it went instead.
    let diverged = RunReach {
        source: RangeSource::Leverage,
        outside: 0.7,
        run: extent(170.0, 1.5, 35.0, 0.2),
        training: Some(training),
        degenerate: None,
    };
    let w = diverged.warning("m.toml", true).unwrap();
    assert!(
        w.contains("it diverged out there") && !w.contains("metrics"),
        "{w}"
    );
}

/// Regression (`extent-from-near-rest-noise`): a run starting from rest has a first sample at
/// 0.005 U0 whose velocity noise points 35° off the bow; the training extent took its drift from it,
/// so a turn with 19° of drift was not named as beyond training drift of 15°.
#[test]
fn the_training_extent_takes_no_drift_from_a_ship_at_rest() {
    let ship = shipid_sim::kvlcc2_ship();
    let u0 = ship.u0;
    // (u, v) [÷ U0] of each sample; r = 0.
    let rec = |uv: &[(f64, f64)]| shipid_io::Recording {
        t: (0..uv.len()).map(|i| i as f64).collect(),
        u: uv.iter().map(|p| p.0 * u0).collect(),
        v: uv.iter().map(|p| p.1 * u0).collect(),
        r: vec![0.0; uv.len()],
        delta: vec![0.0; uv.len()],
        ..Default::default()
    };
    let check = |uv: &[(f64, f64)], drift_deg: f64, min_speed: f64| {
        let r = rec(uv);
        let e = StateExtent::of(&r, &ship, 0..uv.len()).unwrap();
        assert!((e.max_drift_deg - drift_deg).abs() < 0.05, "{e:?}");
        assert!((e.min_speed_over_u0 - min_speed).abs() < 1e-3, "{e:?}");
    };
    let at_rest = (0.004, -0.003);
    let drift_15 = (
        0.5 * 15f64.to_radians().cos(),
        -0.5 * 15f64.to_radians().sin(),
    );
    check(&[at_rest, drift_15], 15.0, 0.005);
    check(&[(1.0, 0.0), drift_15], 15.0, 0.5);
    // Just above the floor the drift counts.
    let slow_drift_30 = (
        0.06 * 30f64.to_radians().cos(),
        -0.06 * 30f64.to_radians().sin(),
    );
    check(&[slow_drift_30, drift_15], 30.0, 0.06);
}

/// Regression (`finding-idrange-asymmetric`): a 35° turn past every training extreme (drift, r′,
/// speed) had 1 % of its states outside the ellipsoid on one side (88 % on the other) and no
/// warning; a run past an extreme by more than 5 % is now warned about whatever the share.
#[test]
fn a_run_past_the_training_extremes_is_warned_about_at_any_share() {
    let training = extent(17.6, 0.77, 35.0, 0.48);
    check(
        0.01,
        extent(18.2, 0.84, 35.0, 0.44),
        Some(training),
        Some(&[
            "this run goes past the extremes",
            "r′ up to 0.84 (training ≤ 0.77)",
            "only 1 % of it lies outside",
            "its metrics are an extrapolation",
        ]),
    );
    // Within the margin of the recorded peaks: no warning at a small share.
    check(0.01, extent(17.9, 0.78, 35.0, 0.47), Some(training), None);
}

/// Regression (`finding-idrange-noise`): 2 % of U0 of noise on the recorded velocities put 5° of drift
/// and 0.16 of r′ into the training extent of a zig-zag, so the turn a fit extrapolated to was
/// inside it. A recording's extent takes its velocities averaged over 0.3 L/U0.
#[test]
fn a_recordings_extent_is_not_widened_by_its_noise() {
    use shipid_sim::{MmgModel, SimOptions, State, ZigZag};
    let model = MmgModel::kvlcc2();
    let ship = shipid_sim::kvlcc2_ship();
    let mut zz = ZigZag::new(35.0, 35.0, shipid_io::Side::Port, 2.0).unwrap();
    let clean = shipid_sim::simulate(
        &model,
        &mut zz,
        State::approach(ship.u0),
        &SimOptions::new(120.0),
    )
    .unwrap()
    .recording;
    let mut noisy = clean.clone();
    for (i, (u, v)) in noisy.u.iter_mut().zip(noisy.v.iter_mut()).enumerate() {
        let r = |k: f64| ((i as f64 * k).sin() * 43758.5453).rem_euclid(1.0) * 2.0 - 1.0;
        *u += 0.02 * ship.u0 * r(12.9898);
        *v += 0.02 * ship.u0 * r(78.233);
    }
    let n = clean.len();
    let exact = StateExtent::of(&clean, &ship, 0..n).unwrap();
    let raw = StateExtent::of(&noisy, &ship, 0..n).unwrap();
    let recorded = StateExtent::of_recorded(&noisy, &ship, 0..n).unwrap();
    assert!(
        raw.max_drift_deg > exact.max_drift_deg + 1.0,
        "{raw:?} {exact:?}"
    );
    assert!(
        (recorded.max_drift_deg - exact.max_drift_deg).abs() < 0.5
            && (recorded.max_yaw_rate_prime / exact.max_yaw_rate_prime - 1.0).abs() < 0.03,
        "noisy, averaged: {recorded:?}; exact: {exact:?}"
    );
}

/// `expected` fragments of the warning that must be there, `absent` those that must not.
fn check_named(
    outside: f64,
    run: StateExtent,
    training: StateExtent,
    expected: &[&str],
    absent: &[&str],
) {
    let reach = RunReach {
        source: RangeSource::StateEllipsoid,
        outside,
        run,
        training: Some(training),
        degenerate: None,
    };
    let w = reach.warning("m.toml", false).expect("a warning");
    for f in expected {
        assert!(w.contains(f), "`{f}` not in: {w}");
    }
    for f in absent {
        assert!(!w.contains(f), "`{f}` in: {w}");
    }
}

/// Regression (probe-mmg §15): `simulate --propeller-rate 30` approached at 2.5 U0 and the warning
/// named "drift up to 19.2° (training ≤ 19.2°), r′ up to 0.89 (training ≤ 0.89)", both inside their
/// training range, and not the speed that put the run outside.
#[test]
fn the_extrapolation_warning_names_the_speed_above_the_training_and_not_what_is_within() {
    let training = extent(19.2, 0.89, 35.0, 0.45);
    let fast = StateExtent {
        max_speed_over_u0: 2.53,
        ..extent(19.23, 0.8904, 35.0, 0.5)
    };
    check_named(
        1.0,
        fast,
        training,
        &[
            "100 % of this run",
            "speed up to 2.53 U0 (training ≤ 1.00 U0)",
        ],
        &["drift up to", "r′ up to", "in combinations"],
    );
    // Nothing single past its extreme: the combination is what lies outside.
    check_named(
        0.4,
        extent(19.2, 0.89, 35.0, 0.45),
        training,
        &["in combinations the training did not visit"],
        &["drift up to", "speed up to"],
    );
    // Past the highest speed by more than the margin: warned about at any share.
    let reach = RunReach {
        source: RangeSource::StateEllipsoid,
        outside: 0.0,
        run: fast,
        training: Some(training),
        degenerate: None,
    };
    assert!(reach.clearly_beyond());
}

/// Regression (probe-mmg §1): a model fitted on a straight run has training states that span no
/// ellipsoid; the range was `None`, read as "no range known", and a 35° turn from it got no
/// extrapolation warning. The range is now one outside which every state lies, saying why.
#[test]
fn a_straight_run_gives_a_range_outside_which_every_state_lies() {
    let straight: Vec<[f64; 4]> = (0..300).map(|_| [0.0, 0.0, 0.0, 0.0]).collect();
    let range = state_range_of(&straight).expect("a range");
    let why = range.degenerate().expect("degenerate");
    assert!(why.contains("δ (rudder) = 0.0° throughout"), "{why}");
    assert!(why.contains("300 training states"), "{why}");
    assert_eq!(range.leverage_ratio(0.0, 0.0, 0.0, 0.0), f64::INFINITY);
    assert_eq!(range.leverage_ratio(-0.3, 0.1, 0.5, 0.6), f64::INFINITY);
    let reach = RunReach {
        source: RangeSource::Degenerate,
        outside: 1.0,
        run: extent(18.1, 1.26, 35.0, 0.33),
        training: Some(extent(0.0, 0.0, 0.0, 1.0)),
        degenerate: Some(why.to_string()),
    };
    let w = reach.warning("m.toml", false).expect("a warning");
    for f in [
        "the training states do not span the state space",
        "δ (rudder) = 0.0° throughout",
        "every state of this run is an extrapolation",
        "rudder up to 35.0° (training ≤ 0.0°)",
    ] {
        assert!(w.contains(f), "`{f}` not in: {w}");
    }
    // A manoeuvre's states still form an ellipsoid.
    let turn: Vec<[f64; 4]> = (0..2000)
        .map(|i| {
            let ph = i as f64 / 2000.0 * 12.0;
            let r = 0.4 * ph.sin() + 0.05 * (3.0 * ph).cos();
            [
                -0.05 * r * r + 0.01 * (7.0 * ph).cos(),
                -0.3 * r + 0.01 * (5.0 * ph).sin(),
                r,
                0.6 * (ph + 0.4).sin(),
            ]
        })
        .collect();
    assert!(state_range_of(&turn).unwrap().degenerate().is_none());
}
