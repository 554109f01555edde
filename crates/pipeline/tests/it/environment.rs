//! The recorded environment as a known input (issue 27): a fit on runs that all carry a recorded wind
//! of varying direction recovers the calm model when the wind is an input, validation of a windy run
//! is exact with the wind and not without it, the identification targets are the model's own
//! hydrodynamics, and the refinement's forward sensitivities hold in a wind and a current.

use shipid_estimators::Solver;
use shipid_io::{Dataset, FlowSeries, Manoeuvre, Recording, Side};
use shipid_pipeline::environment::{
    ChosenWindage, WindageSource, hydrodynamic_recording, recording_environment,
};
use shipid_pipeline::fit::{EstimatorSpec, WindowSpec, fit_dataset, load_set};
use shipid_pipeline::generate::{
    T_EXECUTE_S, default_manoeuvres, generate_manoeuvres, standard_duration_s,
};
use shipid_pipeline::replay::{replay_segment_in, replay_segment_sensitivities_in, segments};
use shipid_pipeline::validate::validate_recording_with;
use shipid_sim::environment::assumed_windage;
use shipid_sim::{
    AbkowitzDynamics, Dynamics, KnownEnvironment, MmgModel, SimOptions, State, WithEnvironment,
    controller_for,
};

/// Wind speed of the test recordings [m/s]: some 4 U0 of the KVLCC2 model, its side force about 1 %
/// of ½ρ L d U0².
const WIND_M_S: f64 = 5.0;

/// A wind of `WIND_M_S` whose direction turns a full circle every 200 s from `from0_deg`: every run is
/// windy, from every side in turn.
fn veering_wind(t: &[f64], from0_deg: f64) -> FlowSeries {
    FlowSeries {
        speed_m_s: vec![WIND_M_S; t.len()],
        from_rad: t
            .iter()
            .map(|t| (from0_deg + 360.0 * t / 200.0).to_radians())
            .collect(),
    }
}

/// `calm` (a generated data set of the MMG reference) with every run simulated again by the
/// reference in a recorded wind (`veering_wind`, each run from another start) and, when given, a
/// current, the channels written into the recordings; `[windage]` the assumed one.
fn windy(calm: &Dataset, current: Option<(f64, f64)>) -> Dataset {
    let model = MmgModel::kvlcc2();
    let ship = *model.ship();
    let windage = assumed_windage(&ship);
    let mut ds = calm.clone();
    ds.windage = Some(windage.clone());
    for (k, r) in ds.recordings.iter_mut().enumerate() {
        let duration = standard_duration_s(&r.manoeuvre, &ship);
        let t: Vec<f64> = (0..=(duration / 0.1).round() as usize)
            .map(|i| i as f64 * 0.1)
            .collect();
        let template = Recording {
            wind: Some(veering_wind(&t, 70.0 * k as f64)),
            current: current.map(|(speed, from_deg)| FlowSeries {
                speed_m_s: vec![speed; t.len()],
                from_rad: vec![from_deg.to_radians(); t.len()],
            }),
            t: t.clone(),
            ..Recording::default()
        };
        let env = KnownEnvironment::of_recording(&template, Some(&windage), &ship)
            .unwrap()
            .unwrap();
        let sim = WithEnvironment::new(&model, env);
        let mut ctrl = controller_for(&r.manoeuvre, T_EXECUTE_S).unwrap();
        let out = shipid_sim::simulate(
            &sim,
            ctrl.as_mut(),
            sim.over_ground(&State::approach(ship.u0)),
            &SimOptions::new(duration).with_step(0.05, 0.1),
        )
        .unwrap();
        let mut rec = out.recording;
        let n = rec.len();
        rec.wind = template.wind.map(|w| w.slice(0..n));
        rec.current = template.current.map(|c| c.slice(0..n));
        r.recording = rec;
    }
    ds
}

/// The recordings of `ds` without their recorded wind and current: what a fit that ignores them sees.
fn concealed(ds: &Dataset) -> Dataset {
    let mut out = ds.clone();
    for r in &mut out.recordings {
        r.recording.wind = None;
        r.recording.current = None;
    }
    out
}

fn calm_training() -> Dataset {
    let m = default_manoeuvres();
    generate_manoeuvres(None, &[], &m)
        .unwrap()
        .in_memory(&m, "calm-training")
}

/// Calm runs none of the fits saw.
fn calm_held_out() -> Dataset {
    let m = vec![
        Manoeuvre::ZigZag {
            rudder_deg: 15.0,
            check_deg: 15.0,
            side: Side::Starboard,
        },
        Manoeuvre::Turning {
            rudder_deg: 25.0,
            side: Side::Port,
        },
    ];
    generate_manoeuvres(None, &[], &m)
        .unwrap()
        .in_memory(&m, "calm-held-out")
}

