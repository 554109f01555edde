//! Tester's findings A2 (stale figures), A7 (figure names colliding) and A9 (cases dropped silently).

use std::path::{Path, PathBuf};

use shipid_figures::write_figures;
use shipid_study::tables::write_tables;
use shipid_study::{Study, load_study, run_study};

/// A one-case-per-set study in a fresh folder, run into `<dir>/out`.
fn run(sets: &[&str], set_files: &[&str]) -> (tempfile::TempDir, Study, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../model/sets/reduced32.toml");
    for f in set_files {
        let to = dir.path().join(f);
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::copy(&shipped, to).unwrap();
    }
    let dataset = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/kvlcc2-mmg/dataset.toml");
    let path = dir.path().join("study.toml");
    std::fs::write(
        &path,
        format!(
            "name = \"figs\"\ndataset = {:?}\nsets = {sets:?}\n[training]\n\
             recordings = [[\"zz35_35_ps.csv\"]]\novershoots = [4]\n[[estimator]]\nname = \"lsq\"\n\
             [test]\nrecordings = [\"zz20_20_ps.csv\"]\n",
            dataset.display().to_string()
        ),
    )
    .unwrap();
    let study = load_study(&path).unwrap();
    let out = dir.path().join("out");
    let results = run_study(&study, &out, 1, false, false).unwrap();
    write_tables(&study, &results, &out).unwrap();
    (dir, study, out)
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn sets_whose_names_sanitise_alike_get_figures_of_their_own() {
    let (_dir, study, out) = run(&["a/b.toml", "a_b.toml"], &["a/b.toml", "a_b.toml"]);
    let report = write_figures(&study, &out);
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    let coefficient_figures: Vec<String> = names(&out.join("figures"))
        .into_iter()
        .filter(|n| n.starts_with("coefficients_"))
        .collect();
    assert_eq!(coefficient_figures.len(), 2, "{coefficient_figures:?}");
    // A name that is already safe keeps its plain file name.
    assert!(names(&out.join("figures")).contains(&"trajectories_zz20_20_ps.svg".to_string()));
}

#[test]
fn figures_of_an_earlier_run_are_removed_and_the_users_files_kept() {
    let (_dir, study, out) = run(&["reduced32"], &[]);
    let figures = out.join("figures");
    std::fs::create_dir_all(&figures).unwrap();
    // Drawn by a run with bands and by another study, as that run recorded them; beside them the
    // user's own files, some named like shipid's figures.
    let stale = [
        "bands_zz20_20_ps.svg",
        "coefficients_full74.svg",
        "forces_old_case_tc35_ps.svg",
    ];
    for name in stale {
        std::fs::write(figures.join(name), "<svg/>").unwrap();
    }
    std::fs::write(
        figures.join(shipid_figures::study::FIGURE_RECORD),
        format!("{}\n../../victim.svg\nnotes.txt\n", stale.join("\n")),
    )
    .unwrap();
    let own = [
        "my_sketch.svg",
        "notes.txt",
        "trajectories_my_hand_drawn.svg",
        "bands_notes.svg",
    ];
    for name in own {
        std::fs::write(figures.join(name), "mine").unwrap();
    }
    std::fs::write(out.join("victim.svg"), "mine").unwrap();
    let report = write_figures(&study, &out);
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    assert_eq!(report.removed.len(), 3, "{:?}", report.removed);
    let left = names(&figures);
    for name in stale {
        assert!(!left.contains(&name.to_string()), "{left:?}");
    }
    for name in own {
        assert!(left.contains(&name.to_string()), "{name}: {left:?}");
    }
    assert!(out.join("victim.svg").is_file());
    assert!(
        left.contains(&"coefficients_reduced32.svg".into()),
        "{left:?}"
    );
}

/// Regression: a resume run deleted the user's `figures/trajectories_my_hand_drawn.svg` and
/// `figures/bands_notes.svg`, whose names begin as shipid's figures do, though no run drew them.
#[test]
fn the_users_svg_files_named_like_figures_survive_every_run() {
    let (_dir, study, out) = run(&["reduced32"], &[]);
    let first = write_figures(&study, &out);
    assert!(first.warnings.is_empty(), "{:?}", first.warnings);
    let figures = out.join("figures");
    for name in ["trajectories_my_hand_drawn.svg", "bands_notes.svg"] {
        std::fs::write(figures.join(name), "mine").unwrap();
    }
    let again = write_figures(&study, &out);
    assert!(again.removed.is_empty(), "{:?}", again.removed);
    for name in ["trajectories_my_hand_drawn.svg", "bands_notes.svg"] {
        assert_eq!(std::fs::read_to_string(figures.join(name)).unwrap(), "mine");
    }
}

#[test]
fn a_case_without_its_model_or_with_a_corrupt_result_is_named_in_the_warnings() {
    let (_dir, study, out) = run(&["reduced32", "full68"], &[]);
    let (a, b) = (&study.cases[0].id, &study.cases[1].id);
    std::fs::remove_file(out.join("cases").join(a).join("model.toml")).unwrap();
    std::fs::write(out.join("cases").join(b).join("result.json"), "{ not json").unwrap();
    let report = write_figures(&study, &out);
    assert_eq!(report.warnings.len(), 2, "{:?}", report.warnings);
    assert!(report.warnings[0].contains(a.as_str()) && report.warnings[0].contains("model.toml"));
    assert!(report.warnings[1].contains(b.as_str()) && report.warnings[1].contains("result.json"));
}

/// A reduced32 study with lsq and bounded-lsq (the same model here: no bound is active), trained
/// on ZZ35 4 OS and tested on ZZ20, run into `<dir>/out` and its figures drawn.
fn run_two_estimators() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let dataset = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/kvlcc2-mmg/dataset.toml");
    let path = dir.path().join("study.toml");
    std::fs::write(
        &path,
        format!(
            "name = \"figs\"\ndataset = {:?}\nsets = [\"reduced32\"]\n[training]\n\
             recordings = [[\"zz35_35_ps.csv\"]]\novershoots = [4]\n[[estimator]]\nname = \"lsq\"\n\
             [[estimator]]\nname = \"bounded-lsq\"\n[test]\nrecordings = [\"zz20_20_ps.csv\"]\n",
            dataset.display().to_string()
        ),
    )
    .unwrap();
    let study = load_study(&path).unwrap();
    let out = dir.path().join("out");
    let results = run_study(&study, &out, 1, false, false).unwrap();
    write_tables(&study, &results, &out).unwrap();
    let report = write_figures(&study, &out);
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    (dir, out)
}

