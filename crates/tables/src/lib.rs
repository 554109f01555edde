//! Result tables of studies: a small column-oriented [`Table`] that the runner fills, written as CSV and
//! Parquet through polars (atomically), read back from CSV for regression checks, compared under
//! per-column tolerances, and pivoted into markdown tables in the layout of paper 000.
//!
//! polars stays inside this crate: it is the one dependency that costs minutes of build time.

use std::collections::BTreeMap;
use std::path::Path;

use polars::prelude::{Column as PlColumn, CsvWriter, DataFrame, ParquetWriter, SerWriter};

/// One column: numbers (missing values allowed) or text.
#[derive(Debug, Clone, PartialEq)]
pub enum Column {
    Num(Vec<Option<f64>>),
    Text(Vec<String>),
}

impl Column {
    pub fn len(&self) -> usize {
        match self {
            Column::Num(v) => v.len(),
            Column::Text(v) => v.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The cell as text (numbers in shortest round-trip form, missing as "").
    pub fn cell(&self, i: usize) -> String {
        match self {
            Column::Num(v) => v
                .get(i)
                .copied()
                .flatten()
                .map(|x| format!("{x}"))
                .unwrap_or_default(),
            Column::Text(v) => v.get(i).cloned().unwrap_or_default(),
        }
    }
}

/// Named columns of equal length, in order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Table {
    pub columns: Vec<(String, Column)>,
}

#[derive(Debug, thiserror::Error)]
pub enum TableError {
    #[error("{0}: {1}")]
    Io(String, std::io::Error),
    #[error("{0}: {1}")]
    Polars(String, polars::error::PolarsError),
    #[error("{0}: {1}")]
    Csv(String, csv::Error),
    #[error("column `{0}` has {1} rows, the table {2}")]
    Ragged(String, usize, usize),
    #[error("no column `{name}` (the table has {})", known.join(", "))]
    NoColumn { name: String, known: Vec<String> },
    #[error(
        "`{0}`: expected ROWS,COLS,VALUE (ROWS and COLS may join columns with +), e.g. window,test,mrae"
    )]
    BadPivot(String),
    /// A pivot would show only the last of several rows in one cell.
    #[error("{0}")]
    Collision(Box<Collision>),
}

/// Several rows of a table that a pivot would put in one cell.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Collision {
    /// The pivot's row and column columns (joined by +) and the cell's labels.
    pub rows: String,
    pub row: String,
    pub cols: String,
    pub col: String,
    /// How many table rows fall into the cell.
    pub count: usize,
    /// Their keys (case ids), each once, in order of appearance.
    pub keys: Vec<String>,
}

impl std::fmt::Display for Collision {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} rows fall into one cell ({} `{}`, {} `{}`), so all but the last would vanish: {}",
            self.count,
            self.rows,
            self.row,
            self.cols,
            self.col,
            short_list(&self.keys)
        )
    }
}

/// The first few of `keys` and how many more.
fn short_list(keys: &[String]) -> String {
    const SHOWN: usize = 4;
    let mut s = keys
        .iter()
        .take(SHOWN)
        .cloned()
        .collect::<Vec<_>>()
        .join(", ");
    if keys.len() > SHOWN {
        s.push_str(&format!(" and {} more", keys.len() - SHOWN));
    }
    s
}

impl Table {
    pub fn rows(&self) -> usize {
        self.columns.first().map_or(0, |(_, c)| c.len())
    }

    pub fn column(&self, name: &str) -> Option<&Column> {
        self.columns.iter().find(|(n, _)| n == name).map(|(_, c)| c)
    }

    pub fn push_num(&mut self, name: &str, values: Vec<Option<f64>>) {
        self.columns.push((name.into(), Column::Num(values)));
    }

    pub fn push_text(&mut self, name: &str, values: Vec<String>) {
        self.columns.push((name.into(), Column::Text(values)));
    }

    fn check_shape(&self) -> Result<(), TableError> {
        let n = self.rows();
        for (name, c) in &self.columns {
            if c.len() != n {
                return Err(TableError::Ragged(name.clone(), c.len(), n));
            }
        }
        Ok(())
    }

