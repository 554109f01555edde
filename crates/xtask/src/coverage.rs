//! Measured coverage of the bands of a polynomial fit (`cargo xtask coverage`).
//!
//! For several noise seeds, the default manoeuvres plus two that no training set contains are
//! generated with the MMG reference and tank-like measurement noise; the structures of `--structures`
//! are fitted (ridge, λ by blocked cross-validation) on training sets from one zig-zag to three
//! manoeuvres and `--replicates` block-bootstrap replicates are pooled over them
//! (`shipid_pipeline::calibration::fit_ensemble`; the first structure gives the point prediction).
//! The truth is the metric of the noise-free reference run. Each band is counted twice: as the
//! percentiles of the pooled replicates (`raw`), and widened by the calibration of
//! `shipid_pipeline::calibration` (`calibrated`: leave-one-recording-out inflation per metric family
//! from the training recordings alone, and the reach outside the identification range). Coverage is
//! counted per training set for manoeuvres in the training set, held-out ones inside the range and
//! held-out ones outside it, and per metric family, with a 95 % Wilson interval, and written as
//! markdown and JSON to `--out`.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result};
use serde_json::json;
use shipid_estimators::Solver;
use shipid_io::Manoeuvre;
use shipid_model::CoefficientSet;
use shipid_pipeline::bands::BandRun;
use shipid_pipeline::calibration::{
    EnsembleSpec, FamilyFit, MetricFamily, calibrate_fit, source_bands,
};
use shipid_pipeline::fit::{EstimatorSpec, WindowSpec};
use shipid_pipeline::generate::{default_manoeuvres, generate_manoeuvres};
use shipid_pipeline::spec::parse_manoeuvre;
use shipid_sim::metrics::metrics;
use shipid_uncertainty::Coverage;

/// Training sets, by recording file (as `generate` names them).
pub(crate) const TRAINING_SETS: [(&str, &[&str]); 3] = [
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

/// A held-out prediction whose reach is below this is counted as inside the identification range
/// (its mean leverage ratio is below 1.1² ≈ 1.2).
const INSIDE_REACH: f64 = 1.1;

/// Where a prediction lies relative to its training data.
const PLACES: [&str; 3] = [
    "trained",
    "held out, inside range",
    "held out, outside range",
];

pub(crate) fn manoeuvres() -> Vec<Manoeuvre> {
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
    let sets: Vec<CoefficientSet> = structures
        .iter()
        .map(|n| CoefficientSet::builtin(n).with_context(|| format!("set {n}")))
        .collect::<Result<_>>()?;
    let spec = EstimatorSpec {
        tune: true,
        ..EstimatorSpec::named("ridge")
    };
    let family = |seed: u64| -> Box<dyn FamilyFit + '_> {
        Box::new(EnsembleSpec {
            sets: &sets,
            estimator: &spec,
            window: WindowSpec::Whole,
            solver: Solver::Fast,
            replicates,
            seed,
        })
    };
    let what = format!(
        "{} ridge (λ tuned), {replicates} block-bootstrap replicates pooled over the structures",
        structures.join(" + ")
    );
    measure(out, &what, &family, seeds, level, true)
}

/// A family's fit for one noise seed (the seed of its replicates).
pub(crate) type FamilyOf<'a> = dyn Fn(u64) -> Box<dyn FamilyFit + 'a> + 'a;

