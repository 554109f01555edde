//! Figures of a study run (SVG, `plotters`), written into `<out>/figures/` after the tables, and by
//! `shipid plot STUDY.toml` from an existing run's outputs (no refitting):
//!
//! - `trajectories_<test>.svg`: recorded track vs every case's closed-loop re-simulation;
//! - `heading_<test>.svg`: heading and rudder vs time, recording and predictions;
//! - `coefficient_convergence.svg` (paper 000 Fig. 16): coefficients normalised by their value at the
//!   largest overshoot count, vs overshoots, when the study varies overshoots;
//! - `coefficients_<set>.svg` (Fig. 18): |coefficient| per term on a log scale, grouped by case, with
//!   a mark where the signs of a term disagree across cases;
//! - `vif_<set>.svg` (Fig. 14/15): VIF per term (log scale);
//! - `forces_<case>_<test>.svg` (Fig. 12/19): per-term force contributions φ_k β_k over time per DOF,
//!   for the case with the smallest mean MRAE over its tests and its first training recording;
//! - `bands_<test>.svg` (studies with `bands`): one panel per metric of the test, each case's band as
//!   a shaded interval with its point prediction, and the recorded value as a line across, so a
//!   case whose band misses the record stands out (its interval drawn in red).
//!
//! A diverged prediction is drawn up to its divergence time, marked with an × and labelled
//! "diverged" in the legend, never dropped. A figure that cannot be drawn is a warning, not a failure.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use shipid_io::{DatasetRecording, Recording};
use shipid_model::design::contributions;
use shipid_model::{AbkowitzModel, Dof, ModelFile, PrimeInertia, design};
use shipid_sim::{AbkowitzDynamics, Dynamics, GpDynamics, SimStatus};
use shipid_tables::Table;

use shipid_pipeline::fit::{WindowSpec, training_samples};
use shipid_pipeline::mmg::load_mmg_model_if_kind;
use shipid_pipeline::model_file::load_gp_model;
use shipid_pipeline::validate::replay_in;
use shipid_study::{Case, Study};

use crate::error::Result;
use crate::fig_err;

const FONT: &str = "sans-serif";
/// Tableau 10: distinguishable line colours.
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

fn colour(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// What the figures of a run could and could not be drawn.
#[derive(Debug, Default)]
pub struct FigureReport {
    pub written: Vec<PathBuf>,
    /// Figures of an earlier run in the folder that this run does not draw, removed.
    pub removed: Vec<PathBuf>,
    /// One message per figure that could not be drawn.
    pub warnings: Vec<String>,
}

use shipid_pipeline::validate::closed_loop_in;

/// (DOF, term, set, estimator) of a convergence line.
type LineKey = (String, String, String, String);

/// A case of the run with what it left on disk.
struct CaseData<'a> {
    case: &'a Case,
    /// The polynomial model (force decompositions and tracks).
    model: Option<AbkowitzModel>,
    /// A sparse-GP case's model (tracks only).
    gp: Option<GpDynamics>,
    /// An mmg case's model (tracks only).
    mmg: Option<shipid_sim::MmgModel>,
}

/// Legend of a case: set, estimator (refined or not, with its fixed hyper-parameter), window, and the
/// training recordings when the study has several training combinations (otherwise cases that differ
/// only in them would share a label).
fn case_label(study: &Study, c: &Case) -> String {
    let e = &c.estimator;
    let hyper = if e.tune {
        " tuned".to_string()
    } else if let Some(l) = e.lambda {
        format!(" λ={l:e}")
    } else if let Some(a) = e.alpha {
        format!(" α={a:e}")
    } else if let Some(c) = e.c {
        format!(" C={c:e}")
    } else if let Some(d) = e.similarity {
        format!(" d_gen={d}")
    } else {
        String::new()
    };
    let several_trainings = study.cases.iter().any(|o| o.training != c.training);
    let training = if several_trainings {
        let names: Vec<&str> = c
            .training
            .iter()
            .map(|f| f.trim_end_matches(".csv"))
            .collect();
        format!(" on {}", names.join("+"))
    } else {
        String::new()
    };
    // A sparse-GP case has no coefficient set.
    let set = if c.set == shipid_study::study::NO_SET {
        String::new()
    } else {
        format!("{} ", c.set)
    };
    format!(
        "{}{}{}{} {}{}",
        set,
        e.name,
        if e.refine { " refined" } else { "" },
        hyper,
        WindowSpec::label(c.window),
        training
    )
}

/// The cases' models as their folders hold them. A case left out of the figures is named in the
/// warnings (no `result.json`, one that cannot be read, or no loadable `model.toml` although its fit
/// made a model), so a figure never lacks a case without a word; a fit that made no model is the
/// tables' to report, not a warning here.
fn load_cases<'a>(study: &'a Study, out: &Path, warnings: &mut Vec<String>) -> Vec<CaseData<'a>> {
    study
        .cases
        .iter()
        .map(|case| {
            let dir = out.join("cases").join(&case.id);
            let result_path = dir.join("result.json");
            let none = CaseData {
                case,
                model: None,
                gp: None,
                mmg: None,
            };
            // Without its result the case is unfinished (or damaged): a model.toml beside it may be
            // of another configuration, so none of it is drawn.
            let has_model = match std::fs::read_to_string(&result_path) {
                Ok(text) => match serde_json::from_str::<shipid_study::CaseResult>(&text) {
                    Ok(r) => r.status.has_model(),
                    Err(e) => {
                        warnings.push(format!(
                            "case {}: {} cannot be read ({e}): the case is left out of the figures",
                            case.id,
                            result_path.display()
                        ));
                        return none;
                    }
                },
                Err(e) => {
                    warnings.push(format!(
                        "case {}: {}: {e} (not run yet?): the case is left out of the figures",
                        case.id,
                        result_path.display()
                    ));
                    return none;
                }
            };
            let path = dir.join("model.toml");
            let text = std::fs::read_to_string(&path);
            let gp = text
                .as_deref()
                .ok()
                .and_then(|t| load_gp_model(&path, t).ok().flatten());
            let mmg = text
                .as_deref()
                .ok()
                .and_then(|t| load_mmg_model_if_kind(&path, t).ok().flatten());
            let model = match (&text, gp.is_some() || mmg.is_some()) {
                (Ok(t), false) => toml::from_str::<ModelFile>(t)
                    .map_err(|e| e.to_string())
                    .and_then(|f| f.to_model().map_err(|e| e.to_string()))
                    .map_err(|e| (has_model, e)),
                (Ok(_), true) => Err((false, String::new())),
                (Err(e), _) => Err((has_model, e.to_string())),
            };
            let model = match model {
                Ok(m) => Some(m),
                Err((true, why)) => {
                    warnings.push(format!(
                        "case {}: {}: {why}: its predictions and forces are left out of the figures",
                        case.id,
                        path.display()
                    ));
                    None
                }
                Err((false, _)) => None,
            };
            CaseData {
                case,
                model,
                gp,
                mmg,
            }
        })
        .collect()
}

