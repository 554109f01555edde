//! Helpers shared by the integration tests of the binary.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The workspace root (tests run in the crate directory).
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Run the `shipid` binary from the workspace root.
pub fn shipid(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shipid"))
        .args(args)
        .current_dir(root())
        .output()
        .expect("the shipid binary runs")
}

/// Run the `shipid` binary from the workspace root and require success (its stderr is the message).
pub fn shipid_ok(args: &[&str]) -> Output {
    let out = shipid(args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// The HSVA recordings of `../shared`, or None after printing a visible skip line. With
/// `SHIPID_REQUIRE_SHARED=1` (CI) a missing directory fails the test instead.
pub fn shared_hsva(test: &str) -> Option<PathBuf> {
    let dir = root().join("../shared/data/kvlcc2-hsva");
    if dir.is_dir() {
        return Some(dir);
    }
    if std::env::var("SHIPID_REQUIRE_SHARED").is_ok_and(|v| v == "1") {
        panic!("{test}: ../shared/data/kvlcc2-hsva is missing and SHIPID_REQUIRE_SHARED=1");
    }
    eprintln!(
        "SKIPPED {test}: ../shared/data/kvlcc2-hsva not found (set SHIPID_REQUIRE_SHARED=1 to fail instead)"
    );
    None
}

/// Import the HSVA recordings of `source` with the project's mapping into `out`; the data set path.
pub fn import_hsva(source: &Path, out: &Path) -> PathBuf {
    let imported = shipid(&[
        "import",
        "data/kvlcc2-hsva/import.toml",
        "--out",
        out.to_str().unwrap(),
        "--source",
        source.to_str().unwrap(),
    ]);
    assert!(
        imported.status.success(),
        "{}",
        String::from_utf8_lossy(&imported.stderr)
    );
    out.join("dataset.toml")
}

/// Run the binary and require the exit code and a piece of the message on stderr.
pub fn check_exit(args: &[&str], code: i32, stderr_has: &str) {
    let out = shipid(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "{args:?}: {err}");
    assert!(err.contains(stderr_has), "{args:?}: stderr was {err}");
}
