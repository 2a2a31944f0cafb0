//! `repose diff A B` of two study directories: the spec fields that differ,
//! and per stage directory the files that differ, the runs both stages
//! name and the rows that changed in their response and verification tables.
//!
//! - Spec: every leaf of the two study.json files by dotted path
//!   ([`super::fields::flatten`]) whose values differ (a factor's range is
//!   `factors.A.min`, `factors.A.max`).
//! - Files: every file of each stage directory, compared byte for byte;
//!   lineage records (`*.lineage.json`) are left out, as they name the study
//!   id and so differ whenever the studies do (their outputs are compared).
//!   A JSON file that differs only in its measured times
//!   ([`MEASURED_TIME_FIELDS`]: two runs of one study measure different
//!   seconds) is listed apart, as differing in measured times only.
//! - Runs: the run ids the stage's CSV tables name
//!   ([`super::study_files::run_ids`]), shared and one-sided.
//! - Rows: in the tables that say what a stage found ([`ROW_TABLES`]: design
//!   points, responses, fitted terms, analyses of variance, optima,
//!   estimates and verdicts), rows are matched by their key columns (the
//!   design's `index`; point and replicate; a term or source; a rank;
//!   response and parameter; point and response, or group and scene) and
//!   each matched row's differing cells are given, with the rows only one
//!   side has.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::diff::{changed_fields, FieldChange};
use super::fields::{flatten, Value};
use super::study_files::{files, run_ids, study_id, STUDY_FILE};
use super::TrackingError;
use crate::manifest::ContentId;
use crate::report::table::Table;
use crate::store::StoreError;
use crate::study::dir::MEASURED_TIME_FIELDS;

/// The tables whose rows are compared, with how many leading columns key a
/// row.
pub const ROW_TABLES: [(&str, usize); 7] = [
    ("design.csv", 1),
    ("responses.csv", 2),
    ("coefficients.csv", 1),
    ("anova.csv", 1),
    ("optimum.csv", 1),
    ("estimates.csv", 2),
    ("verification.csv", 2),
];

/// What differs between two studies (module docs).
#[derive(Debug, Clone, Serialize)]
pub struct StudyDiff {
    /// A's directory.
    pub a: PathBuf,
    /// B's directory.
    pub b: PathBuf,
    /// The study ids of A and B.
    pub ids: [ContentId; 2],
    /// Spec fields that differ.
    pub spec: Vec<FieldChange>,
    /// Every stage directory either has.
    pub stages: Vec<StageDiff>,
}

/// One stage directory of two studies.
#[derive(Debug, Clone, Serialize)]
pub struct StageDiff {
    /// The directory name.
    pub stage: String,
    /// Whether A and B have it.
    pub present: [bool; 2],
    /// Files (relative to the stage) only A has.
    pub only_a: Vec<String>,
    /// Files only B has.
    pub only_b: Vec<String>,
    /// Files both have, with different bytes.
    pub differ: Vec<String>,
    /// JSON files both have that differ only in their measured times
    /// ([`crate::study::dir::MEASURED_TIME_FIELDS`]), not listed in
    /// `differ`.
    pub differ_in_times_only: Vec<String>,
    /// Run ids both stages' tables name.
    pub shared_runs: Vec<ContentId>,
    /// How many run ids only A's tables name.
    pub runs_only_a: usize,
    /// How many only B's name.
    pub runs_only_b: usize,
    /// Changed rows of the [`ROW_TABLES`] both have.
    pub tables: Vec<TableDiff>,
}

/// The rows of one table that changed.
#[derive(Debug, Clone, Serialize)]
pub struct TableDiff {
    /// The file, relative to the stage.
    pub file: String,
    /// The columns rows are matched by.
    pub key: Vec<String>,
    /// Rows only A has, by key.
    pub only_a: Vec<Vec<String>>,
    /// Rows only B has, by key.
    pub only_b: Vec<Vec<String>>,
    /// Rows both have whose cells differ.
    pub changed: Vec<RowChange>,
}

/// One matched row whose cells differ.
#[derive(Debug, Clone, Serialize)]
pub struct RowChange {
    /// The row's key cells.
    pub key: Vec<String>,
    /// Column, A's cell, B's cell; for each cell that differs.
    pub cells: Vec<[String; 3]>,
}

