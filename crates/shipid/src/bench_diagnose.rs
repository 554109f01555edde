//! `shipid bench-diagnose`: the proof of the diagnosis on data where the effect is concealed.
//!
//! Every case simulates the six default manoeuvres with the MMG reference under one concealed effect (or
//! none: the controls) and towing-tank noise with its own seed, and diagnoses them against a model
//! identified from the clean default data (full74, LSQ, all six recordings, then refined in the
//! output-error sense as `shipid fit --refine` does; or `--base`). Effects and
//! magnitudes run from barely-above-noise to strong; directions are drawn per seed. Results:
//! `cases.csv/.parquet` (one row per case), `confusion.csv/.parquet`, `summary.md`.
//!
//! **Detectability threshold** (from the data alone, not from the verdicts): an effect case counts as
//! detectable when, on its recordings, the base model's held-out position RMSE is at least twice its
//! held-out RMSE on effect-free recordings with the same noise (the controls' mean) — the concealed
//! effect at least doubles the mismatch. Below that the effect hides in the model's own error and the
//! noise, and `none` is an acceptable answer. (Until 2026-11-22 the reference was the model's level on
//! its clean training data, which leaves the noise out and made every case detectable for an exact
//! base model such as `mmg:kvlcc2`.)

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use shipid_estimators::Solver;
use shipid_io::{Dataset, DatasetRecording};
use shipid_model::IdentificationRange;
use shipid_sim::effects::{Asymmetry, Current, RudderLag, ShallowWater, Wind};
use shipid_sim::{AbkowitzDynamics, Dynamics, Effect};
use shipid_tables::Table;

use crate::diagnose::{BaseRange, DiagnoseInput, DiagnoseOptions, diagnose, model_level};
use crate::fit::{EstimatorSpec, WindowSpec, fit_dataset, load_set};
use crate::generate::{Generated, default_manoeuvres, generate_with};
use crate::range::{identification_range, training_data};
use crate::simulate_cmd::load_model_parts;
use crate::{CliError, Outcome, failed};

/// One benchmark case.
#[derive(Debug, Clone)]
pub struct BenchCase {
    pub id: String,
    pub effect: Option<Effect>,
    /// Word of the concealed effect (`none` for controls).
    pub word: &'static str,
    /// The magnitude that was varied, with its unit in `magnitude_name`.
    pub magnitude: f64,
    pub magnitude_name: &'static str,
    pub seed: u64,
}

/// Magnitudes per effect, weakest first (model scale KVLCC2, L = 7 m, U0 = 1.179 m/s; full scale × 6.76
/// for speeds of wind and current and times).
pub const CURRENT_SPEEDS_M_S: [f64; 4] = [0.005, 0.01, 0.02, 0.04];
pub const WIND_SPEEDS_M_S: [f64; 4] = [1.0, 2.0, 3.0, 4.5];
pub const LAG_TIME_CONSTANTS_S: [f64; 4] = [0.2, 0.4, 0.8, 1.6];
pub const RUDDER_OFFSETS_DEG: [f64; 4] = [0.25, 0.5, 1.0, 2.0];
pub const DEPTHS_OVER_DRAFT: [f64; 4] = [4.0, 3.0, 2.0, 1.5];

/// A direction [deg] drawn from the seed (a fixed hash, so cases are reproducible).
fn direction(seed: u64, salt: u64) -> f64 {
    let h = crate::generate::fnv1a(&format!("{seed}:{salt}"));
    (h % 3600) as f64 / 10.0
}

