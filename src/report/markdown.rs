//! Markdown tables: a header, an alignment per column and rows of strings.
//!
//! The output is the plain pipe-table form every renderer reads:
//!
//! ```text
//! | group | size | predicted angle (deg) |
//! |---|---:|---|
//! | 0 | 412 | 31.02 |
//! ```
//!
//! Cells are written as given, except that a `|` is escaped (`\|`) and a line
//! break becomes a space, so no cell can split its row.

use std::fmt::Write as _;

/// How a column's cells are aligned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Align {
    /// The renderer's default (`---`).
    #[default]
    Default,
    /// Left (`:---`).
    Left,
    /// Centred (`:---:`).
    Centre,
    /// Right (`---:`), for columns of numbers.
    Right,
}

impl Align {
    fn rule(self) -> &'static str {
        match self {
            Align::Default => "---",
            Align::Left => ":---",
            Align::Centre => ":---:",
            Align::Right => "---:",
        }
    }
}

/// A Markdown table being built.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MarkdownTable {
    header: Vec<String>,
    align: Vec<Align>,
    rows: Vec<Vec<String>>,
}

impl MarkdownTable {
    /// A table with the given column names, every column in the default
    /// alignment.
    pub fn new<S: AsRef<str>>(header: &[S]) -> MarkdownTable {
        MarkdownTable {
            header: header.iter().map(|h| h.as_ref().to_string()).collect(),
            align: vec![Align::Default; header.len()],
            rows: Vec::new(),
        }
    }

    /// Sets the alignment of column `column` (0-based).
    ///
    /// # Panics
    /// If the table has no such column.
    pub fn align(mut self, column: usize, align: Align) -> MarkdownTable {
        assert!(
            column < self.align.len(),
            "column {column} of a {}-column table",
            self.align.len()
        );
        self.align[column] = align;
        self
    }

    /// Appends a row.
    ///
    /// # Panics
    /// If the row's length is not the header's.
    pub fn row<S: AsRef<str>>(&mut self, cells: &[S]) {
        assert_eq!(
            cells.len(),
            self.header.len(),
            "a row of {} cells in a table of {} columns",
            cells.len(),
            self.header.len()
        );
        self.rows
            .push(cells.iter().map(|c| c.as_ref().to_string()).collect());
    }

    /// The table as Markdown, each line ending in `\n`.
    pub fn render(&self) -> String {
        let mut out = String::new();
        cells_line(&mut out, &self.header);
        let rules: Vec<&str> = self.align.iter().map(|a| a.rule()).collect();
        let _ = writeln!(out, "|{}|", rules.join("|"));
        for row in &self.rows {
            cells_line(&mut out, row);
        }
        out
    }
}

/// Appends `| a | b |`, each cell made safe for the table.
fn cells_line(out: &mut String, cells: &[String]) {
    let cells: Vec<String> = cells
        .iter()
        .map(|c| {
            c.replace('|', "\\|")
                .replace("\r\n", " ")
                .replace(['\n', '\r'], " ")
        })
        .collect();
    let _ = writeln!(out, "| {} |", cells.join(" | "));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_header_rule_and_rows() {
        let mut t = MarkdownTable::new(&["group", "size", "angle"])
            .align(1, Align::Right)
            .align(2, Align::Centre);
        t.row(&["0", "412", "31.02"]);
        t.row(&["1".to_string(), "7".to_string(), "—".to_string()]);
        assert_eq!(
            t.render(),
            "| group | size | angle |\n|---|---:|:---:|\n| 0 | 412 | 31.02 |\n| 1 | 7 | — |\n"
        );
        let left = MarkdownTable::new(&["a"]).align(0, Align::Left);
        assert_eq!(left.render(), "| a |\n|:---|\n");
    }

    #[test]
    fn pipes_and_line_breaks_cannot_split_a_row() {
        let mut t = MarkdownTable::new(&["why"]);
        t.row(&["a | b\r\nc\nd"]);
        assert_eq!(t.render(), "| why |\n|---|\n| a \\| b c d |\n");
    }

    #[test]
    #[should_panic(expected = "a row of 1 cells in a table of 2 columns")]
    fn a_short_row_is_a_bug() {
        MarkdownTable::new(&["a", "b"]).row(&["1"]);
    }
}
