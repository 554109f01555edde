//! Reading a recording (one manoeuvre, one CSV file; format in `docs/data-format.md`).

use std::collections::HashMap;
use std::path::Path;

use crate::error::InputError;
use crate::table::{Columns, parse_cell};
use crate::types::Recording;
use crate::units::Quantity;

/// Largest input file read (recordings, open-water tables, import sources): ten hours at 100 Hz of a
/// dozen channels is about 0.5 GB, and a larger file would be read whole into memory several times.
pub const MAX_FILE_BYTES: u64 = 1 << 30;

/// Read and validate a recording file. Values are converted to SI; the origin and rudder sign are the
/// source's (the data set loader converts them, since only it knows them).
pub fn read_recording(path: &Path) -> Result<Recording, InputError> {
    let text = read_text(path)?;
    parse_recording(path, &text)
}

/// Why `path` cannot be read as an input file, if it cannot: missing, a directory, or no regular
/// file (a FIFO would block the read until a writer comes, `/dev/zero` never ends, and "not found"
/// would send the user looking for a file that is there).
pub fn not_a_file(path: &Path) -> Option<&'static str> {
    match std::fs::metadata(path) {
        Err(_) => Some("not found"),
        Ok(m) if m.is_dir() => Some("is a directory, not a file"),
        Ok(m) if !m.is_file() => Some("is not a regular file (a FIFO, device or socket)"),
        Ok(_) => None,
    }
}

/// The bytes of an input file, refused before reading when larger than [`MAX_FILE_BYTES`].
pub fn read_bytes(path: &Path) -> Result<Vec<u8>, InputError> {
    let meta = std::fs::metadata(path).map_err(|e| InputError::read(path, &e))?;
    if meta.is_dir() {
        return Err(InputError::file(path, "is a directory, not a file"));
    }
    if !meta.is_file() {
        return Err(InputError::file(
            path,
            "is not a regular file (a FIFO, device or socket)",
        ));
    }
    if meta.len() > MAX_FILE_BYTES {
        return Err(InputError::file(
            path,
            format!(
                "{:.1} GiB is larger than the {} GiB shipid reads (split the recording)",
                meta.len() as f64 / (1u64 << 30) as f64,
                MAX_FILE_BYTES >> 30
            ),
        ));
    }
    std::fs::read(path).map_err(|e| InputError::read(path, &e))
}

/// An input file's UTF-8 text (size-checked by [`read_bytes`]); a byte that is not UTF-8 is named with
/// its line.
pub fn read_text(path: &Path) -> Result<String, InputError> {
    let bytes = read_bytes(path)?;
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let bytes = e.as_bytes();
        let line = bytes[..at].iter().filter(|&&b| b == b'\n').count() + 1;
        InputError::line(
            path,
            line,
            format!(
                "not UTF-8 text (byte {at}, value 0x{:02x}); save the file as UTF-8, or import it with a mapping that names its encoding",
                bytes[at]
            ),
        )
    })
}

