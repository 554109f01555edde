//! A recording against the data set's propeller (`consistency::check_propeller_loading`): the
//! open-water curve must thrust at the recording's advance ratio, and a recorded thrust must be this
//! propeller's (positive, K_T = T/(ρ n² D⁴) of the curve's order). Each case changes one thing of a
//! plausible straight run of the KVLCC2 model.

use std::path::Path;

use shipid_io::consistency::check_propeller_loading;
use shipid_io::{PropellerData, Recording};

const RHO: f64 = 1000.0;
const U0_M_S: f64 = 1.179;
const RATE: f64 = 11.85;
const DIAMETER_M: f64 = 0.216;

/// A straight run at U0 with the propeller at 11.85 1/s and a thrust of K_T 0.2 with a little ripple.
fn plausible() -> (Recording, PropellerData) {
    let len = 600;
    let t: Vec<f64> = (0..len).map(|i| i as f64 * 0.1).collect();
    let thrust = t
        .iter()
        .map(|t| (0.2 + 0.01 * (0.3 * t).sin()) * RHO * RATE * RATE * DIAMETER_M.powi(4))
        .collect();
    let rec = Recording {
        u: vec![U0_M_S; len],
        v: vec![0.0; len],
        n: Some(vec![RATE; len]),
        thrust: Some(thrust),
        t,
        ..Default::default()
    };
    let propeller = PropellerData {
        diameter_m: DIAMETER_M,
        x_m: -3.36,
        k_t: shipid_io::DEFAULT_K_T,
        open_water: None,
        k_t_default: None,
        rate_rps: None,
    };
    (rec, propeller)
}

/// `change` applied to the plausible run and propeller: `None` expects it accepted, `Some(words)`
/// refused with a message naming the recording and holding `words`.
fn check(change: impl Fn(&mut Recording, &mut PropellerData), expected: Option<&str>) {
    let (mut rec, mut propeller) = plausible();
    change(&mut rec, &mut propeller);
    let got = check_propeller_loading(Path::new("rec.csv"), &rec, &propeller, RHO, U0_M_S);
    match (got, expected) {
        (Ok(()), None) => {}
        (Err(e), Some(words)) => {
            let text = e.to_string();
            assert!(text.starts_with("rec.csv: "), "{text}");
            assert!(text.contains(words), "expected `{words}` in: {text}");
        }
        (Ok(()), Some(words)) => panic!("accepted; expected a refusal with `{words}`"),
        (Err(e), None) => panic!("refused a plausible recording: {e}"),
    }
}

fn scale_thrust(rec: &mut Recording, factor: f64) {
    rec.thrust
        .as_mut()
        .unwrap()
        .iter_mut()
        .for_each(|t| *t *= factor);
}

#[test]
fn a_plausible_run_passes_with_or_without_its_thrust() {
    check(|_, _| {}, None);
    check(|r, _| r.thrust = None, None);
    // The constant rate of the data set in place of an `n` column.
    check(
        |r, p| {
            r.n = None;
            p.rate_rps = Some(RATE);
        },
        None,
    );
    // The HSVA runs: K_T 0.21 … 0.32 against the curve's 0.32 at J = 0.
    check(|r, _| scale_thrust(r, 1.4), None);
}

/// Regression: a thrust in kN under a bare `thrust` header put every wake parameter on its bounds,
/// and `--inflow-from-thrust` held them there (exit 0).
#[test]
fn a_thrust_in_kilonewtons_under_a_bare_header_is_named() {
    check(
        |r, _| scale_thrust(r, 1e-3),
        Some(
            "column `thrust` gives a median K_T = T/(ρ n² D⁴) of 2.01e-4 with propeller.diameter_m = 0.216 m and the `n` channel: 6.85e-4 × the curve's K_T(0) = 0.293, below it in 600 of 600 samples; the thrust in kN under a bare header? Write `thrust[kN]`",
        ),
    );
}

/// Regression: a doubled (K_T 0.49 on 0.29) or negative thrust was dropped by the inflow inversion without a word.
#[test]
fn a_thrust_above_the_bollard_value_or_of_the_other_sign_is_named() {
    check(
        |r, _| scale_thrust(r, 2.0),
        Some("1.370 × the open-water curve's K_T(0) = 0.293, above it in 600 of 600 samples"),
    );
    check(
        |r, _| scale_thrust(r, -1.0),
        Some(
            "column `thrust` is ≤ 0 in 600 of the 600 samples where the propeller turns ahead and the ship moves (the other sign?",
        ),
    );
    check(
        |r, _| scale_thrust(r, 0.0),
        Some("(an empty channel? Leave the column out when the thrust was not measured)"),
    );
}

/// Regression: a diameter ten times too small (J 4.6) passed the advance-ratio check, and the fitted
/// model ran straight at 4 % of U0.
#[test]
fn a_curve_without_thrust_at_the_recorded_advance_ratio_is_named() {
    check(
        |r, p| {
            r.thrust = None;
            p.diameter_m = 0.06;
        },
        Some(
            "the propeller gives no thrust at this recording's advance ratio: the median J = u/(nD) is 1.658 with propeller.diameter_m = 0.06 m and the `n` channel",
        ),
    );
    check(
        |r, p| {
            r.thrust = None;
            r.n = None;
            p.rate_rps = Some(3.4);
        },
        Some("with propeller.diameter_m = 0.216 m and propeller.rate_rps"),
    );
}
