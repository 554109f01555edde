//! `shipid`: ship manoeuvring system identification. See the README for the commands.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use shipid::{CliError, Outcome};

#[derive(Parser)]
#[command(
    name = "shipid",
    version,
    about = "Ship manoeuvring system identification"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Write the embedded default data set (MMG KVLCC2 reference) as a data set (docs/data-format.md).
    Generate {
        /// Output directory.
        #[arg(long, default_value = "data/kvlcc2-mmg")]
        out: PathBuf,
        /// Add seeded Gaussian measurement noise (README: noise model).
        #[arg(long, value_name = "SEED", allow_negative_numbers = true)]
        noise: Option<u64>,
        /// Apply a physical effect, concealed (e.g. `current:speed=0.05,from=120`); repeatable.
        #[arg(long, value_name = "KIND:KEY=VALUE,...")]
        effect: Vec<String>,
        /// Simulate this manoeuvre instead of the default six (`zigzag:15/15:starboard`,
        /// `turning:20:port`); repeatable.
        #[arg(long, value_name = "SPEC")]
        manoeuvre: Vec<String>,
        /// A wind felt and written as recorded channels, varying between runs
        /// (`mean=3,spread=1.5,from=120,from_spread=45,seed=7,gust=0.15,gust_time=2`; docs/data-format.md).
        #[arg(long, value_name = "KEY=VALUE,...")]
        recorded_wind: Option<String>,
        /// A current felt and written as recorded channels (`speed=0.02,from=120`).
        #[arg(long, value_name = "KEY=VALUE,...")]
        recorded_current: Option<String>,
        /// Write the recorded wind as the true wind (`wind_speed`, `wind_from`) or as measured on
        /// board (`relative_wind_speed`, `relative_wind_angle`; docs/data-format.md).
        #[arg(long, value_name = "true|relative", default_value = "true")]
        wind_channels: shipid_io::write::WindChannels,
        /// Write into a folder that is not empty (e.g. regenerate the shipped data set): files of the
        /// same names are replaced, others stay.
        #[arg(long)]
        force: bool,
    },
    /// Import recordings of another layout through a mapping file.
    Import {
        mapping: PathBuf,
        #[arg(long)]
        out: PathBuf,
        /// Directory of the source files (default: the mapping's `source_dir`).
        #[arg(long)]
        source: Option<PathBuf>,
    },
    /// IMO metrics of every recording of a data set.
    Metrics {
        dataset: PathBuf,
        #[arg(long)]
        json: bool,
    },
    /// Identify a model (Abkowitz polynomial, mmg or sparse GP) from a data set.
    Fit {
        dataset: PathBuf,
        /// reduced32, full68, full74 (full68 + port/starboard asymmetry), chen2021, a set file, or mmg
        /// (the MMG model's parameters, docs/mmg.md; --estimator bounded-lsq|ridge, --lambda = the
        /// prior weight or --tune).
        /// Default: reduced32 (none for the sparse GP, which has no coefficient set).
        #[arg(long)]
        set: Option<String>,
        /// lsq, bounded-lsq, ridge, lasso, svr, or sparse-gp (paper 001; --set does not apply).
        /// Default: lsq, and bounded-lsq for --set mmg.
        #[arg(long)]
        estimator: Option<String>,
        /// sparse-gp: similarity threshold d_gen in (0, 1] of the sparsification (default 0.96).
        #[arg(long, value_name = "D", allow_hyphen_values = true)]
        similarity: Option<f64>,
        /// Ridge λ (on the column-scaled design, least-squares term as a mean).
        #[arg(long, allow_hyphen_values = true)]
        lambda: Option<f64>,
        /// Lasso α (scikit-learn convention on the column-scaled design).
        #[arg(long, allow_hyphen_values = true)]
        alpha: Option<f64>,
        /// SVR C.
        #[arg(long, allow_hyphen_values = true)]
        c: Option<f64>,
        /// SVR ε (units of the prime target; default 1 % of its RMS, or tuned with --tune).
        #[arg(long, allow_hyphen_values = true)]
        epsilon: Option<f64>,
        /// Choose the hyper-parameters by blocked cross-validation: λ, α, or the SVR's C and ε (C
        /// alone when --epsilon is given).
        #[arg(long)]
        tune: bool,
        /// Then refine all coefficients so that segment replays of the training windows (10 L/U0,
        /// restarted from the recorded state) match the recorded track and heading (output error).
        #[arg(long)]
        refine: bool,
        /// Training recordings (comma separated file names; default all).
        #[arg(long, value_delimiter = ',')]
        recordings: Vec<String>,
        /// Truncate each training zig-zag after N overshoots.
        #[arg(long, allow_negative_numbers = true)]
        overshoots: Option<u32>,
        /// Time window START:END [s] of each training recording.
        #[arg(long, value_name = "START:END", allow_hyphen_values = true)]
        window: Option<String>,
        /// qp (clarabel reference) or fast (default). Polynomial sets only: the sparse GP and --set
        /// mmg have their own solvers.
        #[arg(long)]
        solver: Option<String>,
        #[arg(long)]
        out: PathBuf,
        #[arg(long)]
        json: bool,
        /// Then validate the model on every recording of the data set.
        #[arg(long)]
        validate: bool,
        /// Store N moving-block bootstrap replicates of the coefficients in the model file (the
        /// replicates `simulate --bands` draws its bands from; 20 to 10 000, a band needs at least
        /// 20; docs/uncertainty.md).
        #[arg(long, value_name = "N", allow_negative_numbers = true)]
        bootstrap: Option<i64>,
        /// Seed of the bootstrap draws.
        #[arg(
            long,
            default_value_t = 1,
            requires = "bootstrap",
            allow_negative_numbers = true
        )]
        bootstrap_seed: u64,
        /// Also store what calibrated bands need at LEVEL (default 0.9): the inflation per metric
        /// family from the training recordings and, for polynomial sets, the pooled bootstrap
        /// replicates of --structures (polynomial and mmg need --bootstrap; a sparse GP widens its
        /// posterior draws; docs/uncertainty.md); `simulate --bands` and `validate --bands` use them.
        #[arg(long, value_name = "LEVEL", num_args = 0..=1, default_missing_value = "0.9",
            allow_negative_numbers = true)]
        calibrate: Option<f64>,
        /// Coefficient sets of the calibration's ensemble, comma-separated (default: --set alone,
        /// as a study's `calibrate = true`); --set is always its first structure.
        #[arg(
            long,
            value_name = "SET,SET,…",
            requires = "calibrate",
            value_delimiter = ','
        )]
        structures: Option<Vec<String>>,
        /// --set mmg: hold the propeller's wake parameters (w_P0, C₁, C₂) at what the training
        /// recordings' `thrust` column measures instead of identifying them from the motion.
        #[arg(long)]
        inflow_from_thrust: bool,
    },
    /// Run a study: its grid of cases in parallel, result tables under results/<study>/.
    Run {
        study: PathBuf,
        /// Parallel cases (default: all cores).
        #[arg(long, value_parser = at_least_one_job)]
        jobs: Option<usize>,
        #[arg(long)]
        out: Option<PathBuf>,
        /// Rerun finished cases too, and write over another study's results in --out.
        #[arg(long)]
        force: bool,
        /// Exit 1 when a prediction diverged (by default a diverged prediction is a result of the
        /// study, counted in its summary line, and the run exits 0).
        #[arg(long)]
        strict: bool,
        /// Run a grid of more than 5000 cases (refused without it).
        #[arg(long)]
        allow_large: bool,
    },
    /// Print a comparison table of a study's summary (markdown).
    Table {
        study: PathBuf,
        /// ROWS,COLS,VALUE columns of the summary table; ROWS and COLS may join several columns
        /// with + (`set+estimator,test,mrae`). A pivot that would put two cases in one cell is
        /// refused. Default: window,test,mrae with the columns that tell the cases apart added to
        /// the rows.
        #[arg(long)]
        pivot: Option<String>,
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Write one self-contained HTML page (DIR/report.html) for a study output folder or a diagnosis
    /// output folder (one holding report.json); it opens offline from the file alone.
    Report {
        /// The output folder of `shipid run` or of `shipid diagnose --plots`.
        dir: PathBuf,
        /// The study file of a study folder (default: the study recorded in the folder's run.json).
        #[arg(long)]
        study: Option<PathBuf>,
    },
    /// Redraw the figures (SVG) of an existing study run into <out>/figures/ (no refitting).
    Plot {
        study: PathBuf,
        /// The run's output directory (default results/<study>/).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Rerun a study and compare its tables with a stored reference.
    Check {
        study: PathBuf,
        #[arg(long)]
        reference: PathBuf,
        /// Store the fresh tables as the new reference.
        #[arg(long)]
        bless: bool,
        /// Parallel cases (default: all cores).
        #[arg(long, value_parser = at_least_one_job)]
        jobs: Option<usize>,
        /// Run a grid of more than 5000 cases (refused without it).
        #[arg(long)]
        allow_large: bool,
    },
    /// Diagnose why a model and recordings it did not see differ: locate the mismatch, name the
    /// physical effect left out, fit it, show the held-out fit improve (docs/diagnosis.md).
    Diagnose {
        /// A model file or `mmg:kvlcc2`.
        model: String,
        dataset: PathBuf,
        /// Write the JSON report here.
        #[arg(long, value_name = "REPORT.json")]
        json: Option<PathBuf>,
        /// Write before/after figures into this directory.
        #[arg(long, value_name = "DIR")]
        plots: Option<PathBuf>,
        /// Write the model with the found effect here (default: beside the report, `.model.toml`).
        #[arg(long, value_name = "MODEL.toml")]
        model_out: Option<PathBuf>,
        /// Replay segment length ÷ (L/U0).
        #[arg(long, default_value_t = 10.0, allow_hyphen_values = true)]
        horizon: f64,
        /// Check mode: conceal the recorded wind and current channels, diagnose, and compare the
        /// verdict and the found wind or current with them.
        #[arg(long)]
        reveal: bool,
        /// Diagnose this one recording of the data set alone (its file name as the data set gives
        /// it): one run's own wind or current, judged on two halves of its time.
        #[arg(long)]
        recording: Option<String>,
    },
    /// Validate a model on a data set: replayed-rudder RMSEs and closed-loop manoeuvre metrics.
    Validate {
        /// A model file or `mmg:kvlcc2`.
        model: String,
        dataset: PathBuf,
        #[arg(long)]
        json: bool,
        /// Check every recorded metric against its band at this level (e.g. 0.9) over the model's
        /// bootstrap replicates (`fit --bootstrap N`), calibrated when the file has a
        /// `[calibration]` (`fit --calibrate`), or a sparse GP's posterior draws.
        #[arg(long, value_name = "LEVEL", allow_hyphen_values = true)]
        bands: Option<f64>,
    },
    /// Simulate a standard manoeuvre (or replay recordings) with a model.
    Simulate {
        /// `mmg:kvlcc2` or a model file.
        model: String,
        /// `zigzag:20/20:port` or `turning:35:starboard`.
        #[arg(long, required_unless_present = "replay", conflicts_with = "replay")]
        manoeuvre: Option<String>,
        /// Replay every recording's rudder of this data set instead.
        #[arg(long, value_name = "DATASET.toml")]
        replay: Option<PathBuf>,
        /// RK4 step [s].
        #[arg(long, allow_hyphen_values = true)]
        dt: Option<f64>,
        /// Simulated time [s].
        #[arg(long, allow_hyphen_values = true)]
        duration: Option<f64>,
        /// Run even more than 1e7 RK4 steps (the stored history is thinned to at most 1e6 samples).
        #[arg(long)]
        allow_large: bool,
        #[arg(long)]
        json: bool,
        /// Write the time series (the recording CSV of docs/data-format.md).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Central band of every metric at this level (e.g. 0.9) over the model's bootstrap
        /// replicates (`fit --bootstrap N`), calibrated when the file has a `[calibration]` (`fit
        /// --calibrate`), or a sparse GP's posterior draws; JSON adds `<metric>_band: [lo, hi]`,
        /// the track band and which band it is.
        #[arg(
            long,
            value_name = "LEVEL",
            allow_hyphen_values = true,
            conflicts_with = "replay"
        )]
        bands: Option<f64>,
        /// A constant true wind: its speed [m/s] and the direction it comes from [deg, clockwise from
        /// north]; the windage is the model file's, else its data set's, else assumed (said so).
        #[arg(
            long,
            value_name = "SPEED_M_S,FROM_DEG",
            conflicts_with = "replay",
            allow_hyphen_values = true
        )]
        wind: Option<String>,
        /// A constant current: its speed [m/s] and the direction it comes from [deg, clockwise from north].
        #[arg(
            long,
            value_name = "SPEED_M_S,FROM_DEG",
            conflicts_with = "replay",
            allow_hyphen_values = true
        )]
        current: Option<String>,
        /// The propeller at this rate [1/s] instead of the model's own, from the model's straight-run
        /// speed at that rate (an mmg model: the polynomial sets and the sparse GP have no rate input).
        #[arg(
            long,
            value_name = "N_PER_S",
            conflicts_with = "replay",
            allow_hyphen_values = true
        )]
        propeller_rate: Option<f64>,
    },
    /// Paper 003: hydrodynamics of a ship from its motion indexes (SVD modes, simulated database, MLP).
    Inverse {
        /// Targets file (ship particulars and motion indexes), e.g. data/paper003/targets.toml.
        targets: PathBuf,
        /// The hydrodynamic database (default: paper 003 Tab. 1, data/paper003/ships.toml, built in).
        #[arg(long)]
        ships: Option<PathBuf>,
        /// Simulated ships per target (paper 003: 2603 for KVLCC2).
        #[arg(long, default_value_t = 2603, allow_negative_numbers = true)]
        samples: usize,
        #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
        seed: u64,
        /// Number of modes (default: the fewest reaching 95 % of the variation).
        #[arg(long, allow_negative_numbers = true)]
        modes: Option<usize>,
        /// Held-out test samples to re-simulate with their predicted weights.
        /// Default 200; at most the held-out test samples (said when more are asked for).
        #[arg(long, allow_negative_numbers = true)]
        resimulate: Option<usize>,
        /// Simulations per start of the Nelder–Mead refinement of the network's answer (0: off; at
        /// most 10000).
        #[arg(long, default_value_t = 150, allow_negative_numbers = true)]
        refine_evals: usize,
        #[arg(long, default_value = "results/paper003")]
        out: PathBuf,
        /// Simulate more than 100 000 ships per target (refused without it).
        #[arg(long)]
        allow_large: bool,
    },
}

