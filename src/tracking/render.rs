//! A listing as text, CSV or JSON.
//!
//! - Text: the classic table ([`crate::store::runs_line`]) when the listing
//!   is classic, else one column per field, left-aligned, two spaces apart,
//!   headed by the field names; ids as their first 12 hex digits, numbers
//!   longer than 10 characters to 6 significant digits, a group's response as
//!   `mean ± half-width` (the mean alone for one run), `-` where a row has
//!   no value. Damaged runs are named below the table.
//! - CSV ([`CsvWriter`]): full ids and every digit; a group's `id` is its
//!   runs' ids joined by `;` and each response column `R` is followed by
//!   `R_ci95` (the half-width).
//! - JSON: a list of objects, one per row, keyed by column (null where a row
//!   has no value); a group adds `ids`, and its responses are objects
//!   `{"n", "mean", "ci95_half_width"}`.

use super::fields::Value;
use super::group::Estimate;
use super::listing::{Listing, Row};
use crate::report::table::{Cell, CsvWriter};
use crate::store::{runs_line, RunSummary};

/// How a listing is printed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Format {
    /// Aligned columns for people.
    #[default]
    Text,
    /// One CSV table.
    Csv,
    /// One JSON list.
    Json,
}

impl Listing {
    /// The listing printed as `format` (module docs).
    pub fn render(&self, format: Format) -> String {
        match format {
            Format::Text => self.text(),
            Format::Csv => self.csv(),
            Format::Json => self.json(),
        }
    }

    fn text(&self) -> String {
        if self.total == 0 {
            return format!("no runs in {}\n", self.root.display());
        }
        if self.rows.is_empty() {
            return format!("no run of the {} in the store matches\n", self.total);
        }
        let mut out = if self.classic {
            self.classic_table()
        } else {
            self.column_table()
        };
        let damaged = self.damaged();
        if !damaged.is_empty() {
            out.push_str("damaged (run them again to recompute):\n");
            for line in damaged {
                out.push_str(&format!("  {line}\n"));
            }
        }
        out
    }

    fn classic_table(&self) -> String {
        let mut out = format!("{}\n", runs_line(&RunSummary::HEADER));
        for record in self.rows.iter().flat_map(Row::records) {
            out.push_str(&format!("{}\n", runs_line(&record.summary.row())));
        }
        out
    }

    fn column_table(&self) -> String {
        let mut table: Vec<Vec<String>> = vec![self.columns.clone()];
        for row in &self.rows {
            table.push(self.columns.iter().map(|c| text_cell(row, c)).collect());
        }
        let widths: Vec<usize> = (0..self.columns.len())
            .map(|i| {
                table
                    .iter()
                    .map(|r| r[i].chars().count())
                    .max()
                    .unwrap_or(0)
            })
            .collect();
        let mut out = String::new();
        for cells in table {
            let line: Vec<String> = cells
                .iter()
                .zip(&widths)
                .map(|(c, w)| format!("{c:<w$}"))
                .collect();
            out.push_str(line.join("  ").trim_end());
            out.push('\n');
        }
        out
    }

    fn csv(&self) -> String {
        let mut header = Vec::new();
        for c in &self.columns {
            header.push(c.clone());
            if self.grouped && self.is_estimated(c) {
                header.push(format!("{c}_ci95"));
            }
        }
        let mut w = CsvWriter::new(&header);
        for row in &self.rows {
            let mut cells = Vec::new();
            for c in &self.columns {
                cells.push(match (c.as_str(), row.estimate(c)) {
                    ("id", _) => Cell::Text(ids(row).join(";")),
                    (_, Some(e)) => Cell::Number(e.mean),
                    _ => row.get(c).map_or(Cell::Empty, |v| csv_cell(&v)),
                });
                if self.grouped && self.is_estimated(c) {
                    let hw = row.estimate(c).and_then(|e| e.ci95_half_width);
                    cells.push(hw.map_or(Cell::Empty, Cell::Number));
                }
            }
            w.row(&cells);
        }
        w.finish()
    }

    fn json(&self) -> String {
        let rows: Vec<serde_json::Value> = self
            .rows
            .iter()
            .map(|row| {
                let mut object = serde_json::Map::new();
                if self.grouped {
                    object.insert("ids".into(), serde_json::json!(ids(row)));
                }
                for c in &self.columns {
                    let value = match row.estimate(c) {
                        Some(e) => serde_json::json!(e),
                        None => row
                            .get(c)
                            .map_or(serde_json::Value::Null, |v| serde_json::json!(v)),
                    };
                    object.insert(c.clone(), value);
                }
                serde_json::Value::Object(object)
            })
            .collect();
        let mut text = serde_json::to_string_pretty(&rows).expect("JSON values serialise");
        text.push('\n');
        text
    }

    /// Whether column `c` holds a response estimate on some row.
    fn is_estimated(&self, c: &str) -> bool {
        self.rows.iter().any(|r| r.estimate(c).is_some())
    }
}

/// Every run id of a row.
fn ids(row: &Row) -> Vec<String> {
    row.records()
        .iter()
        .map(|r| r.summary.id.to_string())
        .collect()
}

/// One cell of the text table (module docs).
fn text_cell(row: &Row, column: &str) -> String {
    if column == "id" {
        return row.id().short(12).to_string();
    }
    match (row.estimate(column), row.get(column)) {
        (
            Some(Estimate {
                mean,
                ci95_half_width: Some(hw),
                ..
            }),
            _,
        ) => format!("{} ± {}", short_number(*mean), short_number(*hw)),
        (Some(e), _) => short_number(e.mean),
        (None, Some(Value::Number(v))) => short_number(v),
        (None, Some(v)) => v.to_string(),
        (None, None) => "-".to_string(),
    }
}

/// `v` in shortest form, or to 6 significant digits when that is longer
/// than 10 characters (`36.2057`, `117253`; below 10⁻⁴ or from 10⁹ in
/// exponent form, `1.10872e-5`).
pub fn short_number(v: f64) -> String {
    let full = v.to_string();
    if full.len() <= 10 || !v.is_finite() || v == 0.0 {
        return full;
    }
    if !(1e-4..1e9).contains(&v.abs()) {
        let shortest = format!("{v:e}");
        return if shortest.len() <= 10 {
            shortest
        } else {
            format!("{v:.5e}")
        };
    }
    let decimals = (5 - v.abs().log10().floor() as i32).clamp(0, 15) as usize;
    format!("{v:.decimals$}")
}

fn csv_cell(v: &Value) -> Cell {
    match v {
        Value::Number(n) => Cell::Number(*n),
        Value::Text(t) => Cell::Text(t.clone()),
    }
}

#[cfg(test)]
mod tests {
    use super::short_number;

    #[test]
    fn long_numbers_keep_six_significant_digits() {
        assert_eq!(short_number(0.5), "0.5");
        assert_eq!(short_number(36.20569455248687), "36.2057");
        assert_eq!(short_number(0.000011087208331525961), "1.10872e-5");
        assert_eq!(short_number(1.5e-21), "1.5e-21");
        assert_eq!(short_number(-4.826711394), "-4.82671");
    }
}
