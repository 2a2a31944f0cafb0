//! `repose studies`: every study of the store (`<store>/studies/*/` holding a
//! study.json), one entry each.
//!
//! An entry gives: the study's name and id (sha256 of its study.json); its
//! method ([`Method`]: a calibration study's from its `noise_aware` block, a
//! design study's `sensitivity` when a `sensitivity/` stage directory exists,
//! else `response_surface`; none when study.json no longer parses, e.g. an
//! older schema); the stage directories present; the runs its tables name
//! ([`super::study_files::run_ids`]) counted by their state in the store,
//! checked as `runs list` checks them (sizes of logs, hashes of JSON):
//! complete, failed, damaged, and pending (started but unfinished, or not in
//! the store); the count of each verdict in `verify/verification.csv`; and
//! the time of the last change, the newest modification time of its files,
//! ISO-8601 UTC.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::study_files::{
    files, iso8601, last_change, run_ids, stages, study_dirs, study_id, STUDY_FILE,
};
use super::TrackingError;
use crate::manifest::ContentId;
use crate::report::table::Table;
use crate::store::{Depth, Lineage, RunStatus, Store};
use crate::study::plan::{Method, StudyFile};

/// The runs a study's tables name, by state.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct RunCounts {
    /// Sealed and intact.
    pub complete: usize,
    /// Failed (error.json).
    pub failed: usize,
    /// Files no longer match their seal.
    pub damaged: usize,
    /// Started and unfinished, or not in the store.
    pub pending: usize,
}

/// One study of the store (module docs).
#[derive(Debug, Clone, Serialize)]
pub struct StudyEntry {
    /// The study's name.
    pub name: String,
    /// Its id.
    pub id: ContentId,
    /// Its directory.
    pub directory: PathBuf,
    /// Its method, when study.json parses.
    pub method: Option<Method>,
    /// The stage directories present, sorted.
    pub stages: Vec<String>,
    /// The runs its tables name, by state.
    pub runs: RunCounts,
    /// Count of each verdict in verify/verification.csv (empty without one).
    pub verdicts: BTreeMap<String, usize>,
    /// verify/verification.csv is not what its stage wrote (its lineage
    /// record, missing or with another hash, does not describe it): the
    /// verdicts above were edited.
    pub verdicts_edited: bool,
    /// Newest modification time of its files, ISO-8601 UTC.
    pub last_change: String,
}

/// Every study of `store`, sorted by directory name.
pub fn list_studies(store: &Store) -> Result<Vec<StudyEntry>, TrackingError> {
    study_dirs(store.root())?
        .into_iter()
        .map(|dir| entry(store, &dir))
        .collect()
}

fn entry(store: &Store, dir: &Path) -> Result<StudyEntry, TrackingError> {
    let all = files(dir)?;
    let stages = stages(dir)?;
    let document = StudyFile::read(&dir.join(STUDY_FILE)).ok();
    let dir_name = dir
        .file_name()
        .map_or(String::new(), |n| n.to_string_lossy().into_owned());
    let name = match &document {
        Some(StudyFile::Calibration(s)) => s.name.clone(),
        Some(StudyFile::Design(s)) => s.name.clone(),
        None => dir_name
            .rsplit_once('-')
            .map_or(dir_name.clone(), |(n, _)| n.to_string()),
    };
    let method = document.map(|d| match d {
        StudyFile::Calibration(s) => Method::of_calibration(&s),
        StudyFile::Design(_) if stages.iter().any(|s| s == "sensitivity") => Method::Sensitivity,
        StudyFile::Design(_) => Method::ResponseSurface,
    });
    // Read once: counted, and checked against its lineage record.
    let verification_path = dir.join("verify").join("verification.csv");
    let verification = std::fs::read(&verification_path).ok();
    let mut runs = RunCounts::default();
    for id in run_ids(dir, &all)? {
        match store.check(&id, Depth::Sizes).status() {
            RunStatus::Complete => runs.complete += 1,
            RunStatus::Failed => runs.failed += 1,
            RunStatus::Damaged => runs.damaged += 1,
            RunStatus::Incomplete | RunStatus::Missing => runs.pending += 1,
        }
    }
    Ok(StudyEntry {
        name,
        id: study_id(dir)?,
        directory: dir.to_path_buf(),
        method,
        stages,
        runs,
        verdicts: verification.as_deref().map(verdicts).unwrap_or_default(),
        verdicts_edited: verification
            .as_deref()
            .is_some_and(|bytes| !written_by_its_stage(&verification_path, bytes)),
        last_change: iso8601(last_change(dir, &all)?),
    })
}

/// Whether `path` holds the bytes its lineage record was written for.
fn written_by_its_stage(path: &Path, bytes: &[u8]) -> bool {
    match Lineage::read_beside(path) {
        Ok(lineage) => lineage.output_sha256.is_some() && lineage.describes(bytes),
        Err(_) => false,
    }
}

/// The count of each value of the `verdict` column of a table's `bytes`
/// (empty when they do not parse or have no such column).
fn verdicts(bytes: &[u8]) -> BTreeMap<String, usize> {
    let mut counts = BTreeMap::new();
    if let Ok(table) = Table::parse(&String::from_utf8_lossy(bytes)) {
        if let Some(i) = table.index("verdict") {
            for v in table.rows.iter().map(|r| &r[i]).filter(|v| !v.is_empty()) {
                *counts.entry(v.clone()).or_insert(0) += 1;
            }
        }
    }
    counts
}

/// The entries as text: one block per study.
pub fn studies_text(entries: &[StudyEntry], store_root: &Path) -> String {
    if entries.is_empty() {
        return format!("no studies in {}\n", store_root.join("studies").display());
    }
    let mut out = String::new();
    for e in entries {
        let method = e
            .method
            .map_or("unknown (study.json does not parse)".to_string(), |m| {
                serde_json::to_value(m)
                    .ok()
                    .and_then(|v| v.as_str().map(str::to_string))
                    .unwrap_or_default()
            });
        let verdicts: Vec<String> = e.verdicts.iter().map(|(v, n)| format!("{n} {v}")).collect();
        let r = e.runs;
        // A name from an old or hand-made study.json may hold control
        // characters: shown escaped, never sent to the terminal raw.
        out.push_str(&format!("{} {}\n", e.name.escape_debug(), e.id.short(12)));
        out.push_str(&format!("  directory:   {}\n", e.directory.display()));
        out.push_str(&format!("  method:      {method}\n"));
        out.push_str(&format!(
            "  stages:      {}\n",
            or_none(&e.stages.join(", "))
        ));
        out.push_str(&format!(
            "  runs:        {} complete, {} failed, {} damaged, {} pending\n",
            r.complete, r.failed, r.damaged, r.pending
        ));
        out.push_str(&format!(
            "  verdicts:    {}{}\n",
            or_none(&verdicts.join(", ")),
            if e.verdicts_edited {
                " (EDITED: verify/verification.csv is not what its stage wrote)"
            } else {
                ""
            }
        ));
        out.push_str(&format!("  last change: {}\n", e.last_change));
    }
    out
}

fn or_none(s: &str) -> &str {
    if s.is_empty() {
        "none"
    } else {
        s
    }
}
