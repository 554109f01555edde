//! The MMG KVLCC2 model against the published check values (Yasukawa & Yoshimura 2015; listed in
//! `docs/conventions.md`, "The reference model"), through
//! the public API: controllers, RK4 simulation, metrics.

use shipid_io::{Manoeuvre, Recording, Side};
use shipid_sim::{Dynamics, Metrics, MmgModel, SimOptions, SimStatus, State, metrics, simulate};

use crate::common::simulate_manoeuvre;

fn run(model: &MmgModel, man: Manoeuvre, duration_s: f64, dt_s: f64) -> (Recording, Metrics) {
    let ship = *model.ship();
    let opts = SimOptions::new(duration_s).with_step(dt_s, dt_s);
    let out = simulate_manoeuvre(model, &man, &opts);
    assert_eq!(out.status, SimStatus::Ok);
    let m = metrics(&out.recording, &man, &ship);
    (out.recording, m)
}

#[test]
fn self_propulsion_rate_balances_the_resistance_at_u0() {
    let m = MmgModel::kvlcc2();
    let n = m.propeller_rate();
    eprintln!("n_P = {n:.5} rps");
    assert!((n - 11.86).abs() < 0.015, "n_P = {n}");
    let f = m.forces(&State::approach(m.ship().u0), 0.0).unwrap();
    let x = f.total()[0];
    assert!(
        x.abs() < 1e-9 * f.hull[0].abs(),
        "X = {x} N, X_H = {} N",
        f.hull[0]
    );
    // R_0 = R'_0 ½ρLdU0² ≈ 49.2 N is what the propeller balances.
    assert!((f.hull[0] + 0.022 * 0.5 * 1000.0 * 7.0 * 0.46 * 1.179f64.powi(2)).abs() < 1e-9);
}

#[test]
fn straight_run_at_zero_rudder_holds_u0() {
    let m = MmgModel::kvlcc2();
    let u0 = m.ship().u0;
    let mut c = shipid_sim::Turning::new(35.0, Side::Port, 1e9).unwrap();
    let out = simulate(&m, &mut c, State::approach(u0), &SimOptions::new(100.0)).unwrap();
    let r = &out.recording;
    let last = r.len() - 1;
    assert!((r.u[last] - u0).abs() < 1e-9, "u = {}", r.u[last]);
    assert!(r.v[last].abs() < 1e-12 && r.r[last].abs() < 1e-12 && r.y0[last].abs() < 1e-9);
    assert!((r.x0[last] - u0 * r.t[last]).abs() < 1e-6);
    let acc = r.accelerations.as_ref().unwrap();
    assert!(acc.u_dot.iter().all(|a| a.abs() < 1e-9));
}

#[test]
fn turning_circle_35_matches_domain_check_values() {
    let m = MmgModel::kvlcc2();
    for side in [Side::Starboard, Side::Port] {
        let man = Manoeuvre::Turning {
            rudder_deg: 35.0,
            side,
        };
        let (rec, mt) = run(&m, man, 500.0, 0.05);
        let steady_speed = rec.speed(rec.len() - 1) / m.ship().u0;
        eprintln!("TC35 {side:?}: {mt:?}, steady speed {steady_speed:.4} U0");
        let advance = mt.advance.unwrap();
        let tactical = mt.tactical_diameter.unwrap();
        assert!((advance - 3.08).abs() < 0.05, "advance {advance}");
        assert!(
            (tactical - 3.1).abs() < 0.05,
            "tactical diameter {tactical}"
        );
        assert!(
            (steady_speed - 0.38).abs() < 0.01,
            "steady speed {steady_speed}"
        );
        let transfer = mt.transfer.unwrap();
        let steady = mt.steady_diameter.unwrap();
        // The turn tightens as the ship slows: transfer < tactical/2 … steady circle < tactical diameter.
        assert!(
            transfer > 0.3 * tactical && transfer < 0.5 * tactical,
            "transfer {transfer}"
        );
        assert!(
            steady > 2.0 && steady < tactical,
            "steady diameter {steady}"
        );
    }
}

/// Published zig-zag check values (Yasukawa & Yoshimura 2015): (rudder = check angle, side, first
/// overshoot, second overshoot) [deg].
const ZIGZAG_CHECKS: [(f64, Side, f64, f64); 4] = [
    (10.0, Side::Starboard, 4.9, 13.6),
    (10.0, Side::Port, 7.0, 8.8),
    (20.0, Side::Starboard, 10.5, 15.7),
    (20.0, Side::Port, 13.7, 11.7),
];

