//! Results do not depend on the working directory (issue 25): every subcommand runs once from the
//! repository root and once from a foreign temporary folder, and both give the same stdout and the
//! same files, byte for byte.
//!
//! The two places are sibling folders `a` and `b` of one temporary folder, so a path stored relative
//! to a written file (a model's data set) is the same from both. Repository files are named by their
//! absolute path in both runs (the spelling a user types is echoed, and must not be what differs);
//! outputs are named by their absolute path from the root and relative to the foreign folder. What
//! is masked, and why:
//! - the place's own folder (`…/a/`, `…/b/`) where an output path is printed or stored: it is where
//!   the user asked the output to go;
//! - wall-clock times (`in 0.09 ms`, `"fit_time_s": …`, run.json's UTC clock and wall time,
//!   the `fit_time_s` column): they differ between any two runs;
//! - Parquet tables are not compared (binary, with `fit_time_s` inside); their CSV twins are;
//! - the study's `report.html` is not compared: it renders the run's clock and each case's fit time
//!   in several forms (dates, rounded cells, tooltips); the tables and run record it is drawn from
//!   are, and the diagnosis page (no clock) is.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::root;

/// The steps, in order; `{repo}` is the repository's absolute path, `{out}` the place's output
/// folder as that place names it. Small inputs: the default data set with a current, reduced32 by
/// least squares, the three cases of the `small` study, 40 simulated ships per inverse target.
const STEPS: &[&[&str]] = &[
    &[
        "generate",
        "--out",
        "{out}/gen",
        "--effect",
        "current:speed=0.05,from=120",
    ],
    &[
        "import",
        "{out}/mapping.toml",
        "--out",
        "{out}/imported",
        "--source",
        "{repo}/data/kvlcc2-mmg",
    ],
    &["metrics", "{out}/imported/dataset.toml", "--json"],
    &[
        "fit",
        "{repo}/data/kvlcc2-mmg/dataset.toml",
        "--out",
        "{out}/model.toml",
        "--validate",
    ],
    &[
        "simulate",
        "{out}/model.toml",
        "--manoeuvre",
        "zigzag:20/20:port",
        "--json",
        "--out",
        "{out}/sim.csv",
    ],
    &[
        "validate",
        "{out}/model.toml",
        "{repo}/data/kvlcc2-mmg/dataset.toml",
        "--json",
    ],
    &[
        "diagnose",
        "{out}/model.toml",
        "{out}/gen/dataset.toml",
        "--plots",
        "{out}/diagnosis",
    ],
    // The augmented model names its training data relative to itself: validated from here too.
    &[
        "validate",
        "{out}/diagnosis/report.model.toml",
        "{out}/gen/dataset.toml",
    ],
    &[
        "run",
        "{repo}/crates/shipid/tests/fixtures/studies/small.toml",
        "--out",
        "{out}/study",
        "--jobs",
        "1",
    ],
    &[
        "table",
        "{repo}/crates/shipid/tests/fixtures/studies/small.toml",
        "--out",
        "{out}/study",
    ],
    &[
        "plot",
        "{repo}/crates/shipid/tests/fixtures/studies/small.toml",
        "--out",
        "{out}/study",
    ],
    &["report", "{out}/study"],
    &[
        "check",
        "{repo}/crates/shipid/tests/fixtures/studies/small.toml",
        "--reference",
        "{out}/reference",
        "--bless",
        "--jobs",
        "1",
    ],
    &[
        "check",
        "{repo}/crates/shipid/tests/fixtures/studies/small.toml",
        "--reference",
        "{out}/reference",
        "--jobs",
        "1",
    ],
    &[
        "inverse",
        "{repo}/data/paper003/targets.toml",
        "--samples",
        "40",
        "--resimulate",
        "2",
        "--refine-evals",
        "5",
        "--out",
        "{out}/inverse",
    ],
];

/// Files that carry wall-clock times in rendered forms (see the module's list).
const NOT_COMPARED: &[&str] = &["study/report.html"];

