//! Regression (a probe with a symmetric polynomial of a port/starboard asymmetric ship): the
//! diagnosis named `asymmetry` on recordings the model reproduced exactly as well as its own
//! training data (held-out 0.0887 L, its own level 0.0887 L). The shape an effect takes out of such
//! a mismatch is the model's own misfit, in its training data as much; the verdict is `none`, with
//! the effect named as that misfit.

use shipid_diagnose::{DiagnoseInput, DiagnoseOptions, Verdict, diagnose, model_level};
use shipid_io::{Manoeuvre, Side};
use shipid_pipeline::generate::generate_manoeuvres;
use shipid_sim::MmgModel;
use shipid_sim::effects::{Asymmetry, Effect};

fn runs(seed: u64) -> shipid_io::Dataset {
    let m: Vec<Manoeuvre> = [Side::Port, Side::Starboard]
        .into_iter()
        .flat_map(|side| {
            [
                Manoeuvre::ZigZag {
                    rudder_deg: 20.0,
                    check_deg: 20.0,
                    side,
                },
                Manoeuvre::ZigZag {
                    rudder_deg: 10.0,
                    check_deg: 10.0,
                    side,
                },
            ]
        })
        .collect();
    // The ship's rudder sits 1.5° off: in the training runs and in the runs diagnosed alike.
    let offset = Effect::Asymmetry(Asymmetry {
        rudder_offset_deg: 1.5,
        y0_n: 0.0,
        n0_nm: 0.0,
    });
    generate_manoeuvres(Some(seed), &[offset], &m)
        .unwrap()
        .in_memory(&m, "offset")
}

#[test]
fn an_effect_in_the_training_data_as_much_is_the_models_own_misfit_not_a_verdict() {
    // The base: the reference without the offset, "identified" on runs that have it.
    let model = MmgModel::kvlcc2();
    let opts = DiagnoseOptions::default();
    let input = |level| DiagnoseInput {
        base: &model,
        base_effects: &[],
        model_level_over_l: level,
        identification_range: None,
    };
    let level = model_level(&input(None), &runs(1), &opts);
    let report = diagnose(&input(Some(level)), &runs(2), &opts).unwrap();
    assert_eq!(report.verdict, Verdict::None, "{}", report.explanation);
    assert!(report.effects.is_empty());
    assert!(
        report.explanation.contains("the model's own misfit")
            && report.explanation.contains("asymmetry"),
        "{}",
        report.explanation
    );
    // Without the model's own level (a model naming no training data) the same mismatch is an
    // effect the recordings show.
    let alone = diagnose(&input(None), &runs(2), &opts).unwrap();
    assert_eq!(alone.verdict, Verdict::Asymmetry, "{}", alone.explanation);
}
