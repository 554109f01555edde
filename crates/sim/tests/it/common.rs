//! Helpers shared by the integration-test modules.

use std::path::PathBuf;

use shipid_io::{Manoeuvre, Recording};
use shipid_sim::{Dynamics, SimOptions, SimOutput, State, controller_for, simulate};

/// First execute of the standard manoeuvres in the tests [s].
pub const T_EXECUTE_S: f64 = 2.0;

/// `man` simulated with its own controller (first execute at [`T_EXECUTE_S`]) from a straight approach at
/// the model's U0; panics on invalid input.
pub fn simulate_manoeuvre(model: &dyn Dynamics, man: &Manoeuvre, opts: &SimOptions) -> SimOutput {
    let mut c = controller_for(man, T_EXECUTE_S).unwrap();
    simulate(model, c.as_mut(), State::approach(model.ship().u0), opts).unwrap()
}

/// Directory of the HSVA KVLCC2 tank data (the HSVA/CPMC zig-zag `.dat` files of the SIMMAN 2008
/// workshop), which the repository does not include: the tests that need them skip when it is absent.
pub fn hsva_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/kvlcc2-hsva")
}

/// Reports a missing shared data file: a `SKIPPED` line, or a failure when `SHIPID_REQUIRE_SHARED=1`
/// (as in CI, see CONTRIBUTING.md).
pub fn skip_missing(what: &str) {
    let msg = format!("SKIPPED: {what} not found under {:?}", hsva_dir());
    if std::env::var("SHIPID_REQUIRE_SHARED").is_ok_and(|v| v == "1") {
        panic!("{msg} (SHIPID_REQUIRE_SHARED=1)");
    }
    eprintln!("{msg}");
}

/// Reads an HSVA `.dat` file into the project's conventions: 4 header lines, then 12 columns
/// t, x0, y0, ψ[deg], ẋ0, ẏ0 (earth-fixed), r[deg/s], φ, δ[deg, SNAME sign: positive to port], n, T, Q.
/// `None` when the file is absent (the data are not part of the repository).
pub fn read_hsva(name: &str) -> Option<Recording> {
    let bytes = std::fs::read(hsva_dir().join(name)).ok()?;
    let text = String::from_utf8_lossy(&bytes);
    let mut rec = Recording::default();
    let mut n = Vec::new();
    for line in text.lines().skip(4) {
        let f: Vec<f64> = line
            .split_whitespace()
            .map(|x| x.parse().expect("number"))
            .collect();
        if f.is_empty() {
            continue;
        }
        assert_eq!(f.len(), 12, "{name}: {line}");
        let psi = f[3].to_radians();
        let (s, c) = psi.sin_cos();
        rec.t.push(f[0]);
        rec.x0.push(f[1]);
        rec.y0.push(f[2]);
        rec.psi.push(psi);
        rec.u.push(f[4] * c + f[5] * s);
        rec.v.push(-f[4] * s + f[5] * c);
        rec.r.push(f[6].to_radians());
        rec.delta.push(-f[8].to_radians());
        n.push(f[9]);
    }
    rec.n = Some(n);
    Some(rec)
}
