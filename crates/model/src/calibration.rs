//! The `[calibration]` table of a model file (`shipid fit --bootstrap N --calibrate`): what calibrated
//! bands need without refitting. The pooled ensemble's replicates per structure (each with its
//! coefficient set, so a file carries every structure it was calibrated with) and the inflation
//! factor of each metric family with how it was obtained. The factors themselves are computed by
//! `shipid_pipeline::calibration`; this crate only stores and checks them. No I/O.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::set::{CoefficientSet, Dof, SetFile};

/// The metric families a calibration may name (as `shipid_pipeline::calibration::MetricFamily`
/// writes them).
pub const FAMILIES: [&str; 3] = ["overshoot", "zigzag-time", "turning-length"];

/// How a family's factor was obtained (the outcomes of `shipid_pipeline::calibration::FamilyFactor`).
pub const OUTCOMES: [&str; 3] = ["own", "pooled", "too-few"];

/// `[calibration]`: calibrated bands of a polynomial fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrationRecord {
    /// The method in words.
    pub method: String,
    /// Nominal level the factors were obtained at (the bands they widen must be at this level).
    pub level: f64,
    /// Seed of every structure's bootstrap draws.
    pub seed: u64,
    /// Training recordings left out in turn (0: a single recording, in-sample errors only).
    pub folds: usize,
    /// Inflation factor per metric family (`overshoot`, `zigzag-time`, `turning-length`).
    pub factors: BTreeMap<String, FactorRecord>,
    /// The term of the manoeuvre kinds the training recordings did not hold (absent in files
    /// calibrated before it existed: no such term).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub out_of_kind: Option<OutOfKindRecord>,
    /// The ensemble's structures; the first is the model file's own set (the point prediction).
    #[serde(rename = "structure")]
    pub structures: Vec<StructureRecord>,
}

/// One family's inflation factor and where it comes from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FactorRecord {
    /// `own` (the family's own errors), `pooled` (all families' errors: too few of its own) or
    /// `too-few` (no inflation: too few errors at all).
    pub outcome: String,
    /// The factor applied (≥ 1; 1 for `too-few`).
    pub factor: f64,
    /// Standardised errors the factor is the `level` quantile of.
    pub errors: usize,
    /// Of those errors: predicted by the ensemble fitted to them (in sample), and held out.
    pub in_sample: usize,
    pub held_out: usize,
}

/// The manoeuvre kinds a model can be said to have seen.
pub const KINDS: [&str; 3] = ["zigzag", "turning", "free"];

/// `[calibration.out_of_kind]`: how far a prediction of a manoeuvre kind the training recordings
/// did not hold (a turning circle from zig-zags alone) lands from the truth, as a relative
/// half-width per metric family, measured on other ships (`shipid_pipeline::calibration`'s
/// population table). Added in quadrature to the calibrated half-width of that family's metrics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutOfKindRecord {
    /// The manoeuvre kinds of the training recordings (`zigzag`, `turning`, `free`).
    pub trained_on: Vec<String>,
    /// Where the relative half-widths come from.
    pub source: String,
    /// Relative half-width (fraction of the band's centre, ≥ 0; `inf`: unbounded) per metric
    /// family of a kind not trained on.
    pub relative: BTreeMap<String, f64>,
}

impl OutOfKindRecord {
    /// Known kinds, known families, half-widths of at least 0 (infinite allowed); the error names
    /// the key.
    pub fn check(&self) -> Result<(), CalibrationDamage> {
        if let Some(k) = self
            .trained_on
            .iter()
            .find(|k| !KINDS.contains(&k.as_str()))
        {
            return Err(damaged(
                "calibration.out_of_kind.trained_on",
                format!("`{k}` is none of {}", KINDS.join(", ")),
            ));
        }
        for (family, &value) in &self.relative {
            let key = format!("calibration.out_of_kind.relative.{family}");
            if !FAMILIES.contains(&family.as_str()) {
                return Err(damaged(
                    key,
                    format!("not a metric family ({})", FAMILIES.join(", ")),
                ));
            }
            // Infinite is meaningful: the population's predictions of that kind diverged.
            if value.is_nan() || value < 0.0 {
                return Err(damaged(
                    key,
                    format!("{value} is not a relative half-width of at least 0"),
                ));
            }
        }
        Ok(())
    }
}

