//! Writing data sets and recordings in the data format of `docs/data-format.md`, atomically (temporary file, then rename), in
//! the project's conventions (SI, midship, rudder positive to starboard).

use std::collections::HashMap;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Component, Path, PathBuf};

use crate::dataset::DatasetFile;
use crate::types::Recording;
pub use crate::units::fmt_sig;

/// Write `contents` to `path` so that readers see either the old file or the whole new one. A path
/// that is a device, pipe or socket (`--out /dev/null`, `/dev/stdout`, a named pipe) is written
/// into as it is: renaming a file over it replaced the machine's `/dev/null` with a regular file.
pub fn write_atomic(path: &Path, contents: &[u8]) -> std::io::Result<()> {
    if let Ok(meta) = std::fs::metadata(path)
        && !meta.is_file()
        && !meta.is_dir()
    {
        let mut f = std::fs::OpenOptions::new().write(true).open(path)?;
        return f.write_all(contents);
    }
    if let Some(dir) = path.parent()
        && !dir.as_os_str().is_empty()
    {
        std::fs::create_dir_all(dir)?;
    }
    // Unique per process and call: two writers of one path (two runs, two threads) must never
    // share a temporary file, or one renames the other's half-written bytes into place.
    static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let tmp = path.with_extension(format!(
        "{}.{}-{n}.tmp",
        path.extension().and_then(|e| e.to_str()).unwrap_or(""),
        std::process::id()
    ));
    let written = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(contents)?;
        f.sync_all()?;
        drop(f);
        std::fs::rename(&tmp, path)
    })();
    // A failed write or rename (the target a folder, a full disk) leaves no temporary file behind.
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written
}

/// The channels a recording's wind is written as: the true wind (`wind_speed`, `wind_from`), or the
/// relative wind an anemometer on board would measure (`relative_wind_speed`, `relative_wind_angle`),
/// computed from the true wind with the recording's own heading and velocities so that reading it
/// back gives the same true wind (to the 9 digits written).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum WindChannels {
    #[default]
    True,
    Relative,
}

impl std::str::FromStr for WindChannels {
    type Err = String;

    fn from_str(s: &str) -> Result<WindChannels, String> {
        match s {
            "true" => Ok(WindChannels::True),
            "relative" => Ok(WindChannels::Relative),
            _ => Err(format!(
                "`{s}` is not a wind channel kind: `true` (wind_speed, wind_from) or `relative` (relative_wind_speed, relative_wind_angle)"
            )),
        }
    }
}

