//! Research harnesses of shipid that users of the tool do not need; `cargo xtask <task> --help`.
//!
//! - `bench-diagnose`: the concealed-effect benchmark of the diagnosis (docs/diagnosis.md);
//! - `paper001`: paper 001's Tab. 6 and Fig. 9–12 on the HSVA tests (docs/reproductions/paper001.md);
//! - `inverse-bench`: wall time of paper 003's simulation database (docs/benchmarks.md);
//! - `circles`: every crate's file import edges, failing on a circle;
//! - `coverage`: measured coverage of the bootstrap bands on generated noisy data;
//! - `fit-bench`: fit times of the estimators for the side-by-side comparison in `bench/`;
//! - `refine-bench`: wall time and results of `shipid fit --refine` (`bench/refine.md`);
//! - `mmg-valley`: the mmg refinements from every prior weight of the cross-validation grid, on one
//!   objective, with the turns they predict (docs/mmg.md).

mod bench_diagnose;
mod bench_known_wind;
mod circles;
mod coverage;
mod coverage_family;
mod fit_bench;
mod inverse_bench;
mod inverse_indexes;
mod mmg_valley;
mod out_of_kind;
mod paper001;
mod refine_bench;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(name = "xtask", about = "shipid's research harnesses")]
struct Cli {
    #[command(subcommand)]
    task: Task,
}

