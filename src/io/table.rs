//! The one reader and writer of our CSV files (plans, sweeps, simulate results, settles): text
//! with a header row, fields trimmed, columns found by name, and every read error naming the
//! file, the line and the column with what was expected.

use crate::error::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// A CSV file read whole: its header and its records, each with its line number.
#[derive(Debug, Clone)]
pub struct Table {
    path: PathBuf,
    headers: csv::StringRecord,
    records: Vec<(usize, csv::StringRecord)>,
}

/// An error in line `line` of the CSV file `path`.
pub(crate) fn row_error(path: &Path, line: usize, message: String) -> Error {
    Error::Row {
        file: path.to_path_buf(),
        line,
        message,
    }
}

impl Table {
    /// Reads the file at `path`.
    pub fn read(path: &Path) -> Result<Table> {
        let text = crate::io::input::text(path)?;
        Table::parse(&text, path)
    }

    /// Parses CSV text (`path` names it in errors). A row with another number of fields than
    /// the header is an error.
    pub fn parse(text: &str, path: &Path) -> Result<Table> {
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(true)
            .trim(csv::Trim::All)
            .from_reader(text.as_bytes());
        let headers = rdr
            .headers()
            .map_err(|e| row_error(path, 1, format!("unreadable header: {e}")))?
            .clone();
        let mut records = Vec::new();
        for rec in rdr.records() {
            let rec = rec.map_err(|e| {
                let line = e.position().map(|p| p.line() as usize).unwrap_or(0);
                row_error(path, line, format!("malformed CSV row: {e}"))
            })?;
            let line = rec.position().map(|p| p.line() as usize).unwrap_or(0);
            records.push((line, rec));
        }
        Ok(Table {
            path: path.to_path_buf(),
            headers,
            records,
        })
    }

    /// The index of column `name`, if the header has it.
    pub fn column(&self, name: &str) -> Option<usize> {
        self.headers.iter().position(|h| h == name)
    }

    /// The index of column `name`, or an error saying the header lacks it (`hint` is appended).
    pub fn require(&self, name: &str, hint: &str) -> Result<usize> {
        self.column(name)
            .ok_or_else(|| self.error(1, format!("expected a column `{name}` in the header{hint}")))
    }

    /// An error in line `line` of this file.
    pub fn error(&self, line: usize, message: String) -> Error {
        row_error(&self.path, line, message)
    }

    /// The records, in file order.
    pub fn rows(&self) -> impl Iterator<Item = Row<'_>> {
        self.records.iter().map(move |(line, rec)| Row {
            table: self,
            line: *line,
            rec,
        })
    }

    /// An error unless the file has at least one record (`what` names them).
    pub fn require_rows(&self, what: &str) -> Result<()> {
        match self.records.is_empty() {
            true => Err(self.error(2, format!("expected at least one {what} row"))),
            false => Ok(()),
        }
    }
}

/// One record of a [`Table`].
#[derive(Debug, Clone, Copy)]
pub struct Row<'a> {
    table: &'a Table,
    /// The line of the file it stands on.
    pub line: usize,
    rec: &'a csv::StringRecord,
}

impl Row<'_> {
    /// The text of column `col` (empty when missing).
    pub fn get(&self, col: usize) -> &str {
        self.rec.get(col).unwrap_or("")
    }

    /// The record's fields.
    pub fn fields(&self) -> Vec<String> {
        self.rec.iter().map(str::to_string).collect()
    }

    /// An error in this record's line.
    pub fn error(&self, message: String) -> Error {
        self.table.error(self.line, message)
    }

    /// Column `col` (named `name`) as a number; NaN and infinities are accepted.
    pub fn number(&self, col: usize, name: &str) -> Result<f64> {
        let s = self.get(col);
        s.parse::<f64>()
            .map_err(|_| self.error(format!("column `{name}`: expected a number, got '{s}'")))
    }

    /// Column `col` (named `name`) as a finite number.
    pub fn finite(&self, col: usize, name: &str) -> Result<f64> {
        let s = self.get(col);
        s.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| {
                self.error(format!(
                    "column `{name}`: expected a finite number, got '{s}'"
                ))
            })
    }

    /// Column `col` as a step number (0, 1, ...).
    pub fn step(&self, col: usize) -> Result<usize> {
        let s = self.get(col);
        s.parse::<usize>().map_err(|_| {
            self.error(format!(
                "column `step`: expected a step number (0, 1, ...), got '{s}'"
            ))
        })
    }
}

/// CSV bytes: `header`, then one line per record (`what` names the output in errors).
pub fn csv_bytes<R, F>(what: &str, header: &[&str], records: R) -> Result<Vec<u8>>
where
    R: IntoIterator<Item = Vec<F>>,
    F: AsRef<[u8]>,
{
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(header).map_err(|e| Error::csv(what, e))?;
    for r in records {
        w.write_record(r).map_err(|e| Error::csv(what, e))?;
    }
    w.into_inner().map_err(|e| Error::io(what, e.into_error()))
}

/// Writes [`csv_bytes`] to `out`.
pub fn write_csv<R, F>(out: &mut dyn Write, what: &str, header: &[&str], records: R) -> Result<()>
where
    R: IntoIterator<Item = Vec<F>>,
    F: AsRef<[u8]>,
{
    let bytes = csv_bytes(what, header, records)?;
    out.write_all(&bytes).map_err(|e| Error::io(what, e))
}
