//! `repose audit`: walks a study's outputs back to their manifests and proves
//! the chain is intact.
//!
//! Every stage output has a lineage record beside it
//! ([`crate::store::Lineage`], `<output>.lineage.json`). The audit reads every
//! record under a path and checks, for each:
//! - the output it describes still exists and, where the record holds its
//!   sha256 (every stage output written since it was added), still has the
//!   bytes the stage wrote: an edited table, fit or acceptance record is
//!   reported;
//! - every file input still exists and its bytes hash to the recorded sha256.
//!   A relative path is looked up in the audited store only (the stages record
//!   files of the store relative to its root), never in the current directory,
//!   so an audit gives the same answer wherever it runs; an absolute path (a
//!   stage records files outside the store that way) is read as it is. An
//!   input that is a run's `<id>/result.json` also has its run checked as
//!   below;
//! - every id input names either a run in the store, or a study.json under the
//!   audited path whose content id it is. A completed run is checked against
//!   its seal with every file hashed (manifest.json, result.json, run.mcap:
//!   [`crate::store::seal`]); a failed or unfinished one must at least have a
//!   manifest.json that hashes to its id.
//!
//! With `rerun > 0` it then re-runs that many of the referenced completed runs
//! (chosen with a seeded ChaCha stream, so an audit is itself reproducible) in
//! a scratch store and checks result.json and run.mcap are byte-identical to
//! the stored ones: the determinism promise, checked on the user's own data.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::manifest::{content_id, ContentId, Study};
use crate::scenes::run_logged;
use crate::store::lineage::{self, LINEAGE_SUFFIX};
use crate::store::{Depth, Lineage, RunState, Store, StoreError, MCAP_FILE, RESULT_FILE};
use crate::study::dir::STUDY_FILE;
use crate::study::plan::design_study::DesignStudy;

/// What the audit found.
#[derive(Debug, Default)]
pub struct AuditReport {
    /// Lineage records read.
    pub records: usize,
    /// File inputs re-hashed.
    pub files_checked: usize,
    /// Distinct run ids checked against the store.
    pub runs_checked: usize,
    /// Every broken link, in the order found.
    pub broken: Vec<BrokenLink>,
    /// Re-run comparisons.
    pub reruns: Vec<RerunCheck>,
}

impl AuditReport {
    /// True when no link is broken and every re-run reproduced its outputs.
    pub fn is_clean(&self) -> bool {
        self.broken.is_empty() && self.reruns.iter().all(RerunCheck::identical)
    }

    /// The report as `repose audit` prints it: the counts, a `BROKEN` line
    /// per broken link, a `rerun` line per re-run, and `audit clean` when
    /// nothing is wrong.
    pub fn text(&self) -> String {
        let mut out = format!(
            "audited {} lineage record(s): {} file input(s) re-hashed, {} run(s) checked\n",
            self.records, self.files_checked, self.runs_checked
        );
        for link in &self.broken {
            out.push_str(&format!(
                "BROKEN {}: {}\n",
                link.record.display(),
                link.problem
            ));
        }
        for r in &self.reruns {
            out.push_str(&format!("rerun {}: {}\n", r.id.short(12), r.verdict()));
        }
        if self.is_clean() {
            out.push_str("audit clean\n");
        }
        out
    }
}

/// One broken link: which record, and what is wrong.
#[derive(Debug)]
pub struct BrokenLink {
    /// The lineage record that names the missing or changed input.
    pub record: PathBuf,
    /// What is wrong, naming the input.
    pub problem: String,
}

/// One re-run of a stored run.
#[derive(Debug)]
pub struct RerunCheck {
    /// The run.
    pub id: ContentId,
    /// Whether the new result.json equals the stored one byte for byte.
    pub result_identical: bool,
    /// Whether the new run.mcap equals the stored one byte for byte (true when
    /// neither exists).
    pub mcap_identical: bool,
    /// Why the re-run failed, if it did.
    pub failure: Option<String>,
}

impl RerunCheck {
    /// True when the re-run succeeded and reproduced both files.
    pub fn identical(&self) -> bool {
        self.failure.is_none() && self.result_identical && self.mcap_identical
    }

    /// What the re-run showed, in words.
    pub fn verdict(&self) -> String {
        let same = |b: bool| if b { "same" } else { "differs" };
        match (&self.failure, self.identical()) {
            (Some(f), _) => format!("re-run FAILED: {f}"),
            (None, true) => "result.json and run.mcap byte-identical".to_string(),
            (None, false) => format!(
                "DIFFERS (result.json {}, run.mcap {})",
                same(self.result_identical),
                same(self.mcap_identical)
            ),
        }
    }
}