#[derive(Subcommand)]
enum Task {
    /// Benchmark the diagnosis on generated data with concealed effects (confusion matrix, fit
    /// improvements, recovered parameters) written to `--out`.
    BenchDiagnose {
        /// sparse-gp (paper 001's GP fitted in memory on the clean default data), full74 (refined
        /// LSQ), mmg:kvlcc2, or a model file.
        #[arg(long, default_value = bench_diagnose::GP_BASE)]
        base: String,
        #[arg(long, default_value = "results/diagnose")]
        out: PathBuf,
        #[arg(long, default_value_t = 3)]
        seeds: u64,
        #[arg(long, default_value_t = 12)]
        controls: u64,
    },
    /// Benchmark the diagnosis with a recorded wind as known input (issue 27): bases identified from
    /// windy training runs with the wind as input, other runs diagnosed with their wind concealed.
    BenchKnownWind {
        /// Base families, comma-separated: full74, mmg, sparse-gp.
        #[arg(long, value_delimiter = ',', default_value = "full74,mmg,sparse-gp")]
        bases: Vec<String>,
        #[arg(long, default_value = "results/diagnose-known-wind")]
        out: PathBuf,
        #[arg(long, default_value_t = 3)]
        seeds: u64,
    },
    /// Paper 001 Tab. 6 and Fig. 9–12 on the imported HSVA tests.
    Paper001 {
        #[arg(long, default_value = "data/kvlcc2-hsva/imported/dataset.toml")]
        dataset: PathBuf,
        #[arg(long, default_value = "results/hsva-gp")]
        out: PathBuf,
        /// Similarity threshold d_gen of the sparsification.
        #[arg(long, default_value_t = shipid_pipeline::fit_gp::DEFAULT_SIMILARITY)]
        similarity: f64,
    },
    /// Time the build of paper 003's simulation database (first target of the file).
    InverseBench {
        #[arg(default_value = "data/paper003/targets.toml")]
        targets: PathBuf,
        #[arg(long, default_value = "data/paper003/ships.toml")]
        ships: PathBuf,
        #[arg(long, default_value_t = 2603)]
        samples: usize,
        #[arg(long, default_value_t = 3)]
        repeats: usize,
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// Measured coverage of reduced32's bootstrap bands on generated noisy data (docs/uncertainty.md).
    Coverage {
        #[arg(long, default_value = "results/coverage")]
        out: PathBuf,
        #[arg(long, default_value_t = 10)]
        seeds: u64,
        #[arg(long, default_value_t = 200)]
        replicates: usize,
        /// Nominal level of the bands.
        #[arg(long, default_value_t = 0.9)]
        level: f64,
        /// Coefficient sets whose replicates are pooled (the first gives the point prediction).
        #[arg(long, value_delimiter = ',', default_value = "reduced32")]
        structures: Vec<String>,
        /// The model family: polynomial (`--structures`), mmg or sparse-gp.
        #[arg(long, value_enum, default_value = "polynomial")]
        family: coverage_family::Family,
        /// Also count the calibrated bands of mmg or sparse-gp (the polynomial's always are).
        #[arg(long)]
        calibrate: bool,
        /// Refine every mmg fit in the output-error sense, as `fit --refine` (mmg only).
        #[arg(long)]
        refine: bool,
    },
    /// Relative error of a manoeuvre kind the training data never showed (a turn from zig-zags,
    /// zig-zags from turns), over the 20 ships of paper 003's database (docs/uncertainty.md).
    OutOfKind {
        #[arg(long, default_value = "results/out-of-kind")]
        out: PathBuf,
        #[arg(long, default_value_t = 2)]
        seeds: u64,
        /// The quantile reported as the out-of-kind term.
        #[arg(long, default_value_t = 0.9)]
        level: f64,
    },
    /// The nine motion indexes of paper 003 of model files, as `[[target.motion]]` tables (a hidden
    /// check's targets from a model whose truth is known).
    InverseIndexes {
        /// Model files (or `mmg:kvlcc2`).
        models: Vec<String>,
    },
    /// The mmg refinements from every prior weight of the cross-validation grid on one objective,
    /// with the 35° turns they predict (docs/mmg.md, "The refinement's valley").
    MmgValley {
        #[arg(default_value = "data/kvlcc2-hsva/imported/dataset.toml")]
        dataset: PathBuf,
    },
    /// List every crate's file import edges and fail on a circle (ARCHITECTURE.md's invariant).
    Circles,
    /// Wall time and results of `shipid fit --refine` on the default data, against a baseline binary
    /// (flags: see the module's documentation).
    #[command(disable_help_flag = true)]
    RefineBench {
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        args: Vec<String>,
    },
    /// Fit-time benchmark of the estimators (flags: see the module's documentation).
    #[command(disable_help_flag = true)]
    FitBench {
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        args: Vec<String>,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.task {
        Task::BenchDiagnose {
            base,
            out,
            seeds,
            controls,
        } => bench_diagnose::run(&base, &out, seeds, controls).map(|all_ok| {
            if all_ok {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(1)
            }
        }),
        Task::BenchKnownWind { bases, out, seeds } => bench_known_wind::run(&bases, &out, seeds)
            .map(|all_ok| {
                if all_ok {
                    ExitCode::SUCCESS
                } else {
                    ExitCode::from(1)
                }
            }),
        Task::Paper001 {
            dataset,
            out,
            similarity,
        } => paper001::run(&dataset, &out, similarity).map(|md| {
            print!("{md}");
            eprintln!("wrote {0}/tab6.md and {0}/hsva_25_5.svg", out.display());
            ExitCode::SUCCESS
        }),
        Task::InverseBench {
            targets,
            ships,
            samples,
            repeats,
            seed,
        } => inverse_bench::bench(&targets, &ships, samples, repeats, seed)
            .map(|()| ExitCode::SUCCESS),
        Task::Coverage {
            out,
            seeds,
            replicates,
            level,
            structures,
            family: coverage_family::Family::Polynomial,
            ..
        } => coverage::run(&out, seeds, replicates, level, &structures).map(|()| ExitCode::SUCCESS),
        Task::Coverage {
            out,
            seeds,
            replicates,
            level,
            family,
            calibrate,
            refine,
            ..
        } => coverage_family::run(&out, family, seeds, replicates, level, calibrate, refine)
            .map(|()| ExitCode::SUCCESS),
        Task::OutOfKind { out, seeds, level } => {
            out_of_kind::run(&out, seeds, level).map(|()| ExitCode::SUCCESS)
        }
        Task::InverseIndexes { models } => {
            inverse_indexes::run(&models).map(|()| ExitCode::SUCCESS)
        }
        Task::MmgValley { dataset } => mmg_valley::run(&dataset).map(|md| {
            print!("{md}");
            ExitCode::SUCCESS
        }),
        Task::Circles => {
            let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
            Ok(if circles::run(&root) {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(1)
            })
        }
        Task::RefineBench { .. } => refine_bench::run().map(|()| ExitCode::SUCCESS),
        Task::FitBench { .. } => {
            fit_bench::main();
            Ok(ExitCode::SUCCESS)
        }
    };
    result.unwrap_or_else(|e| {
        eprintln!("error: {e:#}");
        ExitCode::from(2)
    })
}