/// The case whose force decomposition is drawn: the one with the smallest mean MRAE over its test
/// manoeuvres (its `result.json`), so the figure shows the study's best model rather than whichever
/// case comes first (in a truncation sweep, a one-overshoot fit that diverges); the first case with a
/// model when no case has an MRAE.
fn best_case<'c, 'a>(cases: &'c [CaseData<'a>], out: &Path) -> Option<&'c CaseData<'a>> {
    let mean_mrae = |c: &CaseData| -> Option<f64> {
        let text =
            std::fs::read_to_string(out.join("cases").join(&c.case.id).join("result.json")).ok()?;
        let result: shipid_study::CaseResult = serde_json::from_str(&text).ok()?;
        let m: Vec<f64> = result.tests.iter().filter_map(|t| t.mrae).collect();
        (!m.is_empty()
            && result
                .tests
                .iter()
                .all(|t| t.status == shipid_study::runner::TestStatus::Ok))
        .then(|| m.iter().sum::<f64>() / m.len() as f64)
    };
    let with_model = cases.iter().filter(|c| c.model.is_some());
    with_model
        .clone()
        .filter_map(|c| Some((mean_mrae(c)?, c)))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, c)| c)
        .or_else(|| with_model.clone().next())
}

/// File-name-safe form of a name.
fn slug(s: &str) -> String {
    let s: String = s
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    s.trim_end_matches("_csv").to_string()
}

/// The file-name part of a set or test name, distinct for distinct names: the name itself when it
/// is already safe (`reduced32`, or `zz20_20_ps` for `zz20_20_ps.csv`), else its safe form with a
/// hash of the name as written, as case ids have (`a/b.toml` and `a_b.toml` both read `a_b_toml`).
///
/// A long name is cut to [`MAX_SLUG`] bytes and takes the hash too: a file name holds at most 255
/// bytes, and `forces_<case id>_<test>.svg` holds a case id (up to 109 bytes) and a test name.
fn unique_slug(s: &str) -> String {
    let safe = |x: &str| {
        !x.is_empty()
            && x.len() <= MAX_SLUG
            && !x.ends_with("_csv")
            && x.chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
    };
    let stem = s.strip_suffix(".csv").unwrap_or(s);
    if safe(stem) {
        stem.to_string()
    } else {
        let mut cut = slug(s);
        cut.truncate(MAX_SLUG); // ASCII after `slug`: any byte is a boundary
        format!("{cut}{}", hash_suffix(s))
    }
}

/// Most bytes of a set or test name in a figure's file name before its hash.
const MAX_SLUG: usize = 100;

/// [`unique_slug`] of each of `names`, with the hash of the name added where two of them would
/// differ only in letter case (`ZZ20.csv` and `zz20.csv`): on a case-insensitive file system
/// (macOS, Windows) their figures would be one file, the second drawn over the first.
fn folded_slugs(names: &[String]) -> BTreeMap<String, String> {
    let plain: Vec<String> = names.iter().map(|n| unique_slug(n)).collect();
    names
        .iter()
        .zip(&plain)
        .map(|(name, slug)| {
            let folded = slug.to_ascii_lowercase();
            let clash = plain
                .iter()
                .filter(|o| o.to_ascii_lowercase() == folded)
                .count()
                > 1;
            let slug = if clash && !slug.ends_with(&hash_suffix(name)) {
                format!("{slug}{}", hash_suffix(name))
            } else {
                slug.clone()
            };
            (name.clone(), slug)
        })
        .collect()
}

/// The `-xxxxxxxx` hash [`unique_slug`] gives a name that is not safe as it is.
fn hash_suffix(name: &str) -> String {
    format!("-{:08x}", shipid_pipeline::generate::fnv1a(name) as u32)
}

/// The file-name prefixes of the figures [`write_figures`] draws. A figure an earlier run recorded
/// ([`FIGURE_RECORD`]) that this run does not draw (another study's, or bands since turned off) is
/// removed, so the folder and the report show the current run only.
pub const FIGURE_PREFIXES: [&str; 7] = [
    "trajectories_",
    "heading_",
    "bands_",
    "coefficient_convergence",
    "coefficients_",
    "vif_",
    "forces_",
];

/// The list of the figures a run drew, kept in the figures folder: the next run removes those of
/// them it does not draw, and nothing else. A name alone (`trajectories_my_hand_drawn.svg`, of
/// the user's) says nothing of who wrote the file: removing by prefix deleted such files.
pub const FIGURE_RECORD: &str = ".shipid-figures";

/// The figures an earlier run recorded in `dir` ([`FIGURE_RECORD`]): plain file names of shipid's
/// figures only, so an edited record cannot name a file elsewhere or one of another kind.
fn recorded_figures(dir: &Path) -> Vec<String> {
    let Ok(text) = std::fs::read_to_string(dir.join(FIGURE_RECORD)) else {
        return Vec::new(); // no earlier run, or one before the record existed: remove nothing
    };
    text.lines()
        .map(str::trim)
        .filter(|name| {
            name.ends_with(".svg")
                && FIGURE_PREFIXES.iter().any(|p| name.starts_with(p))
                && !name.contains(['/', '\\'])
                && !name.starts_with('.')
        })
        .map(str::to_string)
        .collect()
}

/// Removes the figures an earlier run recorded in `dir` that `keep` does not hold, then records
/// `keep` for the next run; other files are the user's and stay.
fn remove_stale(dir: &Path, keep: &[PathBuf], report: &mut FigureReport) {
    for name in recorded_figures(dir) {
        let path = dir.join(&name);
        if keep.contains(&path) || !path.is_file() {
            continue;
        }
        match std::fs::remove_file(&path) {
            Ok(()) => report.removed.push(path),
            Err(e) => report.warnings.push(format!(
                "{}: left from an earlier run and cannot be removed: {e}",
                path.display()
            )),
        }
    }
    let names: Vec<String> = keep
        .iter()
        .filter_map(|p| Some(p.file_name()?.to_string_lossy().into_owned()))
        .collect();
    let record = dir.join(FIGURE_RECORD);
    let text = format!("{}\n", names.join("\n"));
    if let Err(e) = shipid_io::write::write_atomic(&record, text.as_bytes()) {
        report.warnings.push(format!(
            "{}: cannot record the figures drawn (the next run will not remove those it no longer draws): {e}",
            record.display()
        ));
    }
}

