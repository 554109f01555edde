//! Inputs no inversion can use, refused before any simulation with the file's key named (probe 12
//! findings 1–5, 9): a database of copies, rounding-noise modes, absurd coefficients, targets
//! without a self-propulsion point or a motion, impossible indexes, and held-out errors not
//! measured.

use shipid_inverse::InverseError;
use shipid_inverse::database::{DatabaseShip, ShipsFile, validate};
use shipid_inverse::indexes::SimSettings;
use shipid_inverse::inversion::{InputFault, check_inputs, header_markdown};
use shipid_inverse::mlp::TrainOptions;
use shipid_inverse::modes::VariationModes;
use shipid_inverse::physical::PhysicalChecks;
use shipid_inverse::pipeline::{InverseModel, build_database, held_out, sample_weights};
use shipid_inverse::target::{AddedMassPrimes, TargetShip, TargetsFile};

fn ships() -> Vec<DatabaseShip> {
    let f: ShipsFile =
        toml::from_str(include_str!("../../../../data/paper003/ships.toml")).expect("parses");
    f.ship
}

fn targets() -> TargetsFile {
    toml::from_str(include_str!("../../../../data/paper003/targets.toml")).expect("parses")
}

fn kvlcc2() -> TargetShip {
    targets().target.remove(0)
}

fn database_error(ships: &[DatabaseShip]) -> String {
    match VariationModes::new(ships) {
        Err(e @ InverseError::Database(_)) => e.to_string(),
        other => panic!("expected a database error, got {other:?}"),
    }
}

fn targets_fault(t: TargetShip) -> String {
    match check_inputs(
        &ShipsFile { ship: ships() },
        TargetsFile { target: vec![t] },
    ) {
        Err(InputFault::Targets(m)) => m,
        other => panic!("expected a targets fault, got {:?}", other.map(|_| ())),
    }
}

/// Finding 1: one ship copied under 20 ids gave "mode 1 carries 100 %" of rounding noise and a
/// network trained on it; now refused, naming the copies and the ship they copy.
#[test]
fn ships_copied_under_other_ids_are_refused_naming_the_ids() {
    let s1 = ships().remove(0);
    let copies: Vec<DatabaseShip> = (1..=20)
        .map(|i| DatabaseShip {
            id: format!("S{i}"),
            ..s1.clone()
        })
        .collect();
    let e = database_error(&copies);
    assert!(
        e.contains("ships S2, S3,") && e.contains("S20 have the same 24 coefficients as ship S1"),
        "{e}"
    );
    assert!(e.contains("rounding noise"), "{e}");
    // One copy among distinct ships is refused too, by its id and the original's.
    let mut db = ships();
    let copy = DatabaseShip {
        id: "S21".into(),
        ..db[4].clone()
    };
    let original = db[4].id.clone();
    db.push(copy);
    let e = validate(&db).expect_err("a copy").to_string();
    assert!(
        e.contains(&format!(
            "ship S21 has the same 24 coefficients as ship {original}"
        )),
        "{e}"
    );
    // A copy differing by rounding only is still a copy.
    let mut db = ships();
    let mut near = db[2].clone();
    near.id = "near".into();
    near.n_r *= 1.0 + 1e-14;
    db.push(near);
    assert!(validate(&db).is_err());
}

