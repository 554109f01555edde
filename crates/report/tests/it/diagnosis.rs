use shipid_report::{DiagnosisFiles, RunMeta, diagnosis_page};

use crate::{assert_self_contained, fixture, meta, summary_case_ids};

#[test]
fn verdict_evidence_candidates_recordings_and_model() {
    let files = DiagnosisFiles::in_dir(&fixture("diagnosis-hsva"));
    assert!(files.figures.is_none());
    assert!(files.model.as_ref().unwrap().ends_with("report.model.toml"));
    let m = RunMeta {
        dataset: Some("data/kvlcc2-hsva/dataset.toml".into()),
        details: vec![("base model".into(), "mmg:kvlcc2".into())],
        ..meta()
    };
    let html = diagnosis_page(&files, &m).unwrap();
    assert_self_contained(&html);
    assert!(html.contains("<div class=\"word\">asymmetry</div>"));
    assert!(html.contains("explains 39 % of the held-out mismatch"));
    assert!(html.contains("0.3251\u{a0}L → 0.1982\u{a0}L (-39\u{a0}%)"));
    assert!(html.contains("offset ± 0.02893"));
    assert!(html.contains("data/kvlcc2-hsva/dataset.toml") && html.contains("mmg:kvlcc2"));
    // 10 candidates, two accepted.
    let c = html.find("<table class=\"candidates\"").unwrap();
    let c = &html[c..c + html[c..].find("</table>").unwrap()];
    assert_eq!(c.matches("<tr").count(), 11);
    assert_eq!(c.matches(">accepted</span>").count(), 2);
    // One summary row per recording; those made worse are marked.
    let recs = summary_case_ids(&html);
    assert_eq!(recs.len(), 13);
    assert!(recs.contains(&"z10_10_ps.csv".to_string()));
    assert!(html.contains("data-case-id=\"z10_10_ps.csv\" class=\"warn\""));
    // The augmented model file.
    assert!(html.contains("[ship]") || html.contains("<span class=\"h\">[ship]</span>"));
    assert!(html.contains("No figures"));
}

#[test]
fn a_verdict_of_none_with_figures_and_no_model() {
    let files = DiagnosisFiles::in_dir(&fixture("diagnosis-none"));
    assert!(files.model.is_none());
    let m = RunMeta {
        name: Some("diagnosis of /tmp/m.toml".into()),
        ..meta()
    };
    let html = diagnosis_page(&files, &m).unwrap();
    assert_self_contained(&html);
    assert!(html.contains("<h1>Diagnosis of /tmp/m.toml</h1>"));
    assert!(html.contains("<title>diagnosis of /tmp/m.toml: none — shipid report</title>"));
    assert!(html.contains("<div class=\"word\">none</div>"));
    assert!(html.contains("No augmented model file"));
    assert_eq!(html.matches("<figure ").count(), 1);
    assert!(html.contains("Equation-error residuals — tc35_sb"));
    assert_eq!(summary_case_ids(&html).len(), 6);
}

/// `shipid diagnose --plots DIR` writes its figures into DIR itself, beside report.json: the folder's
/// own SVGs are its figures when there is no `figures/`.
#[test]
fn figures_written_beside_the_report_are_found() {
    let dir = tempfile::tempdir().unwrap();
    let src = fixture("diagnosis-none");
    std::fs::copy(src.join("report.json"), dir.path().join("report.json")).unwrap();
    for e in std::fs::read_dir(src.join("figures")).unwrap().flatten() {
        std::fs::copy(e.path(), dir.path().join(e.file_name())).unwrap();
    }
    let files = DiagnosisFiles::in_dir(dir.path());
    assert_eq!(files.figures.as_deref(), Some(dir.path()));
    let html = diagnosis_page(&files, &meta()).unwrap();
    assert_eq!(html.matches("<figure ").count(), 1);
}

/// Regression (visual review §1): on a 420-px window the key/value grid left its value column a
/// few pixels wide (values one character per line), and the windage label alone was wider than the
/// window, pushing its value off-screen below a ~3400 px blank gap.
#[test]
fn key_value_pairs_stack_on_a_narrow_window_and_a_label_never_takes_the_row() {
    let files = DiagnosisFiles::in_dir(&fixture("diagnosis-hsva"));
    let html = diagnosis_page(&files, &meta()).unwrap();
    for list in ["dl.kv", "dl.facts"] {
        assert!(
            html.contains(&format!(
                "{list} {{ display:grid; grid-template-columns:fit-content(40%) minmax(0,1fr);"
            )),
            "{list}: a label column of at most 40 %"
        );
    }
    let narrow = html
        .find("@media (max-width:600px)")
        .expect("a narrow-window rule");
    let rule = &html[narrow..narrow + html[narrow..].find("\n}").unwrap()];
    assert!(
        rule.contains("dl.kv, dl.facts { grid-template-columns:minmax(0,1fr);"),
        "{rule}"
    );
}

/// Regression (visual review §1): the windage row's label "windage (assumed: the data set gives no
/// [windage])" outgrew a phone's width; the value says it is assumed.
#[test]
fn the_windage_label_is_short_and_the_value_says_it_is_assumed() {
    let dir = tempfile::tempdir().unwrap();
    let mut r: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(fixture("diagnosis-hsva").join("report.json")).unwrap(),
    )
    .unwrap();
    r["windage"] = serde_json::json!({"source": "assumed", "description": "frontal 0.258 m²"});
    std::fs::write(dir.path().join("report.json"), r.to_string()).unwrap();
    let html = diagnosis_page(&DiagnosisFiles::in_dir(dir.path()), &meta()).unwrap();
    assert!(
        html.contains(
            "<dt>windage</dt><dd>assumed (the data set gives no [windage]): frontal 0.258 m²</dd>"
        ),
        "{html}"
    );
    assert!(!html.contains("windage (assumed"));
}