/// Parse recording text; `path` only names the source in errors.
pub fn parse_recording(path: &Path, text: &str) -> Result<Recording, InputError> {
    // Comments are allowed before the header only; skip them (and blank lines) and remember how many
    // lines we skipped so that errors point at the real line.
    // A byte-order mark is not part of the first line (else `#` comments after it read as a header).
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut skipped = 0usize;
    let mut rest = text;
    loop {
        let (line, tail) = match rest.find('\n') {
            Some(i) => (&rest[..i], &rest[i + 1..]),
            None => (rest, ""),
        };
        let l = line.trim();
        if (l.starts_with('#') || l.is_empty()) && !(l.is_empty() && tail.is_empty()) {
            skipped += 1;
            rest = tail;
        } else {
            break;
        }
    }
    if rest.trim().is_empty() {
        return Err(InputError::file(path, "no header row"));
    }
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(rest.as_bytes());
    let mut records = reader.records();
    let header = match records.next() {
        Some(Ok(h)) => h,
        Some(Err(e)) => return Err(csv_error(path, skipped, &e)),
        None => return Err(InputError::file(path, "no header row")),
    };
    let header_line = skipped + 1;
    if header.len() == 1
        && let Some(hint) = separator_hint(&header[0], rest)
    {
        return Err(InputError::line(path, header_line, hint));
    }
    let mut slots: Vec<Option<(Quantity, f64)>> = Vec::with_capacity(header.len());
    let mut column_of: HashMap<Quantity, (usize, String)> = HashMap::new();
    for (i, raw) in header.iter().enumerate() {
        let (name, unit) =
            split_unit(raw).map_err(|m| InputError::cell(path, header_line, i + 1, raw, m))?;
        let quantity = match Quantity::from_name(name) {
            Some(q) if Quantity::RECORDING.contains(&q) => q,
            _ => {
                if let Some(hint) = misspelt_column(name) {
                    return Err(InputError::cell(path, header_line, i + 1, raw, hint));
                }
                slots.push(None); // unknown columns are kept by the source but ignored here
                continue;
            }
        };
        let factor = match unit {
            None => 1.0,
            Some(u) => quantity.dimension().to_si(u).ok_or_else(|| {
                InputError::cell(
                    path,
                    header_line,
                    i + 1,
                    raw,
                    format!(
                        "unknown unit `{u}` for `{name}` (known: {})",
                        quantity.dimension().known_units()
                    ),
                )
            })?,
        };
        if let Some((c, _)) = column_of.get(&quantity) {
            return Err(InputError::cell(
                path,
                header_line,
                i + 1,
                raw,
                format!("duplicate column `{name}` (also column {c})"),
            ));
        }
        column_of.insert(quantity, (i + 1, raw.to_string()));
        slots.push(Some((quantity, factor)));
    }
    let mut values: HashMap<Quantity, Vec<f64>> =
        column_of.keys().map(|&q| (q, Vec::new())).collect();
    let mut lines = Vec::new();
    for rec in records {
        let rec = rec.map_err(|e| csv_error(path, skipped, &e))?;
        let line = skipped + rec.position().map_or(0, |p| p.line() as usize);
        if rec.len() == 1 && rec.get(0).is_some_and(str::is_empty) {
            continue; // a blank line
        }
        if rec.len() != header.len() {
            // More fields than names: typically `0,25` split by a decimal comma.
            let hint = if rec.len() > header.len() {
                " (decimal commas? shipid reads `.` as the decimal mark)"
            } else {
                ""
            };
            return Err(InputError::line(
                path,
                line,
                format!(
                    "expected {} fields as in the header, found {}{hint}",
                    header.len(),
                    rec.len()
                ),
            ));
        }
        for (i, cell) in rec.iter().enumerate() {
            if let Some((q, factor)) = slots[i] {
                let x = parse_cell(cell).map_err(|m| {
                    InputError::cell(
                        path,
                        line,
                        i + 1,
                        &header[i],
                        crate::table::with_comma_hint(m, cell),
                    )
                })?;
                if let Some(col) = values.get_mut(&q) {
                    col.push(x * factor);
                }
            }
        }
        lines.push(line);
    }
    Columns {
        values,
        lines,
        column_of,
    }
    .into_recording(path)
    .map_err(|mut e| {
        // A missing column is a header problem; point at the header line.
        if e.message.starts_with("missing required column") {
            e.location = crate::error::Location::Line {
                line: header_line,
                column: None,
            };
        }
        e
    })
}

