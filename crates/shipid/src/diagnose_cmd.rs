//! `shipid diagnose MODEL DATASET [--json REPORT.json] [--plots DIR] [--model-out FILE]`: I/O around
//! [`crate::diagnose`].

use std::path::{Path, PathBuf};

use plotters::prelude::*;
use shipid_io::Dataset;
use shipid_io::write::write_atomic;
use shipid_model::{AugmentedModelFile, EffectEntry, ModelFile};
use shipid_sim::{Dynamics, Effect, WithEffects};

use crate::diagnose::{
    DiagnoseInput, DiagnoseOptions, Report, SegmentTrack, diagnose, model_level,
};
use crate::range::{identification_range, training_data};
use crate::simulate_cmd::load_model_parts;
use crate::validate::interp;
use crate::{CliError, Outcome, bad_input, failed};

/// The model's own level: segment replays on the recordings it was trained on.
fn own_level(
    training: &(Option<ModelFile>, Dataset, PathBuf),
    input: &DiagnoseInput,
    opts: &DiagnoseOptions,
) -> Option<(f64, String)> {
    let level = model_level(input, &training.1, opts);
    level
        .is_finite()
        .then(|| (level, training.2.display().to_string()))
}

pub fn run(
    model_spec: &str,
    dataset: &Path,
    json_out: Option<&Path>,
    plots: Option<&Path>,
    model_out: Option<&Path>,
    horizon_l_over_u0: f64,
) -> Result<Outcome, CliError> {
    if !(horizon_l_over_u0.is_finite() && horizon_l_over_u0 > 0.5) {
        return Err(bad_input(format!(
            "--horizon {horizon_l_over_u0}: must be a number of L/U0 above 0.5"
        )));
    }
    let (base, base_effects) = load_model_parts(model_spec)?;
    let ds = Dataset::load(dataset)?;
    let opts = DiagnoseOptions {
        horizon_l_over_u0,
        ..DiagnoseOptions::default()
    };
    let mut input = DiagnoseInput {
        base: base.as_ref(),
        base_effects: &base_effects,
        model_level_over_l: None,
        identification_range: None,
    };
    let training = training_data(model_spec);
    let range = training.as_ref().and_then(identification_range);
    let level = training.as_ref().and_then(|t| own_level(t, &input, &opts));
    input.model_level_over_l = level.as_ref().map(|l| l.0);
    input.identification_range = crate::diagnose::BaseRange::of(range.as_ref(), base.sparse_gp());
    let report = diagnose(&input, &ds, &opts).ok_or_else(|| {
        bad_input(format!(
            "{}: no recording with at least 20 samples to diagnose",
            dataset.display()
        ))
    })?;
    print_summary(
        &report,
        model_spec,
        dataset,
        level.as_ref().map(|l| l.1.as_str()),
    );
    if let Some(p) = json_out {
        let text = serde_json::to_string_pretty(&report).map_err(failed)?;
        write_atomic(p, text.as_bytes()).map_err(failed)?;
        println!("report: {}", p.display());
    }
    let augmented_path = model_out
        .map(Path::to_path_buf)
        .or_else(|| json_out.map(|p| p.with_extension("model.toml")));
    if !report.effects.is_empty() {
        match &augmented_path {
            Some(p) => {
                write_augmented(model_spec, &report, dataset, p)?;
                println!("augmented model: {}", p.display());
            }
            None => println!("(give --model-out FILE to write the augmented model)"),
        }
    }
    if let Some(dir) = plots {
        let effects: Vec<Effect> = report
            .effects
            .iter()
            .filter_map(|e| e.parse().ok())
            .collect();
        let mut all = base_effects.clone();
        all.retain(|b| !effects.iter().any(|e| e.kind() == b.kind()));
        all.extend(effects);
        let before = WithEffects::new(base.as_ref(), &base_effects).map_err(failed)?;
        let after = WithEffects::new(base.as_ref(), &all).map_err(failed)?;
        std::fs::create_dir_all(dir).map_err(failed)?;
        let residuals = crate::diagnose::normalised_residuals(&input, &ds, &opts);
        for (file, t, e) in &residuals {
            let path = dir.join(format!("{}-residuals.svg", file.trim_end_matches(".csv")));
            let windows: Vec<&crate::diagnose::Located> = report
                .located
                .iter()
                .filter(|l| &l.recording == file)
                .collect();
            residual_figure(&path, file, t, e, &windows)
                .map_err(|e| failed(anyhow::anyhow!("{}: {e}", path.display())))?;
        }
        for r in &ds.recordings {
            let path = dir.join(format!("{}-tracks.svg", r.file.trim_end_matches(".csv")));
            track_figure(
                &path,
                &r.file,
                &r.recording,
                &before,
                &after,
                report.horizon_s,
            )
            .map_err(|e| failed(anyhow::anyhow!("{}: {e}", path.display())))?;
        }
        println!("figures: {}", dir.display());
    }
    Ok(Outcome::Ok)
}

