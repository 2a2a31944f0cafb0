//! Small CSV tables: a header line and rows of comma-separated cells.
//!
//! The stage tables (design, angles, sweep, clusters) hold numbers, ids and
//! short words, never commas or quotes, so a plain split suffices; a quoted
//! cell is refused with its line rather than misread. Numbers are written with
//! Rust's shortest round-trip formatting, so a table re-read gives back the
//! same `f64`s and identical inputs give identical bytes.

use std::fmt;
use std::path::{Path, PathBuf};

/// A parsed table.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// Column names.
    pub header: Vec<String>,
    /// Rows of cells, each as long as the header.
    pub rows: Vec<Vec<String>>,
}

/// Why a table could not be read.
#[derive(Debug, thiserror::Error)]
pub enum TableError {
    /// The file could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The text is not a table of the expected form.
    #[error("{}:{line}: {message}", path.display())]
    Format {
        /// The file.
        path: PathBuf,
        /// 1-based line number (1 is the header).
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A column the caller needs is absent.
    #[error("{}: no column `{name}` (columns: {})", path.display(), columns.join(", "))]
    MissingColumn {
        /// The file.
        path: PathBuf,
        /// The column asked for.
        name: String,
        /// The columns present.
        columns: Vec<String>,
    },
}

impl Table {
    /// Reads and parses `path`.
    pub fn read(path: &Path) -> Result<Table, TableError> {
        let text = std::fs::read_to_string(path).map_err(|source| TableError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Table::parse(&text).map_err(|(line, message)| TableError::Format {
            path: path.to_path_buf(),
            line,
            message,
        })
    }

    /// Parses CSV text; an error gives the 1-based line and what is wrong.
    pub fn parse(text: &str) -> Result<Table, (usize, String)> {
        let mut lines = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l.trim_end_matches('\r')))
            .filter(|(_, l)| !l.trim().is_empty());
        let (_, head) = lines.next().ok_or((1, "empty table".to_string()))?;
        let header = split(head).map_err(|m| (1, m))?;
        let mut rows = Vec::new();
        for (line, text) in lines {
            let cells = split(text).map_err(|m| (line, m))?;
            if cells.len() != header.len() {
                return Err((
                    line,
                    format!("{} cells, the header has {}", cells.len(), header.len()),
                ));
            }
            rows.push(cells);
        }
        Ok(Table { header, rows })
    }

    /// Index of column `name`.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h == name)
    }

    /// Column `name` as numbers; `path` names the file in errors. An empty cell
    /// or a non-number is an error naming its line.
    pub fn numbers(&self, path: &Path, name: &str) -> Result<Vec<f64>, TableError> {
        let k = self.require(path, name)?;
        self.rows
            .iter()
            .enumerate()
            .map(|(i, row)| parse_number(&row[k]).ok_or_else(|| self.bad(path, i, name, &row[k])))
            .collect()
    }

    /// The index of column `name`, or an error listing the columns.
    pub fn require(&self, path: &Path, name: &str) -> Result<usize, TableError> {
        self.index(name).ok_or_else(|| TableError::MissingColumn {
            path: path.to_path_buf(),
            name: name.to_string(),
            columns: self.header.clone(),
        })
    }

    /// The columns whose every cell is a finite number.
    pub fn numeric_columns(&self) -> Vec<String> {
        self.header
            .iter()
            .enumerate()
            .filter(|(k, _)| {
                !self.rows.is_empty() && self.rows.iter().all(|r| parse_number(&r[*k]).is_some())
            })
            .map(|(_, h)| h.clone())
            .collect()
    }

    fn bad(&self, path: &Path, row: usize, column: &str, cell: &str) -> TableError {
        TableError::Format {
            path: path.to_path_buf(),
            line: row + 2,
            message: format!("column `{column}` = `{cell}`: must be a finite number"),
        }
    }
}

/// A finite number, or `None`.
pub fn parse_number(cell: &str) -> Option<f64> {
    cell.trim().parse::<f64>().ok().filter(|v| v.is_finite())
}

fn split(line: &str) -> Result<Vec<String>, String> {
    if line.contains('"') {
        return Err("quoted cells are not supported".to_string());
    }
    Ok(line.split(',').map(|c| c.trim().to_string()).collect())
}

/// Builds CSV text row by row.
#[derive(Debug, Clone, Default)]
pub struct CsvWriter {
    text: String,
}

/// One cell of a written table.
#[derive(Debug, Clone, PartialEq)]
pub enum Cell {
    /// A number, written in shortest round-trip form.
    Number(f64),
    /// An integer.
    Integer(u64),
    /// A word or id (must not contain commas, quotes or line breaks).
    Text(String),
    /// No value.
    Empty,
}

impl fmt::Display for Cell {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Cell::Number(v) => write!(f, "{v}"),
            Cell::Integer(v) => write!(f, "{v}"),
            Cell::Text(s) => f.write_str(s),
            Cell::Empty => Ok(()),
        }
    }
}

impl CsvWriter {
    /// A table with the given header.
    pub fn new<S: AsRef<str>>(header: &[S]) -> CsvWriter {
        let mut w = CsvWriter::default();
        w.push_line(header.iter().map(|h| h.as_ref().to_string()));
        w
    }

    /// Appends a row.
    pub fn row(&mut self, cells: &[Cell]) {
        self.push_line(cells.iter().map(|c| c.to_string()));
    }

    fn push_line(&mut self, cells: impl Iterator<Item = String>) {
        let cells: Vec<String> = cells.collect();
        debug_assert!(
            cells.iter().all(|c| !c.contains([',', '"', '\n'])),
            "{cells:?}"
        );
        self.text.push_str(&cells.join(","));
        self.text.push('\n');
    }

    /// The CSV text.
    pub fn finish(self) -> String {
        self.text
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_numbers_exactly() {
        let mut w = CsvWriter::new(&["a", "b", "c"]);
        w.row(&[Cell::Number(0.1 + 0.2), Cell::Text("x".into()), Cell::Empty]);
        let t = Table::parse(&w.finish()).unwrap();
        assert_eq!(t.rows[0][0].parse::<f64>().unwrap(), 0.1 + 0.2);
        assert_eq!(t.rows[0][2], "");
        assert_eq!(t.numeric_columns(), vec!["a".to_string()]);
    }

    #[test]
    fn errors_name_the_line() {
        assert_eq!(
            Table::parse("a,b\n1,2\n3\n").unwrap_err(),
            (3, "1 cells, the header has 2".to_string())
        );
        let t = Table::parse("a\n1\nx\n").unwrap();
        let err = t.numbers(Path::new("t.csv"), "a").unwrap_err().to_string();
        assert_eq!(err, "t.csv:3: column `a` = `x`: must be a finite number");
        let err = t.numbers(Path::new("t.csv"), "b").unwrap_err().to_string();
        assert_eq!(err, "t.csv: no column `b` (columns: a)");
    }
}