    fn frame(&self) -> Result<DataFrame, TableError> {
        self.check_shape()?;
        let cols: Vec<PlColumn> = self
            .columns
            .iter()
            .map(|(name, c)| match c {
                Column::Num(v) => PlColumn::new(name.as_str().into(), v.as_slice()),
                Column::Text(v) => PlColumn::new(name.as_str().into(), v.as_slice()),
            })
            .collect();
        DataFrame::new_infer_height(cols)
            .map_err(|e| TableError::Polars("building the table".into(), e))
    }

    /// Write `dir/stem.csv` and `dir/stem.parquet`, each atomically.
    pub fn write(&self, dir: &Path, stem: &str) -> Result<(), TableError> {
        let mut df = self.frame()?;
        std::fs::create_dir_all(dir).map_err(|e| TableError::Io(dir.display().to_string(), e))?;
        let csv_path = dir.join(format!("{stem}.csv"));
        let pq_path = dir.join(format!("{stem}.parquet"));
        let csv_tmp = unique_tmp(&csv_path);
        let pq_tmp = unique_tmp(&pq_path);
        let name = |p: &Path| p.display().to_string();
        let written = (|| {
            let mut f =
                std::fs::File::create(&csv_tmp).map_err(|e| TableError::Io(name(&csv_tmp), e))?;
            CsvWriter::new(&mut f)
                .finish(&mut df)
                .map_err(|e| TableError::Polars(name(&csv_path), e))?;
            let f = std::fs::File::create(&pq_tmp).map_err(|e| TableError::Io(name(&pq_tmp), e))?;
            ParquetWriter::new(f)
                .finish(&mut df)
                .map_err(|e| TableError::Polars(name(&pq_path), e))?;
            std::fs::rename(&csv_tmp, &csv_path).map_err(|e| TableError::Io(name(&csv_path), e))?;
            std::fs::rename(&pq_tmp, &pq_path).map_err(|e| TableError::Io(name(&pq_path), e))
        })();
        if written.is_err() {
            // A failed write leaves no temporary file behind (a renamed one is simply gone).
            let _ = std::fs::remove_file(&csv_tmp);
            let _ = std::fs::remove_file(&pq_tmp);
        }
        written
    }

    /// Read a CSV written by [`Table::write`]: a column whose every non-empty cell is a number is numeric.
    pub fn read_csv(path: &Path) -> Result<Table, TableError> {
        let name = path.display().to_string();
        let mut r = csv::Reader::from_path(path).map_err(|e| TableError::Csv(name.clone(), e))?;
        let headers: Vec<String> = r
            .headers()
            .map_err(|e| TableError::Csv(name.clone(), e))?
            .iter()
            .map(String::from)
            .collect();
        let mut raw: Vec<Vec<String>> = vec![Vec::new(); headers.len()];
        for rec in r.records() {
            let rec = rec.map_err(|e| TableError::Csv(name.clone(), e))?;
            for (j, cell) in rec.iter().enumerate().take(headers.len()) {
                raw[j].push(cell.to_string());
            }
        }
        let columns = headers
            .into_iter()
            .zip(raw)
            .map(|(h, cells)| {
                let numeric = cells
                    .iter()
                    .all(|c| c.is_empty() || c.parse::<f64>().is_ok())
                    && cells.iter().any(|c| !c.is_empty());
                let col = if numeric {
                    Column::Num(cells.iter().map(|c| c.parse::<f64>().ok()).collect())
                } else {
                    Column::Text(cells)
                };
                (h, col)
            })
            .collect();
        Ok(Table { columns })
    }

