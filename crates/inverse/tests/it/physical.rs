//! Physical checks on generated ships: parameter bounds and stable straight running.

use shipid_inverse::database::ShipsFile;
use shipid_inverse::indexes::{IndexFailure, SimSettings};
use shipid_inverse::modes::VariationModes;
use shipid_inverse::physical::{
    Bound, MAX_STRAIGHT_RUN_GROWTH_PRIME, PhysicalChecks, Unphysical, straight_run_growth_rate,
};
use shipid_inverse::pipeline::{build_database, sample_weights};
use shipid_inverse::target::{TargetShip, TargetsFile};
use shipid_sim::{MmgModel, MmgParameters, kvlcc2_ship};

fn ships() -> ShipsFile {
    toml::from_str(include_str!("../../../../data/paper003/ships.toml")).expect("ships.toml parses")
}

fn kvlcc2_target() -> TargetShip {
    let t: TargetsFile = toml::from_str(include_str!("../../../../data/paper003/targets.toml"))
        .expect("targets.toml parses");
    t.target.into_iter().next().expect("KVLCC2 target")
}

fn t_r_bound() -> PhysicalChecks {
    PhysicalChecks {
        bounds: vec![Bound {
            name: "t_r".into(),
            lower: 0.0,
            upper: 0.8,
        }],
        stable_straight_run: false,
    }
}

/// `growth` of `p` on the KVLCC2 model ship: stable (< 0) or not as `expected_stable`.
fn check_stability(what: &str, p: MmgParameters, expected_stable: bool) {
    let model = MmgModel::new(kvlcc2_ship(), p).expect("valid parameters");
    let g = straight_run_growth_rate(&model).expect("evaluates");
    assert_eq!(g < 0.0, expected_stable, "{what}: growth rate {g} U0/L");
}

#[test]
fn straight_run_stability_follows_the_yaw_damping() {
    let base = MmgParameters::kvlcc2();
    let kvlcc2 = MmgModel::new(kvlcc2_ship(), base).expect("KVLCC2");
    let g = straight_run_growth_rate(&kvlcc2).expect("evaluates");
    // The published KVLCC2 is a full-form ship close to the stability limit: accepted either way.
    assert!(
        g < MAX_STRAIGHT_RUN_GROWTH_PRIME,
        "KVLCC2 grows at {g} U0/L"
    );
    // Three times the hull's yaw damping makes it stable; a yaw damping turned into excitation does not.
    check_stability(
        "N'_r × 3",
        MmgParameters {
            n_r: 3.0 * base.n_r,
            ..base
        },
        true,
    );
    check_stability(
        "N'_r reversed",
        MmgParameters {
            n_r: -3.0 * base.n_r,
            n_v: 3.0 * base.n_v,
            ..base
        },
        false,
    );
}

#[test]
fn a_negative_steering_resistance_deduction_is_rejected_and_counted() {
    let target = kvlcc2_target();
    let modes = VariationModes::new(&ships().ship).expect("SVD");
    let weights = sample_weights(&modes, 12, 300, 3);
    let negative_t_r = weights
        .iter()
        .filter(|x| {
            let c = modes.generate(x).expect("finite");
            target.mmg_parameters(&c).t_r < 0.0
        })
        .count();
    assert!(negative_t_r > 0, "12 modes at ±3σ give ships with t_R < 0");
    let db = build_database(
        &target,
        &modes,
        &weights,
        &SimSettings::default(),
        &t_r_bound(),
        &|| {},
    )
    .expect("valid target");
    let rejected = db
        .dropped
        .iter()
        .filter(|(_, f)| {
            matches!(f, IndexFailure::Unphysical(Unphysical::OutOfBounds { name, .. }) if name == "t_r")
        })
        .count();
    assert_eq!(
        rejected, negative_t_r,
        "every t_R < 0 is rejected, none else"
    );
    for s in &db.samples {
        let c = modes.generate(&s.weights).expect("finite");
        assert!(target.mmg_parameters(&c).t_r >= 0.0);
    }
}
