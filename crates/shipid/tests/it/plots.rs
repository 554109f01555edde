//! Figures of a study run: every SVG is written after the tables, is a non-trivial SVG document, a
//! diverged prediction is kept and labelled "diverged", and `shipid plot` redraws them from the
//! outputs alone.

use crate::common;

use std::path::Path;

use shipid::study_cmd::run_and_write;
use shipid_study::study::load_study;

const FIXTURES: &str = "crates/shipid/tests/fixtures/studies";

fn svg(path: &Path) -> String {
    let text = std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("{} not readable: {e}", path.display()));
    assert!(
        text.len() > 2_000,
        "{} is trivial ({} bytes)",
        path.display(),
        text.len()
    );
    let head = text.trim_start();
    assert!(
        head.starts_with("<svg") || head.starts_with("<?xml"),
        "{} does not start as SVG: {}",
        path.display(),
        &head[..head.len().min(80)]
    );
    assert!(
        text.trim_end().ends_with("</svg>"),
        "{} is not closed",
        path.display()
    );
    text
}

#[test]
fn a_study_run_writes_every_figure() {
    let dir = tempfile::tempdir().unwrap();
    let study = load_study(&common::root().join(FIXTURES).join("small.toml")).unwrap();
    let results = run_and_write(&study, dir.path(), 2, false, false)
        .unwrap()
        .0;
    let figures = dir.path().join("figures");
    // The force decomposition is drawn for the case with the smallest mean MRAE over its tests.
    let mean_mrae = |r: &shipid_study::runner::CaseResult| {
        r.tests.iter().filter_map(|t| t.mrae).sum::<f64>() / r.tests.len() as f64
    };
    let best = results
        .iter()
        .min_by(|a, b| mean_mrae(a).total_cmp(&mean_mrae(b)))
        .unwrap();
    assert!(
        figures
            .join(format!("forces_{}_zz35_35_ps.svg", best.case_id))
            .exists(),
        "forces figure of the best case {}",
        best.case_id
    );
    let mut expected = vec![
        "coefficient_convergence.svg".to_string(),
        "coefficients_reduced32.svg".into(),
        "vif_reduced32.svg".into(),
    ];
    for test in ["zz20_20_ps", "tc35_sb"] {
        expected.push(format!("trajectories_{test}.svg"));
        expected.push(format!("heading_{test}.svg"));
    }
    for name in &expected {
        svg(&figures.join(name));
    }
    let forces = forces_figure(&figures);
    assert!(forces.contains("target y_N"), "the N panel has its target");
    let track = svg(&figures.join("trajectories_zz20_20_ps.svg"));
    assert!(track.contains("y0 / L (east)"), "axis label with units");
    assert!(track.contains("recorded"), "legend of the recording");
    assert!(track.contains("3 OS"), "legend of a case window");
    assert!(
        !track.contains("diverged"),
        "no case of the small study diverges"
    );

    // `shipid plot` redraws them from the outputs (no refit): delete and regenerate.
    std::fs::remove_dir_all(&figures).unwrap();
    common::shipid_ok(&[
        "plot",
        &format!("{FIXTURES}/small.toml"),
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    for name in &expected {
        svg(&figures.join(name));
    }
    forces_figure(&figures);
}

/// The force-contribution figure (named after the chosen case and its first training recording).
fn forces_figure(figures: &Path) -> String {
    let found: Vec<_> = std::fs::read_dir(figures)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("forces_") && n.ends_with("_zz35_35_ps.svg"))
        })
        .collect();
    assert_eq!(found.len(), 1, "one forces figure: {found:?}");
    svg(&found[0])
}

#[test]
fn a_diverged_prediction_is_drawn_and_labelled() {
    let dir = tempfile::tempdir().unwrap();
    let study_path = common::root()
        .join(FIXTURES)
        .join("one_overshoot_diverges.toml");
    let study = load_study(&study_path).unwrap();
    let out = dir.path().join("out");
    let results = run_and_write(&study, &out, 2, false, false).unwrap().0;
    assert!(
        results[0]
            .tests
            .iter()
            .any(|t| t.status == shipid_study::runner::TestStatus::Diverged),
        "the fixture diverges"
    );
    let figures = out.join("figures");
    for name in ["trajectories_tc35_ps.svg", "heading_tc35_ps.svg"] {
        let text = svg(&figures.join(name));
        assert!(
            text.contains("diverged"),
            "{name}: the diverged prediction is labelled"
        );
    }
    // One overshoot count only: no convergence figure, but the others are there.
    assert!(!figures.join("coefficient_convergence.svg").exists());
    svg(&figures.join("coefficients_reduced32.svg"));
    svg(&figures.join("vif_reduced32.svg"));
}

/// Regression: the track and heading figures drew polynomial and sparse-GP cases only, so an mmg
/// case of a study was silently missing from them.
#[test]
fn an_mmg_case_is_drawn_beside_the_polynomial() {
    let dir = tempfile::tempdir().unwrap();
    let study = load_study(
        &common::root()
            .join(FIXTURES)
            .join("mmg_beside_reduced32.toml"),
    )
    .unwrap();
    run_and_write(&study, dir.path(), 2, false, false).unwrap();
    for figure in ["trajectories_zz10_10_ps.svg", "heading_zz10_10_ps.svg"] {
        let text = svg(&dir.path().join("figures").join(figure));
        for label in ["reduced32 bounded-lsq", "mmg bounded-lsq"] {
            assert!(text.contains(label), "{figure} lacks the case {label}");
        }
    }
}