    /// Markdown pivot: one row per distinct combination of the `rows` columns, one column per
    /// distinct combination of the `cols` columns, cells `value` (formatted with `fmt`), in order of
    /// first appearance. Two table rows never share a cell: a pivot that would put them in one (and
    /// so show only the last) is refused, naming them by their `key` column (a case id).
    pub fn pivot_markdown(
        &self,
        pivot: &Pivot,
        key: &str,
        fmt: impl Fn(f64) -> String,
    ) -> Result<String, TableError> {
        let vc = self.get(&pivot.value)?;
        if let Some(c) = self
            .collisions(&pivot.rows, &pivot.cols, key)?
            .into_iter()
            .next()
        {
            return Err(c);
        }
        let row_label = self.labeller(&pivot.rows)?;
        let col_label = self.labeller(&pivot.cols)?;
        let col_columns = pivot
            .cols
            .iter()
            .map(|n| self.get(n))
            .collect::<Result<Vec<_>, _>>()?;
        let mut row_keys: Vec<String> = Vec::new();
        let mut col_keys: Vec<String> = Vec::new();
        let mut cells: BTreeMap<(String, String), String> = BTreeMap::new();
        for i in 0..self.rows() {
            let (r, c) = (row_label(i), col_label(i));
            if !row_keys.contains(&r) {
                row_keys.push(r.clone());
            }
            // A row with no column key at all (a study case whose fit failed has no test) keeps its
            // row but makes no column: a "–" column would read as a test of that name.
            if col_columns.iter().all(|col| col.cell(i).is_empty()) {
                continue;
            }
            if !col_keys.contains(&c) {
                col_keys.push(c.clone());
            }
            let v = match vc {
                Column::Num(v) => v[i].map_or("–".to_string(), &fmt),
                Column::Text(v) => v[i].clone(),
            };
            cells.insert((r, c), v);
        }
        let header: Vec<String> = col_keys.iter().map(|c| md_escape(c)).collect();
        let mut out = format!(
            "| {} | {} |\n",
            md_escape(&pivot.rows.join(" / ")),
            header.join(" | ")
        );
        out.push_str(&format!("|---|{}\n", "---|".repeat(col_keys.len())));
        for r in &row_keys {
            let line: Vec<String> = col_keys
                .iter()
                .map(|c| {
                    cells
                        .get(&(r.clone(), c.clone()))
                        .map(|v| md_escape(v))
                        .unwrap_or_default()
                })
                .collect();
            out.push_str(&format!("| {} | {} |\n", md_escape(r), line.join(" | ")));
        }
        Ok(out)
    }

    /// The columns of `candidates` (in their order, each only if it splits a crowded cell) that
    /// `rows` needs so that no cell of `rows` × `cols` holds two table rows; an error naming the
    /// rows still together when even all candidates do not separate them.
    pub fn separating_columns(
        &self,
        rows: &[String],
        cols: &[String],
        key: &str,
        candidates: &[&str],
    ) -> Result<Vec<String>, TableError> {
        let mut rows = rows.to_vec();
        let mut added = Vec::new();
        for cand in candidates {
            let crowded = self.crowded_cells(&rows, cols)?;
            if crowded.is_empty() {
                break;
            }
            if rows.iter().any(|r| r == cand) || cols.iter().any(|c| c == cand) {
                continue;
            }
            let Ok(col) = self.get(cand) else { continue };
            let splits = crowded
                .iter()
                .any(|members| members.iter().any(|&i| col.cell(i) != col.cell(members[0])));
            if splits {
                rows.push(cand.to_string());
                added.push(cand.to_string());
            }
        }
        match self.collisions(&rows, cols, key)?.into_iter().next() {
            Some(c) => Err(c),
            None => Ok(added),
        }
    }

    /// One [`TableError::Collision`] per cell of `rows` × `cols` that holds more than one row.
    fn collisions(
        &self,
        rows: &[String],
        cols: &[String],
        key: &str,
    ) -> Result<Vec<TableError>, TableError> {
        let kc = self.get(key)?;
        let row_label = self.labeller(rows)?;
        let col_label = self.labeller(cols)?;
        Ok(self
            .crowded_cells(rows, cols)?
            .into_iter()
            .map(|members| {
                let mut keys: Vec<String> = Vec::new();
                for &i in &members {
                    let k = kc.cell(i);
                    if !keys.contains(&k) {
                        keys.push(k);
                    }
                }
                TableError::Collision(Box::new(Collision {
                    rows: rows.join("+"),
                    row: row_label(members[0]),
                    cols: cols.join("+"),
                    col: col_label(members[0]),
                    count: members.len(),
                    keys,
                }))
            })
            .collect())
    }

