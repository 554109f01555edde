//! Integration tests of shipid-report on fixtures cut from real `shipid run`/`plot`/`diagnose` output
//! (tests/fixtures: three cases of the truncation study, two diagnoses).

mod browser;
mod diagnosis;
mod errors;
mod study;

use std::path::{Path, PathBuf};

pub fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

pub fn meta() -> shipid_report::RunMeta {
    shipid_report::RunMeta {
        tool_version: Some("9.9.9-test".into()),
        ..Default::default()
    }
}

/// The shipped page is self-contained and script-free.
pub fn assert_self_contained(html: &str) {
    let lower = html.to_ascii_lowercase();
    assert!(!lower.contains("<script"), "a <script> in the page");
    for attr in [
        "src=\"http",
        "href=\"http",
        "src=\"//",
        "href=\"//",
        "@import",
        "<link",
        "<iframe",
    ] {
        assert!(
            !lower.contains(attr),
            "the page refers to something outside it: {attr}"
        );
    }
    assert!(!lower.contains("url(http"), "an external url() in the page");
}

/// The case ids of the summary table's rows, in order.
pub fn summary_case_ids(html: &str) -> Vec<String> {
    let start = html.find("<table class=\"summary").expect("summary table");
    let end = start + html[start..].find("</table>").unwrap();
    html[start..end]
        .split("data-case-id=\"")
        .skip(1)
        .map(|s| unescape(&s[..s.find('"').unwrap()]))
        .collect()
}

pub fn unescape(s: &str) -> String {
    s.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&#39;", "'")
        .replace("&amp;", "&")
}
