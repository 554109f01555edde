//! The pages in headless Chromium, through `.ci/browser-check.sh`: a screenshot, every expected case
//! id in the rendered summary table, every figure's SVG drawn with a size. Skips with a notice when
//! /usr/bin/chromium is missing, unless SHIPID_REQUIRE_BROWSER=1 (the script decides).
//! Screenshots: target/tmp/report-screenshots/*.png.

use std::path::{Path, PathBuf};
use std::process::Command;

use shipid_report::{DiagnosisFiles, diagnosis_page, study_page, write_report};

use crate::{fixture, meta};

fn check(name: &str, dir: &Path, html: &str, expected: &Path, min_figures: usize) {
    let out = tempfile::tempdir().unwrap();
    let page_dir = out.path().join(name);
    crate::study::copy_dir(dir, &page_dir);
    let report = write_report(&page_dir, html).unwrap();
    let shots = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("report-screenshots");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../.ci/browser-check.sh");
    let o = Command::new("bash")
        .arg(&script)
        .arg(&report)
        .arg(shots.join(format!("{name}.png")))
        .arg(expected)
        .arg(min_figures.to_string())
        .output()
        .expect("bash runs");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    // The script prints a SKIPPED line itself when there is no browser (CONTRIBUTING.md convention).
    eprintln!("{text}");
    assert!(
        o.status.success(),
        "browser check of {name} failed:\n{text}"
    );
}

#[test]
fn study_page_in_a_browser() {
    let dir = fixture("study");
    let html = study_page(&dir, &meta()).unwrap();
    check("study", &dir, &html, &fixture("study.case-ids"), 1);
}

#[test]
fn diagnosis_page_in_a_browser() {
    let dir = fixture("diagnosis-none");
    let html = diagnosis_page(&DiagnosisFiles::in_dir(&dir), &meta()).unwrap();
    let ids = tempfile::NamedTempFile::new().unwrap();
    std::fs::write(
        ids.path(),
        "zz10_10_ps.csv\nzz20_20_ps.csv\nzz35_35_ps.csv\nzz35_35_sb.csv\ntc35_ps.csv\ntc35_sb.csv\n",
    )
    .unwrap();
    check("diagnosis", &dir, &html, ids.path(), 1);
}
