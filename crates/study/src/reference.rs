//! Whose tables a folder holds, before `shipid check --bless` or `shipid run` writes its own over
//! them: a stored reference names its study in `reference.toml` (written by `--bless` beside the
//! tables), a run's folder in `study.toml` / `run.json`. Without a name, the tables themselves
//! say: a `summary.csv` whose cases are all of the study is its reference (one blessed before
//! `reference.toml` existed); any other is someone else's.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use shipid_io::write::write_atomic;
use shipid_tables::Table;

use crate::error::StudyError;
use crate::study::Study;

/// The record `check --bless` writes beside a reference's tables.
pub const REFERENCE_FILE: &str = "reference.toml";

/// The tables `check --bless` copies into a reference folder.
pub const REFERENCE_TABLES: [&str; 6] = [
    "summary.csv",
    "summary.parquet",
    "coefficients.csv",
    "coefficients.parquet",
    "diagnostics.csv",
    "diagnostics.parquet",
];

/// What a folder holds of shipid's, as far as a write into it is concerned.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Holder {
    /// Nothing a reference or a run writes (missing, empty, or other files only).
    Nothing,
    /// A stored reference whose `reference.toml` names `study`.
    Reference { study: String, record: PathBuf },
    /// A run's output folder (`study.toml`, `run.json` or `cases/`); `study` when one names it.
    Run {
        study: Option<String>,
        evidence: PathBuf,
    },
    /// Reference tables without `reference.toml` and without a run beside them: `cases` are the
    /// case ids of its `summary.csv` (`None`: no such file, or not a summary of shipid's).
    Tables {
        found: Vec<String>,
        cases: Option<BTreeSet<String>>,
    },
}

impl Holder {
    /// Whether these are `study`'s own reference tables: named so, or (unnamed) every case of the
    /// summary one of its cases.
    pub fn is_reference_of(&self, study: &Study) -> bool {
        match self {
            Holder::Nothing => true,
            Holder::Reference { study: s, .. } => *s == study.name,
            Holder::Run { .. } => false,
            Holder::Tables { cases, .. } => cases.as_ref().is_some_and(|ids| {
                let known: BTreeSet<&str> = study.cases.iter().map(|c| c.id.as_str()).collect();
                ids.iter().all(|id| known.contains(id.as_str()))
            }),
        }
    }
}

/// What `dir` holds (see [`Holder`]); a run's marks win over a reference record, since a run's
/// folder is the more to lose.
pub fn holder(dir: &Path) -> Holder {
    if let Some((study, evidence)) = run_marks(dir) {
        return Holder::Run { study, evidence };
    }
    let record = dir.join(REFERENCE_FILE);
    if let Ok(text) = std::fs::read_to_string(&record) {
        let study = toml::from_str::<toml::Table>(&text)
            .ok()
            .and_then(|t| t.get("study")?.as_str().map(str::to_string))
            .unwrap_or_default();
        return Holder::Reference { study, record };
    }
    let found: Vec<String> = REFERENCE_TABLES
        .iter()
        .filter(|n| dir.join(n).exists())
        .map(|n| n.to_string())
        .collect();
    if found.is_empty() {
        return Holder::Nothing;
    }
    let cases = Table::read_csv(&dir.join("summary.csv"))
        .ok()
        .and_then(|t| {
            let col = t.column("case")?;
            Some((0..t.rows()).map(|i| col.cell(i)).collect())
        });
    Holder::Tables { found, cases }
}

/// The study a run's folder names (its `study.toml`, else its `run.json`), or just the evidence
/// that it is one (`cases/`).
fn run_marks(dir: &Path) -> Option<(Option<String>, PathBuf)> {
    let toml_path = dir.join("study.toml");
    let json_path = dir.join("run.json");
    let named = std::fs::read_to_string(&toml_path)
        .ok()
        .and_then(|text| {
            let name = toml::from_str::<toml::Table>(&text).ok()?;
            Some((name.get("name")?.as_str()?.to_string(), toml_path.clone()))
        })
        .or_else(|| {
            let text = std::fs::read_to_string(&json_path).ok()?;
            let json: serde_json::Value = serde_json::from_str(&text).ok()?;
            Some((json.get("study")?.as_str()?.to_string(), json_path.clone()))
        });
    if let Some((name, path)) = named {
        return Some((Some(name), path));
    }
    [toml_path, json_path, dir.join("cases")]
        .into_iter()
        .find(|p| p.exists())
        .map(|p| (None, p))
}

