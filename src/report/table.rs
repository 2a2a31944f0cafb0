//! Small CSV tables: a header line and rows of comma-separated cells.
//!
//! Reading and writing go through the `csv` crate, so a cell holding a comma,
//! a quote or a line break is quoted on writing and read back as it was.
//! Numbers are written with Rust's shortest round-trip formatting, so a table
//! re-read gives back the same `f64`s and identical inputs give identical
//! bytes; a cell is quoted only when it must be, so the stage tables (numbers,
//! ids and short words) are plain comma-separated lines.

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
    ///
    /// Cells are trimmed of surrounding spaces, blank lines are skipped, and a
    /// quoted cell may hold commas, doubled quotes and line breaks.
    pub fn parse(text: &str) -> Result<Table, (usize, String)> {
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .trim(csv::Trim::All)
            .from_reader(text.as_bytes());
        let mut header: Option<Vec<String>> = None;
        let mut rows = Vec::new();
        for record in reader.records() {
            let record = record.map_err(|e| {
                let line = e.position().map_or(1, |p| p.line() as usize);
                (line, e.to_string())
            })?;
            let line = record.position().map_or(1, |p| first_line(text, p));
            if record.len() == 1 && record[0].is_empty() {
                continue; // a line of spaces only
            }
            let cells: Vec<String> = record.iter().map(str::to_string).collect();
            match &header {
                None => {
                    if let Some((k, name)) = cells
                        .iter()
                        .enumerate()
                        .find(|(k, c)| cells[..*k].contains(c))
                    {
                        return Err((
                            line,
                            format!("column {} repeats the header `{name}`", k + 1),
                        ));
                    }
                    header = Some(cells)
                }
                Some(h) if cells.len() != h.len() => {
                    return Err((
                        line,
                        format!("{} cells, the header has {}", cells.len(), h.len()),
                    ));
                }
                Some(_) => rows.push(cells),
            }
        }
        let header = header.ok_or((1, "empty table".to_string()))?;
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

    /// Column `name` as optional numbers: an empty cell is `None` (a value
    /// that was not measured); any other cell that is not a finite number
    /// (`NaN`, `inf`, `1e999`, `abc`) is an error naming its line, column and
    /// value.
    pub fn optional_numbers(
        &self,
        path: &Path,
        name: &str,
    ) -> Result<Vec<Option<f64>>, TableError> {
        let k = self.require(path, name)?;
        self.rows
            .iter()
            .enumerate()
            .map(|(i, row)| {
                let cell = row[k].trim();
                if cell.is_empty() {
                    Ok(None)
                } else {
                    parse_number(cell)
                        .map(Some)
                        .ok_or_else(|| self.bad(path, i, name, cell))
                }
            })
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

/// The 1-based line where the record at `position` starts: the csv crate
/// places a record after the blank lines before it, so skip those.
fn first_line(text: &str, position: &csv::Position) -> usize {
    let blank = text
        .as_bytes()
        .get(position.byte() as usize..)
        .unwrap_or_default()
        .iter()
        .take_while(|b| b.is_ascii_whitespace())
        .filter(|b| **b == b'\n')
        .count();
    position.line() as usize + blank
}

/// A CSV cell of an optional number: Rust's shortest round-trip form, or
/// empty for `None`.
pub fn optional_cell(v: Option<f64>) -> String {
    v.map(|x| format!("{x}")).unwrap_or_default()
}

/// A CSV cell of free text: quoted (inner quotes doubled) when it holds a
/// comma, a quote or a line break, a line break becoming a space.
pub fn text_cell(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\"").replace('\n', " "))
    } else {
        s.to_string()
    }
}

/// `text` as a CSV cell of [`Cell::Text`]: commas become semicolons, quotes
/// apostrophes and line breaks spaces (an error message such as "has 1 surface
/// points, at least 3 are needed" would otherwise split its row). The Markdown
/// table quotes the message as it is.
pub fn csv_word(text: &str) -> String {
    text.chars()
        .map(|c| match c {
            ',' => ';',
            '"' => '\'',
            '\n' | '\r' => ' ',
            c => c,
        })
        .collect()
}

/// A finite number, or `None`.
pub fn parse_number(cell: &str) -> Option<f64> {
    cell.trim().parse::<f64>().ok().filter(|v| v.is_finite())
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
    /// A word, id or message (quoted if it holds a comma, a quote or a line break).
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
        // One small writer per line keeps `CsvWriter` a plain buffer (Clone,
        // Default); its records all end in `\n`, quoted only where needed.
        let mut line = csv::WriterBuilder::new()
            .buffer_capacity(256)
            .from_writer(Vec::new());
        line.write_record(&cells)
            .expect("a CSV line in memory cannot fail to write");
        let bytes = line
            .into_inner()
            .expect("a CSV line in memory cannot fail to flush");
        self.text
            .push_str(std::str::from_utf8(&bytes).expect("CSV of strings is UTF-8"));
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

    #[test]
    fn plain_cells_are_written_unquoted() {
        let mut w = CsvWriter::new(&["index", "mu", "id", "angle", "status"]);
        w.row(&[
            Cell::Integer(3),
            Cell::Number(0.25),
            Cell::Text("ab12".into()),
            Cell::Empty,
            Cell::Text("failed".into()),
        ]);
        w.row(&[
            Cell::Integer(4),
            Cell::Number(1e-7),
            Cell::Text("cd34".into()),
            Cell::Number(31.5),
            Cell::Text("ok".into()),
        ]);
        assert_eq!(
            w.finish(),
            "index,mu,id,angle,status\n3,0.25,ab12,,failed\n4,0.0000001,cd34,31.5,ok\n"
        );
    }

    #[test]
    fn commas_quotes_and_line_breaks_round_trip() {
        let awkward = "has 1 surface points, at least 3 are \"needed\"\nsee log";
        let mut w = CsvWriter::new(&["a", "why"]);
        w.row(&[Cell::Integer(1), Cell::Text(awkward.into())]);
        let text = w.finish();
        assert_eq!(
            text,
            "a,why\n1,\"has 1 surface points, at least 3 are \"\"needed\"\"\nsee log\"\n"
        );
        let t = Table::parse(&text).unwrap();
        assert_eq!(t.rows, vec![vec!["1".to_string(), awkward.to_string()]]);
    }

    #[test]
    fn blank_lines_spaces_and_crlf_are_tolerated() {
        let t = Table::parse("a , b\r\n\r\n 1, 2 \r\n   \n3,4\n").unwrap();
        assert_eq!(t.header, vec!["a", "b"]);
        assert_eq!(t.rows, vec![vec!["1", "2"], vec!["3", "4"]]);
        assert_eq!(
            Table::parse("").unwrap_err(),
            (1, "empty table".to_string())
        );
        assert_eq!(
            Table::parse("a,b\n\n1,2,3\n").unwrap_err(),
            (3, "3 cells, the header has 2".to_string())
        );
        assert_eq!(
            Table::parse("a,b\n\"x\ny\",2\n\n  \n3\n").unwrap_err(),
            (6, "1 cells, the header has 2".to_string())
        );
    }
}