/// An unknown column that looks like a known one misspelt (`Psi`, `windspeed`, `wind_dir`), named
/// otherwise (`du`, `tws`, `true_wind_speed`, `cur_from`) or with its unit written otherwise than in
/// square brackets (`u_dot(m/s2)`, `psi_deg`): ignored like any other unknown column it would silently
/// drop a recorded channel (a recorded wind read as calm, recorded accelerations replaced by
/// estimates), so it is refused with the name to write. Other unknown columns (`roll`, `torque`,
/// `wind_gust`, `delta_cmd`) are the source's own and ignored.
fn misspelt_column(name: &str) -> Option<String> {
    if let Some(hint) = unit_written_otherwise(name) {
        return Some(hint);
    }
    let (guess, spelling) = meant(name)?;
    if spelling == Spelling::Case {
        return Some(format!(
            "not a column name: names are lower-case, write `{guess}` (an unknown column would be ignored)"
        ));
    }
    Some(format!(
        "not a column shipid knows; did you mean `{guess}`{}? An unknown column is ignored, and this one would drop a recorded channel (docs/data-format.md)",
        meaning(guess, name)
    ))
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Spelling {
    /// A known name with capitals.
    Case,
    /// Misspelt, or a name other software uses for the channel.
    Other,
}

/// The known column `name` most likely means, if it clearly means one.
fn meant(name: &str) -> Option<(&'static str, Spelling)> {
    let known = || Quantity::RECORDING.iter().map(|q| q.name());
    let lower = name.to_lowercase();
    if let Some(k) = known().find(|k| *k == lower) {
        return Some((k, Spelling::Case));
    }
    let norm = lower.replace([' ', '-', '.'], "_");
    if let Some(k) = alias(&norm) {
        return Some((k, Spelling::Other));
    }
    let close = known()
        .filter(|k| k.len() >= 5 && lower.len() >= 4)
        .map(|k| (edit_distance(&lower, k), k))
        .filter(|&(d, _)| d <= 2)
        .min_by_key(|&(d, _)| d)
        .map(|(_, k)| k);
    close
        .or_else(|| flow_column(&norm))
        .map(|k| (k, Spelling::Other))
}

/// Names loggers and other tools give channels shipid reads under another name. Only unambiguous
/// ones: `du` is read as du/dt, since shipid has no column for a speed change.
fn alias(norm: &str) -> Option<&'static str> {
    Some(match norm {
        "du" | "dudt" | "du_dt" | "du/dt" | "u_acc" | "u_accel" | "surge_acc"
        | "surge_acceleration" => "u_dot",
        "dv" | "dvdt" | "dv_dt" | "dv/dt" | "v_acc" | "v_accel" | "sway_acc"
        | "sway_acceleration" => "v_dot",
        "dr" | "drdt" | "dr_dt" | "dr/dt" | "r_acc" | "r_accel" | "yaw_acc"
        | "yaw_acceleration" => "r_dot",
        // The propeller's (the shaft's) rate; an engine's rpm is not: a gearbox lies between.
        "rpm" | "rps" | "prop_rpm" | "prop_rps" | "propeller_rpm" | "propeller_rps"
        | "prop_rate" | "propeller_rate" | "shaft_rpm" | "shaft_speed" => "n",
        // Sailing instruments: true wind speed / direction, apparent wind speed / angle.
        "tws" => "wind_speed",
        "twd" | "twa" => "wind_from",
        "aws" => "relative_wind_speed",
        "awa" => "relative_wind_angle",
        _ => return None,
    })
}

/// A wind or current speed or direction named otherwise (`wind_dir`, `true_wind_speed`,
/// `apparent_wind_angle`, `cur_from`, `current_direction`): the flow from the name's start, speed or
/// direction from a word in it; a name with neither (`wind_gust`) or both is the source's own.
fn flow_column(norm: &str) -> Option<&'static str> {
    const FLOWS: [(&str, &str); 10] = [
        ("true_wind", "wind"),
        ("truewind", "wind"),
        ("apparent_wind", "relative"),
        ("app_wind", "relative"),
        ("rel_wind", "relative"),
        ("relative_wind", "relative"),
        ("wind", "wind"),
        ("current", "current"),
        ("curr_", "current"),
        ("cur_", "current"),
    ];
    let (_, flow) = FLOWS.iter().find(|(p, _)| norm.starts_with(p))?;
    let direction = ["dir", "from", "angle", "deg", "head"]
        .iter()
        .any(|d| norm.contains(d));
    let speed = ["sp", "vel", "mag", "kn", "m_s", "ms"]
        .iter()
        .any(|d| norm.contains(d));
    // A wind measured on board is the relative wind, which has columns of its own.
    let relative = *flow == "relative" || (*flow == "wind" && norm.contains("rel"));
    let (from, speed_name) = match (*flow, relative) {
        (_, true) => ("relative_wind_angle", "relative_wind_speed"),
        ("wind", false) => ("wind_from", "wind_speed"),
        _ => ("current_from", "current_speed"),
    };
    match (direction, speed) {
        (true, false) => Some(from),
        (false, true) => Some(speed_name),
        _ => None,
    }
}

/// What a suggested column holds, where the name alone could mislead.
fn meaning(guess: &str, written: &str) -> &'static str {
    let lower = written.to_lowercase();
    match guess {
        // A true wind angle is off the bow; `wind_from` is earth-fixed.
        "wind_from" if lower == "twa" || lower.contains("angle") => {
            " (the direction it comes FROM, clockwise from north: a true wind angle off the bow needs the heading added)"
        }
        g if g.ends_with("_from") => " (the direction it comes FROM, clockwise from north)",
        "relative_wind_angle" => " (the angle off the bow the relative wind comes from)",
        "u_dot" => " (the surge acceleration du/dt)",
        "v_dot" => " (the sway acceleration dv/dt)",
        "r_dot" => " (the yaw acceleration dr/dt; the rudder angle is `delta`)",
        _ => "",
    }
}

