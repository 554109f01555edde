use std::fs;

use shipid_report::{RunMeta, study_page, write_report};

use crate::{assert_self_contained, fixture, meta, summary_case_ids};

fn page() -> String {
    study_page(&fixture("study"), &meta()).unwrap()
}

#[test]
fn every_case_has_a_row_with_its_id_and_a_details_block() {
    let html = page();
    let expected: Vec<String> = fs::read_to_string(fixture("study.case-ids"))
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect();
    assert_eq!(summary_case_ids(&html), expected);
    for id in &expected {
        assert!(html.contains(&format!("<tr id=\"case-{id}\" data-case-id=\"{id}\"")));
        assert!(html.contains(&format!(
            "<details id=\"details-{id}\" data-case-id=\"{id}\""
        )));
        assert!(html.contains(&format!("href=\"#details-{id}\"")));
    }
}

#[test]
fn header_shows_version_study_data_set_and_run_record() {
    let html = page();
    assert_self_contained(&html);
    assert!(html.contains("<title>truncation — shipid study report</title>"));
    // The version that made the run, not the caller's (which writes the page and warns).
    assert!(html.contains("<dd>shipid 0.2.1</dd>"), "run.json's version");
    assert!(html.contains("shipid 9.9.9-test"), "the page's writer");
    assert!(html.contains("studies/truncation.toml"));
    assert!(html.contains("data/kvlcc2-mmg/dataset.toml"));
    assert!(html.contains("<dt>started</dt><dd>2026-11-24T06:49:01Z</dd>"));
    // Keys without a place of their own are listed under "Run record", not the ones placed above.
    let r = html.find("Run record").expect("run record");
    let run_record = &html[r..r + html[r..].find("</section>").unwrap()];
    assert!(
        run_record.contains("some prediction diverged") && run_record.contains("wall time [s]")
    );
    assert!(!run_record.contains("started") && !run_record.contains("tool version"));
    // study.toml as the run configuration, its description under the title.
    assert!(html.contains("Overshoot truncation sweep"));
    assert!(html.contains("<span class=\"h\">[training]</span>"));
    // run.json's warning in the warnings box.
    let w = html.find("id=\"warnings\"").expect("warnings box");
    assert!(html[w..].contains("figure forces_x.svg could not be drawn: no data"));
}

#[test]
fn status_counts_and_summary_numbers() {
    let html = page();
    // 3 cases, 2 ok and 1 with a diverged prediction (os1: its fit is ok, 5 of its tests diverged;
    // the page used to say "3 cases ok" beside it where run.json says 2 with every prediction ok);
    // 18 tests of which 5 diverged.
    for (n, what) in [
        (3, "cases"),
        (2, "cases ok"),
        (1, "case with a diverged prediction"),
        (18, "tests"),
        (5, "tests diverged"),
        (13, "tests ok"),
    ] {
        assert!(
            html.contains(&format!("<span class=\"v\">{n}</span>{what}</div>")),
            "{n} {what}"
        );
    }
    // Units from the column names, four significant digits, the constant columns above the table.
    assert!(html.contains(">fit time [s]</th>"));
    assert!(html.contains(">position RMSE ÷ L</th>"));
    assert!(html.contains("All cases: set <code>reduced32</code>"));
    assert!(
        html.contains(">11.76</td>"),
        "position RMSE of os1 on zz10_10_ps, 11.761…"
    );
    assert!(html.contains("title=\"11.761444794293999\""));
    // The case with diverged tests is marked.
    assert!(
        html.contains("data-case-id=\"reduced32_lsq_fast_zz35_35_ps_os1-01228642\" class=\"bad\"")
    );
}

#[test]
fn figures_are_inline_svg_with_captions() {
    let html = page();
    assert_eq!(html.matches("<figure ").count(), 1);
    assert!(
        html.contains(
            "<figure id=\"figure-vif_reduced32.svg\" data-file=\"vif_reduced32.svg\"><svg "
        )
    );
    assert!(html.contains("Variance inflation factor per term — reduced32"));
    assert!(!html.contains("<?xml"));
}