/// A number in the shortest form that reads back to the same `f64`.
fn fmt_exact(x: f64) -> String {
    if x == 0.0 {
        return "0".into();
    }
    if (1e-4..1e16).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// The CSV text of a recording, with `comments` as `#` lines before the header.
pub fn recording_csv(rec: &Recording, comments: &[String]) -> String {
    recording_csv_with(rec, comments, WindChannels::True)
}

/// [`recording_csv`] with the wind written as `wind` channels.
pub fn recording_csv_with(rec: &Recording, comments: &[String], wind: WindChannels) -> String {
    let mut out = String::new();
    for c in comments {
        for line in c.lines() {
            let _ = writeln!(out, "# {line}");
        }
    }
    let mut header = vec!["t", "x0", "y0", "psi", "u", "v", "r", "delta"];
    if rec.n.is_some() {
        header.push("n");
    }
    if rec.thrust.is_some() {
        header.push("thrust");
    }
    if rec.accelerations.is_some() {
        header.extend(["u_dot", "v_dot", "r_dot"]);
    }
    match (&rec.wind, wind) {
        (None, _) => {}
        (Some(_), WindChannels::True) => header.extend(["wind_speed", "wind_from"]),
        (Some(_), WindChannels::Relative) => {
            header.extend(["relative_wind_speed", "relative_wind_angle"]);
        }
    }
    if rec.current.is_some() {
        header.extend(["current_speed", "current_from"]);
    }
    out.push_str(&header.join(","));
    out.push('\n');
    for i in 0..rec.len() {
        let mut row = vec![
            rec.t[i],
            rec.x0[i],
            rec.y0[i],
            rec.psi[i],
            rec.u[i],
            rec.v[i],
            rec.r[i],
            rec.delta[i],
        ];
        if let Some(n) = &rec.n {
            row.push(n[i]);
        }
        if let Some(thrust) = &rec.thrust {
            row.push(thrust[i]);
        }
        if let Some(a) = &rec.accelerations {
            row.extend([a.u_dot[i], a.v_dot[i], a.r_dot[i]]);
        }
        if let Some(w) = &rec.wind {
            let true_wind = crate::relative_wind::Wind {
                speed_m_s: w.speed_m_s[i],
                from_rad: w.from_rad[i],
            };
            let written = match wind {
                WindChannels::True => Some(true_wind),
                WindChannels::Relative => crate::relative_wind::relative_wind(
                    true_wind,
                    crate::relative_wind::ShipMotion {
                        psi_rad: rec.psi[i],
                        u_m_s: rec.u[i],
                        v_m_s: rec.v[i],
                    },
                ),
            };
            // A non-finite value is written as NaN, which every reader refuses naming the cell.
            let w = written.unwrap_or(crate::relative_wind::Wind {
                speed_m_s: f64::NAN,
                from_rad: f64::NAN,
            });
            row.extend([w.speed_m_s, w.from_rad]);
        }
        if let Some(c) = &rec.current {
            row.extend([c.speed_m_s[i], c.from_rad[i]]);
        }
        // Time and position carry an offset (seconds since a year began, UTM metres) that nine
        // significant digits would eat: 2.9e7 s + 0.1 s steps were written as repeated times. They
        // are written in full (the shortest form that reads back exactly); the rest with nine.
        let cells: Vec<String> = row
            .into_iter()
            .enumerate()
            .map(|(k, x)| if k < 3 { fmt_exact(x) } else { fmt_sig(x) })
            .collect();
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    out
}

/// Why a data set could not be written. Every variant names the path or the file name at fault (an
/// `io::Error` alone says only "No such file or directory").
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    // The io::Error is shown in the message, not chained as a source: chained, every report that
    // prints causes would repeat it.
    #[error("cannot write {}: {error}", path.display())]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("output folder {}: exists and is not a directory", dir.display())]
    NotADirectory { dir: PathBuf },
    #[error("output file name `{name}`: {reason}")]
    UnsafeName { name: String, reason: &'static str },
    #[error("output files `{first}` and `{second}` are the same file in {}", dir.display())]
    SameOutput {
        dir: PathBuf,
        first: String,
        second: String,
    },
    #[error("{} leads outside the output folder {} (through a symbolic link)", path.display(), dir.display())]
    Escapes { path: PathBuf, dir: PathBuf },
    #[error("{} is an input of this command ({}); refusing to overwrite it: choose another output folder", path.display(), input.display())]
    WouldOverwriteInput { path: PathBuf, input: PathBuf },
}

impl WriteError {
    /// True when the caller's input is at fault (an output name or an `--out` that is a file), not the
    /// file system.
    pub fn is_bad_input(&self) -> bool {
        !matches!(self, WriteError::Io { .. })
    }
}

fn io_at(path: &Path) -> impl Fn(std::io::Error) -> WriteError + '_ {
    move |error| WriteError::Io {
        path: path.to_path_buf(),
        error,
    }
}

/// An output file name must be a plain relative path that stays inside the output folder: no absolute
/// path, no `..`, no backslash (a separator elsewhere), not the data set file itself.
pub fn check_output_name(name: &str) -> Result<(), &'static str> {
    if name.trim().is_empty() {
        return Err("is empty");
    }
    if name.contains('\\') {
        return Err("contains `\\`; use `/` between folders");
    }
    let path = Path::new(name);
    if path.is_absolute() || name.starts_with('/') {
        return Err("is absolute; it must be relative to the output folder");
    }
    for c in path.components() {
        match c {
            Component::Normal(_) | Component::CurDir => {}
            Component::ParentDir => {
                return Err("contains `..`; it must stay inside the output folder");
            }
            Component::RootDir | Component::Prefix(_) => {
                return Err("is absolute; it must be relative to the output folder");
            }
        }
    }
    if name.ends_with('/') {
        return Err("names a folder, not a file");
    }
    if output_key(name) == "dataset.toml" {
        return Err("is the data set file itself");
    }
    Ok(())
}

/// The name two outputs collide on: `.` components dropped and case folded, since `A.csv` and `a.csv`
/// are one file on case-insensitive file systems.
pub fn output_key(name: &str) -> String {
    name.split('/')
        .filter(|c| !c.is_empty() && *c != ".")
        .collect::<Vec<_>>()
        .join("/")
        .to_lowercase()
}

/// Write a data set: `dir/dataset.toml` and one CSV per entry of `file.recordings` (same order as
/// `recordings`). The file must describe the recordings in the project's conventions (origin midship,
/// rudder_sign 1), which is what the recordings are.
///
/// Nothing is written outside `dir`: names are checked first ([`check_output_name`], no two the same),
/// and a folder reached through a symbolic link that leaves `dir` is refused. A previous `dataset.toml`
/// is removed before the recordings are written and the new one is written last, so a folder whose
/// writing failed half-way has no `dataset.toml` and cannot be mistaken for a complete data set.
pub fn write_dataset(
    dir: &Path,
    file: &DatasetFile,
    recordings: &[&Recording],
    header_comments: &[String],
) -> Result<(), WriteError> {
    write_dataset_with(dir, file, recordings, header_comments, &[], &[])
}

