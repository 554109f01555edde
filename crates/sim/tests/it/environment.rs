//! The recorded environment's force models shared with the concealed `wind` effect.

use shipid_io::{WindModel, Windage};
use shipid_sim::effects::{Effect, EffectError, KVLCC2_FREEBOARD_OVER_DRAFT, Wind};
use shipid_sim::environment::{Aerodynamics, assumed_windage};
use shipid_sim::{MmgModel, State, WithEffects, kvlcc2_ship};

fn wind(from_deg: f64, windage: Option<Windage>) -> Wind {
    Wind {
        speed_m_s: 4.0,
        from_deg,
        frontal_area_m2: None,
        lateral_area_m2: None,
        windage,
    }
}

/// An Isherwood windage of a ship the size of the KVLCC2 model with a deckhouse.
fn isherwood() -> Windage {
    Windage {
        frontal_area_m2: 0.40,
        lateral_area_m2: 1.80,
        model: WindModel::Isherwood1973,
        length_overall_m: Some(7.2),
        lateral_perimeter_m: Some(16.0),
        superstructure_lateral_area_m2: Some(0.3),
        ..assumed_windage(&kvlcc2_ship())
    }
}

/// Without a windage the concealed wind keeps its former force, Fossen's coefficients on the
/// default areas about midship: X = −q A_F 0.70 cos γ, Y = −q A_L 0.825 sin γ,
/// N = −q A_L L 0.125 sin 2γ (the diagnosis's results do not move).
#[test]
fn a_wind_without_windage_keeps_fossens_force_on_the_default_areas() {
    let ship = kvlcc2_ship();
    let (af, al) = (
        ship.beam * KVLCC2_FREEBOARD_OVER_DRAFT * ship.draft,
        ship.lpp * KVLCC2_FREEBOARD_OVER_DRAFT * ship.draft,
    );
    let at_rest = State::default();
    for from_deg in [0.0, 30.0, 90.0, 200.0, 315.0] {
        let f = wind(from_deg, None).force(&ship, &at_rest).unwrap();
        let g = f64::to_radians(from_deg);
        let q = 0.5 * 1.225 * 16.0;
        let expected = [
            -q * af * 0.70 * g.cos(),
            -q * al * 0.825 * g.sin(),
            -q * al * ship.lpp * 0.125 * (2.0 * g).sin(),
        ];
        for i in 0..3 {
            assert!(
                (f[i] - expected[i]).abs() < 1e-12 * (1.0 + expected[i].abs()),
                "from {from_deg}°: {f:?} against {expected:?}"
            );
        }
    }
}

/// With a data set's windage the concealed wind pushes through that windage's model: the same force
/// as the recorded environment's [`Aerodynamics`] for the same relative wind.
#[test]
fn a_wind_with_a_data_sets_windage_uses_its_model() {
    let ship = kvlcc2_ship();
    let aero = Aerodynamics::new(&isherwood(), &ship).unwrap();
    let at_rest = State::default();
    for from_deg in [0.0, 45.0, 90.0, 135.0, 250.0] {
        let w = wind(from_deg, Some(isherwood()));
        let (s, c) = f64::to_radians(from_deg).sin_cos();
        // At rest with heading north the air moves at −V (cos φ, sin φ) in body axes.
        let expected = aero.force([-4.0 * c, -4.0 * s]);
        assert_eq!(w.force(&ship, &at_rest).unwrap(), expected);
        assert_ne!(
            expected,
            wind(from_deg, None).force(&ship, &at_rest).unwrap()
        );
    }
}

/// A concealed wind whose windage lacks a key its model needs is refused when the effect is applied,
/// naming the key.
#[test]
fn a_wind_whose_windage_lacks_a_key_is_refused_naming_it() {
    let broken = Windage {
        lateral_perimeter_m: None,
        ..isherwood()
    };
    let e = WithEffects::new(
        MmgModel::kvlcc2(),
        &[Effect::Wind(wind(90.0, Some(broken)))],
    )
    .err()
    .unwrap();
    assert!(matches!(e, EffectError::Windage(_)), "{e:?}");
    assert!(e.to_string().contains("`lateral_perimeter_m`"), "{e}");
}