#[test]
fn per_case_details_hold_tests_metrics_coefficients_and_files() {
    let html = page();
    let id = "reduced32_lsq_fast_zz35_35_ps_os2-122d3577";
    let start = html.find(&format!("<details id=\"details-{id}\"")).unwrap();
    let end = start
        + html[start..]
            .find("</details>\n")
            .unwrap_or(html.len() - start);
    let d = &html[start..end];
    for s in [
        "<h3>Tests</h3>",
        "<h3>Manoeuvre metrics</h3>",
        "<h3>Coefficients</h3>",
        "Fit diagnostics per DOF",
        "config.toml",
        "model.toml",
        "training samples",
    ] {
        assert!(d.contains(s), "{s}");
    }
}

#[test]
fn the_folder_alone_is_enough_and_meta_fills_gaps() {
    // Without run.json and study.toml: version and data set from the cases' config.toml.
    let dir = tempfile::tempdir().unwrap();
    copy_dir(&fixture("study"), dir.path());
    fs::remove_file(dir.path().join("run.json")).unwrap();
    fs::remove_file(dir.path().join("study.toml")).unwrap();
    fs::remove_dir_all(dir.path().join("figures")).unwrap();
    let html = study_page(dir.path(), &RunMeta::default()).unwrap();
    assert!(
        html.contains("<span class=\"kind\">Study</span> truncation"),
        "name from config.toml"
    );
    assert!(html.contains("shipid 0.2.1"));
    assert!(html.contains("studies/../data/kvlcc2-mmg/dataset.toml"));
    assert!(html.contains("no <code>study.toml</code>"));
    assert!(!html.contains("id=\"warnings\""));
    assert_eq!(summary_case_ids(&html).len(), 3);
    // The caller's warnings are shown.
    let m = RunMeta {
        warnings: vec!["one & <two>".into()],
        ..Default::default()
    };
    let html = study_page(dir.path(), &m).unwrap();
    assert!(html.contains("<li>one &amp; &lt;two&gt;</li>"));
}

#[test]
fn strings_from_the_data_are_escaped() {
    let dir = tempfile::tempdir().unwrap();
    let id = "case <b>&\"x'";
    fs::write(
        dir.path().join("summary.csv"),
        format!("case,set,case_status,fit_time_s,test,status,position_rmse_over_l\n\"{}\",s<1>,ok,0.5,t<script>,ok,0.25\n", id.replace('"', "\"\"")),
    )
    .unwrap();
    fs::create_dir_all(dir.path().join("figures")).unwrap();
    fs::write(
        dir.path().join("figures/evil.svg"),
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="20" height="10" onload="alert(1)"><script>alert(2)</script><a href="javascript:alert(3)"><text>x</text></a></svg>"#,
    )
    .unwrap();
    fs::write(dir.path().join("figures/broken.svg"), "<svg><g></svg>").unwrap();
    let m = RunMeta {
        name: Some("<i>name</i>".into()),
        ..Default::default()
    };
    let html = study_page(dir.path(), &m).unwrap();
    assert_self_contained(&html);
    assert!(!html.contains("<b>") && !html.contains("<i>") && !html.contains("t<script>"));
    assert!(!html.contains("alert") && !html.contains("javascript:"));
    assert!(html.contains("&lt;i&gt;name&lt;/i&gt;"));
    assert_eq!(summary_case_ids(&html), vec![id.to_string()]);
    assert!(html.contains("figure ") && html.contains("broken.svg left out"));
    assert_eq!(html.matches("<figure ").count(), 1);
}

#[test]
fn write_report_replaces_the_page_atomically() {
    let dir = tempfile::tempdir().unwrap();
    let p = write_report(dir.path(), "first").unwrap();
    assert_eq!(p, dir.path().join("report.html"));
    let p = write_report(dir.path(), "second").unwrap();
    assert_eq!(fs::read_to_string(&p).unwrap(), "second");
    let names: Vec<String> = fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names,
        vec!["report.html".to_string()],
        "no temporary file left"
    );
}

pub fn copy_dir(from: &std::path::Path, to: &std::path::Path) {
    fs::create_dir_all(to).unwrap();
    for e in fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let target = to.join(e.file_name());
        if e.path().is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            fs::copy(e.path(), target).unwrap();
        }
    }
}