#[test]
fn zigzags_match_domain_check_values() {
    let m = MmgModel::kvlcc2();
    for (angle, side, os1, os2) in ZIGZAG_CHECKS {
        let man = Manoeuvre::ZigZag {
            rudder_deg: angle,
            check_deg: angle,
            side,
        };
        let (_, mt) = run(&m, man, 200.0, 0.05);
        eprintln!("ZZ{angle}/{angle} {side:?}: {mt:?}");
        let (got1, got2) = (mt.overshoot_1.unwrap(), mt.overshoot_2.unwrap());
        assert!(
            (got1 - os1).abs() < 0.3,
            "{angle} {side:?}: overshoot 1 {got1} vs {os1}"
        );
        assert!(
            (got2 - os2).abs() < 0.3,
            "{angle} {side:?}: overshoot 2 {got2} vs {os2}"
        );
        assert!(mt.t_a.unwrap() > 1.0 && mt.t_a.unwrap() < 3.0);
        assert!(mt.t_check.unwrap() > 0.5 && mt.t_check.unwrap() < 3.0);
    }
}

#[test]
fn default_step_is_converged() {
    let m = MmgModel::kvlcc2();
    for (angle, side, _, _) in ZIGZAG_CHECKS {
        let man = Manoeuvre::ZigZag {
            rudder_deg: angle,
            check_deg: angle,
            side,
        };
        let (_, coarse) = run(&m, man, 200.0, 0.05);
        let (_, fine) = run(&m, man, 200.0, 0.0125);
        for (a, b) in [
            (coarse.overshoot_1, fine.overshoot_1),
            (coarse.overshoot_2, fine.overshoot_2),
        ] {
            assert!(
                (a.unwrap() - b.unwrap()).abs() < 0.01,
                "{coarse:?} vs {fine:?}"
            );
        }
        assert!((coarse.t_a.unwrap() - fine.t_a.unwrap()).abs() < 1e-3);
    }
}

/// The KVLCC2 parameters with `change` applied, built at its self-propulsion rate: `Ok` or the name
/// of the parameter refused for lying outside its physical domain.
fn check_domain(change: impl Fn(&mut shipid_sim::MmgParameters), expected: Result<(), &str>) {
    let mut p = shipid_sim::MmgParameters::kvlcc2();
    change(&mut p);
    let got = shipid_sim::MmgModel::at_rate(shipid_sim::kvlcc2_ship(), p, 10.0);
    match (got, expected) {
        (Ok(_), Ok(())) => {}
        (Err(shipid_sim::MmgError::OutsideDomain { name, .. }), Err(want)) => {
            assert_eq!(name, want)
        }
        (got, want) => panic!("{:?} instead of {want:?}", got.map(|_| ())),
    }
}

/// Regression: a model file with ε = −0.5 simulated a ship turning against its rudder.
#[test]
fn propeller_and_rudder_parameters_outside_their_physical_domain_are_refused() {
    check_domain(|p| p.epsilon = -0.5, Err("epsilon"));
    check_domain(|p| p.epsilon = 0.0, Err("epsilon"));
    check_domain(|p| p.t_p = 1.0, Err("t_p"));
    check_domain(|p| p.t_p = -0.1, Err("t_p"));
    check_domain(|p| p.t_r = 1.2, Err("t_r"));
    check_domain(|p| p.a_h = -1.0, Err("a_h"));
    check_domain(|p| p.kappa = -0.1, Err("kappa"));
    check_domain(|p| p.gamma_r_neg = -0.1, Err("gamma_r_neg"));
    check_domain(|p| p.gamma_r_pos = -0.1, Err("gamma_r_pos"));
    check_domain(|p| p.f_alpha = 0.0, Err("f_alpha"));
    check_domain(|p| p.c1 = -1.0, Err("c1"));
    check_domain(|p| p.c2_neg = -0.5, Err("c2_neg"));
    check_domain(|p| p.r0 = -0.01, Err("r0"));
    check_domain(|p| p.w_p0 = 1.0, Err("w_p0"));
    // The edges of every fit's bounds (docs/mmg.md) lie inside.
    check_domain(
        |p| {
            (p.t_p, p.t_r, p.a_h, p.epsilon, p.kappa) = (0.5, 0.8, 0.0, 0.5, 0.0);
            (p.gamma_r_neg, p.gamma_r_pos, p.f_alpha, p.c1, p.c2_pos) = (0.05, 1.5, 1.0, 0.0, 0.5);
        },
        Ok(()),
    );
    // Hull derivatives keep no domain beyond finiteness (the inverse method's ships take both signs).
    check_domain(|p| p.y_vrr = 0.065, Ok(()));
}