/// The case grid: every effect × magnitude × seed, and `controls` effect-free cases.
pub fn cases(seeds: u64, controls: u64) -> Vec<BenchCase> {
    let mut out = Vec::new();
    for seed in 0..seeds {
        for (k, &s) in CURRENT_SPEEDS_M_S.iter().enumerate() {
            out.push(BenchCase {
                id: format!("current-{s}-s{seed}"),
                effect: Some(Effect::Current(Current {
                    speed_m_s: s,
                    from_deg: direction(seed, 10 + k as u64),
                })),
                word: "current",
                magnitude: s,
                magnitude_name: "speed [m/s]",
                seed,
            });
        }
        for (k, &s) in WIND_SPEEDS_M_S.iter().enumerate() {
            out.push(BenchCase {
                id: format!("wind-{s}-s{seed}"),
                effect: Some(Effect::Wind(Wind {
                    speed_m_s: s,
                    from_deg: direction(seed, 20 + k as u64),
                    frontal_area_m2: None,
                    lateral_area_m2: None,
                })),
                word: "wind",
                magnitude: s,
                magnitude_name: "speed [m/s]",
                seed,
            });
        }
        for &tau in &LAG_TIME_CONSTANTS_S {
            out.push(BenchCase {
                id: format!("rudder_lag-{tau}-s{seed}"),
                effect: Some(Effect::RudderLag(RudderLag {
                    delay_s: 0.0,
                    time_constant_s: tau,
                })),
                word: "rudder_lag",
                magnitude: tau,
                magnitude_name: "time constant [s]",
                seed,
            });
        }
        for &o in &RUDDER_OFFSETS_DEG {
            // Alternate the sign with the seed.
            let sign = if seed % 2 == 0 { 1.0 } else { -1.0 };
            out.push(BenchCase {
                id: format!("asymmetry-{o}-s{seed}"),
                effect: Some(Effect::Asymmetry(Asymmetry {
                    rudder_offset_deg: sign * o,
                    y0_n: 0.0,
                    n0_nm: 0.0,
                })),
                word: "asymmetry",
                magnitude: o,
                magnitude_name: "|rudder offset| [deg]",
                seed,
            });
        }
        for &h in &DEPTHS_OVER_DRAFT {
            out.push(BenchCase {
                id: format!("shallow_water-{h}-s{seed}"),
                effect: Some(Effect::ShallowWater(ShallowWater {
                    depth_over_draft: h,
                    yaw_factor: None,
                })),
                word: "shallow_water",
                magnitude: h,
                magnitude_name: "h/T [-]",
                seed,
            });
        }
    }
    for c in 0..controls {
        out.push(BenchCase {
            id: format!("control-s{}", 100 + c),
            effect: None,
            word: "none",
            magnitude: 0.0,
            magnitude_name: "-",
            seed: 100 + c,
        });
    }
    out
}

/// A generated data set as a loaded [`Dataset`] (in memory).
pub fn to_dataset(g: Generated, name: &str) -> Dataset {
    let recordings = g
        .dataset
        .recordings
        .iter()
        .zip(default_manoeuvres())
        .zip(g.recordings)
        .map(|((e, m), recording)| DatasetRecording {
            file: e.file.clone(),
            manoeuvre: m,
            recording,
        })
        .collect();
    Dataset {
        path: PathBuf::from(name),
        name: g.dataset.name.clone(),
        ship: g.dataset.ship,
        added_mass: g.dataset.added_mass,
        recordings,
    }
}

/// The concealed parameter that should be recovered, and the recovered one from the report's effects.
fn recovered(case: &BenchCase, effects: &[String]) -> Option<(f64, f64)> {
    let truth = case.effect?;
    let found: Effect = effects
        .iter()
        .filter_map(|e| e.parse::<Effect>().ok())
        .find(|e| e.kind() == truth.kind())?;
    match (truth, found) {
        (Effect::Current(t), Effect::Current(f)) => Some((t.speed_m_s, f.speed_m_s)),
        (Effect::Wind(t), Effect::Wind(f)) => Some((t.speed_m_s, f.speed_m_s)),
        (Effect::RudderLag(t), Effect::RudderLag(f)) => {
            Some((t.time_constant_s + t.delay_s, f.time_constant_s + f.delay_s))
        }
        (Effect::Asymmetry(t), Effect::Asymmetry(f)) => {
            Some((t.rudder_offset_deg, f.rudder_offset_deg))
        }
        (Effect::ShallowWater(t), Effect::ShallowWater(f)) => {
            Some((t.depth_over_draft, f.depth_over_draft))
        }
        _ => None,
    }
}

