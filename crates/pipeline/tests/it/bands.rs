//! Block-bootstrap replicates of a polynomial or mmg fit, posterior draws of a sparse GP, and the
//! manoeuvre bands they give.

use std::path::Path;

use shipid_estimators::Solver;
use shipid_io::Dataset;
use shipid_model::CoefficientSet;
use shipid_pipeline::bands::{BandRun, gp_draws, manoeuvre_bands};
use shipid_pipeline::bootstrap::{Bootstrap, bootstrap_abkowitz, bootstrap_mmg};
use shipid_pipeline::fit::{EstimatorSpec, FitOutput, WindowSpec, fit_dataset};
use shipid_pipeline::fit_gp::{DEFAULT_SIMILARITY, fit_gp_dataset};
use shipid_pipeline::mmg::{
    MmgFit, MmgFitOptions, MmgModelFile, fit_mmg_dataset, model_file, write_mmg_model_file,
};
use shipid_pipeline::spec::parse_manoeuvre;
use shipid_sim::{AbkowitzDynamics, Dynamics};

fn default_data() -> Dataset {
    Dataset::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/kvlcc2-mmg/dataset.toml"))
        .expect("the shipped default data load")
}

/// reduced32 ridge (λ fixed) on ZZ35/35 port alone: the single-manoeuvre case.
fn zz35_fit(ds: &Dataset) -> FitOutput {
    let spec = EstimatorSpec {
        lambda: Some(1e-6),
        ..EstimatorSpec::named("ridge")
    };
    fit_dataset(
        ds,
        CoefficientSet::builtin("reduced32").unwrap(),
        &spec,
        &["zz35_35_ps.csv".into()],
        WindowSpec::Whole,
        Solver::Fast,
    )
    .expect("reduced32 fits ZZ35")
}

fn replicates(ds: &Dataset, out: &FitOutput, n: usize, seed: u64) -> Bootstrap {
    let estimators = [0, 1, 2].map(|i| out.dofs[i].fit.estimator);
    bootstrap_abkowitz(
        ds,
        &out.model,
        &out.model.coefficients,
        &out.training,
        &estimators,
        false,
        Solver::Fast,
        n,
        seed,
    )
    .expect("the bootstrap runs")
}

#[test]
fn bootstrap_is_reproducible_and_centred_on_the_fit() {
    let ds = default_data();
    let out = zz35_fit(&ds);
    let a = replicates(&ds, &out, 60, 5);
    let b = replicates(&ds, &out, 60, 5);
    assert_eq!(a.replicates, b.replicates, "same seed, same replicates");
    assert_eq!(a.replicates.len() + a.rejected, 60);
    assert!(
        a.block.rows > 1,
        "manoeuvre residuals are autocorrelated: {:?}",
        a.block
    );
    // Every coefficient varies, and the fit lies inside its replicates' range.
    for dof in 0..3 {
        for (j, &c) in out.model.coefficients[dof].iter().enumerate() {
            let values: Vec<f64> = a.replicates.iter().map(|r| r[dof][j]).collect();
            let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            assert!(lo < hi, "DOF {dof} term {j} does not vary");
            assert!(
                lo <= c && c <= hi,
                "DOF {dof} term {j}: fit {c} outside [{lo}, {hi}]"
            );
        }
    }
}

#[test]
fn too_few_or_absurd_replicate_counts_are_refused() {
    let ds = default_data();
    let out = zz35_fit(&ds);
    let estimators = [0, 1, 2].map(|i| out.dofs[i].fit.estimator);
    for n in [0, 1, 10_001] {
        let err = bootstrap_abkowitz(
            &ds,
            &out.model,
            &out.model.coefficients,
            &out.training,
            &estimators,
            false,
            Solver::Fast,
            n,
            1,
        )
        .unwrap_err();
        assert!(err.to_string().contains("--bootstrap"), "{n}: {err}");
    }
}

#[test]
fn turning_circle_bands_count_every_replicate() {
    let ds = default_data();
    let out = zz35_fit(&ds);
    let boot = replicates(&ds, &out, 40, 9);
    let models: Vec<Box<dyn Dynamics + Send + Sync>> = boot
        .replicates
        .iter()
        .map(|c| {
            let m = shipid_model::AbkowitzModel::new(
                out.model.set.clone(),
                c.clone(),
                out.model.ship,
                out.model.added_mass,
            )
            .unwrap();
            Box::new(AbkowitzDynamics(m)) as Box<dyn Dynamics + Send + Sync>
        })
        .collect();
    let m = parse_manoeuvre("turning:35:starboard").unwrap();
    let bands = manoeuvre_bands(
        &AbkowitzDynamics(out.model.clone()),
        &models,
        &m,
        &ds.ship,
        0.9,
        BandRun::Standard,
    )
    .unwrap();
    assert_eq!(bands.replicates, 40);
    let tactical = bands
        .metrics
        .iter()
        .find(|b| b.metric.starts_with("tactical_diameter"))
        .expect("a turning circle has a tactical diameter");
    let band = tactical.band.as_ref().expect("40 replicates give a band");
    assert!(band.lo <= band.hi);
    assert_eq!(band.finite + band.undefined, 40);
    // Zig-zag metrics are not defined for a turning circle: no band, and the reason says why.
    let overshoot = bands
        .metrics
        .iter()
        .find(|b| b.metric.starts_with("overshoot_1"))
        .unwrap();
    assert!(overshoot.point.is_none() && overshoot.band.is_err());
    let track = bands.track.expect("a run gives a track band");
    assert_eq!(track.t_s.len(), track.psi_deg.len());
}

