//! The output-error refinement's derivatives: the analytic ones of the Abkowitz model against finite
//! differences, the forward-sensitivity replay against finite differences of the replay it
//! differentiates, and the refinement with finite-difference model derivatives (the fallback a
//! model without analytic ones gets) against the analytic refinement.

use std::path::Path;

use shipid_estimators::Solver;
use shipid_io::{AddedMass, Dataset, Recording, Ship};
use shipid_model::AbkowitzModel;
use shipid_pipeline::fit::{EstimatorSpec, WindowSpec, fit_dataset, load_set};
use shipid_pipeline::refine::{RefineOptions, refine, refinement_cost, theta_at};
use shipid_pipeline::replay::{replay_segment, replay_segment_sensitivities, segments};
use shipid_sim::AbkowitzDynamics;
use shipid_sim::dynamics::{Dynamics, DynamicsError, FiniteDifferences, Input, Parametric, State};

fn embedded() -> Dataset {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    Dataset::load(&root.join("data/kvlcc2-mmg/dataset.toml")).unwrap()
}

/// The LSQ model of `set` on ZZ35/35 PS cut after 4 overshoots, and that training window.
fn lsq_on_zz35(ds: &Dataset, set: &str) -> (AbkowitzModel, Recording) {
    let out = fit_dataset(
        ds,
        load_set(set).unwrap(),
        &EstimatorSpec::named("lsq"),
        &["zz35_35_ps.csv".to_string()],
        WindowSpec::Overshoots(4),
        Solver::Fast,
    )
    .unwrap();
    let w = &out.file.training[0];
    let r = &ds.recording("zz35_35_ps.csv").unwrap().recording;
    let lo = r.t.partition_point(|&t| t < w.t_start_s);
    let hi = r.t.partition_point(|&t| t <= w.t_end_s);
    (out.model, r.slice(lo..hi))
}

/// The Abkowitz model with the trait's default derivatives (finite differences): what a model family
/// without analytic derivatives gets.
#[derive(Debug, Clone)]
struct NoAnalyticDerivatives(AbkowitzDynamics);

impl Dynamics for NoAnalyticDerivatives {
    fn accelerations_for(&self, s: &State, input: &Input) -> Result<[f64; 3], DynamicsError> {
        self.0.accelerations_for(s, input)
    }
    fn ship(&self) -> &Ship {
        self.0.ship()
    }
    fn added_mass(&self) -> &AddedMass {
        self.0.added_mass()
    }
}

impl Parametric for NoAnalyticDerivatives {
    fn parameters(&self) -> Vec<f64> {
        self.0.parameters()
    }
    fn with_parameters(&self, theta: &[f64]) -> Option<Self> {
        self.0.with_parameters(theta).map(NoAnalyticDerivatives)
    }
    fn parameter_units(&self, states: &[(State, f64)]) -> Vec<Option<f64>> {
        self.0.parameter_units(states)
    }
}

/// Largest |analytic − finite difference| relative to the largest derivative of its kind.
fn check_model_derivatives(model: &AbkowitzModel, state: State, delta: f64, tolerance: f64) {
    let k = model.coefficient_total();
    let analytic = AbkowitzDynamics(model.clone());
    let fd = NoAnalyticDerivatives(analytic.clone());
    let (mut ds_a, mut ds_f) = ([[0.0; 3]; 3], [[0.0; 3]; 3]);
    let (mut dt_a, mut dt_f) = (vec![[0.0; 3]; k], vec![[0.0; 3]; k]);
    let a = analytic
        .sensitivities(&state, delta, &mut ds_a, &mut dt_a)
        .unwrap();
    let f = fd
        .sensitivities(&state, delta, &mut ds_f, &mut dt_f)
        .unwrap();
    assert_eq!(a, model.accelerations(state.u, state.v, state.r, delta));
    assert_eq!(a, f);
    let worst = |x: &[[f64; 3]], y: &[[f64; 3]]| {
        let scale = x.iter().flatten().fold(0.0_f64, |m, v| m.max(v.abs()));
        let diff = x
            .iter()
            .flatten()
            .zip(y.iter().flatten())
            .fold(0.0_f64, |m, (p, q)| m.max((p - q).abs()));
        diff / scale
    };
    // Each DOF's rows separately: ṙ is orders of magnitude smaller than u̇ in SI.
    for i in 0..3 {
        let row = |m: &[[f64; 3]; 3]| [m[i]];
        let e = worst(&row(&ds_a), &row(&ds_f));
        assert!(
            e < tolerance,
            "∂a_{i}/∂x: relative error {e:e} at {state:?}"
        );
        let col = |m: &[[f64; 3]]| m.iter().map(|c| [c[i], 0.0, 0.0]).collect::<Vec<_>>();
        let e = worst(&col(&dt_a), &col(&dt_f));
        assert!(
            e < tolerance,
            "∂a_{i}/∂θ: relative error {e:e} at {state:?}"
        );
    }
}

