//! The run record beside a study's results: `study.toml` (the study file as run) and `run.json` (tool
//! version, study and data set, UTC start and end, wall time, case outcomes, warnings).

use std::path::Path;
use std::time::SystemTime;

use serde::Serialize;
use shipid_io::write::write_atomic;
use shipid_pipeline::model_file::absolute_path;

use crate::error::StudyError;
use crate::runner::{CaseResult, OutcomeCounts};
use crate::study::Study;

/// What `run.json` holds.
#[derive(Debug, Clone, Serialize)]
pub struct RunRecord {
    pub tool_version: String,
    pub study: String,
    pub study_file: String,
    pub dataset: String,
    pub started_utc: String,
    pub finished_utc: String,
    pub wall_time_s: f64,
    pub cases: usize,
    pub case_outcomes: OutcomeCounts,
    pub warnings: Vec<String>,
}

impl RunRecord {
    /// The record of a run of `study` by `tool_version` that started at `started` and ends now.
    pub fn new(
        tool_version: &str,
        study: &Study,
        results: &[CaseResult],
        started: SystemTime,
        warnings: Vec<String>,
    ) -> RunRecord {
        let finished = SystemTime::now();
        // The study's own warnings (a window past a recording) belong to every record of its run.
        let mut warnings = warnings;
        for w in &study.warnings {
            if !warnings.contains(w) {
                warnings.push(w.clone());
            }
        }
        RunRecord {
            tool_version: tool_version.into(),
            study: study.name.clone(),
            // Absolute: a path relative to the working directory of `shipid run` names nothing
            // once `report` or a reader starts elsewhere.
            study_file: absolute_path(&study.path).display().to_string(),
            dataset: absolute_path(&study.dataset_path).display().to_string(),
            started_utc: utc(started),
            finished_utc: utc(finished),
            wall_time_s: finished
                .duration_since(started)
                .map_or(0.0, |d| d.as_secs_f64()),
            cases: results.len(),
            case_outcomes: OutcomeCounts::of(results),
            warnings,
        }
    }

    /// Writes `study.toml` (a copy of the study file) and `run.json` into `out`.
    pub fn write(&self, study: &Study, out: &Path) -> Result<(), StudyError> {
        let io = |path: &Path| {
            let path = path.to_path_buf();
            move |source| StudyError::Io { path, source }
        };
        let text = std::fs::read_to_string(&study.path).map_err(io(&study.path))?;
        let copy = out.join("study.toml");
        write_atomic(&copy, text.as_bytes()).map_err(io(&copy))?;
        let json = serde_json::to_string_pretty(self).map_err(std::io::Error::other);
        let path = out.join("run.json");
        write_atomic(&path, json.map_err(io(&path))?.as_bytes()).map_err(io(&path))
    }
}

/// `t` as an ISO 8601 UTC time to the second (days to civil date by Howard Hinnant's algorithm).
fn utc(t: SystemTime) -> String {
    let secs = t
        .duration_since(SystemTime::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs()) as i64;
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(unix_s: u64, expected: &str) {
        let t = SystemTime::UNIX_EPOCH + std::time::Duration::from_secs(unix_s);
        assert_eq!(utc(t), expected);
    }

    #[test]
    fn utc_dates_across_leap_years_and_month_ends() {
        check(0, "1970-01-01T00:00:00Z");
        check(951_782_400, "2000-02-29T00:00:00Z");
        check(1_709_251_199, "2024-02-29T23:59:59Z");
        check(1_795_996_800, "2026-11-30T00:00:00Z");
    }
}