/// Write every figure of a run whose outputs are in `out` into `out/figures/`.
pub fn write_figures(study: &Study, out: &Path) -> FigureReport {
    let mut report = FigureReport::default();
    let dir = out.join("figures");
    if let Err(e) = std::fs::create_dir_all(&dir) {
        report
            .warnings
            .push(format!("cannot create {}: {e}", dir.display()));
        return report;
    }
    let cases = load_cases(study, out, &mut report.warnings);
    let r = &mut report;
    let tests = folded_slugs(&study.tests);
    for test in &study.tests {
        let Some(rec) = study.dataset.recording(test) else {
            continue;
        };
        let sims = predictions(study, &cases, rec);
        attempt(
            r,
            dir.join(format!("trajectories_{}.svg", tests[test])),
            &|p: &Path| trajectories(p, study, rec, &sims).map(|_| true),
        );
        attempt(
            r,
            dir.join(format!("heading_{}.svg", tests[test])),
            &|p: &Path| heading(p, rec, &sims).map(|_| true),
        );
    }
    if study.bands.is_some() {
        match Table::read_csv(&out.join("summary.csv")) {
            Ok(summary) => {
                for test in &study.tests {
                    attempt(
                        r,
                        dir.join(format!("bands_{}.svg", tests[test])),
                        &|p: &Path| metric_bands(p, study, &summary, test),
                    );
                }
            }
            Err(e) => r.warnings.push(format!("summary.csv: {e}")),
        }
    }
    match Table::read_csv(&out.join("coefficients.csv")) {
        Ok(t) => {
            let rows = long_rows(&t, "coefficient");
            attempt(r, dir.join("coefficient_convergence.svg"), &|p: &Path| {
                convergence(p, &rows)
            });
            let sets = distinct(rows.iter().map(|x| x.set.clone()));
            let slugs = folded_slugs(&sets);
            for set in sets {
                attempt(
                    r,
                    dir.join(format!("coefficients_{}.svg", slugs[&set])),
                    &|p: &Path| bars(p, &set, &rows, BarKind::Coefficients).map(|_| true),
                );
            }
        }
        Err(e) => r.warnings.push(format!("coefficients.csv: {e}")),
    }
    match Table::read_csv(&out.join("diagnostics.csv")) {
        Ok(t) => {
            let rows = long_rows(&t, "vif");
            let sets = distinct(rows.iter().map(|x| x.set.clone()));
            let slugs = folded_slugs(&sets);
            for set in sets {
                attempt(
                    r,
                    dir.join(format!("vif_{}.svg", slugs[&set])),
                    &|p: &Path| bars(p, &set, &rows, BarKind::Vif).map(|_| true),
                );
            }
        }
        Err(e) => r.warnings.push(format!("diagnostics.csv: {e}")),
    }
    if let Some(chosen) = best_case(&cases, out)
        && let Some(test) = chosen.case.training.first()
    {
        let name = format!(
            "forces_{}_{}.svg",
            slug(&chosen.case.id),
            folded_slugs(&chosen.case.training)[test]
        );
        attempt(r, dir.join(name), &|p: &Path| {
            forces(p, study, chosen, test).map(|_| true)
        });
    }
    let written = report.written.clone();
    remove_stale(&dir, &written, &mut report);
    report
}

/// Draw one figure; `Ok(false)` means the figure does not apply to this study.
fn attempt(report: &mut FigureReport, path: PathBuf, f: &dyn Fn(&Path) -> Result<bool>) {
    match f(&path) {
        Ok(true) => report.written.push(path),
        Ok(false) => {}
        Err(e) => report
            .warnings
            .push(format!("figure {}: {e:#}", path.display())),
    }
}

// ---------------------------------------------------------------------------------------------------
// Time series: trajectories and heading.

/// One case's prediction of a test recording, times shifted back to the recording's clock.
struct Prediction {
    label: String,
    colour: RGBColor,
    t: Vec<f64>,
    x0: Vec<f64>,
    y0: Vec<f64>,
    psi: Vec<f64>,
    delta: Vec<f64>,
    diverged_at_s: Option<f64>,
}

fn predictions(study: &Study, cases: &[CaseData], r: &DatasetRecording) -> Vec<Prediction> {
    let ship = &study.dataset.ship;
    let t0 = r.recording.t.first().copied().unwrap_or(0.0);
    // As the study's own validation: the recording's wind and current act on every prediction (a
    // recording whose environment cannot be used was already refused by the run).
    let env = shipid_pipeline::environment::recording_environment(&study.dataset, &r.recording)
        .ok()
        .and_then(|(env, _)| env);
    cases
        .iter()
        .enumerate()
        .filter_map(|(i, c)| {
            let polynomial = c.model.clone().map(AbkowitzDynamics);
            let model: &dyn Dynamics = match (&polynomial, &c.gp, &c.mmg) {
                (Some(m), _, _) => m,
                (None, Some(g), _) => g,
                (None, None, Some(m)) => m,
                (None, None, None) => return None,
            };
            let sim = closed_loop_in(model, r, ship, env.clone())
                .unwrap_or_else(|| replay_in(model, &r.recording, env.clone()));
            let s = sim.recording;
            let diverged_at_s = match sim.status {
                SimStatus::Ok => None,
                SimStatus::Diverged { t_s, .. } => Some(t_s + t0),
            };
            Some(Prediction {
                label: case_label(study, c.case),
                colour: colour(i),
                t: s.t.iter().map(|t| t + t0).collect(),
                x0: s.x0,
                y0: s.y0,
                psi: s.psi,
                delta: s.delta,
                diverged_at_s,
            })
        })
        .collect()
}

fn legend_label(p: &Prediction) -> String {
    match p.diverged_at_s {
        Some(t) => format!("{} (diverged at {t:.0} s, ×)", p.label),
        None => p.label.clone(),
    }
}

/// (lo, hi) of finite values, padded by `pad` of the span.
fn range_of(values: impl Iterator<Item = f64>, pad: f64) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let span = if hi - lo > 1e-12 * (1.0 + hi.abs()) {
        hi - lo
    } else {
        1.0
    };
    (lo - pad * span, hi + pad * span)
}

/// Points (x, y) up to the first that is not finite or outside the box: a diverging prediction is
/// drawn until it leaves the figure.
fn inside(
    pts: impl Iterator<Item = (f64, f64)>,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
) -> Vec<(f64, f64)> {
    pts.take_while(|&(x, y)| {
        x.is_finite() && y.is_finite() && x >= x0 && x <= x1 && y >= y0 && y <= y1
    })
    .collect()
}

/// Allowed range of a prediction: the recording's range widened by its span on each side.
fn allowed((lo, hi): (f64, f64)) -> (f64, f64) {
    let span = (hi - lo).max(1.0);
    (lo - span, hi + span)
}

/// Draw a prediction's line (and its × when it diverged) on a chart.
/// A prediction's line (and its × when it diverged) on a chart; `dashed` when it coincides with one
/// drawn before it, so that both stay visible.
fn draw_prediction<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    p: &Prediction,
    pts: Vec<(f64, f64)>,
    dashed: bool,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let c = p.colour;
    let last = pts.last().copied();
    if dashed {
        chart
            .draw_series(DashedLineSeries::new(pts, 9, 7, c.stroke_width(2)))
            .map_err(|e| fig_err!("{e}"))?;
    } else {
        chart
            .draw_series(LineSeries::new(pts, c.stroke_width(2)))
            .map_err(|e| fig_err!("{e}"))?;
    }
    if p.diverged_at_s.is_some()
        && let Some(at) = last
    {
        chart
            .draw_series(std::iter::once(Cross::new(at, 7, c.stroke_width(3))))
            .map_err(|e| fig_err!("{e}"))?;
    }
    Ok(())
}

