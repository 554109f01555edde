//! The one loader of model files, used by every command: `mmg:kvlcc2` (the reference), a model file
//! written by `shipid fit` (`kind = "abkowitz"` or `"sparse-gp"`), or an augmented model file
//! (`base = …` plus `[[effects]]`) written by `shipid diagnose`.
//!
//! Paths a model file stores (`training[*].dataset`, `base`) are written relative to the file that names
//! them (absolute only when there is no relative path, e.g. another drive) and resolved relative to it
//! on load, never against the working directory, so a model means the same wherever it is used from.
//! Beside each path the file keeps a fingerprint of what it named (`dataset_hash`, `base_hash`):
//! a changed base is refused here; what a changed or missing training data set means is up to the
//! command ([`crate::range::training_source`]).

use std::path::{Component, Path, PathBuf};

use shipid_io::{InputError, Ship};
use shipid_model::{AugmentedModelFile, EffectEntry, ModelFile, TrainingWindow};
use shipid_sim::{
    AbkowitzDynamics, Dynamics, Effect, GP_KIND, GpDynamics, GpModelFile, MmgModel, WithEffects,
};

use crate::error::{PipelineError, bad_input};
pub use crate::toml_text::toml_error;

/// The model kinds a model file may declare in `kind` (an augmented file has `base` instead).
pub const MODEL_KINDS: [&str; 3] = ["abkowitz", GP_KIND, crate::mmg::file::MMG_KIND];

/// How deep augmented files may wrap each other; deeper is surely a mistake (a loop is caught anyway).
const MAX_BASE_DEPTH: usize = 8;

/// A model named on the command line: `mmg:kvlcc2` (the reference), a model file written by `shipid fit`,
/// or an augmented model file (`base = …` plus effects) written by `shipid diagnose`. Effects in the
/// file are applied around the model, so every simulation includes them.
pub fn load_model(spec: &str) -> Result<Box<dyn Dynamics + Send + Sync>, PipelineError> {
    let (base, effects) = load_model_parts(spec)?;
    if effects.is_empty() {
        return Ok(base);
    }
    let wrapped =
        WithEffects::new(base, &effects).map_err(|e| bad_input(format!("{spec}: effects: {e}")))?;
    Ok(Box::new(wrapped))
}

/// The model without its effects, and its effects (see [`load_model`]).
pub fn load_model_parts(
    spec: &str,
) -> Result<(Box<dyn Dynamics + Send + Sync>, Vec<Effect>), PipelineError> {
    load_parts(spec, &mut Vec::new())
}

fn parse_entries(path: &Path, entries: &[EffectEntry]) -> Result<Vec<Effect>, PipelineError> {
    entries
        .iter()
        .enumerate()
        .map(|(i, e)| {
            let at = |why: String| {
                bad_input(format!(
                    "{}: key `effects[{i}].effect`: {why}",
                    path.display()
                ))
            };
            let effect = e
                .effect
                .parse::<Effect>()
                .map_err(|err| at(err.to_string()))?;
            // The bounds `--wind`, `--current` and `generate --effect` hold a flow to: an edited
            // current of 1e9 m/s was simulated until it "diverged", the edit read as the model's failure.
            let (kind, speed, max) = match &effect {
                Effect::Current(c) => (
                    "current",
                    c.speed_m_s,
                    crate::generate::MAX_RECORDED_CURRENT_M_S,
                ),
                Effect::Wind(w) => ("wind", w.speed_m_s, crate::generate::MAX_RECORDED_WIND_M_S),
                _ => return Ok(effect),
            };
            if speed > max {
                return Err(at(format!(
                    "{kind}: speed = {} m/s is beyond the {max} m/s a recorded {kind} may have",
                    shipid_io::error::number(speed)
                )));
            }
            Ok(effect)
        })
        .collect()
}