fn run(cli: Cli) -> Result<Outcome, CliError> {
    // A model file from a newer shipid is read (its keys are checked as any other's), with a word.
    if let Command::Simulate { model, .. }
    | Command::Validate { model, .. }
    | Command::Diagnose { model, .. } = &cli.command
        && let Some(note) = shipid_pipeline::model_file::newer_version_note(model)
    {
        eprintln!("warning: {note}");
    }
    match cli.command {
        Command::Generate {
            out,
            noise,
            effect,
            manoeuvre,
            recorded_wind,
            recorded_current,
            wind_channels,
            force,
        } => {
            shipid::outputs::check_folder("--out", &out, &[], &shipid::outputs::Inputs::new())?;
            // The default --out is the shipped reference data set: a noisy or concealed-effect run
            // from the repository root would otherwise replace it without a word.
            let before = shipid::outputs::refuse_nonempty_folder(
                "--out",
                &out,
                "a generated data set",
                force,
            )?;
            let effects = shipid_pipeline::generate::parse_effects(&effect)?;
            let recorded = match (&recorded_wind, &recorded_current) {
                (None, None) => None,
                _ => Some(shipid_pipeline::generate::RecordedEnvironment {
                    wind: recorded_wind.as_deref().map(str::parse).transpose()?,
                    current: recorded_current.as_deref().map(str::parse).transpose()?,
                    windage: shipid_pipeline::generate::default_windage(),
                }),
            };
            let channels_comment = shipid_pipeline::generate::wind_channels_provenance(
                recorded.as_ref(),
                wind_channels,
            )?;
            let manoeuvres = if manoeuvre.is_empty() {
                shipid_pipeline::generate::default_manoeuvres()
            } else {
                manoeuvre
                    .iter()
                    .map(|m| {
                        shipid_pipeline::spec::parse_manoeuvre(m)
                            .map_err(|e| shipid::bad_input(format!("--manoeuvre: {e}")))
                    })
                    .collect::<Result<Vec<_>, _>>()?
            };
            let g = shipid_pipeline::generate::generate_recorded(
                noise,
                &effects,
                &manoeuvres,
                recorded.as_ref(),
            )?;
            let recs: Vec<_> = g.recordings.iter().collect();
            let mut comments = shipid_pipeline::generate::provenance(noise);
            comments.extend(
                recorded
                    .iter()
                    .flat_map(shipid_pipeline::generate::recorded_provenance),
            );
            comments.extend(channels_comment);
            shipid_io::write::write_dataset_channels(
                &out,
                &g.dataset,
                &recs,
                &comments,
                wind_channels,
            )
            .map_err(|e| shipid::write_failed(&out, e))?;
            eprintln!(
                "wrote {} recordings and {}",
                recs.len(),
                out.join("dataset.toml").display()
            );
            // Files of an earlier data set that this one does not list would pass for part of it.
            let written: Vec<&str> = g
                .dataset
                .recordings
                .iter()
                .map(|r| r.file.as_str())
                .collect();
            let left: Vec<&String> = before
                .iter()
                .filter(|n| *n != "dataset.toml" && !written.contains(&n.as_str()))
                .collect();
            if !left.is_empty() {
                eprintln!(
                    "warning: --force: {} entr{} of {} left as they were, not part of the new data set: {}",
                    left.len(),
                    if left.len() == 1 { "y" } else { "ies" },
                    out.display(),
                    left.iter()
                        .map(|n| n.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                );
            }
            Ok(Outcome::Ok)
        }
        Command::Import {
            mapping,
            out,
            source,
        } => shipid::import::run(&mapping, &out, source.as_deref()),
        Command::Fit {
            dataset,
            set,
            estimator,
            similarity,
            lambda,
            alpha,
            c,
            epsilon,
            tune,
            refine,
            recordings,
            overshoots,
            window,
            solver,
            out,
            json,
            validate,
            bootstrap,
            bootstrap_seed,
            calibrate,
            structures,
            inflow_from_thrust,
        } => {
            shipid::outputs::check_file(
                "--out",
                &out,
                &shipid::outputs::Inputs::new().dataset(&dataset),
            )?;
            // A set beside the GP would be ignored without a word: it has no coefficients.
            if let (Some(given), Some(shipid_pipeline::fit::GP)) = (&set, estimator.as_deref()) {
                return Err(shipid::bad_input(format!(
                    "--set {given} does not apply to --estimator sparse-gp (a Gaussian process has no coefficient set): drop --set"
                )));
            }
            let set = set.unwrap_or_else(|| "reduced32".to_string());
            if inflow_from_thrust && set != shipid_pipeline::mmg::SET_NAME {
                return Err(shipid::bad_input(
                    "--inflow-from-thrust applies to --set mmg (the other families have no propeller model)",
                ));
            }
            // The mmg family has no unbounded least squares: its physical bounds are part of it.
            let estimator = estimator.unwrap_or_else(|| {
                if set == shipid_pipeline::mmg::SET_NAME {
                    "bounded-lsq".into()
                } else {
                    "lsq".into()
                }
            });
            // Fewer replicates than a band needs would be fitted and then refused: refused up front.
            let min_replicates = shipid_pipeline::bands::MIN_FINITE_REPLICATES;
            let bootstrap = match bootstrap {
                None => None,
                Some(n)
                    if (min_replicates as i64
                        ..=shipid_pipeline::bootstrap::MAX_REPLICATES as i64)
                        .contains(&n) =>
                {
                    Some(n as usize)
                }
                Some(n) => {
                    return Err(shipid::bad_input(format!(
                        "--bootstrap must be between {min_replicates} and {} replicates (a band needs at least {min_replicates}), got {n}",
                        shipid_pipeline::bootstrap::MAX_REPLICATES
                    )));
                }
            };
            // A solver the family does not use would be ignored without a word.
            if solver.is_some() {
                if estimator == shipid_pipeline::fit::GP {
                    return Err(shipid::bad_input(
                        "--solver does not apply to --estimator sparse-gp (it trains its Gaussian processes by its own optimiser): drop --solver",
                    ));
                }
                if set == shipid_pipeline::mmg::SET_NAME {
                    return Err(shipid::bad_input(
                        "--solver does not apply to --set mmg (its bounded fit has its own solver): drop --solver",
                    ));
                }
            }
            let window = match (overshoots, window) {
                (Some(_), Some(_)) => {
                    return Err(shipid::bad_input("give --overshoots or --window, not both"));
                }
                (Some(0), None) => {
                    return Err(shipid::bad_input(
                        "--overshoots must be at least 1 (the record is cut at the peak of overshoot N)",
                    ));
                }
                (Some(n), None) => shipid_pipeline::fit::WindowSpec::Overshoots(n),
                (None, Some(w)) => parse_window(&w)?,
                (None, None) => shipid_pipeline::fit::WindowSpec::Whole,
            };
            let spec = shipid_pipeline::fit::EstimatorSpec {
                name: estimator.clone(),
                lambda,
                alpha,
                c,
                epsilon,
                tune,
                refine,
                similarity,
                inflow_from_thrust,
            };
            // --set mmg reads the estimator's flags its own way (fit_cmd::run_mmg).
            if set != shipid_pipeline::mmg::SET_NAME {
                spec.validate()?;
            }
            if estimator == shipid_pipeline::fit::GP {
                if bootstrap.is_some() {
                    return Err(shipid::bad_input(
                        "--bootstrap applies to polynomial and mmg fits; the sparse GP's uncertainty is its posterior, which `simulate --bands` and `validate --bands` draw from without --bootstrap",
                    ));
                }
                return shipid::fit_cmd::run_gp(
                    &dataset,
                    &recordings,
                    window,
                    similarity,
                    calibrate.map(|level| (level, structures.unwrap_or_default())),
                    &out,
                    json,
                    validate,
                );
            }
            let solver: shipid_estimators::Solver =
                solver.as_deref().unwrap_or("fast").parse().map_err(
                    |e: shipid_estimators::EstimatorError| shipid::bad_input(e.to_string()),
                )?;
            shipid::fit_cmd::run(shipid::fit_cmd::FitArgs {
                dataset: &dataset,
                set: &set,
                estimator: spec,
                recordings,
                window,
                solver,
                out: &out,
                json,
                validate,
                bootstrap: bootstrap.map(|n| (n, bootstrap_seed)),
                calibrate: calibrate.map(|level| (level, structures.unwrap_or_default())),
            })
        }
        Command::Metrics { dataset, json } => shipid::metrics_cmd::run(&dataset, json),
        Command::Simulate {
            model,
            manoeuvre,
            replay,
            dt,
            duration,
            allow_large,
            json,
            out,
            bands,
            wind,
            current,
            propeller_rate,
        } => {
            // With --replay, --out is refused below as not applying.
            if let (Some(out), None) = (&out, &replay) {
                shipid::outputs::check_file_named(
                    "--out",
                    out,
                    "run.csv",
                    &shipid::outputs::Inputs::new().model(&model),
                )?;
            }
            match (manoeuvre, replay) {
                (_, Some(ds)) => {
                    // A replay follows each recording's own time base: these would be silently ignored.
                    for (given, flag) in [
                        (dt.is_some(), "--dt"),
                        (duration.is_some(), "--duration"),
                        (allow_large, "--allow-large"),
                        (out.is_some(), "--out"),
                    ] {
                        if given {
                            return Err(shipid::bad_input(format!(
                                "{flag} does not apply to --replay (each recording is replayed on its own time base)"
                            )));
                        }
                    }
                    shipid::simulate_cmd::run_replay(&model, &ds, json)
                }
                (Some(m), None) => shipid::simulate_cmd::run(&shipid::simulate_cmd::SimulateArgs {
                    model: &model,
                    manoeuvre: &m,
                    dt_s: dt,
                    duration_s: duration,
                    allow_large,
                    json,
                    out_csv: out.as_deref(),
                    bands,
                    wind: wind.as_deref(),
                    current: current.as_deref(),
                    propeller_rate_hz: propeller_rate,
                }),
                (None, None) => Err(shipid::bad_input("give --manoeuvre or --replay")),
            }
        }
        Command::Run {
            study,
            jobs,
            out,
            force,
            strict,
            allow_large,
        } => shipid::study_cmd::run(&study, out.as_deref(), jobs, force, strict, allow_large),
        Command::Table { study, pivot, out } => {
            shipid::study_cmd::table(&study, out.as_deref(), pivot.as_deref())
        }
        Command::Plot { study, out } => shipid::study_cmd::plot(&study, out.as_deref()),
        Command::Report { dir, study } => shipid::report_cmd::run(&dir, study.as_deref()),
        Command::Check {
            study,
            reference,
            bless,
            jobs,
            allow_large,
        } => shipid::study_cmd::check(&study, &reference, bless, jobs, allow_large),
        Command::Validate {
            model,
            dataset,
            json,
            bands,
        } => shipid::validate_cmd::run(&model, &dataset, json, bands),
        Command::Diagnose {
            model,
            dataset,
            json,
            plots,
            model_out,
            horizon,
            reveal,
            recording,
        } => shipid::diagnose_cmd::run(&shipid::diagnose_cmd::DiagnoseArgs {
            model_spec: &model,
            dataset: &dataset,
            json_out: json.as_deref(),
            plots: plots.as_deref(),
            model_out: model_out.as_deref(),
            horizon_l_over_u0: horizon,
            reveal_check: reveal,
            only_recording: recording.as_deref(),
        }),
        Command::Inverse {
            targets,
            ships,
            samples,
            seed,
            modes,
            resimulate,
            refine_evals,
            out,
            allow_large,
        } => shipid::inverse_cmd::run(&shipid::inverse_cmd::InverseArgs {
            targets: &targets,
            ships: ships.as_deref(),
            samples,
            seed,
            modes,
            out: &out,
            max_resim: resimulate.unwrap_or(DEFAULT_RESIMULATE),
            max_resim_given: resimulate.is_some(),
            refine_evals,
            allow_large,
        }),
    }
}

/// `inverse --resimulate` unless given.
const DEFAULT_RESIMULATE: usize = 200;

/// Most parallel cases `--jobs` accepts: each job is a thread with its own stacks and buffers, and
/// 100 000 of them ran for 11 minutes at a load of 2400 on a 2-case study; 1000 started 422 threads
/// for 8 cases on 2 cores. A run never uses more jobs than it has cases (`study_cmd`).
const MAX_JOBS: usize = 256;

/// `--jobs`: 0 would mean no worker at all, so it is refused rather than read as one; more than
/// [`MAX_JOBS`] is more threads than any machine has cores for.
fn at_least_one_job(text: &str) -> Result<usize, String> {
    match text.parse::<usize>() {
        Ok(0) => Err("give at least 1 parallel case".into()),
        Ok(n) if n > MAX_JOBS => Err(format!(
            "{n} parallel cases is more than the {MAX_JOBS} shipid runs (this machine has {} cores)",
            default_jobs()
        )),
        Ok(n) => Ok(n),
        Err(e) => Err(e.to_string()),
    }
}

fn default_jobs() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

fn parse_window(text: &str) -> Result<shipid_pipeline::fit::WindowSpec, CliError> {
    let bad = || {
        shipid::bad_input(format!(
            "--window `{text}`: expected START:END in seconds with END after START, e.g. 0:120"
        ))
    };
    let (a, b) = text.split_once(':').ok_or_else(bad)?;
    let (start_s, end_s) = (
        a.trim().parse::<f64>().map_err(|_| bad())?,
        b.trim().parse::<f64>().map_err(|_| bad())?,
    );
    if !(start_s.is_finite() && end_s.is_finite() && end_s > start_s) {
        return Err(bad());
    }
    // The largest time a recording may hold (its `t` is refused beyond it); such a number would also
    // print as hundreds of digits.
    let max_time_s = shipid_io::units::Quantity::T.bound_si();
    if start_s.abs() > max_time_s || end_s.abs() > max_time_s {
        return Err(shipid::bad_input(format!(
            "--window `{text}`: times beyond ±{max_time_s:e} s, the largest a recording's `t` may hold, are no recording's"
        )));
    }
    Ok(shipid_pipeline::fit::WindowSpec::Time { start_s, end_s })
}

fn main() -> ExitCode {
    // Rust ignores SIGPIPE, so printing the report into `| head` would panic on the closed pipe;
    // the default action ends the process quietly, as for any other command-line tool.
    #[cfg(unix)]
    // SAFETY: called first thing in main, before any thread exists; SIG_DFL is a valid handler.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    match run(cli) {
        Ok(Outcome::Ok) => ExitCode::SUCCESS,
        Ok(Outcome::SomeFailed) => ExitCode::from(1),
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(e.exit_code() as u8)
        }
    }
}
