//! One error type for everything a user can get wrong in a file: it always names the file, and the line
//! and column (CSV) or the key (TOML) when there is one, so a message is enough to find the mistake.

use std::fmt;
use std::path::{Path, PathBuf};

/// Where in a file the problem is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Location {
    /// The file as a whole (missing, unreadable, too short …).
    File,
    /// A line (1-based) and optionally a column (1-based field number, with its header name).
    Line {
        line: usize,
        column: Option<(usize, String)>,
    },
    /// A TOML position: 1-based line and column of the offending text, and the key when known.
    Toml {
        line: usize,
        column: usize,
        key: Option<String>,
    },
    /// A TOML key path without a position (semantic checks after parsing).
    Key(String),
}

/// A problem with a user's input file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub struct InputError {
    pub file: PathBuf,
    pub location: Location,
    pub message: String,
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let file = self.file.display();
        match &self.location {
            Location::File => write!(f, "{file}: {}", self.message),
            Location::Line { line, column: None } => write!(f, "{file}:{line}: {}", self.message),
            Location::Line {
                line,
                column: Some((col, name)),
            } => write!(f, "{file}:{line}:{col}: column `{name}`: {}", self.message),
            Location::Toml {
                line,
                column,
                key: Some(key),
            } => write!(f, "{file}:{line}:{column}: key `{key}`: {}", self.message),
            Location::Toml {
                line,
                column,
                key: None,
            } => write!(f, "{file}:{line}:{column}: {}", self.message),
            Location::Key(key) => write!(f, "{file}: key `{key}`: {}", self.message),
        }
    }
}

impl InputError {
    pub fn file(file: &Path, message: impl Into<String>) -> Self {
        InputError {
            file: file.to_path_buf(),
            location: Location::File,
            message: message.into(),
        }
    }

    pub fn line(file: &Path, line: usize, message: impl Into<String>) -> Self {
        InputError {
            file: file.to_path_buf(),
            location: Location::Line { line, column: None },
            message: message.into(),
        }
    }

    pub fn cell(
        file: &Path,
        line: usize,
        column: usize,
        name: &str,
        message: impl Into<String>,
    ) -> Self {
        InputError {
            file: file.to_path_buf(),
            location: Location::Line {
                line,
                column: Some((column, name.to_string())),
            },
            message: message.into(),
        }
    }

    pub fn key(file: &Path, key: impl Into<String>, message: impl Into<String>) -> Self {
        InputError {
            file: file.to_path_buf(),
            location: Location::Key(key.into()),
            message: message.into(),
        }
    }

    /// Wrap a TOML deserialisation error, turning its byte span into line and column.
    pub fn toml(file: &Path, text: &str, err: &toml::de::Error) -> Self {
        let message = err.message().trim().to_string();
        let key = backticked(&message);
        match err.span() {
            Some(span) => {
                let (line, column) = line_col(text, span.start);
                // The key with the table it sits in (`ship.lpp`, `recording[2].note`): a bare `lpp`
                // or a line number alone leaves the user to work out which table is meant.
                let key = key.or_else(|| key_on_line(text, line)).map(|k| {
                    match table_path_at(text, line) {
                        // On a table's own header (`[foo]` unknown at the top level) the key is
                        // the table: its name already ends the path.
                        Some(table) if header_names(text, line, &k) => table_key(&table),
                        Some(table) => format!("{table}.{k}"),
                        None => k,
                    }
                });
                InputError {
                    file: file.to_path_buf(),
                    location: Location::Toml { line, column, key },
                    message,
                }
            }
            None => InputError {
                file: file.to_path_buf(),
                location: key.map_or(Location::File, Location::Key),
                message,
            },
        }
    }

    /// Reading the file failed (missing, permissions …).
    pub fn read(file: &Path, err: &std::io::Error) -> Self {
        let message = match err.kind() {
            std::io::ErrorKind::NotFound => "file not found".to_string(),
            _ => format!("cannot read file: {err}"),
        };
        InputError::file(file, message)
    }
}