/// The base an augmented model file names: `mmg:…` as written, or the path of its model file resolved
/// relative to `path` (the file that names it), checked against the stored `base_hash`. `chain` holds
/// the files already on the way (a base that is one of them is a loop).
pub fn resolve_base(
    path: &Path,
    file: &AugmentedModelFile,
    chain: &[PathBuf],
) -> Result<String, PipelineError> {
    if file.base.starts_with("mmg:") {
        return Ok(file.base.clone());
    }
    let resolved = resolve_stored(path, &file.base);
    if !resolved.is_file() {
        return Err(InputError::key(
            path,
            "base",
            format!(
                "`{}` is not a model file (paths are relative to the file that names them: {})",
                file.base,
                resolved.display()
            ),
        )
        .into());
    }
    let me = absolute_path(&resolved);
    if chain.contains(&me) || me == absolute_path(path) {
        let names: Vec<String> = chain
            .iter()
            .chain([&absolute_path(path), &me])
            .map(|p| p.display().to_string())
            .collect();
        return Err(InputError::key(
            path,
            "base",
            format!("the chain of base models loops: {}", names.join(" → ")),
        )
        .into());
    }
    if chain.len() >= MAX_BASE_DEPTH {
        return Err(InputError::key(
            path,
            "base",
            format!("more than {MAX_BASE_DEPTH} augmented model files wrap each other"),
        )
        .into());
    }
    if let Some(stored) = &file.base_hash {
        let found = files_hash(&[&resolved])?;
        if &found != stored {
            return Err(InputError::key(
                path,
                "base_hash",
                format!(
                    "{stored}, but the base {} now hashes to {found}: the base model changed since \
                     the effects were fitted to it; diagnose the new base again, or delete `base_hash` \
                     to use the changed base anyway",
                    resolved.display()
                ),
            )
            .into());
        }
    }
    Ok(resolved.display().to_string())
}

fn load_parts(
    spec: &str,
    chain: &mut Vec<PathBuf>,
) -> Result<(Box<dyn Dynamics + Send + Sync>, Vec<Effect>), PipelineError> {
    if spec == "mmg:kvlcc2" {
        return Ok((Box::new(MmgModel::kvlcc2()), Vec::new()));
    }
    let path = Path::new(spec);
    if !spec.starts_with("mmg:") && !path.exists() {
        return Err(bad_input(format!(
            "model file `{spec}` not found (a model is `mmg:kvlcc2` or a model file written by `shipid fit`)"
        )));
    }
    if spec.starts_with("mmg:") || !path.is_file() {
        return Err(bad_input(format!(
            "unknown model `{spec}`: expected `mmg:kvlcc2` or a model file"
        )));
    }
    let text = std::fs::read_to_string(path).map_err(|e| InputError::read(path, &e))?;
    let table = toml::from_str::<toml::Table>(&text).ok();
    if table.as_ref().is_some_and(|t| t.contains_key("base")) {
        let file: AugmentedModelFile =
            toml::from_str(&text).map_err(|e| toml_error(path, &text, &e))?;
        if let Some((key, msg)) = version_fault(&file.shipid_version) {
            return Err(InputError::key(path, &key, msg).into());
        }
        let base_spec = resolve_base(path, &file, chain)?;
        chain.push(absolute_path(path));
        let (base, mut effects) = load_parts(&base_spec, chain)?;
        for e in parse_entries(path, &file.effects)? {
            effects.retain(|x| x.kind() != e.kind());
            effects.push(e);
        }
        return Ok((base, effects));
    }
    check_kind(path, table.as_ref())?;
    check_kind_matches_tables(path, table.as_ref())?;
    // The mmg and sparse-GP formats have no `[environment]` (what a fit in a recorded wind
    // appends, read apart by `environment::model_environment`); the polynomial's has.
    let family_text = crate::environment::without_environment_table(&text);
    // A model file's `[ship]` gets the data set's checks: a negative length or a zero speed came out
    // as "--duration must be positive" from an option the user never gave.
    if let Some(mmg) = crate::mmg::file::load_mmg_model_if_kind(path, &family_text)? {
        shipid_io::dataset::check_ship(path, mmg.ship())?;
        shipid_io::dataset::check_added_mass(path, mmg.added_mass(), mmg.ship())?;
        return Ok((Box::new(mmg), Vec::new()));
    }
    if let Some(gp) = load_gp_model(path, &family_text)? {
        return Ok((Box::new(gp), Vec::new()));
    }
    let file: ModelFile = toml::from_str(&text).map_err(|e| toml_error(path, &text, &e))?;
    shipid_io::dataset::check_ship(path, &file.ship)?;
    shipid_io::dataset::check_added_mass(path, &file.added_mass, &file.ship)?;
    if let Some((key, msg)) = polynomial_file_fault(&file) {
        return Err(InputError::key(path, &key, msg).into());
    }
    let model = file
        .to_model()
        .map_err(|e| bad_input(format!("{}: {e}", path.display())))?;
    // The optional tables are checked whichever command reads the file, not only under `--bands`.
    if let Some(record) = &file.bootstrap {
        record
            .coefficient_vectors(&model.set)
            .map_err(|e| InputError::key(path, "bootstrap", e.to_string()))?;
    }
    if let Some(record) = &file.calibration {
        let checked = record
            .check(&file.set.name)
            .map_err(|e| InputError::key(path, &e.key, e.reason))?;
        crate::metric_family::check_factor_cap(path, &checked.factors)?;
    }
    let effects = parse_entries(path, &file.effects)?;
    Ok((Box::new(AbkowitzDynamics(model)), effects))
}