#[test]
fn a_case_whose_fit_failed_has_its_row_and_no_tests() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(
        dir.path().join("summary.csv"),
        "case,set,case_status,fit_time_s,test,status,position_rmse_over_l\n\
         a,s,ok,0.5,t1,ok,0.25\na,s,ok,0.5,t2,diverged,0.5\nb,s,fit-failed,,,,\n",
    )
    .unwrap();
    fs::create_dir_all(dir.path().join("cases/b")).unwrap();
    fs::write(
        dir.path().join("cases/b/result.json"),
        r#"{"case_id": "b", "status": "fit-failed", "message": "singular <design>", "tests": []}"#,
    )
    .unwrap();
    let html = study_page(dir.path(), &RunMeta::default()).unwrap();
    assert_eq!(summary_case_ids(&html), vec!["a", "b"]);
    assert!(html.contains("data-case-id=\"b\" class=\"bad\""));
    assert!(html.contains("<span class=\"v\">1</span>cases fit-failed</div>"));
    assert!(
        html.contains("<span class=\"v\">2</span>tests</div>"),
        "b has no test"
    );
    assert!(html.contains("singular &lt;design&gt;"));
}

#[test]
fn a_study_with_bands_shows_each_metrics_band_and_whether_the_record_is_inside() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(
        dir.path().join("summary.csv"),
        "case,set,case_status,fit_time_s,test,status,position_rmse_over_l,\
         overshoot_1_recorded,overshoot_1_predicted,overshoot_1_rel_error,\
         overshoot_1_lo,overshoot_1_hi,overshoot_1_inside\n\
         c1,reduced32,ok,0.5,zz20_20_ps.csv,ok,0.25,13.5,10.75,-0.2,2.5,11.25,no\n",
    )
    .unwrap();
    let html = study_page(dir.path(), &RunMeta::default()).unwrap();
    assert!(
        html.contains("<th scope=\"col\">band</th><th scope=\"col\">recorded inside</th>"),
        "{html}"
    );
    assert!(html.contains("[2.5000, 11.2500]</td><td>no</td>"));
    // The band columns are shown in the metric table, not again among the test's other columns.
    assert!(!html.contains(">overshoot_1_lo<"));
    // A study without bands keeps its metric table as it was.
    assert!(!page().contains(">band</th>"));
}

#[test]
fn a_page_names_the_version_of_the_run_and_warns_of_the_callers_other_one() {
    use shipid_report::study_page_with_warnings;
    // Written by the version that made the run: no warning.
    let same = RunMeta {
        tool_version: Some("0.2.1".into()),
        ..Default::default()
    };
    let (html, warnings) = study_page_with_warnings(&fixture("study"), &same).unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    assert!(html.contains("<dd>shipid 0.2.1</dd>") && !html.contains("page written by"));
    // A newer binary reporting the folder: run.json and the three cases' configs name 0.2.1.
    let (html, warnings) = study_page_with_warnings(&fixture("study"), &meta()).unwrap();
    assert_eq!(warnings.len(), 2, "{warnings:?}");
    assert!(warnings[0].contains("run.json") && warnings[0].contains("shipid 0.2.1"));
    assert!(warnings[1].contains("3 case(s) were computed by shipid 0.2.1, not 9.9.9-test"));
    assert!(
        html.contains("<dd>shipid 0.2.1</dd>"),
        "the results' version"
    );
    let w = html.find("id=\"warnings\"").expect("warnings box");
    assert!(html[w..].contains("3 case(s) were computed by shipid 0.2.1"));
}

#[test]
fn a_force_figure_of_a_case_not_in_the_summary_is_left_out() {
    let dir = tempfile::tempdir().unwrap();
    copy_dir(&fixture("study"), dir.path());
    let svg = fs::read_to_string(dir.path().join("figures/vif_reduced32.svg")).unwrap();
    let current = summary_case_ids(&page())[0].clone();
    fs::write(
        dir.path()
            .join(format!("figures/forces_{current}_zz35_35_ps.svg")),
        &svg,
    )
    .unwrap();
    fs::write(
        dir.path()
            .join("figures/forces_full74_lsq_fast_zz35_35_ps_os4-0badcafe_zz35_35_ps.svg"),
        &svg,
    )
    .unwrap();
    let html = study_page(dir.path(), &meta()).unwrap();
    assert!(html.contains(&format!("data-file=\"forces_{current}_zz35_35_ps.svg\"")));
    assert!(!html.contains("data-file=\"forces_full74"));
    assert!(html.contains("forces_full74_lsq_fast_zz35_35_ps_os4-0badcafe_zz35_35_ps.svg: a figure of a case that is not in summary.csv: left out"));
}

