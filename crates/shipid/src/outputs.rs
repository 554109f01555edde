//! Output paths checked before any work: every command with an output option asks here, so a mistake
//! in the command line (an output that is a folder, that lies under a file, or that is one of the
//! files the command reads) is refused at once with exit 2, not found after minutes of work or
//! silently written over the user's data.

use std::path::{Path, PathBuf};

use shipid_pipeline::model_file::{absolute_path, resolve_stored};

use crate::{CliError, bad_input};

/// A chain of augmented model files longer than this is the loader's to refuse; the walk here stops.
const MAX_MODEL_CHAIN: usize = 64;

/// The files a command reads, each with what it is (for the message).
#[derive(Debug, Default)]
pub struct Inputs(Vec<(PathBuf, String)>);

impl Inputs {
    pub fn new() -> Inputs {
        Inputs::default()
    }

    /// One file read as it is.
    pub fn file(mut self, path: &Path, what: &str) -> Inputs {
        self.0.push((path.to_path_buf(), what.into()));
        self
    }

    /// A data set file, its recordings and its open-water file, as far as its TOML names them (a
    /// damaged data set is the loader's to name, after this check).
    pub fn dataset(mut self, path: &Path) -> Inputs {
        self.add_dataset(path);
        self
    }

    /// A model file (`mmg:…` reads none), the bases it wraps and the training data it names.
    pub fn model(mut self, spec: &str) -> Inputs {
        let mut path = PathBuf::from(spec);
        for _ in 0..MAX_MODEL_CHAIN {
            if spec.starts_with("mmg:") || self.0.iter().any(|(p, _)| same_file(p, &path)) {
                return self;
            }
            self.0.push((path.clone(), "the model file".into()));
            let Some(table) = read_table(&path) else {
                return self;
            };
            for dataset in table
                .get("training")
                .and_then(toml::Value::as_array)
                .into_iter()
                .flatten()
                .filter_map(|w| w.get("dataset").and_then(toml::Value::as_str))
            {
                let ds = resolve_stored(&path, dataset);
                if !self.0.iter().any(|(p, _)| same_file(p, &ds)) {
                    self.add_dataset(&ds);
                }
            }
            match table.get("base").and_then(toml::Value::as_str) {
                Some(base) if !base.starts_with("mmg:") => path = resolve_stored(&path, base),
                _ => return self,
            }
        }
        self
    }

    fn add_dataset(&mut self, path: &Path) {
        self.0
            .push((path.to_path_buf(), "the data set file".into()));
        let Some(table) = read_table(path) else {
            return;
        };
        let dir = path.parent().unwrap_or(Path::new(""));
        for file in table
            .get("recording")
            .and_then(toml::Value::as_array)
            .into_iter()
            .flatten()
            .filter_map(|r| r.get("file").and_then(toml::Value::as_str))
        {
            self.0
                .push((dir.join(file), format!("a recording of {}", path.display())));
        }
        if let Some(csv) = table
            .get("propeller")
            .and_then(|p| p.get("open_water"))
            .and_then(toml::Value::as_str)
        {
            self.0.push((
                dir.join(csv),
                format!("the open-water file of {}", path.display()),
            ));
        }
    }

    /// The input `out` would overwrite, if any.
    fn overwritten_by(&self, out: &Path) -> Option<&(PathBuf, String)> {
        self.0.iter().find(|(p, _)| same_file(p, out))
    }
}

fn read_table(path: &Path) -> Option<toml::Table> {
    toml::from_str(&std::fs::read_to_string(path).ok()?).ok()
}

/// Whether `a` and `b` are one file: the same device and inode when both exist (hard and symbolic
/// links included), else the same absolute path with links resolved.
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(x), Ok(y)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return x.dev() == y.dev() && x.ino() == y.ino();
        }
    }
    absolute_path(a) == absolute_path(b)
}

/// `flag`'s file `out` can be written: not a folder, no file among the folders above it, the nearest
/// existing one writable, and not one of the command's `inputs`.
pub fn check_file(flag: &str, out: &Path, inputs: &Inputs) -> Result<(), CliError> {
    check_file_named(flag, out, "out.toml", inputs)
}

/// [`check_file`] for an option whose file is not TOML: `example` is the file name the message
/// suggests inside a folder given by mistake (`run.csv`, `report.json`).
pub fn check_file_named(
    flag: &str,
    out: &Path,
    example: &str,
    inputs: &Inputs,
) -> Result<(), CliError> {
    if out.is_dir() {
        return Err(bad_input(format!(
            "{flag} {}: is a folder; give the path of a file to write (e.g. {})",
            out.display(),
            out.join(example).display()
        )));
    }
    check_folders_above(flag, out, out.parent())?;
    refuse_input(flag, out, inputs)
}