/// Mean position error ÷ L at the end of segment replays of 10 L/U0 (as the diagnosis and the
/// refinement score a model) of `model` on the calm runs of `ds`: whole-run open-loop replays of a
/// polynomial drift too far to compare models by.
fn held_out_error(model: &dyn Dynamics, ds: &Dataset) -> f64 {
    let horizon_s = 10.0 * ds.ship.lpp / ds.ship.u0;
    let mut errors = Vec::new();
    for r in &ds.recordings {
        let rec = &r.recording;
        for (a, b) in segments(rec, horizon_s) {
            let (sim, _) = replay_segment_in(model, None, rec, a, b);
            let k = sim.len().min(b - a).saturating_sub(1);
            let i = a + k;
            errors.push((sim.x0[k] - rec.x0[i]).hypot(sim.y0[k] - rec.y0[i]) / ds.ship.lpp);
        }
    }
    errors.iter().sum::<f64>() / errors.len() as f64
}

fn lsq_full74(ds: &Dataset) -> AbkowitzDynamics {
    let out = fit_dataset(
        ds,
        load_set("full74").unwrap(),
        &EstimatorSpec::named("lsq"),
        &[],
        WindowSpec::Whole,
        Solver::Fast,
    )
    .unwrap();
    AbkowitzDynamics(out.model)
}

/// Identified from runs that all carry a veering wind, with the wind as a known input, the
/// polynomial predicts calm held-out runs as the one identified from the same manoeuvres in calm air
/// does; identified with the wind concealed, it absorbs the wind and predicts them worse.
#[test]
fn a_fit_on_windy_runs_with_the_wind_as_input_recovers_the_calm_model() {
    let calm = calm_training();
    let windy = windy(&calm, None);
    let test = calm_held_out();
    let calm_error = held_out_error(&lsq_full74(&calm), &test);
    let with_wind = held_out_error(&lsq_full74(&windy), &test);
    let without_wind = held_out_error(&lsq_full74(&concealed(&windy)), &test);
    assert!(
        (with_wind - calm_error).abs() < 0.25 * calm_error,
        "with the wind {with_wind:.4e} L, calm-trained {calm_error:.4e} L"
    );
    assert!(
        without_wind > 2.0 * with_wind,
        "without the wind {without_wind:.4e} L against {with_wind:.4e} L with it"
    );
}

/// The exact model replays a windy run (in a current too) to integration accuracy with the recorded
/// wind and current as inputs; replayed in calm water it misses by far more.
#[test]
fn validation_of_a_windy_run_is_exact_with_the_wind_and_not_without() {
    let calm = calm_training();
    let windy = windy(&calm, Some((0.05, 120.0)));
    let model = MmgModel::kvlcc2();
    let windage = ChosenWindage::of_dataset(&windy);
    assert_eq!(windage.source, WindageSource::Dataset);
    for (r, c) in windy.recordings.iter().zip(&calm.recordings) {
        // The floor: the exact model's open-loop replay of the same manoeuvre in calm water (the
        // recorded rudder between samples, a whole run of zig-zag reversals).
        let floor = validate_recording_with(&model, c, &calm.ship, &windage)
            .replay
            .position_rmse_over_l;
        let with = validate_recording_with(&model, r, &windy.ship, &windage);
        let mut bare = r.clone();
        bare.recording.wind = None;
        bare.recording.current = None;
        let without = validate_recording_with(&model, &bare, &windy.ship, &windage);
        let (w, wo) = (
            with.replay.position_rmse_over_l,
            without.replay.position_rmse_over_l,
        );
        assert!(
            w < 1.5 * floor + 1e-4,
            "{}: {w:e} L with the wind, calm floor {floor:e} L",
            r.file
        );
        assert!(wo > 5.0 * w, "{}: {wo:e} L without, {w:e} L with", r.file);
    }
}

/// The largest difference between the accelerations left after removing the recorded environment of
/// run `k` of `ds` (a run of the reference) and the reference's own at the water-relative states, and
/// the reference's largest, per DOF.
fn target_error(ds: &Dataset, k: usize) -> ([f64; 3], [f64; 3]) {
    let model = MmgModel::kvlcc2();
    let hydro = hydrodynamic_recording(ds, &ds.recordings[k], &ds.added_mass.unwrap()).unwrap();
    let (mut worst, mut scale) = ([0.0_f64; 3], [0.0_f64; 3]);
    // An estimating differentiator is one-sided at the ends: compare inside.
    for i in (50..hydro.recording.len() - 50).step_by(7) {
        let s = State::of_recording(&hydro.recording, i);
        let a = model.accelerations(&s, hydro.recording.delta[i]).unwrap();
        let got = [
            hydro.accelerations.u_dot[i],
            hydro.accelerations.v_dot[i],
            hydro.accelerations.r_dot[i],
        ];
        for d in 0..3 {
            worst[d] = worst[d].max((a[d] - got[d]).abs());
            scale[d] = scale[d].max(a[d].abs());
        }
    }
    (worst, scale)
}