/// A `kind` the loader does not know is refused: read as a polynomial it would simulate some other
/// model without a word.
fn check_kind(path: &Path, table: Option<&toml::Table>) -> Result<(), PipelineError> {
    let Some(table) = table else {
        // Not TOML: the full reader names the fault.
        return Ok(());
    };
    let Some(kind) = table.get("kind") else {
        return missing_kind(path, table);
    };
    match kind.as_str() {
        Some(k) if MODEL_KINDS.contains(&k) => Ok(()),
        _ => Err(InputError::key(
            path,
            "kind",
            format!(
                "unknown model kind {kind}: expected one of {} (an augmented model file has `base` instead)",
                MODEL_KINDS
                    .iter()
                    .map(|k| format!("\"{k}\""))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        )
        .into()),
    }
}

/// A file without `kind` is read as a polynomial (files before `kind` existed were all polynomials):
/// one whose tables are another kind's is refused naming `kind`. Read as a polynomial, an mmg file
/// with its `kind` line deleted failed on "unknown field `estimator.determined_share`", a valid key.
fn missing_kind(path: &Path, table: &toml::Table) -> Result<(), PipelineError> {
    let found = |keys: &[&str]| -> Vec<String> {
        keys.iter()
            .filter(|k| table.contains_key(**k))
            .map(|k| format!("`{k}`"))
            .collect()
    };
    let Some((kind, tables)) = KIND_TABLES
        .iter()
        .filter(|(k, _)| *k != "abkowitz")
        .map(|(k, keys)| (k, found(keys)))
        .find(|(_, f)| !f.is_empty())
    else {
        return Ok(());
    };
    Err(InputError::key(
        path,
        "kind",
        format!(
            "missing: the file holds {}, the tables of a model of kind \"{kind}\": add `kind = \"{kind}\"` at the top (as `shipid fit` writes it)",
            tables.join(", ")
        ),
    )
    .into())
}

/// The top-level keys only one kind of model file has, by kind: what a file "looks like".
const KIND_TABLES: [(&str, &[&str]); 3] = [
    ("abkowitz", &["set", "coefficients"]),
    (GP_KIND, &["points", "outputs", "sparsification", "inputs"]),
    (
        crate::mmg::file::MMG_KIND,
        &["parameter", "propeller", "rudder"],
    ),
];

/// A `kind` that does not match the file's tables is refused, naming `kind` and the kind the tables
/// belong to: read with the declared kind's reader, an abkowitz file marked `mmg` failed on
/// "unknown field `coefficients`", which points at the wrong key.
fn check_kind_matches_tables(
    path: &Path,
    table: Option<&toml::Table>,
) -> Result<(), PipelineError> {
    let Some(table) = table else { return Ok(()) };
    let Some(declared) = table.get("kind").and_then(|k| k.as_str()) else {
        return Ok(());
    };
    let has = |keys: &[&str]| -> Vec<String> {
        keys.iter()
            .filter(|k| table.contains_key(**k))
            .map(|k| format!("`{k}`"))
            .collect()
    };
    let own = KIND_TABLES
        .iter()
        .find(|(k, _)| *k == declared)
        .map_or(Vec::new(), |(_, keys)| has(keys));
    if !own.is_empty() {
        return Ok(());
    }
    match KIND_TABLES
        .iter()
        .filter(|(k, _)| *k != declared)
        .map(|(k, keys)| (k, has(keys)))
        .find(|(_, found)| !found.is_empty())
    {
        Some((other, found)) => Err(InputError::key(
            path,
            "kind",
            format!(
                "is \"{declared}\", but the file looks like a model file of kind \"{other}\": it holds \
                 {} and none of the tables of kind \"{declared}\"; was `kind` edited? A model file's \
                 kind is the one `shipid fit` wrote",
                found.join(", ")
            ),
        )
        .into()),
        None => Ok(()),
    }
}

/// `shipid_version` when it is not a version (see [`crate::mmg::file::is_version`]), as (key,
/// message): the newer-version warning cannot compare it, so `"banana"` was read without a word.
pub fn version_fault(version: &str) -> Option<(String, String)> {
    (!crate::mmg::file::is_version(version)).then(|| {
        (
            "shipid_version".into(),
            format!(
                "\"{version}\" is not a version (MAJOR.MINOR.PATCH, as `shipid fit` writes it)"
            ),
        )
    })
}

/// The largest |value| of a polynomial model file's prime coefficient. A fitted one is of order
/// 1e-3 to 1 (forces ÷ ½ρL²U0², a cubic's too); 1e6 is far past any fit and still short of where
/// a manoeuvre's sums overflow: `N_vvv = 1e308` ran to NaN accelerations at 5 s and read as a
/// diverging model.
pub const MAX_PRIME_COEFFICIENT: f64 = 1e6;

/// The first fault (key, message) of a polynomial model file that its model's own checks do not
/// name: the version, the coefficients' magnitudes, a shipped set's name over other terms, the
/// estimator's hyper-parameters and the training windows. The ship must be checked.
pub fn polynomial_file_fault(file: &ModelFile) -> Option<(String, String)> {
    use shipid_io::error::number;
    if let Some(fault) = version_fault(&file.shipid_version) {
        return Some(fault);
    }
    for (dof, per) in &file.coefficients {
        for (name, &v) in per {
            if !(v.is_finite() && v.abs() <= MAX_PRIME_COEFFICIENT) {
                return Some((
                    format!("coefficients.{dof}.{name}"),
                    format!(
                        "{} is not a prime coefficient of at most {MAX_PRIME_COEFFICIENT:e} in \
                         magnitude: fitted ones are of order 1e-3 to 1; a damaged number or a unit slip",
                        number(v)
                    ),
                ));
            }
        }
    }
    if let Some(fault) = shipped_set_fault(&file.set) {
        return Some(fault);
    }
    for (name, &v) in &file.estimator.hyper {
        let max = shipid_estimators::MAX_HYPER_PARAMETER;
        if !(v.is_finite() && (0.0..=max).contains(&v)) {
            return Some((
                format!("estimator.hyper.{name}"),
                format!(
                    "must be a hyper-parameter in [0, {}] (as `shipid fit` takes it), not {}",
                    number(max),
                    number(v)
                ),
            ));
        }
    }
    shipid_model::training_fault(&file.training)
}

/// A set named as a shipped set but holding other terms: reports, studies and the calibration's
/// out-of-kind rows go by the name, so a reduced32 fit renamed `full68` was reported as full68.
fn shipped_set_fault(set: &shipid_model::SetFile) -> Option<(String, String)> {
    let text = shipid_model::CoefficientSet::builtin_text(&set.name)?;
    let shipped: shipid_model::SetFile = toml::from_str(text).ok()?;
    let sorted = |terms: &[String]| {
        let mut t = terms.to_vec();
        t.sort();
        t
    };
    let dofs = [
        ("X", &set.x, &shipped.x),
        ("Y", &set.y, &shipped.y),
        ("N", &set.n, &shipped.n),
    ];
    let (dof, own, theirs) = dofs
        .into_iter()
        .find(|(_, own, theirs)| sorted(&own.terms) != sorted(&theirs.terms))?;
    Some((
        "set.name".into(),
        format!(
            "is the shipped set \"{}\", but the file's {dof} terms are not that set's ({} terms, \
             the shipped set has {}): the set was renamed or its terms edited; a set of your own \
             needs a name of its own",
            set.name,
            own.terms.len(),
            theirs.terms.len()
        ),
    ))
}

/// A warning for a model file written by a newer shipid than this one (`shipid_version` above this
/// build's version): it may mean something this version reads otherwise. `None` for an equal or
/// older version, or one that is not a version (the full reader names a missing key).
pub fn newer_version_note(spec: &str) -> Option<String> {
    let path = Path::new(spec);
    if !path.is_file() {
        return None;
    }
    let text = std::fs::read_to_string(path).ok()?;
    let table = toml::from_str::<toml::Table>(&text).ok()?;
    let written = table.get("shipid_version")?.as_str()?;
    let this = env!("CARGO_PKG_VERSION");
    let parse = |v: &str| -> Option<Vec<u64>> {
        v.trim()
            .split(['-', '+'])
            .next()?
            .split('.')
            .map(|p| p.parse().ok())
            .collect()
    };
    (parse(written)? > parse(this)?).then(|| {
        format!(
            "{spec}: written by shipid {written} (key `shipid_version`), newer than this shipid {this}: \
             a newer version may store what this one reads otherwise; use shipid {written} or later"
        )
    })
}

/// A path as stored in a file at `file`: relative to the file's folder, or absolute when there is no
/// relative path (another drive).
pub fn stored_path(file: &Path, target: &Path) -> String {
    // The target's own name stays as given: a data set read through a symbolic link reads its
    // recordings beside the link, and a path to the link's target named training data the fit
    // never saw (its folders' links are resolved, so `sub/../a` and a linked folder still compare).
    let target = match (target.parent(), target.file_name()) {
        (Some(dir), Some(name)) => absolute_path(if dir.as_os_str().is_empty() {
            Path::new(".")
        } else {
            dir
        })
        .join(name),
        _ => absolute_path(target),
    };
    let dir = absolute_path(file)
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default();
    relative_path(&dir, &target)
        .unwrap_or(target)
        .display()
        .to_string()
}

/// A path stored in the file at `file`, resolved relative to that file's folder (an absolute path
/// stays as it is).
pub fn resolve_stored(file: &Path, stored: &str) -> PathBuf {
    match file.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir.join(stored),
        _ => PathBuf::from(stored),
    }
}

