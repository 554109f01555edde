//! `shipid`: ship manoeuvring system identification. See the README for the commands.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use shipid::{CliError, Outcome, failed};

#[derive(Parser)]
#[command(name = "shipid", version, about = "Ship manoeuvring system identification")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Write the embedded default data set (MMG KVLCC2 reference) as a DATA.md data set.
    Generate {
        /// Output directory.
        #[arg(long, default_value = "data/kvlcc2-mmg")]
        out: PathBuf,
        /// Add seeded Gaussian measurement noise (README: noise model).
        #[arg(long, value_name = "SEED")]
        noise: Option<u64>,
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
    /// Simulate a standard manoeuvre with a model.
    Simulate {
        /// `mmg:kvlcc2` or a model file.
        model: String,
        /// `zigzag:20/20:port` or `turning:35:starboard`.
        #[arg(long)]
        manoeuvre: String,
        /// RK4 step [s].
        #[arg(long)]
        dt: Option<f64>,
        /// Simulated time [s].
        #[arg(long)]
        duration: Option<f64>,
        #[arg(long)]
        json: bool,
        /// Write the time series (DATA.md CSV).
        #[arg(long)]
        out: Option<PathBuf>,
    },
}

fn run(cli: Cli) -> Result<Outcome, CliError> {
    match cli.command {
        Command::Generate { out, noise } => {
            let g = shipid::generate::generate(noise)?;
            let recs: Vec<_> = g.recordings.iter().collect();
            shipid_io::write::write_dataset(&out, &g.dataset, &recs, &shipid::generate::provenance(noise))
                .map_err(failed)?;
            eprintln!("wrote {} recordings and {}", recs.len(), out.join("dataset.toml").display());
            Ok(Outcome::Ok)
        }
        Command::Import { mapping, out, source } => shipid::import::run(&mapping, &out, source.as_deref()),
        Command::Metrics { dataset, json } => shipid::metrics_cmd::run(&dataset, json),
        Command::Simulate {
            model,
            manoeuvre,
            dt,
            duration,
            json,
            out,
        } => shipid::simulate_cmd::run(&model, &manoeuvre, dt, duration, json, out.as_deref()),
    }
}

fn main() -> ExitCode {
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