/// One structure of the ensemble: its set and its bootstrap replicates.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StructureRecord {
    pub set: SetFile,
    /// Rows per bootstrap block of this structure's residuals.
    pub block_rows: usize,
    /// Replicate values per DOF and coefficient (as `[bootstrap].replicates`).
    pub replicates: BTreeMap<String, BTreeMap<String, Vec<f64>>>,
}

/// A checked `[calibration]`: each structure's set and replicate vectors, each family's factor.
#[derive(Debug, Clone)]
pub struct CheckedCalibration {
    pub structures: Vec<(CoefficientSet, Vec<[Vec<f64>; 3]>)>,
    pub factors: BTreeMap<String, FactorRecord>,
}

/// A damaged `[calibration]`: the key (e.g. `calibration.structure[1].replicates`) and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("key `{key}`: {reason}")]
pub struct CalibrationDamage {
    pub key: String,
    pub reason: String,
}

fn damaged(key: impl Into<String>, reason: impl Into<String>) -> CalibrationDamage {
    CalibrationDamage {
        key: key.into(),
        reason: reason.into(),
    }
}

impl CalibrationRecord {
    /// Check every key: a level in (0, 1), the three families each with a known outcome and a
    /// finite factor ≥ 1 (exactly 1 for `too-few`), at least one structure, the first of them
    /// `point_set` (the file's own), and each structure's replicates against its set. The error names
    /// the key.
    pub fn check(&self, point_set: &str) -> Result<CheckedCalibration, CalibrationDamage> {
        check_level(self.level)?;
        check_factors(&self.factors)?;
        if let Some(o) = &self.out_of_kind {
            o.check()?;
        }
        if self.structures.is_empty() {
            return Err(damaged("calibration.structure", "no structure"));
        }
        let mut structures = Vec::with_capacity(self.structures.len());
        for (i, s) in self.structures.iter().enumerate() {
            let key = format!("calibration.structure[{i}]");
            let set = CoefficientSet::from_file(s.set.clone())
                .map_err(|e| damaged(format!("{key}.set"), e.to_string()))?;
            if i == 0 && set.name != point_set {
                return Err(damaged(
                    format!("{key}.set.name"),
                    format!(
                        "`{}`: the first structure must be the model's own set `{point_set}`",
                        set.name
                    ),
                ));
            }
            let vectors = replicate_vectors(&s.replicates, &set)
                .map_err(|e| damaged(format!("{key}.replicates"), e))?;
            if vectors.is_empty() {
                return Err(damaged(format!("{key}.replicates"), "no replicates"));
            }
            structures.push((set, vectors));
        }
        Ok(CheckedCalibration {
            structures,
            factors: self.factors.clone(),
        })
    }
}

fn check_level(level: f64) -> Result<(), CalibrationDamage> {
    if !(level > 0.0 && level < 1.0) {
        return Err(damaged(
            "calibration.level",
            format!("{level} is not strictly between 0 and 1"),
        ));
    }
    Ok(())
}

/// The three families each with a known outcome and a finite factor ≥ 1 (exactly 1 for
/// `too-few`), and no other key.
fn check_factors(factors: &BTreeMap<String, FactorRecord>) -> Result<(), CalibrationDamage> {
    for family in FAMILIES {
        let key = format!("calibration.factors.{family}");
        let f = factors
            .get(family)
            .ok_or_else(|| damaged(&key, "missing"))?;
        if !OUTCOMES.contains(&f.outcome.as_str()) {
            return Err(damaged(
                format!("{key}.outcome"),
                format!("`{}` is none of {}", f.outcome, OUTCOMES.join(", ")),
            ));
        }
        if !(f.factor.is_finite() && f.factor >= 1.0) {
            return Err(damaged(
                format!("{key}.factor"),
                format!("{} is not a finite factor of at least 1", f.factor),
            ));
        }
        if f.outcome == "too-few" && f.factor != 1.0 {
            return Err(damaged(
                format!("{key}.factor"),
                format!("{} with outcome `too-few`, which inflates by 1", f.factor),
            ));
        }
    }
    if let Some(extra) = factors.keys().find(|k| !FAMILIES.contains(&k.as_str())) {
        return Err(damaged(
            format!("calibration.factors.{extra}"),
            format!("not a metric family ({})", FAMILIES.join(", ")),
        ));
    }
    Ok(())
}

