//! `shipid run`, `shipid table` and `shipid check`: studies end to end.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use shipid_report::RunMeta;
use shipid_study::tables::write_tables;
use shipid_study::{
    CaseResult, OutcomeCounts, RunLock, RunPlan, RunRecord, Study, default_out, load_study,
    run_study,
};
use shipid_tables::{Table, Tolerance, compare};

use crate::{CliError, Outcome, bad_input, failed};

/// Run a study and write its tables, figures, run record (`study.toml`, `run.json`) and the HTML
/// report; returns the results and the report's path (`None` when it could not be written: figures and
/// the report are a convenience, one that cannot be made is a warning, never a failed run). Holds the
/// output folder's lock throughout: a second run into the same folder refuses (exit 2).
pub fn run_and_write(
    study: &Study,
    out: &Path,
    jobs: usize,
    force: bool,
    progress: bool,
) -> Result<(Vec<CaseResult>, Option<PathBuf>), CliError> {
    crate::outputs::check_folder(
        "--out",
        out,
        &run_writes(),
        &crate::outputs::Inputs::new()
            .file(&study.path, "the study file")
            .dataset(&study.dataset_path),
    )?;
    refuse_foreign_folder(out)?;
    // Whatever --force says: a reference is the check's, and a run's tables would replace it.
    shipid_study::reference::refuse_run_over_reference(out)?;
    shipid_study::output::refuse_links(out)?;
    if !force {
        refuse_other_study(study, out)?;
    }
    let lock = RunLock::acquire(out)?;
    if let Some(pid) = lock.taken_over_from {
        eprintln!(
            "warning: {}: taken over from pid {pid}, which ended without releasing it (killed?); its finished cases are kept",
            lock.path().display()
        );
    }
    if progress {
        let plan = RunPlan::of(study, out, force);
        eprintln!(
            "{}: {} cases ({}), {} finished earlier, {} to run with {jobs} job(s), each tested on {} recording(s); results in {}",
            study.name,
            plan.cases,
            study.grid,
            plan.finished,
            plan.cases - plan.finished,
            study.tests.len(),
            out.display()
        );
    }
    let started = std::time::SystemTime::now();
    let results = run_study(study, out, jobs, force, progress)
        .map_err(|e| failed(anyhow::anyhow!("writing into {}: {e}", out.display())))?;
    write_tables(study, &results, out)?;
    // What the data carry that the models may not: a varying propeller rate, a recorded wind or
    // current (removed before each fit and applied in each test's replays), and the windage used.
    let mut warnings = study.warnings.clone();
    warnings.extend(shipid_pipeline::validate::validation_warnings(
        "",
        None,
        &study.dataset,
    ));
    warnings.extend(shipid_figures::write_figures(study, out).warnings);
    RunRecord::new(
        env!("CARGO_PKG_VERSION"),
        study,
        &results,
        started,
        warnings.clone(),
    )
    .write(study, out)?;
    let meta = RunMeta {
        tool_version: Some(env!("CARGO_PKG_VERSION").into()),
        name: Some(study.name.clone()),
        // As run.json stores them: the page names files, whatever folder it is opened from.
        study_file: Some(shipid_pipeline::model_file::absolute_path(&study.path)),
        dataset: Some(shipid_pipeline::model_file::absolute_path(
            &study.dataset_path,
        )),
        warnings: warnings.clone(),
        details: vec![],
    };
    let report = shipid_report::study_page_with_warnings(out, &meta).and_then(|(html, notes)| {
        warnings.extend(notes);
        shipid_report::write_report(out, &html)
    });
    let report = match report {
        Ok(p) => Some(p),
        Err(e) => {
            warnings.push(format!("report: {e}"));
            None
        }
    };
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    drop(lock);
    Ok((results, report))
}

/// The files a run writes at the top of its output folder (the cases' own go under `cases/`): its
/// records, its tables (the ones a reference keeps) and its report.
fn run_writes() -> Vec<&'static str> {
    ["study.toml", "run.json"]
        .into_iter()
        .chain(shipid_study::reference::REFERENCE_TABLES)
        .chain([shipid_report::REPORT_FILE])
        .collect()
}

