//! The `mmg` family: identification on the default data, identifiability, bounds, model file.

use std::path::Path;

use shipid_io::Dataset;
use shipid_pipeline::fit::WindowSpec;
use shipid_pipeline::mmg::{MmgFitOptions, MmgGeometry, PriorWeight, fit_mmg};

fn default_data() -> Dataset {
    Dataset::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/kvlcc2-mmg/dataset.toml"))
        .unwrap()
}

fn zz35(both: bool) -> MmgFitOptions {
    let mut recordings = vec!["zz35_35_ps.csv".to_string()];
    if both {
        recordings.push("zz35_35_sb.csv".into());
    }
    MmgFitOptions {
        recordings,
        window: WindowSpec::Whole,
        ..MmgFitOptions::default()
    }
}

#[test]
fn mmg_explore() {
    let ds = default_data();
    let t = std::time::Instant::now();
    let fit = fit_mmg(&ds, &MmgGeometry::kvlcc2_model_scale(), &zz35(false)).unwrap();
    eprintln!(
        "time {:?} iterations {} samples {}",
        t.elapsed(),
        fit.estimate.iterations,
        fit.samples
    );
    eprintln!(
        "resid {:?} scale {:?}",
        fit.estimate.residual_rms, fit.estimate.force_rms
    );
    for p in &fit.estimate.params {
        eprintln!(
            "{:12} {:10.5} prior {:8.4} se {:9.2e} share {:.3} {} {}",
            p.spec.name,
            p.value,
            p.spec.prior,
            p.standard_error,
            p.data_share,
            p.determined_by_data,
            p.at_bound
        );
    }
    let _ = PriorWeight::CrossValidated;
}
