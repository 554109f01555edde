//! A diverged replay's errors cover only the part before the divergence, which made a model that
//! failed look like the best of a study (tester's finding A1).

use shipid_study::load_study;
use shipid_study::runner::{TestStatus, run_case};
use shipid_study::tables::{summary_pivot, summary_table};

use super::study_file;

/// Paper 000's truncation case cut after one overshoot: its replays diverge on most tests.
const ONE_OVERSHOOT: &str = r#"
name = "one_overshoot"
sets = ["reduced32"]
[training]
recordings = [["zz35_35_ps.csv"]]
overshoots = [1]
[[estimator]]
name = "lsq"
[test]
recordings = ["zz35_35_ps.csv", "zz20_20_ps.csv"]
"#;

#[test]
fn a_diverged_replay_has_no_rmse_in_result_summary_or_table() {
    let (_dir, path) = study_file(ONE_OVERSHOOT);
    let study = load_study(&path).unwrap();
    let (result, _) = run_case(&study, &study.cases[0]);
    let diverged: Vec<_> = result
        .tests
        .iter()
        .filter(|t| t.replay_status == TestStatus::Diverged)
        .collect();
    assert!(!diverged.is_empty(), "the fixture must diverge: {result:?}");
    for t in &diverged {
        assert!(t.replay_diverged_at_s.is_some_and(|s| s > 0.0), "{t:?}");
        assert_eq!(
            [
                t.position_rmse_over_l,
                t.heading_rmse_deg,
                t.u_rmse_m_s,
                t.v_rmse_m_s,
                t.r_rmse_deg_s
            ],
            [None; 5],
            "{}",
            t.test
        );
    }

    // A result.json of an earlier version, which stored the errors up to the divergence.
    let mut old = result.clone();
    for t in old.tests.iter_mut() {
        if t.replay_status == TestStatus::Diverged {
            t.position_rmse_over_l = Some(0.0025);
            t.heading_rmse_deg = Some(1.6);
        }
    }
    let table = summary_table(&study, std::slice::from_ref(&old));
    let status = table.column("replay_status").unwrap();
    let position = table.column("position_rmse_over_l").unwrap();
    let heading = table.column("heading_rmse_deg").unwrap();
    for i in 0..table.rows() {
        if status.cell(i) == "diverged" {
            assert_eq!(
                (position.cell(i), heading.cell(i)),
                (String::new(), String::new())
            );
        } else {
            assert!(position.cell(i).parse::<f64>().is_ok());
        }
    }
    let md = summary_pivot(&table, Some("window,test,position_rmse_over_l")).unwrap();
    assert!(!md.contains("0.0025"), "{md}");
    assert!(md.contains("–"), "{md}");
}