/// A mapping of the project's own CSV layout (comment lines, then a header), for `import`.
const MAPPING: &str = r#"rudder_sign = 1
[format]
delimiter = ","
skip_lines = 6
[[column]]
index = 1
quantity = "t"
[[column]]
index = 2
quantity = "x0"
[[column]]
index = 3
quantity = "y0"
[[column]]
index = 4
quantity = "psi"
unit = "rad"
[[column]]
index = 5
quantity = "u"
[[column]]
index = 6
quantity = "v"
[[column]]
index = 7
quantity = "r"
unit = "rad/s"
[[column]]
index = 8
quantity = "delta"
unit = "rad"
[dataset]
name = "KVLCC2 turning circle, imported"
origin = "midship"
[dataset.ship]
lpp = 7.0
beam = 1.27
draft = 0.46
displacement = 3.27
rho = 1000.0
xg = 0.25
kzz = 1.75
u0 = 1.179
rudder_rate = 15.8
[[recording]]
source = "tc35_sb.csv"
file = "tc35_sb.csv"
kind = "turning"
rudder = 35.0
side = "starboard"
"#;

/// Where a run stands and how it names its outputs.
struct Place {
    /// The working directory.
    cwd: PathBuf,
    /// How arguments name the output folder.
    out_arg: String,
    /// The output folder itself.
    out_dir: PathBuf,
    /// The place's own folder, masked wherever it appears (absolute, with a trailing separator).
    own: String,
}

/// What a run produced: per step, its exit code and masked stdout; and every file written, masked.
#[derive(Debug, PartialEq)]
struct Outputs {
    steps: Vec<(String, Option<i32>, String)>,
    files: BTreeMap<String, Vec<u8>>,
}

fn run_all(place: &Place, repo: &str) -> Outputs {
    std::fs::create_dir_all(&place.out_dir).unwrap();
    std::fs::write(place.out_dir.join("mapping.toml"), MAPPING).unwrap();
    let mut steps = Vec::new();
    for step in STEPS {
        let args: Vec<String> = step
            .iter()
            .map(|a| a.replace("{repo}", repo).replace("{out}", &place.out_arg))
            .collect();
        let out = Command::new(env!("CARGO_BIN_EXE_shipid"))
            .args(&args)
            .current_dir(&place.cwd)
            .output()
            .expect("the shipid binary runs");
        let stdout = mask(&String::from_utf8_lossy(&out.stdout), place);
        assert!(
            matches!(out.status.code(), Some(0 | 1)),
            "{args:?} from {}: {}",
            place.cwd.display(),
            String::from_utf8_lossy(&out.stderr)
        );
        steps.push((step[0].to_string(), out.status.code(), stdout));
    }
    let mut files = BTreeMap::new();
    collect(&place.out_dir, &place.out_dir, place, &mut files);
    Outputs { steps, files }
}

fn collect(dir: &Path, top: &Path, place: &Place, files: &mut BTreeMap<String, Vec<u8>>) {
    for entry in std::fs::read_dir(dir).unwrap().flatten() {
        let path = entry.path();
        if path.is_dir() {
            collect(&path, top, place, files);
            continue;
        }
        let name = path.strip_prefix(top).unwrap().display().to_string();
        if path.extension().is_some_and(|e| e == "parquet") || NOT_COMPARED.contains(&name.as_str())
        {
            continue;
        }
        let bytes = std::fs::read(&path).unwrap();
        let bytes = match String::from_utf8(bytes) {
            Ok(text) => mask_file(&name, &mask(&text, place)).into_bytes(),
            Err(e) => e.into_bytes(),
        };
        files.insert(name, bytes);
    }
}

/// The place's own folder and wall-clock times (see the module's list).
fn mask(text: &str, place: &Place) -> String {
    let mut text = text.replace(&place.own, "");
    for key in [
        "fit_time_s",
        "train_time_s",
        "sparsify_time_s",
        "wall_time_s",
        "started_utc",
        "finished_utc",
    ] {
        // As JSON, and as the report page shows JSON (HTML-escaped).
        for marker in [format!("\"{key}\": "), format!("&quot;{key}&quot;: ")] {
            text = mask_after(&text, &marker, |c| c != ',' && c != '\n' && c != '}');
        }
    }
    for unit in [" ms", " s"] {
        text = mask_time(&text, unit);
    }
    text
}

