//! Identification end to end: known coefficients are recovered from their own simulations, and every
//! estimator reproduces the zig-zag it was trained on.

use crate::common;

use shipid_estimators::Solver;
use shipid_io::{Dataset, DatasetRecording, Manoeuvre, Side};
use shipid_pipeline::fit::{EstimatorSpec, WindowSpec, fit_dataset, load_set};
use shipid_sim::{AbkowitzDynamics, SimOptions, State, controller_for, metrics};

fn embedded() -> Dataset {
    Dataset::load(&common::root().join("data/kvlcc2-mmg/dataset.toml")).unwrap()
}

fn spec(name: &str, tune: bool) -> EstimatorSpec {
    EstimatorSpec {
        tune,
        ..EstimatorSpec::named(name)
    }
}

/// A data set simulated by `model` (noise-free, with the model's accelerations).
fn simulated(model: &AbkowitzDynamics, base: &Dataset) -> Dataset {
    let manoeuvres = [
        Manoeuvre::ZigZag {
            rudder_deg: 35.0,
            check_deg: 35.0,
            side: Side::Port,
        },
        Manoeuvre::ZigZag {
            rudder_deg: 20.0,
            check_deg: 20.0,
            side: Side::Starboard,
        },
        Manoeuvre::Turning {
            rudder_deg: 35.0,
            side: Side::Starboard,
        },
    ];
    let recordings = manoeuvres
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let mut c = controller_for(m, 5.0).unwrap();
            let opts = SimOptions::new(250.0).with_step(0.05, 0.1);
            let out = shipid_sim::simulate(model, c.as_mut(), State::approach(base.ship.u0), &opts)
                .unwrap();
            assert_eq!(
                out.status,
                shipid_sim::SimStatus::Ok,
                "the known model is stable on {m:?}"
            );
            DatasetRecording {
                file: format!("synthetic_{i}.csv"),
                manoeuvre: *m,
                recording: out.recording,
            }
        })
        .collect();
    Dataset {
        recordings,
        name: "synthetic".into(),
        ..base.clone()
    }
}

#[test]
fn lsq_recovers_known_coefficients_and_metrics_from_noise_free_simulations() {
    let base = embedded();
    // The known model: reduced32 identified from the MMG zig-zag (a stable, realistic Abkowitz model).
    let truth = fit_dataset(
        &base,
        load_set("reduced32").unwrap(),
        &spec("lsq", false),
        &["zz35_35_ps.csv".into()],
        WindowSpec::Overshoots(4),
        Solver::Fast,
    )
    .unwrap()
    .model;
    let data = simulated(&AbkowitzDynamics(truth.clone()), &base);
    for (estimator, solver) in [
        ("lsq", Solver::Fast),
        ("lsq", Solver::Qp),
        ("bounded-lsq", Solver::Fast),
    ] {
        let fitted = fit_dataset(
            &data,
            load_set("reduced32").unwrap(),
            &spec(estimator, false),
            &[],
            WindowSpec::Whole,
            solver,
        )
        .unwrap()
        .model;
        for d in 0..3 {
            for (j, (got, want)) in fitted.coefficients[d]
                .iter()
                .zip(&truth.coefficients[d])
                .enumerate()
            {
                let rel = (got - want).abs() / want.abs();
                assert!(
                    rel < 1e-3,
                    "{estimator}/{solver:?}: {} = {got} vs {want} ({rel:e})",
                    truth.set.names(shipid_model::Dof::ALL[d])[j]
                );
            }
        }
        // And the identified model predicts the truth's manoeuvres.
        for r in &data.recordings {
            let sim = shipid_pipeline::validate::compare_manoeuvre(
                &AbkowitzDynamics(fitted.clone()),
                r,
                &data.ship,
            )
            .unwrap();
            let mrae = sim.mrae.unwrap();
            assert!(mrae < 1e-3, "{estimator}: {} MRAE {mrae}", r.file);
        }
    }
}

/// Issue 3: trained on ZZ35/35 PS cut after 4 overshoots, every estimator gets the training run's first
/// and second overshoot within 1°, with either set. The reduced set's margin is thin (0.72–0.95°
/// measured): it is odd-symmetric and the MMG truth is not.
#[test]
fn every_estimator_reproduces_its_training_zigzag_with_either_set() {
    let ds = embedded();
    let training = ds.recording("zz35_35_ps.csv").unwrap();
    let recorded = metrics(&training.recording, &training.manoeuvre, &ds.ship);
    for (set, name, tune) in ["full68", "reduced32"].into_iter().flat_map(|set| {
        [
            ("lsq", false),
            ("bounded-lsq", false),
            ("ridge", true),
            ("lasso", true),
            ("svr", true),
        ]
        .map(|(e, t)| (set, e, t))
    }) {
        let estimator = format!("{set} {name}");
        let out = fit_dataset(
            &ds,
            load_set(set).unwrap(),
            &spec(name, tune),
            &["zz35_35_ps.csv".into()],
            WindowSpec::Overshoots(4),
            Solver::Fast,
        )
        .unwrap();
        assert!(
            out.dofs.iter().all(|d| d.fit.status.is_solved()),
            "{estimator}: {:?}",
            out.dofs[0].fit.status
        );
        let cmp = shipid_pipeline::validate::compare_manoeuvre(
            &AbkowitzDynamics(out.model),
            training,
            &ds.ship,
        )
        .unwrap();
        let p = cmp.predicted.expect("training run re-simulates");
        for (k, (a, b)) in [
            (1, (recorded.overshoot_1, p.overshoot_1)),
            (2, (recorded.overshoot_2, p.overshoot_2)),
        ] {
            let (a, b) = (a.unwrap(), b.unwrap());
            assert!(
                (a - b).abs() <= 1.0,
                "{estimator}: overshoot {k} {b:.2}° vs recorded {a:.2}°"
            );
        }
    }
}

