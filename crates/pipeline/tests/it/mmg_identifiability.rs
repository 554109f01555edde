//! What `fit --set mmg` says of each parameter and of its bootstrap: the labels follow the numbers
//! (`shipid_pipeline::mmg::file::{ParamEntry::identifiability, replicate_shape}`).

use shipid_pipeline::mmg::file::{Identifiability, ParamEntry, replicate_shape};

fn entry(value: f64, bounds: (f64, f64), prior: (f64, f64), share: f64) -> ParamEntry {
    ParamEntry {
        name: "p".into(),
        value,
        lower: bounds.0,
        upper: bounds.1,
        prior: prior.0,
        prior_sd: prior.1,
        prior_source: String::new(),
        standard_error: 0.025,
        data_share: share,
        determined_by_data: share > 0.5,
        jackknife_standard_error: None,
    }
}

fn check_label(e: ParamEntry, expected: Identifiability) {
    assert_eq!(e.identifiability(), expected, "{e:?}");
}

/// Regression: epsilon = 1.698 with prior 0.6 ± 0.2 (5.5 sd away) was listed "prior-held (data share
/// 0.44)", and kappa = 0 on its lower bound had `determined_by_data = true` beside a Hessian
/// standard error, as if it were an interior estimate.
#[test]
fn mmg_prior_held_label_of_a_parameter_far_from_its_prior() {
    use Identifiability::*;
    // epsilon of the report: little data share, far from the prior.
    check_label(
        entry(1.698, (0.2, 2.0), (0.6, 0.2), 0.44),
        MovedByCorrelated,
    );
    // Within 2 prior sd with the same share: it stayed at its prior.
    check_label(entry(0.9, (0.2, 2.0), (0.6, 0.2), 0.44), PriorHeld);
    // kappa on its lower bound, data share high: the bound holds it.
    check_label(entry(0.0, (0.0, 1.0), (0.5, 0.2), 0.9), OnBound);
    // On a one-sided bound, within 1e-3 prior sd of it.
    check_label(
        entry(-1.5, (-1.5, f64::INFINITY), (-0.7, 0.3), 0.9),
        OnBound,
    );
    check_label(entry(0.4, (0.0, 1.0), (0.5, 0.2), 0.9), DeterminedByData);
}

/// The jackknife over training recordings overrides the information matrix's "determined" when the
/// refits without one recording spread a parameter as far as its prior allows.
#[test]
fn mmg_recordings_that_disagree_undo_determined_by_data() {
    use Identifiability::*;
    let with = |e: ParamEntry, jse: f64| ParamEntry {
        jackknife_standard_error: Some(jse),
        ..e
    };
    // X′_vv of the HSVA fit: share 0.99, jackknife ± 0.081 against a prior sd of 0.1.
    check_label(
        with(
            entry(
                -0.13,
                (f64::NEG_INFINITY, f64::INFINITY),
                (-0.013, 0.1),
                0.99,
            ),
            0.081,
        ),
        RecordingsDisagree,
    );
    // X′_vr: jackknife ± 0.066 against a prior sd of 0.2 leaves the data most of the precision.
    check_label(
        with(
            entry(0.028, (f64::NEG_INFINITY, f64::INFINITY), (0.0, 0.2), 1.0),
            0.066,
        ),
        DeterminedByData,
    );
    // Not determined by the information matrix in the first place: the jackknife changes nothing.
    check_label(
        with(entry(0.9, (0.2, 2.0), (0.6, 0.2), 0.44), 0.5),
        PriorHeld,
    );
    // On a bound, whatever the refits do.
    check_label(with(entry(0.0, (0.0, 1.0), (0.5, 0.2), 0.9), 0.5), OnBound);
}

fn check_shape(values: &[f64], fit: f64, expected: Option<&str>) {
    let got = replicate_shape(values, fit);
    match expected {
        None => assert_eq!(got, None, "{values:?} about {fit}"),
        Some(words) => assert!(
            got.as_deref().is_some_and(|g| g.contains(words)),
            "{values:?} about {fit}: {got:?}, expected it to say {words:?}"
        ),
    }
}

/// Regression: c1's 60 bootstrap replicates took two values, 0.0 and 8.31, neither near the fit
/// 0.404, and the summary said nothing; its bootstrap standard error described no spread about the
/// estimate.
#[test]
fn mmg_bootstrap_replicates_bimodal_and_far_from_the_fit() {
    let split: Vec<f64> = (0..60)
        .map(|k| if k % 3 == 0 { 0.0 } else { 8.31 })
        .collect();
    check_shape(&split, 0.404, Some("neither holding the fit 0.404"));
    check_shape(&split, 8.31, Some("the fit 8.31 in one"));
    // All on one side of the fit.
    let beside: Vec<f64> = (0..60).map(|k| 1.4 + 0.005 * k as f64).collect();
    check_shape(&beside, 1.698, Some("lies beside the fit 1.698"));
    // Spread around the fit: nothing to say; nor about a parameter held on a bound.
    let around: Vec<f64> = (0..60).map(|k| 0.4 + 0.001 * (k as f64 - 30.0)).collect();
    check_shape(&around, 0.4, None);
    check_shape(&[0.0; 60], 0.0, None);
    // One outlier is no second group.
    let mut outlier = around.clone();
    outlier[0] = 5.0;
    check_shape(&outlier, 0.4, None);
    // Too few replicates to speak of a shape.
    check_shape(&[0.0, 8.31, 0.0, 8.31], 0.404, None);
}