fn print_summary(r: &Report, model: &str, dataset: &Path, level_from: Option<&str>) {
    println!("diagnosis of {model} on {}", dataset.display());
    println!("verdict: {}", r.verdict);
    println!("  {}", r.explanation);
    match level_from {
        Some(from) => println!(
            "  model's own level (training data {from}): {:.4} L",
            r.model_level_position_rmse_over_l.unwrap_or(f64::NAN)
        ),
        // Without its own level an identified model's error counts as a real mismatch: say so.
        None if model.starts_with("mmg:") => {}
        None => println!(
            "  model's own level: unknown (the model file names no training data set that can be read from here); the mismatch is judged against the noise alone"
        ),
    }
    println!(
        "  held-out position RMSE over {:.0} s segments: {:.4} L before, {:.4} L after (noise floor {:.4} L)",
        r.horizon_s,
        r.fit_before.position_rmse_over_l,
        r.fit_after.position_rmse_over_l,
        r.noise_floor_position_rmse_over_l
    );
    if let Some(f) = r.outside_identification_range {
        let each: Vec<String> = r
            .per_recording
            .iter()
            .filter_map(|p| {
                let x = p.outside_identification_range?;
                (x > 0.0).then(|| format!("{} {:.0} %", p.recording, 100.0 * x))
            })
            .collect();
        println!(
            "  recorded states outside the model's identification range: {:.0} %{}",
            100.0 * f,
            if each.is_empty() {
                String::new()
            } else {
                format!(" ({})", each.join(", "))
            }
        );
    }
    for e in &r.effects {
        println!("  effect: {e}");
    }
    for (k, v) in &r.standard_errors {
        println!("    ± {k} {v:.4}");
    }
    println!(
        "  {:<16} {:>6} {:>10} {:>9} {:>8}",
        "candidate", "params", "held-out/L", "explains", "accepted"
    );
    for c in &r.candidates {
        println!(
            "  {:<16} {:>6} {:>10.4} {:>8.0}% {:>8}",
            c.effect,
            c.n_parameters,
            c.held_out_position_rmse_over_l,
            100.0 * c.explains,
            if c.accepted { "yes" } else { "no" }
        );
    }
    if !r.located.is_empty() {
        println!("  mismatch located (equation-error residual, mean ÷ noise scale):");
        for l in r.located.iter().take(6) {
            println!(
                "    {:<16} {:<5} {:>7.1}–{:<7.1} s {:+.2}",
                l.recording, l.dof, l.t_start, l.t_end, l.mean_residual_over_noise
            );
        }
    }
}

fn entries(r: &Report, dataset: &Path) -> Vec<EffectEntry> {
    r.effects
        .iter()
        .map(|e| {
            let kind = e.split(':').next().unwrap_or("");
            let multi = r.effects.len() > 1;
            EffectEntry {
                effect: e.clone(),
                source: format!(
                    "shipid {} diagnose on {} (fitted on all its recordings, equation error)",
                    env!("CARGO_PKG_VERSION"),
                    dataset.display()
                ),
                standard_error: r
                    .standard_errors
                    .iter()
                    .filter_map(|(k, v)| match k.split_once('.') {
                        Some((kk, key)) if multi && kk == kind => Some((key.to_string(), *v)),
                        None if !multi => Some((k.clone(), *v)),
                        _ => None,
                    })
                    .collect(),
            }
        })
        .collect()
}

