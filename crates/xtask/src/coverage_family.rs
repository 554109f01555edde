//! Measured coverage of the bands of the mmg family and the sparse GP (`cargo xtask coverage
//! --family mmg|sparse-gp [--calibrate]`), on the data, training sets, truths and tables of
//! [`crate::coverage`].
//!
//! mmg: the default fit of `shipid fit --set mmg` (bounded LSQ, λ = 1e-6; the generator's KVLCC2
//! propeller and rudder, which the in-memory data carry no tables of) and `--replicates`
//! block-bootstrap replicates, each re-identified with that λ
//! (`shipid_pipeline::calibration::MmgFamily`). Sparse GP: the default fit (d_gen 0.96) and
//! `--replicates` functions drawn from its posterior (`shipid_pipeline::calibration::GpFamily`). With
//! `--refine` every mmg fit (and every refit of its calibration) is refined in the output-error
//! sense, as `shipid fit --refine`. With `--calibrate` each band is also counted widened by the
//! family's calibration from its training recordings, through the same code path as the
//! polynomial's (`shipid_pipeline::calibration::calibrate_fit`).

use std::path::Path;

use anyhow::Result;
use shipid_pipeline::calibration::{FamilyFit, GpFamily, MmgFamily};
use shipid_pipeline::fit::WindowSpec;
use shipid_pipeline::fit_gp::DEFAULT_SIMILARITY;
use shipid_pipeline::mmg::{DEFAULT_PRIOR_WEIGHT, MmgFitOptions, MmgGeometry};

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

/// Coverage of `family`'s bands (mmg or sparse GP) over `seeds` noise seeds, raw and, with
/// `calibrate`, calibrated; with `refine` every mmg fit is refined in the output-error sense.
pub fn run(
    out: &Path,
    family: Family,
    seeds: u64,
    replicates: usize,
    level: f64,
    calibrate: bool,
    refine: bool,
) -> Result<()> {
    if refine && family != Family::Mmg {
        anyhow::bail!("--refine applies to --family mmg");
    }
    let (fit, what): (Box<crate::coverage::FamilyOf>, String) = match family {
        Family::Mmg => (
            Box::new(move |seed| -> Box<dyn FamilyFit> {
                Box::new(MmgFamily {
                    opts: MmgFitOptions::default(),
                    // The generated data carry no [propeller]/[rudder] tables: the generator's own.
                    geometry: MmgGeometry::kvlcc2_model_scale(),
                    refine,
                    replicates,
                    seed,
                })
            }),
            format!(
                "mmg bounded-lsq (λ = {DEFAULT_PRIOR_WEIGHT:e}){}, {replicates} block-bootstrap \
                 replicates",
                if refine {
                    ", refined (output error; the replicates shifted onto it)"
                } else {
                    ""
                }
            ),
        ),
        Family::SparseGp => (
            Box::new(move |seed| -> Box<dyn FamilyFit> {
                Box::new(GpFamily {
                    window: WindowSpec::Whole,
                    similarity: DEFAULT_SIMILARITY,
                    draws: replicates,
                    seed,
                })
            }),
            format!("sparse GP (d_gen {DEFAULT_SIMILARITY}), {replicates} posterior draws"),
        ),
        Family::Polynomial => anyhow::bail!("the polynomial family is measured by coverage::run"),
    };
    crate::coverage::measure(out, &what, fit.as_ref(), seeds, level, calibrate)
}
