//! The hostile-input corpus: every directory `tests/hostile/<area>/<case>/` with a `case.toml` is one
//! careless or hostile use of the binary, with the exit code and the words of the message it must
//! give. Each case runs in a fresh temporary copy of its directory, so relative paths refer to the
//! files beside `case.toml` and whatever the binary writes stays there; `{root}` in the arguments is
//! the repository root (for the shipped data). A case that runs longer than `CASE_TIMEOUT` fails: an
//! absurd request must be refused before work starts, not discovered by waiting.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use serde::Deserialize;

use crate::common::root;

const CASE_TIMEOUT: Duration = Duration::from_secs(60);

/// The corpus must keep covering every subcommand with at least this many cases (issue 25's floor).
const MIN_CASES: usize = 80;

const SUBCOMMANDS: [&str; 13] = [
    "generate", "import", "metrics", "fit", "simulate", "run", "table", "plot", "report", "check",
    "validate", "diagnose", "inverse",
];

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Case {
    what: String,
    args: Vec<String>,
    exit: i32,
    #[serde(default)]
    stderr_has: Vec<String>,
    #[serde(default)]
    stderr_lacks: Vec<String>,
    #[serde(default)]
    stdout_has: Vec<String>,
    #[serde(default)]
    stdout_lacks: Vec<String>,
    #[serde(default)]
    unchanged: Vec<String>,
    #[serde(default)]
    absent: Vec<String>,
}

fn corpus_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/hostile")
}

/// Every case directory, sorted (area/name).
fn case_dirs() -> Vec<PathBuf> {
    let mut dirs = Vec::new();
    let Ok(areas) = std::fs::read_dir(corpus_dir()) else {
        return dirs;
    };
    for area in areas.flatten().filter(|e| e.path().is_dir()) {
        for case in std::fs::read_dir(area.path()).unwrap().flatten() {
            if case.path().join("case.toml").is_file() {
                dirs.push(case.path());
            }
        }
    }
    dirs.sort();
    dirs
}

fn read_case(dir: &Path) -> Result<Case, String> {
    let text = std::fs::read_to_string(dir.join("case.toml")).map_err(|e| e.to_string())?;
    toml::from_str(&text).map_err(|e| format!("case.toml: {e}"))
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap().flatten() {
        let target = to.join(entry.file_name());
        if entry.path().is_dir() {
            copy_dir(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), &target).unwrap();
        }
    }
}

/// Run one case; the list of everything it got wrong (empty when it passes).
fn check(dir: &Path) -> Vec<String> {
    let case = match read_case(dir) {
        Ok(c) => c,
        Err(e) => return vec![e],
    };
    if case.what.trim().is_empty() {
        return vec!["`what` is empty: say what is hostile and what must happen".into()];
    }
    let tmp = tempfile::tempdir().unwrap();
    let work = tmp.path().join("case");
    copy_dir(dir, &work);
    std::fs::remove_file(work.join("case.toml")).unwrap();
    let before: Vec<Option<Vec<u8>>> = case
        .unchanged
        .iter()
        .map(|f| std::fs::read(work.join(f)).ok())
        .collect();
    let root = std::fs::canonicalize(root()).unwrap();
    let args: Vec<String> = case
        .args
        .iter()
        .map(|a| a.replace("{root}", root.to_str().unwrap()))
        .collect();
    let mut child = Command::new(env!("CARGO_BIN_EXE_shipid"))
        .args(&args)
        .current_dir(&work)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the shipid binary starts");
    // Drain both pipes while the case runs: a case that prints more than a pipe holds (64 KiB) would
    // otherwise block on its write and be reported as a timeout.
    let drain = |pipe: Option<Box<dyn std::io::Read + Send>>| {
        std::thread::spawn(move || {
            let mut bytes = Vec::new();
            if let Some(mut p) = pipe {
                let _ = p.read_to_end(&mut bytes);
            }
            bytes
        })
    };
    let out_reader = drain(child.stdout.take().map(|p| Box::new(p) as _));
    let err_reader = drain(child.stderr.take().map(|p| Box::new(p) as _));
    let started = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break Some(status);
        }
        if started.elapsed() > CASE_TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let output = std::process::Output {
        status: status.unwrap_or_default(),
        stdout: out_reader.join().unwrap_or_default(),
        stderr: err_reader.join().unwrap_or_default(),
    };
    let Some(status) = status else {
        return vec![format!("still running after {} s", CASE_TIMEOUT.as_secs())];
    };
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    let mut wrong = Vec::new();
    if status.code() != Some(case.exit) {
        wrong.push(format!("exit {:?}, expected {}", status.code(), case.exit));
    }
    if stderr.contains("panicked") {
        wrong.push("panicked".into());
    }
    for (text, name, has, lacks) in [
        (&stderr, "stderr", &case.stderr_has, &case.stderr_lacks),
        (&stdout, "stdout", &case.stdout_has, &case.stdout_lacks),
    ] {
        for piece in has {
            if !text.contains(piece.as_str()) {
                wrong.push(format!("{name} lacks {piece:?}"));
            }
        }
        for piece in lacks {
            if text.contains(piece.as_str()) {
                wrong.push(format!("{name} has {piece:?}"));
            }
        }
    }
    for (file, was) in case.unchanged.iter().zip(&before) {
        if &std::fs::read(work.join(file)).ok() != was {
            wrong.push(format!("{file} was changed"));
        }
    }
    for path in &case.absent {
        if work.join(path).exists() {
            wrong.push(format!("{path} exists"));
        }
    }
    if !wrong.is_empty() {
        wrong.push(format!("stderr was: {}", stderr.trim_end()));
    }
    wrong
}

#[test]
fn hostile_input_corpus() {
    let dirs = case_dirs();
    let filter = std::env::var("SHIPID_HOSTILE_CASE").ok();
    let dirs: Vec<PathBuf> = dirs
        .into_iter()
        .filter(|d| {
            filter
                .as_ref()
                .is_none_or(|f| d.to_string_lossy().contains(f))
        })
        .collect();
    let threads = std::thread::available_parallelism()
        .map_or(2, |n| n.get())
        .max(2);
    let next = std::sync::atomic::AtomicUsize::new(0);
    let failures = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let Some(dir) = dirs.get(i) else { break };
                    let wrong = check(dir);
                    if !wrong.is_empty() {
                        let name = dir.strip_prefix(corpus_dir()).unwrap_or(dir);
                        failures.lock().unwrap().push(format!(
                            "{}:\n  {}",
                            name.display(),
                            wrong.join("\n  ")
                        ));
                    }
                }
            });
        }
    });
    let mut failures = failures.into_inner().unwrap();
    failures.sort();
    assert!(
        failures.is_empty(),
        "{} of {} hostile cases failed:\n{}",
        failures.len(),
        dirs.len(),
        failures.join("\n")
    );
}

#[test]
fn hostile_corpus_covers_every_subcommand() {
    let cases: Vec<Case> = case_dirs()
        .iter()
        .map(|d| read_case(d).unwrap_or_else(|e| panic!("{}: {e}", d.display())))
        .collect();
    let covered: BTreeSet<&str> = cases
        .iter()
        .filter_map(|c| c.args.first().map(String::as_str))
        .collect();
    let missing: Vec<&str> = SUBCOMMANDS
        .iter()
        .copied()
        .filter(|s| !covered.contains(s))
        .collect();
    assert!(missing.is_empty(), "no hostile case for {missing:?}");
    assert!(
        cases.len() >= MIN_CASES,
        "{} hostile cases, the corpus keeps at least {MIN_CASES}",
        cases.len()
    );
}