/// `path` made absolute with symbolic links resolved as far as it exists (the rest appended with `.`
/// and `..` removed), so two spellings of one file compare equal and relative paths between them hold
/// for the file system, not only for the spelling.
pub fn absolute_path(path: &Path) -> PathBuf {
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut existing = abs.as_path();
    let mut rest = Vec::new();
    loop {
        if let Ok(c) = existing.canonicalize() {
            let mut out = c;
            for part in rest.iter().rev() {
                match part {
                    Component::ParentDir => {
                        out.pop();
                    }
                    Component::CurDir => {}
                    other => out.push(other.as_os_str()),
                }
            }
            return out;
        }
        match (existing.parent(), existing.components().next_back()) {
            (Some(parent), Some(last)) => {
                rest.push(last);
                existing = parent;
            }
            _ => return abs,
        }
    }
}

/// The path from the folder `from_dir` to `to`, both absolute and normalised; `None` when they share
/// no root (another drive).
fn relative_path(from_dir: &Path, to: &Path) -> Option<PathBuf> {
    let a: Vec<Component> = from_dir.components().collect();
    let b: Vec<Component> = to.components().collect();
    if a.first() != b.first() {
        return None;
    }
    let common = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let mut out = PathBuf::new();
    for _ in common..a.len() {
        out.push("..");
    }
    for c in &b[common..] {
        out.push(c.as_os_str());
    }
    Some(out)
}

