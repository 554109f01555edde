//! A standard manoeuvre is the same manoeuvre at any scale: its approach and first execute are in
//! units of L/U0 (`shipid_pipeline::generate::execute_time_s`).

use shipid_io::{AddedMass, Manoeuvre, Ship, Side};
use shipid_pipeline::generate::{T_EXECUTE_S, execute_time_s};
use shipid_pipeline::simulate::simulate_manoeuvre;
use shipid_sim::{Dynamics, DynamicsError, Input, State, kvlcc2_ship};

/// First-order yaw in prime units with a constant yaw moment (as a polynomial set's N₀ or a sparse
/// GP's mean gives): not in equilibrium with the rudder amidships, so it turns during the approach.
/// Froude-similar at any L and U0: ṙ = (U/L)² (−r′/T′ + K′δ/T′ + bias).
struct BiasedNomoto {
    ship: Ship,
}

impl Dynamics for BiasedNomoto {
    fn accelerations_for(&self, s: &State, input: &Input) -> Result<[f64; 3], DynamicsError> {
        let (l, u) = (self.ship.lpp, s.speed());
        let r_prime = s.r * l / u;
        let (t_prime, k_prime, bias) = (2.0, 1.5, 0.02);
        Ok([
            0.0,
            0.0,
            (u / l).powi(2) * ((-r_prime + k_prime * input.delta_rad) / t_prime + bias),
        ])
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

fn froude_scaled(ship: Ship, lambda: f64) -> Ship {
    Ship {
        lpp: ship.lpp * lambda,
        beam: ship.beam * lambda,
        draft: ship.draft * lambda,
        displacement: ship.displacement * lambda.powi(3),
        xg: ship.xg * lambda,
        kzz: ship.kzz * lambda,
        u0: ship.u0 * lambda.sqrt(),
        rudder_rate: ship.rudder_rate / lambda.sqrt(),
        ..ship
    }
}

/// Heading [rad] at the nondimensional time t U0/L, interpolated between samples.
fn heading_at(model: &dyn Dynamics, m: &Manoeuvre, t_nondim: f64) -> f64 {
    let out = simulate_manoeuvre(model, m, None, None).unwrap();
    let ship = model.ship();
    let t = t_nondim * ship.lpp / ship.u0;
    let rec = &out.recording;
    let k = rec.t.partition_point(|&ti| ti <= t);
    let w = (t - rec.t[k - 1]) / (rec.t[k] - rec.t[k - 1]);
    rec.psi[k - 1] + w * (rec.psi[k] - rec.psi[k - 1])
}

fn check_scale_free(m: Manoeuvre, lambda: f64) {
    let model = BiasedNomoto {
        ship: kvlcc2_ship(),
    };
    let full = BiasedNomoto {
        ship: froude_scaled(kvlcc2_ship(), lambda),
    };
    for t_nondim in [0.5, 2.0, 5.0, 10.0] {
        let (a, b) = (
            heading_at(&model, &m, t_nondim),
            heading_at(&full, &m, t_nondim),
        );
        assert!(
            (a - b).abs() < 2e-3 * a.abs().max(1e-3),
            "{m:?} at λ = {lambda}, t U0/L = {t_nondim}: heading {a} rad at model scale, {b} rad at full scale"
        );
    }
}

/// Regression: the first execute was at 5 s whatever the ship, 0.84 L/U0 for the KVLCC2 model and
/// 0.12 L/U0 at 1:50 full scale, so a model with a port/starboard bias had yawed for a different
/// nondimensional time when the rudder moved: `simulate` gave a full68 fit's zig-zag t_a 2.3 %
/// apart at the two scales (and `validate`, which takes the recording's own execute, did not).
#[test]
fn a_biased_model_gives_the_same_manoeuvre_at_model_and_full_scale() {
    let zigzag = Manoeuvre::ZigZag {
        rudder_deg: 10.0,
        check_deg: 10.0,
        side: Side::Starboard,
    };
    let turning = Manoeuvre::Turning {
        rudder_deg: 35.0,
        side: Side::Port,
    };
    for lambda in [50.0, 0.2] {
        check_scale_free(zigzag, lambda);
        check_scale_free(turning, lambda);
    }
    assert_eq!(execute_time_s(&kvlcc2_ship()), T_EXECUTE_S);
}

/// Regression: `simulate` of a model carrying a current (the model file `diagnose` writes) looked
/// for its straight run over ground, found U0 plus the current along the course (0.1 m/s from ahead:
/// 1.079 m/s, 0.92 U0), started there and blamed the propeller rate; its 20°/20° first overshoot was
/// 13.04° where the calm model and `--current` give 13.66°. A uniform current only carries the ship
/// along: the manoeuvre is the calm one.
#[test]
fn a_model_carrying_a_current_approaches_and_manoeuvres_as_in_calm_water() {
    use shipid_pipeline::simulate::straight_run_speed;
    use shipid_sim::effects::Current;
    use shipid_sim::{Effect, MmgModel, WithEffects, metrics};
    let calm = MmgModel::kvlcc2();
    let m = Manoeuvre::ZigZag {
        rudder_deg: 20.0,
        check_deg: 20.0,
        side: Side::Port,
    };
    let ship = *calm.ship();
    let calm_metrics = metrics(
        &simulate_manoeuvre(&calm, &m, None, None).unwrap().recording,
        &m,
        &ship,
    );
    let calm_speed = straight_run_speed(&calm).unwrap();
    for from_deg in [0.0, 90.0, 180.0] {
        let current = Current {
            speed_m_s: 0.1,
            from_deg,
        };
        let model = WithEffects::new(&calm, &[Effect::Current(current)]).unwrap();
        let speed = straight_run_speed(&model).unwrap();
        assert!(
            (speed - calm_speed).abs() < 1e-9,
            "current from {from_deg}°: straight run at {speed} m/s, calm {calm_speed} m/s"
        );
        let got = metrics(
            &simulate_manoeuvre(&model, &m, None, None)
                .unwrap()
                .recording,
            &m,
            &ship,
        );
        for (name, a, b) in [
            ("overshoot_1", got.overshoot_1, calm_metrics.overshoot_1),
            ("t_a", got.t_a, calm_metrics.t_a),
        ] {
            let (a, b) = (a.unwrap(), b.unwrap());
            assert!(
                (a - b).abs() < 1e-6 * b.abs(),
                "current from {from_deg}°: {name} {a}, calm {b}"
            );
        }
    }
}