    /// The table rows of every cell of `rows` × `cols` that holds more than one, in order of first
    /// appearance.
    fn crowded_cells(
        &self,
        rows: &[String],
        cols: &[String],
    ) -> Result<Vec<Vec<usize>>, TableError> {
        let row_label = self.labeller(rows)?;
        let col_label = self.labeller(cols)?;
        let mut order: Vec<(String, String)> = Vec::new();
        let mut members: BTreeMap<(String, String), Vec<usize>> = BTreeMap::new();
        for i in 0..self.rows() {
            let cell = (row_label(i), col_label(i));
            let m = members.entry(cell.clone()).or_default();
            if m.is_empty() {
                order.push(cell);
            }
            m.push(i);
        }
        Ok(order
            .into_iter()
            .filter_map(|c| members.remove(&c).filter(|m| m.len() > 1))
            .collect())
    }

    fn get(&self, name: &str) -> Result<&Column, TableError> {
        self.column(name).ok_or_else(|| TableError::NoColumn {
            name: name.into(),
            known: self.columns.iter().map(|(n, _)| n.clone()).collect(),
        })
    }

    /// The label of row `i` over `names` (their cells joined by " / ", an empty one as "–").
    fn labeller(&self, names: &[String]) -> Result<impl Fn(usize) -> String + '_, TableError> {
        let cols = names
            .iter()
            .map(|n| self.get(n))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(move |i: usize| {
            cols.iter()
                .map(|c| {
                    let cell = c.cell(i);
                    if cell.is_empty() {
                        "–".to_string()
                    } else {
                        cell
                    }
                })
                .collect::<Vec<_>>()
                .join(" / ")
        })
    }
}

/// A name from the data as a markdown table cell: a `|` would end the cell (and split the row into
/// more cells than the header has), and markdown renderers pass HTML through, so a recording named
/// `<svg onload=…>` would become markup. Both are escaped (`\|`, `&lt;`, `&gt;`, `&amp;`, and `\\`
/// so that a name's own backslash cannot unescape a pipe); a line break, which would end the row,
/// becomes a space.
pub fn md_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for ch in s.chars() {
        match ch {
            // A backslash first, so that a name ending in one cannot unescape the `\|` after it.
            '\\' => out.push_str("\\\\"),
            '|' => out.push_str("\\|"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '&' => out.push_str("&amp;"),
            '\n' | '\r' => out.push(' '),
            c => out.push(c),
        }
    }
    out
}

/// A temporary name beside `path`, unique per process and call: two writers of one table (two runs,
/// two threads) must never share one, or one renames the other's half-written file into place.
fn unique_tmp(path: &Path) -> std::path::PathBuf {
    static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let name = path
        .file_name()
        .map(|f| f.to_string_lossy())
        .unwrap_or_default();
    path.with_file_name(format!("{name}.{}-{n}.tmp", std::process::id()))
}

/// Which columns a markdown pivot puts in its rows and columns and which one in its cells.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Pivot {
    pub rows: Vec<String>,
    pub cols: Vec<String>,
    pub value: String,
}

impl std::str::FromStr for Pivot {
    type Err = TableError;

    /// `ROWS,COLS,VALUE`, where ROWS and COLS may each join several columns with `+`
    /// (`set+estimator,test,mrae`).
    fn from_str(text: &str) -> Result<Pivot, TableError> {
        let bad = || TableError::BadPivot(text.to_string());
        let parts: Vec<&str> = text.split(',').map(str::trim).collect();
        let [rows, cols, value] = parts.as_slice() else {
            return Err(bad());
        };
        let names = |s: &str| -> Result<Vec<String>, TableError> {
            let v: Vec<String> = s.split('+').map(|n| n.trim().to_string()).collect();
            if v.iter().any(String::is_empty) {
                return Err(bad());
            }
            Ok(v)
        };
        if value.is_empty() || value.contains('+') {
            return Err(bad());
        }
        Ok(Pivot {
            rows: names(rows)?,
            cols: names(cols)?,
            value: value.to_string(),
        })
    }
}

/// |fresh − reference| ≤ abs + rel·|reference|, per numeric column.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    pub abs: f64,
    pub rel: f64,
}