/// Replaces the characters that follow each `marker` while `keep` holds with `#`.
fn mask_after(text: &str, marker: &str, keep: impl Fn(char) -> bool) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(i) = rest.find(marker) {
        out.push_str(&rest[..i + marker.len()]);
        rest = &rest[i + marker.len()..];
        let n = rest.find(|c: char| !keep(c)).unwrap_or(rest.len());
        if n > 0 {
            out.push('#');
        }
        rest = &rest[n..];
    }
    out.push_str(rest);
    out
}

/// `in 0.09 ms`, `in 1.2 s` → `in # ms`, `in # s`: the durations printed by fit, the sparse GP and
/// inverse.
fn mask_time(text: &str, unit: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(i) = rest.find("in ") {
        out.push_str(&rest[..i + 3]);
        rest = &rest[i + 3..];
        let n = rest
            .find(|c: char| !(c.is_ascii_digit() || c == '.'))
            .unwrap_or(rest.len());
        let is_time = n > 0
            && rest[n..].starts_with(unit)
            && !rest[n + unit.len()..].starts_with(|c: char| c.is_alphanumeric());
        if is_time {
            out.push('#');
            rest = &rest[n..];
        }
    }
    out.push_str(rest);
    out
}

/// CSV tables with a `fit_time_s` column: its values masked.
fn mask_file(name: &str, text: &str) -> String {
    if !name.ends_with(".csv") {
        return text.to_string();
    }
    let mut lines = text.lines();
    let Some(header) = lines.next() else {
        return text.to_string();
    };
    let Some(col) = header.split(',').position(|h| h == "fit_time_s") else {
        return text.to_string();
    };
    let mut out = vec![header.to_string()];
    for line in lines {
        let mut cells: Vec<&str> = line.split(',').collect();
        if let Some(c) = cells.get_mut(col) {
            *c = "#";
        }
        out.push(cells.join(","));
    }
    out.join("\n") + "\n"
}

#[test]
fn every_command_gives_the_same_results_from_a_foreign_directory() {
    let top = tempfile::tempdir().unwrap();
    // Canonical, so the folder printed (symbolic links resolved) is the one masked.
    let top = top.path().canonicalize().unwrap();
    let repo = root().canonicalize().unwrap();
    let repo = repo.to_str().unwrap();
    let a = top.join("a");
    let b = top.join("b");
    std::fs::create_dir_all(&a).unwrap();
    std::fs::create_dir_all(&b).unwrap();
    let from_root = Place {
        cwd: PathBuf::from(repo),
        out_arg: a.join("work").display().to_string(),
        out_dir: a.join("work"),
        own: format!("{}/", a.display()),
    };
    let from_foreign = Place {
        cwd: b.clone(),
        out_arg: "work".into(),
        out_dir: b.join("work"),
        own: format!("{}/", b.display()),
    };
    let first = run_all(&from_root, repo);
    let second = run_all(&from_foreign, repo);
    for (x, y) in first.steps.iter().zip(&second.steps) {
        assert_eq!(x, y, "stdout of `shipid {}` differs", x.0);
    }
    let names = |o: &Outputs| o.files.keys().cloned().collect::<Vec<_>>();
    assert_eq!(names(&first), names(&second), "files written");
    for (name, bytes) in &first.files {
        let other = &second.files[name];
        if other != bytes {
            let (x, y) = (
                String::from_utf8_lossy(bytes),
                String::from_utf8_lossy(other),
            );
            let line = x.lines().zip(y.lines()).position(|(p, q)| p != q);
            let show = |t: &str| {
                line.and_then(|i| t.lines().nth(i))
                    .unwrap_or("")
                    .to_string()
            };
            panic!(
                "{name} differs at line {line:?}:\n--- from the root\n{}\n--- from a foreign folder\n{}",
                show(&x),
                show(&y)
            );
        }
    }
    // The steps that matter most did what they should: the model found its training data from the
    // foreign folder (its own level, the identification range), and inverse ran on the built-in
    // database.
    let step = |name: &str| {
        second
            .steps
            .iter()
            .find(|s| s.0 == name)
            .map(|s| s.2.clone())
            .unwrap()
    };
    assert!(
        step("diagnose").contains("model's own level (training data "),
        "{}",
        step("diagnose")
    );
    assert!(step("inverse").contains("SVD of 20 ships"));
    assert!(first.files.contains_key("diagnosis/report.model.toml"));
}

