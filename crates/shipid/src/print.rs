//! Printing shared by several commands (the binary's only shared output code).

use serde_json::{Map, Value, json};
use shipid_io::Dataset;
use shipid_pipeline::validate::{RangeSource, validate_dataset};
use shipid_sim::Dynamics;

use crate::Outcome;

/// What a model's training data lets a command say about its identification range (`what`: where
/// the command shows it): empty when the range can be given or the model names none to give (the
/// reference), else why it is unavailable or unverified. `validate` and `simulate` say the same.
pub fn training_range_warnings(model_spec: &str, what: &str) -> Vec<String> {
    use shipid_pipeline::range::{TrainingSource, training_source};
    match training_source(model_spec) {
        TrainingSource::Read {
            unverified: true,
            model,
            data,
        } => vec![format!(
            "{}: its training windows carry no `dataset_hash` (written by an older shipid): cannot check that {} is still the data it was fitted on; the identification range assumes it is",
            model.display(),
            data.2.display()
        )],
        TrainingSource::Read { .. } => vec![],
        TrainingSource::NotRecorded if model_spec.starts_with("mmg:") => vec![],
        TrainingSource::NotRecorded => vec![format!(
            "{model_spec}: the model names no training data: the identification range ({what}) is unavailable"
        )],
        TrainingSource::Unavailable(why) => vec![format!(
            "{why}; the identification range ({what}) is unavailable"
        )],
    }
}

/// Where a model file's `[ship]` is not its training data set's (`training`: that data set's ship
/// and path, as the model's envelope read it): the file was edited after the fit (or assembled from
/// two), and its predictions, scaled by its own ship, and its identification range, read from the
/// data, do not belong together. `simulate` of a file with U0 edited tenfold predicted a 49.5°
/// overshoot (14.3° true) "0 % outside" without a word; `validate` compares the ship with the data
/// set it is given, which is usually the same check.
pub fn training_ship_warnings(
    model_spec: &str,
    model_ship: &shipid_io::Ship,
    training: Option<&(shipid_io::Ship, std::path::PathBuf)>,
) -> Vec<String> {
    use shipid_pipeline::model_file::{ship_differences, ship_mismatch};
    let Some((ship, path)) = training else {
        return Vec::new();
    };
    let mut differences: Vec<String> = ship_mismatch(model_ship, ship)
        .map(|m| m.to_string())
        .into_iter()
        .collect();
    differences.extend(ship_differences(model_ship, ship));
    if differences.is_empty() {
        return Vec::new();
    }
    vec![format!(
        "{model_spec}: its [ship] is not the ship of its training data {} ({}): the file was edited after the fit, or describes another ship than the one it was fitted on; its predictions and its identification range do not belong together",
        path.display(),
        differences.join("; ")
    )]
}

/// Validates `model` on every recording of `ds` and prints the table (or the JSON with `as_json`);
/// `SomeFailed` when a simulation diverged.
pub fn validation(model: &dyn Dynamics, model_spec: &str, ds: &Dataset, as_json: bool) -> Outcome {
    validation_with_bands(model, model_spec, ds, as_json, None, None, None)
}

/// The JSON report `shipid validate MODEL DATASET --json` prints, returned instead of printed (for a
/// command that puts it beside its own report), with the validation's outcome.
pub fn validation_value(model: &dyn Dynamics, model_spec: &str, ds: &Dataset) -> (Value, Outcome) {
    let mut value = Value::Null;
    let outcome = validation_into(
        model,
        model_spec,
        ds,
        Emit::Into(&mut value),
        None,
        None,
        None,
    );
    (value, outcome)
}

/// Where a validation's report goes: the table on stdout, the JSON on stdout, or the JSON into a
/// value for the caller.
enum Emit<'a> {
    Text,
    Json,
    Into(&'a mut Value),
}

/// Recorded metrics against a range over models beside the point model, by recording and metric:
/// `{recorded, predicted, <range>: [lo, hi], inside}`.
fn range_rows_by_recording(
    rows: &[shipid_pipeline::bands::RangeRow],
    range: &str,
) -> Map<String, Value> {
    let mut per: Map<String, Value> = Map::new();
    for (file, metric, recorded, predicted, (lo, hi), inside) in rows {
        if let Value::Object(m) = per
            .entry(file.clone())
            .or_insert_with(|| Value::Object(Map::new()))
        {
            m.insert(
                (*metric).into(),
                json!({ "recorded": recorded, "predicted": predicted, range: [lo, hi], "inside": inside }),
            );
        }
    }
    per
}