/// ∂a/∂(u, v, r) and ∂a/∂θ of the Abkowitz model, analytic, against central differences at recorded
/// states of a zig-zag and of a turn (rudder over, large drift), for the smallest and the largest set.
#[test]
fn abkowitz_derivatives_match_finite_differences() {
    let ds = embedded();
    for set in ["reduced32", "full74"] {
        let (model, _) = lsq_on_zz35(&ds, set);
        for (file, t_s) in [("zz35_35_ps.csv", 40.0), ("tc35_sb.csv", 150.0)] {
            let rec = &ds.recording(file).unwrap().recording;
            let i = rec.t.partition_point(|&t| t < t_s);
            check_model_derivatives(&model, State::of_recording(rec, i), rec.delta[i], 1e-6);
        }
    }
}

/// The forward sensitivities of a segment replay are the derivatives of the discretised replay:
/// central differences of `replay_segment` over a few coefficients of each DOF agree at every compared
/// sample, and the sensitivity replay's own trajectory is `replay_segment`'s.
#[test]
fn segment_sensitivities_are_the_derivatives_of_the_replay() {
    let ds = embedded();
    let (model, rec) = lsq_on_zz35(&ds, "full74");
    let base = AbkowitzDynamics(model);
    let theta = base.parameters();
    let horizon_s = 10.0 * base.ship().lpp / base.ship().u0;
    // Two segments: the first (rudder to port) and one across a rudder reversal.
    let segs = segments(&rec, horizon_s);
    for &(a, b) in [segs[0], segs[2]].iter() {
        let (plain, completed) = replay_segment(&base, &rec, a, b);
        assert!(completed);
        // Units of about 1 % of each coefficient's size (or 1e-4 when it is near zero).
        let k = theta.len();
        let directions: Vec<(usize, f64)> = [0, 3, k / 3, k / 2, 2 * k / 3, k - 1]
            .iter()
            .map(|&j| (j, 0.01 * theta[j].abs().max(1e-2)))
            .collect();
        let sens = replay_segment_sensitivities(&base, &rec, a, b, &directions);
        assert!(sens.completed);
        assert_eq!(sens.t, plain.t);
        for (k, pose) in sens.pose.iter().enumerate() {
            let replayed = [plain.x0[k], plain.y0[k], plain.psi[k]];
            for axis in 0..3 {
                assert!((pose[axis] - replayed[axis]).abs() < 1e-9, "step {k}");
            }
        }
        let h = 1e-3;
        for (j, &(index, unit)) in directions.iter().enumerate() {
            let shifted = |sign: f64| {
                let mut q = theta.clone();
                q[index] += sign * h * unit;
                replay_segment(&base.with_parameters(&q).unwrap(), &rec, a, b).0
            };
            let (plus, minus) = (shifted(1.0), shifted(-1.0));
            let fd: Vec<[f64; 3]> = (0..plus.len())
                .map(|k| {
                    [
                        (plus.x0[k] - minus.x0[k]) / (2.0 * h),
                        (plus.y0[k] - minus.y0[k]) / (2.0 * h),
                        (plus.psi[k] - minus.psi[k]) / (2.0 * h),
                    ]
                })
                .collect();
            for axis in 0..3 {
                let scale = fd.iter().fold(0.0_f64, |m, d| m.max(d[axis].abs()));
                let worst = fd
                    .iter()
                    .zip(&sens.pose_sensitivity)
                    .fold(0.0_f64, |m, (d, s)| {
                        m.max((d[axis] - s[3 * j + axis]).abs())
                    });
                assert!(
                    worst <= 1e-5 * scale + 1e-12,
                    "coefficient {index}, axis {axis}: {worst:e} against {scale:e}"
                );
            }
        }
    }
}