/// Differences between a fresh table and a reference one, row by row as `key` (columns that together
/// name a row: a case and its test) pairs them, so a reference stored in another row order still
/// matches. Text columns must match exactly; numeric columns within their tolerance (`default` when
/// not listed; `None` in `per_column` ignores a column); a value present on one side only is a
/// difference, and so is a column the reference lacks (a column added since the reference was stored
/// would otherwise go unchecked until the next bless), and a row of either side that the other lacks
/// (named by its key). A key column missing from either table is an error.
///
/// The reference is trusted to hold finite numbers: |fresh − ∞| ≤ abs + rel·∞ holds for any fresh
/// value, so callers refuse a reference with [`Table::non_finite_cell`] first. Cells that parse as
/// numbers in a text column are compared as numbers only when both are finite, as text otherwise.
pub fn compare(
    fresh: &Table,
    reference: &Table,
    key: &[&str],
    per_column: &BTreeMap<String, Option<Tolerance>>,
    default: Tolerance,
) -> Result<Vec<String>, TableError> {
    let mut diffs = Vec::new();
    let fresh_rows = keyed_rows(fresh, key)?;
    let reference_rows = keyed_rows(reference, key)?;
    for (name, _) in &fresh.columns {
        if reference.column(name).is_none() && per_column.get(name) != Some(&None) {
            diffs.push(format!(
                "column `{name}` is not in the reference (new since it was stored?)"
            ));
        }
    }
    let fresh_index: BTreeMap<&String, usize> =
        fresh_rows.iter().enumerate().map(|(i, k)| (k, i)).collect();
    let reference_index: BTreeMap<&String, usize> = reference_rows
        .iter()
        .enumerate()
        .map(|(i, k)| (k, i))
        .collect();
    for (i, k) in reference_rows.iter().enumerate() {
        if !fresh_index.contains_key(k) {
            diffs.push(format!(
                "row {} ({k}) of the reference is not in the fresh run",
                i + 1
            ));
        }
    }
    for k in &fresh_rows {
        if !reference_index.contains_key(k) {
            diffs.push(format!("the fresh run's row ({k}) is not in the reference"));
        }
    }
    for (name, rcol) in &reference.columns {
        let tol = match per_column.get(name) {
            Some(None) => continue,
            Some(Some(t)) => *t,
            None => default,
        };
        let Some(fcol) = fresh.column(name) else {
            diffs.push(format!("column `{name}` is missing"));
            continue;
        };
        for (ri, k) in reference_rows.iter().enumerate() {
            let Some(&fi) = fresh_index.get(k) else {
                continue;
            };
            let (f, r) = (fcol.cell(fi), rcol.cell(ri));
            let finite = |c: &str| c.parse::<f64>().ok().filter(|x| x.is_finite());
            let same = match (finite(&f), finite(&r)) {
                (Some(a), Some(b)) => (a - b).abs() <= tol.abs + tol.rel * b.abs(),
                _ => f == r,
            };
            if !same {
                diffs.push(format!(
                    "row {} ({k}): `{name}` = {f}, reference {r}",
                    ri + 1
                ));
            }
        }
    }
    Ok(diffs)
}

/// Each row's key (`case `x`, test `y``), with ` #n` added to the second and later rows of one key,
/// so that rows repeating a key are still paired in order.
fn keyed_rows(t: &Table, key: &[&str]) -> Result<Vec<String>, TableError> {
    let cols = key
        .iter()
        .map(|n| t.get(n))
        .collect::<Result<Vec<_>, _>>()?;
    let mut seen: BTreeMap<String, usize> = BTreeMap::new();
    Ok((0..t.rows())
        .map(|i| {
            let k = key
                .iter()
                .zip(&cols)
                .map(|(n, c)| format!("{n} `{}`", c.cell(i)))
                .collect::<Vec<_>>()
                .join(", ");
            let n = seen.entry(k.clone()).or_default();
            *n += 1;
            if *n > 1 { format!("{k} #{n}") } else { k }
        })
        .collect())
}