/// Regression: a test whose replay diverged (its closed-loop manoeuvre ran to the end) counted as
/// "tests ok" and badged its case "2 ok", while the run said "1 with a diverged prediction".
#[test]
fn a_diverged_replay_counts_and_badges_as_a_diverged_test() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(
        dir.path().join("summary.csv"),
        "case,set,case_status,fit_time_s,test,status,diverged_at_s,replay_status,replay_diverged_at_s\n\
         a,s,ok,0.5,zz20.csv,ok,,diverged,228.6\na,s,ok,0.5,tc35.csv,ok,,ok,\n\
         b,s,ok,0.5,zz20.csv,ok,,ok,\nb,s,ok,0.5,tc35.csv,ok,,ok,\n",
    )
    .unwrap();
    let html = study_page(dir.path(), &RunMeta::default()).unwrap();
    for (n, what) in [
        (1, "cases ok"),
        (1, "case with a diverged prediction"),
        (4, "tests"),
        (1, "tests diverged"),
        (3, "tests ok"),
    ] {
        assert!(
            html.contains(&format!("<span class=\"v\">{n}</span>{what}</div>")),
            "{n} {what}"
        );
    }
    assert!(
        html.contains("data-case-id=\"a\" class=\"bad\""),
        "a is marked"
    );
    assert!(html.contains("data-case-id=\"b\" class=\"good\""));
}

/// Regression: a rerun of a changed study stopped after its first case left summary.csv and
/// run.json of the old run beside the new case's files, and the page showed them as one run.
#[test]
fn a_case_rewritten_after_the_summary_is_named_in_the_warnings() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(
        dir.path().join("summary.csv"),
        "case,set,case_status,test,status\na,s,ok,zz35.csv,ok\nb,s,ok,zz35.csv,ok\n",
    )
    .unwrap();
    for (id, tests) in [("a", "zz10.csv"), ("b", "zz35.csv")] {
        fs::create_dir_all(dir.path().join("cases").join(id)).unwrap();
        fs::write(
            dir.path().join(format!("cases/{id}/config.toml")),
            format!("study = \"s\"\ntests = [\"{tests}\"]\n"),
        )
        .unwrap();
    }
    let html = study_page(dir.path(), &RunMeta::default()).unwrap();
    let w = html.find("id=\"warnings\"").expect("warnings box");
    let box_ = &html[w..w + html[w..].find("</section>").unwrap_or(html.len() - w)];
    assert!(
        box_.contains(
            "case a: cases/a/config.toml (other tests) is of another run than summary.csv"
        ),
        "{box_}"
    );
    assert!(!box_.contains("case b:"), "{box_}");
    // The shipped fixture's cases agree with its summary.
    assert!(!page().contains("is of another run than summary.csv"));
}

/// Regression (visual review §6): the 1-overshoot case, whose fit is ok but 5 of whose 6 tests
/// diverged, showed a green "ok" in the summary and in its details.
#[test]
fn a_case_with_diverged_tests_does_not_show_a_green_ok() {
    let html = page();
    let id = "reduced32_lsq_fast_zz35_35_ps_os1-01228642";
    let row = html
        .find(&format!("<tr id=\"case-{id}\""))
        .expect("os1's row");
    let row = &html[row..row + html[row..].find("</tr>").unwrap()];
    assert!(
        row.contains("<span class=\"badge bad\"")
            && row.contains(">fit ok · 5 of 6 diverged</span>"),
        "{row}"
    );
    let d = html.find(&format!("<details id=\"details-{id}\"")).unwrap();
    let summary = &html[d..d + html[d..].find("</summary>").unwrap()];
    assert!(
        summary.contains(">fit ok · 5 of 6 diverged</span>"),
        "{summary}"
    );
    // A case whose every test is ok keeps its plain badge.
    let ok = "reduced32_lsq_fast_zz35_35_ps_os2-122d3577";
    let row = html.find(&format!("<tr id=\"case-{ok}\"")).unwrap();
    let row = &html[row..row + html[row..].find("</tr>").unwrap()];
    assert!(
        row.contains("<span class=\"badge good\">ok</span>"),
        "{row}"
    );
}