fn direction_error(case: &BenchCase, effects: &[String]) -> Option<f64> {
    let truth = match case.effect? {
        Effect::Current(c) => c.from_deg,
        Effect::Wind(w) => w.from_deg,
        _ => return None,
    };
    let found = effects
        .iter()
        .find_map(|e| match e.parse::<Effect>().ok()? {
            Effect::Current(c) if case.word == "current" => Some(c.from_deg),
            Effect::Wind(w) if case.word == "wind" => Some(w.from_deg),
            _ => None,
        })?;
    Some(((found - truth + 180.0).rem_euclid(360.0) - 180.0).abs())
}

struct Row {
    case: BenchCase,
    verdict: String,
    before: f64,
    after: f64,
    detectable: bool,
    truth_param: Option<f64>,
    found_param: Option<f64>,
    direction_error_deg: Option<f64>,
    effects: String,
    /// Fraction of the recorded states outside the base model's identification range.
    outside: Option<f64>,
    time_s: f64,
}

/// `--base` keyword for a sparse GP fitted in memory on the clean default data (the default: the
/// base with which the benchmark meets every floor of the diagnosis, README).
pub const GP_BASE: &str = "sparse-gp";
/// `--base` keyword for full74 LSQ fitted in memory on the clean default data and refined.
pub const FULL74_BASE: &str = "full74";

