//! TOML errors of the model-file readers, worded for what the file holds. No I/O.

use std::path::Path;

use shipid_io::InputError;

/// A TOML error of a model file's reader, as [`InputError::toml`] gives it, except that an unknown
/// table is named as one: `[foo]` was reported as "key `foo.foo`: unknown field `foo`", a doubled
/// key for what is a table.
pub fn toml_error(path: &Path, text: &str, err: &toml::de::Error) -> InputError {
    let plain = InputError::toml(path, text, err);
    let message = err.message().trim();
    let Some(field) = message
        .strip_prefix("unknown field `")
        .and_then(|m| m.split('`').next())
    else {
        return plain;
    };
    let shipid_io::error::Location::Toml { line, .. } = plain.location else {
        return plain;
    };
    let Some(header) = text.lines().nth(line.saturating_sub(1)).and_then(|l| {
        let l = l.trim();
        l.strip_prefix("[[")
            .and_then(|x| x.split("]]").next())
            .or_else(|| l.strip_prefix('[').and_then(|x| x.split(']').next()))
            .map(str::trim)
    }) else {
        return plain;
    };
    // The header names the unknown field itself (`[foo]`, `[[foo]]`, `[propeller.foo]`), not a
    // table whose key is unknown.
    if header.rsplit('.').next() != Some(field) {
        return plain;
    }
    let expected = message
        .split_once(", expected")
        .map_or(String::new(), |(_, rest)| format!(": expected{rest}"));
    InputError::line(path, line, format!("unknown table `[{header}]`{expected}"))
}
