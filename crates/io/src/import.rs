//! Import of foreign recording layouts through a mapping file (`shipid import MAPPING.toml --out DIR`).
//!
//! A mapping says how to read the source files (delimiter or whitespace, header lines to skip, text
//! encoding), which column holds which quantity in which unit (earth-fixed velocities are turned into
//! body velocities with the heading), the source's rudder sign (converted on import), and the data set
//! header to write. The output is an ordinary data set (`docs/data-format.md`) in the project's rudder convention.
//!
//! ```toml
//! source_dir = "raw/kvlcc2-hsva"                   # relative to the mapping file
//! rudder_sign = -1                                  # source's positive rudder turns to port
//! [format]
//! delimiter = "whitespace"                          # or one character: ",", ";", "\t"
//! skip_lines = 4
//! encoding = "windows-1252"                         # a WHATWG label; default "utf-8"
//! [[column]]
//! index = 1                                         # 1-based
//! quantity = "t"                                    # t x0 y0 psi u v r delta n u_dot v_dot r_dot x0_dot y0_dot,
//!                                                   # wind_speed wind_from (true wind) or relative_wind_speed
//!                                                   # relative_wind_angle (on board), current_speed current_from
//! unit = "s"
//! [dataset]                                         # name, origin, [dataset.ship], [dataset.added_mass]
//! [[recording]]                                     # source, file, kind, rudder, check, side
//! ```

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::dataset::{DatasetFile, Kind, Origin, PropellerTable, RecordingEntry, ReferencePoint};
use crate::error::InputError;
use crate::table::{Columns, parse_cell, with_comma_hint};
use crate::types::{AddedMass, Recording, RudderData, Ship, Side, Windage};
use crate::units::Quantity;

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mapping {
    /// Directory of the source files, relative to the mapping file.
    #[serde(default)]
    pub source_dir: Option<String>,
    /// 1 if the source's positive rudder turns the ship to starboard, −1 if to port.
    #[serde(default = "one")]
    pub rudder_sign: i64,
    pub format: Format,
    #[serde(rename = "column")]
    pub columns: Vec<ColumnMap>,
    pub dataset: DatasetHeader,
    #[serde(rename = "recording")]
    pub recordings: Vec<ImportRecording>,
}