pub fn run(base_spec: &str, out: &Path, seeds: u64, controls: u64) -> Result<Outcome, CliError> {
    if [GP_BASE, FULL74_BASE].contains(&base_spec) && Path::new(base_spec).exists() {
        return Err(crate::bad_input(format!(
            "--base {base_spec}: both a base keyword and a file here; pass ./{base_spec} for the file"
        )));
    }
    let clean = to_dataset(generate_with(None, &[])?, "embedded default data (clean)");
    // The in-memory bases are fitted on every clean recording.
    let names: Vec<String> = clean.recordings.iter().map(|r| r.file.clone()).collect();
    type Base = (Box<dyn Dynamics + Send + Sync>, Vec<Effect>, String);
    let ((base, base_effects, base_name), range): (Base, Option<IdentificationRange>) =
        match base_spec {
            GP_BASE => {
                let (_, gp, report) = crate::fit_gp::fit_gp_dataset(
                    &clean,
                    &names,
                    WindowSpec::Whole,
                    crate::fit_gp::DEFAULT_SIMILARITY,
                )?;
                (
                    (
                        Box::new(gp),
                        Vec::new(),
                        format!(
                            "sparse GP (paper 001, d_gen {}: {} of {} samples kept) fitted on the six clean default recordings (`shipid fit --estimator sparse-gp`)",
                            crate::fit_gp::DEFAULT_SIMILARITY,
                            report.kept,
                            report.candidates
                        ),
                    ),
                    None,
                )
            }
            FULL74_BASE => {
                let fit = fit_dataset(
                    &clean,
                    load_set("full74")?,
                    &EstimatorSpec {
                        refine: true,
                        ..EstimatorSpec::named("lsq")
                    },
                    &names,
                    WindowSpec::Whole,
                    Solver::Fast,
                )?;
                let range = IdentificationRange::from_samples(&fit.model.set, &fit.training).ok();
                (
                    (
                        Box::new(AbkowitzDynamics(fit.model)),
                        Vec::new(),
                        "full74 LSQ fitted on the six clean default recordings, refined in the output-error sense (`shipid fit --refine`)".into(),
                    ),
                    range,
                )
            }
            spec => {
                let (b, e) = load_model_parts(spec)?;
                let range = training_data(spec).as_ref().and_then(identification_range);
                ((b, e, spec.to_string()), range)
            }
        };
    let opts = DiagnoseOptions::default();
    let mut input = DiagnoseInput {
        base: base.as_ref(),
        base_effects: &base_effects,
        model_level_over_l: None,
        // A polynomial base's leverage range, or a GP base's own coverage range.
        identification_range: BaseRange::of(range.as_ref(), base.sparse_gp()),
    };
    let level = model_level(&input, &clean, &opts);
    input.model_level_over_l = Some(level);
    let grid = cases(seeds, controls);
    let bar = ProgressBar::new(grid.len() as u64);
    if let Ok(style) = ProgressStyle::with_template("{bar:40} {pos}/{len} cases {elapsed} {msg}") {
        bar.set_style(style);
    }
    let rows: Vec<Result<Row, String>> = grid
        .par_iter()
        .map(|case| {
            let started = Instant::now();
            let effects: Vec<Effect> = case.effect.into_iter().collect();
            let data = generate_with(Some(case.seed), &effects)
                .map_err(|e| format!("{}: {e}", case.id))?;
            let ds = to_dataset(data, &case.id);
            let report = diagnose(&input, &ds, &opts)
                .ok_or_else(|| format!("{}: nothing to diagnose", case.id))?;
            let (truth_param, found_param) =
                recovered(case, &report.effects).map_or((None, None), |(t, f)| (Some(t), Some(f)));
            bar.inc(1);
            Ok(Row {
                verdict: report.verdict.clone(),
                before: report.fit_before.position_rmse_over_l,
                after: report.fit_after.position_rmse_over_l,
                detectable: false,
                truth_param,
                found_param,
                direction_error_deg: direction_error(case, &report.effects),
                effects: report.effects.join(" "),
                outside: report.outside_identification_range,
                time_s: started.elapsed().as_secs_f64(),
                case: case.clone(),
            })
        })
        .collect();
    bar.finish();
    let mut ok_rows = Vec::new();
    let mut failures = Vec::new();
    for r in rows {
        match r {
            Ok(r) => ok_rows.push(r),
            Err(e) => failures.push(e),
        }
    }
    let threshold = detectability_threshold(&ok_rows, level);
    for r in &mut ok_rows {
        r.detectable = r.case.word != "none" && r.before >= threshold;
    }
    let criterion = input.identification_range.map_or("", BaseRange::criterion);
    write_results(
        out, &ok_rows, level, threshold, &base_name, criterion, seeds,
    )
    .map_err(failed)?;
    for f in &failures {
        eprintln!("case failed: {f}");
    }
    Ok(if failures.is_empty() {
        Outcome::Ok
    } else {
        Outcome::SomeFailed
    })
}

/// Twice the base model's held-out position RMSE on effect-free recordings with the same noise (the
/// controls' mean; the model's own clean level when there are no controls): an effect case is
/// detectable when its concealed effect at least doubles that.
fn detectability_threshold(rows: &[Row], level: f64) -> f64 {
    let controls: Vec<f64> = rows
        .iter()
        .filter(|r| r.case.word == "none")
        .map(|r| r.before)
        .collect();
    if controls.is_empty() {
        2.0 * level
    } else {
        2.0 * controls.iter().sum::<f64>() / controls.len() as f64
    }
}

const WORDS: [&str; 8] = [
    "none",
    "current",
    "wind",
    "rudder_lag",
    "asymmetry",
    "shallow_water",
    "unexplained",
    "other",
];

