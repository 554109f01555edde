//! The propeller's inflow from a recorded thrust: the open-water curve inverted, the MMG wake model
//! fitted to what it measures, and the mmg fit holding it there on request.

use std::path::Path;

use shipid_io::Dataset;
use shipid_pipeline::mmg::thrust::{INFLOW_NAMES, advance_ratio};
use shipid_pipeline::mmg::{MmgFitOptions, MmgGeometry, fit_mmg};
use shipid_sim::{MmgModel, MmgParameters, State};

/// The default data (the MMG reference) with the reference's own thrust written into every
/// recording: T = X_P / (1 − t_P) at each sample's state, rudder and rate.
fn default_data_with_thrust() -> Dataset {
    let mut ds = Dataset::load(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/kvlcc2-mmg/dataset.toml"),
    )
    .unwrap();
    let model = MmgModel::kvlcc2();
    let t_p = MmgParameters::kvlcc2().t_p;
    for r in &mut ds.recordings {
        let rec = &r.recording;
        let n = rec.n.clone().unwrap();
        let thrust = (0..rec.len())
            .map(|i| {
                let f = model
                    .forces_at_rate(&State::of_recording(rec, i), rec.delta[i], n[i])
                    .unwrap();
                f.propeller_x / (1.0 - t_p)
            })
            .collect();
        r.recording.thrust = Some(thrust);
    }
    ds
}

fn check_advance_ratio(k_t: f64, expected: Option<f64>) {
    let curve = MmgGeometry::kvlcc2_model_scale().k_t;
    let j = advance_ratio(curve, k_t);
    match (j, expected) {
        (Some(j), Some(e)) => {
            assert!((j - e).abs() < 1e-12, "K_T {k_t}: J {j}, expected {e}");
            let back = curve[0] + curve[1] * j + curve[2] * j * j;
            assert!((back - k_t).abs() < 1e-12);
        }
        (j, e) => assert_eq!(j, e, "K_T {k_t}"),
    }
}

#[test]
fn the_open_water_curve_is_inverted_on_its_falling_branch() {
    check_advance_ratio(0.2931, Some(0.0));
    // K_T = 0.2931 − 0.2753 J − 0.1385 J² at J = 0.5.
    check_advance_ratio(0.2931 - 0.2753 * 0.5 - 0.1385 * 0.25, Some(0.5));
    // Above the bollard value, or a braking propeller: no advance ratio.
    check_advance_ratio(0.35, None);
    check_advance_ratio(0.0, None);
    check_advance_ratio(-5.0, None);
    check_advance_ratio(f64::NAN, None);
}

#[test]
fn the_recorded_thrust_recovers_the_reference_wake_and_is_held_on_request() {
    let ds = default_data_with_thrust();
    let reference = MmgParameters::kvlcc2();
    let truth = [
        reference.w_p0,
        reference.c1,
        reference.c2_pos,
        reference.c2_neg,
    ];
    let opts = MmgFitOptions {
        recordings: vec!["zz35_35_ps.csv".into()],
        ..MmgFitOptions::default()
    };
    let geometry = MmgGeometry::kvlcc2_model_scale();
    // Reported beside the fit's own values, or held there.
    for held in [false, true] {
        let fit = fit_mmg(
            &ds,
            &geometry,
            &MmgFitOptions {
                inflow_from_thrust: held,
                ..opts.clone()
            },
        )
        .unwrap();
        let inflow = fit.inflow.as_ref().unwrap();
        assert_eq!(inflow.held, held);
        for (k, name) in INFLOW_NAMES.iter().enumerate() {
            let measured = inflow.values[k];
            assert!(
                (measured - truth[k]).abs() < 1e-3 * truth[k].abs().max(1.0),
                "{name}: the thrust measures {measured}, the reference has {}",
                truth[k]
            );
            let p = fit
                .estimate
                .params
                .iter()
                .find(|p| p.spec.name == *name)
                .unwrap();
            if held {
                assert_eq!(p.value, measured, "{name} held");
                assert!(p.determined_by_data && p.spec.source.contains("recorded thrust"));
            }
        }
    }
}

#[test]
fn holding_the_inflow_without_a_recorded_thrust_is_bad_input() {
    let ds = Dataset::load(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/kvlcc2-mmg/dataset.toml"),
    )
    .unwrap();
    let opts = MmgFitOptions {
        recordings: vec!["zz35_35_ps.csv".into()],
        inflow_from_thrust: true,
        ..MmgFitOptions::default()
    };
    let err = fit_mmg(&ds, &MmgGeometry::kvlcc2_model_scale(), &opts)
        .err()
        .unwrap()
        .to_string();
    assert!(
        err.contains("no training window") && err.contains("thrust"),
        "{err}"
    );
}