/// serde names the offending key in backticks ("unknown field `foo`", "missing field `lpp`"); other
/// messages quote values or tokens the same way, so only these forms name a key.
fn backticked(message: &str) -> Option<String> {
    if ![
        "unknown field",
        "missing field",
        "duplicate key",
        "duplicate field",
    ]
    .iter()
    .any(|p| message.starts_with(p))
    {
        return None;
    }
    let start = message.find('`')? + 1;
    let len = message[start..].find('`')?;
    Some(message[start..start + len].to_string())
}

/// The table a 1-based `line` of TOML `text` belongs to, as a key path: `ship` under `[ship]`,
/// `recording[2]` under the third `[[recording]]`; `None` at the top level.
fn table_path_at(text: &str, line: usize) -> Option<String> {
    let mut table: Option<String> = None;
    let mut counts: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
    for l in text.lines().take(line) {
        let l = l.trim();
        if let Some(rest) = l.strip_prefix("[[") {
            let name = rest.split("]]").next()?.trim().to_string();
            let k = counts.entry(name.clone()).or_insert(0);
            table = Some(format!("{name}[{k}]"));
            *k += 1;
        } else if let Some(rest) = l.strip_prefix('[') {
            let name = rest.split(']').next()?.trim();
            // `[recording.sub]` after `[[recording]]` belongs to its latest element.
            table = Some(match name.split_once('.') {
                Some((head, tail)) if counts.contains_key(head) => {
                    format!("{head}[{}].{tail}", counts[head] - 1)
                }
                _ => name.to_string(),
            });
        }
    }
    table
}

/// Whether the 1-based `line` is a table header (`[foo]`, `[ship.foo]`, `[[foo]]`) whose last name
/// is `key`.
fn header_names(text: &str, line: usize, key: &str) -> bool {
    let Some(l) = line.checked_sub(1).and_then(|i| text.lines().nth(i)) else {
        return false;
    };
    let l = l.trim();
    if !l.starts_with('[') {
        return false;
    }
    let name = l.trim_start_matches('[').split(']').next().unwrap_or("");
    name.rsplit('.').next().map(|n| n.trim().trim_matches('"')) == Some(key)
}

/// A table path as a key: `foo[0]` of an unknown `[[foo]]` is the array `foo`.
fn table_key(table: &str) -> String {
    match table.strip_suffix(']').and_then(|t| t.rsplit_once('[')) {
        Some((name, index)) if index.chars().all(|c| c.is_ascii_digit()) => name.to_string(),
        _ => table.to_string(),
    }
}

/// The key assigned on a 1-based `line` (`lpp = "7.0"` → `lpp`), when the line is an assignment.
fn key_on_line(text: &str, line: usize) -> Option<String> {
    let l = text.lines().nth(line.checked_sub(1)?)?.trim();
    if l.starts_with('[') || l.starts_with('#') {
        return None;
    }
    let (key, _) = l.split_once('=')?;
    let key = key.trim().trim_matches('"');
    (!key.is_empty() && !key.contains(char::is_whitespace)).then(|| key.to_string())
}

/// 1-based line and column (in characters) of a byte offset.
pub fn line_col(text: &str, byte: usize) -> (usize, usize) {
    let byte = byte.min(text.len());
    let before = &text[..floor_char_boundary(text, byte)];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    (line, before[line_start..].chars().count() + 1)
}

fn floor_char_boundary(text: &str, mut i: usize) -> usize {
    while i > 0 && !text.is_char_boundary(i) {
        i -= 1;
    }
    i
}

/// A number as a message shows it: as written for ordinary magnitudes, in exponent form when Rust's
/// plain form would spell out hundreds of digits (`1e300`, `1e-300`).
pub fn number(value: f64) -> String {
    let a = value.abs();
    if value.is_finite() && a != 0.0 && !(1e-6..1e15).contains(&a) {
        format!("{value:e}")
    } else {
        format!("{value}")
    }
}