fn write_results(
    out: &Path,
    rows: &[Row],
    level: f64,
    threshold: f64,
    base_name: &str,
    range_criterion: &str,
    seeds: u64,
) -> anyhow::Result<()> {
    let mut t = Table::default();
    let num = |f: &dyn Fn(&Row) -> Option<f64>| rows.iter().map(f).collect::<Vec<_>>();
    let text = |f: &dyn Fn(&Row) -> String| rows.iter().map(f).collect::<Vec<_>>();
    t.push_text("case", text(&|r| r.case.id.clone()));
    t.push_text("concealed", text(&|r| r.case.word.to_string()));
    t.push_text(
        "concealed_effect",
        text(&|r| r.case.effect.map_or("none".into(), |e| e.to_string())),
    );
    t.push_num("magnitude", num(&|r| Some(r.case.magnitude)));
    t.push_text("magnitude_name", text(&|r| r.case.magnitude_name.into()));
    t.push_num("seed", num(&|r| Some(r.case.seed as f64)));
    t.push_text("verdict", text(&|r| r.verdict.clone()));
    t.push_text("correct", text(&|r| (r.verdict == r.case.word).to_string()));
    t.push_text("detectable", text(&|r| r.detectable.to_string()));
    t.push_num("before_position_rmse_over_l", num(&|r| Some(r.before)));
    t.push_num("after_position_rmse_over_l", num(&|r| Some(r.after)));
    t.push_num(
        "reduction",
        num(&|r| {
            (r.verdict != "none" && r.verdict != "unexplained").then(|| 1.0 - r.after / r.before)
        }),
    );
    t.push_num("concealed_parameter", num(&|r| r.truth_param));
    t.push_num("recovered_parameter", num(&|r| r.found_param));
    t.push_num("direction_error_deg", num(&|r| r.direction_error_deg));
    t.push_text("found_effects", text(&|r| r.effects.clone()));
    t.push_num("outside_identification_range", num(&|r| r.outside));
    t.push_num("time_s", num(&|r| Some(r.time_s)));
    t.write(out, "cases")?;

    // Confusion matrix: rows concealed, columns verdict.
    let mut counts: BTreeMap<(&str, &str), usize> = BTreeMap::new();
    for r in rows {
        let v = WORDS
            .iter()
            .find(|w| **w == r.verdict)
            .copied()
            .unwrap_or("other");
        *counts.entry((r.case.word, v)).or_default() += 1;
    }
    let concealed: Vec<&str> = WORDS[..6].to_vec();
    let mut c = Table::default();
    c.push_text(
        "concealed",
        concealed.iter().map(|s| s.to_string()).collect(),
    );
    for v in WORDS {
        c.push_num(
            v,
            concealed
                .iter()
                .map(|k| Some(*counts.get(&(*k, v)).unwrap_or(&0) as f64))
                .collect(),
        );
    }
    c.write(out, "confusion")?;

    // Summary.
    let effect_rows: Vec<&Row> = rows.iter().filter(|r| r.case.word != "none").collect();
    let detectable: Vec<&&Row> = effect_rows.iter().filter(|r| r.detectable).collect();
    let correct_det = detectable
        .iter()
        .filter(|r| r.verdict == r.case.word)
        .count();
    let controls: Vec<&Row> = rows.iter().filter(|r| r.case.word == "none").collect();
    let false_claims = controls
        .iter()
        .filter(|r| r.verdict != "none" && r.verdict != "unexplained")
        .count();
    let controls_none = controls.iter().filter(|r| r.verdict == "none").count();
    let correct: Vec<&&Row> = effect_rows
        .iter()
        .filter(|r| r.verdict == r.case.word)
        .collect();
    let reduced_50 = correct.iter().filter(|r| r.after <= 0.5 * r.before).count();
    let mut md = String::new();
    md.push_str(&format!(
        "# Diagnosis benchmark\n\nBase model: {base_name}; its own level (segment replays on its clean training data): {level:.4} L. \
         {} cases: {} effect cases ({seeds} seeds × 5 effects × 4 magnitudes), {} controls; towing-tank noise with a seed per case.\n\n",
        rows.len(),
        effect_rows.len(),
        controls.len()
    ));
    md.push_str(&format!(
        "- Detectable effect cases (the effect at least doubles the model's held-out position RMSE on effect-free recordings, i.e. before ≥ {threshold:.4} L = twice the controls' mean): {} of {}; correct verdicts among them: {} ({:.0} %).\n",
        detectable.len(),
        effect_rows.len(),
        correct_det,
        100.0 * correct_det as f64 / detectable.len().max(1) as f64
    ));
    md.push_str(&format!(
        "- All effect cases: {} of {} correct.\n",
        correct.len(),
        effect_rows.len()
    ));
    md.push_str(&format!(
        "- Controls: {} of {} `none`, effects claimed on {} of them.\n",
        controls_none,
        controls.len(),
        false_claims
    ));
    md.push_str(&format!(
        "- Correct verdicts with the held-out position RMSE reduced by ≥ 50 %: {} of {}.\n",
        reduced_50,
        correct.len()
    ));
    let outside: Vec<f64> = rows.iter().filter_map(|r| r.outside).collect();
    if !outside.is_empty() {
        let short = correct
            .iter()
            .filter(|r| r.detectable && r.after > 0.5 * r.before)
            .filter_map(|r| Some(format!("{} {:.0} %", r.case.id, 100.0 * r.outside?)))
            .collect::<Vec<_>>();
        md.push_str(&format!(
            "- Recorded states outside the base model's identification range ({range_criterion}): at most {:.0} % in any case{}.\n",
            100.0 * outside.iter().cloned().fold(0.0f64, f64::max),
            if short.is_empty() {
                String::new()
            } else {
                format!(
                    "; in the detectable correct cases reduced by less than 50 %: {}",
                    short.join(", ")
                )
            }
        ));
    }
    let mean_time = rows.iter().map(|r| r.time_s).sum::<f64>() / rows.len().max(1) as f64;
    md.push_str(&format!(
        "- Mean wall time per case (generation + diagnosis, cases run two at a time): {mean_time:.1} s.\n\n"
    ));
    md.push_str("| effect | magnitude | correct / cases | detectable | mean reduction (correct) | concealed → recovered (mean) |\n|---|---|---|---|---|---|\n");
    let mut keys: Vec<(&str, f64)> = effect_rows
        .iter()
        .map(|r| (r.case.word, r.case.magnitude))
        .collect();
    keys.sort_by(|a, b| a.0.cmp(b.0).then(a.1.total_cmp(&b.1)));
    keys.dedup();
    for (w, m) in keys {
        let group: Vec<&&Row> = effect_rows
            .iter()
            .filter(|r| r.case.word == w && r.case.magnitude == m)
            .collect();
        let ok: Vec<&&&Row> = group.iter().filter(|r| r.verdict == w).collect();
        let det = group.iter().filter(|r| r.detectable).count();
        let red = if ok.is_empty() {
            "—".to_string()
        } else {
            format!(
                "{:.0} %",
                100.0 * ok.iter().map(|r| 1.0 - r.after / r.before).sum::<f64>() / ok.len() as f64
            )
        };
        let rec: Vec<(f64, f64)> = ok
            .iter()
            .filter_map(|r| Some((r.truth_param?, r.found_param?)))
            .collect();
        let rec = if rec.is_empty() {
            "—".into()
        } else {
            let n = rec.len() as f64;
            format!(
                "{:.3} → {:.3}",
                rec.iter().map(|x| x.0.abs()).sum::<f64>() / n,
                rec.iter().map(|x| x.1.abs()).sum::<f64>() / n
            )
        };
        md.push_str(&format!(
            "| {w} | {m} {} | {}/{} | {det}/{} | {red} | {rec} |\n",
            group[0].case.magnitude_name,
            ok.len(),
            group.len(),
            group.len()
        ));
    }
    md.push_str("\nConfusion matrix (rows: concealed, columns: verdict):\n\n| concealed |");
    for v in WORDS {
        md.push_str(&format!(" {v} |"));
    }
    md.push_str("\n|---|");
    for _ in WORDS {
        md.push_str("---|");
    }
    md.push('\n');
    for k in &concealed {
        md.push_str(&format!("| {k} |"));
        for v in WORDS {
            md.push_str(&format!(" {} |", counts.get(&(*k, v)).unwrap_or(&0)));
        }
        md.push('\n');
    }
    shipid_io::write::write_atomic(&out.join("summary.md"), md.as_bytes())?;
    println!("{md}");
    Ok(())
}
