//! Measured coverage of the bootstrap bands of a polynomial fit (`cargo xtask coverage`).
//!
//! For several noise seeds, the default manoeuvres plus two that no training set contains are
//! generated with the MMG reference and tank-like measurement noise; reduced32 is fitted (ridge, λ by
//! blocked cross-validation) on training sets from one zig-zag to three manoeuvres; `--replicates`
//! block-bootstrap replicates give each manoeuvre's metric bands; the truth is the metric of the
//! noise-free reference run. Coverage is counted per training set, for manoeuvres in the training set
//! and held out, with a 95 % Wilson interval, and written as markdown and JSON to `--out`.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result};
use serde_json::json;
use shipid_estimators::Solver;
use shipid_io::Manoeuvre;
use shipid_model::CoefficientSet;
use shipid_pipeline::bands::{BandRun, manoeuvre_bands};
use shipid_pipeline::bootstrap::bootstrap_abkowitz;
use shipid_pipeline::fit::{EstimatorSpec, WindowSpec, fit_dataset};
use shipid_pipeline::generate::{default_manoeuvres, generate_manoeuvres};
use shipid_pipeline::spec::parse_manoeuvre;
use shipid_sim::AbkowitzDynamics;
use shipid_sim::metrics::metrics;
use shipid_uncertainty::Coverage;

/// Training sets, by recording file (as `generate` names them).
const TRAINING_SETS: [(&str, &[&str]); 3] = [
    ("ZZ35 port", &["zz35_35_ps.csv"]),
    (
        "ZZ35 port + starboard",
        &["zz35_35_ps.csv", "zz35_35_sb.csv"],
    ),
    (
        "ZZ10 + ZZ20 + ZZ35 port",
        &["zz10_10_ps.csv", "zz20_20_ps.csv", "zz35_35_ps.csv"],
    ),
];

/// Manoeuvres no training set contains, besides the default six.
const EXTRA_MANOEUVRES: [&str; 2] = ["zigzag:15/15:starboard", "turning:20:port"];

fn manoeuvres() -> Vec<Manoeuvre> {
    let mut ms = default_manoeuvres();
    ms.extend(
        EXTRA_MANOEUVRES
            .iter()
            .map(|s| parse_manoeuvre(s).expect("valid spec")),
    );
    ms
}

pub fn run(
    out: &Path,
    seeds: u64,
    replicates: usize,
    level: f64,
    structures: &[String],
) -> Result<()> {
    let ms = manoeuvres();
    let truth_data = generate_manoeuvres(None, &[], &ms)?.in_memory(&ms, "truth");
    let ship = truth_data.ship;
    let truth: Vec<_> = truth_data
        .recordings
        .iter()
        .map(|r| (r.file.clone(), metrics(&r.recording, &r.manoeuvre, &ship)))
        .collect();
    // (training set, "trained" | "held out") → coverage; and per metric.
    let mut by_set: BTreeMap<(usize, &str), Coverage> = BTreeMap::new();
    let mut by_metric: BTreeMap<(&str, &str), Coverage> = BTreeMap::new();
    let mut undefined = 0usize;
    let mut rows = Vec::new();
    for seed in 1..=seeds {
        let noisy = generate_manoeuvres(Some(seed), &[], &ms)?
            .in_memory(&ms, &format!("noise seed {seed}"));
        for (s, (set_name, files)) in TRAINING_SETS.iter().enumerate() {
            let recordings: Vec<String> = files.iter().map(|f| f.to_string()).collect();
            let spec = EstimatorSpec {
                tune: true,
                ..EstimatorSpec::named("ridge")
            };
            // The point model is the first structure's; the replicates are pooled over all
            // structures (equal shares), so the band carries the spread between structures too.
            let mut point = None;
            let mut models = Vec::new();
            let mut block_rows = Vec::new();
            for name in structures {
                let fit = fit_dataset(
                    &noisy,
                    CoefficientSet::builtin(name).with_context(|| format!("set {name}"))?,
                    &spec,
                    &recordings,
                    WindowSpec::Whole,
                    Solver::Fast,
                )
                .with_context(|| format!("seed {seed}, {set_name}, {name}"))?;
                let estimators = [0, 1, 2].map(|i| fit.dofs[i].fit.estimator);
                let boot = bootstrap_abkowitz(
                    &noisy,
                    &fit.model,
                    &fit.model.coefficients,
                    &fit.training,
                    &estimators,
                    false,
                    Solver::Fast,
                    (replicates / structures.len()).max(2),
                    seed,
                )?;
                models.extend(boot.models(&fit.model));
                block_rows.push(boot.block.rows);
                point.get_or_insert(AbkowitzDynamics(fit.model.clone()));
            }
            let point = point.context("no structure")?;
            for (r, (file, true_metrics)) in truth_data.recordings.iter().zip(&truth) {
                let bands = manoeuvre_bands(
                    &point,
                    &models,
                    &r.manoeuvre,
                    &ship,
                    level,
                    BandRun::Standard,
                )?;
                let place = if files.contains(&file.as_str()) {
                    "trained"
                } else {
                    "held out"
                };
                for (b, (_, t)) in bands.metrics.iter().zip(true_metrics.entries()) {
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
                        "seed": seed, "training": set_name, "manoeuvre": file, "place": place,
                        "metric": b.metric, "truth": t, "point": b.point, "lo": band.lo, "hi": band.hi,
                        "inside": inside, "block_rows": block_rows,
                    }));
                }
            }
            eprintln!(
                "seed {seed}/{seeds}, {set_name}: blocks {block_rows:?} rows, {} replicate models",
                models.len()
            );
        }
    }
    let cell = |c: &Coverage| {
        let (lo, hi) = c.wilson_95().unwrap_or((f64::NAN, f64::NAN));
        format!(
            "{:.0} % ({}/{}; 95 % CI {:.0}–{:.0} %)",
            100.0 * c.measured().unwrap_or(f64::NAN),
            c.inside,
            c.total,
            100.0 * lo,
            100.0 * hi
        )
    };
    let mut md = String::new();
    writeln!(
        md,
        "Nominal {:.0} % bands, {} ridge (λ tuned), {replicates} block-bootstrap replicates pooled \
         over the structures, seeds 1–{seeds}; truth: the noise-free MMG reference.\n",
        100.0 * level,
        structures.join(" + ")
    )?;
    writeln!(
        md,
        "| training set | trained manoeuvres | held-out manoeuvres |\n|---|---|---|"
    )?;
    for (s, (name, _)) in TRAINING_SETS.iter().enumerate() {
        let get = |p| by_set.get(&(s, p)).map(cell).unwrap_or_else(|| "–".into());
        writeln!(md, "| {name} | {} | {} |", get("trained"), get("held out"))?;
    }
    writeln!(md, "\n| metric | trained | held out |\n|---|---|---|")?;
    let metric_names: Vec<&str> = by_metric
        .keys()
        .map(|(m, _)| *m)
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    for m in metric_names {
        let get = |p| {
            by_metric
                .get(&(m, p))
                .map(cell)
                .unwrap_or_else(|| "–".into())
        };
        writeln!(md, "| {m} | {} | {} |", get("trained"), get("held out"))?;
    }
    writeln!(
        md,
        "\nMetrics without a band (fewer than 20 replicates define them): {undefined}."
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