/// The refinement with the trait's finite-difference model derivatives (the fallback of a model
/// family without analytic ones) takes the analytic refinement's path: the same training cost and
/// replay RMSEs to 1e-6 relative after three iterations, and `refinement_cost` reproduces the cost
/// the refinement reports.
#[test]
fn refinement_with_finite_difference_derivatives_matches_the_analytic_one() {
    let ds = embedded();
    let (model, rec) = lsq_on_zz35(&ds, "reduced32");
    let recs = [rec];
    let opts = RefineOptions {
        max_iterations: 3,
        ..RefineOptions::default()
    };
    let start = AbkowitzDynamics(model);
    let analytic = refine(&start, &recs, &opts).unwrap();
    let fd = refine(&NoAnalyticDerivatives(start.clone()), &recs, &opts).unwrap();
    assert!(
        analytic.cost_after < 0.9 * analytic.cost_before,
        "{analytic:?}"
    );
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * a.abs().max(b.abs());
    assert!(
        close(analytic.cost_after, fd.cost_after),
        "{} vs {}",
        analytic.cost_after,
        fd.cost_after
    );
    let (x, y) = (&analytic.refinement, &fd.refinement);
    assert_eq!(x.iterations, y.iterations);
    assert!(close(
        x.after_position_rmse_over_l,
        y.after_position_rmse_over_l
    ));
    assert!(close(x.after_heading_rmse_deg, y.after_heading_rmse_deg));
    let recomputed = refinement_cost(&start, &analytic.model, &recs, &opts).unwrap();
    assert!(
        close(recomputed, analytic.cost_after),
        "{recomputed} vs {}",
        analytic.cost_after
    );
}

/// A model that refuses any coefficient above its current value for the first one (as a physical
/// family refuses a parameter past its bound).
#[derive(Debug, Clone)]
struct AtUpperBound(AbkowitzDynamics, f64);

impl Dynamics for AtUpperBound {
    fn accelerations_for(&self, s: &State, input: &Input) -> Result<[f64; 3], DynamicsError> {
        self.0.accelerations_for(s, input)
    }
    fn ship(&self) -> &Ship {
        self.0.ship()
    }
    fn added_mass(&self) -> &AddedMass {
        self.0.added_mass()
    }
}

impl Parametric for AtUpperBound {
    fn parameters(&self) -> Vec<f64> {
        self.0.parameters()
    }
    fn with_parameters(&self, theta: &[f64]) -> Option<Self> {
        (theta[0] <= self.1)
            .then(|| {
                self.0
                    .with_parameters(theta)
                    .map(|m| AtUpperBound(m, self.1))
            })
            .flatten()
    }
}

/// At a parameter's bound the finite differences step backwards instead of losing the derivative
/// (or the whole stage): ∂a/∂θ_0 still matches the analytic one.
#[test]
fn finite_differences_step_backwards_at_a_refused_bound() {
    let ds = embedded();
    let (model, rec) = lsq_on_zz35(&ds, "reduced32");
    let analytic = AbkowitzDynamics(model);
    let bounded = AtUpperBound(analytic.clone(), analytic.parameters()[0]);
    let k = analytic.parameters().len();
    let i = rec.len() / 2;
    let (state, delta) = (State::of_recording(&rec, i), rec.delta[i]);
    let (mut ds_a, mut ds_f) = ([[0.0; 3]; 3], [[0.0; 3]; 3]);
    let (mut dt_a, mut dt_f) = (vec![[0.0; 3]; k], vec![[0.0; 3]; k]);
    analytic
        .sensitivities(&state, delta, &mut ds_a, &mut dt_a)
        .unwrap();
    FiniteDifferences::new(&bounded, 0..k)
        .sensitivities(&state, delta, &mut ds_f, &mut dt_f)
        .unwrap();
    assert!(dt_a[0][0] != 0.0);
    assert!(
        (dt_a[0][0] - dt_f[0][0]).abs() < 1e-6 * dt_a[0][0].abs(),
        "{:?} vs {:?}",
        dt_a[0],
        dt_f[0]
    );
}

/// Regression (an mmg fit with `--refine` wrote N'_vvv = 0.3350000000000001 beside its bound 0.335,
/// and the model file was refused when read): from N'_vvv = −0.0888… a step projected onto the bound
/// in the refinement's units came back to θ one rounding past it, whatever the unit.
#[test]
fn a_parameter_refined_onto_its_bound_stays_within_it() {
    let check = |theta0: f64, bounds: (f64, f64), unit: f64| {
        let p = (bounds.1 - theta0) / unit;
        let theta = theta_at(&[theta0], &[(0, unit)], &[p], &[bounds])[0];
        assert!(
            bounds.0 <= theta && theta <= bounds.1,
            "{theta0} + {p} × {unit} = {theta:e} outside {bounds:?}"
        );
    };
    for unit in [1e-3, 0.0123, 0.1, 0.7, 3.3] {
        check(-0.08882716337798482, (f64::NEG_INFINITY, 0.335), unit);
    }
}