/// Regression (visual review §2): on a phone the sticky case column, in nowrap monospace, was as
/// wide as the screen and hid every other column of the summary.
#[test]
fn the_summary_case_column_is_capped_and_not_sticky_on_a_narrow_window() {
    let html = page();
    let narrow = html
        .find("@media (max-width:600px)")
        .expect("a narrow-window rule");
    let rule = &html[narrow..narrow + html[narrow..].find("\n}").unwrap()];
    assert!(
        rule.contains("table.summary td.id, table.summary th.id { position:static; }"),
        "{rule}"
    );
    assert!(html.contains("table.summary td.id a { display:block; max-width:40vw;"));
    // The full id in the link's title; without the prefix all cases share on a narrow window.
    let id = "reduced32_lsq_fast_zz35_35_ps_os2-122d3577";
    assert!(html.contains(&format!(
        "<a href=\"#details-{id}\" title=\"{id}\"><span class=\"full\">{id}</span><span class=\"tail\">…os2-122d3577</span></a>"
    )));
}

/// Regression (visual review §13): inline figures were unnamed images to a screen reader, and the
/// tables had neither a caption nor header scopes.
#[test]
fn each_svg_has_a_title_and_tables_have_captions_and_scopes() {
    let html = page();
    let n_svg = html.matches("<svg ").count();
    assert!(n_svg > 0);
    for (i, svg) in html.split("<svg ").skip(1).enumerate() {
        let open = &svg[..svg.find('>').unwrap()];
        assert!(open.contains("role=\"img\""), "svg {i}");
        let cap = open
            .split("aria-labelledby=\"")
            .nth(1)
            .map(|s| &s[..s.find('"').unwrap()])
            .unwrap_or_else(|| panic!("svg {i} has no aria-labelledby"));
        assert!(
            html.contains(&format!("<figcaption id=\"{cap}\">")),
            "svg {i}"
        );
        assert!(
            svg[open.len() + 1..].starts_with("<title>"),
            "svg {i}: no <title> first"
        );
    }
    assert!(html.contains("<title>Variance inflation factor per term — reduced32</title>"));
    assert!(html.contains("<table class=\"summary\"><caption class=\"vh\">"));
    assert_eq!(
        html.matches("<th>").count(),
        0,
        "a header cell without a scope"
    );
    assert!(html.matches("<th scope=\"col\"").count() > 10);
}

/// Regression: an earlier run of the same study with other grid values left its case folders in
/// the --out, and the page counted them as the run's ("3 cases · 2 cases no row" where run.json
/// says 1 case). They are named in the warnings and not shown as cases.
#[test]
fn leftover_case_folders_of_an_earlier_run_are_not_counted_as_cases() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(
        dir.path().join("summary.csv"),
        "case,set,case_status,test,status\na,s,ok,zz35.csv,ok\n",
    )
    .unwrap();
    for id in ["a", "old1", "old2"] {
        fs::create_dir_all(dir.path().join("cases").join(id)).unwrap();
    }
    let html = study_page(dir.path(), &RunMeta::default()).unwrap();
    assert!(
        html.contains("<span class=\"v\">1</span>cases</div>"),
        "one case"
    );
    assert!(!html.contains("no row</div>"), "no 'cases no row' tile");
    assert!(!html.contains("data-case-id=\"old1\""));
    let w = html.find("id=\"warnings\"").expect("warnings box");
    assert!(
        html[w..].contains(
            "2 folder(s) under cases/ have no row in summary.csv and are not cases of this run"
        ) && html[w..].contains("old1, …"),
        "{}",
        &html[w..]
    );
}
