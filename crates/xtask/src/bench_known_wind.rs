//! `cargo xtask bench-known-wind`: the proof of the diagnosis with a recorded wind as known input
//! (issue 27 item 4; the generator, grid, per-case diagnosis and scoring live in
//! `shipid_diagnose::known_wind`). Identifies each base from training runs that carry a recorded wind,
//! with the wind as input, runs the cases in parallel and writes `cases.csv/.parquet` and `summary.md`
//! into `--out`. Two grids per base: one wind for all the runs of a case, and a wind of its own on
//! each run (trials meet a different wind on every run), each with controls that keep the channels.

use std::path::Path;

use anyhow::{Result, anyhow};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use shipid_diagnose::known_wind::{
    KnownWindRow, OWN_WIND_SPREAD_M_S, cases, hydrodynamic_dataset, own_wind_cases, run_case,
    summary_markdown, training_dataset,
};
use shipid_diagnose::{BaseRange, DiagnoseInput, DiagnoseOptions, model_level};
use shipid_estimators::Solver;
use shipid_model::IdentificationRange;
use shipid_pipeline::fit::{EstimatorSpec, WindowSpec, fit_dataset, load_set};
use shipid_pipeline::fit_gp::{DEFAULT_SIMILARITY, fit_gp_dataset};
use shipid_pipeline::mmg::{MmgFitOptions, fit_mmg_dataset};
use shipid_sim::{AbkowitzDynamics, Dynamics};
use shipid_tables::Table;

/// The base families of the benchmark, as `--bases` names them.
pub const BASES: [&str; 3] = ["full74", "mmg", "sparse-gp"];

/// A base identified from the training runs with their recorded wind as input, its name and its
/// identification range when it has a leverage one.
type Base = (
    Box<dyn Dynamics + Send + Sync>,
    String,
    Option<IdentificationRange>,
);

fn identify(kind: &str) -> Result<Base> {
    let training = training_dataset().map_err(|e| anyhow!(e))?;
    let hydro = hydrodynamic_dataset(&training).map_err(|e| anyhow!(e))?;
    let names: Vec<String> = hydro.recordings.iter().map(|r| r.file.clone()).collect();
    let said = "fitted on the six training runs, each in its own recorded wind (1.5–4.5 m/s from any direction, gusts 15 %), with the wind as input";
    Ok(match kind {
        "full74" => {
            let fit = fit_dataset(
                &hydro,
                load_set("full74")?,
                &EstimatorSpec::named("lsq"),
                &names,
                WindowSpec::Whole,
                Solver::Fast,
            )?;
            let range = IdentificationRange::from_samples(&fit.model.set, &fit.training).ok();
            (
                Box::new(AbkowitzDynamics(fit.model)),
                format!("polynomial full74 LSQ {said}"),
                range,
            )
        }
        "mmg" => {
            let fit = fit_mmg_dataset(&hydro, &MmgFitOptions::default())?;
            (
                Box::new(fit.model),
                format!("mmg family (bounded LSQ with priors) {said}"),
                None,
            )
        }
        "sparse-gp" => {
            let (_, gp, report) =
                fit_gp_dataset(&hydro, &names, WindowSpec::Whole, DEFAULT_SIMILARITY)?;
            (
                Box::new(gp),
                format!(
                    "sparse GP (d_gen {DEFAULT_SIMILARITY}: {} of {} samples kept) {said}",
                    report.kept, report.candidates
                ),
                None,
            )
        }
        other => {
            return Err(anyhow!(
                "--bases {other}: expected one of {}",
                BASES.join(", ")
            ));
        }
    })
}

