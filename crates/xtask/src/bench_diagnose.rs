//! `cargo xtask bench-diagnose`: the concealed-effect benchmark of the diagnosis (the grid, per-case
//! diagnosis and scoring live in `shipid_diagnose::bench`): builds the base model, runs the cases in
//! parallel with a progress bar and writes `cases.csv/.parquet`, `confusion.csv/.parquet` and
//! `summary.md` into `--out`.

use std::path::Path;

use anyhow::{Result, bail};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use shipid_diagnose::bench::{
    BenchRow, WORDS, cases, confusion, mark_detectable, run_case, summary_markdown, to_dataset,
};
use shipid_diagnose::{BaseRange, DiagnoseInput, DiagnoseOptions, model_level};
use shipid_estimators::Solver;
use shipid_model::IdentificationRange;
use shipid_pipeline::fit::{EstimatorSpec, WindowSpec, fit_dataset, load_set};
use shipid_pipeline::fit_gp::{DEFAULT_SIMILARITY, fit_gp_dataset};
use shipid_pipeline::generate::generate_with;
use shipid_pipeline::model_file::load_model_parts;
use shipid_pipeline::range::{identification_range, training_data};
use shipid_sim::{AbkowitzDynamics, Dynamics, Effect};
use shipid_tables::Table;

/// `--base` keyword for a sparse GP fitted in memory on the clean default data (the default: the
/// base with which the benchmark meets every floor of the diagnosis, README).
pub const GP_BASE: &str = "sparse-gp";
/// `--base` keyword for full74 LSQ fitted in memory on the clean default data and refined.
pub const FULL74_BASE: &str = "full74";

pub fn run(base_spec: &str, out: &Path, seeds: u64, controls: u64) -> Result<bool> {
    if [GP_BASE, FULL74_BASE].contains(&base_spec) && Path::new(base_spec).exists() {
        bail!(
            "--base {base_spec}: both a base keyword and a file here; pass ./{base_spec} for the file"
        );
    }
    let clean = to_dataset(generate_with(None, &[])?, "embedded default data (clean)");
    // The in-memory bases are fitted on every clean recording.
    let names: Vec<String> = clean.recordings.iter().map(|r| r.file.clone()).collect();
    type Base = (Box<dyn Dynamics + Send + Sync>, Vec<Effect>, String);
    let ((base, base_effects, base_name), range): (Base, Option<IdentificationRange>) =
        match base_spec {
            GP_BASE => {
                let (_, gp, report) =
                    fit_gp_dataset(&clean, &names, WindowSpec::Whole, DEFAULT_SIMILARITY)?;
                (
                    (
                        Box::new(gp),
                        Vec::new(),
                        format!(
                            "sparse GP (paper 001, d_gen {}: {} of {} samples kept) fitted on the six clean default recordings (`shipid fit --estimator sparse-gp`)",
                            DEFAULT_SIMILARITY, report.kept, report.candidates
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
        identification_range: BaseRange::of(range.as_ref(), base.own_range()),
    };
    let level = model_level(&input, &clean, &opts);
    input.model_level_over_l = Some(level);
    let grid = cases(seeds, controls);
    let bar = ProgressBar::new(grid.len() as u64);
    if let Ok(style) = ProgressStyle::with_template("{bar:40} {pos}/{len} cases {elapsed} {msg}") {
        bar.set_style(style);
    }
    let rows: Vec<Result<BenchRow, String>> = grid
        .par_iter()
        .map(|case| {
            let row = run_case(&input, &opts, case);
            bar.inc(1);
            row
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
    let threshold = mark_detectable(&mut ok_rows, level);
    let criterion = input.identification_range.map_or("", BaseRange::criterion);
    write_results(
        out, &ok_rows, level, threshold, &base_name, criterion, seeds,
    )?;
    for f in &failures {
        eprintln!("case failed: {f}");
    }
    Ok(failures.is_empty())
}

fn write_results(
    out: &Path,
    rows: &[BenchRow],
    level: f64,
    threshold: f64,
    base_name: &str,
    range_criterion: &str,
    seeds: u64,
) -> Result<()> {
    let mut t = Table::default();
    let num = |f: &dyn Fn(&BenchRow) -> Option<f64>| rows.iter().map(f).collect::<Vec<_>>();
    let text = |f: &dyn Fn(&BenchRow) -> String| rows.iter().map(f).collect::<Vec<_>>();
    t.push_text("case", text(&|r| r.case.id.clone()));
    t.push_text("concealed", text(&|r| r.case.concealed.to_string()));
    t.push_text(
        "concealed_effect",
        text(&|r| {
            r.case
                .effect
                .as_ref()
                .map_or("none".into(), |e| e.to_string())
        }),
    );
    t.push_num("magnitude", num(&|r| Some(r.case.magnitude)));
    t.push_text("magnitude_name", text(&|r| r.case.magnitude_name.into()));
    t.push_num("seed", num(&|r| Some(r.case.seed as f64)));
    t.push_text("verdict", text(&|r| r.verdict.to_string()));
    t.push_text("correct", text(&|r| r.correct().to_string()));
    t.push_text("detectable", text(&|r| r.detectable.to_string()));
    t.push_num("before_position_rmse_over_l", num(&|r| Some(r.before)));
    t.push_num("after_position_rmse_over_l", num(&|r| Some(r.after)));
    t.push_num(
        "reduction",
        num(&|r| r.verdict.names_effect().then(|| 1.0 - r.after / r.before)),
    );
    t.push_num("concealed_parameter", num(&|r| r.truth_param));
    t.push_num("recovered_parameter", num(&|r| r.found_param));
    t.push_num("direction_error_deg", num(&|r| r.direction_error_deg));
    t.push_text("found_effects", text(&|r| r.effects.clone()));
    t.push_num("outside_identification_range", num(&|r| r.outside));
    t.push_num("time_s", num(&|r| Some(r.time_s)));
    t.write(out, "cases")?;

    // Confusion matrix: rows concealed, columns verdict.
    let counts = confusion(rows);
    let mut c = Table::default();
    c.push_text(
        "concealed",
        counts.iter().map(|(k, _)| k.to_string()).collect(),
    );
    for (j, v) in WORDS.iter().enumerate() {
        c.push_num(v, counts.iter().map(|(_, n)| Some(n[j] as f64)).collect());
    }
    c.write(out, "confusion")?;

    let md = summary_markdown(rows, level, threshold, base_name, range_criterion, seeds);
    shipid_io::write::write_atomic(&out.join("summary.md"), md.as_bytes())?;
    println!("{md}");
    Ok(())
}