#[test]
fn bootstrap_record_round_trips_through_the_model_file() {
    let ds = default_data();
    let mut out = zz35_fit(&ds);
    let boot = replicates(&ds, &out, 25, 3);
    out.file.bootstrap = Some(boot.record(&out.model));
    let text = toml::to_string(&out.file).unwrap();
    let read: shipid_model::ModelFile = toml::from_str(&text).unwrap();
    let record = read.bootstrap.expect("the [bootstrap] table is read back");
    assert_eq!(
        record.coefficient_vectors(&out.model.set).unwrap(),
        boot.replicates
    );
    assert_eq!(record.block_rows, boot.block.rows);
    // Every coefficient has a standard error, and a correlation matrix per DOF of the set's size.
    for dof in shipid_model::Dof::ALL {
        let n = out.model.set.names(dof).len();
        assert_eq!(record.standard_error[dof.as_str()].len(), n);
        assert_eq!(record.correlation[dof.as_str()].len(), n);
    }
}

#[test]
fn a_damaged_bootstrap_table_names_the_fault() {
    let ds = default_data();
    let mut out = zz35_fit(&ds);
    let boot = replicates(&ds, &out, 25, 3);
    let mut record = boot.record(&out.model);
    let x = record.replicates.get_mut("X").unwrap();
    let first = x.keys().next().unwrap().clone();
    x.get_mut(&first).unwrap().pop();
    out.file.bootstrap = Some(record.clone());
    let err = record.coefficient_vectors(&out.model.set).unwrap_err();
    assert!(err.to_string().contains("replicates"), "{err}");
    record.replicates.get_mut("X").unwrap().remove(&first);
    let err = record.coefficient_vectors(&out.model.set).unwrap_err();
    assert!(err.to_string().contains(&first), "{err}");
}

/// The default mmg fit (bounded LSQ, λ = 1e-6) on ZZ35/35 port alone.
fn zz35_mmg(ds: &Dataset) -> (MmgFit, MmgFitOptions) {
    let opts = MmgFitOptions {
        recordings: vec!["zz35_35_ps.csv".into()],
        ..MmgFitOptions::default()
    };
    (fit_mmg_dataset(ds, &opts).expect("mmg fits ZZ35"), opts)
}

#[test]
fn mmg_bootstrap_is_reproducible_and_round_trips_through_the_model_file() {
    let ds = default_data();
    let (fit, opts) = zz35_mmg(&ds);
    let a = bootstrap_mmg(&ds, &fit, &opts, 24, 7).unwrap();
    let b = bootstrap_mmg(&ds, &fit, &opts, 24, 7).unwrap();
    assert_eq!(a.replicates, b.replicates, "same seed, same replicates");
    assert_eq!(a.replicates.len() + a.rejected, 24);
    assert!(a.block.rows > 1, "autocorrelated residuals: {:?}", a.block);
    // Every parameter the data determine varies over the replicates, and they scatter around the fit.
    for (j, p) in fit.estimate.params.iter().enumerate() {
        let values: Vec<f64> = a.replicates.iter().map(|r| r[j]).collect();
        let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        assert!(
            values
                .iter()
                .all(|v| (p.spec.lower..=p.spec.upper).contains(v)),
            "{}: a replicate outside the bounds",
            p.spec.name
        );
        if p.determined_by_data && !p.at_bound {
            assert!(lo < hi, "{} does not vary", p.spec.name);
            let mean = values.iter().sum::<f64>() / values.len() as f64;
            assert!(
                (mean - p.value).abs() <= 3.0 * (hi - lo),
                "{}: replicates [{lo}, {hi}] far from the fit {}",
                p.spec.name,
                p.value
            );
        }
    }
    let mut file = model_file(&fit, ds.added_mass.unwrap());
    file.bootstrap = Some(a.record());
    let text = write_mmg_model_file(&file).unwrap();
    let read: MmgModelFile = toml::from_str(&text).unwrap();
    let record = read
        .bootstrap
        .clone()
        .expect("the [bootstrap] table is read back");
    assert_eq!(
        record.parameter_vectors(&read.parameters).unwrap(),
        a.replicates
    );
    assert_eq!(record.order.len(), fit.estimate.params.len());
    assert_eq!(record.correlation.len(), record.order.len());
    assert_eq!(record.standard_error.len(), record.order.len());
    let models = read.replicate_models(Path::new("m.toml")).unwrap();
    assert_eq!(models.len(), a.replicates.len());
}