impl Table {
    /// The first numeric cell that is infinite (`inf`, `-inf`, `Infinity`, `1e309`): its row (from
    /// 1, the header not counted), column and value. A `NaN` is not one: it equals only a `NaN`
    /// under [`compare`], so it cannot let a fresh value pass.
    pub fn non_finite_cell(&self) -> Option<(usize, &str, String)> {
        for i in 0..self.rows() {
            for (name, c) in &self.columns {
                if let Column::Num(v) = c
                    && v[i].is_some_and(f64::is_infinite)
                {
                    return Some((i + 1, name.as_str(), c.cell(i)));
                }
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const KEY: [&str; 2] = ["case", "test"];

    fn sample() -> Table {
        let mut t = Table::default();
        t.push_text("case", vec!["a".into(), "a".into(), "b".into()]);
        t.push_text("test", vec!["zz".into(), "tc".into(), "zz".into()]);
        t.push_num("mrae", vec![Some(0.1), None, Some(0.25)]);
        t
    }

    #[test]
    fn csv_round_trip_and_parquet_written() {
        let dir = tempfile::tempdir().unwrap();
        sample().write(dir.path(), "summary").unwrap();
        assert!(dir.path().join("summary.parquet").metadata().unwrap().len() > 0);
        let back = Table::read_csv(&dir.path().join("summary.csv")).unwrap();
        assert_eq!(back, sample());
    }

    #[test]
    fn compare_uses_tolerances_and_reports_each_difference() {
        let mut fresh = sample();
        fresh.columns[2].1 = Column::Num(vec![Some(0.1 + 1e-9), Some(0.3), Some(0.26)]);
        let tol = BTreeMap::from([(
            "mrae".to_string(),
            Some(Tolerance {
                abs: 1e-6,
                rel: 0.0,
            }),
        )]);
        let exact = Tolerance { abs: 0.0, rel: 0.0 };
        let d = compare(&fresh, &sample(), &KEY, &tol, exact).unwrap();
        assert_eq!(
            d,
            vec![
                "row 2 (case `a`, test `tc`): `mrae` = 0.3, reference ".to_string(),
                "row 3 (case `b`, test `zz`): `mrae` = 0.26, reference 0.25".to_string()
            ]
        );
        let ignore = BTreeMap::from([("mrae".to_string(), None)]);
        assert!(
            compare(&fresh, &sample(), &KEY, &ignore, exact)
                .unwrap()
                .is_empty()
        );
    }

    #[test]
    fn a_column_missing_from_either_side_is_a_difference_unless_ignored() {
        let exact = Tolerance { abs: 0.0, rel: 0.0 };
        let mut wider = sample();
        wider.push_num("epsilon", vec![Some(1.0), None, Some(2.0)]);
        let none = BTreeMap::new();
        assert_eq!(
            compare(&wider, &sample(), &KEY, &none, exact).unwrap(),
            vec!["column `epsilon` is not in the reference (new since it was stored?)".to_string()]
        );
        assert_eq!(
            compare(&sample(), &wider, &KEY, &none, exact).unwrap(),
            vec!["column `epsilon` is missing".to_string()]
        );
        let ignore = BTreeMap::from([("epsilon".to_string(), None)]);
        assert!(
            compare(&wider, &sample(), &KEY, &ignore, exact)
                .unwrap()
                .is_empty()
        );
    }

    /// The rows of `t` in the order `order` gives (indices into its rows).
    fn reordered(t: &Table, order: &[usize]) -> Table {
        let mut r = Table::default();
        for (name, c) in &t.columns {
            let col = match c {
                Column::Num(v) => Column::Num(order.iter().map(|&i| v[i]).collect()),
                Column::Text(v) => Column::Text(order.iter().map(|&i| v[i].clone()).collect()),
            };
            r.columns.push((name.clone(), col));
        }
        r
    }

    /// Regression: rows were compared by position, so a reference stored in another order gave a
    /// difference per cell, and a missing row only "N rows, reference has M".
    #[test]
    fn a_reordered_reference_matches_and_a_missing_or_extra_row_is_named_by_its_key() {
        let exact = Tolerance { abs: 0.0, rel: 0.0 };
        let none = BTreeMap::new();
        let shuffled = reordered(&sample(), &[2, 0, 1]);
        assert!(
            compare(&sample(), &shuffled, &KEY, &none, exact)
                .unwrap()
                .is_empty()
        );
        let fewer = reordered(&sample(), &[2, 0]);
        assert_eq!(
            compare(&sample(), &fewer, &KEY, &none, exact).unwrap(),
            vec!["the fresh run's row (case `a`, test `tc`) is not in the reference".to_string()]
        );
        assert_eq!(
            compare(&fewer, &sample(), &KEY, &none, exact).unwrap(),
            vec![
                "row 2 (case `a`, test `tc`) of the reference is not in the fresh run".to_string()
            ]
        );
        let err = compare(&sample(), &sample(), &["case", "dof"], &none, exact).unwrap_err();
        assert!(err.to_string().starts_with("no column `dof`"), "{err}");
    }

    /// Regression: |fresh − ∞| ≤ abs + rel·∞ holds for every fresh value, so a reference of `inf`
    /// cells passed any run. Infinite cells are found (whatever their spelling); a number in a text
    /// column is compared as text when either side is not finite.
    #[test]
    fn an_infinite_reference_cell_is_found_and_never_passes_a_comparison() {
        let dir = tempfile::tempdir().unwrap();
        for (cell, shown) in [
            ("inf", "inf"),
            ("-inf", "-inf"),
            ("Infinity", "inf"),
            ("1e309", "inf"),
        ] {
            let path = dir.path().join("summary.csv");
            std::fs::write(&path, format!("case,test,mrae\na,zz,0.1\nb,tc,{cell}\n")).unwrap();
            let t = Table::read_csv(&path).unwrap();
            assert_eq!(
                t.non_finite_cell(),
                Some((2, "mrae", shown.into())),
                "{cell}"
            );
        }
        let mut nan = sample();
        nan.columns[2].1 = Column::Num(vec![Some(f64::NAN), None, Some(0.25)]);
        assert_eq!(nan.non_finite_cell(), None, "NaN equals only NaN");
        let wide = Tolerance { abs: 1.0, rel: 1.0 };
        let none = BTreeMap::new();
        assert_eq!(
            compare(&sample(), &nan, &KEY, &none, wide).unwrap().len(),
            1
        );
        let mut text = Table::default();
        text.push_text("case", vec!["a".into()]);
        text.push_text("test", vec!["zz".into()]);
        text.push_text("x", vec!["inf".into()]);
        let mut fresh = text.clone();
        fresh.columns[2].1 = Column::Text(vec!["0.5".into()]);
        assert_eq!(
            compare(&fresh, &text, &KEY, &none, wide).unwrap(),
            vec!["row 1 (case `a`, test `zz`): `x` = 0.5, reference inf".to_string()]
        );
    }

    /// Regression: `|` in a recording's name split a markdown row into more cells than its header,
    /// and HTML in a name went into the markdown as markup.
    #[test]
    fn names_with_pipes_and_html_are_escaped_in_a_markdown_pivot() {
        let mut t = Table::default();
        t.push_text("case", vec!["a".into(), "b".into()]);
        t.push_text(
            "training",
            vec!["tr|ain.csv".into(), "<svg onload=x>".into()],
        );
        t.push_text("test", vec!["sb|x.csv".into(), "sb|x.csv".into()]);
        t.push_num("mrae", vec![Some(0.1), Some(0.2)]);
        let md = t
            .pivot_markdown(&pivot("training,test,mrae"), "case", |x| format!("{x}"))
            .unwrap();
        assert_eq!(
            md,
            "| training | sb\\|x.csv |\n|---|---|\n| tr\\|ain.csv | 0.1 |\n| &lt;svg onload=x&gt; | 0.2 |\n"
        );
        assert_eq!(md_escape("a\\|b & c"), "a\\\\\\|b &amp; c");
    }

    fn pivot(text: &str) -> Pivot {
        text.parse().unwrap()
    }

    #[test]
    fn pivot_in_order_of_appearance() {
        let md = sample()
            .pivot_markdown(&pivot("case,test,mrae"), "case", |x| {
                format!("{:.0}%", 100.0 * x)
            })
            .unwrap();
        assert_eq!(
            md,
            "| case | zz | tc |\n|---|---|---|\n| a | 10% | – |\n| b | 25% |  |\n"
        );
    }

    /// Four cases (two sets × two estimators) with the same window and test.
    fn four_cases() -> Table {
        let mut t = Table::default();
        t.push_text(
            "case",
            ["r-lsq", "r-ridge", "f-lsq", "f-ridge"]
                .map(String::from)
                .to_vec(),
        );
        t.push_text("set", ["r", "r", "f", "f"].map(String::from).to_vec());
        t.push_text(
            "estimator",
            ["lsq", "ridge", "lsq", "ridge"].map(String::from).to_vec(),
        );
        t.push_text("window", vec!["4 OS".to_string(); 4]);
        t.push_text("test", vec!["zz".to_string(); 4]);
        t.push_num("mrae", vec![Some(0.1), Some(0.2), Some(0.3), Some(0.4)]);
        t
    }

    fn check_collision(t: &Table, spec: &str, expected: &str) {
        let err = t
            .pivot_markdown(&pivot(spec), "case", |x| format!("{x}"))
            .unwrap_err();
        assert_eq!(err.to_string(), expected, "{spec}");
    }

    /// Regression: `window,test,mrae` printed one row holding the last case's value, the other
    /// cases gone without a word.
    #[test]
    fn a_pivot_that_puts_two_rows_in_one_cell_is_refused_naming_them() {
        let t = four_cases();
        check_collision(
            &t,
            "window,test,mrae",
            "4 rows fall into one cell (window `4 OS`, test `zz`), so all but the last would vanish: r-lsq, r-ridge, f-lsq, f-ridge",
        );
        check_collision(
            &t,
            "set+window,test,mrae",
            "2 rows fall into one cell (set+window `r / 4 OS`, test `zz`), so all but the last would vanish: r-lsq, r-ridge",
        );
        let md = t
            .pivot_markdown(&pivot("set+estimator,test,mrae"), "case", |x| {
                format!("{x}")
            })
            .unwrap();
        assert_eq!(
            md,
            "| set / estimator | zz |\n|---|---|\n| r / lsq | 0.1 |\n| r / ridge | 0.2 |\n| f / lsq | 0.3 |\n| f / ridge | 0.4 |\n"
        );
    }

    #[test]
    fn separating_columns_are_the_candidates_that_split_a_crowded_cell() {
        let t = four_cases();
        let v = |s: &[&str]| s.iter().map(|x| x.to_string()).collect::<Vec<_>>();
        // `window` is constant, so it is not needed; set and estimator both are.
        assert_eq!(
            t.separating_columns(
                &v(&["window"]),
                &v(&["test"]),
                "case",
                &["window", "set", "estimator"]
            )
            .unwrap(),
            v(&["set", "estimator"])
        );
        assert_eq!(
            t.separating_columns(
                &v(&["estimator"]),
                &v(&["test"]),
                "case",
                &["estimator", "set"]
            )
            .unwrap(),
            v(&["set"])
        );
        let err = t
            .separating_columns(&v(&["window"]), &v(&["test"]), "case", &["set"])
            .unwrap_err();
        assert!(
            err.to_string().starts_with("2 rows fall into one cell"),
            "{err}"
        );
    }

    #[test]
    fn bad_pivots_and_unknown_columns_are_named() {
        for text in [
            "window,test",
            "window,test,mrae,x",
            "window+,test,mrae",
            "a,b,c+d",
            ",test,mrae",
        ] {
            assert_eq!(
                text.parse::<Pivot>().unwrap_err().to_string(),
                format!(
                    "`{text}`: expected ROWS,COLS,VALUE (ROWS and COLS may join columns with +), e.g. window,test,mrae"
                )
            );
        }
        let err = sample()
            .pivot_markdown(&pivot("case,colour,mrae"), "case", |x| format!("{x}"))
            .unwrap_err();
        assert_eq!(
            err.to_string(),
            "no column `colour` (the table has case, test, mrae)"
        );
    }
}
