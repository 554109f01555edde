//! A calibration stored in a model file (`shipid fit --bootstrap N --calibrate`): the `[calibration]`
//! table written and read back, its damaged keys refused by name, and the bands it gives
//! (`shipid_pipeline::calibration::{calibration_record, stored_calibration, ModelBands}`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use shipid_estimators::Solver;
use shipid_io::{Dataset, Manoeuvre, Side};
use shipid_model::{
    CalibrationRecord, CoefficientSet, Dof, FactorRecord, OutOfKindRecord, StructureRecord,
};
use shipid_pipeline::bands::{BandRun, manoeuvre_bands};
use shipid_pipeline::calibration::{
    EnsembleSpec, ModelBands, calibrate_ensemble, calibration_record, fit_ensemble_stored,
    stored_calibration, widen_metric,
};
use shipid_pipeline::fit::{EstimatorSpec, WindowSpec, fit_dataset};
use shipid_sim::AbkowitzDynamics;

fn default_data() -> Dataset {
    Dataset::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/kvlcc2-mmg/dataset.toml"))
        .expect("the shipped default data load")
}

fn ridge() -> EstimatorSpec {
    EstimatorSpec {
        lambda: Some(1e-6),
        ..EstimatorSpec::named("ridge")
    }
}

/// A folder of its own for one test's files (no two tests share one).
fn scratch(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("shipid-{test}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// reduced32 fitted to ZZ35 port, 40 replicates, calibrated at 0.9, written as `model.toml` in
/// `dir` (with `[bootstrap]` too, as `shipid fit` writes it); its record.
fn write_calibrated(dir: &Path) -> (PathBuf, CalibrationRecord) {
    let ds = default_data();
    let spec = ridge();
    let recordings = vec!["zz35_35_ps.csv".to_string()];
    let set = CoefficientSet::builtin("reduced32").unwrap();
    let out = fit_dataset(
        &ds,
        set.clone(),
        &spec,
        &recordings,
        WindowSpec::Whole,
        Solver::Fast,
    )
    .unwrap();
    let sets = [set];
    let how = EnsembleSpec {
        sets: &sets,
        estimator: &spec,
        window: WindowSpec::Whole,
        solver: Solver::Fast,
        replicates: 40,
        seed: 1,
    };
    let (ensemble, structures) = fit_ensemble_stored(&ds, &how, &recordings).unwrap();
    let c = calibrate_ensemble(&ensemble, &ds, &how, &recordings, 0.9).unwrap();
    let record = calibration_record(&c, &how, structures);
    let boot =
        shipid_pipeline::bootstrap::bootstrap_fit(&ds, &out, &spec, Solver::Fast, 40, 1).unwrap();
    let mut file = out.file.clone();
    file.bootstrap = Some(boot.record(&out.model));
    file.calibration = Some(record.clone());
    let path = dir.join("model.toml");
    shipid_pipeline::model_file::anchor_training(&mut file.training, &path);
    std::fs::write(&path, toml::to_string(&file).unwrap()).unwrap();
    (path, record)
}

#[test]
fn a_stored_calibration_widens_the_pooled_band_by_its_family_factor_and_the_runs_reach() {
    let dir = scratch("stored-calibration");
    let (path, record) = write_calibrated(&dir);
    let spec = path.to_str().unwrap();
    // The factors come back as written, for every family, with how they were obtained.
    assert_eq!(record.folds, 0, "one training recording: no held-out fold");
    for family in ["overshoot", "zigzag-time", "turning-length"] {
        let f = &record.factors[family];
        assert!(
            f.factor >= 1.0 && f.in_sample == f.errors && f.held_out == 0,
            "{f:?}"
        );
    }
    let stored = stored_calibration(spec, 0.9)
        .unwrap()
        .expect("a [calibration]");
    assert_eq!(stored.structures, vec![("reduced32".to_string(), 40)]);
    assert!(
        stored.range.is_some(),
        "the training data are beside the file"
    );
    let model = shipid_model::ModelFile::to_model(
        &toml::from_str::<shipid_model::ModelFile>(&std::fs::read_to_string(&path).unwrap())
            .unwrap(),
    )
    .unwrap();
    let point = AbkowitzDynamics(model);
    let turning = Manoeuvre::Turning {
        rudder_deg: 35.0,
        side: Side::Starboard,
    };
    let ship = default_data().ship;
    let calibrated = stored
        .bands(&point, &turning, &ship, BandRun::Standard)
        .unwrap();
    let raw = manoeuvre_bands(
        &point,
        &stored.replicates,
        &turning,
        &ship,
        0.9,
        BandRun::Standard,
    )
    .unwrap();
    // A 35° turn from a zig-zag: the run leaves the identification range.
    assert!(calibrated.reach > 1.0, "reach {}", calibrated.reach);
    let factor = record.factors["turning-length"].factor;
    let mut checked = 0;
    for (c, raw_metric) in calibrated.bands.metrics.iter().zip(&raw.metrics) {
        let metric = raw_metric.metric;
        let (Ok(c), Ok(r)) = (&c.band, &raw_metric.band) else {
            continue;
        };
        // Zig-zag-trained: the turn's lengths also carry the out-of-kind term.
        let w = widen_metric(
            r,
            metric,
            factor,
            calibrated.reach,
            record.out_of_kind.as_ref(),
        );
        assert_eq!((c.lo, c.hi), (w.lo, w.hi), "{metric}");
        assert!(c.lo < r.lo && c.hi > r.hi);
        checked += 1;
    }
    assert_eq!(checked, 4, "the four turning-circle lengths have bands");
    // The same file through ModelBands says it is calibrated; at another level it is refused,
    // naming the key.
    assert_eq!(ModelBands::of(spec, 0.9).unwrap().kind(), "calibrated");
    let other = ModelBands::of(spec, 0.8).err().unwrap().to_string();
    assert!(other.contains("calibration.level"), "{other}");
    // Without the table the bands are the bootstrap's alone.
    let text = std::fs::read_to_string(&path).unwrap();
    let mut file: shipid_model::ModelFile = toml::from_str(&text).unwrap();
    file.calibration = None;
    let plain = dir.join("plain.toml");
    std::fs::write(&plain, toml::to_string(&file).unwrap()).unwrap();
    let bands = ModelBands::of(plain.to_str().unwrap(), 0.8).unwrap();
    assert_eq!(bands.kind(), "bootstrap");
    assert!(bands.what().starts_with("bootstrap only"));
    std::fs::remove_dir_all(&dir).ok();
}

/// A sound record of reduced32 with three replicates of every coefficient equal to `value`.
fn sound_record() -> CalibrationRecord {
    let set = CoefficientSet::builtin("reduced32").unwrap();
    let replicates = Dof::ALL
        .iter()
        .map(|&d| {
            (
                d.as_str().to_string(),
                set.names(d)
                    .into_iter()
                    .map(|n| (n, vec![0.01, 0.02, 0.03]))
                    .collect(),
            )
        })
        .collect();
    let factor = |outcome: &str, factor: f64| FactorRecord {
        outcome: outcome.into(),
        factor,
        errors: 4,
        in_sample: 4,
        held_out: 0,
    };
    CalibrationRecord {
        method: "test".into(),
        level: 0.9,
        seed: 1,
        folds: 0,
        factors: BTreeMap::from([
            ("overshoot".into(), factor("own", 2.0)),
            ("zigzag-time".into(), factor("pooled", 1.5)),
            ("turning-length".into(), factor("too-few", 1.0)),
        ]),
        out_of_kind: Some(OutOfKindRecord {
            trained_on: vec!["zigzag".into()],
            source: "test".into(),
            relative: BTreeMap::from([("turning-length".into(), 0.1)]),
        }),
        structures: vec![StructureRecord {
            set: set.file.clone(),
            block_rows: 10,
            replicates,
        }],
    }
}

/// One concern: a damaged record is refused naming `key`.
fn check(damage: fn(&mut CalibrationRecord), key: &str) {
    let mut r = sound_record();
    damage(&mut r);
    let e = r.check("reduced32").expect_err(key);
    assert_eq!(e.key, key, "{e}");
}

#[test]
fn damaged_calibration_tables_are_refused_naming_the_key() {
    assert!(sound_record().check("reduced32").is_ok());
    check(|r| r.level = 1.5, "calibration.level");
    check(|r| r.level = f64::NAN, "calibration.level");
    check(
        |r| {
            r.factors.remove("overshoot");
        },
        "calibration.factors.overshoot",
    );
    check(
        |r| r.factors.get_mut("overshoot").unwrap().outcome = "guessed".into(),
        "calibration.factors.overshoot.outcome",
    );
    check(
        |r| r.factors.get_mut("zigzag-time").unwrap().factor = 0.5,
        "calibration.factors.zigzag-time.factor",
    );
    check(
        |r| r.factors.get_mut("zigzag-time").unwrap().factor = f64::INFINITY,
        "calibration.factors.zigzag-time.factor",
    );
    check(
        |r| r.factors.get_mut("turning-length").unwrap().factor = 3.0,
        "calibration.factors.turning-length.factor",
    );
    check(
        |r| {
            let f = r.factors["overshoot"].clone();
            r.factors.insert("speed".into(), f);
        },
        "calibration.factors.speed",
    );
    check(
        |r| {
            r.out_of_kind
                .as_mut()
                .unwrap()
                .trained_on
                .push("spiral".into())
        },
        "calibration.out_of_kind.trained_on",
    );
    check(
        |r| {
            let o = r.out_of_kind.as_mut().unwrap();
            o.relative.insert("speed".into(), 0.1);
        },
        "calibration.out_of_kind.relative.speed",
    );
    check(
        |r| {
            let o = r.out_of_kind.as_mut().unwrap();
            o.relative.insert("turning-length".into(), -0.1);
        },
        "calibration.out_of_kind.relative.turning-length",
    );
    check(
        |r| {
            let o = r.out_of_kind.as_mut().unwrap();
            o.relative.insert("turning-length".into(), f64::NAN);
        },
        "calibration.out_of_kind.relative.turning-length",
    );
    check(|r| r.structures.clear(), "calibration.structure");
    check(
        |r| r.structures[0].set.name = "full74".into(),
        "calibration.structure[0].set.name",
    );
    check(
        |r| {
            let x = r.structures[0].replicates.get_mut("X").unwrap();
            x.values_mut().next().unwrap().push(0.04);
        },
        "calibration.structure[0].replicates",
    );
    check(
        |r| {
            let y = r.structures[0].replicates.get_mut("Y").unwrap();
            y.values_mut().next().unwrap()[1] = f64::NAN;
        },
        "calibration.structure[0].replicates",
    );
    check(
        |r| {
            r.structures[0].replicates.remove("N");
        },
        "calibration.structure[0].replicates",
    );
    check(
        |r| {
            let x = r.structures[0].replicates["X"].clone();
            r.structures[0].replicates.insert("K".into(), x);
        },
        "calibration.structure[0].replicates",
    );
}