/// The table of [`range_rows_by_recording`], with the count inside and what it means.
fn print_range_rows(rows: &[shipid_pipeline::bands::RangeRow], range: &str, inside_means: &str) {
    println!(
        "{:<16} {:<18} {:>5} {:>10} {:>10} {:>22} {:>7}",
        "recording", "metric", "unit", "recorded", "predicted", range, "inside"
    );
    for (file, metric, recorded, predicted, (lo, hi), inside) in rows {
        let unit = shipid_sim::metrics::metric_unit(metric).unwrap_or("");
        println!(
            "{file:<16} {metric:<18} {unit:>5} {recorded:>10.4} {predicted:>10.4} {:>22} {:>7}",
            format!("[{lo:.4}, {hi:.4}]"),
            if *inside { "yes" } else { "no" }
        );
    }
    let inside = rows.iter().filter(|r| r.5).count();
    println!(
        "inside: {inside} of {} recorded metrics {inside_means}",
        rows.len()
    );
}

/// The bands `validate --bands LEVEL` checks the recorded metrics against: calibrated when the
/// model file has a `[calibration]`, else its replicates' percentiles.
pub struct BandCheck<'a> {
    pub level: f64,
    pub source: &'a shipid_pipeline::calibration::ModelBands,
}

/// Each recorded metric against its band: `(recording, metric, recorded, band or why none, inside)`.
type BandRow = (
    String,
    &'static str,
    f64,
    Result<(f64, f64), String>,
    Option<bool>,
);

/// The band rows of every recording with a standard manoeuvre ([`BandRows`]).
fn band_rows(model: &dyn Dynamics, model_spec: &str, ds: &Dataset, check: &BandCheck) -> BandRows {
    let mut rows = Vec::new();
    let mut unbanded = Vec::new();
    let mut diverged = 0;
    // Once: the model file's windage is read from disk.
    let windage = shipid_pipeline::validate::validation_windage(model_spec, ds);
    let mut reaches = Map::new();
    let banded: Vec<_> = ds
        .recordings
        .iter()
        .filter(|r| !matches!(r.manoeuvre, shipid_io::Manoeuvre::Free))
        .collect();
    // Every recording re-simulates all the replicates (a sparse GP's 200 draws over six recordings
    // take half a minute): a bar on stderr says how far it is (indicatif draws it only on a
    // terminal, so stdout and --json stay clean).
    let bar = band_progress(banded.len(), check.source.replicates(), check.source.noun());
    for r in banded {
        bar.set_message(r.file.clone());
        bar.inc(0);
        let env = shipid_pipeline::validate::validation_environment(&windage, ds, r);
        let run = check.source.bands(
            model,
            &r.manoeuvre,
            &ds.ship,
            check.level,
            // The band goes with validate's own prediction: the recording's manoeuvre re-simulated
            // from its recorded initial state (in its recorded wind and current), not a standard
            // approach at U0.
            shipid_pipeline::bands::BandRun::Recording(r, env.as_ref()),
        );
        bar.inc(1);
        let run = match run {
            Ok(run) => run,
            Err(e) => {
                unbanded.push(format!("{}: {e}", r.file));
                continue;
            }
        };
        if let Some(reach) = run.reach {
            reaches.insert(r.file.clone(), json!(reach));
        }
        let bands = run.bands;
        diverged += bands.diverged;
        let recorded = shipid_sim::metrics(&r.recording, &r.manoeuvre, &ds.ship);
        for (b, (_, value)) in bands.metrics.iter().zip(recorded.entries()) {
            let Some(value) = value else { continue };
            let band = b
                .band
                .as_ref()
                .map(|x| (x.lo, x.hi))
                .map_err(|e| e.to_string());
            let inside = band
                .as_ref()
                .ok()
                .map(|(lo, hi)| *lo <= value && value <= *hi);
            rows.push((r.file.clone(), b.metric, value, band, inside));
        }
    }
    bar.finish_and_clear();
    BandRows {
        rows,
        diverged,
        reaches,
        unbanded,
    }
}