/// A known column with its unit written otherwise than in square brackets: in another bracket
/// (`u_dot(m/s2)`, `psi{deg}`, `r<deg/s>`) or after an underscore (`psi_deg`, `r_deg_s`). Refused with
/// `name[unit]` to write rather than read: one unit syntax keeps every header's meaning plain, and
/// `(…)` or `_deg` read as an unknown column would drop the channel.
fn unit_written_otherwise(name: &str) -> Option<String> {
    let consequence = "(docs/data-format.md); read as an unknown column, this one would be ignored and drop a recorded channel";
    if let Some((base, unit)) = bracketed_unit(name) {
        let lower = base.to_lowercase();
        let q = Quantity::RECORDING
            .into_iter()
            .find(|q| q.name() == lower)
            .or_else(|| meant(base).and_then(|(k, _)| Quantity::from_name(k)))?;
        let k = q.name();
        return Some(match q.dimension().to_si(unit) {
            Some(_) => format!(
                "a unit goes in square brackets after the name: write `{k}[{unit}]` {consequence}"
            ),
            None => format!(
                "a unit goes in square brackets after the name, `{k}[UNIT]`, and `{unit}` is no unit of `{k}` (known: {}) {consequence}",
                q.dimension().known_units()
            ),
        });
    }
    let lower = name.to_lowercase();
    let (q, unit) = Quantity::RECORDING
        .into_iter()
        .filter(|q| {
            lower.len() > q.name().len() + 1 && lower.starts_with(&format!("{}_", q.name()))
        })
        .filter_map(|q| {
            let rest = name.get(q.name().len() + 1..)?;
            [rest.to_string(), rest.replacen('_', "/", 1)]
                .into_iter()
                .find(|u| q.dimension().to_si(u).is_some())
                .map(|u| (q, u))
        })
        .max_by_key(|(q, _)| q.name().len())?;
    Some(format!(
        "not a column name: for `{k}` in {unit}, write `{k}[{unit}]`: a unit goes in square brackets after the name {consequence}",
        k = q.name()
    ))
}

/// `u_dot(m/s2)` → ("u_dot", "m/s2"): a name with a unit in round, curly or angle brackets at its
/// end (square brackets are the header's own syntax, split off before).
fn bracketed_unit(name: &str) -> Option<(&str, &str)> {
    let close = name.chars().last()?;
    let open = match close {
        ')' => '(',
        '}' => '{',
        '>' => '<',
        _ => return None,
    };
    let at = name.find(open)?;
    let base = name[..at].trim().trim_end_matches(['_', '-']);
    let unit = name[at + 1..name.len() - 1].trim();
    (!base.is_empty() && !unit.is_empty()).then_some((base, unit))
}

/// Levenshtein distance of two short ASCII-ish names.
fn edit_distance(a: &str, b: &str) -> usize {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for i in 1..=a.len() {
        let mut prev = row[0];
        row[0] = i;
        for j in 1..=b.len() {
            let cur = row[j];
            row[j] = (row[j] + 1)
                .min(row[j - 1] + 1)
                .min(prev + usize::from(a[i - 1] != b[j - 1]));
            prev = cur;
        }
    }
    row[b.len()]
}

/// `psi[deg]` → ("psi", Some("deg")); `psi` → ("psi", None).
fn split_unit(raw: &str) -> Result<(&str, Option<&str>), String> {
    match raw.find('[') {
        None => Ok((raw.trim(), None)),
        Some(open) => {
            let close = raw
                .rfind(']')
                .filter(|&c| c > open && c == raw.len() - 1)
                .ok_or_else(|| {
                    format!("malformed unit in header `{raw}` (expected `name[unit]`)")
                })?;
            Ok((raw[..open].trim(), Some(raw[open + 1..close].trim())))
        }
    }
}

fn csv_error(path: &Path, skipped: usize, e: &csv::Error) -> InputError {
    let line = e.position().map_or(0, |p| p.line() as usize) + skipped;
    InputError::line(path, line.max(1), format!("malformed CSV: {e}"))
}

/// A one-field header that holds the column names joined by another separator: say so instead of
/// "missing required column `t`".
fn separator_hint(header: &str, rest: &str) -> Option<String> {
    let (sep, word, key) = if header.contains(';') {
        (';', "';'-separated", "\";\"")
    } else if header.contains('\t') {
        ('\t', "tab-separated", "\"\\t\"")
    } else {
        return None;
    };
    let comma = rest
        .lines()
        .skip(1)
        .take(5)
        .any(|l| l.split(sep).any(|c| c.trim().contains(',')));
    let decimal = if comma { " with decimal commas" } else { "" };
    Some(format!(
        "the header `{header}` looks like {word}{decimal}; shipid reads comma-separated recordings with `.` as the decimal mark (convert the file, or import it with a mapping with `delimiter = {key}`)"
    ))
}
