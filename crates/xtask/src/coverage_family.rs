//! Measured coverage of the bands of the mmg family and the sparse GP (`cargo xtask coverage
//! --family mmg|sparse-gp`), on the data, training sets and truths of [`crate::coverage`].
//!
//! mmg: the default fit of `shipid fit --set mmg` (bounded LSQ, λ = 1e-6; the generator's KVLCC2
//! propeller and rudder, which the in-memory data carry no tables of) and `--replicates`
//! block-bootstrap replicates, each re-identified with that λ (`shipid_pipeline::bootstrap::bootstrap_mmg`).
//! Sparse GP: the default fit (d_gen 0.96) and `--replicates` functions drawn from its posterior
//! (`shipid_pipeline::bands::gp_draws`). Coverage is counted per training set, for manoeuvres in the
//! training set and held out, and per metric, with a 95 % Wilson interval, and written as markdown and
//! JSON to `--out`.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result};
use serde_json::json;
use shipid_io::Dataset;
use shipid_pipeline::bands::{BandRun, gp_draws, manoeuvre_bands};
use shipid_pipeline::bootstrap::bootstrap_mmg;
use shipid_pipeline::fit::WindowSpec;
use shipid_pipeline::fit_gp::{DEFAULT_SIMILARITY, fit_gp_dataset};
use shipid_pipeline::generate::generate_manoeuvres;
use shipid_pipeline::mmg::{DEFAULT_PRIOR_WEIGHT, MmgFitOptions, MmgGeometry, fit_mmg, model_file};
use shipid_sim::Dynamics;
use shipid_sim::metrics::metrics;
use shipid_uncertainty::Coverage;

use crate::coverage::{TRAINING_SETS, manoeuvres};

/// The model family whose bands are measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Family {
    /// Polynomial sets with pooled block-bootstrap replicates ([`crate::coverage`]).
    Polynomial,
    /// The mmg family with block-bootstrap replicates.
    Mmg,
    /// The sparse GP with posterior draws.
    SparseGp,
}

/// A point model and the replicated models of its band.
type Fitted = (
    Box<dyn Dynamics + Send + Sync>,
    Vec<Box<dyn Dynamics + Send + Sync>>,
);

/// The default mmg fit on `recordings` of `noisy` and its block-bootstrap replicates.
fn fit_mmg_family(
    noisy: &Dataset,
    recordings: &[String],
    replicates: usize,
    seed: u64,
) -> Result<Fitted> {
    let opts = MmgFitOptions {
        recordings: recordings.to_vec(),
        ..MmgFitOptions::default()
    };
    // The generated data carry no [propeller]/[rudder] tables: the generator's own geometry.
    let fit = fit_mmg(noisy, &MmgGeometry::kvlcc2_model_scale(), &opts)?;
    let boot = bootstrap_mmg(noisy, &fit, &opts, replicates, seed)?;
    let added = noisy.added_mass.context("no added masses")?;
    let mut file = model_file(&fit, added);
    file.bootstrap = Some(boot.record());
    let models = file
        .replicate_models(Path::new("coverage"))?
        .into_iter()
        .map(|m| Box::new(m) as Box<dyn Dynamics + Send + Sync>)
        .collect();
    Ok((Box::new(fit.model), models))
}

/// The default sparse-GP fit on `recordings` of `noisy` and `replicates` posterior draws.
fn fit_sparse_gp(
    noisy: &Dataset,
    recordings: &[String],
    replicates: usize,
    seed: u64,
) -> Result<Fitted> {
    let (_, model, _) = fit_gp_dataset(noisy, recordings, WindowSpec::Whole, DEFAULT_SIMILARITY)?;
    let draws = gp_draws(&model, replicates, seed)?;
    Ok((Box::new(model), draws))
}

/// A family's fit: data set, training recordings, replicates, seed → the fitted model and its bands.
type FitFn = fn(&Dataset, &[String], usize, u64) -> Result<Fitted>;