/// The progress of `validate --bands` on stderr: one step per recording, each re-simulating
/// `replicates` models (`noun`: what they are), with the recording running as its message.
pub fn band_progress(recordings: usize, replicates: usize, noun: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(recordings as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(&format!(
            "{{spinner}} bands: {{pos}}/{{len}} recordings re-simulated with their {replicates} {noun} (now {{msg}})  elapsed {{elapsed}}"
        ))
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
    );
    bar.enable_steady_tick(std::time::Duration::from_millis(200));
    bar
}

/// The band rows of [`band_rows`], the replicate runs that diverged, each recording's reach
/// (calibrated bands only), and the recordings that gave no band at all, with why.
struct BandRows {
    rows: Vec<BandRow>,
    diverged: usize,
    reaches: Map<String, Value>,
    unbanded: Vec<String>,
}

/// A recording and the metrics of it that one reason holds for.
type MetricsOfFile = (String, Vec<&'static str>);

/// The reasons the rows without a band have, each once with the metrics it holds for
/// (`file metric, metric; file metric`), in the order they first appear.
fn no_band_reasons(rows: &[BandRow]) -> Vec<(String, String)> {
    let mut reasons: Vec<(String, Vec<MetricsOfFile>)> = Vec::new();
    for (file, metric, _, band, _) in rows {
        let Err(why) = band else { continue };
        let i = reasons
            .iter()
            .position(|(w, _)| w == why)
            .unwrap_or_else(|| {
                reasons.push((why.clone(), Vec::new()));
                reasons.len() - 1
            });
        let files = &mut reasons[i].1;
        match files.iter_mut().find(|(f, _)| f == file) {
            Some((_, metrics)) => metrics.push(metric),
            None => files.push((file.clone(), vec![metric])),
        }
    }
    reasons
        .into_iter()
        .map(|(why, files)| {
            let which = files
                .iter()
                .map(|(f, m)| format!("{f} {}", m.join(", ")))
                .collect::<Vec<_>>()
                .join("; ");
            (why, which)
        })
        .collect()
}

/// [`validation`], and with `bands` each recorded metric checked against its band over the model's
/// bootstrap replicates.
pub fn validation_with_bands(
    model: &dyn Dynamics,
    model_spec: &str,
    ds: &Dataset,
    as_json: bool,
    bands: Option<BandCheck>,
    valley: Option<&shipid_pipeline::bands::Valley>,
    jackknife: Option<&shipid_pipeline::bands::Jackknife>,
) -> Outcome {
    let emit = if as_json { Emit::Json } else { Emit::Text };
    validation_into(model, model_spec, ds, emit, bands, valley, jackknife)
}

fn validation_into(
    model: &dyn Dynamics,
    model_spec: &str,
    ds: &Dataset,
    emit: Emit<'_>,
    bands: Option<BandCheck>,
    valley: Option<&shipid_pipeline::bands::Valley>,
    jackknife: Option<&shipid_pipeline::bands::Jackknife>,
) -> Outcome {
    let as_json = !matches!(emit, Emit::Text);
    let (rows, source) = validate_dataset(model, model_spec, ds);
    let dataset = &ds.path;
    let any_failed = rows.iter().any(|r| r.validation.diverged());
    let mut recs: Map<String, Value> = rows
        .iter()
        .map(|r| (r.file.clone(), serde_json::to_value(r).unwrap_or_default()))
        .collect();
    // An MRAE of "-" without a diverged run needs its reason: the recording, or its declaration,
    // defines no metric the re-simulation could be compared on.
    let mut no_mrae = Vec::new();
    // A re-simulation that left its manoeuvre (turned against its rudder) is finite and "ok", and
    // its metrics, where defined, describe no such manoeuvre: said beside every row it touches.
    let left: Vec<String> = rows
        .iter()
        .filter_map(|v| {
            let why = v.validation.manoeuvre.as_ref()?.left_manoeuvre.as_ref()?;
            Some(format!(
                "{}: its re-simulation left the manoeuvre: {why}",
                v.file
            ))
        })
        .collect();
    for v in &rows {
        let (Some(c), Some(r)) = (&v.validation.manoeuvre, ds.recording(&v.file)) else {
            continue;
        };
        if c.mrae.is_some() || v.validation.diverged() {
            continue;
        }
        let why = c
            .left_manoeuvre
            .as_ref()
            .map(|l| format!("{}: the re-simulation left the manoeuvre: {l}", v.file))
            .or_else(|| {
                shipid_pipeline::validate::undefined_metrics_reason(r, &ds.ship, &c.recorded)
            })
            .unwrap_or_else(|| {
                format!(
                    "{}: the re-simulation defines none of the recorded metrics",
                    v.file
                )
            });
        if let Some(Value::Object(m)) = recs.get_mut(&v.file).map(|x| &mut x["manoeuvre"]) {
            m.insert("mrae_undefined".into(), json!(why));
        }
        no_mrae.push(why);
    }
    let mut value = json!({
        "model": model_spec,
        "dataset": dataset.display().to_string(),
        "method": "replay: recorded rudder from the recorded initial state (RMSEs); manoeuvre: the recording's standard manoeuvre re-simulated in closed loop (metrics)",
        "identification_range": { "source": source, "outside_means": source.describe() },
        "recordings": recs,
    });
    let mut warnings = shipid_pipeline::validate::validation_warnings(model_spec, Some(model), ds);
    warnings.extend(left);
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    if !warnings.is_empty()
        && let Value::Object(o) = &mut value
    {
        o.insert("warnings".into(), json!(warnings));
    }
    let band_check = bands
        .as_ref()
        .map(|b| (b, band_rows(model, model_spec, ds, b)));
    // A request for bands that yielded none (every recorded metric without one, or no recording to
    // band) must not read as success: warned, with why, and exit 1.
    let no_band_at_all = band_check.as_ref().and_then(|(check, b)| {
        if b.rows.iter().any(|r| r.3.is_ok()) {
            return None;
        }
        let mut why: Vec<String> = no_band_reasons(&b.rows)
            .into_iter()
            .map(|(why, _)| why)
            .collect();
        why.extend(b.unbanded.iter().cloned());
        if b.rows.is_empty() && b.unbanded.is_empty() {
            why.push(format!(
                "{} has no recording with a standard manoeuvre and recorded metrics to band",
                dataset.display()
            ));
        }
        Some(format!(
            "--bands {}: no recorded metric got a band ({}): the request yielded no band",
            check.level,
            why.join("; ")
        ))
    });
    if let Some(w) = &no_band_at_all {
        eprintln!("warning: {w}");
        if let Value::Object(o) = &mut value {
            match o.get_mut("warnings") {
                Some(Value::Array(a)) => a.push(json!(w)),
                _ => {
                    o.insert("warnings".into(), json!([w]));
                }
            }
        }
    }
    if let (Some((check, b)), Value::Object(o)) = (&band_check, &mut value) {
        let (band_rows, diverged, reaches) = (&b.rows, b.diverged, &b.reaches);
        let mut per: Map<String, Value> = Map::new();
        for (file, metric, recorded, band, inside) in band_rows {
            let entry = per
                .entry(file.clone())
                .or_insert_with(|| Value::Object(Map::new()));
            if let Value::Object(m) = entry {
                let mut cell = Map::new();
                cell.insert("recorded".into(), json!(recorded));
                match band {
                    Ok((lo, hi)) => {
                        cell.insert("band".into(), json!([lo, hi]));
                    }
                    Err(why) => {
                        cell.insert("no_band".into(), json!(why));
                    }
                }
                if let Some(inside) = inside {
                    cell.insert("inside".into(), json!(inside));
                }
                m.insert((*metric).into(), Value::Object(cell));
            }
        }
        let mut about = json!({
            "level": check.level,
            "kind": check.source.kind(),
            "replicates": check.source.replicates(),
            "diverged_replicate_runs": diverged,
            "what": check.source.what(),
            "recordings": per,
        });
        if let (Value::Object(a), Some(note)) =
            (&mut about, check.source.beyond_resolution(check.level))
        {
            eprintln!("warning: --bands {}: {note}", check.level);
            a.insert("resolution".into(), json!(note));
        }
        if let Value::Object(a) = &mut about
            && !reaches.is_empty()
        {
            a.insert("reach".into(), Value::Object(reaches.clone()));
            a.insert("factors".into(), json!(check.source.factors()));
            if let Some(o) = check.source.out_of_kind() {
                a.insert("out_of_kind".into(), json!(o));
            }
        }
        if let Value::Object(a) = &mut about
            && !b.unbanded.is_empty()
        {
            a.insert("recordings_without_band".into(), json!(b.unbanded));
        }
        o.insert("bands".into(), about);
    }
    let valley_check = valley.filter(|v| !v.members.is_empty()).map(|v| {
        let beside = shipid_pipeline::bands::Beside::Valley(v);
        (
            v,
            shipid_pipeline::bands::recorded_in_ranges(&rows, model_spec, ds, beside),
        )
    });
    let jackknife_check = jackknife.map(|j| {
        let beside = shipid_pipeline::bands::Beside::Jackknife(j);
        (
            j,
            shipid_pipeline::bands::recorded_in_ranges(&rows, model_spec, ds, beside),
        )
    });
    if let (Some((j, (rows, diverged))), Value::Object(o)) = (&jackknife_check, &mut value) {
        let per = range_rows_by_recording(rows, "jackknife");
        o.insert(
            "jackknife".into(),
            json!({
                "refits": j.members.len(),
                "diverged_runs": diverged,
                "what": j.what(),
                "recordings": per,
            }),
        );
    }
    if let (Some((v, (rows, diverged))), Value::Object(o)) = (&valley_check, &mut value) {
        let per = range_rows_by_recording(rows, "valley");
        o.insert(
            "valley".into(),
            json!({
                "starts": v.starts,
                "in_valley": v.members.len(),
                "cost_tolerance": v.cost_tolerance,
                "diverged_runs": diverged,
                "what": v.what(),
                "recordings": per,
            }),
        );
    }
    for r in rows.iter().filter(|r| !r.beyond_training.is_empty()) {
        eprintln!(
            "warning: {}: the recording goes past the extremes of the states {model_spec} was identified on ({}): its predictions are extrapolations, whatever its `outside` share",
            r.file,
            r.beyond_training.join(", ")
        );
    }
    if let Emit::Into(sink) = emit {
        *sink = value;
    } else if as_json {
        println!(
            "{}",
            serde_json::to_string_pretty(&value).unwrap_or_default()
        );
    } else {
        println!(
            "{:<16} {:>10} {:>9} {:>9} {:>9} {:>9} {:>8} {:>8}",
            "recording", "pos/L", "psi[deg]", "u[m/s]", "v[m/s]", "r[deg/s]", "MRAE", "outside"
        );
        for (file, v) in &recs {
            let f = |k: &str| {
                v["replay"][k]
                    .as_f64()
                    .map_or("-".into(), |x| format!("{x:.4}"))
            };
            let mrae = v["manoeuvre"]["mrae"]
                .as_f64()
                .map_or("-".into(), |x| format!("{:.1}%", 100.0 * x));
            let outside = v["outside_identification_range"]
                .as_f64()
                .map_or("-".into(), |x| format!("{:.0}%", 100.0 * x));
            // Why a row has "-" in place of its errors: which simulation diverged, when and why.
            let diverged = |part: &str| {
                (v[part]["status"].as_str() == Some("diverged")).then(|| {
                    format!(
                        "{part} diverged at t = {:.1} s ({})",
                        v[part]["t_s"].as_f64().unwrap_or(f64::NAN),
                        v[part]["reason"].as_str().unwrap_or("no reason given")
                    )
                })
            };
            let status = [diverged("replay"), diverged("manoeuvre")]
                .into_iter()
                .flatten()
                .collect::<Vec<_>>()
                .join("; ");
            println!(
                "{file:<16} {:>10} {:>9} {:>9} {:>9} {:>9} {:>8} {:>8} {}",
                f("position_rmse_over_l"),
                f("heading_rmse_deg"),
                f("u_rmse_m_s"),
                f("v_rmse_m_s"),
                f("r_rmse_deg_s"),
                mrae,
                outside,
                status
            );
        }
        // The columns' header names quantities and units only: what the numbers are is said once.
        println!(
            "pos/L … r[deg/s]: RMS errors of an open-loop replay of each recording's rudder from its initial state (position ÷ L); MRAE: mean relative absolute error of the closed-loop manoeuvre's IMO metrics"
        );
        for why in &no_mrae {
            println!("MRAE -: {why}");
        }
        if rows.iter().any(|r| r.validation.diverged()) {
            println!(
                "-: undefined where a simulation diverged (errors over the samples before it would read as a fit)"
            );
        }
        let delays: Vec<f64> = recs
            .values()
            .filter_map(|v| v["manoeuvre"]["reaction_delay_s"].as_f64())
            .collect();
        if delays.iter().any(|d| *d > 1e-3) {
            let (lo, hi) = delays
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), d| {
                    (lo.min(*d), hi.max(*d))
                });
            println!(
                "MRAE: each zig-zag re-simulated with its recording's reaction delay at the checks ({lo:.2}–{hi:.2} s; `reaction_delay_s` in --json)"
            );
        }
        match source {
            // Said, not left as a bare "-": a user would otherwise read it as "nothing outside".
            RangeSource::Unknown => println!(
                "outside: not available for this model (the reference carries no identification range; a fitted model's needs its training data, see the warnings above)"
            ),
            known => println!(
                "outside: share of the recording's states outside the model's identification range ({})",
                known.describe()
            ),
        }
    }
    if !as_json && let Some((check, b)) = &band_check {
        let (band_rows, diverged, reaches) = (&b.rows, b.diverged, &b.reaches);
        // Diverged runs are summed over the recordings: say of how many, or "200 diverged" of 200
        // replicates reads as all of them.
        let recordings = band_rows
            .iter()
            .map(|r| r.0.as_str())
            .collect::<std::collections::BTreeSet<_>>()
            .len();
        println!(
            "\nbands: {:.0} % over {} {} ({} of the {} replicate runs diverged, over {} recordings); {}",
            check.level * 100.0,
            check.source.replicates(),
            check.source.noun(),
            diverged,
            check.source.replicates() * recordings,
            recordings,
            check.source.what()
        );
        if !reaches.is_empty() {
            let each: Vec<String> = reaches
                .iter()
                .map(|(file, r)| format!("{file} {:.2}", r.as_f64().unwrap_or(f64::NAN)))
                .collect();
            println!(
                "reach outside the identification range: {}",
                each.join(", ")
            );
        }
        println!(
            "{:<16} {:<18} {:>5} {:>10} {:>22} {:>7}",
            "recording", "metric", "unit", "recorded", "band", "inside"
        );
        for (file, metric, recorded, band, inside) in band_rows {
            let unit = shipid_sim::metrics::metric_unit(metric).unwrap_or("");
            let band = match band {
                Ok((lo, hi)) => format!("[{lo:.4}, {hi:.4}]"),
                Err(_) => "no band".into(),
            };
            let inside = match inside {
                Some(true) => "yes",
                Some(false) => "no",
                None => "-",
            };
            println!("{file:<16} {metric:<18} {unit:>5} {recorded:>10.4} {band:>22} {inside:>7}");
        }
        // Why a row says "no band": each reason once, with the metrics it holds for (--json gives
        // it per metric as `no_band`).
        for (why, which) in no_band_reasons(band_rows) {
            println!("no band: {which}: {why}");
        }
        for why in &b.unbanded {
            println!("no band: {why}");
        }
        let checked = band_rows.iter().filter(|r| r.4.is_some()).count();
        let inside = band_rows.iter().filter(|r| r.4 == Some(true)).count();
        println!(
            "inside: {inside} of {checked} recorded metrics lie in their {:.0} % band",
            check.level * 100.0
        );
    }
    if !as_json && let Some((v, (rows, diverged))) = &valley_check {
        println!(
            "\nvalley: {} of the {} refinements from the other prior weights end within {:.0} % of this model's cost ({} of their runs diverged): {}",
            v.members.len(),
            v.starts,
            100.0 * v.cost_tolerance,
            diverged,
            v.what()
        );
        print_range_rows(rows, "valley", "lie in the valley's range");
    }
    if !as_json && let Some((j, (rows, diverged))) = &jackknife_check {
        println!(
            "\njackknife: {} refits, each without one training recording ({} of their runs diverged): {}",
            j.members.len(),
            diverged,
            j.what()
        );
        print_range_rows(
            rows,
            "jackknife",
            "lie in the jackknife's range (not a band of the truth: how far the training set moves the prediction)",
        );
    }
    if any_failed || no_band_at_all.is_some() {
        Outcome::SomeFailed
    } else {
        Outcome::Ok
    }
}