pub fn run(bases: &[String], out: &Path, seeds: u64) -> Result<bool> {
    let training = training_dataset().map_err(|e| anyhow!(e))?;
    let mut grid = cases(seeds);
    grid.extend(own_wind_cases(seeds));
    let opts = DiagnoseOptions::default();
    let mut all_rows: Vec<(String, KnownWindRow)> = Vec::new();
    let mut md = format!(
        "# Diagnosis with a recorded wind as known input\n\nData from `shipid generate --recorded-wind` (`pipeline::generate::generate_recorded`). Training: the six default manoeuvres, each in its own recorded wind, noise-free; the base is identified with the wind as input. Cases: other runs of the six manoeuvres in one wind per case (steady, or gusty: turbulence intensity 30 %, correlation time 2 s), towing-tank noise on the motion and anemometer noise on the wind channels; wind cases conceal the wind channels, controls keep them. Own-wind cases: each of the six runs in its own steady wind (speed within ±{OWN_WIND_SPREAD_M_S} m/s of the case's strength, direction from anywhere), concealed; right when the verdict is `wind` in its per-recording form (and, for the one-wind cases, in its one-wind form). {seeds} seeds.\n\n"
    );
    let mut failures = Vec::new();
    for kind in bases {
        let (base, name, range) = identify(kind)?;
        let mut input = DiagnoseInput {
            base: base.as_ref(),
            base_effects: &[],
            model_level_over_l: None,
            identification_range: BaseRange::of(range.as_ref(), base.own_range()),
        };
        let level = model_level(&input, &training, &opts);
        input.model_level_over_l = Some(level);
        let bar = ProgressBar::new(grid.len() as u64);
        if let Ok(style) =
            ProgressStyle::with_template("{bar:40} {pos}/{len} cases {elapsed} {msg}")
        {
            bar.set_style(style);
        }
        bar.set_message(kind.clone());
        let rows: Vec<Result<KnownWindRow, String>> = grid
            .par_iter()
            .map(|case| {
                let row = run_case(&input, &opts, case);
                bar.inc(1);
                row
            })
            .collect();
        bar.finish();
        let mut ok = Vec::new();
        for r in rows {
            match r {
                Ok(r) => ok.push(r),
                Err(e) => failures.push(format!("{kind}: {e}")),
            }
        }
        md.push_str(&summary_markdown(&ok, &name, level));
        all_rows.extend(ok.into_iter().map(|r| (kind.clone(), r)));
    }
    write_cases(out, &all_rows)?;
    shipid_io::write::write_atomic(&out.join("summary.md"), md.as_bytes())?;
    println!("{md}");
    for f in &failures {
        eprintln!("case failed: {f}");
    }
    Ok(failures.is_empty())
}

fn write_cases(out: &Path, rows: &[(String, KnownWindRow)]) -> Result<()> {
    let mut t = Table::default();
    let num = |f: &dyn Fn(&KnownWindRow) -> Option<f64>| {
        rows.iter().map(|(_, r)| f(r)).collect::<Vec<_>>()
    };
    let text =
        |f: &dyn Fn(&KnownWindRow) -> String| rows.iter().map(|(_, r)| f(r)).collect::<Vec<_>>();
    t.push_text("base", rows.iter().map(|(b, _)| b.clone()).collect());
    t.push_text("case", text(&|r| r.case.id.clone()));
    t.push_text("control", text(&|r| r.case.control.to_string()));
    t.push_text("own_winds", text(&|r| r.case.own_winds.to_string()));
    t.push_num("wind_speed_m_s", num(&|r| Some(r.case.wind.speed_m_s)));
    // An own-wind case draws each run's direction: no direction of the case.
    t.push_num(
        "wind_from_deg",
        num(&|r| (!r.case.own_winds).then_some(r.case.wind.from_deg)),
    );
    t.push_num("gust", num(&|r| Some(r.case.wind.gust)));
    t.push_num("seed", num(&|r| Some(r.case.seed as f64)));
    t.push_num(
        "recorded_speed_mean_m_s",
        num(&|r| Some(r.recorded.speed_mean_m_s)),
    );
    t.push_num(
        "recorded_from_mean_deg",
        num(&|r| Some(r.recorded.from_mean_deg)),
    );
    t.push_text("verdict", text(&|r| r.verdict.to_string()));
    t.push_text("per_recording", text(&|r| r.per_recording.to_string()));
    t.push_text("correct", text(&|r| r.correct().to_string()));
    t.push_text("meets_targets", text(&|r| r.meets_targets().to_string()));
    t.push_num("before_position_rmse_over_l", num(&|r| Some(r.before)));
    t.push_num("after_position_rmse_over_l", num(&|r| Some(r.after)));
    t.push_num("improvement", num(&|r| Some(r.improvement())));
    t.push_num("found_speed_m_s", num(&|r| r.found_speed_m_s()));
    // Own-wind cases: the largest over the runs; the runs' errors are in `own_errors`.
    t.push_num("direction_error_deg", num(&|r| r.direction_error_deg()));
    t.push_text(
        "own_errors",
        text(&|r| {
            r.own_errors()
                .map(|e| {
                    e.iter()
                        .map(|(s, d)| format!("{s:+.3} m/s {d:.1} deg"))
                        .collect::<Vec<_>>()
                        .join("; ")
                })
                .unwrap_or_default()
        }),
    );
    t.push_text("found_effects", text(&|r| r.effects.clone()));
    t.push_num("time_s", num(&|r| Some(r.time_s)));
    t.write(out, "cases")?;
    Ok(())
}
