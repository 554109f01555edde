//! `shipid diagnose MODEL DATASET [--json REPORT.json] [--plots DIR] [--model-out FILE] [--reveal]`:
//! I/O around [`shipid_diagnose::diagnose`]. Recorded wind and current are known inputs of the base;
//! `--reveal` conceals them on purpose and checks the verdict against them.

use std::path::Path;

use shipid_diagnose::{
    AugmentedModel, BaseRange, DiagnoseError, DiagnoseInput, DiagnoseOptions, Located, Report,
    augmented_model, conceal, diagnose, environments, model_level, normalised_residuals, reveal,
};
use shipid_figures::diagnosis::{residual_figure, track_figure};
use shipid_io::Dataset;
use shipid_io::write::write_atomic;
use shipid_model::ModelFile;
use shipid_pipeline::environment::ChosenWindage;
use shipid_pipeline::model_file::{
    files_hash, load_model_parts, reanchor_training, ship_mismatch, stored_path,
};
use shipid_pipeline::range::{TrainingData, TrainingSource, model_envelope, training_source};
use shipid_sim::{Effect, WithEffects};

use crate::{CliError, Outcome, bad_input, failed};

/// The model's own level: segment replays on the recordings it was trained on.
fn own_level(
    training: &TrainingData,
    input: &DiagnoseInput,
    opts: &DiagnoseOptions,
) -> Option<(f64, String)> {
    let level = model_level(input, &training.1, opts);
    level
        .is_finite()
        .then(|| (level, training.2.display().to_string()))
}

/// The model's training data, or why the diagnosis refuses: its threshold is the model's own level on
/// that data, and without it a model's ordinary error would be judged a real mismatch. A model that
/// names no training data (the reference, a hand-written file) is diagnosed against the noise alone,
/// with a warning.
fn training_for_diagnosis(model_spec: &str) -> Result<Option<TrainingData>, CliError> {
    match training_source(model_spec) {
        TrainingSource::Read {
            data,
            model,
            unverified,
        } => {
            if unverified {
                eprintln!(
                    "warning: {}: its training windows carry no `dataset_hash` (written by an older shipid): cannot check that {} is still the data it was fitted on",
                    model.display(),
                    data.2.display()
                );
            }
            Ok(Some(*data))
        }
        TrainingSource::NotRecorded => {
            if !model_spec.starts_with("mmg:") {
                eprintln!(
                    "warning: {model_spec}: the model names no training data, so its own error level is unknown: the mismatch is judged against the noise alone"
                );
            }
            Ok(None)
        }
        TrainingSource::Unavailable(why) => Err(bad_input(format!(
            "{why}\nthe model's own error level on its training data sets the diagnosis threshold, and it cannot be computed: refusing to judge the mismatch against the noise alone"
        ))),
    }
}

/// A diagnosis refused by the library: bad input, naming the data set.
fn refused(dataset: &Path, e: DiagnoseError) -> CliError {
    bad_input(format!("{}: {e}", dataset.display()))
}

/// Arguments of `shipid diagnose`.
pub struct DiagnoseArgs<'a> {
    pub model_spec: &'a str,
    pub dataset: &'a Path,
    pub json_out: Option<&'a Path>,
    pub plots: Option<&'a Path>,
    pub model_out: Option<&'a Path>,
    pub horizon_l_over_u0: f64,
    /// `--reveal`: conceal the recorded environment and check the verdict against it.
    pub reveal_check: bool,
    /// `--recording`: diagnose this recording of the data set alone.
    pub only_recording: Option<&'a str>,
}

