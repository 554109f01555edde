//! Coefficient sets as data, and the design matrix as the exact inverse of the model's equations.

use proptest::prelude::*;
use shipid_io::{AddedMass, PrimeScale, Recording, Ship};
use shipid_model::{
    AbkowitzModel, CoefficientSet, Dof, EstimatorInfo, ModelFile, Monomial, Powers, Samples,
    SetFile, design,
};

fn kvlcc2() -> (Ship, AddedMass) {
    (
        Ship {
            lpp: 7.0,
            beam: 1.27,
            draft: 0.46,
            displacement: 3.27,
            rho: 1000.0,
            xg: 0.25,
            kzz: 1.75,
            u0: 1.179,
            rudder_rate: 15.8,
        },
        AddedMass {
            X_udot: -247.94,
            Y_vdot: -2513.21,
            Y_rdot: 0.0,
            N_vdot: 0.0,
            N_rdot: -6074.53,
        },
    )
}

fn check_count(name: &str, per_dof: [usize; 3], total: usize) {
    let s = CoefficientSet::builtin(name).unwrap();
    let got: Vec<usize> = Dof::ALL
        .iter()
        .map(|d| s.terms[d.index()].len() + s.known[d.index()].len())
        .collect();
    assert_eq!(got, per_dof, "{name} per DOF (terms + known accelerations)");
    assert_eq!(s.coefficient_count(), total, "{name}");
}

#[test]
fn shipped_sets_have_the_sizes_of_domain_section_3_and_paper_001() {
    check_count("full68", [18, 25, 25], 68);
    check_count("full74", [18, 28, 28], 74);
    check_count("reduced32", [10, 11, 11], 32);
    check_count("chen2021", [11, 14, 14], 39);
}

#[test]
fn sets_respect_port_starboard_symmetry() {
    // X is even in (v, r, δ); Y and N are odd except the asymmetry constants and their Δu dependence,
    // and the second-order asymmetry terms of the set built for it.
    for name in CoefficientSet::builtin_names() {
        let declared_even: &[&str] = if name == "full74" {
            &["vv", "vr", "rr"]
        } else {
            &[]
        };
        let s = CoefficientSet::builtin(name).unwrap();
        assert!(
            s.terms[0].iter().all(|m| !m.is_odd()),
            "{name}: X must be even"
        );
        for d in [Dof::Y, Dof::N] {
            for m in &s.terms[d.index()] {
                let asymmetry = m.v + m.r + m.delta == 0
                    || declared_even
                        .iter()
                        .any(|t| Monomial::parse(t).unwrap() == *m);
                assert!(
                    m.is_odd() || asymmetry,
                    "{name}: {} is even",
                    m.coefficient_name(d)
                );
            }
        }
    }
    let full = CoefficientSet::builtin("full68").unwrap();
    assert!(
        full.names(Dof::Y).contains(&"Y_0".to_string()),
        "full set has Y_0"
    );
    let reduced = CoefficientSet::builtin("reduced32").unwrap();
    assert!(
        !reduced.names(Dof::N).contains(&"N_0".to_string()),
        "reduced set has no N_0"
    );
}

fn set_error(text: &str) -> String {
    let file: SetFile = toml::from_str(text).unwrap();
    CoefficientSet::from_file(file).unwrap_err().to_string()
}

#[test]
fn bad_set_files_name_the_key() {
    let base = "name = \"t\"\nsource = \"test\"\n[X]\nterms = [\"u\"]\n[Y]\nterms = [\"v\"]\n[N]\nterms = [\"v\"]\n";
    assert_eq!(
        set_error(&base.replace("[\"u\"]", "[\"u\", \"q\"]")),
        "key `X.terms[1]`: term \"q\": unknown letter 'q' (u = Δu', v, r, d = δ, or \"1\")"
    );
    assert_eq!(
        set_error(&base.replace("[Y]\nterms = [\"v\"]", "[Y]\nterms = [\"vr\", \"rv\"]")),
        "key `Y.terms[1]`: term \"rv\" appears twice"
    );
    assert_eq!(
        set_error(&format!(
            "{base}[[constraint]]\ndof = \"N\"\nterm = \"r\"\nsign = \"negative\"\nsource = \"x\"\n"
        )),
        "key `constraint[0].term`: \"r\" is not a term of N"
    );
    assert_eq!(
        set_error(&format!(
            "{base}[[constraint]]\ndof = \"N\"\nterm = \"v\"\nsign = \"down\"\nsource = \"x\"\n"
        )),
        "key `constraint[0].sign`: \"down\" is neither \"negative\" nor \"positive\""
    );
}

#[test]
fn constraints_become_bounds() {
    let text = "name = \"t\"\nsource = \"test\"\n[X]\nterms = [\"u\"]\n[Y]\nterms = [\"v\", \"r\"]\n[N]\nterms = [\"v\"]\n\
                [[constraint]]\ndof = \"Y\"\nterm = \"v\"\nsign = \"negative\"\nlower = -1.0\nsource = \"stability\"\n";
    let s = CoefficientSet::from_file(toml::from_str(text).unwrap()).unwrap();
    assert_eq!(
        s.bounds[1],
        vec![(-1.0, 0.0), (f64::NEG_INFINITY, f64::INFINITY)]
    );
    assert!(s.has_bounds(Dof::Y) && !s.has_bounds(Dof::N));
}

