use shipid_inverse::database::ShipsFile;
use shipid_inverse::indexes::*;
use shipid_inverse::modes::VariationModes;
use shipid_inverse::target::*;
use shipid_sim::{MmgModel, MmgParameters};

#[test]
#[ignore]
fn explore() {
    let ships: ShipsFile =
        toml::from_str(include_str!("../../../data/paper003/ships.toml")).unwrap();
    let modes = VariationModes::new(&ships.ship).unwrap();
    println!("contrib {:?}", &modes.contribution[..10]);
    println!("cum {:?}", &modes.cumulative()[..10]);
    println!("n95 {}", modes.modes_for(0.95));
    println!("std {:?}", &modes.weight_std[..8]);
    let t: toml::Value =
        toml::from_str(include_str!("../../../data/paper003/targets.toml")).unwrap();
    let kv: TargetShip = t["target"][0]
        .clone()
        .try_into()
        .unwrap_or_else(|e| panic!("{e}"));
    println!("R0' {}", resistance_prime(320., 58., 20.8, 0.81, 7.97));
    println!("zhou {:?}", zhou_added_mass(320., 58., 20.8, 0.81));
    let s = SimSettings::default();
    // Y&Y KVLCC2 full scale
    let mut p = MmgParameters::kvlcc2();
    p.propeller_diameter_m = 9.86;
    p.rudder_span_m = 15.8;
    p.rudder_area_m2 = 112.5;
    let m = MmgModel::new(kv.ship(), p).unwrap();
    let t0 = std::time::Instant::now();
    println!(
        "YY kvlcc2 full-scale {:?} {:?}",
        motion_indexes(&m, &s),
        t0.elapsed()
    );
    p.r0 = resistance_prime(320., 58., 20.8, 0.81, 7.97);
    let m = MmgModel::new(kv.ship(), p).unwrap();
    println!("YY kvlcc2 + R0 empirical {:?}", motion_indexes(&m, &s));
    let fine = SimSettings {
        dt_prime: 0.005,
        ..s
    };
    println!("YY fine {:?}", motion_indexes(&m, &fine));
    for id in ["S17", "S18"] {
        let sh = ships.ship.iter().find(|x| x.id == id).unwrap();
        let model = kv.model(&sh.coefficients()).unwrap();
        println!("{id} {:?}", motion_indexes(&model, &s));
        println!("{id} weights {:?}", modes.project(&sh.coefficients(), 6));
    }
    let model = kv.model(&modes.mean).unwrap();
    println!("mean {:?}", motion_indexes(&model, &s));
}
