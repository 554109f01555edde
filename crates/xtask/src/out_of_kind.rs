//! How far a prediction of a manoeuvre kind the training data never showed lands from the truth,
//! over a population of ships (`cargo xtask out-of-kind`): the measurement behind
//! `shipid_pipeline::out_of_kind::OUT_OF_KIND`.
//!
//! A band calibrated on the training recordings cannot see the error of a turning circle predicted
//! from zig-zags alone (docs/uncertainty.md: its states lie inside the zig-zags' range, and no
//! training recording shows a turn's error). That error is measured here instead, on ships other
//! than the one a user predicts: the 20 ships of paper 003's hydrodynamic database (Yoshimura's
//! hull and interaction coefficients, `data/paper003/ships.toml`) on the KVLCC2 model of the default
//! data (its particulars, added masses, propeller and rudder; the reference's own hull, Yasukawa &
//! Yoshimura 2015, is not among them). For each ship and noise seed the default manoeuvres, a 20°
//! turn and two more zig-zags are generated with tank-like noise; each family is fitted with its
//! `shipid fit` defaults on zig-zags only (ZZ35 port; ZZ35 both sides; ZZ10 + ZZ20 + ZZ35 port) and
//! predicts the turning circles, and on turning circles only (TC35 port; both sides) and predicts
//! the zig-zags. The error of each metric is relative to the noise-free truth of that ship,
//! |predicted − true| / |true|; the tables give its quantiles per family and metric family, and
//! the nominal-level quantile is the out-of-kind term of that family.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result};
use rayon::prelude::*;
use serde_json::json;
use shipid_estimators::Solver;
use shipid_inverse::database::{PAPER003_SHIPS_TOML, ShipsFile};
use shipid_inverse::target::{AddedMassPrimes, TargetShip};
use shipid_io::{Dataset, Manoeuvre};
use shipid_model::CoefficientSet;
use shipid_pipeline::bands::{BandRun, manoeuvre_bands};
use shipid_pipeline::calibration::MetricFamily;
use shipid_pipeline::fit::{EstimatorSpec, WindowSpec, fit_dataset};
use shipid_pipeline::fit_gp::{DEFAULT_SIMILARITY, fit_gp_dataset};
use shipid_pipeline::generate::generate_model;
use shipid_pipeline::mmg::{MmgFitOptions, MmgGeometry, fit_mmg};
use shipid_pipeline::out_of_kind::OUT_OF_KIND_LEVELS;
use shipid_pipeline::spec::parse_manoeuvre;
use shipid_sim::metrics::metrics;
use shipid_sim::{AbkowitzDynamics, Dynamics, MmgModel, MmgParameters, kvlcc2_ship};
use shipid_uncertainty::band::quantile;

/// Every manoeuvre generated for a ship: the training ones and the predicted ones.
const MANOEUVRES: [&str; 8] = [
    "zigzag:10/10:port",
    "zigzag:20/20:port",
    "zigzag:35/35:port",
    "zigzag:35/35:starboard",
    "turning:35:port",
    "turning:35:starboard",
    "turning:20:port",
    "zigzag:15/15:starboard",
];

/// Training sets of one kind, and the manoeuvres of the other kind they predict.
const CASES: [(&str, &[&str], &[&str]); 5] = [
    (
        "ZZ35 port",
        &["zz35_35_ps.csv"],
        &["tc35_ps.csv", "tc35_sb.csv", "tc20_ps.csv"],
    ),
    (
        "ZZ35 port + starboard",
        &["zz35_35_ps.csv", "zz35_35_sb.csv"],
        &["tc35_ps.csv", "tc35_sb.csv", "tc20_ps.csv"],
    ),
    (
        "ZZ10 + ZZ20 + ZZ35 port",
        &["zz10_10_ps.csv", "zz20_20_ps.csv", "zz35_35_ps.csv"],
        &["tc35_ps.csv", "tc35_sb.csv", "tc20_ps.csv"],
    ),
    (
        "TC35 port",
        &["tc35_ps.csv"],
        &["zz10_10_ps.csv", "zz20_20_ps.csv", "zz15_15_sb.csv"],
    ),
    (
        "TC35 port + starboard",
        &["tc35_ps.csv", "tc35_sb.csv"],
        &["zz10_10_ps.csv", "zz20_20_ps.csv", "zz15_15_sb.csv"],
    ),
];