/// For each prediction, the earlier one it coincides with on `plotted` (points as drawn, one list
/// per prediction): every point within `tol` (x, y) of the other's. Two estimators that give the
/// same model otherwise draw one line over the other and the legend lists a line nobody can see.
fn coincident(plotted: &[Vec<(f64, f64)>], tol: (f64, f64)) -> Vec<Option<usize>> {
    (0..plotted.len())
        .map(|i| {
            (0..i).find(|&j| {
                let (a, b) = (&plotted[i], &plotted[j]);
                !a.is_empty()
                    && a.len() == b.len()
                    && a.iter()
                        .zip(b)
                        .all(|(p, q)| (p.0 - q.0).abs() <= tol.0 && (p.1 - q.1).abs() <= tol.1)
            })
        })
        .collect()
}

/// The recorded series drawn last, on top of the predictions it is the reference for: a wide light
/// underlay keeps it visible where predictions lie on it, a thin black line on top keeps the
/// predictions visible beside it.
fn draw_recorded<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    pts: Vec<(f64, f64)>,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    chart
        .draw_series(LineSeries::new(
            pts.clone(),
            RGBColor(150, 150, 150).mix(0.45).stroke_width(7),
        ))
        .map_err(|e| fig_err!("{e}"))?;
    chart
        .draw_series(LineSeries::new(pts, BLACK.stroke_width(2)))
        .map_err(|e| fig_err!("{e}"))?;
    Ok(())
}

/// One line of a legend drawn outside the plots.
struct LegendEntry {
    label: String,
    colour: RGBColor,
    /// Recorded: black on a grey underlay.
    recorded: bool,
    dashed: bool,
    diverged: bool,
}

/// The legend entries of a time-series figure: the recording, then each prediction (a coinciding
/// one says which it equals).
fn series_entries(file: &str, sims: &[Prediction], same: &[Option<usize>]) -> Vec<LegendEntry> {
    std::iter::once(LegendEntry {
        label: format!("recorded {file}"),
        colour: BLACK,
        recorded: true,
        dashed: false,
        diverged: false,
    })
    .chain(sims.iter().zip(same).map(|(p, s)| LegendEntry {
        label: match s {
            Some(j) => format!("{} (= {}, dashed)", legend_label(p), sims[*j].label),
            None => legend_label(p),
        },
        colour: p.colour,
        recorded: false,
        dashed: s.is_some(),
        diverged: p.diverged_at_s.is_some(),
    }))
    .collect()
}

/// Legend font size and row height, and the width of a column for the longest label.
const LEGEND_FONT: u32 = 14;
const LEGEND_ROW: u32 = 21;
fn legend_column_width(entries: &[LegendEntry]) -> u32 {
    // About half an em per character of a sans-serif label; 44 px of sample line and gap.
    let chars = entries
        .iter()
        .map(|e| e.label.chars().count())
        .max()
        .unwrap_or(0) as u32;
    44 + chars * LEGEND_FONT / 2
}

/// (columns, height) of a legend of `entries` across `width` px, below the plots.
fn legend_layout(entries: &[LegendEntry], width: u32) -> (u32, u32) {
    let cols = ((width.saturating_sub(40)) / legend_column_width(entries).max(1)).clamp(1, 3);
    let rows = (entries.len() as u32).div_ceil(cols);
    (cols, 14 + rows * LEGEND_ROW)
}

/// A legend in an area of its own (outside every plot, so it covers no data), `cols` columns.
fn draw_entries<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    entries: &[LegendEntry],
    cols: u32,
    x0: i32,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let (w, _) = area.dim_in_pixel();
    let col_w = ((w as i32 - x0 - 10) / cols.max(1) as i32).max(1);
    let rows = (entries.len() as u32).div_ceil(cols.max(1)) as i32;
    for (k, e) in entries.iter().enumerate() {
        let (c, r) = (k as i32 / rows.max(1), k as i32 % rows.max(1));
        let (x, y) = (
            x0 + c * col_w,
            10 + r * LEGEND_ROW as i32 + LEGEND_ROW as i32 / 2,
        );
        let style = e.colour.stroke_width(2);
        if e.recorded {
            area.draw(&PathElement::new(
                vec![(x, y), (x + 30, y)],
                RGBColor(150, 150, 150).mix(0.45).stroke_width(7),
            ))
            .map_err(|e| fig_err!("{e}"))?;
        }
        if e.dashed {
            for s in [0, 12, 24] {
                area.draw(&PathElement::new(vec![(x + s, y), (x + s + 7, y)], style))
                    .map_err(|e| fig_err!("{e}"))?;
            }
        } else {
            area.draw(&PathElement::new(vec![(x, y), (x + 30, y)], style))
                .map_err(|e| fig_err!("{e}"))?;
        }
        if e.diverged {
            area.draw(&Cross::new((x + 15, y), 5, e.colour.stroke_width(2)))
                .map_err(|e| fig_err!("{e}"))?;
        }
        area.draw(&Text::new(
            e.label.clone(),
            (x + 38, y),
            TextStyle::from((FONT, LEGEND_FONT).into_font()).pos(
                plotters::style::text_anchor::Pos::new(
                    plotters::style::text_anchor::HPos::Left,
                    plotters::style::text_anchor::VPos::Center,
                ),
            ),
        ))
        .map_err(|e| fig_err!("{e}"))?;
    }
    Ok(())
}

/// A legend inside a plot (where there is no room outside it): opaque, so that no curve runs through
/// its text.
fn draw_legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
) -> Result<()> {
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE)
        .border_style(BLACK)
        .label_font((FONT, 13))
        .draw()
        .map_err(|e| fig_err!("{e}"))
}

