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
    #[error("no column `{0}`")]
    NoColumn(String),
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
        let csv_tmp = csv_path.with_extension("csv.tmp");
        let pq_tmp = pq_path.with_extension("parquet.tmp");
        let name = |p: &Path| p.display().to_string();
        {
            let mut f =
                std::fs::File::create(&csv_tmp).map_err(|e| TableError::Io(name(&csv_tmp), e))?;
            CsvWriter::new(&mut f)
                .finish(&mut df)
                .map_err(|e| TableError::Polars(name(&csv_path), e))?;
        }
        {
            let f = std::fs::File::create(&pq_tmp).map_err(|e| TableError::Io(name(&pq_tmp), e))?;
            ParquetWriter::new(f)
                .finish(&mut df)
                .map_err(|e| TableError::Polars(name(&pq_path), e))?;
        }
        std::fs::rename(&csv_tmp, &csv_path).map_err(|e| TableError::Io(name(&csv_path), e))?;
        std::fs::rename(&pq_tmp, &pq_path).map_err(|e| TableError::Io(name(&pq_path), e))?;
        Ok(())
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

    /// Markdown pivot: one row per distinct value of `rows`, one column per distinct value of `cols`,
    /// cells `value` (formatted with `fmt`), in order of first appearance.
    pub fn pivot_markdown(
        &self,
        rows: &str,
        cols: &str,
        value: &str,
        fmt: impl Fn(f64) -> String,
    ) -> Result<String, TableError> {
        let get = |n: &str| self.column(n).ok_or_else(|| TableError::NoColumn(n.into()));
        let (rc, cc, vc) = (get(rows)?, get(cols)?, get(value)?);
        let mut row_keys: Vec<String> = Vec::new();
        let mut col_keys: Vec<String> = Vec::new();
        let mut cells: BTreeMap<(String, String), String> = BTreeMap::new();
        for i in 0..self.rows() {
            let (r, c) = (rc.cell(i), cc.cell(i));
            if !row_keys.contains(&r) {
                row_keys.push(r.clone());
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
        let mut out = format!("| {rows} | {} |\n", col_keys.join(" | "));
        out.push_str(&format!("|---|{}\n", "---|".repeat(col_keys.len())));
        for r in &row_keys {
            let line: Vec<String> = col_keys
                .iter()
                .map(|c| {
                    cells
                        .get(&(r.clone(), c.clone()))
                        .cloned()
                        .unwrap_or_default()
                })
                .collect();
            out.push_str(&format!("| {r} | {} |\n", line.join(" | ")));
        }
        Ok(out)
    }
}

/// |fresh − reference| ≤ abs + rel·|reference|, per numeric column.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    pub abs: f64,
    pub rel: f64,
}

/// Differences between a fresh table and a reference one. Text columns must match exactly; numeric
/// columns within their tolerance (`default` when not listed; `None` in `per_column` ignores a column);
/// a value present on one side only is a difference, and so is a column the reference lacks (a
/// column added since the reference was stored would otherwise go unchecked until the next bless).
pub fn compare(
    fresh: &Table,
    reference: &Table,
    per_column: &BTreeMap<String, Option<Tolerance>>,
    default: Tolerance,
) -> Vec<String> {
    let mut diffs = Vec::new();
    if fresh.rows() != reference.rows() {
        diffs.push(format!(
            "{} rows, reference has {}",
            fresh.rows(),
            reference.rows()
        ));
        return diffs;
    }
    for (name, _) in &fresh.columns {
        if reference.column(name).is_none() && per_column.get(name) != Some(&None) {
            diffs.push(format!(
                "column `{name}` is not in the reference (new since it was stored?)"
            ));
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
        for i in 0..reference.rows() {
            let (f, r) = (fcol.cell(i), rcol.cell(i));
            let same = match (f.parse::<f64>(), r.parse::<f64>()) {
                (Ok(a), Ok(b)) => {
                    (a - b).abs() <= tol.abs + tol.rel * b.abs() || (a.is_nan() && b.is_nan())
                }
                _ => f == r,
            };
            if !same {
                diffs.push(format!("row {}: `{name}` = {f}, reference {r}", i + 1));
            }
        }
    }
    diffs
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let d = compare(&fresh, &sample(), &tol, Tolerance { abs: 0.0, rel: 0.0 });
        assert_eq!(
            d,
            vec![
                "row 2: `mrae` = 0.3, reference ".to_string(),
                "row 3: `mrae` = 0.26, reference 0.25".to_string()
            ]
        );
        let ignore = BTreeMap::from([("mrae".to_string(), None)]);
        assert!(compare(&fresh, &sample(), &ignore, Tolerance { abs: 0.0, rel: 0.0 }).is_empty());
    }

    #[test]
    fn a_column_missing_from_either_side_is_a_difference_unless_ignored() {
        let exact = Tolerance { abs: 0.0, rel: 0.0 };
        let mut wider = sample();
        wider.push_num("epsilon", vec![Some(1.0), None, Some(2.0)]);
        let none = BTreeMap::new();
        assert_eq!(
            compare(&wider, &sample(), &none, exact),
            vec!["column `epsilon` is not in the reference (new since it was stored?)".to_string()]
        );
        assert_eq!(
            compare(&sample(), &wider, &none, exact),
            vec!["column `epsilon` is missing".to_string()]
        );
        let ignore = BTreeMap::from([("epsilon".to_string(), None)]);
        assert!(compare(&wider, &sample(), &ignore, exact).is_empty());
    }

    #[test]
    fn pivot_in_order_of_appearance() {
        let md = sample()
            .pivot_markdown("case", "test", "mrae", |x| format!("{:.0}%", 100.0 * x))
            .unwrap();
        assert_eq!(
            md,
            "| case | zz | tc |\n|---|---|---|\n| a | 10% | – |\n| b | 25% |  |\n"
        );
    }
}