/// `flag`'s folder `out` can be written: not a file, no file among the folders above it, the nearest
/// existing one writable, and none of `writes` (the files the command writes in it, relative to it)
/// one of the command's `inputs`.
pub fn check_folder(
    flag: &str,
    out: &Path,
    writes: &[&str],
    inputs: &Inputs,
) -> Result<(), CliError> {
    if out.exists() && !out.is_dir() {
        return Err(bad_input(format!(
            "{flag} {}: is a file, not a folder",
            out.display()
        )));
    }
    check_folders_above(flag, out, Some(out))?;
    for name in writes {
        refuse_input(flag, &out.join(name), inputs)?;
    }
    Ok(())
}

/// `flag`'s folder `out` must be new or empty unless `force`: a command that writes a whole set of
/// files there (a data set) would otherwise mix its files with what the folder held, or replace a data
/// set that others rely on without a word. The entries it holds (sorted) when `force` lets it go on.
pub fn refuse_nonempty_folder(
    flag: &str,
    out: &Path,
    what_is_written: &str,
    force: bool,
) -> Result<Vec<String>, CliError> {
    let Ok(entries) = std::fs::read_dir(out) else {
        return Ok(Vec::new());
    };
    let mut names: Vec<String> = entries
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    if names.is_empty() || force {
        return Ok(names);
    }
    let holds = if names.iter().any(|n| n == "dataset.toml") {
        format!(
            "holds a data set (dataset.toml and {} other entries)",
            names.len() - 1
        )
    } else {
        format!("holds {} entries", names.len())
    };
    let shown: Vec<&str> = names.iter().take(4).map(String::as_str).collect();
    let more = if names.len() > shown.len() {
        ", …"
    } else {
        ""
    };
    Err(bad_input(format!(
        "{flag} {}: {holds} (`{}`{more}); {what_is_written} would replace them and leave the rest behind: give a new or empty folder, or --force to write over it",
        out.display(),
        shown.join("`, `")
    )))
}

/// Two outputs of one command that are the same file would overwrite each other.
pub fn check_distinct(
    (flag_a, a): (&str, &Path),
    (flag_b, b): (&str, &Path),
) -> Result<(), CliError> {
    if same_file(a, b) {
        return Err(bad_input(format!(
            "{flag_a} {} and {flag_b} {} are the same file: one output would overwrite the other",
            a.display(),
            b.display()
        )));
    }
    Ok(())
}

fn refuse_input(flag: &str, out: &Path, inputs: &Inputs) -> Result<(), CliError> {
    match inputs.overwritten_by(out) {
        Some((input, what)) => Err(bad_input(format!(
            "{flag} {}: is {what}, {}, which this command reads: writing there would destroy it; give another path",
            out.display(),
            input.display()
        ))),
        None => Ok(()),
    }
}

/// Every existing path from `start` upwards must be a folder, and the nearest one writable (the
/// writers create the missing ones).
fn check_folders_above(flag: &str, out: &Path, start: Option<&Path>) -> Result<(), CliError> {
    let mut dir = start.filter(|d| !d.as_os_str().is_empty());
    while let Some(d) = dir {
        if d.exists() {
            if !d.is_dir() {
                return Err(bad_input(format!(
                    "{flag} {}: {} is a file, not a folder",
                    out.display(),
                    d.display()
                )));
            }
            return writable(flag, out, d);
        }
        dir = d.parent().filter(|p| !p.as_os_str().is_empty());
    }
    // Nothing above exists as spelled: the working directory is the one written into.
    writable(flag, out, Path::new("."))
}

fn writable(flag: &str, out: &Path, dir: &Path) -> Result<(), CliError> {
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        let Ok(c) = std::ffi::CString::new(dir.as_os_str().as_bytes()) else {
            return Ok(());
        };
        // SAFETY: `c` is a valid NUL-terminated path that outlives the call.
        let denied = unsafe { libc::access(c.as_ptr(), libc::W_OK | libc::X_OK) } != 0;
        if denied {
            return Err(bad_input(format!(
                "{flag} {}: cannot write into the folder {}: {}",
                out.display(),
                dir.display(),
                std::io::Error::last_os_error()
            )));
        }
    }
    Ok(())
}
