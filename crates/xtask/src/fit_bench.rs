//! Fit-time benchmark of the estimators on the designs of paper 000's four training sets
//! (Tab. 10), for the side-by-side comparison with the Python stack in `bench/`.
//!
//! ```text
//! cargo xtask fit-bench [--export DIR] [--out FILE]
//!     [--dataset FILE] [--sets full68,reduced32] [--min-repeats N] [--min-time S]
//!     [--cases lsq,bounded_lsq,ridge,lasso,svr] [--solvers fast,qp] [--no-api-floor]
//! ```
//!
//! `--cases` and `--solvers` time a subset (default: all), and `--no-api-floor` skips timing the
//! API floor of every problem; `bench/paired.sh` uses them to alternate short Rust and Python runs
//! of the least-squares cases.
//!
//! For every coefficient set × training set × DOF it builds Φ and y exactly as `shipid fit`
//! does (zig-zags truncated after 4 overshoots, turning circles whole, recordings stacked),
//! optionally exports them as CSV (with column scales, bounds and the hyper-parameters, so that
//! `bench/python_fit.py` solves the very same problems), and times both solver families
//! (`Fast`, `Qp`) of every estimator case on one core: the median wall time of the complete
//! `shipid_estimators::fit` call over several repeats, and the objective J at the solution.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde_json::{Value, json};
use shipid_estimators::faer::{self, Mat};
use shipid_estimators::{Bounds, Estimator, Solver, column_scales, fit, objective};
use shipid_io::Dataset;
use shipid_model::{CoefficientSet, Dof, PrimeInertia, Samples, design};
use shipid_pipeline::fit::{WindowSpec, training_samples};

// Fixed, representative hyper-parameters: the values that blocked cross-validation
// (`shipid fit --tune`) picks on the ZZ35 (4 OS) training set lie at λ ≈ 1e-5…1e-3,
// α ≈ (3e-4…4e-3)·α_max and C ≈ (3e2…3e3)·C₀.

/// Ridge λ (scaled space; `ZᵀZ/n` has a unit diagonal, so λ compares with its eigenvalues).
const RIDGE_LAMBDA: f64 = 1e-5;
/// Lasso α as a fraction of α_max = max_j |z_jᵀy|/n (the smallest α with an all-zero solution).
const LASSO_ALPHA_OF_MAX: f64 = 1e-3;
/// SVR ε as a fraction of rms(y) (the `shipid fit` default).
const SVR_EPSILON_OF_RMS: f64 = 0.01;
/// SVR C in units of C₀ = rms(y)/n (the scale of `default_grid`).
const SVR_C_OF_C0: f64 = 1e3;

/// Paper 000 §3.5 / Tab. 10: the four training sets. Zig-zags truncated after 4 overshoots,
/// turning circles whole.
const TRAINING_SETS: [(&str, &[&str]); 4] = [
    ("ZZ35", &["zz35_35_ps.csv"]),
    ("ZZ35+TC35", &["zz35_35_ps.csv", "tc35_ps.csv"]),
    ("ZZ35+ZZ10", &["zz35_35_ps.csv", "zz10_10_ps.csv"]),
    (
        "ZZ35+ZZ10+TC35",
        &["zz35_35_ps.csv", "zz10_10_ps.csv", "tc35_ps.csv"],
    ),
];

/// Estimator cases: name, whether the set's sign bounds apply. Ridge, Lasso and SVR run
/// without bounds so that scikit-learn can solve the same problems (on these data the sign
/// bounds are not active at their solutions anyway).
const CASES: [(&str, bool); 5] = [
    ("lsq", false),
    ("bounded_lsq", true),
    ("ridge", false),
    ("lasso", false),
    ("svr", false),
];

struct Args {
    export: Option<PathBuf>,
    out: PathBuf,
    dataset: PathBuf,
    sets: Vec<String>,
    min_repeats: usize,
    min_time_s: f64,
    cases: Vec<String>,
    solvers: Vec<Solver>,
    /// Time the API floor of every problem (`report.py` uses it; the paired rounds do not).
    api_floor: bool,
}