/// Refuses `check --bless` of `study` into `dir` unless `dir` is new, holds none of a reference's
/// tables or run's marks, or holds `study`'s own reference.
pub fn refuse_bless_over(study: &Study, dir: &Path) -> Result<(), StudyError> {
    let holder = holder(dir);
    if holder.is_reference_of(study) {
        return Ok(());
    }
    let name = &study.name;
    let message = match holder {
        Holder::Nothing => return Ok(()),
        Holder::Reference {
            study: other,
            record,
        } => format!(
            "holds the reference of study `{other}` ({}), not of `{name}`: --bless would write over \
             it; give another --reference, or remove the folder to bless `{name}` there",
            record.display()
        ),
        Holder::Run {
            study: other,
            evidence,
        } => format!(
            "is the output folder of a run{} ({}), not a reference: --bless would write over its \
             tables; give a folder of its own as --reference",
            other
                .map(|o| format!(" of study `{o}`"))
                .unwrap_or_default(),
            evidence.display()
        ),
        Holder::Tables { found, cases } => {
            let what = match cases {
                None => "whose summary.csv is no study's summary".to_string(),
                Some(ids) => {
                    let known: BTreeSet<&str> = study.cases.iter().map(|c| c.id.as_str()).collect();
                    let foreign = ids.iter().find(|id| !known.contains(id.as_str()));
                    match foreign {
                        Some(id) => format!(
                            "whose cases are not all cases of `{name}` (e.g. {id}): another study's \
                             reference, or an older one of `{name}`"
                        ),
                        None => "without its summary.csv".to_string(),
                    }
                }
            };
            format!(
                "holds {} and no {REFERENCE_FILE} naming its study, {what}: --bless would write \
                 over them; give another --reference, or remove them to bless `{name}` there",
                found.join(", ")
            )
        }
    };
    Err(StudyError::NotThisStudy {
        path: dir.to_path_buf(),
        message,
    })
}

/// Refuses a run into a stored reference (`reference.toml`, or reference tables with no run
/// beside them): its tables would be replaced by the run's without the check's say.
pub fn refuse_run_over_reference(dir: &Path) -> Result<(), StudyError> {
    let message = match holder(dir) {
        Holder::Reference { study, record } => format!(
            "holds the stored reference of study `{study}` ({}), not a run: a run would write over \
             its tables; give another --out (a reference is rewritten by `shipid check --bless` \
             only)",
            record.display()
        ),
        Holder::Tables { found, .. } => format!(
            "holds {} and no cases/: a stored reference (`shipid check --bless`) or another \
             program's tables, which a run would write over; give another --out",
            found.join(", ")
        ),
        Holder::Nothing | Holder::Run { .. } => return Ok(()),
    };
    Err(StudyError::NotThisStudy {
        path: dir.to_path_buf(),
        message,
    })
}

/// Writes `reference.toml` into `dir`, naming `study`.
pub fn write_reference_record(study: &Study, dir: &Path) -> Result<(), StudyError> {
    let path = dir.join(REFERENCE_FILE);
    let text = format!(
        "# Written by `shipid check --bless`: the tables beside this file are the reference of\n\
         # the study named here; --bless of another study refuses to write over them.\n{}",
        toml::to_string(&toml::Table::from_iter([(
            "study".to_string(),
            toml::Value::String(study.name.clone()),
        )]))
        .unwrap_or_default()
    );
    write_atomic(&path, text.as_bytes()).map_err(|source| StudyError::Io { path, source })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn folder(files: &[(&str, &str)]) -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        for (name, text) in files {
            let p = dir.path().join(name);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, text).unwrap();
        }
        dir
    }

    #[test]
    fn a_folder_says_whose_tables_it_holds() {
        let summary = "case,test,mrae\nx-1,a.csv,0.1\n";
        let d = folder(&[]);
        assert_eq!(holder(d.path()), Holder::Nothing);
        let d = folder(&[("notes.txt", "mine")]);
        assert_eq!(holder(d.path()), Holder::Nothing);
        let d = folder(&[
            ("reference.toml", "study = \"s1\"\n"),
            ("summary.csv", summary),
        ]);
        assert!(matches!(holder(d.path()), Holder::Reference { study, .. } if study == "s1"));
        let d = folder(&[
            ("study.toml", "name = \"other\"\n"),
            ("summary.csv", summary),
        ]);
        assert!(matches!(holder(d.path()), Holder::Run { study: Some(s), .. } if s == "other"));
        let d = folder(&[
            ("run.json", "{\"study\": \"r\"}"),
            ("reference.toml", "study = \"s\""),
        ]);
        assert!(matches!(holder(d.path()), Holder::Run { study: Some(s), .. } if s == "r"));
        let d = folder(&[("cases/x/config.toml", "")]);
        assert!(matches!(holder(d.path()), Holder::Run { study: None, .. }));
        let d = folder(&[("summary.csv", summary), ("coefficients.csv", "case\n")]);
        assert_eq!(
            holder(d.path()),
            Holder::Tables {
                found: vec!["summary.csv".into(), "coefficients.csv".into()],
                cases: Some(BTreeSet::from(["x-1".to_string()])),
            }
        );
        let d = folder(&[("summary.csv", "a,b\n1,2\n"), ("notes.txt", "mine")]);
        assert_eq!(
            holder(d.path()),
            Holder::Tables {
                found: vec!["summary.csv".into()],
                cases: None,
            }
        );
    }
}