/// Why the audit itself could not run (broken links are findings, not errors).
#[derive(Debug, thiserror::Error)]
pub enum AuditError {
    /// The path to audit does not exist or cannot be read.
    #[error("audit path {path}: {source}")]
    Path {
        /// The path.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// No lineage record was found under the path.
    #[error(
        "no lineage records (*{LINEAGE_SUFFIX}) under {0}; \
         audit a study output directory written by sample/batch/train/search/verify"
    )]
    NothingToAudit(PathBuf),
    /// The store failed.
    #[error(transparent)]
    Store(#[from] StoreError),
}

/// Audits every lineage record under `path` (a directory, walked recursively in
/// name order, or one output file) and re-runs `rerun` referenced runs chosen
/// with `seed`.
pub fn audit(
    store: &Store,
    path: &Path,
    rerun: usize,
    seed: u64,
) -> Result<AuditReport, AuditError> {
    let records = lineage_records(path)?;
    if records.is_empty() {
        return Err(AuditError::NothingToAudit(path.to_path_buf()));
    }
    let studies = study_ids(path)?;
    let mut report = AuditReport::default();
    let mut runs = RunChecks::new();
    for record in &records {
        report.records += 1;
        check_record(store, record, &studies, &mut runs, &mut report);
    }
    for file in unrecorded_outputs(path)? {
        report.broken.push(BrokenLink {
            record: Lineage::path_beside(&file),
            problem: format!(
                "{} has no lineage record: no stage wrote it, or its record was deleted",
                file.display()
            ),
        });
    }
    report.runs_checked = runs.values().filter(|v| v.is_ok()).count();
    let completed: Vec<ContentId> = runs
        .into_iter()
        .filter_map(|(id, v)| (v == Ok(true)).then_some(id))
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut picked: Vec<usize> = (0..completed.len()).collect();
    picked.shuffle(&mut rng);
    picked.truncate(rerun);
    picked.sort_unstable();
    for i in picked {
        report.reruns.push(rerun_one(store, &completed[i])?);
    }
    Ok(report)
}

fn check_record(
    store: &Store,
    record: &Path,
    studies: &BTreeSet<String>,
    runs: &mut RunChecks,
    report: &mut AuditReport,
) {
    let mut broken = |problem: String| {
        report.broken.push(BrokenLink {
            record: record.to_path_buf(),
            problem,
        })
    };
    let output = lineage::output_of(record);
    if !output.exists() {
        broken(format!("its output {} is missing", output.display()));
    }
    let lineage: Lineage = match Store::read_json(record) {
        Ok(l) => l,
        Err(e) => {
            broken(format!("unreadable lineage record: {e}"));
            return;
        }
    };
    if let Ok(bytes) = std::fs::read(&output) {
        if !lineage.describes(&bytes) {
            broken(format!(
                "its output {} changed since the stage wrote it (sha256 {} recorded, {} now)",
                output.display(),
                lineage.output_sha256.as_deref().unwrap_or_default(),
                ContentId::of_bytes(&bytes)
            ));
        }
    }
    for input in &lineage.inputs {
        let label = format!("input `{}` ({})", input.role, input.id_or_path);
        if input.id_or_path == input.sha256 {
            let Some(id) = ContentId::parse(&input.sha256) else {
                broken(format!("{label}: not a content id"));
                continue;
            };
            if studies.contains(id.as_str()) {
                continue;
            }
            if let Err(problem) = checked(store, runs, &id) {
                broken(format!("{label}: {problem}"));
            }
        } else {
            report.files_checked += 1;
            if let Some(id) = lineage::run_of_result_file(Path::new(&input.id_or_path)) {
                if let Err(problem) = checked(store, runs, &id) {
                    broken(format!("{label}: {problem}"));
                }
            }
            match resolve(store, Path::new(&input.id_or_path)) {
                None => broken(format!("{label}: file not found")),
                Some(file) => match std::fs::read(&file) {
                    Err(e) => broken(format!("{label}: {e}")),
                    Ok(bytes) => {
                        let now = ContentId::of_bytes(&bytes);
                        if now.as_str() != input.sha256 {
                            broken(format!(
                                "{label}: changed since the stage ran (sha256 {} recorded, {} now)",
                                input.sha256, now
                            ));
                        }
                    }
                },
            }
        }
    }
}

/// Each named run's check (complete or not, or what is wrong), made once
/// however many records name the run: a check hashes every file of the run.
type RunChecks = BTreeMap<ContentId, Result<bool, String>>;

/// The check of run `id`, from `runs` or made now and kept there.
fn checked(store: &Store, runs: &mut RunChecks, id: &ContentId) -> Result<bool, String> {
    runs.entry(id.clone())
        .or_insert_with(|| check_run(store, id))
        .clone()
}