/// The diff of the study directories `a` and `b` (module docs).
pub fn diff_studies(a: &Path, b: &Path) -> Result<StudyDiff, TrackingError> {
    let spec = |dir: &Path| -> Result<BTreeMap<String, Value>, TrackingError> {
        let path = dir.join(STUDY_FILE);
        let json: serde_json::Value = crate::store::Store::read_json(&path)?;
        let mut out = BTreeMap::new();
        flatten(&json, String::new(), &mut out);
        Ok(out)
    };
    let spec = changed_fields(&spec(a)?, &spec(b)?);
    let (fa, fb) = (stage_files(a)?, stage_files(b)?);
    let stages: BTreeSet<&String> = fa.keys().chain(fb.keys()).collect();
    let stages = stages
        .into_iter()
        .map(|s| {
            let empty = Vec::new();
            let files = [fa.get(s).unwrap_or(&empty), fb.get(s).unwrap_or(&empty)];
            stage_diff(s, [a, b], [fa.contains_key(s), fb.contains_key(s)], files)
        })
        .collect::<Result<_, _>>()?;
    Ok(StudyDiff {
        a: a.to_path_buf(),
        b: b.to_path_buf(),
        ids: [study_id(a)?, study_id(b)?],
        spec,
        stages,
    })
}

/// The files of each stage directory of `dir`, relative to the stage,
/// lineage records left out.
fn stage_files(dir: &Path) -> Result<BTreeMap<String, Vec<PathBuf>>, TrackingError> {
    let mut out: BTreeMap<String, Vec<PathBuf>> = BTreeMap::new();
    for file in files(dir)? {
        let mut parts = file.components();
        let (Some(stage), rest) = (parts.next(), parts.as_path()) else {
            continue;
        };
        let stage = stage.as_os_str().to_string_lossy().into_owned();
        let lineage = file.to_string_lossy().ends_with(".lineage.json");
        if rest.as_os_str().is_empty() || stage == "slurm" || lineage {
            continue;
        }
        out.entry(stage).or_default().push(rest.to_path_buf());
    }
    Ok(out)
}

fn stage_diff(
    stage: &str,
    dirs: [&Path; 2],
    present: [bool; 2],
    files: [&Vec<PathBuf>; 2],
) -> Result<StageDiff, TrackingError> {
    let [da, db] = dirs.map(|d| d.join(stage));
    let (set_a, set_b): (BTreeSet<&PathBuf>, BTreeSet<&PathBuf>) =
        (files[0].iter().collect(), files[1].iter().collect());
    let name = |p: &&PathBuf| p.display().to_string();
    let (mut differ, mut times_only) = (Vec::new(), Vec::new());
    let mut tables = Vec::new();
    for f in set_a.intersection(&set_b) {
        let read = |d: &Path| std::fs::read(d.join(f)).map_err(StoreError::io(&d.join(f)));
        let (bytes_a, bytes_b) = (read(&da)?, read(&db)?);
        if bytes_a == bytes_b {
            continue;
        }
        if equal_but_for_times(&bytes_a, &bytes_b) {
            times_only.push(name(f));
            continue;
        }
        differ.push(name(f));
        let key = ROW_TABLES
            .iter()
            .find(|(t, _)| f.file_name().is_some_and(|n| n == *t))
            .map(|&(_, key)| key);
        if let Some(key) = key {
            let text = |b: Vec<u8>| String::from_utf8_lossy(&b).into_owned();
            if let (Ok(ta), Ok(tb)) = (Table::parse(&text(bytes_a)), Table::parse(&text(bytes_b))) {
                tables.push(table_diff(name(f), &ta, &tb, key));
            }
        }
    }
    let (ra, rb) = (run_ids(&da, files[0])?, run_ids(&db, files[1])?);
    Ok(StageDiff {
        stage: stage.to_string(),
        present,
        only_a: set_a.difference(&set_b).map(name).collect(),
        only_b: set_b.difference(&set_a).map(name).collect(),
        differ,
        differ_in_times_only: times_only,
        shared_runs: ra.intersection(&rb).cloned().collect(),
        runs_only_a: ra.difference(&rb).count(),
        runs_only_b: rb.difference(&ra).count(),
        tables,
    })
}