/// An output folder that is a file (or under one) is the user's mistake, named before any work.
/// A study writes `cases/`, `figures/`, tables and a report into its folder and removes figures of
/// its own earlier runs there: a folder that holds other things and no sign of a shipid run (`--out
/// /`, a home folder) is refused before anything is written into it.
fn refuse_foreign_folder(out: &Path) -> Result<(), CliError> {
    let Ok(entries) = std::fs::read_dir(out) else {
        return Ok(()); // new (or unreadable: the write says so)
    };
    let names: Vec<String> = entries
        .filter_map(Result::ok)
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    let ours = [
        "run.json",
        "study.toml",
        "cases",
        "summary.csv",
        shipid_study::lock::LOCK_FILE,
    ];
    if names.is_empty() || names.iter().any(|n| ours.contains(&n.as_str())) {
        return Ok(());
    }
    let mut shown: Vec<&str> = names.iter().map(String::as_str).collect();
    shown.sort_unstable();
    let more = if shown.len() > 3 { ", …" } else { "" };
    shown.truncate(3);
    Err(bad_input(format!(
        "--out {}: holds {} other entries (`{}`{more}) and no earlier shipid run; a study writes cases/, figures/, tables and a report there: give a new or empty folder",
        out.display(),
        names.len(),
        shown.join("`, `")
    )))
}

/// A folder holding another study's results (its `study.toml` or `run.json` names another study):
/// a run would leave the other study's cases beside its own, and its tables and page would replace
/// the other's without a word. Refused naming both; `--force` (rerun everything) writes over it.
fn refuse_other_study(study: &Study, out: &Path) -> Result<(), CliError> {
    let from_toml = || {
        let path = out.join("study.toml");
        let text = std::fs::read_to_string(&path).ok()?;
        let name = toml::from_str::<toml::Table>(&text)
            .ok()?
            .get("name")?
            .as_str()?
            .to_string();
        Some((name, path))
    };
    let from_json = || {
        let path = out.join("run.json");
        let text = std::fs::read_to_string(&path).ok()?;
        let json: serde_json::Value = serde_json::from_str(&text).ok()?;
        Some((json.get("study")?.as_str()?.to_string(), path))
    };
    match from_toml().or_else(from_json) {
        Some((other, path)) if other != study.name => Err(bad_input(format!(
            "--out {}: holds the results of study `{other}` ({}), not of `{}`: give another --out, or --force to rerun `{}` into it (the other study's cases stay under cases/)",
            out.display(),
            path.display(),
            study.name,
            study.name
        ))),
        _ => Ok(()),
    }
}

fn check_out_dir(out: &Path) -> Result<(), CliError> {
    let mut p = Some(out);
    while let Some(dir) = p {
        if dir.exists() && !dir.is_dir() {
            return Err(bad_input(format!(
                "--out {}: {} is a file, not a folder",
                out.display(),
                dir.display()
            )));
        }
        p = dir.parent();
    }
    Ok(())
}

/// The parallel cases a run of `cases` cases uses: `--jobs` (default: the cores), never more than the
/// cases, since each job is a thread and one beyond the cases has nothing to do. A `--jobs` above the
/// cases is said, so that the summary's count is not read as a typo's.
fn jobs_for(asked: Option<usize>, cases: usize) -> usize {
    let cap = cases.max(1);
    match asked {
        Some(n) if n > cap => {
            eprintln!("note: --jobs {n}: the study has {cases} case(s); running {cap} job(s)");
            cap
        }
        Some(n) => n,
        None => std::thread::available_parallelism()
            .map_or(1, |n| n.get())
            .min(cap),
    }
}