/// Checks run `id` exists and is intact: a completed run against its seal
/// (every file hashed), any other by its manifest's hash. True when complete.
fn check_run(store: &Store, id: &ContentId) -> Result<bool, String> {
    match store.check(id, Depth::Full) {
        RunState::Complete(_) => return Ok(true),
        RunState::Damaged(problem) => {
            return Err(format!("run {} is damaged: {problem}", id.short(12)))
        }
        RunState::Missing => return Err(format!("no run {} in the store", id.short(12))),
        RunState::Incomplete | RunState::Failed => {}
    }
    let bytes = std::fs::read(store.run_dir(id).manifest_path())
        .map_err(|e| format!("run {}: manifest.json: {e}", id.short(12)))?;
    let hashed = ContentId::of_bytes(&bytes);
    if &hashed != id {
        return Err(format!(
            "run {}: manifest.json hashes to {hashed}, not to its id",
            id.short(12)
        ));
    }
    Ok(false)
}

/// Re-runs `id` in a scratch store beside the real one and compares outputs.
fn rerun_one(store: &Store, id: &ContentId) -> Result<RerunCheck, AuditError> {
    let experiment = store.load_manifest(id)?;
    let scratch_root = store
        .root()
        .join(format!(".audit-{}-{}", std::process::id(), id.short(12)));
    let scratch = Store::open(&scratch_root)?;
    let outcome = scratch.run_cached(&experiment, run_logged);
    let same = |file: &str| -> bool {
        let old = std::fs::read(store.run_dir(id).path().join(file)).ok();
        let new = std::fs::read(scratch.run_dir(id).path().join(file)).ok();
        old == new
    };
    let check = RerunCheck {
        id: id.clone(),
        result_identical: same(RESULT_FILE),
        mcap_identical: same(MCAP_FILE),
        failure: outcome.err().map(|e| e.to_string()),
    };
    std::fs::remove_dir_all(&scratch_root).map_err(|source| AuditError::Path {
        path: scratch_root.clone(),
        source,
    })?;
    Ok(check)
}

/// Files in the stage directories of the study directory `path` (one that
/// holds `study.json`) without a lineage record beside them; none when
/// `path` is not a study directory. Every stage output has a record, so a
/// file without one was put there by hand or lost its record. Not outputs:
/// the study's own `study.json` and `report.html` (the report page), the
/// Slurm ledger (`slurm/`), temp files of a write in progress and the
/// sampled experiment manifests (`sample/experiments/`: content-addressed,
/// their ids in `sample/design.csv`, whose record hashes them).
fn unrecorded_outputs(path: &Path) -> Result<Vec<PathBuf>, AuditError> {
    if !path.join(STUDY_FILE).is_file() {
        return Ok(Vec::new());
    }
    let exempt_dirs = [path.join("slurm"), path.join("sample").join("experiments")];
    let exempt_files = [
        path.join(STUDY_FILE),
        path.join(crate::report::page::PAGE_FILE),
    ];
    Ok(lineage::files_under(path)
        .map_err(path_error)?
        .into_iter()
        .filter(|f| {
            let temp = f
                .file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with(crate::store::TEMP_PREFIX));
            !temp
                && !lineage::is_record(f)
                && !exempt_files.contains(f)
                && !exempt_dirs.iter().any(|d| f.starts_with(d))
                && !Lineage::path_beside(f).is_file()
        })
        .collect())
}

/// Every lineage record under `path` ([`lineage::records_under`]).
fn lineage_records(path: &Path) -> Result<Vec<PathBuf>, AuditError> {
    lineage::records_under(path).map_err(path_error)
}

/// A failed read of the audited tree, naming the path.
fn path_error(e: StoreError) -> AuditError {
    match e {
        StoreError::Io { path, source } => AuditError::Path { path, source },
        other => AuditError::Store(other),
    }
}

/// Content ids of every `study.json` under `path` (a stage may name its study
/// by id).
fn study_ids(path: &Path) -> Result<BTreeSet<String>, AuditError> {
    let mut ids = BTreeSet::new();
    if path.is_dir() {
        for p in lineage::files_under(path).map_err(path_error)? {
            if p.file_name().is_some_and(|n| n == "study.json") {
                if let Ok(study) = Store::read_json::<Study>(&p) {
                    ids.insert(content_id(&study).to_string());
                } else if let Ok(study) = Store::read_json::<DesignStudy>(&p) {
                    ids.insert(study.id().to_string());
                }
            }
        }
    }
    Ok(ids)
}

/// An input path as recorded, resolved: absolute as is; relative against the
/// store root only (where the stages record paths from; see the module docs).
fn resolve(store: &Store, recorded: &Path) -> Option<PathBuf> {
    let path = if recorded.is_absolute() {
        recorded.to_path_buf()
    } else {
        store.root().join(recorded)
    };
    path.exists().then_some(path)
}