/// Training kinds as the product's table tells them apart: label, `TrainedKinds` variant, and the
/// [`CASES`] that count as it.
const CATEGORIES: [(&str, &str, std::ops::Range<usize>); 3] = [
    ("zig-zags of one rudder angle", "ZigzagsOneAngle", 0..2),
    (
        "zig-zags of several rudder angles",
        "ZigzagsSeveralAngles",
        2..3,
    ),
    ("turning circles of one rudder angle", "TurningOnly", 3..5),
];

/// The families measured, as `shipid fit` makes them by default.
const FAMILIES: [&str; 3] = ["polynomial", "mmg", "sparse-gp"];

/// The MMG model of database ship coefficients `c` on the KVLCC2 model of the default data.
fn population_model(c: &shipid_inverse::database::Coefficients) -> Option<MmgModel> {
    let ship = kvlcc2_ship();
    let reference = MmgParameters::kvlcc2();
    let target = TargetShip {
        name: "KVLCC2 model".into(),
        source: String::new(),
        lpp_m: ship.lpp,
        beam_m: ship.beam,
        draft_m: ship.draft,
        propeller_diameter_m: reference.propeller_diameter_m,
        rudder_span_m: reference.rudder_span_m,
        rudder_area_m2: reference.rudder_area_m2,
        cb: ship.displacement / (ship.lpp * ship.beam * ship.draft),
        xg_m: ship.xg,
        k_t: reference.k_t,
        t_p: reference.t_p,
        u0_m_s: ship.u0,
        rudder_rate_deg_s: ship.rudder_rate,
        added_mass: Some(AddedMassPrimes {
            m_x: reference.m_x,
            m_y: reference.m_y,
            j_z: reference.j_z,
        }),
        f_alpha: Some(reference.f_alpha),
        motion: Vec::new(),
    };
    // The resistance of the default data's model, not the full-scale formula the targets use.
    let params = MmgParameters {
        r0: reference.r0,
        ..target.mmg_parameters(c)
    };
    MmgModel::new(ship, params).ok()
}

/// The point model of `family` fitted to `recordings` of `ds` with the defaults of `shipid fit`.
fn fit_point(
    family: &str,
    ds: &Dataset,
    recordings: &[String],
) -> Result<Box<dyn Dynamics + Send + Sync>> {
    Ok(match family {
        "polynomial" => {
            let spec = EstimatorSpec {
                tune: true,
                ..EstimatorSpec::named("ridge")
            };
            let set = CoefficientSet::builtin("reduced32").context("reduced32")?;
            let out = fit_dataset(ds, set, &spec, recordings, WindowSpec::Whole, Solver::Fast)?;
            Box::new(AbkowitzDynamics(out.model))
        }
        "mmg" => {
            let opts = MmgFitOptions {
                recordings: recordings.to_vec(),
                ..MmgFitOptions::default()
            };
            Box::new(fit_mmg(ds, &MmgGeometry::kvlcc2_model_scale(), &opts)?.model)
        }
        _ => {
            let (_, model, _) =
                fit_gp_dataset(ds, recordings, WindowSpec::Whole, DEFAULT_SIMILARITY)?;
            Box::new(model)
        }
    })
}

/// One predicted metric's relative error.
struct Error {
    ship: String,
    seed: u64,
    family: &'static str,
    case: &'static str,
    manoeuvre: String,
    metric: &'static str,
    metric_family: MetricFamily,
    truth: f64,
    predicted: Option<f64>,
}