/// `shipid run STUDY.toml`: exit 0 when every case ended with a recorded status (a diverged prediction
/// is a result), 1 when a case could not be computed (or, with `strict`, when one diverged).
pub fn run(
    study_path: &Path,
    out: Option<&Path>,
    jobs: Option<usize>,
    force: bool,
    strict: bool,
    allow_large: bool,
) -> Result<Outcome, CliError> {
    if jobs == Some(0) {
        return Err(bad_input("--jobs 0: give at least 1"));
    }
    // Sized from the grid's axes before any case is built (a 5 KB file can make millions).
    let study = shipid_study::load_study_within(study_path, allow_large)?;
    let jobs = jobs_for(jobs, study.cases.len());
    let out = out
        .map(PathBuf::from)
        .unwrap_or_else(|| default_out(&study));
    let started = std::time::Instant::now();
    let (results, report) = run_and_write(&study, &out, jobs, force, true)?;
    let c = OutcomeCounts::of(&results);
    eprintln!(
        "{}: {} cases ({} ok, {} with a diverged prediction, {} whose fit could not be computed) in {:.1} s with {jobs} job(s); tables in {}",
        study.name,
        results.len(),
        c.every_prediction_ok,
        c.some_prediction_diverged,
        c.fit_failed,
        started.elapsed().as_secs_f64(),
        out.display()
    );
    if let Some(p) = report {
        println!("report: {}", p.display());
    }
    Ok(
        if c.fit_failed > 0 || (strict && c.some_prediction_diverged > 0) {
            Outcome::SomeFailed
        } else {
            Outcome::Ok
        },
    )
}

/// `shipid plot STUDY.toml [--out DIR]`: the figures of an existing run (no refitting).
pub fn plot(study_path: &Path, out: Option<&Path>) -> Result<Outcome, CliError> {
    let study = load_study(study_path)?;
    let out = out
        .map(PathBuf::from)
        .unwrap_or_else(|| default_out(&study));
    if !out.join("coefficients.csv").is_file() {
        return Err(bad_input(format!(
            "{} holds no run of {} (no coefficients.csv): run `shipid run {}` first",
            out.display(),
            study.name,
            study_path.display()
        )));
    }
    crate::outputs::check_folder(
        "--out",
        &out.join("figures"),
        &[],
        &crate::outputs::Inputs::new().file(study_path, "the study file"),
    )?;
    // Another study's folder (or this one's before its `[test]` list changed): its figures would
    // be drawn from the wrong grid or tests, and its own removed as stale.
    shipid_study::tables::check_output_of(&study, &out)?;
    shipid_study::output::refuse_links(&out)?;
    // Not while a run is rewriting the tables the figures are drawn from.
    let lock = RunLock::acquire(&out)?;
    let report = shipid_figures::write_figures(&study, &out);
    drop(lock);
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    eprintln!(
        "{}: {} figures in {}",
        study.name,
        report.written.len(),
        out.join("figures").display()
    );
    Ok(if report.warnings.is_empty() {
        Outcome::Ok
    } else {
        Outcome::SomeFailed
    })
}

/// `shipid table STUDY.toml [--pivot ROWS,COLS,VALUE]`: a markdown comparison table from `summary.csv`
/// (`None`: the default pivot, with every column that tells the study's cases apart in its rows).
pub fn table(
    study_path: &Path,
    out: Option<&Path>,
    pivot: Option<&str>,
) -> Result<Outcome, CliError> {
    let study = load_study(study_path)?;
    let dir = out
        .map(PathBuf::from)
        .unwrap_or_else(|| default_out(&study));
    let path = dir.join("summary.csv");
    if !path.is_file() {
        return Err(bad_input(format!(
            "{} not found: run `shipid run {}` first",
            path.display(),
            study_path.display()
        )));
    }
    let t = Table::read_csv(&path).map_err(|e| bad_input(e.to_string()))?;
    shipid_study::tables::check_output_of(&study, &dir)?;
    let md = shipid_study::tables::summary_pivot(&t, pivot).map_err(|e| {
        let hint = pivot_hint(&t, pivot, &e).unwrap_or_default();
        bad_input(format!("--pivot: {e} in {}{hint}", path.display()))
    })?;
    println!("{md}");
    Ok(Outcome::Ok)
}

