//! The model with the effects a diagnosis found: a copy of the base's model file with its
//! `[[effects]]` (a found effect replaces one of the same kind), or, for a base that is not a
//! polynomial model file (the reference, a sparse GP, an augmented file), a file that names the base and
//! lists the effects. No I/O: the caller reads the base and writes the result.

use shipid_model::{AugmentedModelFile, EffectEntry, ModelFile};

use crate::report::Report;

/// The augmented model, by the form it takes.
#[derive(Debug, Clone, PartialEq)]
pub enum AugmentedModel {
    /// The base's own model file with the effects added (boxed: a model file is large).
    Copy(Box<ModelFile>),
    /// A file naming the base and listing the effects.
    Wrapper(AugmentedModelFile),
}

impl Report {
    /// The found effects as model-file entries: each with `source` and its standard errors (with
    /// several effects, the errors keyed `<kind>.<key>` in the report go to their effect's entry).
    pub fn effect_entries(&self, source: &str) -> Vec<EffectEntry> {
        let multi = self.effects.len() > 1;
        // What the standard errors cover goes with them into the model file.
        let source = match &self.standard_error_basis {
            Some(b) if !self.standard_errors.is_empty() => {
                format!("{source}; standard errors: {}", b.sentence())
            }
            _ => source.to_string(),
        };
        self.effects
            .iter()
            .map(|e| {
                let kind = e.split(':').next().unwrap_or("");
                EffectEntry {
                    effect: e.clone(),
                    source: source.clone(),
                    standard_error: self
                        .standard_errors
                        .iter()
                        .filter_map(|(k, v)| match k.split_once('.') {
                            Some((kk, key)) if multi && kk == kind => Some((key.to_string(), *v)),
                            None if !multi => Some((k.clone(), *v)),
                            _ => None,
                        })
                        .collect(),
                }
            })
            .collect()
    }
}

/// The base with `entries` added: `base_file` is the base's polynomial model file when it is one (its
/// training paths already made relative to where the result goes), `base_ref` how a wrapper names the
/// base otherwise (relative to the wrapper) and `base_hash` the fingerprint of the base's file, if it
/// is one, `tool_version` the version that writes it.
pub fn augmented_model(
    base_file: Option<ModelFile>,
    base_ref: String,
    base_hash: Option<String>,
    entries: Vec<EffectEntry>,
    tool_version: &str,
) -> AugmentedModel {
    match base_file {
        Some(mut file) => {
            let kind = |e: &EffectEntry| e.effect.split(':').next().map(str::to_string);
            file.effects
                .retain(|b| !entries.iter().any(|n| kind(n) == kind(b)));
            file.effects.extend(entries);
            AugmentedModel::Copy(Box::new(file))
        }
        None => AugmentedModel::Wrapper(AugmentedModelFile {
            shipid_version: tool_version.into(),
            base: base_ref,
            base_hash,
            effects: entries,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(effect: &str) -> EffectEntry {
        EffectEntry {
            effect: effect.into(),
            source: "test".into(),
            standard_error: Default::default(),
        }
    }

    fn effects_of(m: &AugmentedModel) -> Vec<&str> {
        let list = match m {
            AugmentedModel::Copy(f) => &f.effects,
            AugmentedModel::Wrapper(w) => &w.effects,
        };
        list.iter().map(|e| e.effect.as_str()).collect()
    }

    #[test]
    fn a_found_effect_replaces_one_of_its_kind_in_a_copy_of_the_model_file() {
        let base: ModelFile = toml::from_str(include_str!(
            "../../../results/diagnose/hsva/report.model.toml"
        ))
        .unwrap();
        let m = augmented_model(
            Some(base),
            "unused".into(),
            None,
            vec![
                entry("asymmetry:offset=1,y0=0,n0=0"),
                entry("current:speed=0.1,from=90"),
            ],
            "0",
        );
        assert!(matches!(m, AugmentedModel::Copy(_)));
        assert_eq!(
            effects_of(&m),
            ["asymmetry:offset=1,y0=0,n0=0", "current:speed=0.1,from=90"]
        );
    }

    #[test]
    fn a_base_without_a_polynomial_file_is_named_by_a_wrapper() {
        let m = augmented_model(
            None,
            "mmg:kvlcc2".into(),
            None,
            vec![entry("wind:speed=2,from=0")],
            "9.9",
        );
        match &m {
            AugmentedModel::Wrapper(w) => {
                assert_eq!(
                    (w.base.as_str(), w.shipid_version.as_str()),
                    ("mmg:kvlcc2", "9.9")
                )
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(effects_of(&m), ["wind:speed=2,from=0"]);
    }
}