/// Finding 1: modes at rounding level are no variation. n ships give n − 1 modes (the 20th of
/// paper 003's database was 7e-16 with a σ of 4e-30, and `--modes 20` trained on it); ships that are
/// combinations of others give fewer, and the database says so.
#[test]
fn rounding_noise_modes_are_left_out() {
    let modes = VariationModes::new(&ships()).expect("SVD");
    assert_eq!(modes.singular_values.len(), 19);
    assert_eq!(modes.noise_singular_values.len(), 1);
    assert!(!modes.rank_deficient());
    assert!(
        modes.weight_std.iter().all(|s| *s > 1e-4),
        "{:?}",
        modes.weight_std
    );
    // Three ships on one line: one mode, the rest noise.
    let db = ships();
    let (a, b) = (db[0].clone(), db[1].clone());
    let mut mid = a.clone();
    mid.id = "mid".into();
    let mix = |x: f64, y: f64| 0.5 * (x + y);
    mid.x_bb = mix(a.x_bb, b.x_bb);
    mid.x_br_minus_my = mix(a.x_br_minus_my, b.x_br_minus_my);
    mid.x_rr_plus_xg_my = mix(a.x_rr_plus_xg_my, b.x_rr_plus_xg_my);
    mid.x_bbbb = mix(a.x_bbbb, b.x_bbbb);
    mid.y_b = mix(a.y_b, b.y_b);
    mid.y_r_minus_mx = mix(a.y_r_minus_mx, b.y_r_minus_mx);
    mid.y_bbb = mix(a.y_bbb, b.y_bbb);
    mid.y_bbr = mix(a.y_bbr, b.y_bbr);
    mid.y_brr = mix(a.y_brr, b.y_brr);
    mid.y_rrr = mix(a.y_rrr, b.y_rrr);
    mid.n_b = mix(a.n_b, b.n_b);
    mid.n_r = mix(a.n_r, b.n_r);
    mid.n_bbb = mix(a.n_bbb, b.n_bbb);
    mid.n_bbr = mix(a.n_bbr, b.n_bbr);
    mid.n_brr = mix(a.n_brr, b.n_brr);
    mid.n_rrr = mix(a.n_rrr, b.n_rrr);
    mid.one_minus_t_r = mix(a.one_minus_t_r, b.one_minus_t_r);
    mid.a_h = mix(a.a_h, b.a_h);
    mid.x_h = mix(a.x_h, b.x_h);
    mid.epsilon = mix(a.epsilon, b.epsilon);
    mid.kappa = mix(a.kappa, b.kappa);
    mid.gamma_r_pos = mix(a.gamma_r_pos, b.gamma_r_pos);
    mid.gamma_r_neg = mix(a.gamma_r_neg, b.gamma_r_neg);
    mid.l_r = mix(a.l_r, b.l_r);
    let modes = VariationModes::new(&[a, b, mid]).expect("one real mode");
    assert_eq!(modes.singular_values.len(), 1);
    assert!(modes.rank_deficient());
    assert!((modes.contribution[0] - 1.0).abs() < 1e-12);
}

/// Finding 5: `n_r = -1e200` failed as a bare "SVD … NoConvergence"; now the ship and the key are
/// named, the number readable.
#[test]
fn an_absurd_database_coefficient_names_the_ship_and_key() {
    let mut db = ships();
    db[0].n_r = -1e200;
    let id = db[0].id.clone();
    let e = database_error(&db);
    assert!(
        e.contains(&format!("ship {id}: n_r = -1e200 is beyond ±100")),
        "{e}"
    );
    db[0].n_r = -0.05;
    db[3].y_bbb = 1e6;
    assert!(database_error(&db).contains("y_bbb = 1000000 is beyond ±100"));
}

/// Finding 2: a negative K_T curve gave "only 0 of 2603 usable (no MMG model)" after simulating the
/// whole database, exit 1; now refused at reading by the key.
#[test]
fn a_negative_k_t_is_refused_naming_the_key() {
    let mut t = kvlcc2();
    t.k_t = [-0.2931, -0.2753, -0.1385];
    let m = targets_fault(t);
    assert!(m.contains("target KVLCC2: k_t[0] = -0.2931"), "{m}");
    assert!(m.contains("must be positive"), "{m}");
    // A positive but useless curve: no rate balances the resistance (no ship of the target could be
    // simulated), found from one straight run.
    let mut t = kvlcc2();
    t.k_t = [1e-6, -0.2753, -0.1385];
    let m = targets_fault(t);
    assert!(m.contains("no self-propulsion point"), "{m}");
    assert!(m.contains("k_t = [0.000001, -0.2753, -0.1385]"), "{m}");
}

