//! The committed default data set `data/kvlcc2-mmg` is what `shipid generate` makes, and it holds what
//! the rest of the project relies on.

use crate::common;

use shipid_io::{Dataset, Manoeuvre};
use shipid_sim::metrics::zigzag_events;

fn embedded() -> Dataset {
    Dataset::load(&common::root().join("data/kvlcc2-mmg/dataset.toml")).unwrap()
}

#[test]
fn committed_data_equal_a_fresh_generation() {
    let ds = embedded();
    let fresh = shipid_pipeline::generate::generate(None).unwrap();
    assert_eq!(ds.recordings.len(), fresh.recordings.len());
    assert_eq!(ds.ship, fresh.dataset.ship);
    for (stored, new) in ds.recordings.iter().zip(&fresh.recordings) {
        assert_eq!(stored.recording.len(), new.len(), "{}", stored.file);
        let pairs = [
            (&stored.recording.psi, &new.psi),
            (&stored.recording.x0, &new.x0),
            (&stored.recording.y0, &new.y0),
            (&stored.recording.r, &new.r),
            (&stored.recording.delta, &new.delta),
        ];
        for (a, b) in pairs {
            let worst = a
                .iter()
                .zip(b.iter())
                .map(|(x, y)| (x - y).abs() / x.abs().max(1e-6))
                .fold(0.0, f64::max);
            assert!(
                worst < 1e-7,
                "{} differs from a fresh generation by {worst}: run `shipid generate --force`",
                stored.file
            );
        }
    }
}

#[test]
fn six_manoeuvres_at_10_hz_with_accelerations() {
    let ds = embedded();
    let files: Vec<&str> = ds.recordings.iter().map(|r| r.file.as_str()).collect();
    assert_eq!(
        files,
        [
            "zz10_10_ps.csv",
            "zz20_20_ps.csv",
            "zz35_35_ps.csv",
            "zz35_35_sb.csv",
            "tc35_ps.csv",
            "tc35_sb.csv"
        ]
    );
    for r in &ds.recordings {
        let dt = r.recording.t[1] - r.recording.t[0];
        assert!((dt - 0.1).abs() < 1e-9, "{} sampled at {dt} s", r.file);
        assert!(
            r.recording.accelerations.is_some(),
            "{} carries the model's accelerations",
            r.file
        );
    }
    assert!(ds.added_mass.is_some());
}

#[test]
fn zz35_port_holds_at_least_eight_overshoots() {
    let ds = embedded();
    for file in [
        "zz35_35_ps.csv",
        "zz35_35_sb.csv",
        "zz20_20_ps.csv",
        "zz10_10_ps.csv",
    ] {
        let r = ds.recording(file).unwrap();
        let Manoeuvre::ZigZag {
            rudder_deg,
            check_deg,
            side,
        } = r.manoeuvre
        else {
            panic!()
        };
        let ev = zigzag_events(&r.recording, rudder_deg, check_deg, side, &ds.ship).unwrap();
        assert!(
            ev.overshoots.len() >= 8,
            "{file}: {} overshoots",
            ev.overshoots.len()
        );
    }
}

#[test]
fn embedded_metrics_are_the_mmg_check_values() {
    // The MMG reference check values (Yasukawa & Yoshimura 2015), measured on the committed recordings by the one metrics code path.
    let ds = embedded();
    let m = |f: &str| {
        let r = ds.recording(f).unwrap();
        shipid_sim::metrics(&r.recording, &r.manoeuvre, &ds.ship)
    };
    let zz10 = m("zz10_10_ps.csv");
    assert!((zz10.overshoot_1.unwrap() - 7.0).abs() <= 0.3);
    assert!((zz10.overshoot_2.unwrap() - 8.8).abs() <= 0.3);
    let zz20 = m("zz20_20_ps.csv");
    assert!((zz20.overshoot_1.unwrap() - 13.7).abs() <= 0.3);
    assert!((zz20.overshoot_2.unwrap() - 11.7).abs() <= 0.3);
    for f in ["tc35_ps.csv", "tc35_sb.csv"] {
        let tc = m(f);
        assert!(
            (tc.advance.unwrap() - 3.08).abs() <= 0.05,
            "{f} advance {:?}",
            tc.advance
        );
        assert!(
            (tc.tactical_diameter.unwrap() - 3.1).abs() <= 0.05,
            "{f} tactical {:?}",
            tc.tactical_diameter
        );
        assert!(tc.steady_diameter.is_some());
    }
}

#[test]
fn noise_is_seeded_and_leaves_the_metrics_close() {
    let a = shipid_pipeline::generate::generate(Some(7)).unwrap();
    let b = shipid_pipeline::generate::generate(Some(7)).unwrap();
    let c = shipid_pipeline::generate::generate(Some(8)).unwrap();
    let clean = shipid_pipeline::generate::generate(None).unwrap();
    assert_eq!(
        a.recordings[0].psi, b.recordings[0].psi,
        "same seed, same noise"
    );
    assert_ne!(
        a.recordings[0].psi, c.recordings[0].psi,
        "other seed, other noise"
    );
    let ship = clean.dataset.ship;
    // Heading noise is 0.1°: its standard deviation is measured back within 10 %.
    let d: Vec<f64> = a.recordings[1]
        .psi
        .iter()
        .zip(&clean.recordings[1].psi)
        .map(|(x, y)| (x - y).to_degrees())
        .collect();
    let sd = (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt();
    assert!((sd - 0.1).abs() < 0.01, "heading noise sd {sd}");
    assert!(
        a.recordings[1].accelerations.is_none(),
        "noisy data carry no accelerations"
    );
    let m = shipid_io::Manoeuvre::ZigZag {
        rudder_deg: 20.0,
        check_deg: 20.0,
        side: shipid_io::Side::Port,
    };
    let noisy = shipid_sim::metrics(&a.recordings[1], &m, &ship)
        .overshoot_1
        .unwrap();
    let exact = shipid_sim::metrics(&clean.recordings[1], &m, &ship)
        .overshoot_1
        .unwrap();
    assert!(
        (noisy - exact).abs() < 0.3,
        "overshoot with noise {noisy} vs {exact}"
    );
}