fn trajectories(
    path: &Path,
    study: &Study,
    r: &DatasetRecording,
    sims: &[Prediction],
) -> Result<()> {
    let l = study.dataset.ship.lpp;
    let rec = &r.recording;
    // North up, east right: x-axis y0/L (east), y-axis x0/L (north).
    let east_rec = range_of(rec.y0.iter().map(|y| y / l), 0.0);
    let north_rec = range_of(rec.x0.iter().map(|x| x / l), 0.0);
    let (ea, na) = (allowed(east_rec), allowed(north_rec));
    let clipped: Vec<Vec<(f64, f64)>> = sims
        .iter()
        .map(|p| inside(p.y0.iter().zip(&p.x0).map(|(e, n)| (e / l, n / l)), ea, na))
        .collect();
    let all_e = rec
        .y0
        .iter()
        .map(|y| y / l)
        .chain(clipped.iter().flatten().map(|p| p.0));
    let all_n = rec
        .x0
        .iter()
        .map(|x| x / l)
        .chain(clipped.iter().flatten().map(|p| p.1));
    let (mut e0, mut e1) = range_of(all_e, 0.05);
    let (mut n0, mut n1) = range_of(all_n, 0.05);
    // Equal scales on both axes (plot area about 820 × 640 px).
    let (w, h) = (1000u32, 820u32);
    let aspect = 820.0 / 640.0;
    let (de, dn) = (e1 - e0, n1 - n0);
    if de / dn < aspect {
        let grow = (dn * aspect - de) / 2.0;
        e0 -= grow;
        e1 += grow;
    } else {
        let grow = (de / aspect - dn) / 2.0;
        n0 -= grow;
        n1 += grow;
    }
    // Coinciding within half a pixel of the plot area.
    let same = coincident(&clipped, ((e1 - e0) / 1640.0, (n1 - n0) / 1280.0));
    let entries = series_entries(&r.file, sims, &same);
    let (cols, legend_h) = legend_layout(&entries, w);
    let root = SVGBackend::new(path, (w, h + legend_h)).into_drawing_area();
    root.fill(&WHITE)?;
    let (plot, legend) = root.split_vertically(h);
    let mut chart = ChartBuilder::on(&plot)
        .caption(
            format!("Track of {}: recorded vs closed-loop predictions", r.file),
            (FONT, 20),
        )
        .margin(15)
        .x_label_area_size(crate::X_LABEL_AREA_PX)
        .y_label_area_size(crate::Y_LABEL_AREA_PX)
        .build_cartesian_2d(e0..e1, n0..n1)?;
    chart
        .configure_mesh()
        .label_style(("sans-serif", crate::TICK_LABEL_PX))
        .x_desc("y0 / L (east) [-]")
        .y_desc("x0 / L (north) [-]")
        .axis_desc_style((FONT, 15))
        .draw()?;
    let e_range = (e0, e1);
    let n_range = (n0, n1);
    let rec_pts = inside(
        rec.y0.iter().zip(&rec.x0).map(|(e, n)| (e / l, n / l)),
        e_range,
        n_range,
    );
    for ((p, pts), s) in sims.iter().zip(clipped).zip(&same) {
        let pts = inside(pts.into_iter(), e_range, n_range);
        draw_prediction(&mut chart, p, pts, s.is_some())?;
    }
    draw_recorded(&mut chart, rec_pts)?;
    draw_entries(&legend, &entries, cols, 75)?;
    root.present()?;
    Ok(())
}

fn heading(path: &Path, r: &DatasetRecording, sims: &[Prediction]) -> Result<()> {
    let rec = &r.recording;
    let t_range = range_of(
        rec.t
            .iter()
            .copied()
            .chain(sims.iter().flat_map(|p| p.t.iter().copied())),
        0.0,
    );
    // Which predictions coincide is decided on the heading (a heading that coincides is steered by
    // a rudder that does) and holds for both panels, as their one legend says.
    let degrees = |v: &[f64]| -> Vec<f64> { v.iter().map(|x| x.to_degrees()).collect() };
    // One panel's recorded series, the predictions within its allowed range and its y range [deg].
    let panel = |channel: fn(&Recording) -> &[f64], predicted: fn(&Prediction) -> &[f64]| {
        let rec_y = degrees(channel(rec));
        let y_allowed = allowed(range_of(rec_y.iter().copied(), 0.0));
        let pred: Vec<Vec<(f64, f64)>> = sims
            .iter()
            .map(|p| {
                inside(
                    p.t.iter().copied().zip(degrees(predicted(p))),
                    (f64::NEG_INFINITY, f64::INFINITY),
                    y_allowed,
                )
            })
            .collect();
        let y_range = range_of(
            rec_y
                .iter()
                .copied()
                .chain(pred.iter().flatten().map(|p| p.1)),
            0.05,
        );
        (rec_y, pred, y_range)
    };
    let heading_panel = panel(|r| &r.psi, |p| &p.psi);
    let (_, psi_pts, psi_range) = &heading_panel;
    let same = coincident(
        psi_pts,
        (
            (t_range.1 - t_range.0) / 1700.0,
            (psi_range.1 - psi_range.0) / 700.0,
        ),
    );
    let entries = series_entries(&r.file, sims, &same);
    let (cols, legend_h) = legend_layout(&entries, 1000);
    let root = SVGBackend::new(path, (1000, 900 + legend_h)).into_drawing_area();
    root.fill(&WHITE)?;
    let (plots, legend) = root.split_vertically(900);
    let (top, bottom) = plots.split_vertically(470);
    for (first, area) in [(true, &top), (false, &bottom)] {
        let desc = if first {
            "heading ψ [deg]"
        } else {
            "rudder δ [deg]"
        };
        // The heading panel's series were computed once, for the coincidence test above.
        let (rec_y, pred, y_range) = if first {
            heading_panel.clone()
        } else {
            panel(|r| &r.delta, |p| &p.delta)
        };
        let mut b = ChartBuilder::on(area);
        b.margin(15)
            .x_label_area_size(crate::X_LABEL_AREA_PX)
            .y_label_area_size(65);
        if first {
            b.caption(
                format!(
                    "Heading and rudder of {}: recorded vs closed-loop predictions",
                    r.file
                ),
                (FONT, 20),
            );
        }
        let mut chart = b.build_cartesian_2d(t_range.0..t_range.1, y_range.0..y_range.1)?;
        chart
            .configure_mesh()
            .label_style(("sans-serif", crate::TICK_LABEL_PX))
            .x_desc("time t [s]")
            .y_desc(desc)
            .axis_desc_style((FONT, 15))
            .draw()?;
        for ((p, pts), s) in sims.iter().zip(pred).zip(&same) {
            draw_prediction(&mut chart, p, pts, s.is_some())?;
        }
        draw_recorded(
            &mut chart,
            rec.t.iter().copied().zip(rec_y.iter().copied()).collect(),
        )?;
    }
    draw_entries(&legend, &entries, cols, 80)?;
    root.present()?;
    Ok(())
}

// ---------------------------------------------------------------------------------------------------
// Coefficient tables: convergence, magnitudes, VIF.

/// One row of coefficients.csv or diagnostics.csv.
struct LongRow {
    case: String,
    set: String,
    estimator: String,
    training: String,
    window: String,
    overshoots: Option<f64>,
    /// "X_uu".
    term: String,
    value: Option<f64>,
}

fn long_rows(t: &Table, quantity: &str) -> Vec<LongRow> {
    let cell = |name: &str, i: usize| t.column(name).map(|c| c.cell(i)).unwrap_or_default();
    (0..t.rows())
        .filter(|&i| cell("quantity", i) == quantity)
        .map(|i| LongRow {
            case: cell("case", i),
            set: cell("set", i),
            estimator: cell("estimator", i),
            training: cell("training", i),
            window: cell("window", i),
            overshoots: cell("overshoots", i).parse().ok(),
            term: format!("{}_{}", cell("dof", i), cell("term", i)),
            value: cell("value", i)
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite()),
        })
        .collect()
}

fn distinct<T: Ord + Clone>(items: impl Iterator<Item = T>) -> Vec<T> {
    let mut seen = BTreeSet::new();
    items.filter(|x| seen.insert(x.clone())).collect()
}