/// What every family identifies from is the model's own hydrodynamics: on a run of the reference in
/// a recorded wind, the recorded accelerations minus the wind's M⁻¹ F are the reference's to rounding;
/// in a current too (the velocities through the water, their accelerations estimated) to the
/// differentiator's accuracy.
#[test]
fn the_identification_targets_are_the_hydrodynamics_without_the_environment() {
    let calm = calm_training();
    let (worst, scale) = target_error(&windy(&calm, None), 1);
    (0..3).for_each(|d| {
        assert!(
            worst[d] < 1e-9 * scale[d],
            "wind, DOF {d}: {worst:?} {scale:?}"
        )
    });
    // The floor: the differentiator's own error on the calm run without recorded accelerations.
    let mut estimated = calm.clone();
    estimated.recordings[1].recording.accelerations = None;
    let (floor, _) = target_error(&estimated, 1);
    let (worst, scale) = target_error(&windy(&calm, Some((0.05, 120.0))), 1);
    (0..3).for_each(|d| {
        assert!(
            worst[d] < 1.5 * floor[d] + 1e-3 * scale[d],
            "current, DOF {d}: {worst:?}, differentiator {floor:?}"
        )
    });
    // A calm recording is what it was.
    let (env, warning) = recording_environment(&calm, &calm.recordings[0].recording).unwrap();
    assert!(env.is_none() && warning.is_none());
}

/// Regression guard for the refinement in a recorded environment: the sensitivity replay follows the
/// replay that feels the wind and current, and its derivatives are central differences of it.
#[test]
fn segment_sensitivities_in_a_wind_and_current_are_the_derivatives_of_the_replay() {
    let calm = calm_training();
    let windy = windy(&calm, Some((0.05, 120.0)));
    let model = lsq_full74(&windy);
    let rec = &windy.recordings[3].recording;
    let env = KnownEnvironment::of_recording(rec, windy.windage.as_ref(), &windy.ship)
        .unwrap()
        .unwrap();
    let theta = shipid_sim::dynamics::Parametric::parameters(&model);
    let horizon_s = 10.0 * windy.ship.lpp / windy.ship.u0;
    let (a, b) = segments(rec, horizon_s)[2];
    let directions: Vec<(usize, f64)> = [1, theta.len() / 2, theta.len() - 2]
        .iter()
        .map(|&j| (j, 0.01 * theta[j].abs().max(1e-2)))
        .collect();
    let (plain, completed) = replay_segment_in(&model, Some(&env), rec, a, b);
    assert!(completed);
    let sens = replay_segment_sensitivities_in(&model, Some(&env), rec, a, b, &directions);
    assert!(sens.completed);
    for (k, pose) in sens.pose.iter().enumerate() {
        let replayed = [plain.x0[k], plain.y0[k], plain.psi[k]];
        (0..3).for_each(|axis| assert!((pose[axis] - replayed[axis]).abs() < 1e-9, "step {k}"));
    }
    let h = 1e-3;
    for (j, &(index, unit)) in directions.iter().enumerate() {
        let shifted = |sign: f64| {
            let mut q = theta.clone();
            q[index] += sign * h * unit;
            let m = shipid_sim::dynamics::Parametric::with_parameters(&model, &q).unwrap();
            replay_segment_in(&m, Some(&env), rec, a, b).0
        };
        let (plus, minus) = (shifted(1.0), shifted(-1.0));
        for axis in 0..3 {
            let pick = |r: &Recording, k: usize| [r.x0[k], r.y0[k], r.psi[k]][axis];
            let fd: Vec<f64> = (0..plus.len())
                .map(|k| (pick(&plus, k) - pick(&minus, k)) / (2.0 * h))
                .collect();
            let scale = fd.iter().fold(0.0_f64, |m, d| m.max(d.abs()));
            let worst = fd
                .iter()
                .zip(&sens.pose_sensitivity)
                .fold(0.0_f64, |m, (d, s)| m.max((d - s[3 * j + axis]).abs()));
            assert!(
                worst <= 1e-4 * scale + 1e-12,
                "coefficient {index}, axis {axis}: {worst:e} against {scale:e}"
            );
        }
    }
}

/// A recording whose current columns are zero throughout is a recorded calm, and the note says so
/// rather than that the run "carries a recorded current"; a real current is still named.
#[test]
fn a_current_recorded_as_zero_is_noted_as_a_recorded_calm() {
    let check = |speed_m_s: f64, expected: &str| {
        let mut ds = calm_training();
        ds.recordings.truncate(1);
        let n = ds.recordings[0].recording.len();
        ds.recordings[0].recording.current = Some(FlowSeries {
            speed_m_s: vec![speed_m_s; n],
            from_rad: vec![0.0; n],
        });
        let chosen = ChosenWindage::of_dataset(&ds);
        let notes = shipid_pipeline::environment::environment_notes(
            &ds,
            &ds.recordings,
            &chosen,
            "the fit",
        );
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert!(notes[0].contains(expected), "{}", notes[0]);
    };
    check(0.0, "a recorded calm (current zero throughout)");
    check(0.1, "carries a recorded current;");
}
