//! One self-contained HTML page for a study output folder or a diagnosis output folder.
//!
//! The page needs nothing but itself: the stylesheet is inline, figures are inline `<svg>` elements
//! (sanitised, see [`svg`]), and there is no script. Every string taken from the data is
//! HTML-escaped; numbers are shown with four significant digits (the full value in the tooltip).
//!
//! - [`study_page`] reads the folder written by `shipid run STUDY --out DIR`: `summary.csv` (required;
//!   one row per case × test, case id in column `case`), `coefficients.csv`, `diagnostics.csv`,
//!   `cases/<case-id>/{config.toml,result.json,model.toml}`, `figures/*.svg`, and when present
//!   `study.toml` (the resolved study configuration) and `run.json` (facts about the run).
//! - [`diagnosis_page`] reads a diagnosis report (`shipid diagnose --json`), its figures
//!   (`--plots`) and the augmented model (`--model-out`), each optional but the report.
//! - [`write_report`] writes `DIR/report.html` atomically.
//!
//! Optional files that are missing are left out of the page; a figure that is not a usable SVG is
//! left out with a note in the page's warnings. A required file that cannot be read, or any file that
//! is present but cannot be parsed where the page depends on it, is a [`ReportError`] naming it.

use std::path::{Path, PathBuf};

mod data;
mod diagnosis;
pub mod html;
mod study;
pub mod svg;

pub use diagnosis::diagnosis_page;
pub use study::{study_page, study_page_with_warnings};

/// The file name [`write_report`] writes.
pub const REPORT_FILE: &str = "report.html";

/// What went wrong, always naming the file.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{}: {source}", path.display())]
    Csv { path: PathBuf, source: csv::Error },
    #[error("{}: {source}", path.display())]
    Json {
        path: PathBuf,
        source: serde_json::Error,
    },
    #[error("{}: {source}", path.display())]
    Toml {
        path: PathBuf,
        source: toml::de::Error,
    },
    /// The file was read but does not hold what the page needs.
    #[error("{}: {message}", path.display())]
    Invalid { path: PathBuf, message: String },
}

impl ReportError {
    /// The file the error is about.
    pub fn path(&self) -> &Path {
        match self {
            ReportError::Io { path, .. }
            | ReportError::Csv { path, .. }
            | ReportError::Json { path, .. }
            | ReportError::Toml { path, .. }
            | ReportError::Invalid { path, .. } => path,
        }
    }
}

/// What the caller knows about the run that the folder may not say. Every field is optional; for a
/// study, fields left `None` are taken from `run.json`, then `study.toml` (`name`, `dataset`,
/// `description`), then the first case's `config.toml` (`shipid_version`, `study`, `dataset`), and
/// the warnings of the caller and of `run.json` are both shown (duplicates once).
///
/// `run.json` is read leniently (a JSON object): `tool_version` (or `shipid_version`, `version`),
/// `study_name` (or `name`), `study_file` (or `study`), `dataset` (or `data_set`), `started_utc` (or
/// `started`), `finished_utc` (or `finished`) and `warnings` (an array of strings) go to their places;
/// any other key (`wall_time_s`, `cases`, `case_outcomes`, …) is listed under "Run record" as it is.
#[derive(Debug, Clone, Default)]
pub struct RunMeta {
    /// The caller's `shipid` version (`env!("CARGO_PKG_VERSION")` in the CLI). A study page shows the
    /// version that computed the results (`run.json`, else the cases' `config.toml`, else this one)
    /// and warns when they differ from this one.
    pub tool_version: Option<String>,
    /// Study name, or a title for a diagnosis (default: the study's `name`, else the folder name).
    pub name: Option<String>,
    /// The study file as the user gave it.
    pub study_file: Option<PathBuf>,
    /// The data set file.
    pub dataset: Option<PathBuf>,
    /// Warnings of the run (e.g. figures that could not be drawn), shown in a box at the top.
    pub warnings: Vec<String>,
    /// Further labelled facts shown in the header, in this order (e.g. `("base model", path)`).
    pub details: Vec<(String, String)>,
}

/// Where the files of a diagnosis are.
#[derive(Debug, Clone)]
pub struct DiagnosisFiles {
    /// The JSON report (`shipid diagnose --json`). Required.
    pub report: PathBuf,
    /// The figures folder (`--plots`); its `*.svg` are shown.
    pub figures: Option<PathBuf>,
    /// The augmented model file (`--model-out`), shown as TOML.
    pub model: Option<PathBuf>,
}

impl DiagnosisFiles {
    /// The layout of a diagnosis folder: `report.json`, the figures (in `figures/`, else the folder's
    /// own `*.svg`, as `shipid diagnose --plots DIR` writes them) and `report.model.toml` (else the
    /// only `*.model.toml`), the optional ones only when they exist.
    pub fn in_dir(dir: &Path) -> DiagnosisFiles {
        let sub = dir.join("figures");
        let has_svg = std::fs::read_dir(dir)
            .into_iter()
            .flatten()
            .flatten()
            .any(|e| e.path().extension().is_some_and(|x| x == "svg"));
        let figures = if sub.is_dir() {
            Some(sub)
        } else {
            has_svg.then(|| dir.to_path_buf())
        };
        let model = dir.join("report.model.toml");
        let model = if model.is_file() {
            Some(model)
        } else {
            let mut found: Vec<PathBuf> = std::fs::read_dir(dir)
                .into_iter()
                .flatten()
                .flatten()
                .map(|e| e.path())
                .filter(|p| {
                    p.is_file()
                        && p.file_name()
                            .and_then(|n| n.to_str())
                            .is_some_and(|n| n.ends_with(".model.toml"))
                })
                .collect();
            if found.len() == 1 { found.pop() } else { None }
        };
        DiagnosisFiles {
            report: dir.join("report.json"),
            figures,
            model,
        }
    }
}

/// Write `html` to `dir/report.html` atomically (a uniquely named temporary file in `dir`, then a
/// rename over the target); returns the path written.
pub fn write_report(dir: &Path, html: &str) -> Result<PathBuf, ReportError> {
    use std::io::Write;
    use std::sync::atomic::{AtomicU64, Ordering};
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let target = dir.join(REPORT_FILE);
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| ReportError::Io { path, source }
    };
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    let tmp = dir.join(format!(
        ".{REPORT_FILE}.{}.{nanos}.{}.tmp",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let result = (|| {
        let mut f = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
            .map_err(io(&tmp))?;
        f.write_all(html.as_bytes()).map_err(io(&tmp))?;
        f.sync_all().map_err(io(&tmp))?;
        drop(f);
        std::fs::rename(&tmp, &target).map_err(io(&target))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map(|()| target)
}