/// The model with the found effects: a copy of the model file with `[[effects]]` when the base is a
/// model file, otherwise a `base = "mmg:…"` file.
fn write_augmented(
    model_spec: &str,
    r: &Report,
    dataset: &Path,
    out: &Path,
) -> Result<(), CliError> {
    let new = entries(r, dataset);
    let text = match std::fs::read_to_string(model_spec)
        .ok()
        .and_then(|t| toml::from_str::<ModelFile>(&t).ok())
    {
        Some(mut file) => {
            file.effects.retain(|b| {
                !new.iter()
                    .any(|n| n.effect.split(':').next() == b.effect.split(':').next())
            });
            file.effects.extend(new);
            toml::to_string(&file).map_err(failed)?
        }
        None => {
            let base = if model_spec.starts_with("mmg:") {
                model_spec.to_string()
            } else {
                std::path::absolute(model_spec)
                    .map(|p| p.display().to_string())
                    .unwrap_or_else(|_| model_spec.to_string())
            };
            toml::to_string(&AugmentedModelFile {
                shipid_version: env!("CARGO_PKG_VERSION").into(),
                base,
                effects: new,
            })
            .map_err(failed)?
        }
    };
    if let Some(parent) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(failed)?;
    }
    write_atomic(out, text.as_bytes()).map_err(failed)
}

/// Track of a recording with the segment replays of the model before and after the diagnosis, and
/// below it the replays' position error over time: on a track many ship lengths long a mismatch of a
/// few hundredths of L is invisible, its size over time is not.
fn track_figure(
    path: &Path,
    name: &str,
    rec: &shipid_io::Recording,
    before: &dyn Dynamics,
    after: &dyn Dynamics,
    horizon_s: f64,
) -> anyhow::Result<()> {
    let b = crate::diagnose::segment_tracks(before, rec, horizon_s);
    let a = crate::diagnose::segment_tracks(after, rec, horizon_s);
    let l = before.ship().lpp;
    let pts = |s: &SegmentTrack| -> Vec<(f64, f64)> {
        s.x0.iter()
            .zip(&s.y0)
            .map(|(n, e)| (e / l, n / l))
            .collect()
    };
    let mut xs: Vec<f64> = rec.y0.iter().map(|v| v / l).collect();
    let mut ys: Vec<f64> = rec.x0.iter().map(|v| v / l).collect();
    for s in b.iter().chain(&a) {
        xs.extend(s.y0.iter().map(|v| v / l));
        ys.extend(s.x0.iter().map(|v| v / l));
    }
    let range = |v: &[f64]| {
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let pad = 0.05 * (hi - lo).max(1.0);
        (lo - pad, hi + pad)
    };
    let (mut x0, mut x1) = range(&xs);
    let (mut y0, mut y1) = range(&ys);
    // Equal scales on both axes (a track is a shape): widen the narrower range about its centre to the
    // plotting area's aspect (about 835 × 715 px inside the labels).
    let aspect = 835.0 / 715.0;
    let (w, h) = (x1 - x0, y1 - y0);
    if w / h < aspect {
        let c = 0.5 * (x0 + x1);
        (x0, x1) = (c - 0.5 * h * aspect, c + 0.5 * h * aspect);
    } else {
        let c = 0.5 * (y0 + y1);
        (y0, y1) = (c - 0.5 * w / aspect, c + 0.5 * w / aspect);
    }
    let root = SVGBackend::new(path, (900, 1120)).into_drawing_area();
    root.fill(&WHITE)?;
    let (top, bottom) = root.split_vertically(800);
    let mut chart = ChartBuilder::on(&top)
        .caption(
            format!("{name}: recorded track and {horizon_s:.0} s segment replays"),
            ("sans-serif", 20),
        )
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart
        .configure_mesh()
        .x_desc("east y0 / L")
        .y_desc("north x0 / L")
        .draw()?;
    chart
        .draw_series(LineSeries::new(
            rec.x0.iter().zip(&rec.y0).map(|(n, e)| (e / l, n / l)),
            BLACK.stroke_width(2),
        ))?
        .label("recorded")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
    let red = RGBColor(214, 39, 40);
    let blue = RGBColor(31, 119, 180);
    let sides = [
        (&b, red, "model (before)"),
        (&a, blue, "model + effect (after)"),
    ];
    for (tracks, colour, label) in sides {
        for (i, s) in tracks.iter().enumerate() {
            let series = chart.draw_series(LineSeries::new(pts(s), colour.stroke_width(1)))?;
            if i == 0 {
                series
                    .label(label)
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
            }
        }
    }
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.6))
        .draw()?;

    // Distance between each replay and the recorded position at the same time, ÷ L.
    let errors = |tracks: &[SegmentTrack]| -> Vec<Vec<(f64, f64)>> {
        tracks
            .iter()
            .map(|s| {
                s.t_s
                    .iter()
                    .zip(s.x0.iter().zip(&s.y0))
                    .map(|(&t, (&n, &e))| {
                        let dn = n - interp(&rec.t, &rec.x0, t);
                        let de = e - interp(&rec.t, &rec.y0, t);
                        (t, dn.hypot(de) / l)
                    })
                    .collect()
            })
            .collect()
    };
    let (eb, ea) = (errors(&b), errors(&a));
    let top_error = eb
        .iter()
        .chain(&ea)
        .flatten()
        .map(|p| p.1)
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max)
        .max(1e-3);
    let t_end = rec.t.last().copied().unwrap_or(1.0).max(1e-3);
    let mut err_chart = ChartBuilder::on(&bottom)
        .caption(
            "position error of the segment replays ÷ L",
            ("sans-serif", 16),
        )
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..t_end, 0.0..1.05 * top_error)?;
    err_chart
        .configure_mesh()
        .x_desc("t [s]")
        .y_desc("|Δ position| / L")
        .draw()?;
    for (segs, colour) in [(&eb, red), (&ea, blue)] {
        for seg in segs.iter() {
            err_chart.draw_series(LineSeries::new(
                seg.iter().copied().filter(|p| p.1.is_finite()),
                colour.stroke_width(1),
            ))?;
        }
    }
    root.present()?;
    Ok(())
}

