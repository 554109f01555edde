//! What an mmg model file may say about its fit (probe-mmg §12, §13, §16): the metadata a report
//! reads as the fit's uncertainty, the propeller rate the model runs at, and the errors for a file
//! whose `kind` or tables are wrong. Every file the writers produce loads.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use shipid_io::Dataset;
use shipid_pipeline::fit::WindowSpec;
use shipid_pipeline::mmg::{
    MmgFitOptions, MmgGeometry, MmgModelFile, fit_mmg, load_mmg_model, model_file,
    write_mmg_model_file,
};

/// The model file of a ZZ35/35 fit, fitted once for every check.
fn written() -> &'static MmgModelFile {
    static FILE: OnceLock<MmgModelFile> = OnceLock::new();
    FILE.get_or_init(|| {
        let ds = Dataset::load(
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/kvlcc2-mmg/dataset.toml"),
        )
        .unwrap();
        let options = MmgFitOptions {
            recordings: vec!["zz35_35_ps.csv".into()],
            window: WindowSpec::Whole,
            ..MmgFitOptions::default()
        };
        let fit = fit_mmg(&ds, &MmgGeometry::kvlcc2_model_scale(), &options).unwrap();
        model_file(&fit, ds.added_mass.unwrap())
    })
}

/// Index of a parameter of the written file that the data do not determine.
fn prior_held() -> usize {
    written()
        .parameters
        .iter()
        .position(|p| !p.determined_by_data && p.data_share < 0.5 && p.lower < p.upper)
        .expect("a prior-held parameter")
}

/// The written file edited by `edit`, loaded: `Ok` or the error's text (which must be bad input).
fn load_edited(edit: impl Fn(&mut MmgModelFile)) -> Result<(), String> {
    let mut file = written().clone();
    edit(&mut file);
    let text = write_mmg_model_file(&file).unwrap();
    load_mmg_model(Path::new("m.toml"), &text)
        .map(|_| ())
        .map_err(|e| {
            assert!(e.is_bad_input(), "{e}");
            e.to_string()
        })
}

/// `expected`: `None` when the edited file loads, else fragments of its refusal.
fn check(edit: impl Fn(&mut MmgModelFile), expected: Option<&[&str]>) {
    match (load_edited(edit), expected) {
        (Ok(()), None) => {}
        (Err(e), Some(fragments)) => {
            for f in fragments {
                assert!(e.contains(f), "`{f}` not in: {e}");
            }
        }
        (got, want) => panic!("{got:?} where {want:?} was expected"),
    }
}

#[test]
fn the_written_file_loads() {
    check(|_| {}, None);
}

/// Regression (probe-mmg §13): negative or NaN standard errors, prior sd ≤ 0, shares outside
/// [0, 1], a contradicting `determined_by_data`, a prior outside the bounds, a negative prior weight
/// and a version that is not one were all accepted, exit 0.
#[test]
fn mmg_model_file_metadata_that_contradicts_the_fit_is_refused_naming_the_key() {
    let k = prior_held();
    let key = |field: &str| format!("key `parameter[{k}].{field}`");
    check(
        |f| f.parameters[k].standard_error = -0.01,
        Some(&[&key("standard_error"), "≥ 0, not -0.01"]),
    );
    check(
        |f| f.parameters[k].standard_error = f64::NAN,
        Some(&[&key("standard_error"), "not NaN"]),
    );
    check(
        |f| f.parameters[k].prior_sd = -0.1,
        Some(&[&key("prior_sd"), "not -0.1"]),
    );
    check(
        |f| f.parameters[k].prior_sd = f64::NAN,
        Some(&[&key("prior_sd"), "not NaN"]),
    );
    check(
        |f| f.parameters[k].prior_sd = 0.0,
        Some(&[&key("prior_sd"), "> 0 (estimator `bounded-lsq`), not 0"]),
    );
    check(
        |f| f.parameters[k].data_share = 7.5,
        Some(&[&key("data_share"), "in [0, 1], not 7.5"]),
    );
    check(
        |f| f.parameters[k].data_share = -0.5,
        Some(&[&key("data_share"), "not -0.5"]),
    );
    check(
        |f| f.parameters[k].determined_by_data = true,
        Some(&[
            &key("determined_by_data"),
            "is not above estimator.determined_share = 0.5",
        ]),
    );
    check(
        |f| {
            let p = &mut f.parameters[k];
            p.data_share = 0.9;
            p.value = 0.5 * (p.lower.max(-1.0) + p.upper.min(1.0));
        },
        Some(&[&key("determined_by_data"), "false, but its data_share 0.9"]),
    );
    check(
        |f| {
            let p = &mut f.parameters[k];
            p.prior = if p.upper.is_finite() {
                p.upper + 1.0
            } else {
                p.lower - 1.0
            };
        },
        Some(&[&key("prior"), "is outside the bounds"]),
    );
    check(
        |f| f.estimator.prior_weight = -1.0,
        Some(&["key `estimator.prior_weight`", "not -1"]),
    );
    check(
        |f| f.estimator.prior_weight = f64::INFINITY,
        Some(&["key `estimator.prior_weight`"]),
    );
    check(
        |f| f.shipid_version = "banana".into(),
        Some(&["key `shipid_version`", "\"banana\" is not a version"]),
    );
}