/// Coverage of `family`'s bands (mmg or sparse GP) over `seeds` noise seeds.
pub fn run(out: &Path, family: Family, seeds: u64, replicates: usize, level: f64) -> Result<()> {
    let (fit, what): (FitFn, String) = match family {
        Family::Mmg => (
            fit_mmg_family,
            format!(
                "mmg bounded-lsq (λ = {DEFAULT_PRIOR_WEIGHT:e}), {replicates} block-bootstrap \
                 replicates"
            ),
        ),
        Family::SparseGp => (
            fit_sparse_gp,
            format!("sparse GP (d_gen {DEFAULT_SIMILARITY}), {replicates} posterior draws"),
        ),
        Family::Polynomial => anyhow::bail!("the polynomial family is measured by coverage::run"),
    };
    let ms = manoeuvres();
    let truth_data = generate_manoeuvres(None, &[], &ms)?.in_memory(&ms, "truth");
    let ship = truth_data.ship;
    // (training set, "trained" | "held out") → coverage; and per metric.
    let mut by_set: BTreeMap<(usize, &str), Coverage> = BTreeMap::new();
    let mut by_metric: BTreeMap<(&str, &str), Coverage> = BTreeMap::new();
    let (mut undefined, mut diverged) = (0usize, 0usize);
    let mut rows = Vec::new();
    for seed in 1..=seeds {
        let noisy = generate_manoeuvres(Some(seed), &[], &ms)?
            .in_memory(&ms, &format!("noise seed {seed}"));
        for (s, (set_name, files)) in TRAINING_SETS.iter().enumerate() {
            let recordings: Vec<String> = files.iter().map(|f| f.to_string()).collect();
            let (point, models) = fit(&noisy, &recordings, replicates, seed)
                .with_context(|| format!("seed {seed}, {set_name}"))?;
            for r in &truth_data.recordings {
                let truth = metrics(&r.recording, &r.manoeuvre, &ship);
                let bands = manoeuvre_bands(
                    point.as_ref(),
                    &models,
                    &r.manoeuvre,
                    &ship,
                    level,
                    BandRun::Standard,
                )?;
                diverged += bands.diverged;
                let place = if files.contains(&r.file.as_str()) {
                    "trained"
                } else {
                    "held out"
                };
                for (b, (_, t)) in bands.metrics.iter().zip(truth.entries()) {
                    let Some(t) = t else { continue };
                    let Ok(band) = &b.band else {
                        undefined += 1;
                        continue;
                    };
                    let inside = band.contains(t);
                    by_set
                        .entry((s, place))
                        .or_insert(Coverage::new(level))
                        .add(inside);
                    by_metric
                        .entry((b.metric, place))
                        .or_insert(Coverage::new(level))
                        .add(inside);
                    rows.push(json!({
                        "seed": seed, "training": set_name, "manoeuvre": r.file, "place": place,
                        "metric": b.metric, "truth": t, "point": b.point, "lo": band.lo,
                        "hi": band.hi, "inside": inside,
                    }));
                }
            }
            eprintln!(
                "seed {seed}/{seeds}, {set_name}: {} replicate models",
                models.len()
            );
        }
    }
    let cell = |c: Option<&Coverage>| crate::coverage::coverage_cell(c, "95 % CI ", " %");
    let mut md = String::new();
    writeln!(
        md,
        "Nominal {:.0} % bands, {what}, seeds 1–{seeds}; truth: the noise-free MMG reference.\n",
        100.0 * level
    )?;
    writeln!(
        md,
        "| training set | trained manoeuvres | held-out manoeuvres |\n|---|---|---|"
    )?;
    for (s, (name, _)) in TRAINING_SETS.iter().enumerate() {
        let get = |p| cell(by_set.get(&(s, p)));
        writeln!(md, "| {name} | {} | {} |", get("trained"), get("held out"))?;
    }
    writeln!(md, "\n| metric | trained | held out |\n|---|---|---|")?;
    let metric_names: BTreeSet<&str> = by_metric.keys().map(|(m, _)| *m).collect();
    for m in metric_names {
        let get = |p| cell(by_metric.get(&(m, p)));
        writeln!(md, "| {m} | {} | {} |", get("trained"), get("held out"))?;
    }
    writeln!(
        md,
        "\nMetrics without a band (fewer than 20 replicates define them): {undefined}; replicate runs \
         that diverged: {diverged}."
    )?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let md_path = out.join("coverage.md");
    std::fs::write(&md_path, &md).with_context(|| format!("writing {}", md_path.display()))?;
    let json_path = out.join("coverage.json");
    std::fs::write(&json_path, serde_json::to_string_pretty(&rows)?)
        .with_context(|| format!("writing {}", json_path.display()))?;
    print!("{md}");
    eprintln!("wrote {} and {}", md_path.display(), json_path.display());
    Ok(())
}