/// The training windows of a model file about to be written at `model_path`: each `dataset` (as a fit
/// records it, absolute) made relative to the model file.
pub fn anchor_training(windows: &mut [TrainingWindow], model_path: &Path) {
    for w in windows {
        w.dataset = stored_path(model_path, Path::new(&w.dataset));
    }
}

/// Training windows copied from the model file `from` into a file written at `to`: each `dataset`,
/// relative to `from`, made relative to `to` (the fingerprints still hold: the data did not move).
pub fn reanchor_training(windows: &mut [TrainingWindow], from: &Path, to: &Path) {
    for w in windows {
        w.dataset = stored_path(to, &resolve_stored(from, &w.dataset));
    }
}

/// FNV-1a, 64 bits, continued from `hash`: a fingerprint to notice that a file named by a model file
/// changed since the model was written (not a defence against deliberate forgery).
fn fnv1a64(mut hash: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        hash ^= u64::from(b);
        hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
    }
    hash
}

/// The fingerprint of files read in order, `fnv1a64:` + 16 hex digits. Each file's length goes in
/// before its bytes, so moving bytes from one file to the next changes it.
pub fn files_hash(paths: &[&Path]) -> Result<String, PipelineError> {
    let mut hash = 0xcbf2_9ce4_8422_2325_u64;
    for p in paths {
        let bytes = std::fs::read(p).map_err(|e| InputError::read(p, &e))?;
        hash = fnv1a64(hash, &(bytes.len() as u64).to_le_bytes());
        hash = fnv1a64(hash, &bytes);
    }
    Ok(format!("fnv1a64:{hash:016x}"))
}

/// The `dataset_hash` of a training window: its data set file, then its recording (found beside the
/// data set, as the data set's reader finds it).
pub fn training_hash(dataset: &Path, recording: &str) -> Result<String, PipelineError> {
    let csv = resolve_stored(dataset, recording);
    files_hash(&[dataset, &csv])
}

/// A model made for another ship than the recordings': the lengths differ by more than 0.1 %.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShipMismatch {
    pub model_lpp_m: f64,
    pub dataset_lpp_m: f64,
}

impl std::fmt::Display for ShipMismatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the model is of a ship with L = {} m, the data set's ship has L = {} m (another ship, or another scale)",
            self.model_lpp_m, self.dataset_lpp_m
        )
    }
}

/// Whether a model of `model` may be compared with recordings of `data` (see [`ShipMismatch`]).
pub fn ship_mismatch(model: &Ship, data: &Ship) -> Option<ShipMismatch> {
    let same = (model.lpp - data.lpp).abs() <= 1e-3 * model.lpp.abs().max(data.lpp.abs());
    (!same).then_some(ShipMismatch {
        model_lpp_m: model.lpp,
        dataset_lpp_m: data.lpp,
    })
}