/// Fig. 16: coefficient / coefficient at the largest overshoot count, vs overshoots; one panel per DOF.
/// Returns false (no figure) when the study does not vary overshoots.
fn convergence(path: &Path, rows: &[LongRow]) -> Result<bool> {
    let os: BTreeSet<i64> = rows
        .iter()
        .filter_map(|r| r.overshoots.map(|o| o as i64))
        .collect();
    if os.len() < 2 {
        return Ok(false);
    }
    // Lines: (set, estimator, training, term) → (overshoots, value).
    let mut lines: BTreeMap<LineKey, Vec<(f64, f64)>> = BTreeMap::new();
    for r in rows {
        if let (Some(o), Some(v)) = (r.overshoots, r.value) {
            lines
                .entry((
                    r.set.clone(),
                    r.estimator.clone(),
                    r.training.clone(),
                    r.term.clone(),
                ))
                .or_default()
                .push((o, v));
        }
    }
    let combos = distinct(
        lines
            .keys()
            .map(|k| (k.0.clone(), k.1.clone(), k.2.clone())),
    );
    let (o_lo, o_hi) = (
        *os.first().unwrap_or(&0) as f64,
        *os.last().unwrap_or(&1) as f64,
    );
    const CLIP: (f64, f64) = (-3.0, 5.0);
    let root = SVGBackend::new(path, (1500, 700)).into_drawing_area();
    root.fill(&WHITE)?;
    let (title, body) = root.split_vertically(40);
    title.draw(&Text::new(
        "Coefficient convergence with the training window: value / value at the most overshoots (clipped to [-3, 5])",
        (20, 12),
        (FONT, 18),
    ))?;
    let panels = body.split_evenly((1, 3));
    for (dof, area) in Dof::ALL.iter().zip(panels.iter()) {
        let prefix = format!("{}_", dof.as_str());
        let mut norm: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
        for ((set, est, training, term), pts) in &lines {
            if !term.starts_with(&prefix) {
                continue;
            }
            let mut pts = pts.clone();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            let Some(&(_, reference)) = pts.last() else {
                continue;
            };
            if reference == 0.0 {
                continue;
            }
            let label = if combos.len() > 1 {
                format!("{term} ({set} {est} {training})")
            } else {
                term.clone()
            };
            norm.push((
                label,
                pts.iter()
                    .map(|&(o, v)| (o, (v / reference).clamp(CLIP.0, CLIP.1)))
                    .collect(),
            ));
        }
        let y = range_of(norm.iter().flat_map(|l| l.1.iter().map(|p| p.1)), 0.05);
        let mut chart = ChartBuilder::on(area)
            .caption(format!("{dof}"), (FONT, 18))
            .margin(12)
            .x_label_area_size(crate::X_LABEL_AREA_PX)
            .y_label_area_size(crate::Y_LABEL_AREA_PX)
            .build_cartesian_2d(o_lo - 0.2..o_hi + 0.2, y.0.min(0.0)..y.1.max(1.2))?;
        chart
            .configure_mesh()
            .label_style(("sans-serif", crate::TICK_LABEL_PX))
            .x_desc("overshoots in the training window [-]")
            .y_desc("β / β(most overshoots) [-]")
            .axis_desc_style((FONT, 14))
            .x_labels(os.len().min(12))
            .draw()?;
        for (i, (label, pts)) in norm.into_iter().enumerate() {
            let c = colour(i);
            chart
                .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))?
                .label(label)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                });
            chart.draw_series(pts.into_iter().map(|p| Circle::new(p, 3, c.filled())))?;
        }
        draw_legend(&mut chart, SeriesLabelPosition::UpperRight)?;
    }
    root.present()?;
    Ok(true)
}

#[derive(Clone, Copy, PartialEq)]
enum BarKind {
    Coefficients,
    Vif,
}

/// Fig. 18 (|coefficient|, sign disagreement marked) or Fig. 14/15 (VIF): bars per term on a log scale,
/// one bar per case of the set.
fn bars(path: &Path, set: &str, rows: &[LongRow], kind: BarKind) -> Result<()> {
    let rows: Vec<&LongRow> = rows.iter().filter(|r| r.set == set).collect();
    let terms = distinct(rows.iter().map(|r| r.term.clone()));
    let cases = distinct(rows.iter().map(|r| r.case.clone()));
    let label_of = |case: &str| {
        rows.iter()
            .find(|r| r.case == case)
            .map(|r| format!("{} {} {}", r.estimator, r.window, r.training))
            .unwrap_or_default()
    };
    let value = |case: &str, term: &str| {
        rows.iter()
            .find(|r| r.case == case && r.term == term)
            .and_then(|r| r.value)
    };
    let magnitudes: Vec<f64> = rows
        .iter()
        .filter_map(|r| r.value.map(f64::abs))
        .filter(|v| *v > 0.0)
        .collect();
    if terms.is_empty() || magnitudes.is_empty() {
        return Err(fig_err!("no values of set {set}"));
    }
    let lo = magnitudes.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = magnitudes.iter().copied().fold(0.0, f64::max);
    let (lo, hi) = match kind {
        BarKind::Vif => (lo.min(1.0) / 2.0, hi.max(10.0) * 3.0),
        BarKind::Coefficients => (lo / 2.0, hi * 5.0),
    };
    // Headroom above the tallest bar for the legend (one row per case, the VIF line and the ±
    // mark), so that it covers no bar: that share of the log axis's ~640 px is added on top.
    let legend_rows = cases.len() + 2;
    let share = ((20.0 * legend_rows as f64 + 30.0) / 640.0).min(0.6);
    let hi = lo * (hi / lo).powf(1.0 / (1.0 - share));
    let n = terms.len() as f64;
    let width = (300 + 28 * terms.len()).clamp(900, 3000) as u32;
    let root = SVGBackend::new(path, (width, 800)).into_drawing_area();
    root.fill(&WHITE)?;
    let title = match kind {
        BarKind::Coefficients => {
            format!(
                "|coefficient| per term of set {set} by case (red ± above a term: signs disagree across cases)"
            )
        }
        BarKind::Vif => format!("Variance inflation factor per term of set {set} by case"),
    };
    let mut chart = ChartBuilder::on(&root)
        .caption(title, (FONT, 20))
        .margin(15)
        .x_label_area_size(90)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..n, (lo..hi).log_scale())?;
    chart
        .configure_mesh()
        .label_style(("sans-serif", crate::TICK_LABEL_PX))
        .disable_x_mesh()
        .disable_x_axis()
        .y_desc(match kind {
            BarKind::Coefficients => "|β| (prime) [-]",
            BarKind::Vif => "VIF [-]",
        })
        .axis_desc_style((FONT, 15))
        // Decades as 1e-5, not the 9.999999999999e-6 that the log scale's ticks print.
        .y_label_formatter(&|v| {
            let e = v.log10().round();
            if (v / 10f64.powf(e) - 1.0).abs() < 1e-6 {
                format!("1e{e:.0}")
            } else {
                format!("{v:.1e}")
            }
        })
        .draw()?;
    let k = cases.len().max(1) as f64;
    for (ci, case) in cases.iter().enumerate() {
        let c = colour(ci);
        let bars: Vec<Rectangle<(f64, f64)>> = terms
            .iter()
            .enumerate()
            .filter_map(|(j, term)| {
                let v = value(case, term)?.abs();
                (v > 0.0).then(|| {
                    let x0 = j as f64 + 0.1 + 0.8 * ci as f64 / k;
                    Rectangle::new([(x0, lo), (x0 + 0.8 / k, v)], c.filled())
                })
            })
            .collect();
        chart
            .draw_series(bars)?
            .label(label_of(case))
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 15, y + 5)], c.filled()));
    }
    if kind == BarKind::Vif {
        chart
            .draw_series(LineSeries::new(
                vec![(0.0, 10.0), (n, 10.0)],
                RED.stroke_width(1),
            ))?
            .label("VIF = 10")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED.stroke_width(1)));
    }
    let mut any_disagreement = false;
    for (j, term) in terms.iter().enumerate() {
        let (mut pos, mut neg) = (false, false);
        let mut top: f64 = lo;
        for case in &cases {
            if let Some(v) = value(case, term) {
                pos |= v > 0.0;
                neg |= v < 0.0;
                top = top.max(v.abs());
            }
        }
        if kind == BarKind::Coefficients && pos && neg {
            any_disagreement = true;
            chart.draw_series(std::iter::once(Text::new(
                "±",
                (j as f64 + 0.35, (top * 1.6).min(hi)),
                (FONT, 18).into_font().color(&RED),
            )))?;
        }
        // Term names under the axis, rotated.
        let (px, py) = chart.backend_coord(&(j as f64 + 0.5, lo));
        root.draw(&Text::new(
            term.clone(),
            (px - 6, py + 6),
            (FONT, 12).into_font().transform(FontTransform::Rotate90),
        ))?;
    }
    if any_disagreement {
        chart
            .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())?
            .label("± signs disagree across cases")
            .legend(|(x, y)| Text::new("±", (x, y - 8), (FONT, 16).into_font().color(&RED)));
    }
    draw_legend(&mut chart, SeriesLabelPosition::UpperRight)?;
    root.present()?;
    Ok(())
}