fn parse_args() -> Result<Args, String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut a = Args {
        export: None,
        out: root.join("bench/results_rust.json"),
        dataset: root.join("data/kvlcc2-mmg/dataset.toml"),
        sets: vec!["full68".into(), "reduced32".into()],
        min_repeats: 5,
        min_time_s: 0.5,
        cases: CASES.iter().map(|(c, _)| c.to_string()).collect(),
        solvers: vec![Solver::Fast, Solver::Qp],
        api_floor: true,
    };
    let mut it = std::env::args().skip(2);
    while let Some(flag) = it.next() {
        let mut value = || it.next().ok_or(format!("{flag} needs a value"));
        match flag.as_str() {
            "--export" => a.export = Some(value()?.into()),
            "--out" => a.out = value()?.into(),
            "--dataset" => a.dataset = value()?.into(),
            "--sets" => a.sets = value()?.split(',').map(String::from).collect(),
            "--min-repeats" => {
                a.min_repeats = value()?.parse().map_err(|e| format!("{flag}: {e}"))?;
            }
            "--min-time" => a.min_time_s = value()?.parse().map_err(|e| format!("{flag}: {e}"))?,
            "--cases" => {
                a.cases = value()?.split(',').map(String::from).collect();
                if let Some(bad) = a.cases.iter().find(|c| !CASES.iter().any(|(k, _)| k == c)) {
                    return Err(format!("{flag}: unknown case `{bad}`"));
                }
            }
            "--solvers" => {
                a.solvers = value()?
                    .split(',')
                    .map(|v| v.parse().map_err(|e| format!("{flag}: {e}")))
                    .collect::<Result<_, _>>()?;
            }
            "--no-api-floor" => a.api_floor = false,
            "-h" | "--help" => {
                return Err(
                    "usage: fit_bench [--export DIR] [--out FILE] [--dataset FILE] \
                     [--sets full68,reduced32] [--min-repeats N] [--min-time S] \
                     [--cases lsq,bounded_lsq,ridge,lasso,svr] [--solvers fast,qp] \
                     [--no-api-floor]"
                        .into(),
                );
            }
            other => return Err(format!("unknown argument `{other}` (try --help)")),
        }
    }
    a.min_repeats = a.min_repeats.max(1);
    Ok(a)
}

/// Stacked samples of the recordings: zig-zags cut after 4 overshoots, the rest whole.
fn stacked_samples(ds: &Dataset, files: &[&str]) -> Result<Samples, String> {
    let mut all = Samples::default();
    for (g, &file) in files.iter().enumerate() {
        let window = if file.starts_with("zz") {
            WindowSpec::Overshoots(4)
        } else {
            WindowSpec::Whole
        };
        let (s, _) = training_samples(ds, &[file.to_string()], window)
            .map_err(|e| format!("{file}: {e}"))?;
        all.du.extend(s.du);
        all.v.extend(s.v);
        all.r.extend(s.r);
        all.delta.extend(s.delta);
        all.u_dot.extend(s.u_dot);
        all.v_dot.extend(s.v_dot);
        all.r_dot.extend(s.r_dot);
        all.group.extend(std::iter::repeat_n(g, s.group.len()));
        all.t.extend(s.t);
    }
    Ok(all)
}

fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

/// α_max = max_j |z_jᵀy|/n with z_j = φ_j/s_j.
fn alpha_max(phi: &Mat<f64>, y: &[f64], scales: &[f64]) -> f64 {
    let n = y.len() as f64;
    (0..phi.ncols())
        .filter(|&j| scales[j] > 0.0)
        .map(|j| {
            let dot: f64 = (0..phi.nrows()).map(|i| phi[(i, j)] * y[i]).sum();
            (dot / scales[j] / n).abs()
        })
        .fold(0.0, f64::max)
}

/// One regression problem with its hyper-parameters.
struct Problem {
    set: String,
    training_set: String,
    dof: Dof,
    names: Vec<String>,
    phi: Mat<f64>,
    y: Vec<f64>,
    scales: Vec<f64>,
    bounds: Bounds,
    lambda: f64,
    alpha: f64,
    c: f64,
    epsilon: f64,
}

impl Problem {
    fn id(&self) -> String {
        format!(
            "{}_{}_{}",
            self.set,
            self.training_set.replace('+', "-"),
            self.dof
        )
    }

    fn estimator(&self, case: &str) -> Estimator {
        match case {
            "lsq" => Estimator::Lsq,
            "bounded_lsq" => Estimator::BoundedLsq,
            "ridge" => Estimator::Ridge {
                lambda: self.lambda,
            },
            "lasso" => Estimator::Lasso { alpha: self.alpha },
            "svr" => Estimator::Svr {
                c: self.c,
                epsilon: self.epsilon,
            },
            other => unreachable!("case {other}"),
        }
    }
}