/// The ship particulars other than the length in which a model and a data set differ by more than
/// 2 % (U0 by 1 %, x_G by 0.2 % of L), each as "u0 0.9 m/s in the model, 1.179 m/s in the data set".
/// The length is [`ship_mismatch`]'s; these make another ship too (a different speed or mass scales
/// every prime force), and comparing them would blame the difference on the model or on an effect.
pub fn ship_differences(model: &Ship, data: &Ship) -> Vec<String> {
    // Geometry within 2 %: two descriptions of one hull (a report's rounded draft, the reference
    // model's 0.46 m for HSVA's 0.455 m) are one ship; a speed 1 % off is another test condition.
    let relative = [
        ("beam", model.beam, data.beam, "m", 0.02),
        ("draft", model.draft, data.draft, "m", 0.02),
        (
            "displacement",
            model.displacement,
            data.displacement,
            "m³",
            0.02,
        ),
        ("rho", model.rho, data.rho, "kg/m³", 0.02),
        ("kzz", model.kzz, data.kzz, "m", 0.02),
        ("u0", model.u0, data.u0, "m/s", 0.01),
        (
            "rudder_rate",
            model.rudder_rate,
            data.rudder_rate,
            "deg/s",
            0.02,
        ),
    ];
    let mut out: Vec<String> = relative
        .into_iter()
        .filter(|(_, m, d, _, tol)| (m - d).abs() > tol * m.abs().max(d.abs()))
        .map(|(key, m, d, unit, _)| (key, m, d, unit))
        .map(|(key, m, d, unit)| {
            format!("{key} {m} {unit} in the model, {d} {unit} in the data set")
        })
        .collect();
    if (model.xg - data.xg).abs() > 2e-3 * data.lpp {
        out.push(format!(
            "xg {} m in the model, {} m in the data set",
            model.xg, data.xg
        ));
    }
    out
}

/// The GP model of a model file whose `kind` is `sparse-gp`; `None` for any other kind.
pub fn load_gp_model(path: &Path, text: &str) -> Result<Option<GpDynamics>, PipelineError> {
    #[derive(serde::Deserialize)]
    struct Kind {
        kind: Option<String>,
    }
    // Only the kind is read here; a file that is not TOML gets its error from the full reader.
    let is_gp = toml::from_str::<toml::Table>(text)
        .ok()
        .and_then(|t| t.try_into::<Kind>().ok())
        .and_then(|k| k.kind)
        .is_some_and(|k| k == GP_KIND);
    if !is_gp {
        return Ok(None);
    }
    let file: GpModelFile = toml::from_str(text).map_err(|e| toml_error(path, text, &e))?;
    shipid_io::dataset::check_ship(path, &file.ship)?;
    shipid_io::dataset::check_added_mass(path, &file.added_mass, &file.ship)?;
    if let Some((key, msg)) = gp_file_fault(&file) {
        return Err(InputError::key(path, &key, msg).into());
    }
    GpDynamics::from_file(&file)
        .map(Some)
        .map_err(|e| bad_input(format!("{}: {e}", path.display())))
}

/// How far a sparse point may lie from the ship's own scales: |u|, |v| up to this × U0, |r| up to
/// this × U0/L. Manoeuvres stay within about 1 × (r′ of a tight turn is 0.5–1), so a point beyond
/// 10 × is a unit slip or a damaged number, on which the kernel would put a training sample where
/// no ship goes.
pub const GP_POINT_SCALES: f64 = 10.0;
/// The largest rudder angle [rad] of a sparse point: a quarter turn, past every rudder's stop.
pub const GP_MAX_RUDDER_RAD: f64 = std::f64::consts::FRAC_PI_2;
/// The shortest length scale, as a share of its input's scale (U0, U0, U0/L, 1 rad): shorter, the
/// kernel between two sparse points a millionth of a manoeuvre apart is zero, every point is an
/// island and the model is its constant mean everywhere else.
pub const GP_MIN_LENGTH_SCALE_SHARE: f64 = 1e-6;