#[test]
fn mmg_bootstrap_follows_a_moved_centre() {
    // A refined model's replicates are its own parameters shifted by each replicate's departure from
    // the equation-error estimate: move the file's n_r, and the replicates move with it.
    let ds = default_data();
    let (fit, opts) = zz35_mmg(&ds);
    let k = fit
        .estimate
        .params
        .iter()
        .position(|p| p.spec.name == "n_r")
        .unwrap();
    let at_fit = bootstrap_mmg(&ds, &fit, &opts, 20, 3).unwrap();
    let mut moved = fit;
    let shift = 0.1 * moved.estimate.params[k].value;
    moved.estimate.params[k].value += shift;
    let shifted = bootstrap_mmg(&ds, &moved, &opts, 20, 3).unwrap();
    let mean = |b: &shipid_pipeline::bootstrap::MmgBootstrap| {
        b.replicates.iter().map(|r| r[k]).sum::<f64>() / b.replicates.len() as f64
    };
    let moved_by = mean(&shifted) - mean(&at_fit);
    assert!(
        (moved_by - shift).abs() < 0.2 * shift.abs(),
        "the replicates moved by {moved_by}, the centre by {shift}"
    );
}

/// Regression (`mmg-bootstrap-band-excludes-fit`): with a prior far from what the data show (a
/// full-scale ship's Reynolds-scaled resistance prior; here a strong prior weight), every resampled
/// refit leaned further towards the prior than the fit, and the band of the 35° turn lay beside the
/// fit's own prediction. The replicates are now centred on the fit: their mean departure is the
/// bootstrap's estimate of that bias and is taken out.
#[test]
fn mmg_bootstrap_replicates_are_centred_on_the_fit_under_a_strong_prior() {
    let ds = default_data();
    let opts = MmgFitOptions {
        recordings: vec!["zz35_35_ps.csv".into()],
        prior_weight: shipid_pipeline::mmg::PriorWeight::Fixed(1e-2),
        ..MmgFitOptions::default()
    };
    let fit = fit_mmg_dataset(&ds, &opts).expect("mmg fits ZZ35");
    let boot = bootstrap_mmg(&ds, &fit, &opts, 24, 5).unwrap();
    for (j, p) in fit.estimate.params.iter().enumerate() {
        let values: Vec<f64> = boot.replicates.iter().map(|r| r[j]).collect();
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        let spread = values.iter().map(|v| (v - mean).abs()).fold(0.0, f64::max);
        // Clamping at a bound may leave a parameter on the bound's side.
        let near_bound = values
            .iter()
            .any(|v| *v == p.spec.lower || *v == p.spec.upper);
        assert!(
            near_bound || (mean - p.value).abs() <= 1e-9 * p.value.abs().max(1.0) + 1e-3 * spread,
            "{}: replicate mean {mean} against the fit {} (spread {spread})",
            p.spec.name,
            p.value
        );
    }
}

#[test]
fn sparse_gp_draws_are_reproducible_and_their_band_holds_the_mean_prediction() {
    let ds = default_data();
    let (_, model, _) = fit_gp_dataset(
        &ds,
        &["zz35_35_ps.csv".into()],
        WindowSpec::Whole,
        DEFAULT_SIMILARITY,
    )
    .unwrap();
    let a = gp_draws(&model, 40, 11).unwrap();
    let b = gp_draws(&model, 40, 11).unwrap();
    let state = shipid_sim::State {
        u: 1.1,
        v: 0.05,
        r: -0.02,
        ..Default::default()
    };
    let at = |d: &dyn Dynamics| d.accelerations(&state, 0.2).unwrap();
    assert!(
        a.iter()
            .zip(&b)
            .all(|(x, y)| at(x.as_ref()) == at(y.as_ref())),
        "same seed, same draws"
    );
    assert!(
        a.windows(2).any(|w| at(w[0].as_ref()) != at(w[1].as_ref())),
        "the draws differ from each other"
    );
    let m = parse_manoeuvre("zigzag:10/10:port").unwrap();
    let bands = manoeuvre_bands(&model, &a, &m, &ds.ship, 0.9, BandRun::Standard).unwrap();
    assert_eq!(bands.replicates, 40);
    let overshoot = bands
        .metrics
        .iter()
        .find(|b| b.metric == "overshoot_1")
        .unwrap();
    let band = overshoot.band.as_ref().expect("40 draws give a band");
    let point = overshoot.point.unwrap();
    assert!(band.lo < band.hi, "the posterior has a spread: {band:?}");
    assert!(
        band.lo <= point && point <= band.hi,
        "mean {point} outside its band {band:?}"
    );
}