/// For a pivot refused because it puts cases together: the pivot that tells them apart.
fn pivot_hint(
    summary: &Table,
    pivot: Option<&str>,
    e: &shipid_tables::TableError,
) -> Option<String> {
    let shipid_tables::TableError::Collision(_) = e else {
        return None;
    };
    let mut p: shipid_tables::Pivot = pivot?.parse().ok()?;
    p.rows = shipid_study::tables::separated_rows(summary, &p).ok()?;
    Some(format!(
        "; to tell them apart: --pivot {},{},{} (or leave --pivot out)",
        p.rows.join("+"),
        p.cols.join("+"),
        p.value
    ))
}

/// The tables `shipid check` compares, each with the columns that name a row (rows are paired by
/// them, not by position).
const COMPARED: [(&str, &[&str]); 2] = [
    ("summary", &["case", "test"]),
    ("coefficients", &["case", "dof", "term", "quantity"]),
];

/// Tolerances of `shipid check`: timings are ignored, everything else is compared to 1e-8 absolute plus
/// 1e-5 relative unless the study's `[check]` table says otherwise.
pub const DEFAULT_TOLERANCE: Tolerance = Tolerance {
    abs: 1e-8,
    rel: 1e-5,
};

pub fn check(
    study_path: &Path,
    reference: &Path,
    bless: bool,
    jobs: Option<usize>,
    allow_large: bool,
) -> Result<Outcome, CliError> {
    if jobs == Some(0) {
        return Err(bad_input("--jobs 0: give at least 1"));
    }
    // Sized from the grid's axes before any case is built (a 5 KB file can make millions).
    let study = shipid_study::load_study_within(study_path, allow_large)?;
    let jobs = jobs_for(jobs, study.cases.len());
    // Named before the run, not after minutes of it.
    shipid_study::tables::check_tolerance_columns(&study)?;
    if bless {
        check_out_dir(reference)
            .map_err(|_| bad_input(format!("--reference {}: not a folder", reference.display())))?;
        // Before the run, not after minutes of it.
        shipid_study::reference::refuse_bless_over(&study, reference)?;
    } else {
        for (stem, _) in COMPARED {
            let path = reference.join(format!("{stem}.csv"));
            if !path.is_file() {
                return Err(bad_input(format!(
                    "{} not found (create it with --bless)",
                    path.display()
                )));
            }
            let r = Table::read_csv(&path).map_err(|e| bad_input(e.to_string()))?;
            // |fresh − ∞| ≤ abs + rel·∞ holds for every fresh value: such a reference passes any run.
            if let Some((row, column, value)) = r.non_finite_cell() {
                return Err(bad_input(format!(
                    "{}: row {row} (line {}), column `{column}`: {value} is not a finite number; a reference holds the finite values of a run (bless it again)",
                    path.display(),
                    row + 1
                )));
            }
        }
    }
    let fresh = ScratchDir::new(&study)?;
    let fresh_dir = fresh.0.clone();
    // Only the tables are compared: no figures, run record or report for a run that is thrown away.
    let results = run_study(&study, &fresh_dir, jobs, true, false).map_err(failed)?;
    write_tables(&study, &results, &fresh_dir)?;
    let mut per_column: BTreeMap<String, Option<Tolerance>> =
        BTreeMap::from([("fit_time_s".to_string(), None)]);
    for (k, t) in &study.check {
        per_column.insert(
            k.clone(),
            Some(Tolerance {
                abs: t.abs,
                rel: t.rel,
            }),
        );
    }
    if bless {
        let named = |p: &Path| {
            let p = p.display().to_string();
            move |e: std::io::Error| failed(anyhow::anyhow!("{p}: {e}"))
        };
        std::fs::create_dir_all(reference).map_err(named(reference))?;
        for stem in ["summary", "coefficients", "diagnostics"] {
            for ext in ["csv", "parquet"] {
                let name = format!("{stem}.{ext}");
                let to = reference.join(&name);
                std::fs::copy(fresh_dir.join(&name), &to).map_err(named(&to))?;
            }
        }
        // Last: tables without it are still taken as this study's by their case ids.
        shipid_study::reference::write_reference_record(&study, reference)?;
        eprintln!(
            "blessed {} as the reference of {} ({} cases)",
            reference.display(),
            study.name,
            results.len()
        );
        return Ok(Outcome::Ok);
    }
    let mut all = Vec::new();
    for (stem, key) in COMPARED {
        let reference_path = reference.join(format!("{stem}.csv"));
        // A reference that cannot be read is the user's input, not a failed run.
        let r = Table::read_csv(&reference_path).map_err(|e| bad_input(e.to_string()))?;
        let f = Table::read_csv(&fresh_dir.join(format!("{stem}.csv"))).map_err(failed)?;
        let diffs = compare(&f, &r, key, &per_column, DEFAULT_TOLERANCE)
            .map_err(|e| bad_input(format!("{}: {e}", reference_path.display())))?;
        all.extend(diffs.into_iter().map(|d| format!("{stem}: {d}")));
    }
    drop(fresh);
    if all.is_empty() {
        eprintln!(
            "{}: {} cases match the reference {}",
            study.name,
            results.len(),
            reference.display()
        );
        Ok(Outcome::Ok)
    } else {
        for d in all.iter().take(50) {
            println!("{d}");
        }
        if all.len() > 50 {
            println!("… and {} more differences", all.len() - 50);
        }
        eprintln!(
            "{}: {} differences from the reference {}",
            study.name,
            all.len(),
            reference.display()
        );
        Ok(Outcome::SomeFailed)
    }
}