/// `[calibration]` of an mmg or sparse-GP model file (`shipid fit --set mmg --bootstrap N
/// --calibrate`, `shipid fit --estimator sparse-gp --calibrate`): the inflation factors alone. The
/// replicates the factors widen are the file's own (the mmg `[bootstrap]`, the GP's posterior
/// draws), so none are stored twice.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FactorCalibrationRecord {
    /// The method in words.
    pub method: String,
    /// Nominal level the factors were obtained at (the bands they widen must be at this level).
    pub level: f64,
    /// Seed of the replicates of every refit (bootstrap draws or posterior draws).
    pub seed: u64,
    /// Training recordings left out in turn (0: a single recording, in-sample errors only).
    pub folds: usize,
    /// Replicates (bootstrap replicates or posterior draws) of every refit.
    pub replicates: usize,
    /// Inflation factor per metric family (`overshoot`, `zigzag-time`, `turning-length`).
    pub factors: BTreeMap<String, FactorRecord>,
    /// As [`CalibrationRecord::out_of_kind`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub out_of_kind: Option<OutOfKindRecord>,
}

impl FactorCalibrationRecord {
    /// Check every key as [`CalibrationRecord::check`] checks the level, the factors and the
    /// out-of-kind term; the error names the key.
    pub fn check(&self) -> Result<(), CalibrationDamage> {
        check_level(self.level)?;
        check_factors(&self.factors)?;
        self.out_of_kind
            .as_ref()
            .map_or(Ok(()), OutOfKindRecord::check)
    }
}

/// Replicate values per DOF and coefficient (as `[bootstrap].replicates`) as coefficient vectors in
/// the set's term order, checked against the set: every term present, equal lengths, finite values,
/// no foreign names.
pub fn replicate_vectors(
    replicates: &BTreeMap<String, BTreeMap<String, Vec<f64>>>,
    set: &CoefficientSet,
) -> Result<Vec<[Vec<f64>; 3]>, String> {
    let mut count: Option<usize> = None;
    let mut per_dof: [Vec<&Vec<f64>>; 3] = Default::default();
    for d in Dof::ALL {
        let given = replicates.get(d.as_str());
        for name in set.names(d) {
            let values = given
                .and_then(|g| g.get(&name))
                .ok_or_else(|| format!("no replicates of {name}"))?;
            match count {
                None => count = Some(values.len()),
                Some(n) if n != values.len() => {
                    return Err(format!(
                        "{name} has {} replicates, other coefficients {n}",
                        values.len()
                    ));
                }
                Some(_) => {}
            }
            if values.iter().any(|v| !v.is_finite()) {
                return Err(format!("a replicate of {name} is not finite"));
            }
            per_dof[d.index()].push(values);
        }
        if let Some(g) = given
            && let Some(extra) = g.keys().find(|k| !set.names(d).contains(k))
        {
            return Err(format!("{extra} is not a term of the set"));
        }
    }
    if let Some(extra) = replicates
        .keys()
        .find(|k| !Dof::ALL.iter().any(|d| d.as_str() == k.as_str()))
    {
        return Err(format!("{extra} is not a degree of freedom (X, Y, N)"));
    }
    let n = count.unwrap_or(0);
    Ok((0..n)
        .map(|k| Dof::ALL.map(|d| per_dof[d.index()].iter().map(|v| v[k]).collect()))
        .collect())
}