/// Whether two JSON documents are equal once every measured-time field
/// ([`MEASURED_TIME_FIELDS`], at any depth) is removed; false for anything
/// that is not JSON.
fn equal_but_for_times(a: &[u8], b: &[u8]) -> bool {
    fn strip(v: &mut serde_json::Value) {
        match v {
            serde_json::Value::Object(map) => {
                map.retain(|k, _| !MEASURED_TIME_FIELDS.contains(&k.as_str()));
                map.values_mut().for_each(strip);
            }
            serde_json::Value::Array(items) => items.iter_mut().for_each(strip),
            _ => {}
        }
    }
    let parse = |bytes: &[u8]| serde_json::from_slice::<serde_json::Value>(bytes).ok();
    match (parse(a), parse(b)) {
        (Some(mut x), Some(mut y)) => {
            strip(&mut x);
            strip(&mut y);
            x == y
        }
        _ => false,
    }
}

/// The rows of `a` and `b` matched by their first `key` columns (module
/// docs).
fn table_diff(file: String, a: &Table, b: &Table, key: usize) -> TableDiff {
    let keyed = |t: &Table| -> BTreeMap<Vec<String>, BTreeMap<String, String>> {
        t.rows
            .iter()
            .map(|row| {
                let cells = t.header.iter().cloned().zip(row.iter().cloned()).collect();
                (row.iter().take(key).cloned().collect(), cells)
            })
            .collect()
    };
    let (ka, kb) = (keyed(a), keyed(b));
    let changed = ka
        .iter()
        .filter_map(|(key, ra)| {
            let rb = kb.get(key)?;
            let columns: BTreeSet<&String> = ra.keys().chain(rb.keys()).collect();
            let cells: Vec<[String; 3]> = columns
                .into_iter()
                .filter(|c| ra.get(*c) != rb.get(*c))
                .map(|c| {
                    let cell = |r: &BTreeMap<String, String>| r.get(c).cloned().unwrap_or_default();
                    [c.clone(), cell(ra), cell(rb)]
                })
                .collect();
            (!cells.is_empty()).then(|| RowChange {
                key: key.clone(),
                cells,
            })
        })
        .collect();
    TableDiff {
        file,
        key: a.header.iter().take(key).cloned().collect(),
        only_a: ka
            .keys()
            .filter(|k| !kb.contains_key(*k))
            .cloned()
            .collect(),
        only_b: kb
            .keys()
            .filter(|k| !ka.contains_key(*k))
            .cloned()
            .collect(),
        changed,
    }
}

impl StudyDiff {
    /// The diff as text: the spec changes, then one section per stage.
    pub fn text(&self) -> String {
        let mut out = format!("studies {} → {}\n", self.a.display(), self.b.display());
        out.push_str(&format!("spec fields that differ ({}):\n", self.spec.len()));
        for c in &self.spec {
            out.push_str(&c.line());
        }
        for s in &self.stages {
            out.push_str(&s.text());
        }
        out
    }
}

impl StageDiff {
    fn text(&self) -> String {
        let mut out = format!("stage {}/", self.stage);
        match self.present {
            [true, false] => out.push_str(" (only in A)"),
            [false, true] => out.push_str(" (only in B)"),
            _ => {}
        }
        out.push('\n');
        for (label, list) in [
            ("only in A", &self.only_a),
            ("only in B", &self.only_b),
            ("differs", &self.differ),
            ("differs in measured times only", &self.differ_in_times_only),
        ] {
            for f in list {
                out.push_str(&format!("  {label}: {f}\n"));
            }
        }
        out.push_str(&format!(
            "  runs named: {} shared, {} only in A, {} only in B\n",
            self.shared_runs.len(),
            self.runs_only_a,
            self.runs_only_b
        ));
        for t in &self.tables {
            let key = t.key.join(",");
            for (label, rows) in [("only in A", &t.only_a), ("only in B", &t.only_b)] {
                for k in rows {
                    out.push_str(&format!("  {} row {key}={} {label}\n", t.file, k.join(",")));
                }
            }
            for r in &t.changed {
                let cells: Vec<String> = r
                    .cells
                    .iter()
                    .map(|[c, a, b]| format!("{c}: {} → {}", or_empty(a), or_empty(b)))
                    .collect();
                out.push_str(&format!(
                    "  {} row {key}={}: {}\n",
                    t.file,
                    r.key.join(","),
                    cells.join("; ")
                ));
            }
        }
        out
    }
}

/// A table cell as text: `(empty)` for an empty one.
fn or_empty(cell: &str) -> &str {
    if cell.is_empty() {
        "(empty)"
    } else {
        cell
    }
}
