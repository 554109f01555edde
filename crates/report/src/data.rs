//! Reading the folder's files, each error naming its file; figures as inline SVG.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::ReportError;
use crate::html::{esc, id_of};

/// A CSV file as text: header and rows.
pub struct Csv {
    pub path: PathBuf,
    pub headers: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

impl Csv {
    pub fn read(path: &Path) -> Result<Csv, ReportError> {
        let err = |source| ReportError::Csv {
            path: path.to_path_buf(),
            source,
        };
        let file = std::fs::File::open(path).map_err(|source| ReportError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let mut r = csv::ReaderBuilder::new().from_reader(std::io::BufReader::new(file));
        let headers = r
            .headers()
            .map_err(err)?
            .iter()
            .map(str::to_string)
            .collect();
        let mut rows = Vec::new();
        for rec in r.records() {
            rows.push(rec.map_err(err)?.iter().map(str::to_string).collect());
        }
        Ok(Csv {
            path: path.to_path_buf(),
            headers,
            rows,
        })
    }

    /// Like [`Csv::read`], `None` when the file does not exist.
    pub fn read_optional(path: &Path) -> Result<Option<Csv>, ReportError> {
        if path.exists() {
            Csv::read(path).map(Some)
        } else {
            Ok(None)
        }
    }

    pub fn col(&self, name: &str) -> Option<usize> {
        self.headers.iter().position(|h| h == name)
    }

    /// The case id column: `case` (as `shipid run` writes it), else `case_id` or `id`.
    pub fn case_col(&self) -> Result<usize, ReportError> {
        ["case", "case_id", "id"]
            .iter()
            .find_map(|n| self.col(n))
            .ok_or_else(|| ReportError::Invalid {
                path: self.path.clone(),
                message: format!(
                    "no case id column (`case`) among the {} columns",
                    self.headers.len()
                ),
            })
    }
}

pub fn read_text(path: &Path) -> Result<String, ReportError> {
    std::fs::read_to_string(path).map_err(|source| ReportError::Io {
        path: path.to_path_buf(),
        source,
    })
}

pub fn read_text_optional(path: &Path) -> Result<Option<String>, ReportError> {
    if path.is_file() {
        read_text(path).map(Some)
    } else {
        Ok(None)
    }
}

pub fn read_json_optional(path: &Path) -> Result<Option<serde_json::Value>, ReportError> {
    let Some(text) = read_text_optional(path)? else {
        return Ok(None);
    };
    serde_json::from_str(&text)
        .map(Some)
        .map_err(|source| ReportError::Json {
            path: path.to_path_buf(),
            source,
        })
}

/// A TOML file: its text and its parsed table (a file that does not parse is an error).
pub fn read_toml_optional(path: &Path) -> Result<Option<(String, toml::Table)>, ReportError> {
    let Some(text) = read_text_optional(path)? else {
        return Ok(None);
    };
    let table = text
        .parse::<toml::Table>()
        .map_err(|source| ReportError::Toml {
            path: path.to_path_buf(),
            source,
        })?;
    Ok(Some((text, table)))
}

/// The `*.svg` of a folder, in reading order (see [`figure_rank`]).
pub fn svg_files(dir: &Path) -> Result<Vec<PathBuf>, ReportError> {
    let io = |source| ReportError::Io {
        path: dir.to_path_buf(),
        source,
    };
    let mut files = Vec::new();
    for e in std::fs::read_dir(dir).map_err(io)? {
        let p = e.map_err(io)?.path();
        if p.is_file() && p.extension().is_some_and(|x| x.eq_ignore_ascii_case("svg")) {
            files.push(p);
        }
    }
    files.sort_by_key(|p| {
        let stem = stem(p);
        (figure_rank(&stem), stem)
    });
    Ok(files)
}

fn stem(p: &Path) -> String {
    p.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Known figure kinds (file-name prefix, caption), in reading order.
const KINDS: [(&str, &str); 10] = [
    ("trajectories_", "Trajectories"),
    ("trajectory_", "Trajectory"),
    ("heading_", "Heading and rudder angle"),
    ("coefficient_convergence", "Coefficient convergence"),
    ("coefficients_", "Coefficients per term"),
    ("vif_", "Variance inflation factor per term"),
    ("forces_", "Force contributions per term"),
    ("before_after", "Before and after"),
    ("residuals", "Residuals"),
    ("candidates", "Candidate effects"),
];

/// Known figure kinds by file-name suffix (the diagnosis names figures `<recording>-<kind>.svg`).
const SUFFIXES: [(&str, &str); 2] = [
    ("-tracks", "Tracks before and after the effect"),
    ("-residuals", "Equation-error residuals"),
];

fn figure_rank(stem: &str) -> usize {
    KINDS
        .iter()
        .position(|(p, _)| stem.starts_with(p))
        .or_else(|| {
            SUFFIXES
                .iter()
                .position(|(x, _)| stem.ends_with(x))
                .map(|i| KINDS.len() + i)
        })
        .unwrap_or(KINDS.len() + SUFFIXES.len())
}

/// The heading of a group of figures of one kind.
fn group_title(rank: usize) -> &'static str {
    KINDS
        .iter()
        .chain(SUFFIXES.iter())
        .nth(rank)
        .map_or("Other figures", |k| k.1)
}

/// A caption from a file name: the kind's words for known prefixes, followed by the rest of the
/// name (`trajectories_zz10_10_ps.svg` → "Trajectories — zz10_10_ps"); otherwise the name with
/// underscores as spaces.
pub fn caption(path: &Path) -> String {
    let stem = stem(path);
    for (prefix, words) in KINDS {
        if let Some(rest) = stem.strip_prefix(prefix) {
            let rest = rest.trim_matches('_');
            return if rest.is_empty() {
                words.to_string()
            } else {
                format!("{words} — {rest}")
            };
        }
    }
    for (suffix, words) in SUFFIXES {
        if let Some(rest) = stem.strip_suffix(suffix).filter(|r| !r.is_empty()) {
            return format!("{words} — {rest}");
        }
    }
    let s = stem.replace(['_', '-'], " ");
    let mut c = s.chars();
    match c.next() {
        Some(f) => f.to_uppercase().chain(c).collect(),
        None => s,
    }
}

/// An inline `<svg>` with an accessible name: `aria-labelledby` its figcaption and a `<title>` as its
/// first child (a screen reader otherwise announces an unnamed image; the title is also the tooltip).
fn named_svg(svg: &str, title: &str, caption_id: &str) -> String {
    // The root tag ends at the first '>' (attribute values are escaped, so hold none).
    let Some(end) = svg.find('>') else {
        return svg.to_string();
    };
    let (open, rest) = svg.split_at(end);
    let self_closing = open.ends_with('/');
    let open = open.trim_end_matches('/');
    let title = format!("<title>{}</title>", esc(title));
    if self_closing {
        format!(
            "{open} aria-labelledby=\"{}\">{title}</svg>",
            esc(caption_id)
        )
    } else {
        format!(
            "{open} aria-labelledby=\"{}\">{title}{}",
            esc(caption_id),
            &rest[1..]
        )
    }
}

/// The figures of a folder as `<figure>` elements in a grid; a file that is not a usable SVG becomes
/// a note. `id_prefix` keeps the figures' ids apart from other sections'.
pub fn figures_html(
    dir: &Path,
    id_prefix: &str,
    notes: &mut Vec<String>,
    keep: &dyn Fn(&str) -> Option<String>,
) -> Result<(String, usize), ReportError> {
    let mut files = svg_files(dir)?;
    files.retain(|f| {
        let name = f
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        match keep(&name) {
            None => true,
            Some(why) => {
                notes.push(format!("figures/{name}: {why}: left out"));
                false
            }
        }
    });
    let mut body = String::new();
    let mut index: Vec<String> = Vec::new();
    let mut group = None;
    for (i, f) in files.iter().enumerate() {
        let text = match std::fs::read(f) {
            Ok(b) => String::from_utf8_lossy(&b).into_owned(),
            Err(source) => {
                return Err(ReportError::Io {
                    path: f.clone(),
                    source,
                });
            }
        };
        match crate::svg::inline(&text, &format!("{id_prefix}{i}-")) {
            Ok(svg) => {
                let name = f
                    .file_name()
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_default();
                let rank = figure_rank(&stem(f));
                if group != Some(rank) {
                    if group.is_some() {
                        body.push_str("</div>");
                    }
                    let _ = write!(
                        body,
                        "<h3>{}</h3><div class=\"figs\">",
                        esc(group_title(rank))
                    );
                    group = Some(rank);
                }
                let id = id_of("figure-", &name);
                let cap_id = format!("{id}-caption");
                let svg = named_svg(&svg, &caption(f), &cap_id);
                let _ = write!(
                    body,
                    "<figure id=\"{}\" data-file=\"{}\">{svg}<figcaption id=\"{}\">{} <code>{}</code></figcaption></figure>",
                    esc(&id),
                    esc(&name),
                    esc(&cap_id),
                    esc(&caption(f)),
                    esc(&name)
                );
                index.push(format!(
                    "<a href=\"#{}\">{}</a>",
                    esc(&id),
                    esc(&caption(f))
                ));
            }
            Err(e) => notes.push(format!("figure {} left out: {e}", f.display())),
        }
    }
    if group.is_some() {
        body.push_str("</div>");
    }
    let n = index.len();
    let s = if n > 1 {
        format!("<nav class=\"figindex\">{}</nav>{body}", index.join(""))
    } else {
        body
    };
    Ok((s, n))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn captions_name_the_figure_kind() {
        for (f, c) in [
            ("trajectories_zz10_10_ps.svg", "Trajectories — zz10_10_ps"),
            ("coefficient_convergence.svg", "Coefficient convergence"),
            (
                "vif_reduced32.svg",
                "Variance inflation factor per term — reduced32",
            ),
            ("some_other-plot.svg", "Some other plot"),
            (
                "tc35_ps-tracks.svg",
                "Tracks before and after the effect — tc35_ps",
            ),
        ] {
            assert_eq!(caption(Path::new(f)), c);
        }
    }
}