/// Coverage of the bands of `family` (`what` it is, in words) over `seeds` noise seeds: raw, and
/// with `calibrate` also calibrated (`shipid_pipeline::calibration::calibrate_fit`).
pub(crate) fn measure(
    out: &Path,
    what: &str,
    family: &FamilyOf,
    seeds: u64,
    level: f64,
    calibrate: bool,
) -> Result<()> {
    let ms = manoeuvres();
    let truth_data = generate_manoeuvres(None, &[], &ms)?.in_memory(&ms, "truth");
    let ship = truth_data.ship;
    let truth: Vec<_> = truth_data
        .recordings
        .iter()
        .map(|r| (r.file.clone(), metrics(&r.recording, &r.manoeuvre, &ship)))
        .collect();
    let kinds: &[&str] = if calibrate {
        &["raw", "calibrated"]
    } else {
        &["raw"]
    };
    // (training set, place, raw | calibrated) → coverage; and per metric family.
    let mut by_set: BTreeMap<(usize, &str, &str), Coverage> = BTreeMap::new();
    let mut by_family: BTreeMap<(MetricFamily, &str, &str), Coverage> = BTreeMap::new();
    let (mut undefined, mut diverged, mut replicate_runs) = (0usize, 0usize, 0usize);
    let mut rows = Vec::new();
    let mut calibrations = Vec::new();
    for seed in 1..=seeds {
        let noisy = generate_manoeuvres(Some(seed), &[], &ms)?
            .in_memory(&ms, &format!("noise seed {seed}"));
        let fit = family(seed);
        for (s, (set_name, files)) in TRAINING_SETS.iter().enumerate() {
            let recordings: Vec<String> = files.iter().map(|f| f.to_string()).collect();
            let context = || format!("seed {seed}, {set_name}");
            let fitted = fit.fit(&noisy, &recordings).with_context(context)?;
            let calibration = if calibrate {
                Some(
                    calibrate_fit(fitted.source(), fit.as_ref(), &noisy, &recordings, level)
                        .with_context(context)?,
                )
            } else {
                None
            };
            let factor = |metric: &str| calibration.as_ref().map_or(1.0, |c| c.factor(metric));
            for (r, (file, true_metrics)) in truth_data.recordings.iter().zip(&truth) {
                let (bands, reach) = source_bands(
                    fitted.source(),
                    &r.manoeuvre,
                    &ship,
                    level,
                    BandRun::Standard,
                )?;
                diverged += bands.diverged;
                replicate_runs += bands.replicates;
                let place = if files.contains(&file.as_str()) {
                    PLACES[0]
                } else if reach < INSIDE_REACH {
                    PLACES[1]
                } else {
                    PLACES[2]
                };
                for (b, (_, t)) in bands.metrics.iter().zip(true_metrics.entries()) {
                    let Some(t) = t else { continue };
                    let Ok(band) = &b.band else {
                        undefined += 1;
                        continue;
                    };
                    let Some(family) = MetricFamily::of(b.metric) else {
                        continue;
                    };
                    let calibrated = calibration
                        .as_ref()
                        .map_or(*band, |c| c.widen(band, b.metric, reach));
                    for &kind in kinds {
                        let inside = if kind == "raw" {
                            band.contains(t)
                        } else {
                            calibrated.contains(t)
                        };
                        by_set
                            .entry((s, place, kind))
                            .or_insert(Coverage::new(level))
                            .add(inside);
                        by_family
                            .entry((family, place, kind))
                            .or_insert(Coverage::new(level))
                            .add(inside);
                    }
                    rows.push(json!({
                        "seed": seed, "training": set_name, "manoeuvre": file, "place": place,
                        "metric": b.metric, "truth": t, "point": b.point, "lo": band.lo, "hi": band.hi,
                        "inside": band.contains(t), "reach": reach,
                        "factor": factor(b.metric),
                        "calibrated_lo": calibrated.lo, "calibrated_hi": calibrated.hi,
                        "calibrated_inside": calibrated.contains(t),
                    }));
                }
            }
            eprintln!(
                "seed {seed}/{seeds}, {set_name}: {} replicate models{}",
                fitted.replicates.len(),
                calibration.as_ref().map_or(String::new(), |c| format!(
                    ", factors {}",
                    MetricFamily::ALL
                        .iter()
                        .map(|f| format!("{} {:.2}", f.as_str(), c.factor_of(*f)))
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            );
            calibrations
                .push(json!({"seed": seed, "training": set_name, "calibration": calibration}));
        }
    }
    let cell = |c: Option<&Coverage>| coverage_cell(c, "", "");
    let mut md = String::new();
    writeln!(
        md,
        "Nominal {:.0} % bands, {what}, seeds 1–{seeds}; truth: the noise-free MMG reference. Each \
         cell: measured coverage (inside/total; 95 % Wilson interval in %). raw: the replicates' \
         percentiles; calibrated: widened by the factor of the training recordings' errors (in \
         sample and left out) and the reach.\n",
        100.0 * level,
    )?;
    let header = |md: &mut String, first: &str| -> std::fmt::Result {
        write!(md, "| {first} | band |")?;
        for p in PLACES {
            write!(md, " {p} |")?;
        }
        writeln!(md, "\n|---|---|---|---|---|")
    };
    header(&mut md, "training set")?;
    for (s, (name, _)) in TRAINING_SETS.iter().enumerate() {
        for &kind in kinds {
            write!(md, "| {name} | {kind} |")?;
            for p in PLACES {
                write!(md, " {} |", cell(by_set.get(&(s, p, kind))))?;
            }
            writeln!(md)?;
        }
    }
    writeln!(md)?;
    header(&mut md, "metric family")?;
    for f in MetricFamily::ALL {
        for &kind in kinds {
            write!(md, "| {} | {kind} |", f.as_str())?;
            for p in PLACES {
                write!(md, " {} |", cell(by_family.get(&(f, p, kind))))?;
            }
            writeln!(md)?;
        }
    }
    writeln!(
        md,
        "\nMetrics without a band (fewer than 20 replicates define them): {undefined}; replicate \
         runs that diverged: {diverged} of {replicate_runs}."
    )?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let md_path = out.join("coverage.md");
    std::fs::write(&md_path, &md).with_context(|| format!("writing {}", md_path.display()))?;
    let json_path = out.join("coverage.json");
    std::fs::write(
        &json_path,
        serde_json::to_string_pretty(&json!({"rows": rows, "calibrations": calibrations}))?,
    )
    .with_context(|| format!("writing {}", json_path.display()))?;
    print!("{md}");
    eprintln!("wrote {} and {}", md_path.display(), json_path.display());
    Ok(())
}

/// A coverage table cell: measured share, count, and the 95 % Wilson interval between `ci_before`
/// and `ci_after` ("–" without cases).
pub(crate) fn coverage_cell(c: Option<&Coverage>, ci_before: &str, ci_after: &str) -> String {
    let Some(c) = c else {
        return "–".to_string();
    };
    let (lo, hi) = c.wilson_95().unwrap_or((f64::NAN, f64::NAN));
    format!(
        "{:.0} % ({}/{}; {ci_before}{:.0}–{:.0}{ci_after})",
        100.0 * c.measured().unwrap_or(f64::NAN),
        c.inside,
        c.total,
        100.0 * lo,
        100.0 * hi
    )
}