#[test]
fn masks_change_only_what_they_name() {
    let place = Place {
        cwd: PathBuf::new(),
        out_arg: String::new(),
        out_dir: PathBuf::new(),
        own: "/tmp/x/a/".into(),
    };
    let check = |input: &str, expected: &str| assert_eq!(mask(input, &place), expected);
    check(
        "fitted reduced32 with lsq on 300 samples in 0.09 ms → /tmp/x/a/work/model.toml",
        "fitted reduced32 with lsq on 300 samples in # ms → work/model.toml",
    );
    check(
        "trained 3 GPs in 1.25 s → m.toml",
        "trained 3 GPs in # s → m.toml",
    );
    check(
        "kept in 3 sets, in 2 samples",
        "kept in 3 sets, in 2 samples",
    );
    check(
        "{\n  \"fit_time_s\": 0.0012,\n  \"samples\": 300\n}",
        "{\n  \"fit_time_s\": #,\n  \"samples\": 300\n}",
    );
    assert_eq!(
        mask_file("summary.csv", "case,fit_time_s,mrae\nc1,0.5,0.1\n"),
        "case,fit_time_s,mrae\nc1,#,0.1\n"
    );
}

/// Regression: `import` wrote the mapping, and `simulate --out` the model, into the first comment of
/// every file as typed ("mapping ../../imp/import.toml"), so the bytes depended on the working
/// directory. The same inputs typed from two folders now write the same bytes.
#[test]
fn import_and_simulate_comments_do_not_depend_on_the_working_directory() {
    let tmp = tempfile::tempdir().unwrap();
    let top = tmp.path();
    let deep = top.join("deep/er");
    std::fs::create_dir_all(&deep).unwrap();
    std::fs::write(top.join("mapping.toml"), MAPPING).unwrap();
    let sub = root().join(
        "crates/shipid/tests/hostile/paths/simulate_model_in_a_subfolder_flags_its_extrapolation/sub",
    );
    std::fs::create_dir_all(top.join("sub")).unwrap();
    for f in ["dataset.toml", "model.toml", "r.csv"] {
        std::fs::copy(sub.join(f), top.join("sub").join(f)).unwrap();
    }
    let source = root().join("data/kvlcc2-mmg");
    let source = source.to_str().unwrap();
    // The exit code is not the point (this model's run diverges: exit 1, its CSV written all the same).
    let run = |cwd: &Path, args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_shipid"))
            .args(args)
            .current_dir(cwd)
            .output()
            .unwrap()
    };
    let o = run(
        top,
        &["import", "mapping.toml", "--out", "o1", "--source", source],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = run(
        &deep,
        &[
            "import",
            "../../mapping.toml",
            "--out",
            "../../o2",
            "--source",
            source,
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in ["dataset.toml", "tc35_sb.csv"] {
        let (a, b) = (
            std::fs::read_to_string(top.join("o1").join(f)).unwrap(),
            std::fs::read_to_string(top.join("o2").join(f)).unwrap(),
        );
        assert_eq!(a, b, "{f}");
    }
    let zigzag = ["--manoeuvre", "zigzag:20/20:port", "--out"];
    run(
        top,
        &[&["simulate", "sub/model.toml"][..], &zigzag, &["s1.csv"]].concat(),
    );
    run(
        &deep,
        &[
            &["simulate", "../../sub/model.toml"][..],
            &zigzag,
            &["../../s2.csv"],
        ]
        .concat(),
    );
    let (a, b) = (
        std::fs::read_to_string(top.join("s1.csv")).unwrap(),
        std::fs::read_to_string(top.join("s2.csv")).unwrap(),
    );
    assert!(a.starts_with("# shipid"), "{a:.200}");
    assert_eq!(a, b);
}