// ---------------------------------------------------------------------------------------------------
// Metric bands.

/// One case's band of one metric: (lo, hi), the point prediction, and whether the record is inside.
struct CaseBand {
    lo: f64,
    hi: f64,
    predicted: Option<f64>,
    inside: Option<bool>,
}

/// One metric of a test: its key, the recorded value, and each case's band (None: no band).
type BandPanel = (&'static str, Option<f64>, Vec<Option<CaseBand>>);

/// The unit of a metric as the summary gives it.
fn metric_unit(metric: &str) -> &'static str {
    match metric {
        "overshoot_1" | "overshoot_2" => "[deg]",
        "t_a" | "t_check" => "[× U0/L]",
        _ => "[÷ L]",
    }
}

/// The bands of a test's metrics for every case (summary rows of that test, in case order):
/// `Ok(false)` when no metric of the test has a band (a replay-only recording).
fn metric_bands(path: &Path, study: &Study, summary: &Table, test: &str) -> Result<bool> {
    let Some(tests) = summary.column("test") else {
        return Err(fig_err!("summary.csv has no `test` column"));
    };
    let rows: Vec<usize> = (0..summary.rows())
        .filter(|&i| tests.cell(i) == test)
        .collect();
    let num = |col: &str, i: usize| {
        summary
            .column(col)
            .and_then(|c| c.cell(i).parse::<f64>().ok())
    };
    let case_of = |i: usize| {
        summary
            .column("case")
            .map(|c| c.cell(i))
            .unwrap_or_default()
    };
    let mut panels: Vec<BandPanel> = Vec::new();
    for key in shipid_study::tables::METRIC_KEYS {
        let bands: Vec<Option<CaseBand>> = rows
            .iter()
            .map(|&i| {
                Some(CaseBand {
                    lo: num(&format!("{key}_lo"), i)?,
                    hi: num(&format!("{key}_hi"), i)?,
                    predicted: num(&format!("{key}_predicted"), i),
                    inside: summary.column(&format!("{key}_inside")).and_then(|c| {
                        match c.cell(i).as_str() {
                            "yes" => Some(true),
                            "no" => Some(false),
                            _ => None,
                        }
                    }),
                })
            })
            .collect();
        if bands.iter().any(Option::is_some) {
            let recorded = rows
                .iter()
                .find_map(|&i| num(&format!("{key}_recorded"), i));
            panels.push((key, recorded, bands));
        }
    }
    if panels.is_empty() {
        return Ok(false);
    }
    let level = study.bands.map_or(0.9, |b| b.level);
    let n = rows.len();
    let labels: Vec<String> = rows
        .iter()
        .map(|&i| {
            let id = case_of(i);
            study
                .cases
                .iter()
                .find(|c| c.id == id)
                .map_or(id, |c| case_label(study, c))
        })
        .collect();
    let panel_height = 260u32;
    let legend_height = 40 + 18 * n as u32;
    let height = 50 + panel_height * panels.len() as u32 + legend_height;
    let width = (420 + 70 * n as u32).clamp(800, 1800);
    let root = SVGBackend::new(path, (width, height)).into_drawing_area();
    root.fill(&WHITE)?;
    let (title_area, rest) = root.split_vertically(50);
    title_area.draw(&Text::new(
        format!(
            "{test}: {:.0} % bootstrap band of each metric by case",
            100.0 * level
        ),
        (15, 15),
        (FONT, 18),
    ))?;
    let (plots, legend) = rest.split_vertically(panel_height * panels.len() as u32);
    let areas = plots.split_evenly((panels.len(), 1));
    for (area, (metric, recorded, bands)) in areas.iter().zip(&panels) {
        let values = bands
            .iter()
            .flatten()
            .flat_map(|b| [Some(b.lo), Some(b.hi), b.predicted])
            .chain(std::iter::once(*recorded))
            .flatten();
        let (y_lo, y_hi) = range_of(values, 0.1);
        let mut chart = ChartBuilder::on(area)
            .margin(10)
            .x_label_area_size(crate::X_LABEL_AREA_PX)
            .y_label_area_size(70)
            .build_cartesian_2d(-0.5..(n as f64 - 0.5), y_lo..y_hi)?;
        chart
            .configure_mesh()
            .label_style(("sans-serif", crate::TICK_LABEL_PX))
            .disable_x_mesh()
            .x_labels(n.max(1))
            .x_label_formatter(&|x| format!("case {}", x.round() as i64 + 1))
            .y_desc(format!("{metric} {}", metric_unit(metric)))
            .axis_desc_style((FONT, 15))
            .draw()?;
        for (k, b) in bands.iter().enumerate() {
            let Some(b) = b else { continue };
            let x = k as f64;
            let c = if b.inside == Some(false) {
                RGBColor(214, 39, 40)
            } else {
                RGBColor(31, 119, 180)
            };
            chart.draw_series(std::iter::once(Rectangle::new(
                [(x - 0.25, b.lo), (x + 0.25, b.hi)],
                c.mix(0.3).filled(),
            )))?;
            chart.draw_series(std::iter::once(Rectangle::new(
                [(x - 0.25, b.lo), (x + 0.25, b.hi)],
                c.stroke_width(1),
            )))?;
            if let Some(p) = b.predicted {
                chart.draw_series(std::iter::once(Circle::new((x, p), 4, c.filled())))?;
            }
        }
        if let Some(v) = recorded {
            chart.draw_series(LineSeries::new(
                vec![(-0.5, *v), (n as f64 - 0.5, *v)],
                BLACK.stroke_width(2),
            ))?;
        }
    }
    legend.draw(&Text::new(
        "black line: recorded value; dot: point prediction; shaded: band (blue: record inside, red: outside)",
        (20, 8),
        (FONT, 14),
    ))?;
    for (k, label) in labels.iter().enumerate() {
        legend.draw(&Text::new(
            format!("case {}: {label}", k + 1),
            (20, 30 + 18 * k as i32),
            (FONT, 14),
        ))?;
    }
    root.present()?;
    Ok(true)
}

