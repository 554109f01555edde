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

/// The diagnosis input of `model` with its own level `level` [÷ L] (None: a model naming no
/// training data).
fn input_of(model: &MmgModel, level: Option<f64>) -> DiagnoseInput<'_> {
    DiagnoseInput {
        base: model,
        base_effects: &[],
        model_level_over_l: level,
        identification_range: None,
    }
}

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
    let input = |level| input_of(&model, level);
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

/// Runs of the reference ship in a concealed current of `speed_m_s` from 120°.
fn runs_in_current(seed: u64, speed_m_s: f64) -> shipid_io::Dataset {
    let m: Vec<Manoeuvre> = [Side::Port, Side::Starboard]
        .into_iter()
        .map(|side| Manoeuvre::ZigZag {
            rudder_deg: 20.0,
            check_deg: 20.0,
            side,
        })
        .collect();
    let current = Effect::Current(shipid_sim::effects::Current {
        speed_m_s,
        from_deg: 120.0,
    });
    generate_manoeuvres(Some(seed), &[current], &m)
        .unwrap()
        .in_memory(&m, "current")
}

/// Regression (probe of the mmg family): a model that did not reproduce its own training data
/// (own level 0.38 L, fitted on a straight run) said `none`, "within the model's own level", as if
/// model and recordings agreed. `none` is all such a model allows, and the explanation now says the
/// misfit is what bounds it; a model that reproduces its training data keeps the plain wording.
#[test]
fn none_from_a_model_that_misfits_its_own_training_data_says_that_misfit_bounds_it() {
    let model = MmgModel::kvlcc2();
    let opts = DiagnoseOptions::default();
    let input = |level| input_of(&model, level);
    let calm = runs_in_current(3, 0.0);
    let misfit = diagnose(&input(Some(0.3)), &calm, &opts).unwrap();
    assert_eq!(misfit.verdict, Verdict::None, "{}", misfit.explanation);
    assert!(
        misfit.explanation.contains(
            "Most of that threshold is the model's own misfit of its training data (0.3000 L)"
        ),
        "{}",
        misfit.explanation
    );
    let level = model_level(&input(None), &runs_in_current(4, 0.0), &opts);
    let plain = diagnose(&input(Some(level)), &calm, &opts).unwrap();
    assert_eq!(plain.verdict, Verdict::None, "{}", plain.explanation);
    assert!(
        !plain.explanation.contains("Most of that threshold"),
        "{}",
        plain.explanation
    );
    // An effect whose held-out mismatch exceeds that level is still found.
    let current = diagnose(&input(Some(0.3)), &runs_in_current(3, 0.05), &opts).unwrap();
    assert_eq!(current.verdict, Verdict::Current, "{}", current.explanation);
}