fn one() -> i64 {
    1
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Format {
    /// "whitespace" or a single character.
    #[serde(default = "comma")]
    pub delimiter: String,
    /// Lines to skip before the data (titles, header rows).
    #[serde(default)]
    pub skip_lines: usize,
    /// Text encoding label (WHATWG, e.g. "utf-8", "windows-1252", "latin1").
    #[serde(default = "utf8")]
    pub encoding: String,
}

fn comma() -> String {
    ",".into()
}
fn utf8() -> String {
    "utf-8".into()
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ColumnMap {
    /// 1-based column number in the source.
    pub index: usize,
    pub quantity: String,
    /// Unit of the source column; default the quantity's SI unit.
    #[serde(default)]
    pub unit: Option<String>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DatasetHeader {
    pub name: String,
    #[serde(default)]
    pub origin: Origin,
    #[serde(default)]
    pub reference_point: Option<ReferencePoint>,
    pub ship: Ship,
    #[serde(default)]
    pub added_mass: Option<AddedMass>,
    /// The `[propeller]` table to write; its `open_water` file is read from the source folder and
    /// copied into the output folder under its file name.
    #[serde(default)]
    pub propeller: Option<PropellerTable>,
    #[serde(default)]
    pub rudder: Option<RudderData>,
    /// The `[windage]` table to write (for recordings with wind columns).
    #[serde(default)]
    pub windage: Option<Windage>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImportRecording {
    /// Source file name, relative to `source_dir`.
    pub source: String,
    /// Output CSV name.
    pub file: String,
    pub kind: Kind,
    #[serde(default)]
    pub rudder: Option<f64>,
    #[serde(default)]
    pub check: Option<f64>,
    #[serde(default)]
    pub side: Option<Side>,
}

/// What an import produced.
pub struct Imported {
    pub dataset: DatasetFile,
    pub recordings: Vec<Recording>,
    /// One line per recording saying where it came from.
    pub provenance: Vec<String>,
    /// Other files the data set names (the open-water table): output name and contents.
    pub files: Vec<(String, Vec<u8>)>,
    /// Every file the import read (mapping, sources, open-water table): the output must not overwrite them.
    pub inputs: Vec<PathBuf>,
}

/// Read a mapping file and check it.
pub fn read_mapping(path: &Path) -> Result<Mapping, InputError> {
    let text = crate::recording::read_text(path)?;
    let m: Mapping = toml::from_str(&text).map_err(|e| InputError::toml(path, &text, &e))?;
    if m.rudder_sign != 1 && m.rudder_sign != -1 {
        return Err(InputError::key(
            path,
            "rudder_sign",
            format!("must be 1 or -1, not {}", m.rudder_sign),
        ));
    }
    if m.format.delimiter != "whitespace" && m.format.delimiter.chars().count() != 1 {
        return Err(InputError::key(
            path,
            "format.delimiter",
            format!(
                "must be \"whitespace\" or one character, not \"{}\"",
                m.format.delimiter
            ),
        ));
    }
    if encoding_rs::Encoding::for_label(m.format.encoding.as_bytes()).is_none() {
        return Err(InputError::key(
            path,
            "format.encoding",
            format!("unknown encoding \"{}\"", m.format.encoding),
        ));
    }
    let mut seen = HashMap::new();
    for (i, c) in m.columns.iter().enumerate() {
        let key = |k: &str| format!("column[{i}].{k}");
        if c.index == 0 {
            return Err(InputError::key(
                path,
                key("index"),
                "column numbers start at 1",
            ));
        }
        let q = Quantity::from_name(&c.quantity).ok_or_else(|| {
            InputError::key(
                path,
                key("quantity"),
                format!("unknown quantity \"{}\"", c.quantity),
            )
        })?;
        if let Some(u) = &c.unit
            && q.dimension().to_si(u).is_none()
        {
            return Err(InputError::key(
                path,
                key("unit"),
                format!(
                    "unknown unit \"{u}\" for {} (known: {})",
                    c.quantity,
                    q.dimension().known_units()
                ),
            ));
        }
        if let Some((j, _)) = m.columns[..i]
            .iter()
            .enumerate()
            .find(|(_, o)| o.index == c.index)
        {
            return Err(InputError::key(
                path,
                key("index"),
                format!(
                    "source column {} is already mapped to {} (column[{j}]): one source column is one quantity",
                    c.index, m.columns[j].quantity
                ),
            ));
        }
        if let Some(j) = seen.insert(q, i) {
            return Err(InputError::key(
                path,
                key("quantity"),
                format!("\"{}\" is already mapped by column[{j}]", c.quantity),
            ));
        }
    }
    // The output data set must itself be valid: reuse its checks on a trial file.
    let trial = m.dataset_file(&[]);
    let text = toml::to_string(&trial).map_err(|e| InputError::file(path, e.to_string()))?;
    crate::dataset::parse_dataset(path, &text).map_err(|mut e| {
        if let crate::error::Location::Key(k) = &e.location {
            e.location = crate::error::Location::Key(format!("dataset.{k}"));
        }
        e
    })?;
    for (i, r) in m.recordings.iter().enumerate() {
        let entry = r.entry();
        let t = DatasetFile {
            recordings: vec![entry],
            ..trial.clone()
        };
        let text = toml::to_string(&t).map_err(|e| InputError::file(path, e.to_string()))?;
        crate::dataset::parse_dataset(path, &text).map_err(|mut e| {
            if let crate::error::Location::Key(k) = &e.location {
                e.location = crate::error::Location::Key(k.replacen(
                    "recording[0]",
                    &format!("recording[{i}]"),
                    1,
                ));
            }
            e
        })?;
    }
    check_outputs(path, &m.recordings)?;
    if m.dataset
        .propeller
        .as_ref()
        .is_some_and(|p| p.rate_rps.is_none())
        && !m.columns.iter().any(|c| c.quantity == Quantity::N.name())
    {
        return Err(InputError::key(
            path,
            "dataset.propeller.rate_rps",
            "needed: no column is mapped to `n`, and the model family that uses [propeller] needs the propeller rate (give the constant rate_rps, or map n)",
        ));
    }
    if let Some(f) = m
        .dataset
        .propeller
        .as_ref()
        .and_then(|p| p.open_water.as_deref())
    {
        let name = open_water_output(f);
        let key = crate::write::output_key(&name);
        let clash = m
            .recordings
            .iter()
            .position(|r| crate::write::output_key(&r.file) == key);
        if crate::write::check_output_name(&name).is_err() || clash.is_some() {
            return Err(InputError::key(
                path,
                "dataset.propeller.open_water",
                format!(
                    "`{f}` would be copied to `{name}` in the output folder{}; rename it",
                    clash.map_or(String::new(), |i| format!(", the file of recording[{i}]"))
                ),
            ));
        }
    }
    Ok(m)
}

/// The name the open-water table gets in the output folder: its file name (it is read from the source
/// folder, whose layout the output does not copy).
fn open_water_output(source: &str) -> String {
    Path::new(source)
        .file_name()
        .map_or_else(|| source.to_string(), |n| n.to_string_lossy().into_owned())
}

/// Output names must stay inside `--out` and be distinct (else one recording silently overwrites
/// another); a source imported twice would put one recording in the data set twice.
fn check_outputs(path: &Path, recordings: &[ImportRecording]) -> Result<(), InputError> {
    let mut outputs: HashMap<String, usize> = HashMap::new();
    let mut sources: HashMap<String, usize> = HashMap::new();
    for (i, r) in recordings.iter().enumerate() {
        crate::write::check_output_name(&r.file).map_err(|reason| {
            InputError::key(
                path,
                format!("recording[{i}].file"),
                format!("`{}` {reason}", r.file),
            )
        })?;
        if let Some(j) = outputs.insert(crate::write::output_key(&r.file), i) {
            return Err(InputError::key(
                path,
                format!("recording[{i}].file"),
                format!(
                    "`{}` is the same output file as recording[{j}].file `{}`{}; give each recording its own file",
                    r.file,
                    recordings[j].file,
                    if r.file == recordings[j].file {
                        ""
                    } else {
                        " (names differing only in case are one file on some systems)"
                    }
                ),
            ));
        }
        let source = r
            .source
            .split(['/', '\\'])
            .filter(|c| !c.is_empty() && *c != ".")
            .collect::<Vec<_>>()
            .join("/");
        if let Some(j) = sources.insert(source, i) {
            return Err(InputError::key(
                path,
                format!("recording[{i}].source"),
                format!(
                    "`{}` is already imported by recording[{j}] (as `{}`); import each source once",
                    r.source, recordings[j].file
                ),
            ));
        }
    }
    Ok(())
}

impl ImportRecording {
    fn entry(&self) -> RecordingEntry {
        RecordingEntry {
            file: self.file.clone(),
            kind: self.kind,
            rudder: self.rudder,
            check: self.check,
            side: self.side,
        }
    }
}

impl Mapping {
    /// The data set file the import writes: the header, rudder sign converted, the recordings.
    pub fn dataset_file(&self, recordings: &[RecordingEntry]) -> DatasetFile {
        DatasetFile {
            name: self.dataset.name.clone(),
            origin: self.dataset.origin,
            reference_point: self.dataset.reference_point,
            rudder_sign: 1,
            ship: self.dataset.ship,
            added_mass: self.dataset.added_mass,
            propeller: self.dataset.propeller.clone().map(|mut p| {
                p.open_water = p.open_water.as_deref().map(open_water_output);
                p
            }),
            rudder: self.dataset.rudder,
            windage: self.dataset.windage.clone(),
            recordings: recordings.to_vec(),
        }
    }
}

/// Import every recording of a mapping. `source_dir` overrides the mapping's.
pub fn import(mapping_path: &Path, source_dir: Option<&Path>) -> Result<Imported, InputError> {
    let m = read_mapping(mapping_path)?;
    let base = mapping_path.parent().unwrap_or(Path::new("."));
    let dir: PathBuf = match (source_dir, &m.source_dir) {
        (Some(d), _) => d.to_path_buf(),
        (None, Some(d)) => base.join(d),
        (None, None) => base.to_path_buf(),
    };
    let encoding = encoding_rs::Encoding::for_label(m.format.encoding.as_bytes())
        .unwrap_or(encoding_rs::UTF_8);
    let mut recordings = Vec::new();
    let mut provenance = Vec::new();
    let mut inputs = vec![mapping_path.to_path_buf()];
    for r in &m.recordings {
        let src = dir.join(&r.source);
        let bytes = crate::recording::read_bytes(&src)?;
        inputs.push(src.clone());
        let (text, _, had_errors) = encoding.decode(&bytes);
        if had_errors {
            // The decoder put U+FFFD where the bytes were invalid: its line is the one to fix.
            let line = text
                .find('\u{fffd}')
                .map_or(1, |at| text[..at].matches('\n').count() + 1);
            return Err(InputError::line(
                &src,
                line,
                format!(
                    "not valid {} text (check `format.encoding` in {})",
                    encoding.name(),
                    mapping_path.display()
                ),
            ));
        }
        let mut rec = parse_table(&src, &text, &m)?;
        if m.rudder_sign == -1 {
            rec.delta.iter_mut().for_each(|d| *d = -*d);
        }
        provenance.push(format!("{} <- {}", r.file, src.display()));
        recordings.push(rec);
    }
    let mut files = Vec::new();
    if let Some(f) = m
        .dataset
        .propeller
        .as_ref()
        .and_then(|p| p.open_water.as_deref())
    {
        let src = dir.join(f);
        // Read and fitted now so that a bad table is refused before anything is written.
        crate::open_water::read_open_water(&src, f)?;
        files.push((open_water_output(f), crate::recording::read_bytes(&src)?));
        inputs.push(src);
    }
    let entries: Vec<RecordingEntry> = m.recordings.iter().map(ImportRecording::entry).collect();
    Ok(Imported {
        dataset: m.dataset_file(&entries),
        recordings,
        provenance,
        files,
        inputs,
    })
}

/// Parse one source file's text by the mapping.
pub fn parse_table(path: &Path, text: &str, m: &Mapping) -> Result<Recording, InputError> {
    let mut slots: Vec<(usize, Quantity, f64, String)> = Vec::new();
    for c in &m.columns {
        let q = Quantity::from_name(&c.quantity).unwrap_or(Quantity::T);
        let factor = c
            .unit
            .as_deref()
            .and_then(|u| q.dimension().to_si(u))
            .unwrap_or(1.0);
        let label = format!("{}[{}]", q.name(), c.unit.as_deref().unwrap_or(q.si_unit()));
        slots.push((c.index - 1, q, factor, label));
    }
    let needed = slots.iter().map(|s| s.0 + 1).max().unwrap_or(0);
    let mut values: HashMap<Quantity, Vec<f64>> = slots.iter().map(|s| (s.1, Vec::new())).collect();
    let column_of = slots
        .iter()
        .map(|s| (s.1, (s.0 + 1, s.3.clone())))
        .collect();
    let mut lines = Vec::new();
    // Every data line has as many fields as the first: a blank field in a whitespace-separated file
    // shifts every later field into the wrong quantity (a propeller rate read from the roll column).
    let mut width: Option<(usize, usize)> = None;
    for (i, line) in text.lines().enumerate().skip(m.format.skip_lines) {
        let line_no = i + 1;
        if line.trim().is_empty() {
            continue;
        }
        let fields: Vec<&str> = if m.format.delimiter == "whitespace" {
            line.split_whitespace().collect()
        } else {
            let d = m.format.delimiter.chars().next().unwrap_or(',');
            line.split(d).map(str::trim).collect()
        };
        match width {
            None => width = Some((fields.len(), line_no)),
            Some((n, first)) if fields.len() != n => {
                return Err(InputError::line(
                    path,
                    line_no,
                    format!(
                        "{} fields where line {first} has {n}: a missing value (a blank field{}) would shift the columns after it; fill it or cut the recording",
                        fields.len(),
                        if m.format.delimiter == "whitespace" {
                            ", which whitespace separation cannot see"
                        } else {
                            ""
                        }
                    ),
                ));
            }
            Some(_) => {}
        }
        if fields.len() < needed {
            return Err(InputError::line(
                path,
                line_no,
                format!(
                    "expected at least {needed} fields, found {}{}",
                    fields.len(),
                    delimiter_hint(line, &m.format.delimiter)
                ),
            ));
        }
        for (idx, q, factor, label) in &slots {
            let x = parse_cell(fields[*idx]).map_err(|msg| {
                InputError::cell(
                    path,
                    line_no,
                    idx + 1,
                    label,
                    with_comma_hint(msg, fields[*idx]),
                )
            })?;
            if let Some(col) = values.get_mut(q) {
                col.push(x * factor);
            }
        }
        lines.push(line_no);
    }
    Columns {
        values,
        lines,
        column_of,
    }
    .into_recording(path)
}

/// A line split into too few fields often uses another delimiter than the mapping says.
fn delimiter_hint(line: &str, delimiter: &str) -> String {
    let found = [(';', "\";\""), ('\t', "\"\\t\""), (',', "\",\"")]
        .into_iter()
        .find(|(c, _)| !delimiter.starts_with(*c) && line.contains(*c));
    match found {
        Some((_, key)) if delimiter != "whitespace" || key != "\"\\t\"" => {
            format!(" (the line contains {key}: should `format.delimiter` be {key}?)")
        }
        _ => String::new(),
    }
}