/// Equation-error residuals of one recording over time (each DOF ÷ its noise scale), with the located
/// windows shaded.
fn residual_figure(
    path: &Path,
    name: &str,
    t: &[f64],
    e: &[[f64; 3]],
    windows: &[&crate::diagnose::Located],
) -> anyhow::Result<()> {
    let root = SVGBackend::new(path, (1000, 800)).into_drawing_area();
    root.fill(&WHITE)?;
    let (t0, t1) = (
        t.first().copied().unwrap_or(0.0),
        t.last()
            .copied()
            .unwrap_or(1.0)
            .max(t.first().copied().unwrap_or(0.0) + 1.0),
    );
    let panels = root.split_evenly((3, 1));
    let dofs = ["surge", "sway", "yaw"];
    for (d, panel) in panels.iter().enumerate() {
        let lim = e
            .iter()
            .map(|x| x[d].abs())
            .fold(1.0f64, f64::max)
            .min(10.0);
        let mut chart = ChartBuilder::on(panel)
            .caption(
                if d == 0 {
                    format!(
                        "{name}: equation-error residual ÷ noise scale (shaded: located mismatch)"
                    )
                } else {
                    String::new()
                },
                ("sans-serif", 18),
            )
            .margin(10)
            .x_label_area_size(30)
            .y_label_area_size(50)
            .build_cartesian_2d(t0..t1, -lim..lim)?;
        chart
            .configure_mesh()
            .x_desc("t [s]")
            .y_desc(dofs[d])
            .draw()?;
        let shade = RGBColor(255, 200, 120).mix(0.5);
        for w in windows.iter().filter(|w| w.dof == dofs[d]) {
            chart.draw_series(std::iter::once(Rectangle::new(
                [(w.t_start, -lim), (w.t_end, lim)],
                shade.filled(),
            )))?;
        }
        chart.draw_series(LineSeries::new(
            t.iter().zip(e).map(|(&t, x)| (t, x[d].clamp(-lim, lim))),
            BLACK.stroke_width(1),
        ))?;
    }
    root.present()?;
    Ok(())
}
