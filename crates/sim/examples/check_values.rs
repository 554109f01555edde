//! Prints the MMG KVLCC2 check values of Yasukawa & Yoshimura (2015) as this crate computes them, and how each effect
//! changes a 35° turning circle and a 20/20 zig-zag:
//! `cargo run --release -p shipid-sim --example check_values`.

use shipid_io::{Manoeuvre, Side};
use shipid_sim::{
    Dynamics, Effect, MmgModel, SimOptions, State, controller_for, metrics, simulate_with_effects,
};

fn main() {
    let model = MmgModel::kvlcc2();
    let ship = *model.ship();
    println!(
        "self-propulsion rate n_P = {:.4} rps",
        model.propeller_rate()
    );
    let run = |effects: &[Effect], man: Manoeuvre, duration_s: f64| {
        let mut c = controller_for(&man, 2.0).expect("standard manoeuvre");
        let out = simulate_with_effects(
            &model,
            effects,
            c.as_mut(),
            State::approach(ship.u0),
            &SimOptions::new(duration_s),
        )
        .expect("valid simulation input");
        let speed = out.recording.speed(out.recording.len() - 1) / ship.u0;
        (metrics(&out.recording, &man, &ship), speed)
    };
    for side in [Side::Starboard, Side::Port] {
        let (m, speed) = run(
            &[],
            Manoeuvre::Turning {
                rudder_deg: 35.0,
                side,
            },
            500.0,
        );
        println!(
            "TC35 {side:?}: advance {:.3} L, transfer {:.3} L, tactical {:.3} L, steady {:.3} L, speed {:.3} U0 \
             (DOMAIN: 3.08 L, 3.1 L, 0.38 U0)",
            m.advance.unwrap_or(f64::NAN),
            m.transfer.unwrap_or(f64::NAN),
            m.tactical_diameter.unwrap_or(f64::NAN),
            m.steady_diameter.unwrap_or(f64::NAN),
            speed
        );
    }
    for (angle, side, os1, os2) in [
        (10.0, Side::Starboard, 4.9, 13.6),
        (10.0, Side::Port, 7.0, 8.8),
        (20.0, Side::Starboard, 10.5, 15.7),
        (20.0, Side::Port, 13.7, 11.7),
    ] {
        let man = Manoeuvre::ZigZag {
            rudder_deg: angle,
            check_deg: angle,
            side,
        };
        let (m, _) = run(&[], man, 200.0);
        println!(
            "ZZ{angle}/{angle} {side:?}: overshoots {:.3}° / {:.3}° (DOMAIN {os1}° / {os2}°), t_a {:.3}, t_check {:.3}",
            m.overshoot_1.unwrap_or(f64::NAN),
            m.overshoot_2.unwrap_or(f64::NAN),
            m.t_a.unwrap_or(f64::NAN),
            m.t_check.unwrap_or(f64::NAN)
        );
    }
    for effect in [
        "current:speed=0.05,from=120",
        "wind:speed=3,from=90",
        "rudder_lag:tau=1.5,delay=0.3",
        "asymmetry:offset=1",
        "shallow_water:h_over_t=2",
        "shallow_water:h_over_t=1.5",
        "shallow_water:h_over_t=1.2",
    ] {
        let e: Effect = effect.parse().expect("valid effect");
        let tc = Manoeuvre::Turning {
            rudder_deg: 35.0,
            side: Side::Starboard,
        };
        let zz = Manoeuvre::ZigZag {
            rudder_deg: 20.0,
            check_deg: 20.0,
            side: Side::Starboard,
        };
        let (mt, _) = run(std::slice::from_ref(&e), tc, 500.0);
        let (mz, _) = run(&[e], zz, 200.0);
        println!(
            "{effect:30} TC35 stbd advance {:.3} tactical {:.3} steady {:.3} | ZZ20/20 stbd {:.2}° / {:.2}°",
            mt.advance.unwrap_or(f64::NAN),
            mt.tactical_diameter.unwrap_or(f64::NAN),
            mt.steady_diameter.unwrap_or(f64::NAN),
            mz.overshoot_1.unwrap_or(f64::NAN),
            mz.overshoot_2.unwrap_or(f64::NAN)
        );
    }
}