pub fn run(args: &DiagnoseArgs) -> Result<Outcome, CliError> {
    let &DiagnoseArgs {
        model_spec,
        dataset,
        json_out,
        plots,
        model_out,
        horizon_l_over_u0,
        reveal_check,
        only_recording,
    } = args;
    if !(horizon_l_over_u0.is_finite() && horizon_l_over_u0 > 0.5) {
        return Err(bad_input(format!(
            "--horizon {horizon_l_over_u0}: must be a number of L/U0 above 0.5"
        )));
    }
    check_outputs(args)?;
    let (base, base_effects) = load_model_parts(model_spec)?;
    let mut ds = Dataset::load(dataset)?;
    if let Some(name) = only_recording {
        let names: Vec<String> = ds.recordings.iter().map(|r| r.file.clone()).collect();
        // The data set's own spelling of the name given (`./a.csv` for `a.csv`).
        let file = ds.recording(name).map(|r| r.file.clone());
        ds.recordings.retain(|r| Some(&r.file) == file.as_ref());
        if ds.recordings.is_empty() {
            return Err(bad_input(format!(
                "--recording {name}: {} has no such recording (it has: {})",
                dataset.display(),
                names.join(", ")
            )));
        }
    }
    // Checked before any work: a recorded environment that cannot be turned into forces is bad input.
    environments(&ds, &ChosenWindage::of_dataset(&ds)).map_err(|e| refused(dataset, e))?;
    let concealed = if reveal_check {
        Some(conceal(&mut ds).ok_or_else(|| {
            bad_input(format!(
                "--reveal: no recording of {} carries a recorded wind or current (columns wind_speed/wind_from or current_speed/current_from) to conceal and compare with",
                dataset.display()
            ))
        })?)
    } else {
        None
    };
    if let Some(m) = ship_mismatch(base.ship(), &ds.ship) {
        return Err(bad_input(format!(
            "{model_spec} on {}: {m}: a diagnosis would blame the difference on a missing effect",
            dataset.display()
        )));
    }
    let differences = shipid_pipeline::model_file::ship_differences(base.ship(), &ds.ship);
    if !differences.is_empty() {
        eprintln!(
            "warning: {model_spec} on {}: the ships differ ({}): a diagnosis may blame the difference on a missing effect; diagnose with a model of this ship",
            dataset.display(),
            differences.join("; ")
        );
    }
    // A horizon raised beyond every recording makes each segment a whole recording: the mismatch
    // could no longer be located in time, and a model's own drift would be blamed on an effect.
    // (Short recordings under the default horizon are diagnosed whole, as documented.)
    let l_over_u0_s = ds.ship.lpp / ds.ship.u0;
    let longest_s = ds
        .recordings
        .iter()
        .map(|r| r.recording.t.last().unwrap_or(&0.0) - r.recording.t.first().unwrap_or(&0.0))
        .fold(0.0, f64::max);
    if horizon_l_over_u0 > DiagnoseOptions::default().horizon_l_over_u0
        && horizon_l_over_u0 * l_over_u0_s > longest_s
    {
        return Err(bad_input(format!(
            "--horizon {horizon_l_over_u0} L/U0 ({:.0} s) is longer than every recording of {} (the longest lasts {:.0} s = {:.1} L/U0): segments would be whole recordings; the default is 10",
            horizon_l_over_u0 * l_over_u0_s,
            dataset.display(),
            longest_s,
            longest_s / l_over_u0_s
        )));
    }
    let training = training_for_diagnosis(model_spec)?;
    // Recordings all shorter than the horizon: the horizon is shortened to them, before the model's
    // own level is measured with it, and a note says so.
    let (opts, horizon_note) = DiagnoseOptions {
        horizon_l_over_u0,
        ..DiagnoseOptions::default()
    }
    .fitted_to(&ds)
    .map_err(|e| refused(dataset, e))?;
    let mut input = DiagnoseInput {
        base: base.as_ref(),
        base_effects: &base_effects,
        model_level_over_l: None,
        identification_range: None,
    };
    // A polynomial's own leverage, or the ellipsoid of an mmg model's training states.
    let envelope = training
        .is_some()
        .then(|| model_envelope(model_spec, base.as_ref()))
        .flatten();
    let level = training.as_ref().and_then(|t| own_level(t, &input, &opts));
    input.model_level_over_l = level.as_ref().map(|l| l.0);
    input.identification_range = BaseRange::of(
        envelope.as_ref().and_then(|e| e.leverage()),
        base.own_range(),
    );
    let mut report = diagnose(&input, &ds, &opts).map_err(|e| refused(dataset, e))?;
    // What was diagnosed against what, for a page rebuilt later from the report alone.
    report.model = Some(model_spec.to_string());
    report.dataset = Some(dataset.display().to_string());
    report.horizon_note = horizon_note;
    // A recording past the training extremes (a 45° turn of a model trained to 35°) is judged on the
    // model's extrapolation as much as on what the recordings add, however few of its states lie
    // outside the leverage ellipsoid: said, as validate says it.
    if let Some(e) = &envelope {
        for r in &ds.recordings {
            if let Some(reach) = e
                .reach(base.as_ref(), &r.recording)
                .filter(|reach| reach.clearly_beyond())
            {
                report.warnings.push(format!(
                    "{}: the recording goes past the extremes of the states {model_spec} was identified on ({}): its mismatch is partly the model's extrapolation, not only an effect the recordings add",
                    r.file,
                    reach.beyond().join(", ")
                ));
            }
        }
    }
    // A base without a propeller-rate input replays every recording at the rate it was identified
    // at: a recording made at another rate is a mismatch the diagnosis should not be blamed for.
    if !base.takes_propeller_rate() {
        report
            .warnings
            .extend(shipid_pipeline::validate::training_rate_mismatches(
                model_spec,
                &ds.recordings,
            ));
    }
    if let Some(c) = &concealed {
        let found: Vec<Effect> = report
            .effects
            .iter()
            .filter_map(|e| e.parse().ok())
            .collect();
        report.reveal = Some(reveal(
            report.verdict,
            &found,
            &report.per_recording_wind,
            c,
        ));
    }
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    print_summary(
        &report,
        model_spec,
        dataset,
        level.as_ref().map(|l| l.1.as_str()),
    );
    // With --plots the folder gets the JSON report too (unless --json puts it elsewhere): the HTML page
    // is built from it.
    let json_out = json_out
        .map(Path::to_path_buf)
        .or_else(|| plots.map(|d| d.join("report.json")));
    let json_out = json_out.as_deref();
    if let Some(p) = json_out {
        let text = serde_json::to_string_pretty(&report).map_err(failed)?;
        write_atomic(p, text.as_bytes()).map_err(|e| crate::write_failed(p, e))?;
        println!("report: {}", p.display());
    }
    let augmented_path = model_out
        .map(Path::to_path_buf)
        .or_else(|| json_out.map(|p| p.with_extension("model.toml")));
    let mut augmented_written = None;
    if !report.effects.is_empty() {
        match &augmented_path {
            Some(p) => {
                write_augmented(model_spec, &report, dataset, p)?;
                augmented_written = Some(p.clone());
                println!("augmented model: {}", p.display());
            }
            None => println!("(give --model-out FILE to write the augmented model)"),
        }
    } else if !report.per_recording_wind.is_empty() {
        println!(
            "no augmented model: a wind of its own on each run is the runs' environment, not the model's"
        );
    }
    // A script that reads the file it asked for next would otherwise fail, or read an older one.
    if augmented_written.is_none()
        && let Some(p) = model_out
    {
        let why = if report.per_recording_wind.is_empty() {
            "no effect found"
        } else {
            "each run has a wind of its own, not the model"
        };
        let older = if p.exists() {
            " (the file there is an earlier one, left as it was)"
        } else {
            ""
        };
        eprintln!(
            "warning: {why}: --model-out {} not written{older}",
            p.display()
        );
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
        std::fs::create_dir_all(dir).map_err(|e| crate::write_failed(dir, e))?;
        let residuals =
            normalised_residuals(&input, &ds, &opts).map_err(|e| refused(dataset, e))?;
        let envs =
            environments(&ds, &ChosenWindage::of_dataset(&ds)).map_err(|e| refused(dataset, e))?;
        for (file, t, e) in &residuals {
            let path = dir.join(format!("{}-residuals.svg", file.trim_end_matches(".csv")));
            let windows: Vec<&Located> = report
                .located
                .iter()
                .filter(|l| &l.recording == file)
                .collect();
            residual_figure(&path, file, t, e, &windows)
                .map_err(|e| failed(anyhow::anyhow!("{}: {e}", path.display())))?;
        }
        let windage = ChosenWindage::of_dataset(&ds);
        for (r, env) in ds.recordings.iter().zip(&envs) {
            let path = dir.join(format!("{}-tracks.svg", r.file.trim_end_matches(".csv")));
            // A recording's own wind, when the verdict gave each run one, is its "after".
            let own = report
                .per_recording_wind
                .iter()
                .find(|w| w.recording == r.file)
                .map(|w| own_wind_effect(w, &windage));
            let own_after = match own {
                Some(wind) => {
                    // It replaces a wind of the base's own, as a found effect does.
                    let mut with_own: Vec<Effect> = all
                        .iter()
                        .filter(|e| e.kind() != wind.kind())
                        .cloned()
                        .collect();
                    with_own.push(wind);
                    Some(WithEffects::new(base.as_ref(), &with_own).map_err(failed)?)
                }
                None => None,
            };
            track_figure(
                &path,
                &r.file,
                &r.recording,
                env.as_ref(),
                &before,
                own_after.as_ref().unwrap_or(&after),
                report.horizon_s,
            )
            .map_err(|e| failed(anyhow::anyhow!("{}: {e}", path.display())))?;
        }
        println!("figures: {}", dir.display());
        let files = shipid_report::DiagnosisFiles {
            report: json_out.map_or_else(|| dir.join("report.json"), Path::to_path_buf),
            figures: Some(dir.to_path_buf()),
            model: augmented_written,
        };
        let meta = shipid_report::RunMeta {
            tool_version: Some(env!("CARGO_PKG_VERSION").into()),
            name: Some(format!("diagnosis of {model_spec}")),
            dataset: Some(dataset.to_path_buf()),
            details: vec![("model".into(), model_spec.into())],
            ..shipid_report::RunMeta::default()
        };
        match shipid_report::diagnosis_page(&files, &meta)
            .and_then(|html| shipid_report::write_report(dir, &html))
        {
            Ok(p) => println!("report: {}", p.display()),
            Err(e) => eprintln!("warning: report: {e}"),
        }
    }
    Ok(Outcome::Ok)
}

