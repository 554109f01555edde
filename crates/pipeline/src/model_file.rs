//! The one loader of model files, used by every command: `mmg:kvlcc2` (the reference), a model file
//! written by `shipid fit` (`kind = "abkowitz"` or `"sparse-gp"`), or an augmented model file
//! (`base = …` plus `[[effects]]`) written by `shipid diagnose`, whose base is found relative to the
//! file that names it.

use std::path::Path;

use shipid_model::{AugmentedModelFile, EffectEntry, ModelFile};
use shipid_sim::{
    AbkowitzDynamics, Dynamics, Effect, GP_KIND, GpDynamics, GpModelFile, MmgModel, WithEffects,
};

use crate::error::{PipelineError, bad_input};

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
    load_parts(spec, 0)
}

fn parse_entries(path: &Path, entries: &[EffectEntry]) -> Result<Vec<Effect>, PipelineError> {
    entries
        .iter()
        .enumerate()
        .map(|(i, e)| {
            e.effect.parse::<Effect>().map_err(|err| {
                bad_input(format!(
                    "{}: key `effects[{i}].effect`: {err}",
                    path.display()
                ))
            })
        })
        .collect()
}

fn load_parts(
    spec: &str,
    depth: usize,
) -> Result<(Box<dyn Dynamics + Send + Sync>, Vec<Effect>), PipelineError> {
    if spec == "mmg:kvlcc2" {
        return Ok((Box::new(MmgModel::kvlcc2()), Vec::new()));
    }
    let path = Path::new(spec);
    if spec.starts_with("mmg:") || !path.is_file() {
        return Err(bad_input(format!(
            "unknown model `{spec}`: expected `mmg:kvlcc2` or a model file"
        )));
    }
    let text = std::fs::read_to_string(path).map_err(|e| shipid_io::InputError::read(path, &e))?;
    let is_augmented = toml::from_str::<toml::Table>(&text)
        .map(|t| t.contains_key("base"))
        .unwrap_or(false);
    if is_augmented {
        let file: AugmentedModelFile =
            toml::from_str(&text).map_err(|e| shipid_io::InputError::toml(path, &text, &e))?;
        if depth > 4 {
            return Err(bad_input(format!(
                "{}: key `base`: too many nested augmented model files",
                path.display()
            )));
        }
        let base_spec = if file.base.starts_with("mmg:") {
            file.base.clone()
        } else {
            path.parent()
                .unwrap_or(Path::new("."))
                .join(&file.base)
                .display()
                .to_string()
        };
        let (base, mut effects) = load_parts(&base_spec, depth + 1)?;
        for e in parse_entries(path, &file.effects)? {
            effects.retain(|x| x.kind() != e.kind());
            effects.push(e);
        }
        return Ok((base, effects));
    }
    if let Some(gp) = load_gp_model(path, &text)? {
        return Ok((Box::new(gp), Vec::new()));
    }
    let file: ModelFile =
        toml::from_str(&text).map_err(|e| shipid_io::InputError::toml(path, &text, &e))?;
    let model = file
        .to_model()
        .map_err(|e| bad_input(format!("{}: {e}", path.display())))?;
    let effects = parse_entries(path, &file.effects)?;
    Ok((Box::new(AbkowitzDynamics(model)), effects))
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
    let file: GpModelFile =
        toml::from_str(text).map_err(|e| shipid_io::InputError::toml(path, text, &e))?;
    GpDynamics::from_file(&file)
        .map(Some)
        .map_err(|e| bad_input(format!("{}: {e}", path.display())))
}