pub fn run(out: &Path, seeds: u64, level: f64) -> Result<()> {
    let ships: ShipsFile = toml::from_str(PAPER003_SHIPS_TOML).context("the built-in database")?;
    let ms: Vec<Manoeuvre> = MANOEUVRES
        .iter()
        .map(|s| parse_manoeuvre(s).expect("valid spec"))
        .collect();
    let jobs: Vec<(usize, u64)> = (0..ships.ship.len())
        .flat_map(|s| (1..=seeds).map(move |seed| (s, seed)))
        .collect();
    let skipped = std::sync::Mutex::new(Vec::new());
    let errors: Vec<Error> = jobs
        .par_iter()
        .flat_map_iter(|&(s, seed)| {
            let db_ship = &ships.ship[s];
            let id = db_ship.id.clone();
            let Some(model) = population_model(&db_ship.coefficients()) else {
                skipped
                    .lock()
                    .unwrap()
                    .push(format!("{id}: no self-propulsion point"));
                return Vec::new();
            };
            let generated =
                |noise| generate_model(&model, &id, noise, &ms).map(|g| g.in_memory(&ms, &id));
            let (truth, noisy) = match (generated(None), generated(Some(seed))) {
                (Ok(t), Ok(n)) => (t, n),
                (Err(e), _) | (_, Err(e)) => {
                    if seed == 1 {
                        skipped.lock().unwrap().push(format!("{id}: {e}"));
                    }
                    return Vec::new();
                }
            };
            let ship = truth.ship;
            let mut found = Vec::new();
            for family in FAMILIES {
                for (case, training, predicted) in CASES {
                    let recordings: Vec<String> = training.iter().map(|f| f.to_string()).collect();
                    let point = match fit_point(family, &noisy, &recordings) {
                        Ok(p) => p,
                        Err(e) => {
                            eprintln!("{id} seed {seed} {family} {case}: fit failed: {e:#}");
                            continue;
                        }
                    };
                    for file in predicted {
                        let Some(t) = truth.recordings.iter().find(|r| r.file == *file) else {
                            continue;
                        };
                        let true_metrics = metrics(&t.recording, &t.manoeuvre, &ship);
                        let bands = manoeuvre_bands(
                            point.as_ref(),
                            &[],
                            &t.manoeuvre,
                            &ship,
                            level,
                            BandRun::Standard,
                        );
                        let predicted_of = |metric: &str| {
                            bands.as_ref().ok().and_then(|b| {
                                b.metrics
                                    .iter()
                                    .find(|m| m.metric == metric)
                                    .and_then(|m| m.point)
                            })
                        };
                        for (metric, truth_value) in true_metrics.entries() {
                            let (Some(truth_value), Some(metric_family)) =
                                (truth_value, MetricFamily::of(metric))
                            else {
                                continue;
                            };
                            found.push(Error {
                                ship: id.clone(),
                                seed,
                                family,
                                case,
                                manoeuvre: file.to_string(),
                                metric,
                                metric_family,
                                truth: truth_value,
                                predicted: predicted_of(metric),
                            });
                        }
                    }
                }
            }
            eprintln!("{id} seed {seed}: {} predicted metrics", found.len());
            found
        })
        .collect();
    let skipped = skipped.into_inner().unwrap();

    // Relative errors; a prediction that diverged or defines no metric counts as an infinite error
    // (it is outside any band).
    let rel = |e: &Error| {
        e.predicted.map_or(f64::INFINITY, |p| {
            (p - e.truth).abs() / e.truth.abs().max(1e-12)
        })
    };
    let mut md = String::new();
    writeln!(
        md,
        "Relative error |predicted − true| / |true| of a manoeuvre kind the training data never \
         showed, over the {} ships of paper 003's database on the KVLCC2 model (noise seeds \
         1–{seeds}; skipped: {}). Each cell: median / {:.0} % quantile / largest (count).\n",
        ships.ship.len(),
        if skipped.is_empty() {
            "none".to_string()
        } else {
            skipped.join("; ")
        },
        100.0 * level
    )?;
    writeln!(md, "| family | training | metric family | relative error |")?;
    writeln!(md, "|---|---|---|---|")?;
    // Sorted relative errors of `family` trained as `cases` on the metrics of `mf`.
    let sorted_errors = |family: &str, cases: &std::ops::Range<usize>, mf: MetricFamily| {
        let mut v: Vec<f64> = errors
            .iter()
            .filter(|e| {
                e.family == family
                    && e.metric_family == mf
                    && CASES[cases.clone()].iter().any(|c| c.0 == e.case)
            })
            .map(rel)
            .collect();
        v.sort_by(f64::total_cmp);
        v
    };
    let mut summary = BTreeMap::new();
    for family in FAMILIES {
        for (label, _, cases) in &CATEGORIES {
            for mf in MetricFamily::ALL {
                let v = sorted_errors(family, cases, mf);
                if v.is_empty() {
                    continue;
                }
                let q = quantile(&v, level);
                writeln!(
                    md,
                    "| {family} | {label} | {} | {:.3} / {:.3} / {:.3} ({}) |",
                    mf.as_str(),
                    quantile(&v, 0.5),
                    q,
                    v[v.len() - 1],
                    v.len()
                )?;
                summary.insert(format!("{family} {label} {}", mf.as_str()), q);
            }
        }
    }
    writeln!(
        md,
        "\nBy training set (turning lengths from zig-zags, overshoots from turns):\n"
    )?;
    writeln!(
        md,
        "| family | training | median | {:.0} % quantile | count |",
        100.0 * level
    )?;
    writeln!(md, "|---|---|---|---|---|")?;
    for family in FAMILIES {
        for (case, _, _) in CASES {
            let mut v: Vec<f64> = errors
                .iter()
                .filter(|e| {
                    e.family == family
                        && e.case == case
                        && matches!(
                            e.metric_family,
                            MetricFamily::TurningLength | MetricFamily::Overshoot
                        )
                })
                .map(rel)
                .collect();
            if v.is_empty() {
                continue;
            }
            v.sort_by(f64::total_cmp);
            writeln!(
                md,
                "| {family} | {case} | {:.3} | {:.3} | {} |",
                quantile(&v, 0.5),
                quantile(&v, level),
                v.len()
            )?;
        }
    }
    // The table `shipid_pipeline::out_of_kind::OUT_OF_KIND` holds: quantiles at its levels.
    writeln!(
        md,
        "\nQuantiles at the levels of `shipid_pipeline::out_of_kind::OUT_OF_KIND_LEVELS` \
         ({OUT_OF_KIND_LEVELS:?}), as its table holds them:\n\n```text"
    )?;
    for family in FAMILIES {
        for (_, trained, cases) in &CATEGORIES {
            for mf in MetricFamily::ALL {
                let v = sorted_errors(family, cases, mf);
                if v.is_empty() {
                    continue;
                }
                let qs: Vec<String> = OUT_OF_KIND_LEVELS
                    .iter()
                    .map(|&l| {
                        let q = quantile(&v, l);
                        if q.is_finite() {
                            format!("{q:.3}")
                        } else {
                            "INF".into()
                        }
                    })
                    .collect();
                writeln!(md, "{family} {trained} {} [{}]", mf.as_str(), qs.join(", "))?;
            }
        }
    }
    writeln!(md, "```")?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    std::fs::write(out.join("out-of-kind.md"), &md)?;
    let rows: Vec<_> = errors
        .iter()
        .map(|e| {
            json!({"ship": e.ship, "seed": e.seed, "family": e.family, "training": e.case,
                   "manoeuvre": e.manoeuvre, "metric": e.metric, "truth": e.truth,
                   "predicted": e.predicted, "relative_error": rel(e)})
        })
        .collect();
    std::fs::write(
        out.join("out-of-kind.json"),
        serde_json::to_string_pretty(
            &json!({"quantiles": summary, "skipped": skipped, "rows": rows}),
        )?,
    )?;
    print!("{md}");
    Ok(())
}