#[test]
fn the_symmetric_reduced_set_still_gets_the_first_overshoot_and_the_turning_circles() {
    // reduced32 has no port/starboard asymmetry terms (docs/conventions.md, coefficient sets) while the MMG truth has; its first
    // overshoot and its turning circles are still close (README: identification table).
    let ds = embedded();
    let out = fit_dataset(
        &ds,
        load_set("reduced32").unwrap(),
        &spec("lsq", false),
        &["zz35_35_ps.csv".into()],
        WindowSpec::Overshoots(4),
        Solver::Fast,
    )
    .unwrap();
    let model = AbkowitzDynamics(out.model);
    let zz = shipid_pipeline::validate::compare_manoeuvre(
        &model,
        ds.recording("zz35_35_ps.csv").unwrap(),
        &ds.ship,
    )
    .unwrap();
    assert!(
        zz.relative_error["overshoot_1"].abs() < 0.02,
        "{:?}",
        zz.relative_error
    );
    for f in ["tc35_ps.csv", "tc35_sb.csv"] {
        let tc = shipid_pipeline::validate::compare_manoeuvre(
            &model,
            ds.recording(f).unwrap(),
            &ds.ship,
        )
        .unwrap();
        assert!(tc.mrae.unwrap() < 0.03, "{f}: {:?}", tc.relative_error);
    }
}

#[test]
fn asking_for_more_overshoots_than_the_record_has_is_bad_input() {
    let ds = embedded();
    let err = fit_dataset(
        &ds,
        load_set("reduced32").unwrap(),
        &spec("lsq", false),
        &["zz35_35_ps.csv".into()],
        WindowSpec::Overshoots(40),
        Solver::Fast,
    )
    .err()
    .unwrap();
    assert!(err.is_bad_input());
    assert!(
        err.to_string()
            .starts_with("zz35_35_ps.csv: 40 overshoots requested but the record has"),
        "{err}"
    );
}

/// `--refine`: the output-error refinement lowers the segment-replay error on the training window
/// without giving up the force fit (the equation error stays within a factor of the LSQ one), and the
/// model file records what it did.
#[test]
fn output_error_refinement_lowers_the_replay_error_and_keeps_the_force_fit() {
    let ds = embedded();
    let fit = |refine: bool| {
        fit_dataset(
            &ds,
            load_set("reduced32").unwrap(),
            &EstimatorSpec {
                refine,
                ..EstimatorSpec::named("lsq")
            },
            &["zz35_35_ps.csv".to_string()],
            WindowSpec::Overshoots(4),
            Solver::Fast,
        )
        .unwrap()
    };
    let lsq = fit(false);
    let refined = fit(true);
    assert!(lsq.file.estimator.refinement.is_none());
    let how = refined.file.estimator.refinement.clone().unwrap();
    assert!(
        how.after_position_rmse_over_l < 0.8 * how.before_position_rmse_over_l,
        "{how:?}"
    );
    assert!(
        how.after_heading_rmse_deg < how.before_heading_rmse_deg,
        "{how:?}"
    );
    // The file round-trips with the refinement and rebuilds the refined coefficients.
    let text = toml::to_string(&refined.file).unwrap();
    let back: shipid_model::ModelFile = toml::from_str(&text).unwrap();
    assert_eq!(back.to_model().unwrap(), refined.model);
    assert_eq!(back.estimator.refinement, Some(how));
    // Equation error of the refined model on the training data: within 3× the LSQ optimum per DOF.
    let rec = &ds.recording("zz35_35_ps.csv").unwrap().recording;
    let acc = rec.accelerations.as_ref().unwrap();
    let ee = |m: &shipid_model::AbkowitzModel| -> [f64; 3] {
        let mut s = [0.0; 3];
        for i in (0..rec.len()).step_by(5) {
            let a = m.accelerations(rec.u[i], rec.v[i], rec.r[i], rec.delta[i]);
            let r = [acc.u_dot[i], acc.v_dot[i], acc.r_dot[i]];
            (0..3).for_each(|d| s[d] += (a[d] - r[d]).powi(2));
        }
        s
    };
    let (e0, e1) = (ee(&lsq.model), ee(&refined.model));
    for d in 0..3 {
        assert!(e1[d] < 9.0 * e0[d], "DOF {d}: {} vs {}", e1[d], e0[d]);
    }
}