/// [`write_dataset`] plus other files the data set names (`files`: output name and contents, e.g. the
/// open-water table), under the same name checks, written before `dataset.toml`. No output may be one
/// of the `inputs` (an import's mapping and sources when `--out` is their folder): that is refused
/// before anything is written.
pub fn write_dataset_with(
    dir: &Path,
    file: &DatasetFile,
    recordings: &[&Recording],
    header_comments: &[String],
    files: &[(String, Vec<u8>)],
    inputs: &[PathBuf],
) -> Result<(), WriteError> {
    write_all(
        dir,
        file,
        recordings,
        header_comments,
        files,
        inputs,
        WindChannels::True,
    )
}

/// [`write_dataset`] with the recordings' wind written as `wind` channels.
pub fn write_dataset_channels(
    dir: &Path,
    file: &DatasetFile,
    recordings: &[&Recording],
    header_comments: &[String],
    wind: WindChannels,
) -> Result<(), WriteError> {
    write_all(dir, file, recordings, header_comments, &[], &[], wind)
}

fn write_all(
    dir: &Path,
    file: &DatasetFile,
    recordings: &[&Recording],
    header_comments: &[String],
    files: &[(String, Vec<u8>)],
    inputs: &[PathBuf],
    wind: WindChannels,
) -> Result<(), WriteError> {
    if dir.exists() && !dir.is_dir() {
        return Err(WriteError::NotADirectory {
            dir: dir.to_path_buf(),
        });
    }
    let mut seen: HashMap<String, &str> = HashMap::new();
    let names = file
        .recordings
        .iter()
        .map(|e| e.file.as_str())
        .chain(files.iter().map(|f| f.0.as_str()));
    for name in names {
        check_output_name(name).map_err(|reason| WriteError::UnsafeName {
            name: name.to_string(),
            reason,
        })?;
        if let Some(first) = seen.insert(output_key(name), name) {
            return Err(WriteError::SameOutput {
                dir: dir.to_path_buf(),
                first: first.to_string(),
                second: name.to_string(),
            });
        }
    }
    let real_inputs: Vec<(PathBuf, &PathBuf)> = inputs
        .iter()
        .filter_map(|p| p.canonicalize().ok().map(|c| (c, p)))
        .collect();
    let targets = file
        .recordings
        .iter()
        .map(|e| e.file.as_str())
        .chain(files.iter().map(|f| f.0.as_str()))
        .chain(["dataset.toml"]);
    for name in targets {
        let target = dir.join(name);
        if let Ok(real) = target.canonicalize()
            && let Some((_, input)) = real_inputs.iter().find(|(c, _)| *c == real)
        {
            return Err(WriteError::WouldOverwriteInput {
                path: target,
                input: input.to_path_buf(),
            });
        }
    }
    std::fs::create_dir_all(dir).map_err(io_at(dir))?;
    let real_dir = dir.canonicalize().map_err(io_at(dir))?;
    let dataset_path = dir.join("dataset.toml");
    match std::fs::remove_file(&dataset_path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            return Err(io_at(&dataset_path)(e));
        }
        _ => {}
    }
    let contents = file
        .recordings
        .iter()
        .zip(recordings)
        .map(|(entry, rec)| {
            (
                entry.file.as_str(),
                recording_csv_with(rec, header_comments, wind).into_bytes(),
            )
        })
        .chain(
            files
                .iter()
                .map(|(name, bytes)| (name.as_str(), bytes.clone())),
        );
    for (name, bytes) in contents {
        let target = dir.join(name);
        if let Some(parent) = target.parent() {
            std::fs::create_dir_all(parent).map_err(io_at(parent))?;
            let real = parent.canonicalize().map_err(io_at(parent))?;
            if !real.starts_with(&real_dir) {
                return Err(WriteError::Escapes {
                    path: target,
                    dir: dir.to_path_buf(),
                });
            }
        }
        write_atomic(&target, &bytes).map_err(io_at(&target))?;
    }
    let mut text = String::new();
    for c in header_comments {
        for line in c.lines() {
            let _ = writeln!(text, "# {line}");
        }
    }
    let toml = toml::to_string(file).map_err(|e| io_at(&dataset_path)(std::io::Error::other(e)))?;
    text.push_str(&toml);
    write_atomic(&dataset_path, text.as_bytes()).map_err(io_at(&dataset_path))
}
