//! Writing data sets and recordings in the data format of `docs/data-format.md`, atomically (temporary file, then rename), in
//! the project's conventions (SI, midship, rudder positive to starboard).

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

use crate::dataset::DatasetFile;
use crate::types::Recording;

/// Write `contents` to `path` so that readers see either the old file or the whole new one.
pub fn write_atomic(path: &Path, contents: &[u8]) -> std::io::Result<()> {
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
    {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(contents)?;
        f.sync_all()?;
    }
    std::fs::rename(&tmp, path)
}

/// A number with 9 significant digits in its shortest form: exact enough for every channel (relative
/// 1e-9) and keeps committed data small.
pub fn fmt_sig(x: f64) -> String {
    if x == 0.0 {
        return "0".into();
    }
    let rounded: f64 = format!("{x:.8e}").parse().unwrap_or(x);
    // Plain notation reads best in the usual range; far outside it the exponent form is shorter.
    if (1e-4..1e9).contains(&rounded.abs()) {
        format!("{rounded}")
    } else {
        format!("{rounded:e}")
    }
}

/// The CSV text of a recording, with `comments` as `#` lines before the header.
pub fn recording_csv(rec: &Recording, comments: &[String]) -> String {
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
    if rec.accelerations.is_some() {
        header.extend(["u_dot", "v_dot", "r_dot"]);
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
        if let Some(a) = &rec.accelerations {
            row.extend([a.u_dot[i], a.v_dot[i], a.r_dot[i]]);
        }
        let cells: Vec<String> = row.into_iter().map(fmt_sig).collect();
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    out
}

/// Write a data set: `dir/dataset.toml` and one CSV per entry of `file.recordings` (same order as
/// `recordings`). The file must describe the recordings in the project's conventions (origin midship,
/// rudder_sign 1), which is what the recordings are.
pub fn write_dataset(
    dir: &Path,
    file: &DatasetFile,
    recordings: &[&Recording],
    header_comments: &[String],
) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    for (entry, rec) in file.recordings.iter().zip(recordings) {
        write_atomic(
            &dir.join(&entry.file),
            recording_csv(rec, header_comments).as_bytes(),
        )?;
    }
    let mut text = String::new();
    for c in header_comments {
        for line in c.lines() {
            let _ = writeln!(text, "# {line}");
        }
    }
    text.push_str(&toml::to_string(file).map_err(std::io::Error::other)?);
    write_atomic(&dir.join("dataset.toml"), text.as_bytes())
}