/// Every path the diagnosis may write, checked before it starts: the report, the augmented model
/// (beside the report by default), the figures' folder, against each other and the files read.
fn check_outputs(a: &DiagnoseArgs) -> Result<(), CliError> {
    use crate::outputs::{Inputs, check_distinct, check_file, check_folder};
    let inputs = || Inputs::new().model(a.model_spec).dataset(a.dataset);
    if let Some(dir) = a.plots {
        check_folder("--plots", dir, &["report.json", "report.html"], &inputs())?;
    }
    let report = a
        .json_out
        .map(Path::to_path_buf)
        .or_else(|| a.plots.map(|d| d.join("report.json")));
    if let Some(p) = &report {
        crate::outputs::check_file_named("--json", p, "report.json", &inputs())?;
    }
    let model = a
        .model_out
        .map(Path::to_path_buf)
        .or_else(|| report.as_ref().map(|p| p.with_extension("model.toml")));
    if let Some(m) = &model {
        check_file("--model-out", m, &inputs())?;
        if let Some(r) = &report {
            check_distinct(("--json", r), ("--model-out", m))?;
        }
    }
    Ok(())
}

/// A recording's own wind as an effect acting on the data set's windage (as the diagnosis fitted it).
fn own_wind_effect(w: &shipid_diagnose::RecordingWind, windage: &ChosenWindage) -> Effect {
    let own = windage.source == shipid_pipeline::environment::WindageSource::Dataset;
    Effect::Wind(shipid_sim::effects::Wind {
        speed_m_s: w.speed_m_s,
        from_deg: w.from_deg,
        frontal_area_m2: own.then_some(windage.windage.frontal_area_m2),
        lateral_area_m2: own.then_some(windage.windage.lateral_area_m2),
        windage: Some(windage.windage.clone()),
    })
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
            "  model's own level: unknown (the model file names no training data); the mismatch is judged against the noise alone"
        ),
    }
    println!(
        "  held-out position RMSE over {:.0} s segments: {:.4} L before, {:.4} L after (noise floor {:.4} L)",
        r.horizon_s,
        r.fit_before.position_rmse_over_l,
        r.fit_after.position_rmse_over_l,
        r.noise_floor_position_rmse_over_l
    );
    if let Some(note) = &r.horizon_note {
        println!("  note: {note}");
    }
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
        println!("  effect: {}", effect_with_units(e, &r.standard_errors));
    }
    if let (false, Some(basis)) = (r.effects.is_empty(), &r.standard_error_basis) {
        println!("    (± one standard error: {})", basis.sentence());
    }
    if !r.per_recording_wind.is_empty() {
        println!(
            "  a wind of its own on each recording (speed [m/s], direction it comes from [deg, earth-fixed, clockwise from north]; held-out position RMSE ÷ L on the recording's time halves):"
        );
        let se = |x: Option<f64>| x.map_or(String::new(), |x| format!(" ± {x:.2}"));
        for w in &r.per_recording_wind {
            println!(
                "    {:<20} {:.2}{} m/s from {:.0}{}°   {:.4} L → {:.4} L",
                w.recording,
                w.speed_m_s,
                se(w.speed_standard_error_m_s),
                w.from_deg,
                se(w.from_standard_error_deg),
                w.before_position_rmse_over_l,
                w.after_position_rmse_over_l
            );
        }
    }
    if let Some(env) = &r.recorded_environment {
        let names = |f: &[shipid_diagnose::RecordedFlow]| {
            f.iter()
                .map(|x| x.recording.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        };
        if !env.wind.is_empty() {
            println!(
                "  recorded wind taken as a known input: {} (windage: {})",
                names(&env.wind),
                r.windage.description
            );
        }
        if !env.current.is_empty() {
            println!(
                "  recorded current taken as a known input: {}",
                names(&env.current)
            );
        }
    }
    if let Some(check) = &r.reveal {
        for line in check.lines() {
            println!("  {line}");
        }
    }
    // Combined candidates ("asymmetry [rudder_offset] + wind") are long: the name column takes the
    // widest title so that the numbers stay in their columns.
    let name_width = r
        .candidates
        .iter()
        .map(|c| c.title().chars().count())
        .max()
        .unwrap_or(0)
        .max("candidate".len());
    println!(
        "  {:<name_width$} {:>6} {:>10} {:>9} {:>8}",
        "candidate", "params", "held-out/L", "explains", "accepted"
    );
    for c in &r.candidates {
        println!(
            "  {:<name_width$} {:>6} {:>10.4} {:>8.0}% {:>8}",
            c.title(),
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

/// The model with the found effects (see [`augmented_model`]), written to `out`.
fn write_augmented(
    model_spec: &str,
    r: &Report,
    dataset: &Path,
    out: &Path,
) -> Result<(), CliError> {
    let source = format!(
        "shipid {} diagnose on {} (fitted on all its recordings, equation error)",
        env!("CARGO_PKG_VERSION"),
        dataset.display()
    );
    let base_path = Path::new(model_spec);
    // A copy keeps the base's training windows: their paths, relative to the base, are made relative
    // to the copy.
    let base_file = std::fs::read_to_string(base_path)
        .ok()
        .and_then(|t| toml::from_str::<ModelFile>(&t).ok())
        .map(|mut f| {
            reanchor_training(&mut f.training, base_path, out);
            f
        });
    let (base_ref, base_hash) = if model_spec.starts_with("mmg:") {
        (model_spec.to_string(), None)
    } else {
        (
            stored_path(out, base_path),
            Some(files_hash(&[base_path]).map_err(failed)?),
        )
    };
    let text = match augmented_model(
        base_file,
        base_ref,
        base_hash,
        r.effect_entries(&source),
        env!("CARGO_PKG_VERSION"),
    ) {
        AugmentedModel::Copy(file) => toml::to_string(&file),
        AugmentedModel::Wrapper(file) => toml::to_string(&file),
    }
    .map_err(failed)?;
    if let Some(parent) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|e| crate::write_failed(parent, e))?;
    }
    write_atomic(out, text.as_bytes()).map_err(|e| crate::write_failed(out, e))
}

/// An effect as the diagnosis found it: its string form as `--effect` reads it (six significant
/// digits), then each parameter with its unit and standard error.
fn effect_with_units(
    effect_text: &str,
    standard_errors: &std::collections::BTreeMap<String, f64>,
) -> String {
    let Ok(effect) = effect_text.parse::<shipid_sim::Effect>() else {
        return effect_text.to_string();
    };
    let parameters = effect.parameters();
    let canonical = format!(
        "{}:{}",
        effect.kind(),
        parameters
            .iter()
            .map(|(k, v)| format!("{k}={}", significant(*v, 6)))
            .collect::<Vec<_>>()
            .join(",")
    );
    let described: Vec<String> = parameters
        .iter()
        .map(|(k, v)| {
            let unit = shipid_sim::Effect::parameter_unit(k);
            let se = standard_errors
                .get(*k)
                .or_else(|| standard_errors.get(&format!("{}.{k}", effect.kind())))
                .map_or(String::new(), |s| format!(" ± {}", significant(*s, 2)));
            format!(
                "{k} {}{se}{}",
                significant(*v, 4),
                if unit.is_empty() {
                    String::new()
                } else {
                    format!(" {unit}")
                }
            )
        })
        .collect();
    format!("{canonical} ({})", described.join(", "))
}

/// `x` with `digits` significant digits, without trailing zeros.
fn significant(x: f64, digits: usize) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let magnitude = x.abs().log10().floor() as i32;
    let decimals = (digits as i32 - 1 - magnitude).max(0) as usize;
    let text = format!("{x:.decimals$}");
    if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        text
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression: the found effect was printed as `asymmetry:offset=0.9756141492521352` and its
    /// standard errors as bare `± offset 0.0366` lines, without units.
    #[test]
    fn a_found_effect_is_printed_with_units_and_its_standard_errors() {
        let se = std::collections::BTreeMap::from([("offset".to_string(), 0.0366)]);
        assert_eq!(
            effect_with_units(
                "asymmetry:offset=0.9756141492521352,y0=0,n0=-0.899671016418675",
                &se
            ),
            "asymmetry:offset=0.975614,y0=0,n0=-0.899671 (offset 0.9756 ± 0.037 deg, y0 0 N, n0 -0.8997 N m)"
        );
        assert_eq!(significant(241.0764, 4), "241.1");
        assert_eq!(significant(0.000123456, 2), "0.00012");
    }
}