/// The private folder of `check`'s fresh run, removed however the check ends.
struct ScratchDir(PathBuf);

impl ScratchDir {
    /// A new folder of this process's own under the temporary folder. `create_dir` (not `_all`)
    /// fails on anything already there, a symbolic link planted at a predictable name included, so
    /// the tables are never written through it; the name takes the clock's nanoseconds too, and a
    /// taken name is tried again with the next.
    fn new(study: &Study) -> Result<ScratchDir, CliError> {
        let base = std::env::temp_dir();
        let mut last = None;
        for attempt in 0..16u32 {
            let nanos = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.subsec_nanos());
            let dir = base.join(format!(
                "shipid-check-{}-{}-{nanos:09}-{attempt}",
                study.name,
                std::process::id()
            ));
            match std::fs::create_dir(&dir) {
                Ok(()) => {
                    remove_when_interrupted(&dir);
                    return Ok(ScratchDir(dir));
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => last = Some(dir),
                Err(e) => return Err(failed(anyhow::anyhow!("{}: {e}", dir.display()))),
            }
        }
        Err(failed(anyhow::anyhow!(
            "{}: every scratch folder name tried is taken",
            last.unwrap_or(base).display()
        )))
    }
}

/// The scratch folder an interrupt (Ctrl-C, SIGTERM) removes before the process exits with 130:
/// without it an interrupted `check` left its fresh run under the temporary folder (`Drop` does not
/// run when a signal ends the process).
static INTERRUPT_SCRATCH: std::sync::Mutex<Option<PathBuf>> = std::sync::Mutex::new(None);

fn remove_when_interrupted(dir: &std::path::Path) {
    static HANDLER: std::sync::Once = std::sync::Once::new();
    if let Ok(mut slot) = INTERRUPT_SCRATCH.lock() {
        *slot = Some(dir.to_path_buf());
    }
    HANDLER.call_once(|| {
        // Without a handler (another one installed, no signal support) an interrupt leaves the
        // folder as before; the check itself is unaffected.
        let _ = ctrlc::set_handler(|| {
            if let Ok(slot) = INTERRUPT_SCRATCH.lock()
                && let Some(dir) = slot.as_ref()
            {
                let _ = std::fs::remove_dir_all(dir);
            }
            eprintln!("interrupted: the check's scratch folder is removed");
            std::process::exit(130);
        });
    });
}

impl Drop for ScratchDir {
    fn drop(&mut self) {
        if let Ok(mut slot) = INTERRUPT_SCRATCH.lock() {
            *slot = None;
        }
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