/// The first fault (key, message) of a sparse-GP file's numbers that the GP's own checks do not name
/// by key: non-finite or absurd sparse points (each input within its physical range), non-finite
/// targets, hyper-parameters out of their domain, calibration factors. The ship must be checked.
pub fn gp_file_fault(file: &GpModelFile) -> Option<(String, String)> {
    use shipid_io::error::number;
    if let Some(fault) = version_fault(&file.shipid_version) {
        return Some(fault);
    }
    if let Some(fault) = shipid_model::training_fault(&file.training) {
        return Some(fault);
    }
    let ship = &file.ship;
    let input_scale = [ship.u0, ship.u0, ship.u0 / ship.lpp, 1.0];
    let limits = [
        (GP_POINT_SCALES * ship.u0, "m/s", "10 × U0"),
        (GP_POINT_SCALES * ship.u0, "m/s", "10 × U0"),
        (GP_POINT_SCALES * ship.u0 / ship.lpp, "rad/s", "10 × U0/L"),
        (GP_MAX_RUDDER_RAD, "rad", "π/2"),
    ];
    // The shapes first: a short row or a deleted point otherwise surfaced as a length mismatch of
    // the GP library, numbers reversed and blamed on `targets`.
    let dims = shipid_sim::gp::GP_INPUTS.len();
    if let Some((i, row)) = file
        .points
        .iter()
        .enumerate()
        .find(|(_, r)| r.len() != dims)
    {
        return Some((
            format!("points[{i}]"),
            format!(
                "has {} numbers; every sparse point has one per input ({dims}: {})",
                row.len(),
                shipid_sim::gp::GP_INPUTS.join(", ")
            ),
        ));
    }
    for (k, o) in file.outputs.iter().enumerate() {
        if o.targets.len() != file.points.len() {
            return Some((
                format!("outputs[{k}].targets"),
                format!(
                    "has {} values of {} but `points` has {} rows: each sparse point has one target per output",
                    o.targets.len(),
                    o.name,
                    file.points.len()
                ),
            ));
        }
    }
    for (k, o) in file.outputs.iter().enumerate() {
        if o.hyper.length_scales.len() != dims {
            return Some((
                format!("outputs[{k}].hyper.length_scales"),
                format!(
                    "has {} values; the kernel has one length scale per input ({dims})",
                    o.hyper.length_scales.len()
                ),
            ));
        }
    }
    if file.sparsification.scales.len() != dims {
        return Some((
            "sparsification.scales".into(),
            format!(
                "has {} values; the similarity has one scale per input ({dims})",
                file.sparsification.scales.len()
            ),
        ));
    }
    if file.sparsification.kept != file.points.len() {
        return Some((
            "sparsification.kept".into(),
            format!(
                "is {} but the file holds {} sparse points: the file contradicts itself (edited or damaged)",
                file.sparsification.kept,
                file.points.len()
            ),
        ));
    }
    for (i, row) in file.points.iter().enumerate() {
        for (j, &v) in row.iter().enumerate() {
            let key = format!("points[{i}][{j}]");
            if !v.is_finite() {
                return Some((key, format!("must be a finite number, not {v}")));
            }
            if let Some(&(limit, unit, what)) = limits.get(j)
                && v.abs() > limit
            {
                return Some((
                    key,
                    format!(
                        "{} {unit} is beyond {what} = {limit:.4} {unit} for the input {}: a unit \
                         slip or a damaged number",
                        number(v),
                        file.inputs.get(j).map_or("?", String::as_str)
                    ),
                ));
            }
        }
    }
    for (k, o) in file.outputs.iter().enumerate() {
        if let Some((i, v)) = o.targets.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Some((
                format!("outputs[{k}].targets[{i}]"),
                format!("must be a finite number, not {v}"),
            ));
        }
        for (j, &l) in o.hyper.length_scales.iter().enumerate() {
            let key = format!("outputs[{k}].hyper.length_scales[{j}]");
            let floor = GP_MIN_LENGTH_SCALE_SHARE * input_scale.get(j).copied().unwrap_or(1.0);
            if !(l.is_finite() && l >= floor) {
                return Some((
                    key,
                    format!(
                        "{} is not a finite length scale of at least {floor:.3e} (a millionth of the \
                         input's scale): the kernel would tie no two points together",
                        number(l)
                    ),
                ));
            }
        }
        for (name, v) in [
            ("signal_std", o.hyper.signal_std),
            ("noise_std", o.hyper.noise_std),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Some((
                    format!("outputs[{k}].hyper.{name}"),
                    format!("must be a positive number, not {}", number(v)),
                ));
            }
        }
    }
    if let Some(record) = &file.calibration {
        if let Err(e) = record.check() {
            return Some((e.key, e.reason));
        }
        if let Some(fault) = crate::metric_family::factor_cap_fault(
            record.factors.iter().map(|(k, f)| (k, f.factor)),
        ) {
            return Some(fault);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh folder under the system's temporary folder, removed when dropped.
    struct Scratch(PathBuf);

    impl Scratch {
        fn new(name: &str) -> Scratch {
            let dir = std::env::temp_dir()
                .join(format!("shipid-model-file-{}-{name}", std::process::id()));
            let _ = std::fs::remove_dir_all(&dir);
            std::fs::create_dir_all(&dir).unwrap();
            Scratch(dir)
        }

        fn path(&self) -> &Path {
            &self.0
        }
    }

    impl Drop for Scratch {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    fn check_relative(from_dir: &str, to: &str, expected: Option<&str>) {
        assert_eq!(
            relative_path(Path::new(from_dir), Path::new(to)),
            expected.map(PathBuf::from),
            "{from_dir} → {to}"
        );
    }

    #[test]
    fn relative_paths_climb_to_the_common_folder() {
        check_relative("/a/b", "/a/b/c.toml", Some("c.toml"));
        check_relative("/a/b", "/a/d/c.toml", Some("../d/c.toml"));
        check_relative("/x/y/z", "/a/c.toml", Some("../../../a/c.toml"));
        check_relative("/", "/a/c.toml", Some("a/c.toml"));
    }

    #[test]
    fn a_stored_path_resolves_back_to_its_target_from_the_file_that_names_it() {
        let dir = Scratch::new("stored");
        let data = dir.path().join("data/set/dataset.toml");
        std::fs::create_dir_all(data.parent().unwrap()).unwrap();
        std::fs::write(&data, "x").unwrap();
        // The model's folder need not exist yet (fit writes it after).
        let model = dir.path().join("results/run/model.toml");
        let stored = stored_path(&model, &data);
        assert_eq!(stored, "../../data/set/dataset.toml");
        std::fs::create_dir_all(model.parent().unwrap()).unwrap();
        assert_eq!(
            absolute_path(&resolve_stored(&model, &stored)),
            absolute_path(&data)
        );
        // Spelled with `..` and `.`, the same file.
        let odd = dir.path().join("results/./run/../../data/set/dataset.toml");
        assert_eq!(absolute_path(&odd), absolute_path(&data));
    }

    /// Regression: a fit through a linked `dataset.toml` stored the link's target, whose folder
    /// holds other recordings than the ones the fit read beside the link.
    #[cfg(unix)]
    #[test]
    fn a_linked_data_set_is_stored_as_the_link() {
        let dir = Scratch::new("linked");
        let base = dir.path().join("base/dataset.toml");
        let link = dir.path().join("x/dataset.toml");
        std::fs::create_dir_all(base.parent().unwrap()).unwrap();
        std::fs::create_dir_all(link.parent().unwrap()).unwrap();
        std::fs::write(&base, "x").unwrap();
        std::os::unix::fs::symlink(&base, &link).unwrap();
        let model = dir.path().join("m.toml");
        assert_eq!(stored_path(&model, &link), "x/dataset.toml");
        // A linked folder is still resolved: the stored path is the file system's.
        let linked_dir = dir.path().join("y");
        std::os::unix::fs::symlink(dir.path().join("base"), &linked_dir).unwrap();
        assert_eq!(
            stored_path(&model, &linked_dir.join("dataset.toml")),
            "base/dataset.toml"
        );
    }

    #[test]
    fn fnv1a64_matches_the_published_test_vectors() {
        let offset = 0xcbf2_9ce4_8422_2325_u64;
        assert_eq!(fnv1a64(offset, b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a64(offset, b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a64(offset, b"foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn moving_bytes_between_two_files_changes_their_fingerprint() {
        let dir = Scratch::new("hash");
        let (a, b) = (dir.path().join("a"), dir.path().join("b"));
        std::fs::write(&a, "ab").unwrap();
        std::fs::write(&b, "c").unwrap();
        let before = files_hash(&[&a, &b]).unwrap();
        std::fs::write(&a, "a").unwrap();
        std::fs::write(&b, "bc").unwrap();
        assert_ne!(files_hash(&[&a, &b]).unwrap(), before);
    }

    #[test]
    fn lengths_that_differ_by_more_than_a_thousandth_are_another_ship() {
        let ship = |lpp| Ship {
            lpp,
            ..*MmgModel::kvlcc2().ship()
        };
        assert_eq!(ship_mismatch(&ship(7.0), &ship(7.0000001)), None);
        // Regression: a model at U0 0.9 m/s validated on recordings at 1.179 m/s gave no warning.
        let slower = Ship {
            u0: 0.9,
            ..ship(7.0)
        };
        assert_eq!(
            ship_differences(&slower, &ship(7.0)),
            [format!(
                "u0 0.9 m/s in the model, {} m/s in the data set",
                ship(7.0).u0
            )]
        );
        assert!(ship_differences(&ship(7.0), &ship(7.0)).is_empty());
        let m = ship_mismatch(&ship(7.0), &ship(14.0)).unwrap();
        assert!(m.to_string().contains("L = 7 m") && m.to_string().contains("L = 14 m"));
    }
}