/// `--tune` on the SVR chooses C and ε together by the blocked cross-validation (the point of least
/// validation MSE over the ε × C grid); a given ε stays fixed and only C is tuned.
#[test]
fn svr_tuning_chooses_epsilon_too_unless_it_is_given() {
    let ds = embedded();
    let fit = |epsilon: Option<f64>| {
        fit_dataset(
            &ds,
            load_set("reduced32").unwrap(),
            &EstimatorSpec {
                epsilon,
                ..spec("svr", true)
            },
            &["zz35_35_ps.csv".into()],
            WindowSpec::Overshoots(4),
            Solver::Fast,
        )
        .unwrap()
    };
    let joint = fit(None);
    let mut chosen = Vec::new();
    for d in &joint.dofs {
        let t = d.tuning.as_ref().expect("tuned");
        let grid = shipid_estimators::default_epsilon_grid(&[d.target_rms; 7]);
        assert_eq!(t.curve.len(), grid.len() * 13, "{}", d.dof);
        let best = t
            .curve
            .iter()
            .min_by(|a, b| a.mse.total_cmp(&b.mse))
            .unwrap();
        let shipid_estimators::Estimator::Svr { c, epsilon } = d.fit.estimator else {
            panic!("{}: {:?}", d.dof, d.fit.estimator)
        };
        assert_eq!((c, Some(epsilon)), (best.param, best.epsilon), "{}", d.dof);
        let share = epsilon / d.target_rms;
        assert!(
            (1e-3 * 0.99..=0.32).contains(&share),
            "{}: ε/rms {share}",
            d.dof
        );
        chosen.push(share);
    }
    // On this run the choice is not the old fixed 1 % everywhere (X 0.3 %, Y 0.1 %, N 10 % measured).
    assert!(chosen.iter().any(|s| (s - 0.01).abs() > 1e-3), "{chosen:?}");

    let fixed = fit(Some(2e-5));
    for d in &fixed.dofs {
        let t = d.tuning.as_ref().expect("tuned");
        assert_eq!(t.curve.len(), 13, "{}", d.dof);
        assert!(t.curve.iter().all(|p| p.epsilon.is_none()));
        assert!(matches!(
            d.fit.estimator,
            shipid_estimators::Estimator::Svr { epsilon, .. } if epsilon == 2e-5
        ));
    }
}

/// Which regressors a fit of the embedded zig-zag on `window` finds without information, per DOF
/// (empty when every coefficient is identified).
fn check_information(window: WindowSpec, expected: &[(&str, &[&str])]) {
    let ds = embedded();
    let out = fit_dataset(
        &ds,
        load_set("reduced32").unwrap(),
        &spec("lsq", false),
        &["zz20_20_ps.csv".to_string()],
        window,
        Solver::Fast,
    )
    .unwrap();
    let got: Vec<(String, Vec<String>)> = out
        .no_information()
        .map(|n| {
            n.regressors
                .into_iter()
                .map(|(dof, names)| (dof.to_string(), names))
                .collect()
        })
        .unwrap_or_default();
    let expected: Vec<(String, Vec<String>)> = expected
        .iter()
        .map(|(dof, names)| {
            (
                dof.to_string(),
                names.iter().map(|s| s.to_string()).collect(),
            )
        })
        .collect();
    assert_eq!(got, expected, "{window:?}");
}

#[test]
fn window_before_rudder_action_is_rank_deficient() {
    // Regression: `fit --window 0:3` (the rudder first moves at 5 s) reported status Ok with every
    // coefficient 0, and `validate` called that model ok.
    let uv: &[&str] = &["v", "r", "d", "vvv", "vvr", "vrr", "uv", "ur", "ud"];
    let y: Vec<String> = uv.iter().map(|t| format!("Y_{t}")).collect();
    let n: Vec<String> = uv.iter().map(|t| format!("N_{t}")).collect();
    let x = [
        "X_u", "X_uu", "X_uuu", "X_vv", "X_rr", "X_dd", "X_vr", "X_vd", "X_rd",
    ];
    let y: Vec<&str> = y.iter().map(String::as_str).collect();
    let n: Vec<&str> = n.iter().map(String::as_str).collect();
    check_information(
        WindowSpec::Time {
            start_s: 0.0,
            end_s: 3.0,
        },
        &[("X", &x), ("Y", &y), ("N", &n)],
    );
    // Half a second after the rudder first moves, every column is still exactly collinear in
    // floating point (effective condition number infinite): no information either.
    check_information(
        WindowSpec::Time {
            start_s: 0.0,
            end_s: 5.5,
        },
        &[("X", &x), ("Y", &y), ("N", &n)],
    );
    check_information(
        WindowSpec::Time {
            start_s: 0.0,
            end_s: 60.0,
        },
        &[],
    );
}