/// What the writers legitimately store loads: `inverse` and a published model write prior_sd 0 for
/// "no prior" (and a value edited away from it stays loadable) and ∞ for a prior of no weight; a
/// held inflow with an undetermined standard error has ∞.
#[test]
fn mmg_model_file_metadata_the_writers_produce_loads() {
    let k = prior_held();
    for name in ["inverse-network", "published"] {
        check(
            |f| {
                f.estimator.name = name.into();
                f.parameters[k].prior_sd = 0.0;
            },
            None,
        );
    }
    check(|f| f.parameters[k].prior_sd = f64::INFINITY, None);
    check(|f| f.parameters[k].standard_error = f64::INFINITY, None);
    check(|f| f.shipid_version = "0.3.0-dev+abc".into(), None);
    check(|f| f.shipid_version = "1".into(), None);
}

/// Regression (probe-mmg §12): a `rate_rps` in rpm diverged with exit 1, and 0 was accepted.
#[test]
fn mmg_model_file_propeller_rate_gets_the_data_sets_checks() {
    check(
        |f| f.propeller.rate_rps = 711.1,
        Some(&[
            "key `propeller.rate_rps`",
            "advance ratio",
            "revolutions per minute",
        ]),
    );
    check(
        |f| f.propeller.rate_rps = 0.0,
        Some(&["key `propeller.rate_rps`", "> 0, not 0"]),
    );
    check(|f| f.propeller.rate_rps = 12.5, None);
}

/// A fresh folder under the system's temporary folder, removed when dropped.
struct Scratch(PathBuf);

impl Scratch {
    fn new(name: &str) -> Scratch {
        let dir =
            std::env::temp_dir().join(format!("shipid-mmg-file-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The error of loading the written text edited by `edit` through the one loader of model files.
fn check_loader(name: &str, edit: impl Fn(&str) -> String, expected: &[&str], absent: &[&str]) {
    let dir = Scratch::new(name);
    let path = dir.0.join("m.toml");
    let text = write_mmg_model_file(written()).unwrap();
    std::fs::write(&path, edit(&text)).unwrap();
    let err = match shipid_pipeline::model_file::load_model(path.to_str().unwrap()) {
        Ok(_) => panic!("{name}: loaded"),
        Err(e) => e,
    };
    assert!(err.is_bad_input(), "{err}");
    let e = err.to_string();
    for f in expected {
        assert!(e.contains(f), "`{f}` not in: {e}");
    }
    for f in absent {
        assert!(!e.contains(f), "`{f}` in: {e}");
    }
}

/// Regression (probe-mmg §16): without its `kind` line an mmg file was read as a polynomial and the
/// error blamed `estimator.determined_share`; an unknown table `[foo]` came out as "key `foo.foo`".
#[test]
fn a_model_file_without_kind_or_with_an_unknown_table_says_so() {
    check_loader(
        "nokind",
        |t| t.replacen("kind = \"mmg\"\n", "", 1),
        &["key `kind`: missing", "add `kind = \"mmg\"`"],
        &["determined_share"],
    );
    check_loader(
        "table",
        |t| format!("{t}\n[foo]\nbar = 1\n"),
        &["unknown table `[foo]`"],
        &["foo.foo"],
    );
    check_loader(
        "top",
        |t| t.replacen("kind = \"mmg\"\n", "kind = \"mmg\"\ncomment = \"x\"\n", 1),
        &["key `comment`", "unknown field"],
        &[],
    );
}