/// Finding 2: `added_mass.m_y = 1e6` (a mass in kg for the prime) ran the database to "only 0 usable";
/// now bounded as a data set's added mass is.
#[test]
fn an_absurd_added_mass_is_refused_naming_the_key() {
    for (m_x, m_y, j_z, key) in [
        (0.022, 1e6, 0.011, "added_mass.m_y = 1000000"),
        (50.0, 0.223, 0.011, "added_mass.m_x = 50"),
        (0.022, 0.223, 1e20, "added_mass.j_z = 1e20"),
    ] {
        let mut t = kvlcc2();
        t.added_mass = Some(AddedMassPrimes { m_x, m_y, j_z });
        let m = targets_fault(t);
        assert!(m.contains(&format!("target KVLCC2: {key}")), "{m}");
        assert!(m.contains("× the ship's own mass"), "{m}");
    }
    // The published values pass.
    targets_fault_free(kvlcc2());
}

fn targets_fault_free(t: TargetShip) {
    check_inputs(
        &ShipsFile { ship: ships() },
        TargetsFile { target: vec![t] },
    )
    .expect("valid");
}

/// Finding 3: a target without `[[target.motion]]` ran the whole pipeline and exited 0 with no model.
#[test]
fn a_target_without_a_motion_is_refused() {
    let mut t = kvlcc2();
    t.motion.clear();
    let m = targets_fault(t);
    assert!(
        m.contains("target KVLCC2: no [[target.motion]] (key `motion`): no motion to invert"),
        "{m}"
    );
}

/// Finding 4: `t1_p20 = 1e300` and `t2_m20` before `t1_p20` were inverted; now refused with the key,
/// the number readable.
#[test]
fn impossible_motion_indexes_are_refused() {
    let mut t = kvlcc2();
    t.motion[0].t1_p20 = 1e300;
    let m = targets_fault(t);
    assert!(m.contains("index t1_p20 = 1e300: above 100"), "{m}");
    assert!(!m.contains("00000000"), "{m}");
    let mut t = kvlcc2();
    t.motion[0].t2_m20 = 2.0;
    let m = targets_fault(t);
    assert!(
        m.contains("index t2_m20 = 2: must be later than t1_p20 = 4.0573"),
        "{m}"
    );
    for (edit, key) in [
        (
            (|t: &mut TargetShip| t.motion[0].advance_p35 = 3e5) as fn(&mut TargetShip),
            "advance_p35",
        ),
        (
            |t: &mut TargetShip| t.motion[0].tactical_diameter_m35 = -1e4,
            "tactical_diameter_m35",
        ),
        (
            |t: &mut TargetShip| t.motion[0].heading_peak_m20 = 12.0,
            "heading_peak_m20",
        ),
    ] {
        let mut t = kvlcc2();
        edit(&mut t);
        let m = targets_fault(t);
        assert!(m.contains(&format!("index {key} = ")), "{m}");
    }
    // Far outside the database but not impossible: inverted with a warning (the CLI's).
    let mut t = kvlcc2();
    t.motion[0].advance_p35 = 30.0;
    t.motion[0].tactical_diameter_p35 = 40.0;
    targets_fault_free(t);
}

/// Finding 9: `--resimulate 0` printed the held-out errors as `NaN %`.
#[test]
fn held_out_errors_without_resimulation_are_not_measured() {
    let target = kvlcc2();
    let modes = VariationModes::new(&ships()).expect("SVD");
    let weights = sample_weights(&modes, 3, 60, 3);
    let settings = SimSettings::default();
    let checks = PhysicalChecks::default();
    let db = build_database(&target, &modes, &weights, &settings, &checks, &|| {})
        .expect("valid target");
    let model = InverseModel::train(&db, &TrainOptions::default()).expect("enough samples");
    let held = held_out(&target, &modes, &db, &model, &settings, &checks, 0);
    assert_eq!(held.index_mare, None);
    let md = header_markdown(&target, 3, &db, 0.0, &model, &held);
    assert!(!md.contains("NaN"), "{md}");
    assert!(
        md.contains(
            "none re-simulated (--resimulate 0): the held-out index errors were not measured"
        ),
        "{md}"
    );
    let held = held_out(&target, &modes, &db, &model, &settings, &checks, 2);
    assert!(held.index_mare.is_some());
    let md = header_markdown(&target, 3, &db, 0.0, &model, &held);
    assert!(
        md.contains("mean |relative error| per index: AD+35/L"),
        "{md}"
    );
}