fn build_problems(ds: &Dataset, sets: &[String]) -> Result<Vec<Problem>, String> {
    let added = ds
        .added_mass
        .ok_or("the data set has no [added_mass] table")?;
    let mut out = Vec::new();
    for set_name in sets {
        let set = CoefficientSet::builtin(set_name)
            .ok_or_else(|| format!("unknown built-in set `{set_name}`"))?;
        let inertia = PrimeInertia::new(&ds.ship, &added, &set);
        for (ts, files) in TRAINING_SETS {
            let samples = stacked_samples(ds, files)?;
            for dof in Dof::ALL {
                let d = design(&set, dof, &samples, &inertia);
                let scales = column_scales(d.phi.as_ref()).map_err(|e| e.to_string())?;
                let (lo, hi): (Vec<f64>, Vec<f64>) = d.bounds.iter().copied().unzip();
                let bounds = Bounds::new(lo, hi).map_err(|e| format!("{dof} bounds: {e}"))?;
                let n = d.y.len() as f64;
                let y_rms = rms(&d.y);
                let alpha = LASSO_ALPHA_OF_MAX * alpha_max(&d.phi, &d.y, &scales);
                out.push(Problem {
                    set: set_name.clone(),
                    training_set: ts.into(),
                    dof,
                    names: d.names,
                    lambda: RIDGE_LAMBDA,
                    alpha,
                    c: SVR_C_OF_C0 * y_rms / n,
                    epsilon: SVR_EPSILON_OF_RMS * y_rms,
                    phi: d.phi,
                    y: d.y,
                    scales,
                    bounds,
                });
            }
        }
    }
    Ok(out)
}

/// Shortest round-trip text of a float; ±inf as `inf`/`-inf` (numpy reads both).
fn num(v: f64) -> String {
    if v == f64::INFINITY {
        "inf".into()
    } else if v == f64::NEG_INFINITY {
        "-inf".into()
    } else {
        format!("{v:e}")
    }
}

fn write_file(path: &Path, text: &str) -> Result<(), String> {
    std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))
}

/// `DIR/<id>_phi.csv` (header: coefficient names), `<id>_y.csv`, `<id>_columns.csv` (name,
/// scale, lower, upper) and `DIR/manifest.json` with sizes and hyper-parameters.
fn export(dir: &Path, problems: &[Problem]) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut manifest = Vec::new();
    for pb in problems {
        let id = pb.id();
        let (n, p) = (pb.phi.nrows(), pb.phi.ncols());
        let mut phi = pb.names.join(",");
        phi.push('\n');
        for i in 0..n {
            let row: Vec<String> = (0..p).map(|j| num(pb.phi[(i, j)])).collect();
            phi.push_str(&row.join(","));
            phi.push('\n');
        }
        write_file(&dir.join(format!("{id}_phi.csv")), &phi)?;
        let mut y = String::from("y\n");
        for v in &pb.y {
            let _ = writeln!(y, "{}", num(*v));
        }
        write_file(&dir.join(format!("{id}_y.csv")), &y)?;
        let mut cols = String::from("name,scale,lower,upper\n");
        for j in 0..p {
            let _ = writeln!(
                cols,
                "{},{},{},{}",
                pb.names[j],
                num(pb.scales[j]),
                num(pb.bounds.lower[j]),
                num(pb.bounds.upper[j])
            );
        }
        write_file(&dir.join(format!("{id}_columns.csv")), &cols)?;
        manifest.push(json!({
            "id": id,
            "set": pb.set,
            "training_set": pb.training_set,
            "dof": pb.dof.to_string(),
            "n": n,
            "p": p,
            "phi": format!("{id}_phi.csv"),
            "y": format!("{id}_y.csv"),
            "columns": format!("{id}_columns.csv"),
            "lambda": pb.lambda,
            "alpha": pb.alpha,
            "c": pb.c,
            "epsilon": pb.epsilon,
        }));
    }
    let text = serde_json::to_string_pretty(&json!({
        "objectives": {
            "scaling": "Z = Phi diag(s)^-1, s_j = RMS of column j; gamma = s * beta",
            "lsq": "(1/2n)||Z g - y||^2",
            "bounded_lsq": "(1/2n)||Z g - y||^2, lower*s <= g <= upper*s",
            "ridge": "(1/2n)||Z g - y||^2 + (lambda/2)||g||^2",
            "lasso": "(1/2n)||Z g - y||^2 + alpha ||g||_1",
            "svr": "(1/2)||g||^2 + C sum_i max(0, |y_i - (Z g)_i| - epsilon)",
            "bounded": "bounded_lsq adds lower <= beta <= upper (i.e. lower*s <= g <= upper*s)",
        },
        "hyper_parameters": {
            "ridge_lambda": RIDGE_LAMBDA,
            "lasso_alpha_of_alpha_max": LASSO_ALPHA_OF_MAX,
            "svr_epsilon_of_rms_y": SVR_EPSILON_OF_RMS,
            "svr_c_of_rms_y_over_n": SVR_C_OF_C0,
        },
        "cases": CASES.iter().map(|(c, b)| json!({"case": c, "bounded": b})).collect::<Vec<_>>(),
        "problems": manifest,
    }))
    .map_err(|e| e.to_string())?;
    write_file(&dir.join("manifest.json"), &text)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let k = v.len();
    if k % 2 == 1 {
        v[k / 2]
    } else {
        0.5 * (v[k / 2 - 1] + v[k / 2])
    }
}