/// The `<polyline>`s of an SVG as (stroke, number of points), in drawing order.
fn polylines(svg: &str) -> Vec<(String, usize)> {
    svg.split("<polyline ")
        .skip(1)
        .map(|p| {
            let attr = |k: &str| {
                p.split(&format!("{k}=\""))
                    .nth(1)
                    .map(|s| s[..s.find('"').unwrap()].to_string())
                    .unwrap_or_default()
            };
            (attr("stroke"), attr("points").split_whitespace().count())
        })
        .collect()
}

/// Regression (visual review §3): the recorded track was the first series in the SVG and every
/// prediction was painted over it, so in the gp study's figures the reference had disappeared.
#[test]
fn the_recorded_series_is_the_last_polyline_of_each_time_series_figure() {
    let (_dir, out) = run_two_estimators();
    for name in ["trajectories_zz20_20_ps.svg", "heading_zz20_20_ps.svg"] {
        let svg = std::fs::read_to_string(out.join("figures").join(name)).unwrap();
        // Data series have many points; the mesh, ticks and legend samples have two.
        let series: Vec<(String, usize)> = polylines(&svg)
            .into_iter()
            .filter(|(_, n)| *n > 20)
            .collect();
        assert!(series.len() >= 3, "{name}: {series:?}");
        // In the heading figure each of the two panels ends with its recorded series.
        let last = series.last().unwrap();
        assert_eq!(
            last.0, "#000000",
            "{name}: the last series is not the recorded one"
        );
        if name.starts_with("heading") {
            let blacks = series.iter().filter(|(s, _)| s == "#000000").count();
            assert_eq!(blacks, 2, "{name}: one recorded line per panel");
            let first_black = series.iter().position(|(s, _)| s == "#000000").unwrap();
            // Before the first panel's recorded line, only its predictions and its underlay.
            assert!(first_black >= 2, "{name}: {series:?}");
        }
    }
}

/// Regression (visual review §3): two estimators that gave the same model drew one line exactly over
/// the other, and the legend listed a line nobody could see; the second is dashed and says so.
#[test]
fn a_prediction_that_coincides_with_another_is_dashed_and_named_in_the_legend() {
    let (_dir, out) = run_two_estimators();
    let svg = std::fs::read_to_string(out.join("figures/trajectories_zz20_20_ps.svg")).unwrap();
    assert!(
        svg.contains("reduced32 bounded-lsq 4 OS (= reduced32 lsq 4 OS, dashed)"),
        "no coincidence noted in the legend"
    );
    // Dashes: the second case's colour (tab10 orange) as many short polylines, not one long one.
    let orange: Vec<usize> = polylines(&svg)
        .into_iter()
        .filter(|(s, _)| s.eq_ignore_ascii_case("#FF7F0E"))
        .map(|(_, n)| n)
        .collect();
    assert!(orange.len() > 20, "{} orange polylines", orange.len());
}

/// Regression (visual review §4): the legends sat inside the plots over the data (the heading
/// figure's two legends over its first peak and its rudder signal); there is one, below the plots.
#[test]
fn the_legend_of_a_time_series_figure_is_below_its_plots() {
    let (_dir, out) = run_two_estimators();
    let svg = std::fs::read_to_string(out.join("figures/heading_zz20_20_ps.svg")).unwrap();
    // One entry per series, once: the recording and the two cases (plotters writes a text on a
    // line of its own).
    let text = |t: &str| format!(">\n{t}\n</text>");
    assert_eq!(svg.matches(&text("recorded zz20_20_ps.csv")).count(), 1);
    assert_eq!(svg.matches(&text("reduced32 lsq 4 OS")).count(), 1);
    // Below the 900-px plots.
    let at = svg.find(&text("recorded zz20_20_ps.csv")).unwrap();
    let tag = &svg[svg[..at].rfind("<text").unwrap()..at];
    let y: f64 = tag
        .split("y=\"")
        .nth(1)
        .unwrap()
        .split('"')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(y > 900.0, "legend text at y = {y}");
}