// ---------------------------------------------------------------------------------------------------
// Force contributions.

/// Fig. 12/19: φ_k β_k over time per DOF for a case's model on one training recording (whole record),
/// with the regression target y.
fn forces(path: &Path, study: &Study, c: &CaseData, test: &str) -> Result<()> {
    let model = c
        .model
        .as_ref()
        .ok_or_else(|| fig_err!("case {} has no model (its fit failed)", c.case.id))?;
    let ds = &study.dataset;
    let (samples, _) = training_samples(ds, &[test.to_string()], WindowSpec::Whole)
        .map_err(|e| fig_err!("{e}"))?;
    let inertia = PrimeInertia::new(&ds.ship, &model.added_mass, &model.set);
    // Each panel's legend to its right, outside the plot: drawn over it (even half transparent),
    // the curves ran through the term names. Columns as many as the panel's height needs.
    let (panel_h, plot_w) = (420u32, 1100u32);
    let per_dof: Vec<Vec<LegendEntry>> = Dof::ALL
        .iter()
        .map(|dof| {
            let names = design(&model.set, *dof, &samples, &inertia).names;
            std::iter::once(LegendEntry {
                label: format!("target y_{dof}"),
                colour: BLACK,
                recorded: false,
                dashed: false,
                diverged: false,
            })
            .chain(names.iter().enumerate().map(|(j, n)| LegendEntry {
                label: n.clone(),
                colour: colour(j),
                recorded: false,
                dashed: j >= PALETTE.len(),
                diverged: false,
            }))
            .collect()
        })
        .collect();
    let rows_fit = ((panel_h - 20) / LEGEND_ROW).max(1);
    let legend_cols: Vec<u32> = per_dof
        .iter()
        .map(|e| (e.len() as u32).div_ceil(rows_fit))
        .collect();
    let legend_w = per_dof
        .iter()
        .zip(&legend_cols)
        .map(|(e, c)| legend_column_width(e) * c + 20)
        .max()
        .unwrap_or(0);
    let root = SVGBackend::new(path, (plot_w + legend_w, 40 + 3 * panel_h)).into_drawing_area();
    root.fill(&WHITE)?;
    let (title, body) = root.split_vertically(40);
    title.draw(&Text::new(
        format!(
            "Force contributions φ_k β_k of case {} on {} (prime)",
            case_label(study, c.case),
            test
        ),
        (20, 12),
        (FONT, 18),
    ))?;
    let panels = body.split_evenly((3, 1));
    let t_range = range_of(samples.t.iter().copied(), 0.0);
    for (k, (dof, panel)) in Dof::ALL.iter().zip(panels.iter()).enumerate() {
        let (area, legend) = panel.split_horizontally(plot_w);
        let area = &area;
        let d = design(&model.set, *dof, &samples, &inertia);
        let beta = &model.coefficients[dof.index()];
        if beta.len() != d.names.len() {
            return Err(fig_err!("{dof}: model and set disagree"));
        }
        let contrib = contributions(&d, beta);
        let y_range = range_of(
            d.y.iter()
                .copied()
                .chain((0..contrib.nrows()).flat_map(|i| {
                    let row: Vec<f64> = (0..contrib.ncols()).map(|j| contrib[(i, j)]).collect();
                    row
                })),
            0.05,
        );
        let mut chart = ChartBuilder::on(area)
            .margin(12)
            .x_label_area_size(crate::X_LABEL_AREA_PX)
            .y_label_area_size(80)
            .build_cartesian_2d(t_range.0..t_range.1, y_range.0..y_range.1)?;
        chart
            .configure_mesh()
            .label_style(("sans-serif", crate::TICK_LABEL_PX))
            .x_desc("time t [s]")
            .y_desc(format!("{dof}' contribution [-]"))
            .axis_desc_style((FONT, 14))
            .draw()?;
        chart.draw_series(LineSeries::new(
            samples.t.iter().copied().zip(d.y.iter().copied()),
            BLACK.stroke_width(3),
        ))?;
        // Terms past the palette's ten colours repeat a colour, dashed to stay apart.
        for j in 0..d.names.len() {
            let style = colour(j).stroke_width(2);
            let pts = samples
                .t
                .iter()
                .enumerate()
                .map(|(i, t)| (*t, contrib[(i, j)]));
            if j >= PALETTE.len() {
                chart.draw_series(DashedLineSeries::new(pts, 9, 7, style))?;
            } else {
                chart.draw_series(LineSeries::new(pts, style))?;
            }
        }
        draw_entries(&legend, &per_dof[k], legend_cols[k], 10)?;
    }
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression: in a study with several training combinations (the HSVA study), cases that
    /// differed only in their training recordings shared one legend label.
    #[test]
    fn cases_that_differ_only_in_training_get_different_labels() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../shipid/tests/fixtures/studies/small.toml");
        let mut study = shipid_study::load_study(&path).unwrap();
        let alone = case_label(&study, &study.cases[0]);
        assert!(
            !alone.contains(" on "),
            "{alone}: one training combination needs no names"
        );
        let mut other = study.cases[0].clone();
        other.training = vec!["zz20_20_ps.csv".into()];
        study.cases.push(other);
        let (a, b) = (
            case_label(&study, &study.cases[0]),
            case_label(&study, study.cases.last().unwrap()),
        );
        assert_ne!(a, b);
        assert!(b.ends_with(" on zz20_20_ps"), "{b}");
    }

    /// Regression: a 121-character recording name gave a force figure's name over 255 bytes
    /// ("File name too long"), and names differing only in letter case shared one figure file on a
    /// case-insensitive file system.
    #[test]
    fn figure_names_stay_short_and_apart_when_letter_case_is_folded() {
        let long = format!("{}.csv", "a".repeat(121));
        let cut = unique_slug(&long);
        assert_eq!(cut.len(), MAX_SLUG + 9, "{cut}");
        assert!(cut.ends_with(&hash_suffix(&long)));
        let names: Vec<String> = ["ZZ20.csv", "zz20.csv", "tc35.csv"]
            .map(String::from)
            .to_vec();
        let slugs = folded_slugs(&names);
        assert_eq!(
            slugs["tc35.csv"], "tc35",
            "a name alone keeps its plain form"
        );
        let (a, b) = (&slugs["ZZ20.csv"], &slugs["zz20.csv"]);
        assert_ne!(a.to_ascii_lowercase(), b.to_ascii_lowercase(), "{a} {b}");
        assert!(a.starts_with("ZZ20-") && b.starts_with("zz20-"), "{a} {b}");
    }
}
