//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::PathBuf;

use shipid_io::Recording;

/// Directory of the HSVA KVLCC2 tank data (outside the repository; see ../shared/data/kvlcc2-hsva/SOURCE.md).
pub fn hsva_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/kvlcc2-hsva")
}

/// Reports a missing shared data file: a `SKIPPED` line, or a failure when `SHIPID_REQUIRE_SHARED=1`
/// (as in CI, CONTRIBUTING.md).
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