#[test]
fn monomial_codes_round_trip() {
    for code in ["1", "u", "uuu", "vvr", "vrd", "uud", "dd"] {
        let m = Monomial::parse(code).unwrap();
        assert_eq!(m.code(), code);
    }
    assert_eq!(Monomial::parse("dvr").unwrap().code(), "vrd");
    assert_eq!(
        Monomial::parse("vvr").unwrap().eval(0.5, 2.0, 3.0, 7.0),
        12.0
    );
}

fn model_with(set: &str, seed: u64) -> AbkowitzModel {
    let (ship, am) = kvlcc2();
    let s = CoefficientSet::builtin(set).unwrap();
    let coeffs = std::array::from_fn(|d| {
        (0..s.terms[d].len())
            .map(|j| (((j as u64 + 3) * (seed + 11 + d as u64)) as f64 * 0.7).sin() * 0.01)
            .collect()
    });
    AbkowitzModel::new(s, coeffs, ship, am).unwrap()
}

proptest! {
    /// Accelerations from the model, put through the regression targets (the equations of motion,
    /// `docs/conventions.md`), give back y = Φβ exactly:
    /// the design matrix and the model's equations are the same equations.
    #[test]
    fn targets_invert_the_model_equations(seed in 0u64..50, states in proptest::collection::vec(
        (0.3f64..1.3, -0.3f64..0.3, -0.1f64..0.1, -0.6f64..0.6), 5..30)) {
        for set in ["full68", "full74", "reduced32", "chen2021"] {
            let model = model_with(set, seed);
            let (ship, _) = kvlcc2();
            let mut rec = Recording::default();
            let mut acc = shipid_io::Accelerations::default();
            for (k, &(u, v, r, d)) in states.iter().enumerate() {
                let a = model.accelerations(u, v, r, d);
                rec.t.push(k as f64);
                rec.u.push(u); rec.v.push(v); rec.r.push(r); rec.delta.push(d);
                rec.x0.push(0.0); rec.y0.push(0.0); rec.psi.push(0.0);
                acc.u_dot.push(a[0]); acc.v_dot.push(a[1]); acc.r_dot.push(a[2]);
            }
            let mut samples = Samples::default();
            samples.push(&rec, &acc, &PrimeScale::of(&ship), 0);
            let inertia = shipid_model::PrimeInertia::new(&ship, &model.added_mass, &model.set);
            for dof in Dof::ALL {
                let des = design(&model.set, dof, &samples, &inertia);
                for i in 0..samples.len() {
                    let fit: f64 = (0..des.phi.ncols()).map(|j| des.phi[(i, j)] * model.coefficients[dof.index()][j]).sum();
                    prop_assert!((fit - des.y[i]).abs() <= 1e-12 + 1e-9 * des.y[i].abs(), "{set} {dof} sample {i}: {fit} vs {}", des.y[i]);
                }
            }
        }
    }
}

#[test]
fn model_file_round_trips_and_rejects_foreign_coefficients() {
    let m = model_with("reduced32", 3);
    let file = ModelFile::from_model(
        &m,
        EstimatorInfo {
            name: "lsq".into(),
            solver: "fast".into(),
            ..Default::default()
        },
        vec![],
    );
    let text = toml::to_string(&file).unwrap();
    let back: ModelFile = toml::from_str(&text).unwrap();
    assert_eq!(back.to_model().unwrap(), m);
    let mut bad = back.clone();
    bad.coefficients
        .get_mut("Y")
        .unwrap()
        .insert("Y_rrr".into(), 1.0);
    assert_eq!(
        bad.to_model().unwrap_err().to_string(),
        "coefficient `Y_rrr` is not a term of the set"
    );
}

#[test]
fn straight_run_at_u0_is_an_equilibrium_of_any_symmetric_model() {
    let m = model_with("reduced32", 5);
    let a = m.accelerations(1.179, 0.0, 0.0, 0.0);
    assert!(a.iter().all(|x| x.abs() < 1e-15), "{a:?}");
}

proptest! {
    /// The tabulated powers give every monomial's value to the last bit (the model's forces,
    /// and so every simulation, did not change when they replaced `powi`).
    #[test]
    fn tabulated_powers_equal_powi_to_the_last_bit(
        x in proptest::array::uniform4(-2.0f64..2.0),
        e in proptest::array::uniform4(0u8..6),
    ) {
        let m = Monomial { du: e[0], v: e[1], r: e[2], delta: e[3] };
        let p = Powers::new(x[0], x[1], x[2], x[3]);
        prop_assert_eq!(m.eval_powers(&p).to_bits(), m.eval(x[0], x[1], x[2], x[3]).to_bits());
    }
}