/// Wall times of `run` after one warm-up, repeated at least `min_repeats` times and for
/// at least `min_time_s` seconds.
fn repeat<T>(args: &Args, run: impl Fn() -> T) -> Vec<f64> {
    let mut times = Vec::new();
    let started = Instant::now();
    while times.len() < args.min_repeats || started.elapsed().as_secs_f64() < args.min_time_s {
        let t = Instant::now();
        let out = run();
        times.push(t.elapsed().as_secs_f64());
        std::hint::black_box(out);
    }
    times
}

fn timing(times: Vec<f64>) -> Value {
    json!({
        "time_s": median(times.clone()),
        "time_min_s": times.iter().copied().fold(f64::INFINITY, f64::min),
        "repeats": times.len(),
    })
}

/// Median wall time of the whole `fit` call, and the fit.
fn time_case(pb: &Problem, case: &str, bounded: bool, solver: Solver, args: &Args) -> Value {
    let est = pb.estimator(case);
    let bounds = bounded.then_some(&pb.bounds);
    let run = || fit(pb.phi.as_ref(), &pb.y, &est, bounds, solver);
    let first = match run() {
        Ok(f) => f,
        Err(e) => return json!({"error": e.to_string()}),
    };
    let mut out = timing(repeat(args, || run().ok()));
    let extra = json!({
        "objective": first.objective,
        "status": format!("{:?}", first.status),
        "iterations": first.iterations,
        "condition_number": first.condition_number,
        "coefficients": first.coefficients,
    });
    if let (Some(m), Value::Object(extra)) = (out.as_object_mut(), extra) {
        m.extend(extra);
    }
    out
}

/// The part of a fit that any solver pays through this API: validating Φ and y, the column
/// scales and scaled copy, and evaluating J once (`shipid_estimators::objective`).
fn time_api_floor(pb: &Problem, args: &Args) -> Value {
    let beta = vec![0.0; pb.phi.ncols()];
    timing(repeat(args, || {
        objective(pb.phi.as_ref(), &pb.y, &Estimator::Lsq, &beta).ok()
    }))
}

/// One result row: the problem's identity, the case and solver, and the timing fields.
fn record(pb: &Problem, case: &str, solver: &str, timing: Value) -> Value {
    let mut rec = json!({
        "id": pb.id(),
        "set": pb.set,
        "training_set": pb.training_set,
        "dof": pb.dof.to_string(),
        "n": pb.phi.nrows(),
        "p": pb.phi.ncols(),
        "case": case,
        "solver": solver,
    });
    if let (Some(m), Value::Object(extra)) = (rec.as_object_mut(), timing) {
        m.extend(extra);
    }
    rec
}

/// `cargo xtask fit-bench [FLAGS]`: exit 2 with the message on a bad flag or input.
pub fn main() {
    if let Err(e) = run() {
        eprintln!("fit-bench: {e}");
        std::process::exit(2);
    }
}

fn run() -> Result<(), String> {
    let args = parse_args()?;
    faer::set_global_parallelism(faer::Par::Seq);
    let ds = Dataset::load(&args.dataset).map_err(|e| e.to_string())?;
    let problems = build_problems(&ds, &args.sets)?;
    if let Some(dir) = &args.export {
        export(dir, &problems)?;
        eprintln!("exported {} designs to {}", problems.len(), dir.display());
    }
    let mut records = Vec::new();
    for pb in &problems {
        if args.api_floor {
            records.push(record(
                pb,
                "api_floor",
                "objective_call",
                time_api_floor(pb, &args),
            ));
        }
        for (case, bounded) in CASES {
            if !args.cases.iter().any(|c| c == case) {
                continue;
            }
            for &solver in &args.solvers {
                let r = time_case(pb, case, bounded, solver, &args);
                eprintln!(
                    "{:>9} {:>15} {} n={:5} p={:2} {:>13} {:?}: {:>10.3e} s  J={}",
                    pb.set,
                    pb.training_set,
                    pb.dof,
                    pb.phi.nrows(),
                    pb.phi.ncols(),
                    case,
                    solver,
                    r["time_s"].as_f64().unwrap_or(f64::NAN),
                    r["objective"]
                );
                records.push(record(pb, case, solver.name(), r));
            }
        }
    }
    let text = serde_json::to_string_pretty(&json!({
        "threads": 1,
        "min_repeats": args.min_repeats,
        "min_time_s": args.min_time_s,
        "records": records,
    }))
    .map_err(|e| e.to_string())?;
    if let Some(parent) = args.out.parent() {
        std::fs::create_dir_all(parent).map_err(|e| format!("{}: {e}", parent.display()))?;
    }
    write_file(&args.out, &text)?;
    eprintln!("wrote {}", args.out.display());
    Ok(())
}
